//! Scoring of found edges and corners against true ones: pure functions over plain segments
//! and points, in model units (the caller divides by the spacing).
//!
//! Input: found corners and edge polylines, true corners and edge segments, tolerances.
//! Output: one-to-one corner matches ([`match_corners`]), the exact length of a set of
//! segments that lies within a distance of another set ([`coverage`], used both ways for edge
//! recall and precision), and the RMS distance of densely sampled found edges to the true
//! ones over their matched part ([`edge_samples`]).
//!
//! Coverage is computed exactly, not by sampling: the distance from a point moving linearly
//! along one segment to another (convex) segment is a convex function of the parameter, so the
//! part within `r` is one interval per pair of segments. Its minimum is found by golden-section
//! search and its two ends by bisection, both to machine precision; the union of the intervals
//! over all nearby segments is the covered length.

use std::collections::HashMap;

use crate::geometry::{V3, dist, point_segment, sub};

/// A found corner matched to a true one.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CornerMatch {
    pub found: usize,
    pub truth: usize,
    pub distance: f64,
}

/// One-to-one matching of found to true corners within `tol`: all pairs closer than `tol`,
/// taken greedily in order of distance (ties by index, so the result is deterministic).
/// Greedy is optimal — the most matches, then the smallest errors — whenever true corners are
/// more than `2 tol` apart, because each found corner then has at most one true candidate.
pub fn match_corners(found: &[V3], truth: &[V3], tol: f64) -> Vec<CornerMatch> {
    let mut pairs: Vec<CornerMatch> = Vec::new();
    for (i, f) in found.iter().enumerate() {
        for (j, t) in truth.iter().enumerate() {
            let d = dist(*f, *t);
            if d <= tol {
                pairs.push(CornerMatch {
                    found: i,
                    truth: j,
                    distance: d,
                });
            }
        }
    }
    pairs.sort_by(|a, b| {
        a.distance
            .total_cmp(&b.distance)
            .then(a.found.cmp(&b.found))
            .then(a.truth.cmp(&b.truth))
    });
    let mut used_found = vec![false; found.len()];
    let mut used_truth = vec![false; truth.len()];
    let mut out = Vec::new();
    for p in pairs {
        if !used_found[p.found] && !used_truth[p.truth] {
            used_found[p.found] = true;
            used_truth[p.truth] = true;
            out.push(p);
        }
    }
    out.sort_by_key(|m| m.truth);
    out
}

/// The consecutive segments of polylines (a one-point polyline is a zero-length segment).
pub fn polyline_segments(polylines: &[Vec<V3>]) -> Vec<(V3, V3)> {
    let mut out = Vec::new();
    for pl in polylines {
        match pl.len() {
            0 => {}
            1 => out.push((pl[0], pl[0])),
            _ => out.extend(pl.windows(2).map(|w| (w[0], w[1]))),
        }
    }
    out
}

/// Segments with an exact "everything within `reach`" query through a uniform hash grid.
///
/// Every segment is registered in the cells that can hold a point within `1.5 · reach` of
/// it: the segment is sampled every `cell / 2` (so each of its points is within `cell / 4`
/// of a sample), and each sample registers the 3×3×3 block of cells around its own. With
/// `cell = 2 · reach`, a point within `reach + cell / 4 = 1.5 · reach` of the segment lies
/// within `cell` of a sample on every axis, hence in that block. Long segments therefore cost
/// cells along their length only, not the volume of their bounding box.
pub struct SegmentSet {
    segments: Vec<(V3, V3)>,
    reach: f64,
    cell: f64,
    grid: HashMap<[i64; 3], Vec<u32>>,
}

impl SegmentSet {
    /// Indexes `segments` for queries up to `reach` (> 0, finite).
    pub fn new(segments: Vec<(V3, V3)>, reach: f64) -> Self {
        let cell = 2.0 * reach;
        let mut grid: HashMap<[i64; 3], Vec<u32>> = HashMap::new();
        for (id, &(a, b)) in segments.iter().enumerate() {
            for s in samples(a, b, 0.5 * cell) {
                let c = cell_of(s, cell);
                for dx in -1..=1 {
                    for dy in -1..=1 {
                        for dz in -1..=1 {
                            let list = grid.entry([c[0] + dx, c[1] + dy, c[2] + dz]).or_default();
                            // Consecutive samples share most cells: skip the repeat.
                            if list.last() != Some(&(id as u32)) {
                                list.push(id as u32);
                            }
                        }
                    }
                }
            }
        }
        SegmentSet {
            segments,
            reach,
            cell,
            grid,
        }
    }

