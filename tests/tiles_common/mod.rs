//! Helpers shared by the tiles tests (`tiles.rs`, `tiles_slurm.rs`): synthetic scans, plans
//! run through the real binary, and the comparison of a merged result with the untiled run
//! (edges and corners from report.json, rectified points by their input index).
#![allow(dead_code)] // each test file uses a different part of this module

use std::path::{Path, PathBuf};
use std::process::Command;

use sharpedge::cloud::Column;

pub const BIN: &str = env!("CARGO_BIN_EXE_sharpedge");

/// Runs `sharpedge ARGS` in `cwd`; returns (success, stderr).
pub fn sharpedge(cwd: &Path, args: &[&str]) -> (bool, String) {
    let out = Command::new(BIN)
        .current_dir(cwd)
        .args(args)
        .env_remove("RUST_LOG")
        .output()
        .expect("start sharpedge");
    (
        out.status.success(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

/// Like [`sharpedge`], panicking with stderr on failure.
pub fn ok(cwd: &Path, args: &[&str]) {
    let (ok, err) = sharpedge(cwd, args);
    assert!(ok, "sharpedge {args:?} failed: {err}");
}

/// The repository's pipeline.toml with `corners.reach` set to `reach` radii (the halo follows
/// it: a smaller reach makes tiles that read only part of a small test cloud), written as
/// `dir/pipeline.toml`.
pub fn config(dir: &Path, reach: f64) -> PathBuf {
    let text = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/pipeline.toml"))
        .expect("read pipeline.toml");
    assert!(
        text.contains("\nreach = 25.0\n"),
        "pipeline.toml's corners.reach moved"
    );
    let text = text.replace("\nreach = 25.0\n", &format!("\nreach = {reach:?}\n"));
    let path = dir.join("pipeline.toml");
    std::fs::write(&path, text).expect("write config");
    path
}

/// Number of tiles of a plan.
pub fn tile_count(plan: &Path) -> usize {
    sharpedge::tiles::Plan::load(plan)
        .expect("plan")
        .tiles
        .len()
}

/// Runs every tile of a plan with the binary, one after the other.
pub fn run_tiles(cwd: &Path, plan: &str) {
    let config = format!("{plan}/pipeline.toml");
    for t in 0..tile_count(&cwd.join(plan)) {
        ok(
            cwd,
            &[
                "-q",
                "run",
                &config,
                "--plan",
                plan,
                "--tile",
                &t.to_string(),
            ],
        );
    }
}

/// An edge or corner of report.json.
#[derive(Debug, Clone)]
pub struct Feature {
    pub a: [f64; 3],
    pub b: [f64; 3],
}

fn point(v: &serde_json::Value) -> [f64; 3] {
    let a = v.as_array().expect("point");
    [0, 1, 2].map(|k| a[k].as_f64().expect("coordinate"))
}

/// Edges (start, end) and corners (position twice) of an output folder's report.json.
pub fn features(dir: &Path) -> (Vec<Feature>, Vec<Feature>) {
    let text = std::fs::read_to_string(dir.join("report.json")).expect("report.json");
    let r: serde_json::Value = serde_json::from_str(&text).expect("json");
    let edges = r["edges"]
        .as_array()
        .expect("edges")
        .iter()
        .map(|e| Feature {
            a: point(&e["start"]),
            b: point(&e["end"]),
        })
        .collect();
    let corners = r["corners"]
        .as_array()
        .expect("corners")
        .iter()
        .map(|c| Feature {
            a: point(&c["position"]),
            b: point(&c["position"]),
        })
        .collect();
    (edges, corners)
}

fn dist(a: [f64; 3], b: [f64; 3]) -> f64 {
    ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
}

/// For each feature of `whole`, the distance to the nearest of `merged` (an edge's ends in
/// either order); the largest.
pub fn worst_match(whole: &[Feature], merged: &[Feature]) -> f64 {
    whole
        .iter()
        .map(|w| {
            merged
                .iter()
                .map(|m| {
                    dist(w.a, m.a)
                        .max(dist(w.b, m.b))
                        .min(dist(w.a, m.b).max(dist(w.b, m.a)))
                })
                .fold(f64::INFINITY, f64::min)
        })
        .fold(0.0, f64::max)
}

/// The rectified points of a merged output folder by input index (read from its
/// rectified.json and per-tile files), checking that every index appears once.
pub fn merged_points(dir: &Path, n: usize) -> Vec<[f64; 3]> {
    let text = std::fs::read_to_string(dir.join("rectified.json")).expect("rectified.json");
    let index: serde_json::Value = serde_json::from_str(&text).expect("json");
    let mut out = vec![[f64::NAN; 3]; n];
    let mut seen = vec![false; n];
    for f in index["files"].as_array().expect("files") {
        let file = dir.join(f["file"].as_str().expect("file"));
        let cloud = sharpedge::io::read(&file, &Default::default()).expect("tile file");
        let Some(Column::F64(idx)) = cloud.attribute("scalar_index").map(|a| &a.values) else {
            panic!("{}: no double scalar_index", file.display());
        };
        assert_eq!(f["points"].as_u64(), Some(cloud.len() as u64));
        for (p, &i) in cloud.positions.iter().zip(idx) {
            let i = i as usize;
            assert!(i < n && !seen[i], "point {i} missing or twice");
            seen[i] = true;
            out[i] = *p;
        }
    }
    assert!(seen.iter().all(|&s| s), "some points are in no tile file");
    out
}

/// Largest bounding box side of the points.
pub fn extent(points: &[[f64; 3]]) -> f64 {
    let (lo, hi) = sharpedge::geometry::bounds(points);
    (0..3).map(|k| hi[k] - lo[k]).fold(0.0, f64::max)
}

/// How far the merged rectified points are from the untiled run's: (largest distance,
/// points farther than `tol`).
pub fn point_differences(whole: &Path, merged: &Path, tol: f64) -> (f64, usize, usize) {
    let w = sharpedge::io::read(&whole.join("rectified.ply"), &Default::default())
        .expect("rectified.ply");
    let m = merged_points(merged, w.len());
    let mut worst = 0.0f64;
    let mut over = 0;
    for (a, b) in w.positions.iter().zip(&m) {
        let d = dist(*a, *b);
        worst = worst.max(d);
        if d > tol {
            over += 1;
        }
    }
    (worst, over, w.len())
}
