//! Particle swarm search for the corner (§3, Eq. 9–10).
//!
//! One particle per candidate point (the corner-region data points, the paper's "high-quality
//! initialisation"); each particle keeps its best position p_i, the swarm its best p_g, and
//!   v ← w·v + c1·r1·(p_i − q) + c2·r2·(p_g − q),   q ← q + v.
//! The paper's defaults: w = 0.6, c1 = c2 = 2, r1, r2 ~ U[0, 0.2], initial velocity ~ U[0, 0.2],
//! 20 iterations in 2D and 10 in 3D.
//!
//! The paper's ranges are absolute and per axis. To make the result independent of units and
//! orientation, the swarm runs in coordinates of an orthonormal frame attached to the corner
//! (built by the caller from the side directions, e.g. its first axis pointing along the
//! bisector towards the tip), r1 and r2 are drawn per coordinate of that frame, and the
//! initial velocity's coordinates are U[0, v0_max] · s with s the corner region's extent. (A
//! rotation-invariant variant with one scalar r per particle confines the swarm to the span of
//! its initial spread; measured on 3D corners of two edges, whose data is nearly planar, it
//! stalls off the optimum.) All random draws come from the caller's RNG, in a fixed order.
//!
//! Inputs: an [`Objective`], the initial positions, the frame and extent, parameters and
//! an RNG. Output: a [`Search`] (best point, its error, evaluations, the iteration it converged
//! at) and the per-iteration history of the best error (index 0 = initial swarm).

use rand::{Rng, RngExt};
use serde::{Deserialize, Serialize};

use super::objective::Objective;
use crate::geometry::{axpy, dot};

/// PSO parameters (paper §3).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct PsoParams {
    /// Inertia weight w.
    pub w: f64,
    /// Cognitive constant c1.
    pub c1: f64,
    /// Social constant c2.
    pub c2: f64,
    /// r1, r2 ~ U[0, r_max].
    pub r_max: f64,
    /// Initial velocity components ~ U[0, v0_max], in units of the corner region's extent.
    pub v0_max: f64,
    /// Iterations for the 2D (edge profile) case.
    pub iterations_2d: usize,
    /// Iterations for the 3D (vertex) case.
    pub iterations_3d: usize,
}

impl Default for PsoParams {
    fn default() -> Self {
        PsoParams {
            w: 0.6,
            c1: 2.0,
            c2: 2.0,
            r_max: 0.2,
            v0_max: 0.2,
            iterations_2d: 20,
            iterations_3d: 10,
        }
    }
}

impl PsoParams {
    /// The iterations of a fit in `dim` dimensions: `iterations_2d` for an edge profile (2),
    /// `iterations_3d` for a vertex.
    pub fn iterations(&self, dim: usize) -> usize {
        if dim == 2 {
            self.iterations_2d
        } else {
            self.iterations_3d
        }
    }
}

/// Result of one search (PSO, GA or Scheme 1).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Search<const D: usize> {
    /// The best corner found.
    pub point: [f64; D],
    /// Its error (sum of point-to-line distances).
    pub error: f64,
    /// Objective evaluations spent.
    pub evaluations: usize,
    /// First iteration whose best error is within 0.1 % of the final one (0 = the initial
    /// swarm was already there).
    pub converged_at: usize,
}

impl<const D: usize> Default for Search<D> {
    fn default() -> Self {
        Search {
            point: [f64::NAN; D],
            error: f64::INFINITY,
            evaluations: 0,
            converged_at: 0,
        }
    }
}

/// The first index of `history` within 0.1 % of its last value.
pub fn converged_at(history: &[f64]) -> usize {
    let Some(&last) = history.last() else {
        return 0;
    };
    history
        .iter()
        .position(|&e| e - last <= 1e-3 * last.abs())
        .unwrap_or(0)
}

/// Work buffers of [`pso`], reusable between calls.
#[derive(Clone, Debug, Default)]
pub struct SwarmScratch<const D: usize> {
    pos: Vec<[f64; D]>,
    vel: Vec<[f64; D]>,
    best: Vec<[f64; D]>,
    best_err: Vec<f64>,
}

/// Coordinates of `q` in the orthonormal `basis` (rows).
#[inline]
pub(crate) fn to_basis<const D: usize>(basis: &[[f64; D]; D], q: &[f64; D]) -> [f64; D] {
    std::array::from_fn(|k| dot(basis[k], q))
}

/// The point with coordinates `y` in the orthonormal `basis` (rows).
#[inline]
pub(crate) fn from_basis<const D: usize>(basis: &[[f64; D]; D], y: &[f64; D]) -> [f64; D] {
    let mut q = [0.0; D];
    for k in 0..D {
        q = axpy(q, y[k], basis[k]);
    }
    q
}

