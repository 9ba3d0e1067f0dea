//! Issue 12, degenerate clouds: `sharpedge info` and `run` on clouds that are readable but
//! degenerate (massive duplicates, a float file far from the origin that collapses onto one
//! position, two positions only, tiny and huge scales, coordinates beyond what the stages can
//! compute with, a line), through the real binary. Each case asserts what a user checks: the
//! duplicates reported and collapsed, the same edges and corners as the clean cloud, or the
//! error naming the file and the fix. (Before the fix these inputs took 25 s to over two
//! minutes at 50,000–100,000 points; the tests assert the behaviour, not a time.)

mod run_common;

use std::path::Path;

use run_common::*;
use serde_json::Value;
use sharpedge::io::{self, PlyEncoding, PlyWriteOptions, Precision};

/// `sharpedge info --json FILE` in `dir`, checked to succeed.
fn info_json(dir: &Path, file: &str) -> Value {
    let r = sharpedge(dir, &["info", "--json", file]);
    r.assert_ok();
    serde_json::from_str(&r.stdout).unwrap()
}

fn assert_contains(text: &str, want: &str) {
    assert!(text.contains(want), "`{text}` should contain `{want}`");
}

/// `sharpedge -q run pipeline.toml --input INPUT --out OUT` in the case's folder, checked to
/// succeed; returns its report.
fn run_ok(c: &Case, input: &str, out: &str) -> Value {
    let r = sharpedge(
        c.path(),
        &["-q", "run", "pipeline.toml", "--input", input, "--out", out],
    );
    r.assert_ok();
    report(&c.path().join(out))
}

/// The noisy, rounded, rotated box, smaller than `BOX` so each test takes a second.
const SMALL_BOX: &[&str] = &[
    "--part", "box", "--points", "20000", "--noise", "0.15", "--round", "1.5", "--rotate",
    "--double",
];

/// A case holding `SMALL_BOX` as box.ply, its points and the report of its run into `unit`.
fn small_box_case() -> (Case, Vec<[f64; 3]>, Value) {
    let c = Case::new();
    let scan = synth(c.path(), "box.ply", SMALL_BOX);
    let pts = read_cloud(&scan).positions;
    let unit = run_ok(&c, "box.ply", "unit");
    (c, pts, unit)
}

/// A run's edges and corners with every position scaled by `s`, for comparing runs on one
/// cloud at two scales.
fn corners_scaled(rep: &Value, s: f64) -> Vec<[f64; 3]> {
    let mut v: Vec<[f64; 3]> = rep["corners"]
        .as_array()
        .unwrap()
        .iter()
        .map(|c| {
            let p = &c["position"];
            [0, 1, 2].map(|k| p[k].as_f64().unwrap() * s)
        })
        .collect();
    v.sort_by(|a, b| a.partial_cmp(b).unwrap());
    v
}

/// The same number of corners, each within `tol` of its counterpart (both sorted).
fn assert_corners_near(got: &[[f64; 3]], want: &[[f64; 3]], tol: f64) {
    assert_eq!(got.len(), want.len());
    for (g, w) in got.iter().zip(want) {
        let d = (0..3).map(|k| (g[k] - w[k]).powi(2)).sum::<f64>().sqrt();
        assert!(d < tol, "corner {g:?} vs {w:?}");
    }
}

#[test]
fn copies_of_one_point_are_analysed_once_and_get_its_result() {
    let c = Case::new();
    let scan = synth(c.path(), "box.ply", SMALL_BOX);
    let once = read_cloud(&scan).positions;
    // 30,000 copies of one point, spread through the file.
    let copied = 7;
    let mut many = Vec::new();
    for (i, p) in once.iter().enumerate() {
        many.push(*p);
        if i % 2 == 0 && many.len() < once.len() + 30_000 {
            many.extend(std::iter::repeat_n(once[copied], 3));
        }
    }
    let copies = many.len() - once.len();
    write_raw_ply(&c.path().join("many.ply"), &many);

    let r = c.run("many.ply", &[]);
    r.assert_ok();
    assert_contains(
        &r.stderr,
        &format!(
            "many.ply: {copies} of {} points repeat the position of an earlier point",
            many.len()
        ),
    );
    let got = report(&c.out());
    let want = run_ok(&c, "box.ply", "once");
    // The copies add nothing: the same edges and corners, bit for bit.
    assert!(want["corners"].as_array().unwrap().len() >= 6, "{want:#}");
    assert_eq!(got["edges"], want["edges"]);
    assert_eq!(got["corners"], want["corners"]);
    assert_eq!(got["counts"]["points"], many.len());

    // Every copy carries the copied point's result; unmoved points keep their coordinates.
    let rect = read_cloud(&c.out().join("rectified.ply"));
    let moved = column(&rect, "scalar_moved");
    let edge = column(&rect, "scalar_edge_id");
    let first = many.iter().position(|p| *p == once[copied]).unwrap();
    for (i, p) in many.iter().enumerate() {
        if *p == once[copied] {
            assert_eq!(rect.positions[i], rect.positions[first], "copy {i}");
            assert_eq!((moved[i], edge[i]), (moved[first], edge[first]), "copy {i}");
        } else if moved[i] == 0.0 {
            assert_eq!(rect.positions[i], *p, "unmoved point {i}");
        }
    }
}

