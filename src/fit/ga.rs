//! A real-coded genetic algorithm for the corner, for the paper's PSO-vs-GA comparison
//! (Figure 10: "same discrete data points and same iterations").
//!
//! Same start, frame and budget as the PSO: the population is the corner-region points, each
//! generation evaluates as many children as there are individuals, and coordinates are taken
//! in the same orthonormal frame. A child comes from two
//! parents picked by binary tournament, by BLX-α crossover per coordinate (Eshelman & Schaffer
//! 1993), then, with probability `mutation_rate`, a Gaussian mutation of size
//! `mutation_scale` × the corner region's extent, shrinking linearly over the generations.
//! Elitism: the best individual so far replaces the worst child.
//!
//! Inputs: an [`Objective`], the initial population, the extent, parameters, an RNG. Output: a
//! [`Search`] and the per-generation history of the best error.

use rand::{Rng, RngExt};
use serde::{Deserialize, Serialize};

use super::objective::Objective;
use super::pso::{Search, argmin, converged_at, from_basis, to_basis};

/// GA parameters.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct GaParams {
    /// BLX-α: children are drawn from the parents' interval widened by α of its length on
    /// each side.
    pub alpha: f64,
    /// Probability that a child is mutated.
    pub mutation_rate: f64,
    /// Standard deviation of the mutation at the first generation, in units of the corner
    /// region's extent.
    pub mutation_scale: f64,
}

impl Default for GaParams {
    fn default() -> Self {
        GaParams {
            alpha: 0.5,
            mutation_rate: 0.2,
            mutation_scale: 0.2,
        }
    }
}

/// A standard normal draw (Box–Muller), from the caller's RNG only.
pub fn standard_normal<R: Rng + ?Sized>(rng: &mut R) -> f64 {
    // 1 − U lies in (0, 1], so the logarithm is finite.
    let u1 = 1.0 - rng.random::<f64>();
    let u2 = rng.random::<f64>();
    (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
}

/// Work buffers of [`ga`].
#[derive(Clone, Debug, Default)]
pub struct GaScratch<const D: usize> {
    pop: Vec<[f64; D]>,
    err: Vec<f64>,
    kids: Vec<[f64; D]>,
    kid_err: Vec<f64>,
}

/// Runs the GA for `generations` generations from population `init`.
#[allow(clippy::too_many_arguments)]
pub fn ga<const D: usize, O: Objective<D> + ?Sized, R: Rng + ?Sized>(
    obj: &O,
    init: &[[f64; D]],
    basis: &[[f64; D]; D],
    scale: f64,
    params: &GaParams,
    generations: usize,
    rng: &mut R,
    scratch: &mut GaScratch<D>,
    history: &mut Vec<f64>,
) -> Search<D> {
    let n = init.len();
    history.clear();
    if n == 0 {
        return Search::default();
    }
    let s = &mut *scratch;
    s.pop.clear();
    s.pop.extend(init.iter().map(|q| to_basis(basis, q)));
    s.err.clear();
    s.err.extend(init.iter().map(|q| obj.error(q)));
    let mut evaluations = n;
    let mut b = argmin(&s.err);
    let (mut best, mut best_err) = (s.pop[b], s.err[b]);
    history.push(best_err);
    let pick = |rng: &mut R, err: &[f64]| {
        let i = rng.random_range(0..n);
        let j = rng.random_range(0..n);
        if err[j] < err[i] { j } else { i }
    };
    for g in 0..generations {
        let sigma = params.mutation_scale * scale * (1.0 - g as f64 / generations.max(1) as f64);
        s.kids.clear();
        s.kid_err.clear();
        for _ in 0..n {
            let a = s.pop[pick(rng, &s.err)];
            let c = s.pop[pick(rng, &s.err)];
            let mut kid = [0.0; D];
            for k in 0..D {
                let (lo, hi) = (a[k].min(c[k]), a[k].max(c[k]));
                let w = hi - lo;
                kid[k] =
                    lo - params.alpha * w + rng.random::<f64>() * (1.0 + 2.0 * params.alpha) * w;
            }
            if rng.random::<f64>() < params.mutation_rate {
                for x in kid.iter_mut() {
                    *x += sigma * standard_normal(rng);
                }
            }
            s.kid_err.push(obj.error(&from_basis(basis, &kid)));
            s.kids.push(kid);
        }
        evaluations += n;
        // Elitism: the best so far replaces the worst child.
        let mut worst = 0;
        for (i, &e) in s.kid_err.iter().enumerate() {
            if e > s.kid_err[worst] || s.kid_err[worst].is_nan() {
                worst = i;
            }
        }
        if best_err < s.kid_err[worst] {
            s.kids[worst] = best;
            s.kid_err[worst] = best_err;
        }
        std::mem::swap(&mut s.pop, &mut s.kids);
        std::mem::swap(&mut s.err, &mut s.kid_err);
        b = argmin(&s.err);
        if s.err[b] < best_err {
            best = s.pop[b];
            best_err = s.err[b];
        }
        history.push(best_err);
    }
    Search {
        point: from_basis(basis, &best),
        error: best_err,
        evaluations,
        converged_at: converged_at(history),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;
    use rand::rngs::SmallRng;

    struct Bowl;
    impl Objective<2> for Bowl {
        fn error(&self, q: &[f64; 2]) -> f64 {
            ((q[0] - 1.0).powi(2) + (q[1] + 2.0).powi(2)).sqrt()
        }
    }

    #[test]
    fn ga_improves_on_its_start_with_the_same_budget_as_pso() {
        let init = [
            [0.0, 0.0],
            [2.0, -1.0],
            [1.5, -3.0],
            [0.5, -2.5],
            [0.0, -1.0],
        ];
        let mut hist = Vec::new();
        let r = ga(
            &Bowl,
            &init,
            &[[1.0, 0.0], [0.0, 1.0]],
            1.0,
            &GaParams::default(),
            20,
            &mut SmallRng::seed_from_u64(2),
            &mut GaScratch::default(),
            &mut hist,
        );
        assert_eq!(r.evaluations, 5 * 21);
        assert_eq!(hist.len(), 21);
        assert!(hist.windows(2).all(|w| w[1] <= w[0]));
        assert!(r.error < 0.25 * hist[0], "{} vs {}", r.error, hist[0]);
    }

    #[test]
    fn standard_normal_has_unit_variance() {
        let mut rng = SmallRng::seed_from_u64(9);
        let n = 200_000;
        let xs: Vec<f64> = (0..n).map(|_| standard_normal(&mut rng)).collect();
        let m = xs.iter().sum::<f64>() / n as f64;
        let v = xs.iter().map(|x| (x - m) * (x - m)).sum::<f64>() / n as f64;
        assert!(m.abs() < 0.01 && (v - 1.0).abs() < 0.01, "{m} {v}");
    }
}
