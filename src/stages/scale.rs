//! Local scale: each point's own spacing, noise sigma and neighbourhood radius, measured from
//! its neighbourhood (DESIGN.md, "Scale is local").
//!
//! Inputs: positions, the cloud's mean nearest-neighbour distance (only to size the sampling
//! cells) and `ScaleRules` (radius and noise overrides, the radius rule; the features stage's
//! settings give them). Outputs:
//! `LocalScale` (each point's sampling cell, and each cell's spacing, pitch, noise and
//! radius) and the cloud-wide medians as a summary `Scale` that no decision depends on.
//!
//! Why local: real scans are not uniform. A line scanner is 3–10x denser along its lines than
//! across them, structured light samples a grid whose pitch grows with the incidence, views
//! overlap, and an RGB-D frame's density falls with the square of the depth. One cloud-wide
//! spacing is the along-line distance on scan lines (every neighbourhood is then a line and
//! no face is seen) and the mean of dense and sparse parts elsewhere.
//!
//! How:
//! - The **spacing** of a point is the spacing *across* the sampling pattern: its k = 48
//!   nearest neighbours are projected on their plane, the plane is cut in eight 45° sectors
//!   starting at the nearest neighbour, and the spacing is the third smallest of the sectors'
//!   nearest distances. Along a scan line the nearest neighbours lie in two opposite sectors;
//!   the third smallest is the distance to the next line. On a pixel grid it is the larger
//!   pitch; on uniform sampling about the mean spacing (calibrated below); at a scan border
//!   half the sectors are empty and the rest still give it.
//! - The **pitch** is the finest spacing of the pattern: the spacing over the anisotropy, the
//!   ratio of the third smallest to the second smallest of the same sector distances (its
//!   median over the samples on faces around), so along a scan line the distance to the next
//!   point on the line, on a pixel grid the smaller pitch. It is what the scan resolves across an edge where its lines
//!   cross it: the bins of an edge's abnormal zone and the margins around it are in pitches
//!   (rectification must not move points that lie on a face one along-line step beyond the
//!   rounding, though the next line is ten steps away). On uniform sampling it equals the
//!   spacing (it is capped by it; see [`PITCH_RATIO`]), so uniform scans are unchanged.
//! - The **noise** is the out-of-plane sigma of those 48 neighbours (the plane's three
//!   parameters taken out: λ0·n/(n−3)).
//! - Both are measured at one point per occupied cell of a grid 10 mean spacings wide (a few
//!   percent of the points: the k-nearest queries would otherwise dominate the run) and
//!   smoothed over the cells around it (three wide) by the median of the samples that lie on faces
//!   (`on_faces`): a neighbourhood straddling an edge reads the bend as noise and its two
//!   faces as a denser sampling. A sample whose neighbours all lie on one scan line (lines
//!   farther apart than they reach, on a face leaning towards the cutting planes) measures
//!   no surface and counts only where no sample of the cloud does (`Sample::one_line`). Each
//!   point takes its cell's values: they depend on the surface around it, not on what else
//!   was read.
//! - The **radius** is max(`min_radius` spacings, `noise_radius` sigmas, `normal_radius`
//!   √(sigma·spacing) up to `noise_radius` spacings): the first two as the cloud-wide rule
//!   was, the third keeping the
//!   normals steady where the noise is a large share of the spacing (see [`NORMAL_RADIUS`]).
//!   On scan lines `min_radius` shrinks with the lines' density along them, down to
//!   [`LINE_MIN_RADIUS`] spacings ([`min_radius_on`]).
//!   A radius or noise given in the config replaces the measured one everywhere.

use rayon::prelude::*;

use crate::error::{Error, Result};
use crate::geometry::moments::{add_moments, pca_from_moments};
use crate::geometry::{dot, perp_basis};
use crate::neighbours::{Grid, KdTree};

/// The length scales of a scan, measured or given: one point's, one edge's or (as a summary)
/// the cloud's medians.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct Scale {
    /// Spacing across the sampling pattern (on uniform sampling the mean distance to the
    /// nearest distinct neighbour).
    pub spacing: f64,
    /// Finest spacing of the pattern (along a scan line), at most `spacing`; equal to it on
    /// uniform sampling.
    pub pitch: f64,
    /// Noise sigma perpendicular to the surface.
    pub noise: f64,
    /// Neighbourhood radius used for the features.
    pub radius: f64,
}

/// How lengths follow from the measurement: given values replace measured ones.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ScaleRules {
    /// Neighbourhood radius in model units; `None` = max(`min_radius` spacings,
    /// `noise_radius` sigmas).
    pub radius: Option<f64>,
    /// Noise sigma in model units; `None` = measured.
    pub noise: Option<f64>,
    /// Smallest automatic radius, in spacings.
    pub min_radius: f64,
    /// Automatic radius in noise sigmas (when larger than `min_radius` spacings).
    pub noise_radius: f64,
    /// Automatic radius in √(sigma·spacing), at most `noise_radius` spacings, when larger
    /// than both: the radius whose PCA normals are as steady as at `min_radius` spacings and
    /// sigma 0.25 spacing (see [`NORMAL_RADIUS`]). 0 turns the rule off.
    pub normal_radius: f64,
}

