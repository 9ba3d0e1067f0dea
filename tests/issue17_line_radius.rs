//! Scan lines get a neighbourhood as full as uniform sampling's, not one three line gaps
//! wide (issue 17: "scan lines ... give the same edges as uniform sampling of the same part").
//! Lines g mean spacings apart are about g² times denser along than across; the local
//! spacing is measured across them, so `features.min_radius` = 4 spacings reached 3 gaps, as
//! wide as the small faces of a part, and the edges around those faces were never segmented.
//! `scale::min_radius_on` shrinks it by √(spacing/pitch − 1), down to 3 spacings. Run as the
//! real binary on draws of `bench --random 100 --seed 1`, scored by the bench:
//!
//! - r050 (33,494 points, lines 5.1 mean spacings apart, a 2.3x density gradient): 20 of 40
//!   corners missed, edge recall 0.71 and precision 0.87; now 10 missed, 0.78 and 0.95.
//! - r081 (196,087 points, lines 7.4 apart): 3 of 16 corners missed, edge recall 0.96; now
//!   every corner and recall 1.0.
//!
//! Stop 45 (walls a few scan lines wide grow faces, `faces::small_normals`) took r050's edge
//! precision from 0.954 to 0.912: two walls of a notch (19 h wide, turning by 51° and 64°
//! from an 11 h wall between them) now grow faces, the wall between them does not, and
//! their planes' line, 8.6 h inside the scan, passes for an edge of 199 h. The bound below
//! is 0.90 since then; the edge is an open problem of issue 17 (seeds 1, 2, 3, 53, 79 and 83
//! of `bench --random 100` gain edge recall 0.000–0.010 and lose no passing case).

mod run_common;

use run_common::bench_random_draws;

#[test]
fn issue17_scan_lines_find_the_corners_of_small_faces() {
    let cases = bench_random_draws(1, &[("r050", 33_494), ("r081", 196_087)]);
    let (r050, r081) = (&cases[0], &cases[1]);
    for c in [r050, r081] {
        assert!(
            c["reproduce"].as_str().unwrap().contains("--pattern lines"),
            "{} is no longer a line scan",
            c["name"]
        );
    }

    let c = &r050["corners"];
    let missed = c["missed"].as_array().unwrap().len();
    assert!(
        missed <= 12,
        "r050: {missed} of 40 corners missed (20 before)"
    );
    let e = &r050["edges"];
    let (recall, precision) = (
        e["recall"].as_f64().unwrap(),
        e["precision"].as_f64().unwrap(),
    );
    assert!(
        recall >= 0.76,
        "r050: edge recall {recall:.3} (0.71 before)"
    );
    assert!(
        precision >= 0.90,
        "r050: edge precision {precision:.3} (0.87 before, 0.954 before stop 45)"
    );

    let c = &r081["corners"];
    assert_eq!(c["recall"].as_f64(), Some(1.0), "r081: corners {c}");
    assert_eq!(c["precision"].as_f64(), Some(1.0), "r081: corners {c}");
    let recall = r081["edges"]["recall"].as_f64().unwrap();
    assert!(
        recall >= 0.99,
        "r081: edge recall {recall:.3} (0.96 before)"
    );
}
