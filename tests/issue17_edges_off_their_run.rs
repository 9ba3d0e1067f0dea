//! An edge fitted off its candidates is no edge of theirs (issue 17: "edge precision ≥ 0.99",
//! "points away from edges moved: 0"). Run as the real binary on draws of `bench --random
//! 100`, scored by the bench against the part's truth.
//!
//! - seed 3's r084 (228,218 points): a run's slab fits met faces other than the ones its
//!   candidates straddle, and made a 103-spacing edge 5.6 spacings beside a concave edge of
//!   the part: edge precision 0.980, 40 points away from the edges moved. An edge fitted more
//!   than two radii beyond its rounding's apex from its run's centre line is now a failed fit
//!   (`edges::OFF_RUN_RADII`), and the case passes.
//! - seed 2's r071 (111,355 points, σ 0.27 h growing with the incidence): such an edge, 2.4–3.7
//!   spacings beside the part's, moved 11 points away from the edges; 3 move now.

mod run_common;

use run_common::{assert_passes, bench_random_draw};

#[test]
fn issue17_an_edge_off_its_candidates_is_left_out() {
    let case = bench_random_draw(3, "r084", 228_218);
    assert_passes(&case);
    let case = bench_random_draw(2, "r071", 111_355);
    let away = case["rectify"]["away_moved"].as_u64().unwrap();
    assert!(
        away <= 5,
        "r071: {away} points away from the edges moved (11 before)"
    );
}