/// A PCA normal's angular variance over a disc of radius r holding n ∝ r²/h² points with
/// noise σ is ≈ 4σ²/(n r²) ∝ σ²h²/r⁴: the normals (and the normal-split score the candidates
/// are chosen by) are equally steady wherever r ∝ √(σh). 8 leaves the radius where the
/// spacing rule puts it up to σ = 0.25 spacing (8·√0.25 = 4), the noise the simulator's
/// suite was tuned at, and beyond it grows the radius as the normals need, up to
/// `noise_radius` spacings (reached at σ = 0.56 spacing; from σ = 1 spacing on the noise rule
/// takes over, so the radius grows continuously with the noise). On the real RGB-D frames in
/// ../shared/data/rgbd (σ = 0.5 spacing: 0.61 mm on 1.24 mm) it gives 5.7 spacings where the
/// spacing rule gave 4, and the box edges went from 0–17 % of their length found to 75–100 %
/// (`bench --frames`; fixed radii of 5, 6, 7, 8 and 10 mm found them in between). At σ = 1
/// spacing a radius of 8 spacings rectified the simulated box worse than 6 (zone ratio 0.33
/// against 0.22): hence the cap.
pub const NORMAL_RADIUS: f64 = 8.0;

impl Default for ScaleRules {
    fn default() -> Self {
        ScaleRules {
            radius: None,
            noise: None,
            min_radius: 4.0,
            noise_radius: 6.0,
            normal_radius: NORMAL_RADIUS,
        }
    }
}

/// Per-point scale: each point's sampling cell, and the cells' scales. Every point of a cell
/// takes the cell's values (see the module comment), so one index a point and four numbers a
/// cell hold what four side arrays held (4 bytes a point instead of 16; 120 MB at 10M points,
/// the features stage's peak).
#[derive(Debug, Clone, Default)]
pub struct LocalScale {
    /// Index into `cells`, by point id.
    cell: Vec<u32>,
    /// [spacing, pitch, noise, radius] of each cell.
    cells: Vec<[f32; 4]>,
}

/// Neighbours of a sampled point whose plane and sectors give its spacing and noise.
const K: usize = 48;
/// Sampling cells, in mean spacings.
const SAMPLE_CELL: f64 = 10.0;
/// Samples within this many cells smooth each other: about 28 on a surface, which keeps the
/// radii of a uniform scan within a few percent of each other (the features stage's grid is
/// sized for the widest of nine in ten).
const SMOOTH_CELLS: f64 = 3.0;
/// Sector nearest distances measure the sampling pitch (1.01–1.12 pitches on jittered grids,
/// noise or not), while the cloud-wide mean nearest distance every length in spacings was
/// tuned with shrinks with the noise. Dividing by this ratio keeps the spacing, and so every
/// radius and tolerance, what it was on the simulator's uniform scans at the suite's noise
/// (sigma 0.15 pitch: third sector distance 1.075 pitches, mean nearest distance 0.81; the
/// test below checks it).
const SECTOR_RATIO: f64 = 1.33;
/// Anisotropy (third over second smallest sector distance) up to which the sampling counts
/// as isotropic: pitch = spacing / max(1, anisotropy − (PITCH_ISOTROPIC − 1)). On jittered
/// uniform grids the median anisotropy is 1.13–1.23 whatever the noise (the test below), so
/// the pitch is the spacing there; on scan lines g steps apart the anisotropy is about g and
/// the pitch g / (g − 0.5) steps, the along-line step within 6 % from g = 10 and 20 % at
/// g = 3; in between it changes continuously.
const PITCH_ISOTROPIC: f64 = 1.5;

impl LocalScale {
    /// One scale for `n` points (tests, and configs giving every length).
    pub fn uniform(n: usize, scale: Scale) -> LocalScale {
        LocalScale {
            cell: vec![0; n],
            cells: vec![[scale.spacing, scale.pitch, scale.noise, scale.radius].map(|x| x as f32)],
        }
    }

    /// Number of points.
    pub fn len(&self) -> usize {
        self.cell.len()
    }

    /// Whether there are no points.
    pub fn is_empty(&self) -> bool {
        self.cell.is_empty()
    }

    #[inline]
    fn of(&self, i: usize) -> &[f32; 4] {
        &self.cells[self.cell[i] as usize]
    }