    pub fn segments(&self) -> &[(V3, V3)] {
        &self.segments
    }

    /// Distance to the nearest segment and its id, if one is within `reach` of `p`.
    pub fn nearest_within(&self, p: V3) -> Option<(f64, usize)> {
        let list = self.grid.get(&cell_of(p, self.cell))?;
        list.iter()
            .map(|&id| {
                let (a, b) = self.segments[id as usize];
                (point_segment(p, a, b).0, id as usize)
            })
            .filter(|&(d, _)| d <= self.reach)
            .min_by(|x, y| x.0.total_cmp(&y.0).then(x.1.cmp(&y.1)))
    }

    /// Every segment within `reach` of `p`, with its distance, in id order.
    pub fn all_within(&self, p: V3) -> Vec<(usize, f64)> {
        let Some(list) = self.grid.get(&cell_of(p, self.cell)) else {
            return Vec::new();
        };
        let mut out: Vec<(usize, f64)> = list
            .iter()
            .map(|&id| {
                let (a, b) = self.segments[id as usize];
                (id as usize, point_segment(p, a, b).0)
            })
            .filter(|&(_, d)| d <= self.reach)
            .collect();
        out.sort_unstable_by_key(|x| x.0);
        out.dedup_by_key(|x| x.0);
        out
    }

    /// Ids of every segment that may come within `reach` of the segment `a b` (a superset:
    /// all that do, plus some that come within `1.5 · reach`), sorted.
    pub fn candidates_near_segment(&self, a: V3, b: V3) -> Vec<usize> {
        let mut ids: Vec<usize> = Vec::new();
        for s in samples(a, b, 0.5 * self.cell) {
            if let Some(list) = self.grid.get(&cell_of(s, self.cell)) {
                ids.extend(list.iter().map(|&i| i as usize));
            }
        }
        ids.sort_unstable();
        ids.dedup();
        ids
    }
}

fn cell_of(p: V3, cell: f64) -> [i64; 3] {
    p.map(|c| (c / cell).floor() as i64)
}

/// Points along `a b`, both ends included, at most `step` apart.
fn samples(a: V3, b: V3, step: f64) -> impl Iterator<Item = V3> {
    let len = dist(a, b);
    let n = if len > 0.0 && step > 0.0 {
        (len / step).ceil().max(1.0) as usize
    } else {
        0
    };
    (0..=n).map(move |k| {
        let t = if n == 0 { 0.0 } else { k as f64 / n as f64 };
        lerp(a, b, t)
    })
}

fn lerp(a: V3, b: V3, t: f64) -> V3 {
    [0, 1, 2].map(|k| a[k] + t * (b[k] - a[k]))
}

/// The parameter interval `[t0, t1]` of segment `a b` within `r` of segment `c d`, if any.
/// `f(t) = dist(a + t (b − a), cd)` is convex (distance to a convex set along a line), so this
/// set is one interval: golden-section search finds the minimum, bisection the two crossings.
pub fn interval_within(a: V3, b: V3, c: V3, d: V3, r: f64) -> Option<(f64, f64)> {
    let f = |t: f64| point_segment(lerp(a, b, t), c, d).0;
    // Golden-section search; 0.618^90 < 1e-18, below f64 resolution of [0, 1].
    const G: f64 = 0.618_033_988_749_895;
    let (mut lo, mut hi) = (0.0f64, 1.0f64);
    let mut x1 = hi - G * (hi - lo);
    let mut x2 = lo + G * (hi - lo);
    let (mut f1, mut f2) = (f(x1), f(x2));
    for _ in 0..90 {
        if f1 <= f2 {
            hi = x2;
            x2 = x1;
            f2 = f1;
            x1 = hi - G * (hi - lo);
            f1 = f(x1);
        } else {
            lo = x1;
            x1 = x2;
            f1 = f2;
            x2 = lo + G * (hi - lo);
            f2 = f(x2);
        }
    }
    // The ends may be the minimum (a monotone f); compare them too.
    let mut best = (f1, x1);
    for t in [0.0, 1.0, x2] {
        let v = f(t);
        if v < best.0 {
            best = (v, t);
        }
    }
    let (fmin, tmin) = best;
    if fmin > r {
        return None;
    }
    // f is non-increasing on [0, tmin] and non-decreasing on [tmin, 1].
    let crossing = |mut inside: f64, mut outside: f64| {
        for _ in 0..64 {
            let mid = 0.5 * (inside + outside);
            if f(mid) <= r {
                inside = mid;
            } else {
                outside = mid;
            }
        }
        inside
    };
    let t0 = if f(0.0) <= r {
        0.0
    } else {
        crossing(tmin, 0.0)
    };
    let t1 = if f(1.0) <= r {
        1.0
    } else {
        crossing(tmin, 1.0)
    };
    Some((t0, t1))
}