#[test]
fn info_counts_copies_and_measures_the_spacing_of_distinct_positions() {
    let c = Case::new();
    let scan = synth(c.path(), "box.ply", SMALL_BOX);
    let once = read_cloud(&scan).positions;
    let mut many = once.clone();
    many.extend(std::iter::repeat_n(once[0], 50_000));
    write_raw_ply(&c.path().join("many.ply"), &many);

    let got = info_json(c.path(), "many.ply");
    let want = info_json(c.path(), "box.ply");
    assert_eq!(got["points"], many.len());
    assert_eq!(got["duplicates"], 50_000);
    assert_eq!(want["duplicates"], 0);
    assert_eq!(got["mean_spacing"], want["mean_spacing"]);
    let text = sharpedge(c.path(), &["info", "many.ply"]);
    text.assert_ok();
    assert_contains(
        &text.stdout,
        &format!(
            "points:      {} (50000 at the position of an earlier point)\n",
            many.len()
        ),
    );
}

/// Writes a binary little-endian PLY with float x, y, z (sharpedge's writer).
fn write_float_ply(path: &Path, points: &[[f64; 3]]) {
    let opts = PlyWriteOptions {
        encoding: PlyEncoding::BinaryLittleEndian,
        precision: Precision::F32,
    };
    io::write_ply(path, points, &[], &[], &opts).unwrap();
}

#[test]
fn float_file_far_from_the_origin_collapsed_to_one_position() {
    // At 1e12 a float's step is 65,536: a 100-unit part stored as float is one position.
    let c = Case::new();
    let scan = synth(c.path(), "box.ply", SMALL_BOX);
    let far: Vec<[f64; 3]> = read_cloud(&scan)
        .positions
        .iter()
        .map(|p| p.map(|x| x + 1e12))
        .collect();
    write_float_ply(&c.path().join("far.ply"), &far);
    let n = far.len();

    let info = info_json(c.path(), "far.ply");
    assert_eq!(info["points"], n);
    assert_eq!(info["duplicates"], n - 1);
    assert_eq!(info["mean_spacing"], Value::Null);
    assert_eq!(info["bbox"]["min"][0], 999_999_995_904.0);
    assert_eq!(info["bbox"]["min"], info["bbox"]["max"]);

    let r = c.run("far.ply", &["-q"]);
    assert_failed_cleanly(
        &r,
        &[&format!(
            "far.ply: all {n} points are identical (999999995904, 999999995904, 999999995904)"
        )],
        &c.out(),
    );
}

#[test]
fn two_positions_only_are_no_surface() {
    let c = Case::new();
    let two: Vec<[f64; 3]> = (0..40_000)
        .map(|i| {
            if i % 2 == 0 {
                [0.0; 3]
            } else {
                [1.0, 2.0, 2.0]
            }
        })
        .collect();
    write_raw_ply(&c.path().join("two.ply"), &two);
    let info = info_json(c.path(), "two.ply");
    assert_eq!(info["duplicates"], 39_998);
    assert_eq!(info["mean_spacing"], 3.0);
    let r = c.run("two.ply", &[]);
    assert_failed_cleanly(
        &r,
        &["two.ply: the cloud has only 2 distinct positions (40000 points)"],
        &c.out(),
    );
}