    /// The k-th smallest (from 0) over the points of the length `pick` takes from their
    /// scale, e.g. `|s| s.spacing`; `None` for k past the points. Read from the cells, each
    /// counted for its points: no per-point array.
    pub fn ranked(&self, pick: impl Fn(&Scale) -> f64, k: usize) -> Option<f64> {
        let mut count = vec![0usize; self.cells.len()];
        for &c in &self.cell {
            count[c as usize] += 1;
        }
        let mut values: Vec<(f32, usize)> = self
            .cells
            .iter()
            .zip(count)
            .filter(|&(_, n)| n > 0)
            .map(|(&c, n)| (pick(&scale_of(c)) as f32, n))
            .collect();
        values.sort_by(|a, b| a.0.total_cmp(&b.0));
        let mut seen = 0;
        values.into_iter().find_map(|(v, n)| {
            seen += n;
            (k < seen).then_some(f64::from(v))
        })
    }

    /// The smallest and the largest radius of the points (`(inf, 0)` without points).
    pub fn radius_range(&self) -> (f32, f32) {
        if self.cell.is_empty() {
            return (f32::INFINITY, 0.0);
        }
        // Every cell holds at least one point (`uniform` for no points aside).
        self.cells
            .iter()
            .fold((f32::INFINITY, 0.0f32), |(lo, hi), c| {
                (lo.min(c[3]), hi.max(c[3]))
            })
    }

    /// The scale of point `i`.
    #[inline]
    pub fn at(&self, i: usize) -> Scale {
        scale_of(*self.of(i))
    }

    /// The median scale over some points (an edge's, a corner's); `None` without points.
    pub fn around(&self, ids: impl IntoIterator<Item = u32>) -> Option<Scale> {
        let mut v: Vec<[f32; 4]> = ids
            .into_iter()
            .map(|i| {
                let [spacing, pitch, noise, radius] = *self.of(i as usize);
                [spacing, noise, radius, pitch]
            })
            .collect();
        if v.is_empty() {
            return None;
        }
        let mid = v.len() / 2;
        let median = |v: &mut Vec<[f32; 4]>, k: usize| {
            v.select_nth_unstable_by(mid, |a, b| a[k].total_cmp(&b[k]));
            f64::from(v[mid][k])
        };
        let spacing = median(&mut v, 0);
        Some(Scale {
            spacing,
            // The median of the pitches may pass the median of the spacings only by rounding.
            pitch: median(&mut v, 3).min(spacing),
            noise: median(&mut v, 1),
            radius: median(&mut v, 2),
        })
    }

    /// The cloud's medians: the summary reported and logged.
    pub fn summary(&self) -> Scale {
        self.around(0..self.cell.len() as u32).unwrap_or(Scale {
            spacing: 0.0,
            pitch: 0.0,
            noise: 0.0,
            radius: 0.0,
        })
    }

    /// The `q`-quantile of the radii (0 ≤ q ≤ 1): the neighbour grid's cell; 0 for none.
    pub fn radius_quantile(&self, q: f64) -> f64 {
        let last = self.len().saturating_sub(1);
        let k = (last as f64 * q.clamp(0.0, 1.0)).round() as usize;
        self.ranked(|s| s.radius, k).unwrap_or(0.0)
    }
}

/// A cell's [spacing, pitch, noise, radius] as a `Scale`.
#[inline]
fn scale_of(cell: [f32; 4]) -> Scale {
    let [spacing, pitch, noise, radius] = cell.map(f64::from);
    Scale {
        spacing,
        pitch,
        noise,
        radius,
    }
}

/// Measures every point's spacing, noise and radius (see the module comment). `spacing` is
/// the cloud's mean nearest-neighbour distance.
pub fn local_scale(
    positions: &[[f64; 3]],
    spacing: f64,
    params: &ScaleRules,
) -> Result<LocalScale> {
    local_scale_in(&KdTree::new(positions)?, positions, spacing, params)
}

