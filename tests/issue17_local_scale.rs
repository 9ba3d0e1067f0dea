//! Issue 17 (every scan a user brings): with one cloud-wide spacing, a scan sampled in lines
//! (dense along each line, sparse across) gave no edge at all, because the measured spacing was
//! the along-line distance and every neighbourhood a line. With each point's scale measured
//! across the pattern (`stages::scale`), the box scanned in lines 3 and 10 spacings apart gives
//! its 12 edges and 8 corners at their true positions, as its uniform scan does.

mod run_common;

use run_common::{Case, report, synth};

/// Runs the default pipeline on the box scanned in lines `gap` along-line spacings apart and
/// returns (found edges, corner errors to the nearest true corner, the line gap) in model units.
fn lines_box(gap: &str, points: &str) -> (usize, Vec<f64>, f64) {
    let c = Case::new();
    let cloud = synth(
        c.path(),
        "lines.ply",
        &[
            "--part",
            "box",
            "--pattern",
            "lines",
            "--line-gap",
            gap,
            "--points",
            points,
            "--noise",
            "0.1",
            "--seed",
            "11",
        ],
    );
    c.run(cloud.to_str().unwrap(), &["-q"]).assert_ok();
    let report = report(&c.out());
    let truth: serde_json::Value =
        serde_json::from_slice(&std::fs::read(c.path().join("lines.truth.json")).unwrap()).unwrap();
    let pos = |v: &serde_json::Value| -> Vec<f64> {
        v["position"]
            .as_array()
            .unwrap()
            .iter()
            .map(|x| x.as_f64().unwrap())
            .collect()
    };
    let truth_corners: Vec<Vec<f64>> = truth["corners"]
        .as_array()
        .unwrap()
        .iter()
        .map(pos)
        .collect();
    let errors = truth_corners
        .iter()
        .map(|t| {
            report["corners"]
                .as_array()
                .unwrap()
                .iter()
                .map(|c| {
                    let p = pos(c);
                    (0..3).map(|k| (p[k] - t[k]).powi(2)).sum::<f64>().sqrt()
                })
                .fold(f64::INFINITY, f64::min)
        })
        .collect();
    let gap_len = gap.parse::<f64>().unwrap() * truth["spacing"].as_f64().unwrap();
    (report["edges"].as_array().unwrap().len(), errors, gap_len)
}

#[test]
fn issue17_box_in_scan_lines_ten_spacings_apart_gives_its_edges_and_corners() {
    let (edges, errors, gap) = lines_box("10", "60000");
    assert_eq!(edges, 12, "corner errors {errors:?}");
    assert_eq!(errors.len(), 8);
    for e in &errors {
        assert!(
            *e < 0.1 * gap,
            "a corner {e} from the truth, line gap {gap}: {errors:?}"
        );
    }
}

#[test]
fn issue17_box_in_scan_lines_three_spacings_apart_gives_its_edges_and_corners() {
    let (edges, errors, gap) = lines_box("3", "60000");
    assert_eq!(edges, 12, "corner errors {errors:?}");
    for e in &errors {
        assert!(
            *e < 0.1 * gap,
            "a corner {e} from the truth, line gap {gap}: {errors:?}"
        );
    }
}
