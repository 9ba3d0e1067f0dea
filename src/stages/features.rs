//! Per-point local shape: noise level, neighbourhood scale, PCA normal, sharpness score and the
//! candidate edge points.
//!
//! Inputs: positions, the neighbour grid, each point's `LocalScale` (spacing, noise sigma,
//! radius: `stages::scale`), `FeatureParams`. Outputs: `Features` (side arrays by point id).
//!
//! Why these scores: surface variation λ0/(λ0+λ1+λ2) at a fixed k is swamped by noise once
//! sigma approaches the spacing (CRATES.md: best F1 0.34 at k = 16). Here the noise sigma is
//! measured from the data first (each point's own, `stages::scale`), and each neighbourhood
//! radius is made several sigmas and spacings wide. Two scores follow:
//! - `sharpness` = λ0 / σ²: the neighbourhood's out-of-plane variance in noise variances, ≈ 1 on
//!   a face. Across an edge whose normals differ by θ it is ≈ 0.07·sin²(θ/2)·(r/σ)² + 1, which
//!   is strong at the apex of sharp wedges but weak for obtuse edges or heavy noise.
//! - `split`: the middle eigenvalue of the mean normal tensor mean(n nᵀ) of the neighbourhood's
//!   PCA normals, ≈ a(1−a)·sin²θ across an edge. The PCA normals are averages over hundreds of
//!   points, so this stays ~5x above the face level even at σ = spacing (measured in the tests:
//!   near-edge 10th percentile 0.14 against a face maximum of 0.03), and ~35x at σ = 0.15
//!   spacing for a 150° dihedral edge.
//!
//! A point is a candidate when either score stands out: thresholds are fixed statements about
//! noise statistics and angles (relative to the cloud's own median), not per-scan tuning. A
//! point whose neighbourhood holds one scan line and nothing else (`LocalPca::spans_one_line`)
//! is none: its normal is the noise's, and so are both scores.

use rayon::prelude::*;

use crate::geometry::eigen3;
pub use crate::geometry::moments::{LocalPca, add_moments, add_moments_weighted, pca_from_moments};
use crate::neighbours::{Block, Crowd, Grid};
use crate::progress::Progress;
pub use crate::stages::scale::{LocalScale, NORMAL_RADIUS, Scale, ScaleRules};

/// Settings of the features stage (validated by `config`).
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct FeatureParams {
    /// Neighbourhood radius in model units; `None` = max(`min_radius` spacings,
    /// `noise_radius` sigmas).
    pub radius: Option<f64>,
    /// Noise sigma in model units; `None` = estimated from the data.
    pub noise: Option<f64>,
    /// Smallest automatic radius, in spacings.
    pub min_radius: f64,
    /// Automatic radius in noise sigmas (when larger than `min_radius` spacings).
    pub noise_radius: f64,
    /// Automatic radius in √(sigma·spacing) (when larger than the two above): see
    /// `ScaleRules::normal_radius`.
    pub normal_radius: f64,
    /// A point is a candidate when its sharpness (λ0 / σ²) exceeds this...
    pub threshold: f64,
    /// ...or when its normal split exceeds this (≈ a(1−a)·sin²θ; 0.008 is a 30° normal change
    /// seen by a fifth of the neighbourhood)...
    pub split_threshold: f64,
    /// ...and this many times the cloud's median split (the normals' own noise).
    pub split_noise_factor: f64,
    /// A point with fewer neighbours than this share of the median count is an outlier.
    pub outlier_share: f64,
}

impl FeatureParams {
    /// The rules the scale stage sizes neighbourhoods by.
    pub fn scale_rules(&self) -> ScaleRules {
        ScaleRules {
            radius: self.radius,
            noise: self.noise,
            min_radius: self.min_radius,
            noise_radius: self.noise_radius,
            normal_radius: self.normal_radius,
        }
    }
}