/// [`local_scale`] with a tree of `positions` built already (the pipeline's, shared with the
/// mean spacing: building it is a third of this stage on a million points).
pub fn local_scale_in(
    tree: &KdTree,
    positions: &[[f64; 3]],
    spacing: f64,
    params: &ScaleRules,
) -> Result<LocalScale> {
    if !(spacing.is_finite() && spacing > 0.0) {
        return Err(Error::Degenerate {
            what: "scale estimate",
            why: format!("mean spacing must be positive, got {spacing}"),
        });
    }
    let cells = Grid::new(positions, SAMPLE_CELL * spacing)?;
    let blocks = cells.blocks();
    // One sample per occupied cell: its lowest id (cells list their points by id).
    let samples: Vec<u32> = blocks
        .iter()
        .map(|b| cells.slot_ids(b.slots.clone())[0])
        .collect();
    let mut raw: Vec<Option<Sample>> = samples
        .par_iter()
        .map(|&i| measure(positions, tree, i as usize))
        .collect();
    if raw.iter().all(Option::is_none) {
        return Err(Error::Degenerate {
            what: "scale estimate",
            why: "no point has 8 distinct neighbours spread over a surface; the cloud is too \
                  small or lies on a line"
                .into(),
        });
    }
    // A sample on one scan line (`Sample::one_line`) measures nothing where some sample of
    // the cloud measures a surface: it is dropped, so that a cell with only such samples
    // around takes the cloud's values, as one with no measurement around it does.
    if raw.iter().flatten().any(|s| !s.one_line) {
        for s in &mut raw {
            if s.is_some_and(|s| s.one_line) {
                *s = None;
            }
        }
    }
    // Smoothing: the samples within SMOOTH_CELLS cells of each sample.
    let sample_pos: Vec<[f64; 3]> = samples.iter().map(|&i| positions[i as usize]).collect();
    let reach = SMOOTH_CELLS * SAMPLE_CELL * spacing;
    let sample_grid = Grid::new(&sample_pos, reach)?;
    let smooth: Vec<OnFaces> = (0..samples.len())
        .into_par_iter()
        .map(|s| {
            let mut around: Vec<Sample> = Vec::new();
            sample_grid.for_each_within(sample_pos[s], reach, |j, _, _| {
                around.extend(raw[j as usize]);
            });
            on_faces(&mut around)
        })
        .collect();
    // Samples without a measurement of their own (and none around) take the cloud's.
    let fallback = on_faces(&mut raw.iter().flatten().copied().collect());
    let n = positions.len();
    let mut out = LocalScale {
        cell: vec![0; n],
        cells: Vec::with_capacity(blocks.len()),
    };
    for (b, &measured) in blocks.iter().zip(&smooth) {
        let OnFaces {
            spacing: h,
            anisotropy,
            var,
        } = if measured.is_finite() {
            measured
        } else {
            fallback
        };
        let h = h / SECTOR_RATIO;
        let pitch = h / (anisotropy - (PITCH_ISOTROPIC - 1.0)).max(1.0);
        let sigma = params.noise.unwrap_or(var.sqrt());
        let radius = params.radius.unwrap_or_else(|| {
            (min_radius_on(params.min_radius, h / pitch) * h)
                .max(params.noise_radius * sigma)
                .max((params.normal_radius * (sigma * h).sqrt()).min(params.noise_radius * h))
        });
        let c = out.cells.len() as u32;
        out.cells.push([h, pitch, sigma, radius].map(|x| x as f32));
        for &i in cells.slot_ids(b.slots.clone()) {
            out.cell[i as usize] = c;
        }
    }
    Ok(out)
}

/// Smallest automatic radius in spacings on scan lines, however dense they are: 3 spacings
/// are 2.3 of the lines' gaps (the spacing is the gap over [`SECTOR_RATIO`]), so a
/// neighbourhood holds its own line and the next two on either side. With one `min_radius`
/// for every case, the 26 line scans of `bench --random 100 --seed 1` missed 142 / 125 / 120
/// corners at 4 / 3 / 2.5 spacings; a floor of 2.5 found a few more corners over seeds 1, 2,
/// 3 (702 missed against 717) but overshot the ends of edges running along lines 9 h
/// apart (seed 1's r075: edge precision 0.999 → 0.981, `tests/issue17_pair_edges.rs`).
pub const LINE_MIN_RADIUS: f64 = 3.0;

/// The smallest automatic radius, in spacings (across the pattern), where the pattern is
/// `ratio` = spacing / pitch times denser along its lines than across them. A disc of r
/// spacings holds ∝ ratio·r² points, so about `min_radius / √ratio` spacings hold as many as
/// `min_radius` do on uniform sampling; it is floored at [`LINE_MIN_RADIUS`]. The ratio
/// counts from 1 above isotropic (`ratio − 1`): grids and overlapping views read 1–2 and
/// keep `min_radius` (with `ratio` itself, grid cases of `bench --random` lost edge recall:
/// seed 1's r046 0.98 → 0.91). Why: scan lines g mean spacings apart are g² times denser
/// along than across, and on lines 8 mean spacings apart 4 spacings across were 27 mean
/// spacings, wider than a part's small faces, whose edges were then never segmented
/// (`bench --random 100`, seed 1's r050: 20 of 40 corners missed, 10 now; over seeds 1, 2
/// and 3, 769 missed corners, 717 now).
pub fn min_radius_on(min_radius: f64, ratio: f64) -> f64 {
    let scaled = min_radius / (ratio - 1.0).max(1.0).sqrt();
    scaled.max(LINE_MIN_RADIUS.min(min_radius))
}

/// What one sampled neighbourhood says.
#[derive(Debug, Clone, Copy)]
struct Sample {
    /// Spacing across the pattern, before calibration.
    spacing: f64,
    /// Third over second smallest sector distance (≥ 1).
    anisotropy: f64,
    /// Out-of-plane variance.
    var: f64,
    /// Surface variation λ0 / (λ0 + λ1 + λ2): noise alone on a face, more across an edge.
    variation: f64,
    /// Its neighbours lie on one scan line ([`LocalPca::spans_one_line`]): its plane is the
    /// noise's, its sectors the noise's across the line, and it measures neither the spacing
    /// nor the noise. Where any sample of the cloud measures a surface it is dropped before
    /// smoothing, and its cell takes the values of the samples around or the cloud's. Why:
    /// where scan lines cross a face that leans towards their cutting planes they lie farther
    /// apart than K neighbours reach along one (issue 17, seed 1's r039 of `bench --random
    /// 100`: lines 37 h apart on a face, the neighbours reaching 24 h either way along their
    /// line). That face measured a 2.4 h spacing and a 9.5 h radius; every neighbourhood
    /// there held one line, and its normals were noise. Two lines g apart among K neighbours
    /// a pitch p apart along them spread g²/4 across against (K p / 2)²/12 along: they pass
    /// from g ≈ 1.4 p, closer than any scan's lines.
    ///
    /// [`LocalPca::spans_one_line`]: crate::geometry::moments::LocalPca::spans_one_line
    one_line: bool,
}