#[test]
fn tiny_and_huge_scales_give_the_edges_and_corners_of_the_unscaled_part() {
    let (c, pts, unit) = small_box_case();
    let want = corners_scaled(&unit, 1.0);
    assert_eq!(want.len(), 8, "{unit:#}");
    let unit_spacing = info_json(c.path(), "box.ply")["mean_spacing"]
        .as_f64()
        .unwrap();
    for s in [1e-30, 1e30] {
        let name = format!("box{s:e}.ply");
        let scaled: Vec<[f64; 3]> = pts.iter().map(|p| p.map(|x| x * s)).collect();
        write_raw_ply(&c.path().join(&name), &scaled);

        let spacing = info_json(c.path(), &name)["mean_spacing"].as_f64().unwrap();
        assert!(
            (spacing / s / unit_spacing - 1.0).abs() < 1e-6,
            "{name}: spacing {spacing} vs {unit_spacing}"
        );

        let rep = run_ok(&c, &name, &format!("out{s:e}"));
        assert_eq!(rep["edges"].as_array().unwrap().len(), 12, "{name}");
        assert_eq!(rep["counts"]["moved"], unit["counts"]["moved"], "{name}");
        let got = corners_scaled(&rep, 1.0 / s);
        for (g, w) in got.iter().zip(&want) {
            let d = (0..3).map(|k| (g[k] - w[k]).powi(2)).sum::<f64>().sqrt();
            assert!(d < 1e-9, "{name}: corner {g:?} vs {w:?}");
        }
    }
}

#[test]
fn coordinates_beyond_what_floats_hold_are_described_and_refused() {
    let c = Case::new();
    let scan = synth(c.path(), "box.ply", SMALL_BOX);
    let pts = read_cloud(&scan).positions;
    for (s, fact) in [
        (1e300, "model units, more than the 1e35"),
        (1e-320, "model units apart, less than the 1e-35"),
    ] {
        let name = format!("box{s:e}.ply");
        let scaled: Vec<[f64; 3]> = pts.iter().map(|p| p.map(|x| x * s)).collect();
        write_raw_ply(&c.path().join(&name), &scaled);
        // info describes the file: a bounding box and a spacing at the file's scale.
        let info = info_json(c.path(), &name);
        assert_eq!(info["points"], pts.len(), "{name}");
        let spacing = info["mean_spacing"].as_f64().unwrap();
        assert!(spacing > 0.0 && spacing.is_finite(), "{name}: {spacing}");
        assert!(spacing / s > 0.1 && spacing / s < 10.0, "{name}: {spacing}");
        // run refuses, naming the file and the fix.
        let r = c.run(&name, &[]);
        assert_failed_cleanly(
            &r,
            &[&format!("{name}: "), fact, "scale the coordinates"],
            &c.out(),
        );
    }
}

#[test]
fn identical_points_are_described() {
    let c = Case::new();
    write_raw_ply(&c.path().join("same.ply"), &[[1.5, -2.0, 3.25]; 60_000]);
    let r = sharpedge(c.path(), &["info", "same.ply"]);
    r.assert_ok();
    assert_contains(
        &r.stdout,
        "points:      60000 (59999 at the position of an earlier point)\n",
    );
    assert!(
        r.stdout
            .ends_with("spacing:     none (fewer than two distinct points)\n"),
        "{}",
        r.stdout
    );
}

#[test]
fn a_far_outlier_leaves_the_part_measured_and_its_edges_found() {
    // One point 1e12 away from a 100-unit part: the k-d tree's f32 coordinates held the part
    // in a few float steps (info read every point per query; run failed to measure the
    // spacing), and the grid's radius and ray queries walked 2^21 cells a side.
    let (c, mut pts, unit) = small_box_case();
    let unit_spacing = info_json(c.path(), "box.ply")["mean_spacing"]
        .as_f64()
        .unwrap();
    pts.push([1e12, 1e12, 1e12]);
    write_raw_ply(&c.path().join("far.ply"), &pts);
    // The outlier is no sample of the spacing (the tree's other frame rounds differently).
    let spacing = info_json(c.path(), "far.ply")["mean_spacing"]
        .as_f64()
        .unwrap();
    assert!(
        (spacing - unit_spacing).abs() < 1e-6 * unit_spacing,
        "{spacing} vs {unit_spacing}"
    );
    let rep = run_ok(&c, "far.ply", "far");
    assert_eq!(rep["edges"].as_array().unwrap().len(), 12);
    assert_corners_near(
        &corners_scaled(&rep, 1.0),
        &corners_scaled(&unit, 1.0),
        0.05,
    );
}

