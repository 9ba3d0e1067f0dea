//! The exact minimum of the fixed-slope objective — the certificate for the searchers.
//!
//! With the slopes fixed the error is convex in the corner q (DESIGN.md, "Beyond the paper"):
//! - 2D, two lines: error = Σ |n1·p − u| + Σ |n2·p − v| with (u, v) = (n1·q, n2·q), so the
//!   minimum is u = median(n1·p over side 1), v = median(n2·p over side 2), and q solves the
//!   2x2 system [n1; n2] q = (u, v). With an even count any value between the two middle
//!   values is optimal; the midpoint is taken.
//! - 2D, k ≥ 3 lines: a least-absolute-deviations problem in two unknowns; it is solved
//!   exactly by descending along the edges of its piecewise-linear graph (each step an exact
//!   weighted-median line search, as in Barrodale & Roberts' simplex method for L1 fitting).
//! - 3D: a sum of Euclidean norms of projections, minimised by the Weiszfeld iteration
//!   generalised to lines (iteratively reweighted least squares, each step the minimum of a
//!   quadratic majoriser, so the error never increases), accelerated by safeguarded Newton
//!   steps, and stopped when the step falls below a tolerance. The usual guard applies when an
//!   iterate lands on a data line (a zero residual): its weight is capped at 1/ε.
//!
//! Inputs: a [`FixedSlopes2`] / [`FixedSlopes3`]. Outputs: the minimiser and its error, or an
//! error value for parallel lines (no unique corner).

use serde::{Deserialize, Serialize};

use super::objective::{FixedSlopes2, FixedSlopes3, Objective};
use crate::geometry::{dot, norm, solve2, solve3};
use crate::{Error, Result};

/// Tolerances of the iterative exact solvers.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ExactParams {
    /// Stop when a step moves q by less than this, relative to the scale of the problem (the
    /// solvers run in a frame where the corner region has unit size).
    pub tolerance: f64,
    /// Iteration cap of the 3D solver.
    pub max_iterations: usize,
}

impl Default for ExactParams {
    fn default() -> Self {
        ExactParams {
            tolerance: 1e-12,
            max_iterations: 200,
        }
    }
}

/// Result of an exact solve.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Exact<const D: usize> {
    pub point: [f64; D],
    pub error: f64,
    /// Iterations used (1 for the closed-form two-line 2D case).
    pub iterations: usize,
}

fn parallel(what: &'static str) -> Error {
    Error::Degenerate {
        what,
        why: "the side lines are parallel, so they have no unique common point; \
              this is a straight run, not a corner"
            .into(),
    }
}

/// Median of `v` (midpoint of the two middle values for an even count); reorders `v`.
fn median(v: &mut [f64]) -> f64 {
    let n = v.len();
    let mid = n / 2;
    let (_, &mut hi, _) = v.select_nth_unstable_by(mid, f64::total_cmp);
    if n % 2 == 1 {
        hi
    } else {
        let lo = v[..mid].iter().copied().fold(f64::NEG_INFINITY, f64::max);
        0.5 * (lo + hi)
    }
}

/// The exact minimiser of a 2D fixed-slope objective. `scratch` is reused between calls.
pub fn exact_2d(obj: &FixedSlopes2, scratch: &mut Vec<f64>) -> Result<Exact<2>> {
    const WHAT: &str = "exact 2D corner";
    let k = obj.lines();
    if k < 2 {
        return Err(Error::TooFewPoints {
            what: "exact 2D corner (lines)",
            needed: 2,
            got: k,
        });
    }
    for j in 0..k {
        if obj.values(j).is_empty() {
            return Err(Error::Degenerate {
                what: WHAT,
                why: format!("line {j} has no points"),
            });
        }
    }
    if k == 2 {
        scratch.clear();
        scratch.extend_from_slice(obj.values(0));
        let u = median(scratch);
        scratch.clear();
        scratch.extend_from_slice(obj.values(1));
        let v = median(scratch);
        let q = solve2(obj.normal(0), obj.normal(1), [u, v]).ok_or_else(|| parallel(WHAT))?;
        return Ok(Exact {
            point: q,
            error: obj.error(&q),
            iterations: 1,
        });
    }
    lad_2d(obj, scratch)
}