/// Samples whose surface variation exceeds this many times the lower quartile of those
/// around them straddle an edge, and are left out.
const ON_FACE: f64 = 2.0;

/// Medians over the samples on faces, before calibration.
#[derive(Debug, Clone, Copy)]
struct OnFaces {
    spacing: f64,
    anisotropy: f64,
    var: f64,
}

impl OnFaces {
    fn is_finite(&self) -> bool {
        self.spacing.is_finite() && self.anisotropy.is_finite() && self.var.is_finite()
    }
}

/// (median spacing, pitch and variance) of the samples that lie on faces: those whose surface
/// variation is at most [`ON_FACE`] times the lower quartile around them. A neighbourhood
/// across an edge reads the bend as noise, and its two faces projected on one plane as a
/// denser sampling; near a sharp wedge's apex most neighbourhoods do (on a 30° wedge, within
/// nine spacings of it), and the quartile stays on the faces while a quarter of the samples
/// around does. At high noise every sample's variation is the noise's and none is left out,
/// and none needs to be. NaNs without samples.
fn on_faces(around: &mut Vec<Sample>) -> OnFaces {
    let mut variation: Vec<f64> = around.iter().map(|s| s.variation).collect();
    let limit = ON_FACE * quantile(&mut variation, 0.25);
    around.retain(|s| s.variation <= limit);
    let mut h: Vec<f64> = around.iter().map(|s| s.spacing).collect();
    let mut anisotropy: Vec<f64> = around.iter().map(|s| s.anisotropy).collect();
    let mut var: Vec<f64> = around.iter().map(|s| s.var).collect();
    OnFaces {
        spacing: quantile(&mut h, 0.5),
        anisotropy: quantile(&mut anisotropy, 0.5),
        var: quantile(&mut var, 0.5),
    }
}

/// What the K nearest distinct neighbours of point `i` say; `None` with fewer than 8 of them.
fn measure(positions: &[[f64; 3]], tree: &KdTree, i: usize) -> Option<Sample> {
    let p = positions[i];
    let offsets: Vec<[f64; 3]> = tree
        .nearest(p, K + 1)
        .into_iter()
        .filter(|&(j, d)| j as usize != i && d > 0.0)
        .map(|(j, _)| {
            let q = positions[j as usize];
            [q[0] - p[0], q[1] - p[1], q[2] - p[2]]
        })
        .filter(|d| dot(*d, *d) > 0.0)
        .collect();
    if offsets.len() < 8 {
        return None;
    }
    let mut m = [0.0f64; 10];
    for &d in &offsets {
        add_moments(&mut m, d);
    }
    let pca = pca_from_moments(&m)?;
    let one_line = pca.spans_one_line();
    let n = f64::from(pca.count);
    let var = pca.eigenvalues[0] * n / (n - 3.0);
    let (u, v) = perp_basis(&pca.normal);
    let in_plane: Vec<(f64, f64)> = offsets.iter().map(|&d| (dot(d, u), dot(d, v))).collect();
    let nearest = in_plane
        .iter()
        .copied()
        .filter(|&(x, y)| x * x + y * y > 0.0)
        .min_by(|a, b| (a.0 * a.0 + a.1 * a.1).total_cmp(&(b.0 * b.0 + b.1 * b.1)))?;
    let total = pca.eigenvalues.iter().sum::<f64>();
    let [second, third] = sector_distances(&in_plane, nearest.1.atan2(nearest.0))?;
    let spacing = line_gap(&in_plane, second).map_or(third, |g| g.max(third));
    Some(Sample {
        spacing,
        anisotropy: spacing / second,
        var,
        variation: if total > 0.0 {
            pca.eigenvalues[0] / total
        } else {
            0.0
        },
        one_line,
    })
}

/// The third smallest of the nearest distances in eight 45° sectors of the plane, the first
/// centred on the direction `start` (radians); the largest when fewer than three sectors hold
/// a point. `None` without points.
pub fn sector_spacing(in_plane: &[(f64, f64)], start: f64) -> Option<f64> {
    sector_distances(in_plane, start).map(|d| d[1])
}

/// Neighbours that fix a neighbourhood's along-line direction in [`line_gap`].
const LINE_NEAREST: usize = 6;
/// A jump in the neighbours' distances across the line by this factor, and by more than the
/// along-line step, separates the own line from the next.
const LINE_JUMP: f64 = 2.0;