/// Total length of the union of parameter intervals on [0, 1] (sorted and merged).
fn union_length(mut intervals: Vec<(f64, f64)>) -> f64 {
    intervals.sort_by(|x, y| x.0.total_cmp(&y.0));
    let mut total = 0.0;
    let mut current: Option<(f64, f64)> = None;
    for (s, e) in intervals {
        match current {
            Some((cs, ce)) if s <= ce => current = Some((cs, ce.max(e))),
            Some((cs, ce)) => {
                total += ce - cs;
                current = Some((s, e));
            }
            None => current = Some((s, e)),
        }
    }
    if let Some((cs, ce)) = current {
        total += ce - cs;
    }
    total
}

/// Covered length of each segment of `segments`: the length of its part within `others.reach`
/// of any segment in `others`. Exact up to floating point (see the module comment).
pub fn coverage(segments: &[(V3, V3)], others: &SegmentSet) -> Vec<f64> {
    segments
        .iter()
        .map(|&(a, b)| {
            let len = dist(a, b);
            let near = others.candidates_near_segment(a, b);
            if len == 0.0 {
                // A point: covered entirely or not at all (it has no length either way).
                return 0.0;
            }
            let intervals: Vec<(f64, f64)> = near
                .iter()
                .filter_map(|&k| {
                    let (c, d) = others.segments()[k];
                    interval_within(a, b, c, d, others.reach)
                })
                .collect();
            union_length(intervals) * len
        })
        .collect()
}

/// A sample of a found edge matched to a true one.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EdgeSample {
    /// The length of found edge the sample stands for.
    pub weight: f64,
    pub distance: f64,
    /// The nearest true segment and the vector from its closest point to the sample.
    pub segment: usize,
    pub offset: V3,
}

/// The midpoints of `segments` cut into pieces at most `step` long, each with its piece's
/// length (zero-length segments give none), segment by segment, start to end.
pub fn midpoints(segments: &[(V3, V3)], step: f64) -> impl Iterator<Item = (V3, f64)> + '_ {
    segments.iter().flat_map(move |&(a, b)| {
        let len = dist(a, b);
        let n = if len == 0.0 {
            0
        } else {
            (len / step).ceil().max(1.0) as usize
        };
        (0..n).map(move |k| (lerp(a, b, (k as f64 + 0.5) / n as f64), len / n as f64))
    })
}

/// Dense samples of `segments` within `truth`'s reach, with their distance to the nearest
/// true segment. Samples are the midpoints of pieces at most `step` long.
pub fn edge_samples(segments: &[(V3, V3)], truth: &SegmentSet, step: f64) -> Vec<EdgeSample> {
    let mut out = Vec::new();
    for (p, weight) in midpoints(segments, step) {
        if let Some((distance, segment)) = truth.nearest_within(p) {
            let (c, d) = truth.segments()[segment];
            let (_, t) = point_segment(p, c, d);
            let q = lerp(c, d, t);
            out.push(EdgeSample {
                weight,
                distance,
                segment,
                offset: sub(p, q),
            });
        }
    }
    out
}

/// Weighted RMS, mean and maximum of `(weight, value)` pairs; `None` when empty.
pub fn weighted_stats(samples: &[(f64, f64)]) -> Option<(f64, f64, f64)> {
    let w: f64 = samples.iter().map(|s| s.0).sum();
    if samples.is_empty() || w <= 0.0 {
        return None;
    }
    let ms = samples.iter().map(|s| s.0 * s.1 * s.1).sum::<f64>() / w;
    let mean = samples.iter().map(|s| s.0 * s.1).sum::<f64>() / w;
    let max = samples.iter().map(|s| s.1).fold(0.0, f64::max);
    Some((ms.sqrt(), mean, max))
}

