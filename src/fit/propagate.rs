//! Line propagation (§2.1): from an end point A, grow a fitted line point by point towards the
//! corner while the points keep following it; stop at C when the tangent direction has changed
//! significantly. The same from the other end B gives D; the points between C and D are the
//! corner region, the accepted points on each side give the local fits L2 and L4.
//!
//! "Significantly" is measured against the noise level, not as an absolute angle: the tangent
//! has turned when the next `patience` points all leave the current line by more than
//! `tolerance` times their expected deviation, on the same side (a turn pushes consecutive
//! points to one side; noise does not). The expected deviation is σ widened by the current
//! line's own uncertainty at the point (the regression prediction interval), so a short,
//! still-uncertain starting line does not stop the propagation by mistake. The last points before the stop that already lean to that side by more than
//! `backoff` · σ are handed back to the corner region, since the turn starts before it is
//! detected. σ is given by the caller or estimated from the residuals of line fits to the far
//! halves of the sides (median absolute residual, scaled for a normal distribution).
//!
//! Inputs: points plus a visiting order (from the far end towards the corner). Outputs: how
//! many points of that order were accepted. [`propagate_polyline`] applies this to an ordered
//! polyline from both ends; the unordered 2D profile and the 3D vertex use the same primitive
//! per side (see `profile` and `corner`).

use std::ops::Range;

use serde::{Deserialize, Serialize};

use super::line::{Line, LineAcc, LineForm};
use crate::geometry::{dot, finite, norm, reject, sub};
use crate::{Error, Result};

/// Parameters of the line propagation.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct PropagationParams {
    /// A point leaves the line when its distance exceeds `tolerance` · σ.
    pub tolerance: f64,
    /// This many consecutive points must leave the line on the same side to stop.
    pub patience: usize,
    /// After stopping, trailing points leaning to the turn's side by more than `backoff` · σ
    /// go back to the corner region. 0 disables.
    pub backoff: f64,
    /// Fewest points of the starting line fit.
    pub init_points: usize,
    /// The starting line grows until its RMS length is this many times its RMS width.
    pub init_elongation: f64,
    /// Noise level σ (per coordinate, input units); estimated from the data when absent.
    pub noise: Option<f64>,
}

impl Default for PropagationParams {
    fn default() -> Self {
        PropagationParams {
            tolerance: 3.0,
            patience: 3,
            backoff: 1.0,
            init_points: 4,
            init_elongation: 4.0,
            noise: None,
        }
    }
}

/// Median of |residual| / σ for a residual with D − 1 normal components of deviation σ:
/// |N(0,1)| in 2D (0.6745), Rayleigh in 3D (√(2 ln 2) = 1.1774).
pub fn residual_median_factor(dim: usize) -> f64 {
    if dim == 2 {
        0.674_489_750_196_081_7
    } else {
        (2.0 * std::f64::consts::LN_2).sqrt()
    }
}

/// Appends the distances of the points `idx` to their own total-least-squares line to `out`.
/// Does nothing for fewer than 3 points.
pub fn line_residuals<const D: usize>(pts: &[[f64; D]], idx: &[usize], out: &mut Vec<f64>) {
    if idx.len() < 3 {
        return;
    }
    let mut acc = LineAcc::default();
    for &i in idx {
        acc.push(&pts[i]);
    }
    if let Some((_, l)) = acc.fit() {
        out.extend(idx.iter().map(|&i| l.distance(&pts[i])));
    }
}

/// σ from pooled residual distances (median / the factor for the dimension); `None` when
/// there are none. Reorders `res`.
pub fn noise_from_residuals<const D: usize>(res: &mut [f64]) -> Option<f64> {
    if res.is_empty() {
        return None;
    }
    let mid = res.len() / 2;
    let (_, &mut m, _) = res.select_nth_unstable_by(mid, f64::total_cmp);
    Some(m / residual_median_factor(D))
}