impl Default for FeatureParams {
    fn default() -> Self {
        // The scale rules' defaults are the scale stage's (one place for them).
        let ScaleRules {
            radius,
            noise,
            min_radius,
            noise_radius,
            normal_radius,
        } = ScaleRules::default();
        FeatureParams {
            radius,
            noise,
            min_radius,
            noise_radius,
            normal_radius,
            threshold: 3.0,
            split_threshold: 0.008,
            split_noise_factor: 15.0,
            outlier_share: 0.2,
        }
    }
}

/// Per-point outputs of the features stage, indexed by point id. In a run's `Outcome` the
/// arrays [`Features::release_shape`] frees are empty.
#[derive(Debug, Clone, Default)]
pub struct Features {
    /// Unit normal of the neighbourhood's best plane (sign arbitrary).
    pub normal: Vec<[f32; 3]>,
    /// λ0 / σ²: out-of-plane variance of the neighbourhood in noise variances.
    pub sharpness: Vec<f32>,
    /// Surface variation λ0 / (λ0 + λ1 + λ2), the classic score, for inspection.
    pub variation: Vec<f32>,
    /// Number of points within the radius (the point itself included).
    pub count: Vec<u32>,
    /// Middle eigenvalue of the neighbourhood's normal tensor: ≈ a(1−a)·sin²θ across an edge.
    pub split: Vec<f32>,
    /// Smallest eigenvector of the normal tensor: the edge direction where `split` is large.
    pub direction: Vec<[f32; 3]>,
    /// Smallest eigenvalue of the normal tensor: large where three faces meet.
    pub corner: Vec<f32>,
    /// Candidate edge point.
    pub candidate: Vec<bool>,
    /// Isolated point (too few neighbours): never a candidate, never used by fits.
    pub outlier: Vec<bool>,
    /// The `split` threshold used for this cloud.
    pub split_threshold: f32,
}

impl Features {
    /// Frees the arrays only segmentation reads (edge direction, corner score) and the
    /// sharpness nothing reads after this stage, leaving them empty.
    pub fn release_for_faces(&mut self) {
        self.direction = Vec::new();
        self.corner = Vec::new();
        self.sharpness = Vec::new();
    }

    /// Frees the arrays faces and segmentation read (normal, variation, count, and those of
    /// [`Features::release_for_faces`]), leaving them empty; `candidate`, `outlier` and
    /// `split` stay. The pipeline frees them as soon as runs and faces are grown, so that
    /// the later stages do not carry 40 bytes a point they never read.
    pub fn release_shape(&mut self) {
        self.release_for_faces();
        self.normal = Vec::new();
        self.variation = Vec::new();
        self.count = Vec::new();
    }
}

/// Cells per unit of parallel work: a few thousand points.
const BLOCK_CHUNK: usize = 256;

/// A cell with more than this many times the median cell's points (and more than
/// `CROWD_FLOOR`) is crowded: its neighbourhood sums come from a weighted subset
/// (`Grid::crowd`), so a query reads at most about this many medians of a cell.
const CROWD_FACTOR: usize = 64;
const CROWD_FLOOR: usize = 1024;

/// `v` (one value per slot) cut into the stretches of slots `lens` long, in order.
fn split_by<'a, T>(mut v: &'a mut [T], lens: &[usize]) -> Vec<&'a mut [T]> {
    let mut parts = Vec::with_capacity(lens.len());
    for &len in lens {
        let (part, rest) = std::mem::take(&mut v).split_at_mut(len);
        parts.push(part);
        v = rest;
    }
    parts
}

/// The points of a chunk of cells in slot order, each with its cell.
fn slots_of<'a>(grid: &'a Grid, chunk: &'a [Block]) -> impl Iterator<Item = (&'a Block, u32)> {
    chunk
        .iter()
        .flat_map(move |b| grid.slot_ids(b.slots.clone()).iter().map(move |&i| (b, i)))
}

