//! The command line of `sharpedge run` through the real binary: what `-q`, the default and `-v`
//! print, `--input`/`--out`/`--threads` overriding the pipeline file, and relative paths in the
//! pipeline file resolved against the file's folder, not the working directory.

mod run_common;

use std::path::Path;

use run_common::*;

#[test]
fn quiet_prints_nothing_on_success() {
    let dir = job();
    let r = sharpedge(dir.path(), &["-q", "run", "pipeline.toml"]);
    r.assert_ok();
    assert_eq!(r.stdout, "");
    assert_eq!(r.stderr, "");
    assert_eq!(entries(&dir.path().join("out")), PLY_OUTPUTS);
    // `--quiet` after the subcommand works too (a global option).
    let r = sharpedge(dir.path(), &["run", "pipeline.toml", "--quiet"]);
    r.assert_ok();
    assert_eq!((r.stdout.as_str(), r.stderr.as_str()), ("", ""));
}

#[test]
fn summary_goes_to_stderr_with_counts_timings_and_outputs() {
    let dir = job();
    let r = sharpedge(dir.path(), &["run", "pipeline.toml"]);
    r.assert_ok();
    assert_eq!(r.stdout, "", "stdout stays free for data");
    let rep = report(&dir.path().join("out"));
    let c = &rep["counts"];
    let e = &r.stderr;
    assert!(
        e.starts_with(&format!(
            "sharpedge {}: scan.ply\n",
            env!("CARGO_PKG_VERSION")
        )),
        "{e}"
    );
    for part in [
        format!("points {}", c["points"]),
        format!("candidates {}", c["candidates"]),
        format!(
            "{} edges, {} corners; left out {} candidates",
            c["edges"], c["corners"], c["left_out"]
        ),
        format!("moved points {}", c["moved"]),
        format!("{} fit", c["failed_fits"]),
        "wrote out/rectified.ply\n".into(),
        "wrote out/features.ply\n".into(),
        "wrote out/edges.geojson\n".into(),
        "wrote out/report.json\n".into(),
    ] {
        assert!(e.contains(&part), "summary lacks `{part}`:\n{e}");
    }
    let time = e
        .lines()
        .find(|l| l.trim_start().starts_with("time "))
        .unwrap_or_else(|| panic!("no time line:\n{e}"));
    for stage in [
        "read",
        "scale",
        "neighbours",
        "features",
        "segment",
        "edges",
        "corners",
        "rectify",
        "write",
    ] {
        assert!(time.contains(&format!("{stage} ")), "{time}");
    }
    // Without -v, no log lines: the summary is the whole output (5 lines + 4 outputs).
    assert!(!e.contains("INFO"), "{e}");
    assert_eq!(e.lines().count(), 9, "{e}");
}

#[test]
fn verbose_adds_stage_log_lines() {
    let dir = job();
    let r = sharpedge(dir.path(), &["-v", "run", "pipeline.toml"]);
    r.assert_ok();
    let e = &r.stderr;
    for stage in [
        "read",
        "scale",
        "neighbours",
        "features",
        "segment",
        "edges",
        "corners",
        "rectify",
        "write",
    ] {
        assert!(
            e.lines().any(|l| l.contains(" INFO ")
                && l.ends_with(" s")
                && l.contains(&format!("{stage}: "))),
            "no log line for {stage}:\n{e}"
        );
    }
    assert!(e.contains("noise sigma"), "{e}");
    // and the summary still follows
    assert!(e.contains("wrote out/report.json"), "{e}");
    // -v and -q contradict each other: a usage error from clap, before any work.
    let r = sharpedge(
        dir.path(),
        &["-q", "-v", "run", "pipeline.toml", "--out", "o2"],
    );
    assert_eq!(r.code, Some(2), "{r:#?}");
    assert!(r.stderr.contains("cannot be used with"), "{}", r.stderr);
    assert!(!dir.path().join("o2").exists());
}

