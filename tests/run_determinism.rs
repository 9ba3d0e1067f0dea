//! Determinism of `sharpedge run` through the real binary: 1 and 2 worker threads give
//! byte-identical rectified.ply and features.ply and the same report.json apart from the
//! timings and the echoed thread count, on a box and on an L-block (noise and rounded
//! edges); two runs with the same seed agree; another seed keeps the point count.

mod run_common;

use std::path::Path;

use run_common::*;

/// The three outputs of one run: rectified.ply and features.ply bytes, report.json parsed.
struct Outputs {
    rectified: Vec<u8>,
    features: Vec<u8>,
    report: serde_json::Value,
}

/// Runs `sharpedge -q run pipeline.toml --out out ARGS` in `dir` and takes the outputs away
/// (so the next run cannot be compared with a leftover).
fn run_and_take(dir: &Path, args: &[&str]) -> Outputs {
    let mut all = vec!["-q", "run", "pipeline.toml", "--out", "out"];
    all.extend_from_slice(args);
    sharpedge(dir, &all).assert_ok();
    let out = dir.join("out");
    let o = Outputs {
        rectified: std::fs::read(out.join("rectified.ply")).unwrap(),
        features: std::fs::read(out.join("features.ply")).unwrap(),
        report: report(&out),
    };
    std::fs::remove_dir_all(&out).unwrap();
    o
}

fn assert_same(a: &Outputs, b: &Outputs, what: &str) {
    // Not assert_eq!: a diff of megabytes helps nobody; say where the first difference is.
    let first_diff = |x: &[u8], y: &[u8]| x.iter().zip(y).position(|(p, q)| p != q);
    assert!(
        a.rectified == b.rectified,
        "{what}: rectified.ply differs (sizes {} and {}, first difference at byte {:?})",
        a.rectified.len(),
        b.rectified.len(),
        first_diff(&a.rectified, &b.rectified)
    );
    assert!(
        a.features == b.features,
        "{what}: features.ply differs (sizes {} and {}, first difference at byte {:?})",
        a.features.len(),
        b.features.len(),
        first_diff(&a.features, &b.features)
    );
    assert_eq!(
        without_timings(a.report.clone()),
        without_timings(b.report.clone()),
        "{what}: report.json differs beyond timings and threads"
    );
}

fn threads_do_not_change_the_result(part: &[&str]) {
    let dir = tempfile::tempdir().unwrap();
    synth(dir.path(), "scan.ply", part);
    config(dir.path(), "[input]\npath = \"scan.ply\"\n");
    let one = run_and_take(dir.path(), &["--threads", "1"]);
    let two = run_and_take(dir.path(), &["--threads", "2"]);
    assert_eq!(one.report["config"]["threads"], 1);
    assert_eq!(two.report["config"]["threads"], 2);
    // A result worth comparing: edges were found, fitted and points moved.
    let counts = &one.report["counts"];
    assert!(counts["edges"].as_u64().unwrap() > 0, "{counts}");
    assert!(counts["corners"].as_u64().unwrap() > 0, "{counts}");
    assert!(counts["moved"].as_u64().unwrap() > 0, "{counts}");
    assert_same(&one, &two, "--threads 1 vs --threads 2");
}

#[test]
fn box_is_identical_with_one_and_two_threads() {
    threads_do_not_change_the_result(BOX);
}

#[test]
fn lblock_is_identical_with_one_and_two_threads() {
    threads_do_not_change_the_result(LBLOCK);
}

#[test]
fn same_seed_same_output_other_seed_same_point_count() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    synth(d, "scan.ply", LBLOCK);
    config(d, "seed = 11\n[input]\npath = \"scan.ply\"\n");
    let a = run_and_take(d, &[]);
    let b = run_and_take(d, &[]);
    assert_eq!(a.report["config"]["seed"], 11);
    assert_same(&a, &b, "two runs with seed 11");

    config(d, "seed = 12345\n[input]\npath = \"scan.ply\"\n");
    let c = run_and_take(d, &[]);
    assert_eq!(c.report["config"]["seed"], 12345);
    let points = |o: &Outputs| {
        let h = parse_header(&o.rectified);
        h.element("vertex").count
    };
    assert_eq!(points(&c), points(&a));
    assert_eq!(c.report["counts"]["points"], a.report["counts"]["points"]);
    assert_eq!(
        c.rectified.len(),
        a.rectified.len(),
        "same points, same fields"
    );
}