/// The gap to the next scan line when the in-plane neighbours lie on lines: the direction of
/// the [`LINE_NEAREST`] nearest (their principal axis through the point) is the line's, and
/// the neighbours' distances across it split in two groups, the own line (within its noise)
/// and the next lines, a jump by [`LINE_JUMP`] apart. The sectors alone miss it when the
/// noise across the line is a good share of the step along it: the own line's points then
/// fill the sectors beside the line's direction (seen at σ = 0.28 step, lines 8.4 steps
/// apart: third sector distance 2 steps). `None` when no such jump exists (uniform
/// sampling, a neighbourhood on one line only). `step`: the along-line step (the second
/// smallest sector distance).
fn line_gap(in_plane: &[(f64, f64)], step: f64) -> Option<f64> {
    let mut by_dist: Vec<(f64, f64)> = in_plane.to_vec();
    by_dist.sort_by(|a, b| (a.0 * a.0 + a.1 * a.1).total_cmp(&(b.0 * b.0 + b.1 * b.1)));
    let near = &by_dist[..LINE_NEAREST.min(by_dist.len())];
    let (sxx, sxy, syy) = near.iter().fold((0.0, 0.0, 0.0), |(a, b, c), &(x, y)| {
        (a + x * x, b + x * y, c + y * y)
    });
    let theta = 0.5 * (2.0 * sxy).atan2(sxx - syy);
    let (sin, cos) = theta.sin_cos();
    let mut across: Vec<f64> = in_plane
        .iter()
        .map(|&(x, y)| (y * cos - x * sin).abs())
        .collect();
    across.sort_by(f64::total_cmp);
    // The own line needs a few points, the next line too.
    let (lo, hi) = (LINE_NEAREST - 1, across.len().checked_sub(3)?);
    (lo..hi)
        .filter(|&i| across[i + 1] >= LINE_JUMP * across[i] && across[i + 1] - across[i] > step)
        .max_by(|&i, &j| (across[i + 1] - across[i]).total_cmp(&(across[j + 1] - across[j])))
        .map(|i| across[i + 1])
}

/// [second smallest, third smallest] of the sectors' nearest distances (see
/// [`sector_spacing`]; with fewer sectors, the largest stands in for the missing).
fn sector_distances(in_plane: &[(f64, f64)], start: f64) -> Option<[f64; 2]> {
    let sector = std::f64::consts::FRAC_PI_4;
    let mut best = [f64::INFINITY; 8];
    for &(x, y) in in_plane {
        let d = (x * x + y * y).sqrt();
        if d == 0.0 {
            continue;
        }
        let a = (y.atan2(x) - start + 0.5 * sector).rem_euclid(std::f64::consts::TAU);
        let s = ((a / sector) as usize).min(7);
        best[s] = best[s].min(d);
    }
    let mut found: Vec<f64> = best.into_iter().filter(|d| d.is_finite()).collect();
    found.sort_by(f64::total_cmp);
    match found.len() {
        0 => None,
        1 => Some([found[0]; 2]),
        2 => Some([found[1]; 2]),
        _ => Some([found[1], found[2]]),
    }
}

/// The `q`-quantile (nearest rank) of `v`; NaN when empty.
pub(crate) fn quantile(v: &mut [f64], q: f64) -> f64 {
    quantile_by(v, q, f64::total_cmp).unwrap_or(f64::NAN)
}