/// Weighted median of breakpoints along a direction: minimises Σ w_i |b_i − t|.
fn weighted_median(pairs: &mut [(f64, f64)]) -> f64 {
    pairs.sort_by(|a, b| a.0.total_cmp(&b.0));
    let total: f64 = pairs.iter().map(|p| p.1).sum();
    let mut acc = 0.0;
    for &(b, w) in pairs.iter() {
        acc += w;
        if acc >= 0.5 * total {
            return b;
        }
    }
    pairs.last().map_or(0.0, |p| p.0)
}

/// Exact LAD minimum for k ≥ 3 lines in 2D by edge descent from a vertex.
fn lad_2d(obj: &FixedSlopes2, _scratch: &mut [f64]) -> Result<Exact<2>> {
    const WHAT: &str = "exact 2D corner";
    let k = obj.lines();
    // Each term: |a_i − n_j·q|. Flatten (normal, value) pairs once.
    let terms: Vec<([f64; 2], f64)> = (0..k)
        .flat_map(|j| obj.values(j).iter().map(move |&a| (obj.normal(j), a)))
        .collect();
    let span = {
        let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
        for t in &terms {
            lo = lo.min(t.1);
            hi = hi.max(t.1);
        }
        (hi - lo).max(1e-300)
    };
    // The lines must not all be parallel.
    let n0 = obj.normal(0);
    if !(1..k).any(|j| (n0[0] * obj.normal(j)[1] - n0[1] * obj.normal(j)[0]).abs() > 1e-9) {
        return Err(parallel(WHAT));
    }
    let tol = 1e-12 * span;
    let mut pairs: Vec<(f64, f64)> = Vec::with_capacity(terms.len());
    let line_search = |q: &[f64; 2], d: &[f64; 2], pairs: &mut Vec<(f64, f64)>| -> [f64; 2] {
        pairs.clear();
        for (n, a) in &terms {
            let nd = dot(n, d);
            if nd.abs() > 1e-15 {
                pairs.push(((a - dot(n, q)) / nd, nd.abs()));
            }
        }
        let t = weighted_median(pairs);
        [q[0] + t * d[0], q[1] + t * d[1]]
    };
    // Start: the least-squares corner of the first two non-parallel lines' medians would do;
    // any start works, so begin at the origin and walk to a vertex.
    let mut q = [0.0, 0.0];
    q = line_search(&q, &[1.0, 0.0], &mut pairs);
    let mut f = obj.error(&q);
    let mut iterations = 1;
    for _ in 0..(4 * terms.len() + 16) {
        iterations += 1;
        // Active terms (zero residual) define the candidate edge directions.
        let mut best: Option<(f64, [f64; 2])> = None;
        for (n, a) in &terms {
            if (a - dot(n, q)).abs() > tol {
                continue;
            }
            for s in [1.0, -1.0] {
                let d = [-n[1] * s, n[0] * s];
                // Directional derivative of Σ|a_i − n_i·q| along d.
                let mut g = 0.0;
                for (m, b) in &terms {
                    let r = b - dot(m, q);
                    let md = dot(m, d);
                    g += if r.abs() <= tol {
                        md.abs()
                    } else {
                        -r.signum() * md
                    };
                }
                if best.is_none_or(|(bg, _)| g < bg) {
                    best = Some((g, d));
                }
            }
        }
        let d = match best {
            Some((g, d)) if g < -1e-12 * terms.len() as f64 => d,
            Some(_) => break,
            // No active term (only after a degenerate start): descend along an axis.
            None => [0.0, 1.0],
        };
        let next = line_search(&q, &d, &mut pairs);
        let fn_ = obj.error(&next);
        if fn_ >= f - 1e-15 * f.abs() && best.is_some() {
            break;
        }
        q = next;
        f = fn_;
    }
    Ok(Exact {
        point: q,
        error: f,
        iterations,
    })
}