#[test]
fn where_a_far_outlier_lies_changes_nothing_in_the_parts_edges_and_corners() {
    // One point 1e12 above, 1e15 below or 1e30 above a part, or two of them: the neighbour
    // grid's cells follow the part's radius whatever the cloud's extent, in coordinates
    // local to the part, so the part's edges and corners are the same in every case. (With
    // 2^21 cells over the box, local to its low corner, the part sat in one cell whose size
    // and offsets depended on the outlier: the corners moved with it, and every radius
    // query read the whole part.)
    let (c, pts, unit) = small_box_case();
    let with = |far: &[[f64; 3]], name: &str| {
        let mut all = pts.clone();
        all.extend_from_slice(far);
        write_raw_ply(&c.path().join(format!("{name}.ply")), &all);
        let rep = run_ok(&c, &format!("{name}.ply"), name);
        (corners_scaled(&rep, 1.0), rep["edges"].clone())
    };
    let (above, edges) = with(&[[1e12, 1e12, 1e12]], "above");
    assert_eq!(edges.as_array().unwrap().len(), 12);
    for (far, name) in [
        (&[[-1e15, -1e15, -1e15]][..], "below"),
        (&[[1e30, 0.0, 1e30]], "beyond"),
        (&[[-1e15, -1e15, -1e15], [1e30, 0.0, 1e30]], "both"),
    ] {
        let (corners, e) = with(far, name);
        assert_eq!(corners, above, "{name}");
        assert_eq!(e, edges, "{name}");
    }
    assert_corners_near(&above, &corners_scaled(&unit, 1.0), 0.05);
}

#[test]
fn near_copies_of_one_point_leave_the_parts_spacing_edges_and_corners() {
    // 5,000 distinct points within 1e-9 of one point of the part: the k-d tree's f32
    // coordinates merged them into one (every query among them read all of them); in f64
    // their nearest distances are a billion times below the spacing and are left out of it.
    let (c, mut pts, unit) = small_box_case();
    let spacing = |file: &str| info_json(c.path(), file)["mean_spacing"].as_f64().unwrap();
    let at = pts[100];
    pts.extend((0..5000).map(|i| {
        let t = f64::from(i) / 5000.0;
        [
            at[0] + 1e-9 * t,
            at[1] + 1e-9 * (7.0 * t).fract(),
            at[2] + 1e-9 * (13.0 * t).fract(),
        ]
    }));
    write_raw_ply(&c.path().join("near.ply"), &pts);
    let (got, want) = (spacing("near.ply"), spacing("box.ply"));
    assert!((got - want).abs() < 1e-3 * want, "{got} vs {want}");
    let rep = run_ok(&c, "near.ply", "near");
    assert_eq!(rep["edges"].as_array().unwrap().len(), 12);
    assert_corners_near(&corners_scaled(&rep, 1.0), &corners_scaled(&unit, 1.0), 0.1);
}

#[test]
fn issue12_crowded_points_beside_a_box_leave_its_edges_and_corners() {
    // 15,000 distinct points within 1e-3 of the middle of a face (a tenth of a spacing):
    // before crowded cells were thinned every radius query around them read all of them.
    let (c, pts, unit) = small_box_case();
    let n = pts.len() as f64;
    let centre = [0, 1, 2].map(|k| pts.iter().map(|p| p[k]).sum::<f64>() / n);
    let dist = |p: &[f64; 3]| (0..3).map(|k| (p[k] - centre[k]).powi(2)).sum::<f64>();
    let at = *pts
        .iter()
        .min_by(|a, b| dist(a).total_cmp(&dist(b)))
        .unwrap();
    let mut state = 7u64;
    let mut next = move || {
        state = state
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1_442_695_040_888_963_407);
        (state >> 11) as f64 / (1u64 << 53) as f64 - 0.5
    };
    let mut crowded = pts.clone();
    crowded.extend((0..15_000).map(|_| [0, 1, 2].map(|k| at[k] + 2e-3 * next())));
    write_raw_ply(&c.path().join("crowded.ply"), &crowded);

    let r = sharpedge(
        c.path(),
        &[
            "-v",
            "run",
            "pipeline.toml",
            "--input",
            "crowded.ply",
            "--out",
            "crowd",
        ],
    );
    r.assert_ok();
    assert_contains(&r.stderr, "crowded cells");
    let got = report(&c.path().join("crowd"));
    let spacing = unit["scale"]["spacing"].as_f64().unwrap();
    assert_eq!(
        got["edges"].as_array().unwrap().len(),
        unit["edges"].as_array().unwrap().len()
    );
    assert_corners_near(
        &corners_scaled(&got, 1.0),
        &corners_scaled(&unit, 1.0),
        0.05 * spacing,
    );
    // The crowd lies on a face, far from every edge: its points are not moved.
    let rect = read_cloud(&c.path().join("crowd").join("rectified.ply"));
    for (i, p) in crowded.iter().enumerate().skip(pts.len()) {
        assert_eq!(rect.positions[i], *p, "crowd point {i}");
    }
}