/// `v` (one value per slot) by point id: the value of slot s at index `ids[s]`. The
/// features are computed in the grid's slot order (each chunk of cells writes its own
/// stretch of the arrays, with no rows held on the side) and handed out by point id, one
/// array at a time, so that at most one array is held twice.
fn slots_to_ids<T: Copy + Default>(v: Vec<T>, ids: &[u32]) -> Vec<T> {
    let mut out = vec![T::default(); v.len()];
    for (&i, &x) in ids.iter().zip(&v) {
        out[i as usize] = x;
    }
    out
}

/// Computes the per-point features, each point with its own radius and noise from `scale`.
/// Any grid works; cells about as wide as most radii are fastest.
pub fn features(
    positions: &[[f64; 3]],
    grid: &Grid,
    scale: &LocalScale,
    params: &FeatureParams,
    progress: &Progress,
) -> Features {
    let n = positions.len();
    // Noise floor: never divide by less than a millionth of the spacing squared, so a
    // noise-free synthetic scan still gets finite scores.
    let var_of = |i: usize| {
        let Scale {
            noise: s,
            spacing: h,
            ..
        } = scale.at(i);
        (s * s).max(1e-6 * h * h)
    };
    // Work cell by cell, in the grid's spatial order (cache locality, and the 27 cells around
    // a cell found once for all its points), into arrays in that order; handed out by id at
    // the end.
    let blocks = grid.blocks();
    let crowd = grid.crowd(positions, CROWD_FACTOR, CROWD_FLOOR);
    if let Some(c) = &crowd {
        tracing::info!(
            "features: crowded cells: {} of {} points stand for the others in neighbourhood sums",
            c.ids.len(),
            n
        );
    }

    // The cells' chunks, each owning a stretch of slots: the blocks cover the slots in order.
    let chunks: Vec<&[Block]> = blocks.chunks(BLOCK_CHUNK).collect();
    let lens: Vec<usize> = chunks
        .iter()
        .map(|c| c.iter().map(|b| b.slots.len()).sum())
        .collect();
    debug_assert_eq!(lens.iter().sum::<usize>(), n);

    // Pass 1: plane fit of each neighbourhood. Every array in slot order until the end.
    let mut normal = vec![[0.0f32; 3]; n];
    let mut sharpness = vec![0.0f32; n];
    let mut variation = vec![0.0f32; n];
    let mut count = vec![0u32; n];
    let mut one_line = vec![false; n];
    split_by(&mut normal, &lens)
        .into_iter()
        .zip(split_by(&mut sharpness, &lens))
        .zip(split_by(&mut variation, &lens))
        .zip(split_by(&mut count, &lens))
        .zip(split_by(&mut one_line, &lens))
        .zip(&chunks)
        .collect::<Vec<_>>()
        .into_par_iter()
        .for_each(|(((((nrm, sh), va), co), ol), chunk)| {
            for (k, (block, i)) in slots_of(grid, chunk).enumerate() {
                let q = positions[i as usize];
                let r = scale.at(i as usize).radius;
                let var = var_of(i as usize);
                let mut m = [0.0f64; 10];
                match &crowd {
                    None => grid.for_each_in_block_weighted(block, q, r, |_, d, w| {
                        add_moments_weighted(&mut m, d, w)
                    }),
                    Some(c) => c.grid.for_each_within(q, r, |k, d, _| {
                        add_moments_weighted(&mut m, d, c.weight[k as usize])
                    }),
                }
                (nrm[k], sh[k], va[k], co[k], ol[k]) = match pca_from_moments(&m) {
                    Some(p) => {
                        let sum = p.eigenvalues.iter().sum::<f64>();
                        let v = if sum > 0.0 {
                            p.eigenvalues[0] / sum
                        } else {
                            0.0
                        };
                        let c = m[0].round() as u32;
                        (
                            p.normal.map(|c| c as f32),
                            (p.eigenvalues[0] / var) as f32,
                            v as f32,
                            c,
                            p.spans_one_line(),
                        )
                    }
                    None => ([0.0; 3], 0.0, 0.0, 1, false),
                };
            }
            let done = nrm.len() as u64;
            progress.inc(done / 2);
        });
    let ids = grid.slot_ids(0..n);
    // The neighbours' normals are read in slot order by the block scans
    // (`Grid::for_each_in_block_weighted`), by id when a crowd stands in.
    if crowd.is_some() {
        normal = slots_to_ids(normal, ids);
    }

    // Pass 2: the normal tensor T = mean(n nᵀ) over the same neighbourhood (sign-free). On a
    // face all normals agree and T has one eigenvalue ≈ 1; across an edge they form two
    // clusters at the faces' angle θ and T's middle eigenvalue is ≈ a(1−a)·sin²θ (a = share of
    // the neighbourhood on one side), its smallest eigenvector the edge direction. The PCA
    // normals are averages over ~r²/h² points, so their noise is far below the point noise:
    // this is what keeps detection alive when σ approaches the spacing.
    let mut split = vec![0.0f32; n];
    let mut direction = vec![[0.0f32; 3]; n];
    let mut corner = vec![0.0f32; n];
    split_by(&mut split, &lens)
        .into_iter()
        .zip(split_by(&mut direction, &lens))
        .zip(split_by(&mut corner, &lens))
        .zip(&chunks)
        .collect::<Vec<_>>()
        .into_par_iter()
        .for_each(|(((sp, di), co), chunk)| {
            for (k, (block, i)) in slots_of(grid, chunk).enumerate() {
                let r = scale.at(i as usize).radius;
                let q = positions[i as usize];
                let (t, d) = normal_tensor(grid, crowd.as_ref(), block, &normal, q, r);
                (sp[k], di[k], co[k]) = (t[1] as f32, d.map(|c| c as f32), t[0] as f32);
            }
            let done = sp.len() as u64;
            progress.inc(done - done / 2);
        });
    // The cells' 27-cell lists (11 bytes a point) are done with before the arrays are
    // handed out, each held twice for a moment.
    drop(chunks);
    drop(blocks);
    if crowd.is_none() {
        normal = slots_to_ids(normal, ids);
    }
    let sharpness = slots_to_ids(sharpness, ids);
    let variation = slots_to_ids(variation, ids);
    let count = slots_to_ids(count, ids);
    let one_line = slots_to_ids(one_line, ids);
    let split = slots_to_ids(split, ids);
    let direction = slots_to_ids(direction, ids);
    let corner = slots_to_ids(corner, ids);

    // Thresholds from the cloud's own statistics (medians: faces are the majority).
    let median_count = median_u32(&count);
    let min_count = ((params.outlier_share * f64::from(median_count)).ceil() as u32).max(4);
    let split_floor = median_f32(&split);
    let split_threshold = params
        .split_threshold
        .max(params.split_noise_factor * f64::from(split_floor)) as f32;
    let plane_threshold = params.threshold as f32;
    tracing::debug!(
        "features: median split {split_floor:.5}, split threshold {split_threshold:.5}, \
         median count {median_count}, outlier below {min_count}"
    );
    let outlier: Vec<bool> = count.iter().map(|&c| c < min_count).collect();
    // A neighbourhood on one scan line (`LocalPca::spans_one_line`) has the noise's normal:
    // its split and sharpness say nothing of an edge. Issue 17: where the scale stage sizes
    // the radius of a face seen by sparse lines after the faces around it (`stages::scale`,
    // `Sample::one_line`), the points of a line farther than a radius from any other (a lone
    // line across a narrow face, the middle of a wall leaning towards the cutting planes)
    // were candidates, and a fit through them gave a 484 h edge across a flat face of seed
    // 107's r057 of `bench --random 100` (edge precision 1.0 -> 0.867; 0.980 with this rule).
    let lone = one_line.iter().filter(|&&l| l).count();
    if lone > 0 {
        tracing::debug!("features: {lone} points see one scan line within their radius");
    }
    let candidate: Vec<bool> = (0..n)
        .map(|i| {
            !outlier[i]
                && !one_line[i]
                && (split[i] > split_threshold || sharpness[i] > plane_threshold)
        })
        .collect();
    Features {
        normal,
        sharpness,
        variation,
        count,
        split,
        direction,
        corner,
        candidate,
        outlier,
        split_threshold,
    }
}