/// The exact minimiser of a 3D fixed-slope objective (Weiszfeld / IRLS with Newton
/// acceleration). `scale` is the size of the problem (the corner region's extent in the
/// objective's frame); tolerances are relative to it.
pub fn exact_3d(obj: &FixedSlopes3, scale: f64, params: &ExactParams) -> Result<Exact<3>> {
    const WHAT: &str = "exact 3D corner";
    let k = obj.lines();
    if k < 2 {
        return Err(Error::TooFewPoints {
            what: "exact 3D corner (lines)",
            needed: 2,
            got: k,
        });
    }
    let scale = if scale > 0.0 && scale.is_finite() {
        scale
    } else {
        1.0
    };
    let eps = 1e-12 * scale;

    // One pass: residuals at q, error, and the IRLS / Newton systems.
    struct Pass {
        f: f64,
        grad: [f64; 3],
        hess: [[f64; 3]; 3],
        irls_m: [[f64; 3]; 3],
        irls_b: [f64; 3],
    }
    let pass = |q: &[f64; 3], want_systems: bool| -> Pass {
        let mut p = Pass {
            f: 0.0,
            grad: [0.0; 3],
            hess: [[0.0; 3]; 3],
            irls_m: [[0.0; 3]; 3],
            irls_b: [0.0; 3],
        };
        for j in 0..k {
            let (e1, e2) = &obj.bases[j];
            let bx = dot(e1, q);
            let by = dot(e2, q);
            // Per-line sums in the 2D normal-plane coordinates, lifted to 3D at the end.
            let (mut w_sum, mut wx, mut wy) = (0.0, 0.0, 0.0);
            let (mut gx, mut gy) = (0.0, 0.0);
            let (mut hxx, mut hxy, mut hyy) = (0.0, 0.0, 0.0);
            for i in obj.starts[j]..obj.starts[j + 1] {
                let dx = obj.ax[i] - bx;
                let dy = obj.ay[i] - by;
                let r = (dx * dx + dy * dy).sqrt();
                p.f += r;
                if !want_systems {
                    continue;
                }
                let rr = r.max(eps);
                let w = 1.0 / rr;
                w_sum += w;
                wx += w * obj.ax[i];
                wy += w * obj.ay[i];
                // d r / d b = −(dx, dy)/r; the gradient in q is E^T of it.
                gx -= dx * w;
                gy -= dy * w;
                // Hessian of r in b: (I − ρ̂ρ̂ᵀ)/r = ρ̂⊥ρ̂⊥ᵀ / r.
                let (ux, uy) = (-dy / rr, dx / rr);
                hxx += ux * ux * w;
                hxy += ux * uy * w;
                hyy += uy * uy * w;
            }
            if !want_systems {
                continue;
            }
            for a in 0..3 {
                p.grad[a] += e1[a] * gx + e2[a] * gy;
                p.irls_b[a] += e1[a] * wx + e2[a] * wy;
                for b in 0..3 {
                    let pab = e1[a] * e1[b] + e2[a] * e2[b];
                    p.irls_m[a][b] += w_sum * pab;
                    p.hess[a][b] += hxx * e1[a] * e1[b]
                        + hxy * (e1[a] * e2[b] + e2[a] * e1[b])
                        + hyy * e2[a] * e2[b];
                }
            }
        }
        p
    };

    // Start at the unweighted least-squares corner (the first Weiszfeld step from w = 1).
    let mut m = [[0.0; 3]; 3];
    let mut b = [0.0; 3];
    for j in 0..k {
        let (e1, e2) = &obj.bases[j];
        let cnt = (obj.starts[j + 1] - obj.starts[j]) as f64;
        let sx: f64 = obj.ax[obj.starts[j]..obj.starts[j + 1]].iter().sum();
        let sy: f64 = obj.ay[obj.starts[j]..obj.starts[j + 1]].iter().sum();
        for a in 0..3 {
            b[a] += e1[a] * sx + e2[a] * sy;
            for c in 0..3 {
                m[a][c] += cnt * (e1[a] * e1[c] + e2[a] * e2[c]);
            }
        }
    }
    let mut q = solve3(&m, &b).ok_or_else(|| parallel(WHAT))?;
    let mut cur = pass(&q, true);
    let mut iterations = 0;
    while iterations < params.max_iterations {
        iterations += 1;
        // Newton step, accepted only if it lowers the error; otherwise the Weiszfeld step,
        // which never raises it.
        let mut next: Option<([f64; 3], Pass)> = None;
        if let Some(step) = solve3(&cur.hess, &cur.grad) {
            let mut t = 1.0;
            for _ in 0..4 {
                let cand = [q[0] - t * step[0], q[1] - t * step[1], q[2] - t * step[2]];
                let f = pass(&cand, false).f;
                if f < cur.f {
                    next = Some((cand, pass(&cand, true)));
                    break;
                }
                t *= 0.5;
            }
        }
        let (cand, np) = match next {
            Some(x) => x,
            None => {
                let Some(w) = solve3(&cur.irls_m, &cur.irls_b) else {
                    return Err(parallel(WHAT));
                };
                let np = pass(&w, true);
                if np.f > cur.f {
                    // Only possible through the ε guard; the current point is optimal to it.
                    break;
                }
                (w, np)
            }
        };
        let moved = norm([cand[0] - q[0], cand[1] - q[1], cand[2] - q[2]]);
        q = cand;
        cur = np;
        if moved <= params.tolerance * scale {
            break;
        }
    }
    if !cur.f.is_finite() || !q.iter().all(|x| x.is_finite()) {
        return Err(Error::Degenerate {
            what: WHAT,
            why: "the iteration did not stay finite; the side lines are nearly parallel".into(),
        });
    }
    Ok(Exact {
        point: q,
        error: cur.f,
        iterations,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fit::objective::FixedSlopes;
    use crate::geometry::unit;
    use rand::rngs::SmallRng;
    use rand::{RngExt, SeedableRng};

    fn random_2d(k: usize, seed: u64) -> FixedSlopes2 {
        let mut rng = SmallRng::seed_from_u64(seed);
        let mut obj = FixedSlopes2::default();
        for j in 0..k {
            let ang = j as f64 * std::f64::consts::PI / k as f64 + 0.3 * rng.random::<f64>();
            let d = [ang.cos(), ang.sin()];
            let n = 5 + (rng.random::<f64>() * 20.0) as usize;
            let pts: Vec<[f64; 2]> = (0..n)
                .map(|i| {
                    let t = 0.3 * i as f64 + 0.1;
                    let e = rng.random::<f64>() - 0.5;
                    [1.0 + t * d[0] - e * d[1], 2.0 + t * d[1] + e * d[0]]
                })
                .collect();
            obj.add_line(&d, &pts);
        }
        obj
    }

    /// Dense grid search refined twice around its best cell.
    fn brute<const D: usize, O: Objective<D>>(obj: &O, centre: [f64; D], half: f64) -> f64 {
        let mut c = centre;
        let mut h = half;
        let mut best = obj.error(&c);
        for _ in 0..12 {
            let steps = if D == 2 { 40 } else { 14 };
            let mut bc = c;
            let mut idx = [0usize; D];
            loop {
                let q: [f64; D] =
                    std::array::from_fn(|k| c[k] - h + 2.0 * h * idx[k] as f64 / steps as f64);
                let e = obj.error(&q);
                if e < best {
                    best = e;
                    bc = q;
                }
                let mut k = 0;
                while k < D {
                    idx[k] += 1;
                    if idx[k] <= steps {
                        break;
                    }
                    idx[k] = 0;
                    k += 1;
                }
                if k == D {
                    break;
                }
            }
            c = bc;
            h *= 4.0 / steps as f64;
        }
        best
    }

    #[test]
    fn two_line_medians_are_the_brute_force_minimum() {
        let mut scratch = Vec::new();
        for seed in 0..30 {
            let obj = random_2d(2, seed);
            let ex = exact_2d(&obj, &mut scratch).unwrap();
            let b = brute(&obj, ex.point, 3.0);
            assert!(
                ex.error <= b + 1e-9,
                "seed {seed}: exact {} > brute {b}",
                ex.error
            );
            // The general LAD path agrees with the medians.
            let lad = lad_2d(&obj, &mut scratch).unwrap();
            assert!(
                (lad.error - ex.error).abs() < 1e-9 * ex.error,
                "seed {seed}"
            );
        }
    }

    #[test]
    fn lad_is_exact_for_three_and_four_lines() {
        let mut scratch = Vec::new();
        for k in [3, 4] {
            for seed in 0..20 {
                let obj = random_2d(k, 100 + seed);
                let ex = exact_2d(&obj, &mut scratch).unwrap();
                let b = brute(&obj, ex.point, 3.0);
                assert!(
                    ex.error <= b + 1e-9,
                    "k {k} seed {seed}: {} > {b}",
                    ex.error
                );
            }
        }
    }

    #[test]
    fn weiszfeld_newton_is_the_brute_force_minimum() {
        for seed in 0..20 {
            let mut rng = SmallRng::seed_from_u64(seed);
            let mut obj = FixedSlopes3::default();
            let k = 2 + (seed % 3) as usize;
            for _ in 0..k {
                let d = unit([
                    rng.random::<f64>() - 0.5,
                    rng.random::<f64>() - 0.5,
                    rng.random::<f64>() - 0.5,
                ])
                .unwrap();
                let pts: Vec<[f64; 3]> = (0..30)
                    .map(|i| {
                        let t = 0.2 * i as f64;
                        std::array::from_fn(|a| {
                            [1.0, -1.0, 0.5][a] + t * d[a] + 0.1 * (rng.random::<f64>() - 0.5)
                        })
                    })
                    .collect();
                obj.add_line(&d, &pts);
            }
            let ex = exact_3d(&obj, 1.0, &ExactParams::default()).unwrap();
            let b = brute(&obj, ex.point, 1.0);
            assert!(
                ex.error <= b + 1e-9,
                "seed {seed}: exact {} > brute {b}",
                ex.error
            );
            assert!(
                ex.iterations < 60,
                "seed {seed}: {} iterations",
                ex.iterations
            );
        }
    }

    #[test]
    fn noise_free_lines_put_the_exact_corner_on_the_true_one() {
        // Every residual is zero at the optimum: the guard must keep the iteration finite.
        let mut obj = FixedSlopes3::default();
        let c = [2.0, 3.0, -1.0];
        for d in [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]] {
            let pts: Vec<[f64; 3]> = (1..20)
                .map(|i| std::array::from_fn(|a| c[a] + 0.1 * i as f64 * d[a]))
                .collect();
            obj.add_line(&d, &pts);
        }
        let ex = exact_3d(&obj, 1.0, &ExactParams::default()).unwrap();
        assert!(norm([ex.point[0] - 2.0, ex.point[1] - 3.0, ex.point[2] + 1.0]) < 1e-9);
        assert!(ex.error < 1e-8);
    }

    #[test]
    fn parallel_lines_are_an_error() {
        let mut obj = FixedSlopes2::default();
        obj.add_line(&[1.0, 0.0], &[[0.0, 0.0], [1.0, 0.0]]);
        obj.add_line(&[-1.0, 0.0], &[[0.0, 1.0], [1.0, 1.0]]);
        let e = exact_2d(&obj, &mut Vec::new()).unwrap_err().to_string();
        assert!(e.contains("parallel"), "{e}");
        let mut o3 = FixedSlopes3::default();
        o3.add_line(&[0.0, 0.0, 1.0], &[[0.0, 0.0, 0.0], [0.0, 0.0, 1.0]]);
        o3.add_line(&[0.0, 0.0, 1.0], &[[1.0, 0.0, 0.0], [1.0, 0.0, 1.0]]);
        let e = exact_3d(&o3, 1.0, &ExactParams::default())
            .unwrap_err()
            .to_string();
        assert!(e.contains("parallel"), "{e}");
    }
}