/// The `q`-quantile (nearest rank, 0 ≤ q ≤ 1) of `v` in the order `cmp`; `None` when empty.
fn quantile_by<T: Copy>(
    v: &mut [T],
    q: f64,
    cmp: impl FnMut(&T, &T) -> std::cmp::Ordering,
) -> Option<T> {
    if v.is_empty() {
        return None;
    }
    let k = ((v.len() - 1) as f64 * q.clamp(0.0, 1.0)).round() as usize;
    Some(*v.select_nth_unstable_by(k, cmp).1)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::neighbours::mean_spacing;
    use crate::testdata::dihedral;

    #[test]
    fn sectors_of_scan_lines_give_the_gap_between_lines() {
        // Lines along x, 0.1 apart along, 1.0 apart across.
        let mut pts = Vec::new();
        for l in -3..=3 {
            for k in -40..=40 {
                if (l, k) != (0, 0) {
                    pts.push((0.1 * f64::from(k), f64::from(l)));
                }
            }
        }
        let h = sector_spacing(&pts, 0.0).unwrap();
        assert!((h - 1.0).abs() < 1e-9, "{h}");
        // A square grid of pitch 0.5 by 2: the larger pitch.
        let grid: Vec<(f64, f64)> = (-5..=5)
            .flat_map(|a| (-5..=5).map(move |b| (0.5 * f64::from(a), 2.0 * f64::from(b))))
            .filter(|&(x, y)| x != 0.0 || y != 0.0)
            .collect();
        assert!((sector_spacing(&grid, 0.0).unwrap() - 2.0).abs() < 1e-9);
        // A half plane (scan border): still the pitch.
        let half: Vec<(f64, f64)> = grid.iter().copied().filter(|p| p.1 >= 0.0).collect();
        assert!((sector_spacing(&half, 0.0).unwrap() - 2.0).abs() < 1e-9);
        assert_eq!(sector_spacing(&[], 0.0), None);
    }

    #[test]
    fn uniform_sampling_keeps_its_spacing_and_noise() {
        // The simulator's uniform sampling at the suite's noise: the spacing is the mean
        // nearest distance there (the calibration of SECTOR_RATIO), the noise the true sigma.
        let params = crate::synth::SynthParams {
            sampling: crate::synth::Sampling::Points(60_000),
            noise: 0.15,
            seed: 4,
            ..Default::default()
        };
        let scan = crate::synth::generate(&params).unwrap();
        let pts = &scan.cloud.positions;
        let s = mean_spacing(pts, 50_000).unwrap();
        let local = local_scale(pts, s, &ScaleRules::default()).unwrap();
        let sum = local.summary();
        assert!(
            (sum.spacing / s - 1.0).abs() < 0.05,
            "{} against {s}",
            sum.spacing
        );
        let sigma = 0.15 * scan.ground_truth.spacing;
        assert!(
            (sum.noise / sigma - 1.0).abs() < 0.15,
            "{} against {sigma}",
            sum.noise
        );
        // Whatever the noise, the spacing follows the pitch, not the noise.
        for sigma in [0.0, 0.05, 0.15, 0.5, 1.0] {
            let (pts, _) = dihedral(90.0, 1.0, sigma, 30.0, 3);
            let local = local_scale(&pts, 0.64, &ScaleRules::default()).unwrap();
            let sum = local.summary();
            let pitch = sum.spacing * SECTOR_RATIO;
            assert!((1.0..1.2).contains(&pitch), "sigma {sigma}: pitch {pitch}");
            if sigma > 0.0 {
                let rel = (sum.noise - sigma).abs() / sigma;
                assert!(rel < 0.15, "sigma {sigma}: estimated {}", sum.noise);
            }
            // Second against third sector distance on this sampling (PITCH_RATIO's margin).
            let tree = KdTree::new(&pts).unwrap();
            let mut ratios: Vec<f64> = (0..pts.len())
                .step_by(97)
                .filter_map(|i| measure(&pts, &tree, i))
                .map(|m| m.anisotropy)
                .collect();
            let (q10, q50) = (quantile(&mut ratios, 0.1), quantile(&mut ratios, 0.5));
            eprintln!("sigma {sigma}: third / second sector distance q10 {q10:.3} median {q50:.3}");
            for i in 0..pts.len() {
                let sc = local.at(i);
                assert_eq!(
                    sc.pitch, sc.spacing,
                    "sigma {sigma}: uniform pitch is the spacing"
                );
                assert!(sc.radius >= 4.0 * sc.spacing * 0.999);
                assert!(sc.radius >= 6.0 * sc.noise * 0.999);
            }
        }
    }

    #[test]
    fn scan_lines_get_the_spacing_across_them() {
        // A plane scanned in lines 0.1 apart along x and 1.0 apart across: the mean nearest
        // distance is the along-line 0.1, the local spacing must be the gap.
        let mut pts = Vec::new();
        for l in 0..60 {
            for k in 0..600 {
                pts.push([0.1 * f64::from(k), f64::from(l), 0.0]);
            }
        }
        let s = mean_spacing(&pts, 50_000).unwrap();
        assert!(s < 0.11);
        let local = local_scale(&pts, s, &ScaleRules::default()).unwrap();
        let h = local.summary().spacing * SECTOR_RATIO;
        assert!((h - 1.0).abs() < 0.05, "{h}");
        // Ten times denser along the lines: the radius is the floor of 3 spacings (2.3 of
        // the lines' gaps), not 4.
        let Scale {
            spacing, radius, ..
        } = local.summary();
        assert!(
            (radius - LINE_MIN_RADIUS * spacing).abs() < 1e-6 * radius,
            "radius {radius}, spacing {spacing}"
        );
        assert!((radius - 2.26).abs() < 0.1, "radius {radius} gaps");
    }

    #[test]
    fn issue17_scan_lines_farther_apart_than_the_neighbours_reach_take_the_spacing_around() {
        // A plane in lines along x, 0.1 apart along them: 1.0 apart up to y = 30, then 8.0
        // apart (a face that leans towards the cutting planes). K neighbours reach 2.4 along
        // a line: there each sample sees its own line only, and its sectors would read the
        // noise across the line (0.01 here) as the spacing.
        let mut pts = Vec::new();
        let mut y = 0.0;
        while y < 150.0 {
            for k in 0..600 {
                // A little noise across the line and out of the plane, fixed by the point.
                let e = |a: u32| ((f64::from(k * 7919 + a) * 0.618_034).fract() - 0.5) * 0.01;
                pts.push([0.1 * f64::from(k), y + e(1), e(2)]);
            }
            y += if y < 30.0 { 1.0 } else { 8.0 };
        }
        let s = mean_spacing(&pts, 50_000).unwrap();
        let local = local_scale(&pts, s, &ScaleRules::default()).unwrap();
        let tree = KdTree::new(&pts).unwrap();
        for (i, p) in pts.iter().enumerate().step_by(37) {
            let sc = local.at(i);
            if p[1] >= 60.0 {
                assert!(measure(&pts, &tree, i).is_some_and(|m| m.one_line));
                // The spacing the lines 1.0 apart measured, not the step along a line.
                let h = sc.spacing * SECTOR_RATIO;
                assert!((0.9..1.2).contains(&h), "y {}: spacing {h}", p[1]);
            } else if p[1] <= 25.0 {
                assert!(measure(&pts, &tree, i).is_some_and(|m| !m.one_line));
            }
        }
    }

    #[test]
    fn min_radius_shrinks_with_the_density_along_scan_lines() {
        // Uniform sampling, grids and overlapping views (ratio up to 2) keep min_radius.
        for ratio in [0.5, 1.0, 1.5, 2.0] {
            assert_eq!(min_radius_on(4.0, ratio), 4.0, "ratio {ratio}");
        }
        // As many points as on uniform sampling: 4 / sqrt(ratio - 1).
        assert!((min_radius_on(4.0, 2.5) - 4.0 / 1.5f64.sqrt()).abs() < 1e-12);
        // Floored at LINE_MIN_RADIUS, however dense the lines.
        assert_eq!(min_radius_on(4.0, 100.0), LINE_MIN_RADIUS);
        // A min_radius below the floor is the user's choice and stays.
        assert_eq!(min_radius_on(2.0, 100.0), 2.0);
        // Never larger than min_radius, and monotone in the ratio.
        let mut last = f64::INFINITY;
        for k in 0..200 {
            let r = min_radius_on(6.0, 1.0 + 0.25 * f64::from(k));
            assert!(r <= 6.0 && r <= last, "{r} after {last}");
            last = r;
        }
    }

    #[test]
    fn density_gradient_gives_each_side_its_own_spacing() {
        // Two squares side by side, spacing 0.5 and 2.0: each keeps its own.
        let mut pts = Vec::new();
        for a in 0..120 {
            for b in 0..120 {
                pts.push([0.5 * f64::from(a), 0.5 * f64::from(b), 0.0]);
            }
        }
        for a in 0..60 {
            for b in 0..30 {
                pts.push([100.0 + 2.0 * f64::from(a), 2.0 * f64::from(b), 0.0]);
            }
        }
        let s = mean_spacing(&pts, 50_000).unwrap();
        let local = local_scale(&pts, s, &ScaleRules::default()).unwrap();
        let h = |i: usize| local.at(i).spacing * SECTOR_RATIO;
        assert!(
            (h(60 * 120 + 60) - 0.5).abs() < 0.05,
            "{}",
            h(60 * 120 + 60)
        );
        assert!((h(120 * 120 + 30 * 30 + 15) - 2.0).abs() < 0.2);

        // Ranks read from the cells are the ranks of the per-point values.
        for pick in [|s: &Scale| s.spacing, |s: &Scale| s.radius] {
            let mut brute: Vec<f32> = (0..local.len())
                .map(|i| pick(&local.at(i)) as f32)
                .collect();
            brute.sort_by(f32::total_cmp);
            for k in [0, 1, brute.len() / 3, brute.len() * 9 / 10, brute.len() - 1] {
                assert_eq!(local.ranked(pick, k), Some(f64::from(brute[k])), "rank {k}");
            }
            assert_eq!(local.ranked(pick, brute.len()), None);
        }
    }

    #[test]
    fn given_radius_and_noise_replace_the_measured_ones() {
        let (pts, _) = dihedral(90.0, 1.0, 0.1, 20.0, 3);
        let params = ScaleRules {
            radius: Some(3.5),
            noise: Some(0.2),
            ..ScaleRules::default()
        };
        let local = local_scale(&pts, 1.0, &params).unwrap();
        assert!((0..local.len()).all(|i| local.at(i).radius as f32 == 3.5));
        assert!((0..local.len()).all(|i| local.at(i).noise as f32 == 0.2));
        assert_eq!(local.radius_range(), (3.5, 3.5));
        let none = LocalScale::uniform(0, local.summary());
        assert_eq!(none.radius_range(), (f32::INFINITY, 0.0));
    }

    #[test]
    fn bad_spacing_is_an_error() {
        let (pts, _) = dihedral(90.0, 1.0, 0.1, 5.0, 3);
        assert!(local_scale(&pts, 0.0, &ScaleRules::default()).is_err());
        assert!(local_scale(&pts, f64::NAN, &ScaleRules::default()).is_err());
    }
}