/// Eigenvalues (ascending) of the mean normal tensor around `q`, and its smallest eigenvector.
/// `normal` is in the grid's slot order, or by id with a crowd (over its kept points,
/// weighted).
fn normal_tensor(
    grid: &Grid,
    crowd: Option<&Crowd>,
    block: &Block,
    normal: &[[f32; 3]],
    q: [f64; 3],
    r: f64,
) -> ([f64; 3], [f64; 3]) {
    // Weight 1 leaves every product as it was (x * 1.0 == x): the same sums, bit for bit.
    // The sums go by value through the fold, which keeps them in registers.
    let add = |(mut t, mut c): ([f64; 6], f64), n: [f32; 3], w: f64| {
        let m = n.map(f64::from);
        t[0] += w * m[0] * m[0];
        t[1] += w * m[0] * m[1];
        t[2] += w * m[0] * m[2];
        t[3] += w * m[1] * m[1];
        t[4] += w * m[1] * m[2];
        t[5] += w * m[2] * m[2];
        c += w;
        (t, c)
    };
    let zero = ([0.0f64; 6], 0.0f64);
    let (t, c) = match crowd {
        None => {
            grid.fold_in_block_weighted(block, q, r, zero, |acc, s, _, w| add(acc, normal[s], w))
        }
        Some(crowd) => {
            let mut acc = zero;
            crowd.grid.for_each_within(q, r, |k, _, _| {
                acc = add(
                    acc,
                    normal[crowd.ids[k as usize] as usize],
                    crowd.weight[k as usize],
                )
            });
            acc
        }
    };
    if c == 0.0 {
        return ([0.0; 3], [0.0; 3]);
    }
    match eigen3::smallest(&t.map(|x| x / c)) {
        Some((values, d)) => (values.map(|v| v.max(0.0)), d),
        None => ([0.0; 3], [0.0; 3]),
    }
}

