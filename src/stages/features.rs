//! Per-point local shape: noise level, neighbourhood scale, PCA normal, sharpness score and the
//! candidate edge points.
//!
//! Inputs: positions, the cloud's mean spacing, `FeatureParams`. Outputs: `Scale` (spacing,
//! estimated noise sigma, neighbourhood radius) and `Features` (side arrays by point id).
//!
//! Why these scores: surface variation λ0/(λ0+λ1+λ2) at a fixed k is swamped by noise once
//! sigma approaches the spacing (CRATES.md: best F1 0.34 at k = 16). Here the noise sigma is
//! measured from the data first (the median out-of-plane spread of neighbourhoods, almost all
//! on faces), and the neighbourhood radius is made several sigmas wide. Two scores follow:
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
//! noise statistics and angles (relative to the cloud's own median), not per-scan tuning.

use rayon::prelude::*;

use crate::geometry::eigen3;

use crate::error::{Error, Result};
use crate::neighbours::{Block, Grid};
use crate::progress::Progress;

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

impl Default for FeatureParams {
    fn default() -> Self {
        FeatureParams {
            radius: None,
            noise: None,
            min_radius: 4.0,
            noise_radius: 6.0,
            threshold: 3.0,
            split_threshold: 0.008,
            split_noise_factor: 15.0,
            outlier_share: 0.2,
        }
    }
}

/// The length scales of a scan, measured or given.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct Scale {
    /// Mean distance to the nearest distinct neighbour.
    pub spacing: f64,
    /// Noise sigma perpendicular to the surface.
    pub noise: f64,
    /// Neighbourhood radius used for the features.
    pub radius: f64,
}

/// Per-point outputs of the features stage, indexed by point id.
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

/// Covariance summary of one neighbourhood.
#[derive(Debug, Clone, Copy)]
pub struct LocalPca {
    pub count: u32,
    /// Eigenvalues ascending.
    pub eigenvalues: [f64; 3],
    /// Unit eigenvector of the smallest eigenvalue: the normal of the best plane.
    pub normal: [f64; 3],
    /// Centroid offset from the query point.
    pub centroid: [f64; 3],
}

/// PCA of the points within `r` of `q`. `None` with fewer than 3 neighbours.
pub fn local_pca(grid: &Grid, q: [f64; 3], r: f64) -> Option<LocalPca> {
    let mut m = [0.0f64; 10];
    grid.for_each_within(q, r, |_, d, _| add_moments(&mut m, d));
    pca_from_moments(&m)
}

/// Adds an offset to the raw moments [n, Σx, Σy, Σz, Σxx, Σxy, Σxz, Σyy, Σyz, Σzz].
#[inline]
pub fn add_moments(m: &mut [f64; 10], d: [f64; 3]) {
    m[0] += 1.0;
    m[1] += d[0];
    m[2] += d[1];
    m[3] += d[2];
    m[4] += d[0] * d[0];
    m[5] += d[0] * d[1];
    m[6] += d[0] * d[2];
    m[7] += d[1] * d[1];
    m[8] += d[1] * d[2];
    m[9] += d[2] * d[2];
}

/// Cells per unit of parallel work: a few thousand points.
const BLOCK_CHUNK: usize = 256;

/// PCA from raw moments [n, Σx, Σy, Σz, Σxx, Σxy, Σxz, Σyy, Σyz, Σzz] (offsets from the query,
/// so the subtraction of the mean loses no precision at georeferenced magnitudes).
pub fn pca_from_moments(m: &[f64; 10]) -> Option<LocalPca> {
    let n = m[0];
    if n < 3.0 {
        return None;
    }
    let c = [m[1] / n, m[2] / n, m[3] / n];
    let cov = [
        m[4] / n - c[0] * c[0],
        m[5] / n - c[0] * c[1],
        m[6] / n - c[0] * c[2],
        m[7] / n - c[1] * c[1],
        m[8] / n - c[1] * c[2],
        m[9] / n - c[2] * c[2],
    ];
    let (values, normal) = eigen3::smallest(&cov)?;
    Some(LocalPca {
        count: n as u32,
        eigenvalues: values.map(|v| v.max(0.0)),
        normal,
        centroid: c,
    })
}

