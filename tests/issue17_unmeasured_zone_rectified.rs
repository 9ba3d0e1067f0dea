//! An edge whose abnormal zone could not be measured still rectifies (issue 17: "rectified
//! zone ≤ 0.3x", "points away from edges moved: 0"). Run as the real binary on a draw of
//! `bench --random 100`, scored by the bench against the part's truth.
//!
//! Where a part's edges are barely rounded, their abnormal points are those the noise throws
//! about the edge, and rectifying them means moving them onto the faces' traces. A fitted
//! edge with too few side points in its slabs to measure its zone moved none of them; it now
//! moves them within the margin, as a sharp edge would (`rectify::rectify`). Seed 1's r093
//! (43,547 points, σ 0.18 h, rounding 0.04 h): rectified / raw 0.347, now 0.296, and the
//! case passes every check with no point away from the edges moved.

mod run_common;

use run_common::{assert_passes, assert_rectified, bench_random_draw};

#[test]
fn issue17_an_edge_whose_zone_was_not_measured_rectifies_within_the_margin() {
    let case = bench_random_draw(1, "r093", 43_547);
    assert_rectified(&case, (0, 0), (0.3, 0.347));
    assert_passes(&case);
}