fn median_u32(v: &[u32]) -> u32 {
    let mut v = v.to_vec();
    let mid = v.len() / 2;
    v.select_nth_unstable(mid);
    v.get(mid).copied().unwrap_or(0)
}

fn median_f32(v: &[f32]) -> f32 {
    let mut v = v.to_vec();
    let mid = v.len() / 2;
    v.select_nth_unstable_by(mid, f32::total_cmp);
    v.get(mid).copied().unwrap_or(0.0)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testdata::dihedral;

    /// A scan's scale at a pitch and spacing of 1.
    fn unit_scale(noise: f64, radius: f64) -> Scale {
        Scale {
            spacing: 1.0,
            pitch: 1.0,
            noise,
            radius,
        }
    }

    fn measured(pts: &[[f64; 3]], params: &FeatureParams) -> (LocalScale, Scale) {
        let s = crate::neighbours::mean_spacing(pts, 50_000).unwrap();
        let local = crate::stages::scale::local_scale(pts, s, &params.scale_rules()).unwrap();
        let summary = local.summary();
        (local, summary)
    }

    #[test]
    fn candidates_form_a_band_around_the_edge_and_nothing_else() {
        for (angle, sigma) in [(90.0, 0.15), (30.0, 0.15), (150.0, 0.15), (90.0, 1.0)] {
            let (pts, dist) = dihedral(angle, 1.0, sigma, 25.0, 5);
            let params = FeatureParams::default();
            // The scan's pitch is 1 (fully jittered: its mean nearest distance is 0.64); the
            // noise as measured; the radius by the rules.
            let noise = measured(&pts, &params).1.noise;
            let scale = Scale {
                spacing: 1.0,
                pitch: 1.0,
                noise,
                radius: (4.0f64).max(6.0 * noise),
            };
            let local = LocalScale::uniform(pts.len(), scale);
            let grid = Grid::new(&pts, scale.radius).unwrap();
            let f = features(&pts, &grid, &local, &params, &Progress::hidden());
            // Away from the edge (and from the patch's own border) nothing is flagged. On a
            // sharp wedge the other face is only s·sin(angle) away from a point at distance s.
            let gap = if angle < 90.0 {
                f64::to_radians(angle).sin()
            } else {
                1.0
            };
            let far: Vec<usize> = (0..pts.len())
                .filter(|&i| {
                    dist[i] * gap > 1.5 * scale.radius
                        && dist[i] < 25.0 - scale.radius
                        && pts[i][1] > scale.radius
                        && pts[i][1] < 40.0 - scale.radius
                })
                .collect();
            let false_pos = far.iter().filter(|&&i| f.candidate[i]).count();
            assert!(
                false_pos * 1000 <= far.len(),
                "angle {angle} sigma {sigma}: {false_pos} of {} far points flagged",
                far.len()
            );
            // On the edge nearly everything is flagged.
            let near: Vec<usize> = (0..pts.len())
                .filter(|&i| {
                    dist[i] < 0.5 && pts[i][1] > scale.radius && pts[i][1] < 40.0 - scale.radius
                })
                .collect();
            let hits = near.iter().filter(|&&i| f.candidate[i]).count();
            assert!(
                hits * 100 >= near.len() * 95,
                "angle {angle} sigma {sigma}: {hits} of {} edge points flagged",
                near.len()
            );
        }
    }

    #[test]
    fn normals_of_a_plane_are_its_normal() {
        let (pts, dist) = dihedral(90.0, 1.0, 0.0, 20.0, 9);
        let scale = LocalScale::uniform(pts.len(), unit_scale(0.0, 4.0));
        let grid = Grid::new(&pts, 4.0).unwrap();
        let f = features(
            &pts,
            &grid,
            &scale,
            &FeatureParams::default(),
            &Progress::hidden(),
        );
        for i in 0..pts.len() {
            if dist[i] > 6.0 && pts[i][2].abs() < 1e-12 && pts[i][1] > 5.0 && pts[i][1] < 35.0 {
                assert!(
                    (f.normal[i][2].abs() - 1.0).abs() < 1e-5,
                    "{:?}",
                    f.normal[i]
                );
            }
        }
    }

    #[test]
    fn isolated_points_are_outliers_not_candidates() {
        let (mut pts, _) = dihedral(180.0, 1.0, 0.1, 20.0, 2);
        pts.push([10.0, 20.0, 50.0]);
        let params = FeatureParams::default();
        let (local, scale) = measured(&pts, &params);
        let grid = Grid::new(&pts, scale.radius).unwrap();
        let f = features(&pts, &grid, &local, &params, &Progress::hidden());
        let last = pts.len() - 1;
        assert!(f.outlier[last] && !f.candidate[last]);
    }

    #[test]
    fn issue17_a_scan_line_alone_within_the_radius_is_no_candidate() {
        // A plane scanned in lines along x, 0.1 apart along them, 2.5 apart up to y = 72.5,
        // and two lone lines farther than the radius from any other (a face leaning towards
        // the cutting planes, whose scale stage sized its radius after the faces around).
        // Noise 0.02 across the lines and out of the plane: a lone line's plane is the noise's.
        // A lone line holds a third of the points a neighbourhood of the others does: no
        // outlier.
        use rand::rngs::SmallRng;
        use rand::{RngExt, SeedableRng};
        let mut rng = SmallRng::seed_from_u64(17);
        let mut pts = Vec::new();
        let ys: Vec<f64> = (0..30)
            .map(|k| 2.5 * f64::from(k))
            .chain([90.0, 110.0])
            .collect();
        for &y in &ys {
            for k in 0..500 {
                let mut e = || 0.02 * (rng.random::<f64>() - 0.5) * 12f64.sqrt();
                pts.push([0.1 * f64::from(k), y + e(), e()]);
            }
        }
        let scale = unit_scale(0.02, 5.0);
        let local = LocalScale::uniform(pts.len(), scale);
        let grid = Grid::new(&pts, scale.radius).unwrap();
        let params = FeatureParams::default();
        let f = features(&pts, &grid, &local, &params, &Progress::hidden());
        // Near their ends a neighbourhood holds about half a line, and some of those points
        // are outliers: left out here.
        let lone: Vec<usize> = (0..pts.len())
            .filter(|&i| pts[i][1] > 80.0 && (6.0..44.0).contains(&pts[i][0]))
            .collect();
        assert!(lone.iter().all(|&i| !f.outlier[i]));
        // Without the rule most of them are candidates: their normals turn at random about
        // the line, and the split between them is large.
        let wild = lone
            .iter()
            .filter(|&&i| f.split[i] > f.split_threshold)
            .count();
        assert!(wild * 2 > lone.len(), "{wild} of {} split", lone.len());
        let flagged: Vec<usize> = lone.iter().copied().filter(|&i| f.candidate[i]).collect();
        assert!(flagged.is_empty(), "{} lone-line candidates", flagged.len());
        // Away from the patch's rim the lines 2.5 apart are a plane like any other.
        let inner = (0..pts.len())
            .filter(|&i| (10.0..62.0).contains(&pts[i][1]) && (10.0..40.0).contains(&pts[i][0]));
        assert!(inner.clone().count() > 5000);
        for i in inner {
            assert!(!f.candidate[i], "point {i} at {:?}", pts[i]);
            assert!(f.normal[i][2].abs() > 0.99, "{:?}", f.normal[i]);
        }
    }

    #[test]
    fn slots_to_ids_puts_each_slot_value_at_its_id() {
        let ids: Vec<u32> = vec![3, 0, 4, 1, 2];
        let v = vec![30, 0, 40, 10, 20];
        assert_eq!(slots_to_ids(v, &ids), vec![0, 10, 20, 30, 40]);
        assert!(slots_to_ids(Vec::<u8>::new(), &[]).is_empty());
        let lens = [2, 0, 3];
        let mut w = [1, 2, 3, 4, 5];
        let parts = split_by(&mut w, &lens);
        assert_eq!(parts.iter().map(|p| p.len()).collect::<Vec<_>>(), lens);
        assert_eq!(parts[2], [3, 4, 5]);
    }

    #[test]
    fn every_point_gets_the_plane_of_its_own_neighbourhood() {
        // The passes work in the grid's slot order and hand the arrays out by id: check a
        // spread of points against a brute-force plane fit of their own neighbours.
        let (pts, _) = dihedral(120.0, 1.0, 0.15, 12.0, 9);
        let scale = unit_scale(0.15, 3.0);
        let local = LocalScale::uniform(pts.len(), scale);
        // Cells narrower than the radius: the wider query path too.
        for cell in [3.0, 1.3] {
            let grid = Grid::new(&pts, cell).unwrap();
            let f = features(
                &pts,
                &grid,
                &local,
                &FeatureParams::default(),
                &Progress::hidden(),
            );
            for i in (0..pts.len()).step_by(97) {
                let mut m = [0.0f64; 10];
                for q in &pts {
                    let d = [0, 1, 2].map(|k| q[k] - pts[i][k]);
                    if d[0] * d[0] + d[1] * d[1] + d[2] * d[2] <= 9.0 {
                        add_moments(&mut m, d);
                    }
                }
                let p = pca_from_moments(&m).unwrap();
                assert_eq!(f.count[i], m[0].round() as u32, "point {i}");
                let cos: f64 = (0..3)
                    .map(|k| p.normal[k] * f64::from(f.normal[i][k]))
                    .sum();
                assert!(cos.abs() > 1.0 - 1e-5, "point {i}: normals at cos {cos}");
                let sharp = p.eigenvalues[0] / (0.15 * 0.15);
                assert!(
                    (f64::from(f.sharpness[i]) - sharp).abs() <= 1e-4 * sharp.max(1.0),
                    "point {i}: sharpness {} against {sharp}",
                    f.sharpness[i]
                );
            }
        }
    }
}