/// Grows a line along `order` (indices into `pts`, from the far end towards the corner) and
/// returns how many of its points are accepted before the tangent turns (all of them when it
/// never does). `sigma` is the noise level in the units of `pts`. `prior` is the side's
/// approximate direction (from a fit to many of its points); without it the first quarter of
/// the run is fitted for one.
pub fn propagate_run<const D: usize>(
    pts: &[[f64; D]],
    order: &[usize],
    sigma: f64,
    params: &PropagationParams,
    prior: Option<[f64; D]>,
) -> usize {
    let m = order.len();
    let init = params.init_points.max(2);
    if m <= init {
        return m;
    }
    let thr = params.tolerance * sigma;
    let prior = prior.and_then(crate::geometry::unit).or_else(|| {
        let mut acc = LineAcc::default();
        for &k in &order[..(m / 4).max(init)] {
            acc.push(&pts[k]);
        }
        acc.fit().map(|(_, l)| l.direction)
    });
    let Some(prior) = prior else {
        return m;
    };
    // The starting line: at least `init_points`, grown until the points are elongated enough
    // along the side's direction (RMS length >= `init_elongation` x RMS width) for a line fit
    // to mean something. With noise comparable to the spacing, the first few points are a
    // blob whose own principal axis can be anything, even across the side. Never more than
    // two thirds of the run.
    let cap = (2 * m / 3).max(init);
    let e2 = params.init_elongation * params.init_elongation;
    let mut acc = LineAcc::default();
    let mut i = 0;
    while i < m {
        acc.push(&pts[order[i]]);
        i += 1;
        if i < init {
            continue;
        }
        let s = acc.scatter();
        let along: f64 = (0..D).map(|a| prior[a] * dot(s[a], prior)).sum();
        let trace: f64 = (0..D).map(|a| s[a][a]).sum();
        if along >= e2 * (trace - along).max(0.0) || i >= cap {
            break;
        }
    }
    let mut dir = match acc.fit() {
        // The fitted axis, unless the points are still too blob-like to have turned it
        // reliably (more than 30° off the prior).
        Some((_, l)) if dot(l.direction, prior).abs() >= 0.866 => l.direction,
        _ => prior,
    };
    // Deviation of p from the current line, and the standard deviation expected for it:
    // noise plus the line's own uncertainty at p (the regression prediction interval,
    // σ² (1 + 1/m + τ² / Σ τ_i²) with τ the position along the line from the centroid).
    let test = |acc: &LineAcc<D>, dir: &[f64; D], p: &[f64; D]| {
        let c = acc.centroid();
        let v = sub(p, c);
        let tau = dot(v, dir);
        let s = acc.scatter();
        let stt: f64 = (0..D).map(|a| dir[a] * dot(s[a], dir)).sum();
        let m = acc.len() as f64;
        let spread = (1.0 + 1.0 / m + if stt > 0.0 { tau * tau / stt } else { 0.0 }).sqrt();
        (reject(v, dir), spread)
    };
    while i < m {
        let (r, spread) = test(&acc, &dir, &pts[order[i]]);
        if norm(r) > thr * spread {
            // A turn, or one noisy point? Look at the next points against the same line.
            let end = (i + params.patience.max(1)).min(m);
            let turned = (i + 1..end).all(|k| {
                let (rk, sk) = test(&acc, &dir, &pts[order[k]]);
                norm(rk) > thr * sk && dot(rk, r) > 0.0
            });
            if turned {
                let mut stop = i;
                if params.backoff > 0.0 {
                    while stop > init {
                        let (rb, _) = test(&acc, &dir, &pts[order[stop - 1]]);
                        if dot(rb, r) > 0.0 && norm(rb) > params.backoff * sigma {
                            stop -= 1;
                        } else {
                            break;
                        }
                    }
                }
                return stop;
            }
            // An isolated outlier: it stays on this side but does not steer the line.
            i += 1;
            continue;
        }
        acc.push(&pts[order[i]]);
        for _ in 0..2 {
            if let Some(d) = acc.power_step(&dir) {
                dir = d;
            }
        }
        i += 1;
    }
    m
}

/// Local (piecewise) fit of one side: the paper's L2 / L4, in the chosen form, refitted once
/// without the points farther than `trim` · σ from the first fit (0 = no trimming). `buf` is
/// scratch. Errors as [`super::line::fit_line`].
pub fn side_fit<const D: usize>(
    pts: &[[f64; D]],
    idx: &[usize],
    form: LineForm,
    trim: f64,
    sigma: f64,
    buf: &mut Vec<[f64; D]>,
) -> Result<Line<D>> {
    buf.clear();
    buf.extend(idx.iter().map(|&i| pts[i]));
    let line = super::line::fit_line_form(buf, form)?;
    if trim <= 0.0 || sigma.is_nan() || sigma <= 0.0 {
        return Ok(line);
    }
    let before = buf.len();
    buf.retain(|p| line.distance(p) <= trim * sigma);
    if buf.len() == before || buf.len() < 2 {
        return Ok(line);
    }
    super::line::fit_line_form(buf, form).or(Ok(line))
}

/// The result of propagating along an ordered polyline from both ends.
#[derive(Clone, Debug, PartialEq)]
pub struct PolylineSplit<const D: usize> {
    /// Side 1: points A..=C (indices), side 2: points D..=B.
    pub sides: [Range<usize>; 2],
    /// The corner region: the points strictly between C and D (empty when they are adjacent).
    pub corner: Range<usize>,
    /// Local fits of the two sides (L2, L4), directions pointing away from the corner.
    pub local: [Line<D>; 2],
    /// The noise level used.
    pub noise: f64,
}