#[test]
fn input_and_out_override_the_config() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    synth(d, "other.ply", BOX);
    // The config names a file that does not exist and another output folder.
    config(
        d,
        "[input]\npath = \"missing.ply\"\n[output]\ndir = \"from_config\"\n",
    );
    let r = sharpedge(
        d,
        &[
            "-q",
            "run",
            "pipeline.toml",
            "--input",
            "other.ply",
            "--out",
            "from_cli",
        ],
    );
    r.assert_ok();
    assert!(!d.join("from_config").exists());
    assert_eq!(entries(&d.join("from_cli")), PLY_OUTPUTS);
    let rep = report(&d.join("from_cli"));
    assert_eq!(rep["input"]["path"], "other.ply");
    assert_eq!(rep["config"]["input"]["path"], "other.ply");
    assert_eq!(rep["config"]["output"]["dir"], "from_cli");
    // Without the overrides the config's missing input is what fails.
    let r = sharpedge(d, &["-q", "run", "pipeline.toml"]);
    assert_eq!(r.code, Some(1));
    assert!(
        r.stderr.contains("missing.ply: cannot open"),
        "{}",
        r.stderr
    );
}

#[test]
fn threads_override_is_echoed_in_the_report() {
    let dir = job();
    config(dir.path(), "threads = 2\n[input]\npath = \"scan.ply\"\n");
    sharpedge(dir.path(), &["-q", "run", "pipeline.toml"]).assert_ok();
    assert_eq!(report(&dir.path().join("out"))["config"]["threads"], 2);
    sharpedge(
        dir.path(),
        &["-q", "run", "pipeline.toml", "--threads", "1"],
    )
    .assert_ok();
    assert_eq!(report(&dir.path().join("out"))["config"]["threads"], 1);
}

#[test]
fn relative_paths_in_the_config_follow_the_config_folder() {
    let dir = tempfile::tempdir().unwrap();
    let root = dir.path();
    let job = root.join("jobs/a");
    std::fs::create_dir_all(&job).unwrap();
    synth(&job, "scan.ply", BOX);
    config(
        &job,
        "[input]\npath = \"scan.ply\"\n[output]\ndir = \"results\"\n",
    );
    // From the root: paths resolve against jobs/a, not the working directory.
    let r = sharpedge(root, &["run", "jobs/a/pipeline.toml"]);
    r.assert_ok();
    assert!(
        r.stderr.contains("wrote jobs/a/results/rectified.ply"),
        "{}",
        r.stderr
    );
    assert_eq!(entries(&job.join("results")), PLY_OUTPUTS);
    assert!(!root.join("results").exists());
    // From an unrelated folder with an absolute config path; the default output folder `out`
    // is next to the config too.
    let elsewhere = root.join("elsewhere");
    std::fs::create_dir(&elsewhere).unwrap();
    config(&job, "[input]\npath = \"scan.ply\"\n");
    sharpedge(
        &elsewhere,
        &["-q", "run", job.join("pipeline.toml").to_str().unwrap()],
    )
    .assert_ok();
    assert_eq!(entries(&job.join("out")), PLY_OUTPUTS);
    assert_eq!(entries(&elsewhere), Vec::<String>::new());
    // Command-line paths, by contrast, are relative to the working directory.
    std::fs::copy(job.join("scan.ply"), elsewhere.join("local.ply")).unwrap();
    sharpedge(
        &elsewhere,
        &[
            "-q",
            "run",
            job.join("pipeline.toml").to_str().unwrap(),
            "--input",
            "local.ply",
            "--out",
            "here",
        ],
    )
    .assert_ok();
    assert_eq!(entries(&elsewhere.join("here")), PLY_OUTPUTS);
    let same = |p: &Path| std::fs::read(p.join("rectified.ply")).unwrap();
    assert_eq!(same(&elsewhere.join("here")), same(&job.join("out")));
}