/// Mean, median and maximum; `None` when empty.
pub fn stats(values: &[f64]) -> Option<(f64, f64, f64)> {
    if values.is_empty() {
        return None;
    }
    let mut v = values.to_vec();
    v.sort_by(f64::total_cmp);
    let n = v.len();
    let median = if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    };
    let mean = v.iter().sum::<f64>() / n as f64;
    Some((mean, median, v[n - 1]))
}

/// Edge recall, precision and distance of found edges to true ones.
#[derive(Debug, Clone, PartialEq)]
pub struct EdgeScore {
    pub true_length: f64,
    pub found_length: f64,
    /// Length of the true edges within `tol` of a found edge.
    pub true_covered: f64,
    /// Length of the found edges within `tol` of a true edge.
    pub found_covered: f64,
    /// Covered length per true segment and per found segment (same order as given).
    pub true_covered_each: Vec<f64>,
    pub found_covered_each: Vec<f64>,
    /// RMS, mean and maximum distance of the found edges' matched part to the true edges.
    pub distance: Option<(f64, f64, f64)>,
    /// The samples behind `distance`.
    pub samples: Vec<EdgeSample>,
}

impl EdgeScore {
    pub fn recall(&self) -> Option<f64> {
        (self.true_length > 0.0).then(|| self.true_covered / self.true_length)
    }
    pub fn precision(&self) -> Option<f64> {
        (self.found_length > 0.0).then(|| self.found_covered / self.found_length)
    }
}

/// Scores `found` segments against `truth` segments with tolerance `tol`, sampling the found
/// edges every `step` for the distance statistics.
pub fn score_edges(found: &[(V3, V3)], truth: &[(V3, V3)], tol: f64, step: f64) -> EdgeScore {
    let found_set = SegmentSet::new(found.to_vec(), tol);
    let truth_set = SegmentSet::new(truth.to_vec(), tol);
    let true_covered_each = coverage(truth, &found_set);
    let found_covered_each = coverage(found, &truth_set);
    let length = |s: &[(V3, V3)]| s.iter().map(|&(a, b)| dist(a, b)).sum::<f64>();
    let samples = edge_samples(found, &truth_set, step);
    EdgeScore {
        true_length: length(truth),
        found_length: length(found),
        true_covered: true_covered_each.iter().sum(),
        found_covered: found_covered_each.iter().sum(),
        true_covered_each,
        found_covered_each,
        distance: weighted_stats(
            &samples
                .iter()
                .map(|s| (s.weight, s.distance))
                .collect::<Vec<_>>(),
        ),
        samples,
    }
}

/// Length of a polyline.
pub fn polyline_length(pl: &[V3]) -> f64 {
    pl.windows(2).map(|w| dist(w[0], w[1])).sum()
}