/// Line propagation along an ordered polyline (points in order from end A to end B), from
/// both ends. If the two propagations cross (each ran past the other's stop), the points
/// accepted by both form the corner region.
///
/// Errors: non-finite points, fewer than `min_side_points` on a side, coincident points.
pub fn propagate_polyline<const D: usize>(
    pts: &[[f64; D]],
    params: &PropagationParams,
    form: LineForm,
    min_side_points: usize,
) -> Result<PolylineSplit<D>> {
    const WHAT: &str = "line propagation along a polyline";
    let min_side = min_side_points.max(2);
    let m = pts.len();
    if m < 2 * min_side {
        return Err(Error::TooFewPoints {
            what: WHAT,
            needed: 2 * min_side,
            got: m,
        });
    }
    if let Some(i) = pts.iter().position(|p| !finite(p)) {
        return Err(Error::Degenerate {
            what: WHAT,
            why: format!("point {i} has a non-finite coordinate; remove it first"),
        });
    }
    let sigma = match params.noise {
        Some(s) => s,
        None => {
            // The first and last quarter are the parts least likely to contain the corner.
            let w = (m / 4).max(params.init_points).max(3).min(m / 2);
            let mut res = Vec::with_capacity(2 * w);
            let head: Vec<usize> = (0..w).collect();
            let tail: Vec<usize> = (m - w..m).collect();
            line_residuals(pts, &head, &mut res);
            line_residuals(pts, &tail, &mut res);
            noise_from_residuals::<D>(&mut res).unwrap_or(0.0)
        }
    };
    let sigma = sigma.max(1e-12 * extent(pts));
    let fwd: Vec<usize> = (0..m).collect();
    let bwd: Vec<usize> = (0..m).rev().collect();
    let a = propagate_run(pts, &fwd, sigma, params, None);
    let b = propagate_run(pts, &bwd, sigma, params, None);
    // Side 1 is [0, a), side 2 is [m - b, m); overlapping acceptance goes to the corner.
    let (s1_end, s2_start) = if a <= m - b { (a, m - b) } else { (m - b, a) };
    if s1_end < min_side || m - s2_start < min_side {
        return Err(Error::TooFewPoints {
            what: "line propagation: points on a side of the polyline",
            needed: min_side,
            got: s1_end.min(m - s2_start),
        });
    }
    let mut buf = Vec::new();
    let idx1: Vec<usize> = (0..s1_end).collect();
    let idx2: Vec<usize> = (s2_start..m).collect();
    let l1 = side_fit(pts, &idx1, form, 0.0, sigma, &mut buf)?;
    let l2 = side_fit(pts, &idx2, form, 0.0, sigma, &mut buf)?;
    // Directions away from the corner: from the side's inner end towards its outer end.
    let l1 = l1.oriented(&sub(pts[0], pts[s1_end - 1]));
    let l2 = l2.oriented(&sub(pts[m - 1], pts[s2_start]));
    Ok(PolylineSplit {
        sides: [0..s1_end, s2_start..m],
        corner: s1_end..s2_start,
        local: [l1, l2],
        noise: sigma,
    })
}

