//! Plane corners whose edges run into a fillet (issue 17: "corner precision ≥ 0.99, edge
//! precision ≥ 0.99"). A plane corner is kept only where the scan follows each of its three
//! edges (`plane_corners::unfollowed_edge`); a fillet a little wider than the widest sharp
//! rounding keeps the scan off its two faces' line by less than each point's allowance, and
//! the corners where that line met the other faces, and the edge between them, were
//! reported. The median of the points near the line shows the fillet
//! (`faces::rounded_crease`, now also judged along a corner's edges). Run as the
//! real binary on draws of `bench --random 100 --seed 1`, scored by the bench:
//!
//! - r003 (35,697 points, σ 0.06 h, a fillet of 7.4 h at 109°): an edge of 56.7 h along the
//!   fillet, edge precision 0.954; now 1.0.
//! - r080 (31,104 points, one view with a density gradient): 4 corners found, 3 true; now
//!   the 3.

mod run_common;

use run_common::bench_random_draws;

#[test]
fn issue17_faces_beside_a_fillet_give_no_corner_and_no_edge() {
    let cases = bench_random_draws(1, &[("r003", 35_697), ("r080", 31_104)]);
    let (r003, r080) = (&cases[0], &cases[1]);

    let precision = r003["edges"]["precision"].as_f64().unwrap();
    assert!(precision >= 0.99, "r003: edge precision {precision:.3}");
    let spurious = r003["edges"]["spurious"].as_array().unwrap();
    assert!(
        spurious
            .iter()
            .all(|e| e["length_h"].as_f64().unwrap() < 10.0),
        "r003: spurious edges {spurious:?}"
    );
    let recall = r003["edges"]["recall"].as_f64().unwrap();
    assert!(recall >= 0.99, "r003: edge recall {recall:.3}");
    assert_eq!(r003["corners"]["recall"].as_f64(), Some(1.0));

    let c = &r080["corners"];
    assert_eq!(
        (c["found"].as_u64(), c["matched"].as_u64()),
        (Some(3), Some(3)),
        "r080: corners {c}"
    );
}