/// Measures the noise sigma and chooses the neighbourhood radius (see the module comment).
/// `spacing` is the cloud's mean spacing. Uses an evenly spread subsample of at most
/// `max_samples` points.
pub fn estimate_scale(
    positions: &[[f64; 3]],
    spacing: f64,
    params: &FeatureParams,
    max_samples: usize,
) -> Result<Scale> {
    if !(spacing.is_finite() && spacing > 0.0) {
        return Err(Error::Degenerate {
            what: "scale estimate",
            why: format!("mean spacing must be positive, got {spacing}"),
        });
    }
    let noise = match params.noise {
        Some(s) => s,
        None => {
            // Two passes: the first radius only needs to see a plane; the second is the
            // working radius, where the estimate has more points.
            let r0 = params.min_radius * spacing;
            let s0 = noise_at(positions, r0, max_samples)?;
            let r1 = (params.noise_radius * s0).max(r0);
            if r1 > r0 * 1.05 {
                noise_at(positions, r1, max_samples)?
            } else {
                s0
            }
        }
    };
    let radius = params
        .radius
        .unwrap_or_else(|| (params.min_radius * spacing).max(params.noise_radius * noise));
    Ok(Scale {
        spacing,
        noise,
        radius,
    })
}

/// Median out-of-plane sigma of radius-`r` neighbourhoods over a subsample.
fn noise_at(positions: &[[f64; 3]], r: f64, max_samples: usize) -> Result<f64> {
    let grid = Grid::new(positions, r)?;
    let step = positions.len().div_ceil(max_samples.max(1));
    let mut vars: Vec<f64> = (0..positions.len())
        .into_par_iter()
        .step_by(step)
        .filter_map(|i| {
            let pca = local_pca(&grid, positions[i], r)?;
            // n/(n-3): the plane's three parameters were fitted to the same points.
            (pca.count >= 8).then(|| {
                let n = f64::from(pca.count);
                pca.eigenvalues[0] * n / (n - 3.0)
            })
        })
        .collect();
    if vars.is_empty() {
        return Err(Error::Degenerate {
            what: "noise estimate",
            why: format!(
                "no point has 8 neighbours within {r:.4}; the cloud is too sparse for its spacing"
            ),
        });
    }
    let mid = vars.len() / 2;
    let (_, median, _) = vars.select_nth_unstable_by(mid, f64::total_cmp);
    Ok(median.sqrt())
}