/// Root-mean-square distance of the points from their centroid.
pub(crate) fn extent<const D: usize>(pts: &[[f64; D]]) -> f64 {
    if pts.is_empty() {
        return 0.0;
    }
    let n = pts.len() as f64;
    let c: [f64; D] = std::array::from_fn(|k| pts.iter().map(|p| p[k]).sum::<f64>() / n);
    (pts.iter()
        .map(|p| crate::geometry::norm2(sub(p, c)))
        .sum::<f64>()
        / n)
        .sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fit::ga::standard_normal;
    use rand::SeedableRng;
    use rand::rngs::SmallRng;

    /// A polyline along two segments meeting at `corner`, `n` points a side, noise `sigma`.
    fn vee(angle_deg: f64, n: usize, sigma: f64, seed: u64) -> (Vec<[f64; 2]>, [[f64; 2]; 2]) {
        let mut rng = SmallRng::seed_from_u64(seed);
        let corner = [10.0, 10.0];
        let h = angle_deg.to_radians() / 2.0;
        let d1 = [-h.sin(), -h.cos()];
        let d2 = [h.sin(), -h.cos()];
        let mut pts = Vec::new();
        let ts: Vec<f64> = (1..=n).map(|i| i as f64 * 0.25).collect();
        for (d, rev) in [(d1, true), (d2, false)] {
            let mut arm: Vec<[f64; 2]> = ts
                .iter()
                .map(|t| {
                    [
                        corner[0] + t * d[0] + sigma * standard_normal(&mut rng),
                        corner[1] + t * d[1] + sigma * standard_normal(&mut rng),
                    ]
                })
                .collect();
            if rev {
                arm.reverse();
            }
            pts.extend(arm);
        }
        (pts, [d1, d2])
    }

    #[test]
    fn propagation_stops_near_the_corner_of_a_clean_vee() {
        let (pts, _) = vee(90.0, 30, 0.0, 1);
        let s = propagate_polyline(&pts, &PropagationParams::default(), LineForm::Tls, 3).unwrap();
        // Noise-free: every point of each side is accepted, nothing else.
        assert_eq!(s.sides, [0..30, 30..60]);
        assert!(s.corner.is_empty());
        let (pts, _) = vee(90.0, 40, 0.02, 2);
        let s = propagate_polyline(&pts, &PropagationParams::default(), LineForm::Tls, 3).unwrap();
        assert!(
            s.sides[0].end >= 36 && s.sides[0].end <= 40,
            "{:?}",
            s.sides
        );
        assert!(
            s.sides[1].start >= 40 && s.sides[1].start <= 44,
            "{:?}",
            s.sides
        );
        assert!((s.noise - 0.02).abs() < 0.01, "noise {}", s.noise);
    }

    #[test]
    fn propagation_finds_an_obtuse_corner_in_noise() {
        // 150° profile: a 30° turn, noise 0.02 on a 0.25 spacing.
        let (pts, _) = vee(150.0, 40, 0.02, 3);
        let s = propagate_polyline(&pts, &PropagationParams::default(), LineForm::Tls, 3).unwrap();
        assert!(
            s.sides[0].end >= 33 && s.sides[0].end <= 41,
            "{:?}",
            s.sides
        );
        assert!(
            s.sides[1].start >= 39 && s.sides[1].start <= 47,
            "{:?}",
            s.sides
        );
        // Local fits follow the true directions within a degree, pointing away from the corner.
        let (pts2, dirs) = vee(150.0, 40, 0.02, 3);
        assert_eq!(pts, pts2);
        for (l, d) in s.local.iter().zip(dirs) {
            let c = l.direction[0] * d[1] - l.direction[1] * d[0];
            assert!(
                c.abs() < 0.02 && dot(l.direction, d) > 0.0,
                "{:?} vs {d:?}",
                l.direction
            );
        }
    }

    #[test]
    fn a_straight_polyline_has_no_corner_and_reports_a_clear_error_when_too_short() {
        let line: Vec<[f64; 3]> = (0..5).map(|i| [i as f64, 0.0, 0.0]).collect();
        let e = propagate_polyline(&line, &PropagationParams::default(), LineForm::Tls, 3)
            .unwrap_err()
            .to_string();
        assert!(e.contains("needs at least 6 points, got 5"), "{e}");
    }

    #[test]
    fn a_bent_3d_polyline_splits_at_its_bend() {
        // 30 points along x, then 30 along a direction 100° away, noise 0.01 on a 0.2 spacing.
        let mut rng = SmallRng::seed_from_u64(4);
        let d2 = [-(10f64.to_radians().sin()), 0.6, 0.8];
        let n2 = norm(d2);
        let mut pts: Vec<[f64; 3]> = Vec::new();
        for i in (1..=30).rev() {
            let t = 0.2 * i as f64;
            pts.push(std::array::from_fn(|k| {
                [1.0 + t, 2.0, 3.0][k] + 0.01 * standard_normal(&mut rng)
            }));
        }
        for i in 1..=30 {
            let t = 0.2 * i as f64;
            pts.push(std::array::from_fn(|k| {
                [1.0, 2.0, 3.0][k] + t * d2[k] / n2 + 0.01 * standard_normal(&mut rng)
            }));
        }
        let s = propagate_polyline(&pts, &PropagationParams::default(), LineForm::Tls, 3).unwrap();
        assert!((28..=31).contains(&s.sides[0].end), "{:?}", s.sides);
        assert!((29..=32).contains(&s.sides[1].start), "{:?}", s.sides);
        assert!(
            s.local[0].direction[0] > 0.999,
            "{:?}",
            s.local[0].direction
        );
        let paper =
            propagate_polyline(&pts, &PropagationParams::default(), LineForm::Paper, 3).unwrap();
        assert_eq!(paper.sides, s.sides);
    }

    #[test]
    fn an_isolated_outlier_does_not_stop_propagation() {
        let mut pts: Vec<[f64; 2]> = (0..30).map(|i| [i as f64, 0.0]).collect();
        pts[10][1] = 5.0;
        let order: Vec<usize> = (0..30).collect();
        assert_eq!(
            propagate_run(&pts, &order, 0.01, &PropagationParams::default(), None),
            30
        );
        // A genuine turn stops it right before the turn.
        let mut bent: Vec<[f64; 2]> = (0..20).map(|i| [i as f64, 0.0]).collect();
        bent.extend((1..10).map(|i| [19.0 + i as f64, i as f64]));
        let order: Vec<usize> = (0..bent.len()).collect();
        assert_eq!(
            propagate_run(&bent, &order, 0.01, &PropagationParams::default(), None),
            20
        );
    }
}
