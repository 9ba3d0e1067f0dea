//! `sharpedge bench`, run as the real binary on a tiny suite: the JSON's keys and values
//! against what is known of the simulated box, the table, determinism across thread counts,
//! and bad options.

use std::path::Path;
use std::process::Command;

use serde_json::Value;

fn bench(args: &[&str], dir: &Path) -> (bool, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_sharpedge"))
        .arg("bench")
        .args(args)
        .current_dir(dir)
        .output()
        .expect("running sharpedge");
    (
        out.status.success(),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

/// Runs `sharpedge ARGS` in `dir` and asserts it succeeded.
fn sharpedge_ok(args: &[&str], dir: &Path) {
    let out = Command::new(env!("CARGO_BIN_EXE_sharpedge"))
        .args(args)
        .current_dir(dir)
        .output()
        .expect("running sharpedge");
    assert!(
        out.status.success(),
        "sharpedge {args:?}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
}

fn read_json(path: &Path) -> Value {
    serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap()
}

/// Runs `sharpedge bench ARGS --out JSON` in `dir`, asserts it succeeded, and returns its
/// stdout and the JSON it wrote.
fn bench_ok(args: &[&str], dir: &Path, json: &str) -> (String, Value) {
    let mut all = args.to_vec();
    all.extend(["--out", json]);
    let (ok, out, err) = bench(&all, dir);
    assert!(ok, "{err}");
    (out, read_json(&dir.join(json)))
}

/// The names of a case's checks.
fn check_names(c: &Value) -> Vec<&str> {
    c["checks"]
        .as_array()
        .unwrap()
        .iter()
        .map(|k| k["name"].as_str().unwrap())
        .collect()
}

fn f(v: &Value) -> f64 {
    v.as_f64().unwrap_or_else(|| panic!("{v} is not a number"))
}

/// A number in [0, 1], or null (undefined).
fn share_or_null(v: &Value) {
    assert!(v.is_null() || (0.0..=1.0).contains(&f(v)), "{v}");
}

#[test]
fn tiny_box_suite_writes_sane_json_and_a_table() {
    let dir = tempfile::tempdir().unwrap();
    let (out, j) = bench_ok(
        &["--cases", "box", "--points", "20000", "--threads", "2"],
        dir.path(),
        "b.json",
    );
    assert!(
        out.contains("bench: 20000 points per case, seed 1, 2 threads"),
        "{out}"
    );
    assert!(out.lines().any(|l| l.starts_with("box ")), "{out}");
    assert!(out.contains("wrote b.json"), "{out}");

    for key in [
        "sharpedge",
        "points",
        "seed",
        "threads",
        "tolerances",
        "cases",
        "skipped",
        "seconds",
        "slowest_case",
        "passed",
        "failed",
        "settings",
    ] {
        assert!(j.get(key).is_some(), "missing {key}");
    }
    assert_eq!(j["points"], 20000);
    assert_eq!(j["threads"], 2);
    assert_eq!(j["tolerances"]["corner_h"], 3.0);
    assert_eq!(j["tolerances"]["edge_h"], 2.0);
    assert_eq!(j["cases"].as_array().unwrap().len(), 1);
    assert_eq!(j["skipped"].as_array().unwrap().len(), 0);
    assert_eq!(j["slowest_case"], "box");

    let c = &j["cases"][0];
    assert_eq!(c["name"], "box");
    assert_eq!(c["kind"], "polyhedral");
    assert!(c["error"].is_null(), "{}", c["error"]);
    let n = f(&c["points"]);
    assert!((n / 20_000.0 - 1.0).abs() < 0.02, "{n}");
    // The box is 100 x 80 x 60 (surface 37,600) sampled with h = sqrt(area / N); its 12 edges
    // are 960 long.
    let h = f(&c["spacing"]);
    assert!((h - (37_600.0f64 / 20_000.0).sqrt()).abs() < 1e-12, "{h}");
    assert_eq!(c["noise_h"], 0.15);
    assert_eq!(c["round_h"], 1.5);
    assert_eq!(c["params"]["rotate"], true);

    let corners = &c["corners"];
    assert_eq!(corners["true"], 8);
    let found = corners["found"].as_u64().unwrap();
    let matched = corners["matched"].as_u64().unwrap();
    assert!(matched <= found.min(8));
    share_or_null(&corners["recall"]);
    share_or_null(&corners["precision"]);
    assert_eq!(
        corners["missed"].as_array().unwrap().len() as u64,
        8 - matched
    );
    assert_eq!(
        corners["spurious"].as_array().unwrap().len() as u64,
        found - matched
    );
    // The oracle: planes fitted to 0.15 h noise over thousands of points per face.
    assert!(
        f(&corners["oracle_h"]["mean"]) < 0.1,
        "{}",
        corners["oracle_h"]
    );

    let edges = &c["edges"];
    assert_eq!(edges["true_segments"], 12);
    assert_eq!(edges["true_polylines"], 12);
    assert!((f(&edges["true_length_h"]) - 960.0 / h).abs() < 1e-9 * 960.0 / h);
    share_or_null(&edges["recall"]);
    share_or_null(&edges["precision"]);
    assert!(
        f(&edges["oracle_rms_h"]) < 0.05,
        "{}",
        edges["oracle_rms_h"]
    );
    assert!((f(&edges["oracle_recall"]) - 1.0).abs() < 1e-9);
    if !edges["rms_h"].is_null() {
        // Only the matched part counts: within the 2 h tolerance.
        assert!(f(&edges["rms_h"]) <= 2.0 && f(&edges["max_h"]) <= 2.0);
    }

    let r = &c["rectify"];
    assert!(r["abnormal_points"].as_u64().unwrap() > 1000);
    // Rounding 1.5 h and noise 0.15 h: the raw abnormal points are a fraction of h off.
    let before = f(&r["before_h"]);
    assert!(before > 0.1 && before < 1.0, "{before}");
    assert!(r["away_points"].as_u64().unwrap() > 10_000);

    let m = &c["measured"];
    assert!(f(&m["spacing_h"]) > 0.5 && f(&m["spacing_h"]) < 1.5, "{m}");
    assert!(f(&c["seconds"]["total"]) > 0.0);
    assert!(!c["seconds"]["stages"].as_array().unwrap().is_empty());
    assert!((f(&c["oracle_margin_h"]) - 4.5).abs() < 1e-9);

    let checks = c["checks"].as_array().unwrap();
    let names = check_names(c);
    for want in [
        "corner recall",
        "corner precision",
        "edge recall",
        "edge precision",
        "mean corner error (h)",
        "edge RMS (h)",
        "rectified / raw distance",
        "points away from edges moved",
    ] {
        assert!(names.contains(&want), "{names:?}");
    }
    let all_pass = checks.iter().all(|k| k["pass"] == true);
    assert_eq!(c["pass"], all_pass);
    assert_eq!(j["passed"], u64::from(all_pass));
    // The table's verdict agrees with the JSON.
    let verdict = if all_pass { "PASS" } else { "FAIL" };
    assert!(
        out.lines()
            .any(|l| l.starts_with("box ") && l.contains(verdict)),
        "{out}"
    );
}

/// Everything but wall times and the thread count.
fn without_times(mut j: Value) -> Value {
    j["seconds"] = Value::Null;
    j["threads"] = Value::Null;
    j["settings"]["threads"] = Value::Null;
    for c in j["cases"].as_array_mut().unwrap() {
        c["seconds"] = Value::Null;
    }
    j
}

#[test]
fn json_on_stdout_equals_the_file_and_is_the_same_for_one_and_two_threads() {
    let dir = tempfile::tempdir().unwrap();
    let args = |t: &'static str, out: &'static str| {
        [
            "--cases",
            "pyramid",
            "--points",
            "20000",
            "--seed",
            "5",
            "--threads",
            t,
            "--out",
            out,
            "--json",
            "-q",
        ]
    };
    let (ok, out1, err) = bench(&args("1", "one.json"), dir.path());
    assert!(ok, "{err}");
    let stdout: Value = serde_json::from_str(&out1).expect("stdout is the JSON");
    let one = read_json(&dir.path().join("one.json"));
    assert_eq!(stdout, one);
    assert_eq!(one["seed"], 5);
    let (ok, _, err) = bench(&args("2", "two.json"), dir.path());
    assert!(ok, "{err}");
    let two = read_json(&dir.path().join("two.json"));
    assert_eq!(without_times(one), without_times(two));
}

#[test]
fn unknown_case_is_an_error_naming_the_valid_ones() {
    let dir = tempfile::tempdir().unwrap();
    let (ok, _, err) = bench(&["--cases", "box,cube", "-q"], dir.path());
    assert!(!ok);
    assert!(err.contains("--cases: unknown case \"cube\""), "{err}");
    assert!(
        err.contains("box, lblock, step, wedge, prism6, prism8"),
        "{err}"
    );
    assert!(!dir.path().join("bench.json").exists());
}

#[test]
fn unwritable_out_folder_fails_before_running() {
    let dir = tempfile::tempdir().unwrap();
    let t = std::time::Instant::now();
    let (ok, _, err) = bench(
        &["--cases", "box", "--out", "missing/folder/b.json", "-q"],
        dir.path(),
    );
    assert!(!ok);
    assert!(
        err.contains("missing/folder: cannot write into the folder of --out"),
        "{err}"
    );
    // No case ran (a 200k box takes about a second).
    assert!(t.elapsed().as_secs_f64() < 5.0);
}

/// Runs the bench with `args` and an empty data folder, writing `s.json` in `dir`: it must
/// succeed (mesh cases are skipped with their reason, not an error). Returns stdout.
fn bench_without_data(args: &[&str], dir: &Path) -> String {
    let empty = dir.join("empty");
    std::fs::create_dir_all(&empty).unwrap();
    let mut all = args.to_vec();
    all.extend(["--data", empty.to_str().unwrap(), "--out", "s.json"]);
    let (ok, out, err) = bench(&all, dir);
    assert!(ok, "{err}");
    out
}

#[test]
fn mesh_cases_run_or_are_skipped_with_a_note() {
    let data = Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/data");
    let dir = tempfile::tempdir().unwrap();
    let out = bench_without_data(&["--cases", "fandisk"], dir.path());
    assert!(out.contains("skipped fandisk: "), "{out}");
    assert!(out.contains("fandisk.off not found"), "{out}");
    let j = read_json(&dir.path().join("s.json"));
    assert_eq!(j["cases"].as_array().unwrap().len(), 0);
    assert_eq!(j["skipped"][0]["case"], "fandisk");

    if !data.is_dir() {
        eprintln!("skipped: ../shared/data absent");
        return;
    }
    let (ok, _, err) = bench(
        &[
            "--cases",
            "fandisk",
            "--points",
            "20000",
            "--data",
            data.to_str().unwrap(),
            "--out",
            "m.json",
            "-q",
        ],
        dir.path(),
    );
    assert!(ok, "{err}");
    let j = read_json(&dir.path().join("m.json"));
    let c = &j["cases"][0];
    assert_eq!(c["kind"], "curved");
    assert!(c["error"].is_null(), "{}", c["error"]);
    // SOURCES.md: 722 sharp mesh edges in 35 polylines, 23 corners; no oracle on curves.
    // The simulator smooths the curved patches with two levels of subdivision, which splits
    // every sharp mesh edge in four.
    assert_eq!(c["edges"]["true_segments"], 4 * 722);
    assert_eq!(c["edges"]["true_polylines"], 35);
    assert_eq!(c["corners"]["true"], 23);
    assert!(c["edges"]["oracle_rms_h"].is_null());
    assert!(c["corners"]["oracle_h"].is_null());
    let names = check_names(c);
    assert!(names.contains(&"edge recall") && !names.contains(&"corner recall"));
}

#[test]
fn the_pipeline_file_is_read_and_its_errors_name_it() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("bad.toml"), "seed = 3\nbogus = 1\n").unwrap();
    let (ok, _, err) = bench(
        &["--cases", "box", "--config", "bad.toml", "-q"],
        dir.path(),
    );
    assert!(!ok);
    assert!(err.contains("bad.toml:2: bogus: unknown field"), "{err}");

    std::fs::write(dir.path().join("good.toml"), "seed = 3\n").unwrap();
    let (out, j) = bench_ok(
        &["--cases", "box-30k", "--config", "good.toml"],
        dir.path(),
        "g.json",
    );
    assert!(out.contains("config good.toml"), "{out}");
    assert_eq!(j["config"], "good.toml");
    assert_eq!(j["settings"]["seed"], 3);
    assert_eq!(j["cases"][0]["points"].as_u64().unwrap() / 1000, 29);
}

/// Issue 4's acceptance on every parametric case at the default 500,000 points (the CAD
/// meshes are the curved-edge work and have their own status): every verdict PASS — corner
/// and edge recall and precision, corner error ≤ 0.05 h and edge RMS ≤ 0.03 h at σ 0.15 h,
/// rectification ratio ≤ 0.3, no point away from the edges moved. Regression for the 30k box
/// (0.064 h before the edge's faces were shared by its slabs), the 30° wedge and the σ = 1 h
/// box (points beyond the rounding moved).
#[test]
fn issue4_parametric_suite_passes_every_threshold() {
    let dir = tempfile::tempdir().unwrap();
    let cases = "box,lblock,step,wedge,prism6,prism8,pyramid,sphere,box-noise0.5,box-noise1.0,\
                 box-30k,box-far";
    let (ok, out, err) = bench(&["--cases", cases, "--out", "all.json", "-q"], dir.path());
    assert!(ok, "{err}");
    let j = read_json(&dir.path().join("all.json"));
    let failed: Vec<String> = j["cases"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|c| c["pass"] != Value::Bool(true))
        .map(|c| format!("{}: {}", c["name"], c["checks"]))
        .collect();
    assert!(failed.is_empty(), "{failed:#?}\n{out}");
    assert_eq!(j["cases"].as_array().unwrap().len(), 12);
}

/// Issue 4's acceptance on the CAD models (curved surfaces, curved sharp edges), at the
/// bench's default 500,000 points and seed: edge recall and precision at least 0.9, and every
/// other check of the case (no point away from the edges moved, rectification ratio ≤ 0.3).
/// Regression for the faceted patches taken for edges (precision 0.66 on fandisk), arcs drawn
/// as chords, hole rims broken into pieces with virtual corners, and fillets flattened.
#[test]
fn issue4_cad_models_pass_every_threshold() {
    let data = Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/data");
    if !data.is_dir() {
        eprintln!("skipped: ../shared/data absent");
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let (ok, out, err) = bench(
        &[
            "--cases",
            "fandisk,anchor",
            "--data",
            data.to_str().unwrap(),
            "--out",
            "cad.json",
            "-q",
        ],
        dir.path(),
    );
    assert!(ok, "{err}");
    let j = read_json(&dir.path().join("cad.json"));
    let cases = j["cases"].as_array().unwrap();
    assert_eq!(cases.len(), 2, "{out}");
    for c in cases {
        let recall = c["edges"]["recall"].as_f64().unwrap();
        let precision = c["edges"]["precision"].as_f64().unwrap();
        assert!(
            recall >= 0.9 && precision >= 0.9,
            "{}: edge recall {recall}, precision {precision}",
            c["name"]
        );
        assert_eq!(
            c["pass"],
            Value::Bool(true),
            "{}: {}",
            c["name"],
            c["checks"]
        );
    }
}

/// `bench --random 3 --uniform`: three random parts under drawn scan settings, scanned
/// uniformly (the whole part seen); the JSON carries each case's seed, draw and reproduce
/// command, the summary aggregates them, and the printed command makes exactly the case's
/// scan.
#[test]
fn three_random_parts_report_their_draws_a_summary_and_reproduce_alone() {
    let dir = tempfile::tempdir().unwrap();
    let (out, j) = bench_ok(
        &[
            "--random",
            "3",
            "--points",
            "30000",
            "--seed",
            "2",
            "--threads",
            "2",
            "--uniform",
        ],
        dir.path(),
        "r.json",
    );
    assert!(
        out.contains("bench: 3 random parts, 30000..30000 points, seed 2"),
        "{out}"
    );
    assert!(
        out.contains("summary over 3 random cases (3 scored)"),
        "{out}"
    );
    let cases = j["cases"].as_array().unwrap();
    assert_eq!(cases.len(), 3);
    let mut seeds = Vec::new();
    for (i, c) in cases.iter().enumerate() {
        assert_eq!(c["name"], format!("r{i:03}"));
        assert_eq!(c["kind"], "random");
        assert!(c["error"].is_null(), "{}", c["error"]);
        assert_eq!(c["params"]["part"], "random");
        assert_eq!(c["params"]["sampling"]["points"], 30000);
        let noise = f(&c["params"]["noise"]);
        let round = f(&c["params"]["round"]);
        assert!((0.0..=0.3).contains(&noise) && (0.0..=2.0).contains(&round));
        assert_eq!(c["params"]["rotate"], true);
        let part = &c["part"];
        assert!((4..=9).contains(&part["sides"].as_u64().unwrap()), "{part}");
        // Every part has corners and edges to find; the whole part is seen.
        assert!(c["corners"]["true"].as_u64().unwrap() >= 8);
        assert_eq!(f(&c["edges"]["unseen_length_h"]), 0.0);
        let names = check_names(c);
        for want in [
            "corner recall",
            "corner precision",
            "edge recall",
            "edge precision",
            "median corner error / oracle",
            "points away from edges moved",
        ] {
            assert!(names.contains(&want), "{names:?}");
        }
        let cmd = c["reproduce"].as_str().unwrap();
        let seed = c["params"]["seed"].as_u64().unwrap();
        assert!(
            cmd.starts_with(&format!("sharpedge synth --part random --seed {seed} ")),
            "{cmd}"
        );
        assert!(out.contains(&format!("seed {seed:>20}:")), "{out}");
        if c["pass"] == false {
            assert!(out.contains(&format!("reproduce: {cmd}")), "{out}");
        }
        seeds.push(seed);
    }
    seeds.dedup();
    assert_eq!(seeds.len(), 3);
    let s = &j["summary"];
    assert_eq!(s["cases"], 3);
    assert_eq!(s["scored"], 3);
    assert_eq!(s["passed"], j["passed"]);
    for k in [
        "corner_recall",
        "corner_precision",
        "edge_recall",
        "edge_precision",
    ] {
        share_or_null(&s[k]);
    }
    // The summary's corner recall is matched / true over all cases.
    let (m, t): (u64, u64) = cases.iter().fold((0, 0), |(m, t), c| {
        (
            m + c["corners"]["matched"].as_u64().unwrap(),
            t + c["corners"]["true"].as_u64().unwrap(),
        )
    });
    assert!((f(&s["corner_recall"]) - m as f64 / t as f64).abs() < 1e-12);

    // The first case alone, through `synth`: the same number of points.
    let cmd = cases[0]["reproduce"].as_str().unwrap();
    let args: Vec<&str> = cmd.split(' ').skip(1).collect();
    sharpedge_ok(&args, dir.path());
    let truth = read_json(&dir.path().join("case.truth.json"));
    assert_eq!(truth["points"], cases[0]["points"]);
    assert_eq!(truth["part"], "random");
    assert_eq!(truth["random"], cases[0]["part"]);
}

/// `bench --random` draws a sampling pattern per case (issue 17 item 7): the drawn patterns
/// are in the JSON, and the reproduce command of a case scanned in a pattern makes exactly
/// its scan.
#[test]
fn random_parts_are_scanned_in_drawn_patterns_and_reproduce_alone() {
    let dir = tempfile::tempdir().unwrap();
    let (_, j) = bench_ok(
        &[
            "--random",
            "8",
            "--points",
            "30000",
            "--seed",
            "5",
            "--threads",
            "2",
        ],
        dir.path(),
        "r.json",
    );
    let cases = j["cases"].as_array().unwrap();
    let patterned: Vec<&Value> = cases
        .iter()
        .filter(|c| {
            // A uniform scan has no `scan` in its params (see SynthParams::scan).
            let p = &c["params"]["scan"]["pattern"];
            p.is_string() && p != "uniform"
        })
        .collect();
    assert!(
        !patterned.is_empty(),
        "8 draws at 60 % non-uniform: {:?}",
        cases
            .iter()
            .map(|c| c["params"]["scan"]["pattern"].clone())
            .collect::<Vec<_>>()
    );
    let c = patterned[0];
    let pattern = c["params"]["scan"]["pattern"].as_str().unwrap();
    let cmd = c["reproduce"].as_str().unwrap();
    assert!(cmd.contains(&format!("--pattern {pattern}")), "{cmd}");
    let args: Vec<&str> = cmd.split(' ').skip(1).collect();
    sharpedge_ok(&args, dir.path());
    let truth = read_json(&dir.path().join("case.truth.json"));
    assert_eq!(truth["points"], c["points"], "{cmd}");
    // ... and `run` on it with the default settings gives what the bench scored: the cloud
    // is written in double, so the pipeline sees the bench's coordinates bit for bit
    // (issue 17: reproduced in float, seed 1's r037 moved 3,001 points, the bench 12,291).
    let header = std::fs::read(dir.path().join("case.ply")).unwrap();
    assert!(
        String::from_utf8_lossy(&header[..400]).contains("property double x"),
        "{cmd}"
    );
    std::fs::write(
        dir.path().join("p.toml"),
        "[input]\npath = \"case.ply\"\n[output]\ndir = \"out\"\n",
    )
    .unwrap();
    sharpedge_ok(&["run", "p.toml", "-q"], dir.path());
    let report = read_json(&dir.path().join("out/report.json"));
    assert_eq!(
        report["counts"]["moved"], c["rectify"]["moved_points"],
        "{cmd}"
    );
    assert_eq!(report["counts"]["edges"], c["edges"]["found"], "{cmd}");
    assert_eq!(report["counts"]["corners"], c["corners"]["found"], "{cmd}");
}

/// `--random N --cases rNNN` reruns one drawn case alone (the same draw as in the whole run);
/// a name outside the draw is refused with the drawn range.
#[test]
fn random_cases_are_selected_by_name() {
    let dir = tempfile::tempdir().unwrap();
    let args = [
        "--random",
        "3",
        "--points",
        "30000",
        "--seed",
        "2",
        "--uniform",
    ];
    let (_, all) = bench_ok(&args, dir.path(), "all.json");
    let mut one_args = args.to_vec();
    one_args.extend(["--cases", "r002"]);
    let (_, one) = bench_ok(&one_args, dir.path(), "one.json");
    let cases = one["cases"].as_array().unwrap();
    assert_eq!(cases.len(), 1);
    assert_eq!(cases[0]["name"], "r002");
    assert_eq!(cases[0]["params"], all["cases"][2]["params"]);
    assert_eq!(cases[0]["corners"], all["cases"][2]["corners"]);

    let (ok, _, err) = bench(&["--random", "2", "--cases", "r005"], dir.path());
    assert!(!ok);
    assert!(
        err.contains("no random case named 'r005'") && err.contains("r000..r001"),
        "{err}"
    );
}

/// The checks of a scored case with their values: the four detection checks are present and
/// every recall and precision is a share.
fn assert_scored_shares(c: &Value) {
    assert!(c["error"].is_null(), "{}: {}", c["name"], c["error"]);
    for k in ["recall", "precision"] {
        share_or_null(&c["corners"][k]);
        share_or_null(&c["edges"][k]);
    }
    let names = check_names(c);
    for n in [
        "corner recall",
        "corner precision",
        "edge recall",
        "edge precision",
    ] {
        assert!(names.contains(&n), "{}: {names:?}", c["name"]);
    }
}

#[test]
fn patterns_mode_scores_every_part_under_every_pattern() {
    let dir = tempfile::tempdir().unwrap();
    let (out, j) = bench_ok(
        &["--patterns", "--points", "20000", "--threads", "2"],
        dir.path(),
        "p.json",
    );
    assert!(
        out.contains("bench: sampling patterns, 20000 points per case"),
        "{out}"
    );
    // The part x pattern table.
    assert!(
        out.lines().any(|l| l.starts_with("part ")
            && [
                "uniform", "lines3", "lines10", "grid", "views3", "view", "density4"
            ]
            .iter()
            .all(|p| l.contains(p))),
        "{out}"
    );
    for part in ["box", "lblock", "prism8"] {
        assert!(
            out.lines().any(|l| l.starts_with(&format!("{part} "))),
            "{out}"
        );
    }
    assert_eq!(j["mode"], "patterns");
    let cases = j["cases"].as_array().unwrap();
    assert_eq!(cases.len(), 21);
    for c in cases {
        assert_eq!(c["kind"], "pattern");
        assert_scored_shares(c);
        let name = c["name"].as_str().unwrap();
        let pattern = &c["params"]["scan"]["pattern"];
        // One-view and multi-view scans: a border score, and some corners and edge length
        // left out because a face of them was not scanned; the uniform scan sees everything.
        if name.ends_with("/view") || name.ends_with("/views3") {
            assert_eq!(pattern, "view", "{name}");
            let b = &c["border"];
            assert!(b["border_points"].as_u64().unwrap() > 100, "{name}: {b}");
            assert!(f(&b["found_on_border_h"]) >= 0.0, "{name}: {b}");
            assert!(c["corners"]["unseen"].as_u64().unwrap() > 0, "{name}");
            assert!(f(&c["edges"]["unseen_length_h"]) > 0.0, "{name}");
            let names = check_names(c);
            assert!(
                names.contains(&"found edge on scan borders (h)"),
                "{names:?}"
            );
        } else {
            assert!(c.get("border").is_none(), "{name}");
        }
        if name.ends_with("/uniform") {
            assert!(pattern.is_null(), "{name}: {pattern}");
            assert_eq!(c["corners"]["unseen"], 0, "{name}");
            assert_eq!(f(&c["edges"]["unseen_length_h"]), 0.0, "{name}");
        }
        if name.ends_with("/lines10") {
            assert_eq!(c["params"]["scan"]["line_gap"], 10.0);
        }
    }
}

/// The CAD check's cases in their order: each mesh with its facets, then subdivided.
const CAD_CASES: [&str; 6] = [
    "fandisk-s0",
    "fandisk-s2",
    "anchor-s0",
    "anchor-s2",
    "joint-s0",
    "joint-s2",
];

#[test]
fn cad_mode_runs_each_mesh_twice_or_skips_with_a_note() {
    let dir = tempfile::tempdir().unwrap();
    let out = bench_without_data(&["--cad"], dir.path());
    for name in CAD_CASES {
        assert!(out.contains(&format!("skipped {name}: ")), "{out}");
    }
    assert!(out.contains("joint.off not found"), "{out}");
    let j = read_json(&dir.path().join("s.json"));
    assert_eq!(j["cases"].as_array().unwrap().len(), 0);
    assert_eq!(j["skipped"].as_array().unwrap().len(), 6);

    let data = Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/data");
    if !data.is_dir() {
        eprintln!("skipped: ../shared/data absent");
        return;
    }
    let (out, j) = bench_ok(
        &[
            "--cad",
            "--points",
            "20000",
            "--threads",
            "2",
            "--data",
            data.to_str().unwrap(),
        ],
        dir.path(),
        "c.json",
    );
    assert!(
        out.contains("bench: CAD meshes, 20000 points per case"),
        "{out}"
    );
    assert_eq!(j["mode"], "cad");
    let cases = j["cases"].as_array().unwrap();
    let names: Vec<&str> = cases.iter().map(|c| c["name"].as_str().unwrap()).collect();
    assert_eq!(names, CAD_CASES);
    for c in cases {
        assert_eq!(c["kind"], "cad");
        assert_scored_shares(c);
        assert_eq!(c["params"]["sharp_angle"], 30.0);
        assert!(f(&c["edges"]["crease_length_h"]) >= 0.0);
        let level = if c["name"].as_str().unwrap().ends_with("s0") {
            0
        } else {
            2
        };
        assert_eq!(c["params"]["subdivide"], level);
        // SOURCES.md: fandisk has 23 corners; nothing is hidden from a uniform scan.
        if c["name"].as_str().unwrap().starts_with("fandisk") {
            assert_eq!(c["corners"]["true"], 23);
            assert_eq!(c["corners"]["unseen"], 0);
        }
    }
}

#[test]
fn patterns_and_cases_do_not_go_together() {
    let dir = tempfile::tempdir().unwrap();
    let (ok, _, err) = bench(&["--patterns", "--cases", "box"], dir.path());
    assert!(!ok);
    assert!(
        err.contains("--patterns") && err.contains("--cases"),
        "{err}"
    );
}