/// `true` when the two vectors have the same bits (the contract for untouched points).
pub fn same_bits(a: V3, b: V3) -> bool {
    (0..3).all(|k| a[k].to_bits() == b[k].to_bits())
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    const H: f64 = 0.5;

    fn close(a: f64, b: f64, tol: f64) -> bool {
        (a - b).abs() <= tol
    }

    #[test]
    fn edge_offset_by_one_spacing_has_rms_one_spacing() {
        let truth = [([0.0, 0.0, 0.0], [100.0 * H, 0.0, 0.0])];
        let found = [([0.0, H, 0.0], [100.0 * H, H, 0.0])];
        let s = score_edges(&found, &truth, 2.0 * H, H / 10.0);
        let (rms, mean, max) = s.distance.unwrap();
        assert!(close(rms / H, 1.0, 1e-12), "{rms}");
        assert!(close(mean / H, 1.0, 1e-12));
        assert!(close(max / H, 1.0, 1e-12));
        assert!(close(s.recall().unwrap(), 1.0, 1e-12));
        assert!(close(s.precision().unwrap(), 1.0, 1e-12));
    }

    #[test]
    fn edge_offset_by_three_spacings_is_unmatched() {
        let truth = [([0.0, 0.0, 0.0], [100.0 * H, 0.0, 0.0])];
        let found = [([0.0, 0.0, 3.0 * H], [100.0 * H, 0.0, 3.0 * H])];
        let s = score_edges(&found, &truth, 2.0 * H, H / 10.0);
        assert_eq!(s.recall(), Some(0.0));
        assert_eq!(s.precision(), Some(0.0));
        assert_eq!(s.distance, None);
    }

    #[test]
    fn half_long_edge_has_recall_one_half_and_full_precision() {
        let (a, b) = ([1.0, 2.0, 3.0], [41.0, -28.0, 3.0]); // length 50 = 100 h
        let truth = [(a, b)];
        let found = [(a, lerp(a, b, 0.5))];
        let s = score_edges(&found, &truth, 2.0 * H, H / 10.0);
        // Half the true edge, plus the 2 h beyond the found edge's end that are still within
        // the tolerance of it: 0.5 + 2 / 100.
        assert!(close(s.recall().unwrap(), 0.52, 1e-12), "{:?}", s.recall());
        assert!(close(s.precision().unwrap(), 1.0, 1e-12));
        assert!(close(s.distance.unwrap().0, 0.0, 1e-12));
    }

    #[test]
    fn crossing_edge_covers_exactly_its_capsule() {
        // True edge along x on [0, 10]; a found edge along y through x = 5: the true edge is
        // within r = 2 of it for x in [3, 7], so recall = 4 / 10. The found edge (length 2,
        // y in [-1, 1]) lies entirely within 1 of the true edge: precision 1, and its mean
        // distance is the mean of |y| = 0.5, RMS sqrt(1/3).
        let truth = [([0.0, 0.0, 0.0], [10.0, 0.0, 0.0])];
        let found = [([5.0, -1.0, 0.0], [5.0, 1.0, 0.0])];
        let s = score_edges(&found, &truth, 2.0, 1e-3);
        assert!(close(s.recall().unwrap(), 0.4, 1e-12), "{:?}", s.recall());
        assert!(close(s.precision().unwrap(), 1.0, 1e-12));
        let (rms, mean, max) = s.distance.unwrap();
        assert!(close(mean, 0.5, 1e-9), "{mean}");
        assert!(close(rms, (1.0f64 / 3.0).sqrt(), 1e-6), "{rms}");
        assert!(close(max, 1.0, 1e-3));
    }

    #[test]
    fn overlapping_found_edges_are_not_counted_twice() {
        let truth = [([0.0, 0.0, 0.0], [10.0, 0.0, 0.0])];
        let found = [
            ([0.0, 0.1, 0.0], [6.0, 0.1, 0.0]),
            ([4.0, -0.1, 0.0], [10.0, -0.1, 0.0]),
        ];
        let s = score_edges(&found, &truth, 2.0, 0.01);
        assert!(close(s.recall().unwrap(), 1.0, 1e-12));
        assert!(close(s.precision().unwrap(), 1.0, 1e-12));
        assert!(close(s.found_length, 12.0, 1e-12));
    }

    #[test]
    fn overshoot_beyond_the_tolerance_lowers_precision() {
        // A found edge that runs 10 past the true edge's end along its line: the first 2 of
        // the overshoot are within r = 2 of the end point, the other 8 are not.
        let truth = [([0.0, 0.0, 0.0], [10.0, 0.0, 0.0])];
        let found = [([0.0, 0.0, 0.0], [20.0, 0.0, 0.0])];
        let s = score_edges(&found, &truth, 2.0, 0.01);
        assert!(close(s.precision().unwrap(), 12.0 / 20.0, 1e-12));
        assert!(close(s.recall().unwrap(), 1.0, 1e-12));
    }

    #[test]
    fn corner_four_spacings_away_is_unmatched_two_is_matched() {
        let truth = [[0.0, 0.0, 0.0], [100.0, 0.0, 0.0]];
        let found = [[0.0, 4.0 * H, 0.0], [100.0, 0.0, 2.0 * H]];
        let m = match_corners(&found, &truth, 3.0 * H);
        assert_eq!(
            m,
            vec![CornerMatch {
                found: 1,
                truth: 1,
                distance: 2.0 * H
            }]
        );
    }

    #[test]
    fn corner_matching_is_one_to_one_and_takes_the_nearest() {
        let truth = [[0.0, 0.0, 0.0]];
        let found = [[0.0, 0.0, 1.0], [0.0, 0.5, 0.0]];
        let m = match_corners(&found, &truth, 3.0);
        assert_eq!(m.len(), 1);
        assert_eq!((m[0].found, m[0].truth), (1, 0));
        assert_eq!(m[0].distance, 0.5);
    }

    #[test]
    fn statistics_of_hand_made_values() {
        assert_eq!(stats(&[3.0, 1.0, 2.0, 10.0]), Some((4.0, 2.5, 10.0)));
        assert_eq!(stats(&[]), None);
        let (rms, mean, max) = weighted_stats(&[(1.0, 1.0), (3.0, 3.0)]).unwrap();
        assert!(close(rms, (28.0f64 / 4.0).sqrt(), 1e-15));
        assert!(close(mean, 10.0 / 4.0, 1e-15));
        assert_eq!(max, 3.0);
    }

    #[test]
    fn polylines_become_segments() {
        let pl = vec![
            vec![[0.0; 3], [1.0, 0.0, 0.0], [1.0, 1.0, 0.0]],
            vec![[5.0; 3]],
            vec![],
        ];
        let s = polyline_segments(&pl);
        assert_eq!(s.len(), 3);
        assert_eq!(s[2], ([5.0; 3], [5.0; 3]));
        assert_eq!(polyline_length(&pl[0]), 2.0);
        assert_eq!(s[0], ([0.0; 3], [1.0, 0.0, 0.0]));
    }

    fn brute_nearest(segs: &[(V3, V3)], p: V3, reach: f64) -> Option<f64> {
        segs.iter()
            .map(|&(a, b)| point_segment(p, a, b).0)
            .filter(|&d| d <= reach)
            .min_by(f64::total_cmp)
    }

    fn brute_interval(a: V3, b: V3, c: V3, d: V3, r: f64) -> Option<(f64, f64)> {
        let n = 20_000;
        let inside: Vec<f64> = (0..=n)
            .map(|k| k as f64 / n as f64)
            .filter(|&t| point_segment(lerp(a, b, t), c, d).0 <= r)
            .collect();
        Some((*inside.first()?, *inside.last()?))
    }

    fn v3() -> impl Strategy<Value = V3> {
        [-10.0..10.0f64, -10.0..10.0f64, -10.0..10.0f64]
    }

    proptest! {
        #[test]
        fn grid_query_matches_brute_force(
            segs in prop::collection::vec((v3(), v3()), 1..20),
            pts in prop::collection::vec(v3(), 1..30),
            reach in 0.2..4.0f64,
        ) {
            let set = SegmentSet::new(segs.clone(), reach);
            for p in pts {
                let fast = set.nearest_within(p).map(|x| x.0);
                prop_assert_eq!(fast, brute_nearest(&segs, p, reach));
            }
        }

        #[test]
        fn segment_candidates_include_every_segment_within_reach(
            segs in prop::collection::vec((v3(), v3()), 1..20),
            q in (v3(), v3()),
            reach in 0.2..4.0f64,
        ) {
            let set = SegmentSet::new(segs.clone(), reach);
            let cands = set.candidates_near_segment(q.0, q.1);
            for (k, &(c, d)) in segs.iter().enumerate() {
                if interval_within(q.0, q.1, c, d, reach).is_some() {
                    prop_assert!(cands.contains(&k), "segment {} missing", k);
                }
            }
        }

        #[test]
        fn interval_matches_dense_sampling(
            a in v3(), b in v3(), c in v3(), d in v3(), r in 0.5..6.0f64,
        ) {
            let exact = interval_within(a, b, c, d, r);
            let sampled = brute_interval(a, b, c, d, r);
            match (exact, sampled) {
                (Some((e0, e1)), Some((s0, s1))) => {
                    // The samples lie inside the exact interval, at most one step in.
                    prop_assert!(e0 <= s0 + 1e-12 && s0 - e0 <= 5e-5 + 1e-12, "{} {}", e0, s0);
                    prop_assert!(e1 >= s1 - 1e-12 && e1 - s1 <= 5e-5 + 1e-12, "{} {}", e1, s1);
                }
                (None, None) => {}
                // A sliver between two samples may be missed by the sampling only.
                (Some((e0, e1)), None) => prop_assert!(e1 - e0 < 5e-5),
                (None, Some(s)) => prop_assert!(false, "exact missed {:?}", s),
            }
        }
    }
}