/// Runs the particle swarm. `init` are the particles' starting positions (at least one);
/// `basis` is the orthonormal frame (rows) whose coordinates the swarm updates one by one:
/// r1 and r2 are drawn per coordinate as in the usual reading of Eq. 9, and the initial
/// velocity has coordinates U[0, v0_max] · `scale`. `iterations` is the number of updates.
/// `history` is cleared and receives `iterations + 1` best errors.
#[allow(clippy::too_many_arguments)]
pub fn pso<const D: usize, O: Objective<D> + ?Sized, R: Rng + ?Sized>(
    obj: &O,
    init: &[[f64; D]],
    basis: &[[f64; D]; D],
    scale: f64,
    params: &PsoParams,
    iterations: usize,
    rng: &mut R,
    scratch: &mut SwarmScratch<D>,
    history: &mut Vec<f64>,
) -> Search<D> {
    let n = init.len();
    history.clear();
    if n == 0 {
        return Search::default();
    }
    let s = &mut *scratch;
    s.pos.clear();
    s.pos.extend(init.iter().map(|q| to_basis(basis, q)));
    s.best.clear();
    s.best.extend_from_slice(&s.pos);
    s.vel.clear();
    s.best_err.clear();
    for q in init {
        let v: [f64; D] = std::array::from_fn(|_| rng.random::<f64>() * params.v0_max * scale);
        s.vel.push(v);
        s.best_err.push(obj.error(q));
    }
    let mut evaluations = n;
    let mut g = argmin(&s.best_err);
    history.push(s.best_err[g]);
    for _ in 0..iterations {
        let gbest = s.best[g];
        for i in 0..n {
            let q = s.pos[i];
            let mut v = [0.0; D];
            for k in 0..D {
                let r1 = rng.random::<f64>() * params.r_max;
                let r2 = rng.random::<f64>() * params.r_max;
                v[k] = params.w * s.vel[i][k]
                    + params.c1 * r1 * (s.best[i][k] - q[k])
                    + params.c2 * r2 * (gbest[k] - q[k]);
            }
            let q: [f64; D] = std::array::from_fn(|k| q[k] + v[k]);
            s.vel[i] = v;
            s.pos[i] = q;
            let e = obj.error(&from_basis(basis, &q));
            evaluations += 1;
            if better(e, s.best_err[i]) {
                s.best_err[i] = e;
                s.best[i] = q;
            }
        }
        // The swarm's best changes only on a real improvement, so its error never rises (with
        // the rounding margin, a fresh argmin could pick a hair-worse particle).
        for i in 0..n {
            if better(s.best_err[i], s.best_err[g]) {
                g = i;
            }
        }
        history.push(s.best_err[g]);
    }
    Search {
        point: from_basis(basis, &s.best[g]),
        error: s.best_err[g],
        evaluations,
        converged_at: converged_at(history),
    }
}

/// Whether error `e` improves on `best` by more than rounding can explain.
///
/// The 2D error is piecewise linear and constant over a small polygon around its minimum (any
/// point between the two middle values of each side's median is optimal), so inside it two
/// candidates differ only by rounding. Counting such differences as improvements would let
/// the last bit of the input steer the swarm: a rotated or reordered input would end at
/// another point of the same flat minimum. With this margin the search ignores them.
#[inline]
pub(crate) fn better(e: f64, best: f64) -> bool {
    e < best - 1e-12 * best.abs() || (best.is_nan() && !e.is_nan())
}

/// Index of the smallest value, in the sense of [`better`] (the first one on ties; NaN never
/// wins).
pub(crate) fn argmin(v: &[f64]) -> usize {
    let mut best = 0;
    for (i, &e) in v.iter().enumerate() {
        if better(e, v[best]) {
            best = i;
        }
    }
    best
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fit::objective::{FixedSlopes, FixedSlopes2};
    use rand::SeedableRng;
    use rand::rngs::SmallRng;

    struct Bowl;
    impl Objective<2> for Bowl {
        fn error(&self, q: &[f64; 2]) -> f64 {
            ((q[0] - 1.0).powi(2) + (q[1] + 2.0).powi(2)).sqrt()
        }
    }

    #[test]
    fn swarm_never_gets_worse_than_its_best_particle_and_records_history() {
        let init = [[0.0, 0.0], [2.0, -1.0], [1.5, -3.0], [0.5, -2.5]];
        let mut rng = SmallRng::seed_from_u64(5);
        let mut hist = Vec::new();
        let r = pso(
            &Bowl,
            &init,
            &[[1.0, 0.0], [0.0, 1.0]],
            1.0,
            &PsoParams::default(),
            20,
            &mut rng,
            &mut SwarmScratch::default(),
            &mut hist,
        );
        assert_eq!(hist.len(), 21);
        assert!(hist.windows(2).all(|w| w[1] <= w[0]));
        let start = init
            .iter()
            .map(|q| Bowl.error(q))
            .fold(f64::INFINITY, f64::min);
        assert_eq!(hist[0], start);
        assert!(r.error < 0.1 * start, "{} vs {start}", r.error);
        assert_eq!(r.evaluations, 4 + 4 * 20);
        assert_eq!(r.error, Bowl.error(&r.point));
    }

    #[test]
    fn same_seed_same_result() {
        let mut obj = FixedSlopes2::default();
        obj.add_line(&[1.0, 0.0], &[[1.0, 0.1], [2.0, -0.1], [3.0, 0.05]]);
        obj.add_line(&[0.0, 1.0], &[[0.1, 1.0], [-0.1, 2.0], [0.0, 3.0]]);
        let init = [[0.5, 0.5], [0.3, 0.2], [0.2, 0.4]];
        let run = |seed| {
            let mut hist = Vec::new();
            pso(
                &obj,
                &init,
                &[[1.0, 0.0], [0.0, 1.0]],
                0.5,
                &PsoParams::default(),
                20,
                &mut SmallRng::seed_from_u64(seed),
                &mut SwarmScratch::default(),
                &mut hist,
            )
        };
        assert_eq!(run(3), run(3));
        assert_eq!(converged_at(&[5.0, 4.0, 3.0, 3.0]), 2);
    }
}
