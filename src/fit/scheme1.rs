//! Scheme 1 of the paper (§2.1, §4): the corner-region data point with the least error, taken
//! as the constrained corner. The reference the PSO is compared against.
//!
//! Input: an [`Objective`] and the candidate points. Output: the best candidate's index and a
//! [`Search`] record (one evaluation per candidate).

use super::objective::Objective;
use super::pso::Search;

/// The candidate with the least error; `None` when there are no candidates. Ties (up to
/// rounding) go to the first candidate.
pub fn scheme1<const D: usize, O: Objective<D> + ?Sized>(
    obj: &O,
    candidates: &[[f64; D]],
) -> Option<(usize, Search<D>)> {
    let mut best: Option<(usize, f64)> = None;
    for (i, q) in candidates.iter().enumerate() {
        let e = obj.error(q);
        if best.is_none_or(|(_, b)| super::pso::better(e, b)) {
            best = Some((i, e));
        }
    }
    best.map(|(i, e)| {
        (
            i,
            Search {
                point: candidates[i],
                error: e,
                evaluations: candidates.len(),
                converged_at: 0,
            },
        )
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fit::objective::{FixedSlopes, FixedSlopes2};

    #[test]
    fn picks_the_data_point_with_least_error() {
        let mut obj = FixedSlopes2::default();
        obj.add_line(&[1.0, 0.0], &[[1.0, 0.0], [2.0, 0.0]]);
        obj.add_line(&[0.0, 1.0], &[[0.0, 1.0], [0.0, 2.0]]);
        let cands = [[0.5, 0.5], [0.1, -0.1], [0.3, 0.0]];
        let (i, s) = scheme1(&obj, &cands).unwrap();
        assert_eq!(i, 1);
        assert!((s.error - 0.4).abs() < 1e-15);
        assert!(scheme1(&obj, &[]).is_none());
    }
}