/// Computes the per-point features with the neighbourhood radius of `scale`. `grid` must have
/// cells at least `scale.radius` wide.
pub fn features(
    positions: &[[f64; 3]],
    grid: &Grid,
    scale: &Scale,
    params: &FeatureParams,
    progress: &Progress,
) -> Features {
    let n = positions.len();
    let r = scale.radius;
    // Noise floor: never divide by less than a millionth of the spacing squared, so a
    // noise-free synthetic scan still gets finite scores.
    let var = (scale.noise * scale.noise).max(1e-6 * scale.spacing * scale.spacing);
    // Work cell by cell, in the grid's spatial order (cache locality, and the 27 cells around
    // a cell found once for all its points); write back by id.
    let blocks = grid.blocks();
    let chunk = BLOCK_CHUNK;

    // Pass 1: plane fit of each neighbourhood.
    let mut normal = vec![[0.0f32; 3]; n];
    let mut sharpness = vec![0.0f32; n];
    let mut variation = vec![0.0f32; n];
    let mut count = vec![0u32; n];
    let pass1: Vec<(u32, [f32; 3], f32, f32, u32)> = blocks
        .par_chunks(chunk)
        .flat_map_iter(|blocks| {
            let mut rows = Vec::new();
            for block in blocks {
                for &i in grid.slot_ids(block.slots.clone()) {
                    let q = positions[i as usize];
                    let mut m = [0.0f64; 10];
                    grid.for_each_within_block(block, q, r, |_, d, _| add_moments(&mut m, d));
                    rows.push(match pca_from_moments(&m) {
                        Some(p) => {
                            let sum = p.eigenvalues.iter().sum::<f64>();
                            let v = if sum > 0.0 {
                                p.eigenvalues[0] / sum
                            } else {
                                0.0
                            };
                            let nrm = p.normal.map(|c| c as f32);
                            (i, nrm, (p.eigenvalues[0] / var) as f32, v as f32, p.count)
                        }
                        None => (i, [0.0; 3], 0.0, 0.0, 1),
                    });
                }
            }
            progress.inc(rows.len() as u64 / 2);
            rows.into_iter()
        })
        .collect();
    for (i, nrm, s, v, c) in pass1 {
        let i = i as usize;
        (normal[i], sharpness[i], variation[i], count[i]) = (nrm, s, v, c);
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
    let pass2: Vec<(u32, f32, [f32; 3], f32)> = blocks
        .par_chunks(chunk)
        .flat_map_iter(|blocks| {
            let mut rows = Vec::new();
            for block in blocks {
                for &i in grid.slot_ids(block.slots.clone()) {
                    let (t, d) = normal_tensor(grid, block, &normal, positions[i as usize], r);
                    rows.push((i, t[1] as f32, d.map(|c| c as f32), t[0] as f32));
                }
            }
            progress.inc(rows.len() as u64 - rows.len() as u64 / 2);
            rows.into_iter()
        })
        .collect();
    for (i, s, d, c) in pass2 {
        let i = i as usize;
        (split[i], direction[i], corner[i]) = (s, d, c);
    }

    // Thresholds from the cloud's own statistics (medians: faces are the majority).
    let median_count = median_u32(&count);
    let min_count = ((params.outlier_share * f64::from(median_count)).ceil() as u32).max(4);
    let split_floor = median_f32(&split);
    let split_threshold = params
        .split_threshold
        .max(params.split_noise_factor * f64::from(split_floor)) as f32;
    let plane_threshold = params.threshold as f32;
    let outlier: Vec<bool> = count.iter().map(|&c| c < min_count).collect();
    let candidate: Vec<bool> = (0..n)
        .map(|i| !outlier[i] && (split[i] > split_threshold || sharpness[i] > plane_threshold))
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
fn normal_tensor(
    grid: &Grid,
    block: &Block,
    normal: &[[f32; 3]],
    q: [f64; 3],
    r: f64,
) -> ([f64; 3], [f64; 3]) {
    let mut t = [0.0f64; 6];
    let mut c = 0.0f64;
    grid.for_each_within_block(block, q, r, |j, _, _| {
        let m = normal[j as usize].map(f64::from);
        t[0] += m[0] * m[0];
        t[1] += m[0] * m[1];
        t[2] += m[0] * m[2];
        t[3] += m[1] * m[1];
        t[4] += m[1] * m[2];
        t[5] += m[2] * m[2];
        c += 1.0;
    });
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

    #[test]
    fn noise_estimate_recovers_sigma() {
        for sigma in [0.05, 0.15, 0.5, 1.0] {
            let (pts, _) = dihedral(90.0, 1.0, sigma, 30.0, 3);
            let scale = estimate_scale(&pts, 1.0, &FeatureParams::default(), 20_000).unwrap();
            let rel = (scale.noise - sigma).abs() / sigma;
            assert!(rel < 0.15, "sigma {sigma}: estimated {}", scale.noise);
            assert!(scale.radius >= 4.0 && scale.radius >= 6.0 * scale.noise * 0.999);
        }
    }

    #[test]
    fn candidates_form_a_band_around_the_edge_and_nothing_else() {
        for (angle, sigma) in [(90.0, 0.15), (30.0, 0.15), (150.0, 0.15), (90.0, 1.0)] {
            let (pts, dist) = dihedral(angle, 1.0, sigma, 25.0, 5);
            let params = FeatureParams::default();
            let scale = estimate_scale(&pts, 1.0, &params, 20_000).unwrap();
            let grid = Grid::new(&pts, scale.radius).unwrap();
            let f = features(&pts, &grid, &scale, &params, &Progress::hidden());
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
        let scale = Scale {
            spacing: 1.0,
            noise: 0.0,
            radius: 4.0,
        };
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
        let scale = estimate_scale(&pts, 1.0, &params, 20_000).unwrap();
        let grid = Grid::new(&pts, scale.radius).unwrap();
        let f = features(&pts, &grid, &scale, &params, &Progress::hidden());
        let last = pts.len() - 1;
        assert!(f.outlier[last] && !f.candidate[last]);
    }

    #[test]
    fn pca_needs_three_points() {
        let mut m = [0.0; 10];
        m[0] = 2.0;
        assert!(pca_from_moments(&m).is_none());
    }
}
