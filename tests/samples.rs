//! What a fresh clone promises: the committed pipeline.toml is the documented defaults (every
//! key, with its default value), `samples/` holds exactly what `samples/make.sh` makes, and
//! the README's first command (`sharpedge run pipeline.toml`) finds the sample box's edges
//! and corners where its ground truth puts them.

mod run_common;

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};

use run_common::sharpedge;
use serde_json::Value;
use sharpedge::config::{self, Settings};

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn read_json(path: &Path) -> Value {
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    serde_json::from_str(&text).unwrap()
}

#[test]
fn committed_pipeline_toml_holds_the_defaults() {
    let path = root().join("pipeline.toml");
    let text = std::fs::read_to_string(&path).unwrap();
    let s = config::parse(&text, Path::new("pipeline.toml")).unwrap();
    let mut expected = Settings::default();
    expected.input.path = Some(PathBuf::from("samples/box.ply"));
    assert_eq!(
        s, expected,
        "pipeline.toml sets a value other than its default"
    );
}

/// Dotted keys of the leaves of a JSON object (`fit.pso.w`).
fn leaves(v: &Value, prefix: &str, out: &mut BTreeSet<String>) {
    match v {
        Value::Object(m) => {
            for (k, x) in m {
                let key = if prefix.is_empty() {
                    k.clone()
                } else {
                    format!("{prefix}.{k}")
                };
                leaves(x, &key, out);
            }
        }
        _ => {
            out.insert(prefix.to_string());
        }
    }
}

/// Keys written in a pipeline file, set (`key = v`) or shown commented out (`# key = v`, for
/// options whose default is "none"), with their table prefix.
fn keys_in_file(text: &str) -> BTreeSet<String> {
    let mut table = String::new();
    let mut out = BTreeSet::new();
    for line in text.lines() {
        if let Some(t) = line.strip_prefix('[').and_then(|t| t.strip_suffix(']')) {
            table = format!("{t}.");
            continue;
        }
        let body = line.strip_prefix("# ").unwrap_or(line);
        let Some((k, v)) = body.split_once(" = ") else {
            continue;
        };
        let is_key = !k.is_empty()
            && k.bytes()
                .all(|b| b.is_ascii_lowercase() || b.is_ascii_digit() || b == b'_')
            && !v.trim().is_empty();
        if is_key {
            assert!(
                out.insert(format!("{table}{k}")),
                "{table}{k} appears twice in pipeline.toml"
            );
        }
    }
    out
}

#[test]
fn committed_pipeline_toml_shows_every_key() {
    let text = std::fs::read_to_string(root().join("pipeline.toml")).unwrap();
    let in_file = keys_in_file(&text);
    let mut known = BTreeSet::new();
    leaves(
        &serde_json::to_value(Settings::default()).unwrap(),
        "",
        &mut known,
    );
    // The one key whose file name differs from the settings field.
    assert!(known.remove("features.threshold"));
    known.insert("features.plane_threshold".into());
    let missing: Vec<_> = known.difference(&in_file).collect();
    let unknown: Vec<_> = in_file.difference(&known).collect();
    assert!(
        missing.is_empty() && unknown.is_empty(),
        "pipeline.toml lacks {missing:?}; shows keys that are not settings: {unknown:?}"
    );
    // Every key is commented: the line above each key is a comment (or another key of a
    // group the comment above describes).
    let lines: Vec<&str> = text.lines().collect();
    for (i, l) in lines.iter().enumerate() {
        if l.contains(" = ") && !l.starts_with('#') {
            assert!(
                i > 0 && (lines[i - 1].starts_with('#') || lines[i - 1].contains(" = ")),
                "pipeline.toml:{}: `{l}` has no comment",
                i + 1
            );
        }
    }
}

/// The `sharpedge ...` lines of samples/make.sh, as argument lists.
fn make_sh_commands() -> Vec<Vec<String>> {
    let text = std::fs::read_to_string(root().join("samples/make.sh")).unwrap();
    let cmds: Vec<Vec<String>> = text
        .lines()
        .filter_map(|l| l.strip_prefix("sharpedge "))
        .map(|l| l.split_whitespace().map(String::from).collect())
        .collect();
    assert!(
        !cmds.is_empty(),
        "samples/make.sh runs no sharpedge command"
    );
    cmds
}

#[test]
fn samples_are_what_make_sh_makes() {
    let dir = tempfile::tempdir().unwrap();
    let mut files = Vec::new();
    for args in make_sh_commands() {
        sharpedge(dir.path(), &args).assert_ok();
        let out = &args[args.iter().position(|a| a == "--out").unwrap() + 1];
        files.push(out.clone());
        files.push(out.replace(".ply", ".truth.json"));
    }
    let mut total = 0;
    for f in &files {
        let made = std::fs::read(dir.path().join(f)).unwrap();
        let committed = std::fs::read(root().join("samples").join(f))
            .unwrap_or_else(|e| panic!("samples/{f}: {e}; run samples/make.sh"));
        total += committed.len();
        assert!(
            made == committed,
            "samples/{f} is not what samples/make.sh makes now; run it again"
        );
    }
    // A few hundred KB in all: the repository stays small.
    assert!(total < 600_000, "samples/ holds {total} bytes");
}

/// The README's first command on the bundled box: every true edge and corner found, corners
/// within a fraction of the spacing, every point written back.
#[test]
fn readme_run_command_finds_the_sample_box() {
    let out = tempfile::tempdir().unwrap();
    let r = sharpedge(
        &root(),
        &[
            "-q",
            "run",
            "pipeline.toml",
            "--out",
            out.path().to_str().unwrap(),
        ],
    );
    r.assert_ok();
    let truth = read_json(&root().join("samples/box.truth.json"));
    let report = read_json(&out.path().join("report.json"));
    let h = truth["spacing"].as_f64().unwrap();
    let pos = |v: &Value| -> [f64; 3] {
        let a = v.as_array().unwrap();
        [0, 1, 2].map(|k| a[k].as_f64().unwrap())
    };
    let found: Vec<[f64; 3]> = report["corners"]
        .as_array()
        .unwrap()
        .iter()
        .map(|c| pos(&c["position"]))
        .collect();
    let true_corners = truth["corners"].as_array().unwrap();
    assert_eq!(found.len(), true_corners.len(), "{report}");
    for c in true_corners {
        let t = pos(&c["position"]);
        let d = found
            .iter()
            .map(|f| (0..3).map(|k| (f[k] - t[k]).powi(2)).sum::<f64>().sqrt())
            .fold(f64::INFINITY, f64::min);
        assert!(
            d < 0.3 * h,
            "true corner {t:?}: nearest found {:.3} h away",
            d / h
        );
    }
    assert_eq!(
        report["edges"].as_array().unwrap().len(),
        truth["edges"].as_array().unwrap().len()
    );
    let ply = std::fs::read(out.path().join("rectified.ply")).unwrap();
    let head = String::from_utf8_lossy(&ply[..ply.len().min(600)]).to_string();
    let count = truth["points"].as_u64().unwrap();
    assert!(
        head.contains(&format!("element vertex {count}\n")),
        "{head}"
    );
}
