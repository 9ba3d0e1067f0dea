//! `sharpedge experiment` through the real binary: the JSON contract, determinism, the SVG
//! figures written by `--out`, the text tables and the errors for bad options.

use std::path::Path;
use std::process::{Command, Output};

use serde_json::Value;

fn run(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_sharpedge"))
        .arg("experiment")
        .args(args)
        .output()
        .expect("the binary runs")
}

fn json(args: &[&str]) -> Value {
    let out = run(args);
    assert!(
        out.status.success(),
        "stderr: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    let text = String::from_utf8(out.stdout).unwrap();
    // Exactly one JSON object on stdout.
    let mut stream = serde_json::Deserializer::from_str(&text).into_iter::<Value>();
    let v = stream.next().expect("one JSON value").expect("valid JSON");
    assert!(
        stream.next().is_none(),
        "more than one JSON value on stdout"
    );
    assert!(v.is_object());
    v
}

fn num(v: &Value, path: &[&str]) -> f64 {
    let mut x = v;
    for p in path {
        x = x
            .get(p)
            .unwrap_or_else(|| panic!("missing key {path:?} in {v}"));
    }
    x.as_f64()
        .unwrap_or_else(|| panic!("{path:?} is not a number: {x}"))
}

fn check_report(v: &Value, dim: u64, trials: u64) {
    assert_eq!(v["dim"].as_u64(), Some(dim));
    assert_eq!(v["trials"].as_u64(), Some(trials));
    assert_eq!(v["failed"].as_u64(), Some(0), "{}", v["failures"]);
    for m in ["scheme1", "pso", "ga", "exact"] {
        assert!(num(v, &["mean_error", m]) > 0.0);
        assert!(num(v, &["corner_error", m]) > 0.0);
        assert!(num(v, &["time_per_fit_us", m]) > 0.0);
    }
    let (s1, pso, exact) = (
        num(v, &["mean_error", "scheme1"]),
        num(v, &["mean_error", "pso"]),
        num(v, &["mean_error", "exact"]),
    );
    assert!(
        exact <= pso && pso <= s1,
        "exact {exact} pso {pso} scheme1 {s1}"
    );
    // The swarm starts at Scheme 1's candidates: it is never worse.
    assert_eq!(num(v, &["pso_beats_scheme1"]), 1.0);
    let within = num(v, &["pso_within_1pct_of_exact"]);
    assert!((0.0..=1.0).contains(&within));
    assert!(num(v, &["pso_gap_to_exact_mean"]) >= 0.0);
    assert_eq!(num(v, &["exact_violations"]), 0.0);
    // Corners land near the true one (sides of length 10, noise up to 0.3).
    assert!(num(v, &["corner_error", "exact"]) < 0.5);
    assert!(num(v, &["iterations_to_converge", "pso"]) >= 0.0);
}

#[test]
fn json_for_one_dimension_has_the_documented_keys() {
    let v = json(&[
        "--dim", "2", "--trials", "15", "--seed", "3", "--json", "-q",
    ]);
    check_report(&v, 2, 15);
    assert_eq!(num(&v, &["pso_params", "iterations"]), 20.0);
    let v = json(&["--dim", "3", "--trials", "8", "--seed", "3", "--json", "-q"]);
    check_report(&v, 3, 8);
    assert_eq!(num(&v, &["pso_params", "iterations"]), 10.0);
}

#[test]
fn json_for_both_dimensions_is_one_object() {
    let v = json(&["--trials", "5", "--json", "-q"]);
    let runs = v["experiments"].as_array().expect("an experiments array");
    assert_eq!(runs.len(), 2);
    check_report(&runs[0], 2, 5);
    check_report(&runs[1], 3, 5);
}

/// The report without its timings, which vary from run to run.
fn untimed(mut v: Value) -> Value {
    let o = v.as_object_mut().unwrap();
    o.remove("time_per_fit_us");
    o.remove("prepare_us");
    o["joint_refinement"]
        .as_object_mut()
        .unwrap()
        .remove("time_per_fit_us");
    v
}

#[test]
fn same_seed_same_numbers() {
    let a = untimed(json(&[
        "--dim", "2", "--trials", "10", "--seed", "9", "--json", "-q",
    ]));
    let b = untimed(json(&[
        "--dim", "2", "--trials", "10", "--seed", "9", "--json", "-q",
    ]));
    assert_eq!(a, b);
    let c = untimed(json(&[
        "--dim", "2", "--trials", "10", "--seed", "10", "--json", "-q",
    ]));
    assert_ne!(a["mean_error"], c["mean_error"]);
}

/// Checks that `text` is a well-formed SVG document: one <svg> root, every tag closed in
/// order. Returns the element names seen.
fn svg_elements(text: &str) -> Vec<String> {
    let body = text.trim_start();
    let body = match body.strip_prefix("<?xml") {
        Some(rest) => &rest[rest.find("?>").expect("closed xml declaration") + 2..],
        None => body,
    };
    let mut stack: Vec<String> = Vec::new();
    let mut seen = Vec::new();
    let mut rest = body;
    while let Some(i) = rest.find('<') {
        let j = rest[i..].find('>').expect("unterminated tag") + i;
        let tag = &rest[i + 1..j];
        rest = &rest[j + 1..];
        if tag.starts_with('!') || tag.starts_with('?') {
            continue;
        }
        if let Some(name) = tag.strip_prefix('/') {
            assert_eq!(
                stack.pop().as_deref(),
                Some(name.trim()),
                "mismatched </{name}>"
            );
            continue;
        }
        let name = tag
            .split_whitespace()
            .next()
            .unwrap_or("")
            .trim_end_matches('/')
            .to_string();
        if stack.is_empty() {
            assert_eq!(name, "svg", "root element");
            assert!(seen.is_empty(), "two root elements");
        }
        seen.push(name.clone());
        if !tag.ends_with('/') {
            stack.push(name);
        }
    }
    assert!(stack.is_empty(), "unclosed elements {stack:?}");
    assert!(rest.trim().is_empty(), "text after the root element");
    seen
}

fn check_svg(path: &Path, must_have: &[&str]) {
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let elems = svg_elements(&text);
    for m in must_have {
        assert!(elems.iter().any(|e| e == m), "{}: no <{m}>", path.display());
    }
}

#[test]
fn out_writes_valid_svg_figures() {
    let dir = tempfile::TempDir::new().unwrap();
    let out = dir.path().join("figs");
    let o = run(&["--trials", "6", "--out", out.to_str().unwrap(), "-q"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    for d in ["2d", "3d"] {
        check_svg(
            &out.join(format!("convergence_{d}.svg")),
            &["polyline", "text"],
        );
        check_svg(
            &out.join(format!("pso_vs_ga_{d}.svg")),
            &["polyline", "circle"],
        );
        check_svg(&out.join(format!("fit_{d}.svg")), &["circle", "polyline"]);
    }
    let text = String::from_utf8(o.stdout).unwrap();
    assert!(
        text.contains("2D: 6 trials") && text.contains("3D: 6 trials"),
        "{text}"
    );
    assert!(
        text.contains("mean fitting error") && text.contains("Scheme 1"),
        "{text}"
    );
}

#[test]
fn bad_options_are_refused_with_a_reason() {
    let o = run(&["--trials", "0"]);
    assert!(!o.status.success());
    let e = String::from_utf8_lossy(&o.stderr);
    assert!(e.contains("--trials: must be at least 1"), "{e}");
    let o = run(&["--dim", "4"]);
    assert!(!o.status.success());
    let o = run(&["--rounding=9", "--trials", "1"]);
    assert!(!o.status.success());
    assert!(String::from_utf8_lossy(&o.stderr).contains("--rounding: must be between 0 and 5"));
    let o = run(&["--min-particles", "0", "--trials", "1"]);
    assert!(!o.status.success());
    let e = String::from_utf8_lossy(&o.stderr);
    assert!(
        e.contains("fit parameter min_particles = 0: expected at least 1"),
        "{e}"
    );
    // --out pointing at an existing file.
    let dir = tempfile::TempDir::new().unwrap();
    let file = dir.path().join("a_file");
    std::fs::write(&file, b"x").unwrap();
    let o = run(&[
        "--dim",
        "2",
        "--trials",
        "2",
        "--out",
        file.to_str().unwrap(),
        "-q",
    ]);
    assert!(!o.status.success());
    let e = String::from_utf8_lossy(&o.stderr);
    assert!(
        e.contains("a_file") && e.contains("cannot create folder"),
        "{e}"
    );
}

/// Issue 3's acceptance over 1000 trials per dimension with the paper's parameters (w 0.6,
/// c1 = c2 = 2, r ≤ 0.2, 20 / 10 iterations): PSO at least as good as Scheme 1 in ≥ 95 % of
/// trials and ≥ 20 % lower on average, within 1 % of the exact optimum in ≥ 99 %, PSO and GA
/// within a few percent of each other. (Speed is measured by `benches/fit.rs`, not here.)
#[test]
fn paper_thresholds_hold_over_1000_trials() {
    for dim in ["2", "3"] {
        let v = json(&["--dim", dim, "--trials", "1000", "--json", "-q"]);
        assert_eq!(v["seed_with_intersection"], Value::Bool(true));
        assert!(num(&v, &["pso_beats_scheme1"]) >= 0.95, "{dim}D: {v}");
        assert!(
            num(&v, &["pso_error_reduction_vs_scheme1"]) >= 0.20,
            "{dim}D: {v}"
        );
        assert!(
            num(&v, &["pso_within_1pct_of_exact"]) >= 0.99,
            "{dim}D: {v}"
        );
        assert!(num(&v, &["ga_vs_pso"]).abs() <= 0.05, "{dim}D: {v}");
    }
}

/// Regression (issue 3): with the paper's start alone (every particle on a corner-region data
/// point) a 3D vertex, which lies beyond its data, is out of the swarm's reach in 10
/// iterations for about one trial in ten; the local fits' meeting point as one more particle
/// closes that gap. `--paper-init` keeps the paper's start for reproduction.
#[test]
fn paper_init_leaves_3d_vertices_out_of_reach() {
    let seeded = json(&["--dim", "3", "--trials", "300", "--json", "-q"]);
    let paper = json(&[
        "--dim",
        "3",
        "--trials",
        "300",
        "--paper-init",
        "--json",
        "-q",
    ]);
    assert_eq!(paper["seed_with_intersection"], Value::Bool(false));
    check_report(&paper, 3, 300);
    let (a, b) = (
        num(&seeded, &["pso_within_1pct_of_exact"]),
        num(&paper, &["pso_within_1pct_of_exact"]),
    );
    assert!(a >= 0.99 && b < 0.97, "seeded {a}, paper's start {b}");
}
