//! Joint refinement (beyond the paper): the corner and the slopes move together. For a
//! candidate q every side's line is re-fitted through q (total least squares about q), and the
//! error is the sum of distances to those lines ([`JointSlopes`]). The function is not convex,
//! so the paper's PSO searches it, from the same particles and in the same frame as the
//! fixed-slope search.
//!
//! Input: a prepared [`Problem`] (from `prepare_profile_2d` / `prepare_corner_3d`), parameters,
//! the iteration count and an RNG. Output: the refined corner (a [`Search`] in the problem's
//! local frame, like the other searchers) and the re-fitted side directions there.

use rand::Rng;

use super::objective::JointSlopes;
use super::problem::Problem;
use super::pso::{PsoParams, Search, SwarmScratch, pso};

/// Runs the joint refinement on `p`; returns the corner and, per side (in the problem's line
/// order), the direction of its line re-fitted through that corner.
pub fn refine_joint<const D: usize, O, R: Rng + ?Sized>(
    p: &Problem<'_, D, O>,
    params: &PsoParams,
    iterations: usize,
    rng: &mut R,
) -> (Search<D>, Vec<[f64; D]>) {
    let mut obj = JointSlopes::<D>::default();
    for side in p.assigned {
        obj.add_side(side.iter().map(|&i| &p.points[i]));
    }
    let best = pso(
        &obj,
        p.candidates,
        &p.basis,
        p.scale,
        params,
        iterations,
        rng,
        &mut SwarmScratch::default(),
        &mut Vec::new(),
    );
    let dirs = (0..obj.lines())
        .map(|j| obj.direction_at(j, &best.point).unwrap_or([0.0; D]))
        .collect();
    (best, dirs)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fit::{FitParams, ProfileFit, ProfileScratch, prepare_profile_2d};
    use rand::SeedableRng;
    use rand::rngs::SmallRng;

    #[test]
    fn joint_refinement_recovers_a_clean_corner_and_its_slopes() {
        // Noise-free V with 90° opening at (3, 4): the joint error is zero there.
        let mut pts = Vec::new();
        for i in 1..30 {
            let t = 0.2 * i as f64;
            pts.push([3.0 + t * 0.6, 4.0 + t * 0.8]);
            pts.push([3.0 - t * 0.8, 4.0 + t * 0.6]);
        }
        let params = FitParams::default();
        let mut s = ProfileScratch::default();
        let mut out = ProfileFit::default();
        prepare_profile_2d(&pts, [3.1, 4.2], &params, &mut s, &mut out).unwrap();
        let p = s.problem().unwrap();
        let (best, dirs) = refine_joint(&p, &params.pso, 40, &mut SmallRng::seed_from_u64(1));
        let q = p.frame.to_input(&best.point);
        assert!(
            (q[0] - 3.0).abs() < 1e-3 && (q[1] - 4.0).abs() < 1e-3,
            "{q:?}"
        );
        for d in dirs {
            let c1 = (d[0] * 0.6 + d[1] * 0.8).abs();
            let c2 = (d[0] * -0.8 + d[1] * 0.6).abs();
            assert!(c1.max(c2) > 1.0 - 1e-6, "{d:?}");
        }
    }
}
