//! The output contract of `sharpedge run` (DESIGN.md, "Output contract"), checked on the files
//! the real binary writes for a synthetic box: rectified.ply keeps every input point in input
//! order, untouched points bit for bit, with the inspection fields and the input's own
//! attributes; features.ply has `element edge` with in-range `int vertex1, vertex2`;
//! report.json has the documented keys. Also a box 4,000,000 units from the origin.

mod run_common;

use std::path::Path;

use run_common::*;
use serde_json::Value;
use sharpedge::io::{self, PlyEncoding, PlyWriteOptions, Precision};
use sharpedge::{Attribute, Column};

fn xyz(v: &Value) -> [f64; 3] {
    let a = v
        .as_array()
        .unwrap_or_else(|| panic!("{v} is not [x, y, z]"));
    assert_eq!(a.len(), 3, "{v}");
    [0, 1, 2].map(|k| a[k].as_f64().unwrap())
}

fn dist(a: [f64; 3], b: [f64; 3]) -> f64 {
    ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
}

/// The synth box with attributes of its own: `intensity` (ushort), `red` (uchar: clashes with
/// sharpedge's colour, so it must come back as `input_red`) and `confidence` (double).
fn box_with_attributes(dir: &Path) -> sharpedge::Cloud {
    let scan = synth(dir, "plain.ply", BOX);
    let mut cloud = read_cloud(&scan);
    let n = cloud.len();
    cloud.attributes = vec![
        Attribute {
            name: "intensity".into(),
            values: Column::U16((0..n).map(|i| (i * 7 % 65_521) as u16).collect()),
        },
        Attribute {
            name: "red".into(),
            values: Column::U8((0..n).map(|i| (i % 251) as u8).collect()),
        },
        Attribute {
            name: "confidence".into(),
            values: Column::F64((0..n).map(|i| 1.0 / (i as f64 + 3.0)).collect()),
        },
    ];
    let refs: Vec<&Attribute> = cloud.attributes.iter().collect();
    let opts = PlyWriteOptions {
        encoding: PlyEncoding::BinaryLittleEndian,
        precision: Precision::F32,
    };
    io::write_ply(&dir.join("scan.ply"), &cloud.positions, &refs, &[], &opts).unwrap();
    read_cloud(&dir.join("scan.ply"))
}

#[test]
fn output_contract_on_a_synth_box() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let input = box_with_attributes(d);
    let n = input.len();
    config(d, "[input]\npath = \"scan.ply\"\n");
    let r = sharpedge(d, &["-q", "run", "pipeline.toml"]);
    r.assert_ok();
    let out = d.join("out");
    assert_eq!(entries(&out), PLY_OUTPUTS);
    let rep = report(&out);

    // ---- rectified.ply: header types ----
    let bytes = std::fs::read(out.join("rectified.ply")).unwrap();
    let h = parse_header(&bytes);
    assert_eq!(h.format, "binary_little_endian");
    assert_eq!(h.elements.len(), 1, "only vertices: {h:?}");
    let v = h.element("vertex");
    assert_eq!(v.count, n);
    let names: Vec<&str> = v.props.iter().map(|p| p.name.as_str()).collect();
    assert_eq!(&names[..3], ["x", "y", "z"]);
    for c in ["x", "y", "z"] {
        assert_eq!(v.ty(c), Some("float"), "float input, float output");
    }
    for (name, ty) in [
        ("scalar_edge_id", "int"),
        ("scalar_moved", "uchar"),
        ("scalar_displacement", "float"),
        ("scalar_sharpness", "float"),
        ("quality", "float"),
        ("red", "uchar"),
        ("green", "uchar"),
        ("blue", "uchar"),
        // carried through, the clashing one renamed
        ("intensity", "ushort"),
        ("input_red", "uchar"),
        ("confidence", "double"),
    ] {
        assert_eq!(v.ty(name), Some(ty), "property {name}");
    }
    assert_eq!(
        bytes.len(),
        h.body + n * stride_of(v),
        "size matches the header"
    );

    // ---- rectified.ply: values ----
    let rect = read_cloud(&out.join("rectified.ply"));
    assert_eq!(rect.len(), n);
    let moved = column(&rect, "scalar_moved");
    let disp = column(&rect, "scalar_displacement");
    let edge_id = column(&rect, "scalar_edge_id");
    let sharp = column(&rect, "scalar_sharpness");
    assert_eq!(sharp, column(&rect, "quality"), "quality is the sharpness");
    let edges = rep["edges"].as_array().unwrap();
    let corners = rep["corners"].as_array().unwrap();
    let mut n_moved = 0;
    for i in 0..n {
        let (a, b) = (input.positions[i], rect.positions[i]);
        assert!(
            moved[i] == 0.0 || moved[i] == 1.0,
            "moved flag {}",
            moved[i]
        );
        if moved[i] == 0.0 {
            // bit for bit, and in input order
            assert_eq!(
                a.map(f64::to_bits),
                b.map(f64::to_bits),
                "unmoved point {i} changed"
            );
            assert_eq!(disp[i], 0.0, "point {i}");
        } else {
            n_moved += 1;
            // the stored displacement is the distance between input and output (f32 rounding)
            let dd = dist(a, b);
            assert!(dd > 0.0, "moved point {i} did not move");
            assert!(
                (disp[i] - dd).abs() <= 1e-4 * (1.0 + dd),
                "point {i}: {} vs {dd}",
                disp[i]
            );
            assert!(edge_id[i] >= 0.0, "moved point {i} belongs to an edge");
        }
        assert!(
            edge_id[i] == -1.0 || (edge_id[i] >= 0.0 && (edge_id[i] as usize) < edges.len()),
            "edge id {} of point {i}",
            edge_id[i]
        );
        assert!(sharp[i].is_finite(), "sharpness of {i}");
    }
    assert!(n_moved > 0, "a noisy rounded box has points to move");
    assert!(
        n_moved < n / 4,
        "{n_moved} of {n} moved: only edge zones move"
    );
    assert_eq!(rep["counts"]["moved"], n_moved);
    // Colours: one per edge, grey off edges; every point of an edge has its edge's colour.
    let (red, green, blue) = (
        column(&rect, "red"),
        column(&rect, "green"),
        column(&rect, "blue"),
    );
    let mut colour_of_edge = std::collections::HashMap::new();
    for i in 0..n {
        let c = (red[i], green[i], blue[i]);
        if edge_id[i] == -1.0 {
            assert_eq!(c, (170.0, 170.0, 170.0), "grey off edges, point {i}");
        } else {
            assert_eq!(*colour_of_edge.entry(edge_id[i] as i64).or_insert(c), c);
        }
    }
    // Carried attributes: same values, same order.
    for name in ["intensity", "confidence"] {
        assert_eq!(column(&rect, name), column(&input, name), "{name}");
    }
    assert_eq!(column(&rect, "input_red"), column(&input, "red"));

    // ---- features.ply ----
    let (fv, pairs) = read_edges(&out.join("features.ply"));
    assert!(!pairs.is_empty(), "a box has edges");
    for [a, b] in &pairs {
        assert!(
            (0..fv as i32).contains(a) && (0..fv as i32).contains(b),
            "{a} {b} of {fv}"
        );
        assert_ne!(a, b);
    }
    let polyline_segments: usize = edges
        .iter()
        .map(|e| e["polyline"].as_array().unwrap().len() - 1)
        .sum();
    assert_eq!(
        pairs.len(),
        polyline_segments,
        "one PLY edge per polyline segment"
    );
    let feats = read_cloud(&out.join("features.ply"));
    assert_eq!(feats.len(), fv);
    // The first vertices are the corners (float coordinates, within float rounding).
    for (k, c) in corners.iter().enumerate() {
        let p = xyz(&c["position"]);
        assert!(dist(p, feats.positions[k]) < 1e-4, "corner {k}");
    }
    let kind = column(&feats, "scalar_kind");
    assert_eq!(kind.iter().filter(|&&k| k == 0.0).count(), corners.len());
    assert!(kind.contains(&2.0), "rectified edge points are present");
    // Each edge vertex carries its edge's kind by the LAS edge_kind code table (2 sharp);
    // corners none (255).
    let edge_kind = column(&feats, "scalar_edge_kind");
    for (k, ek) in kind.iter().zip(&edge_kind) {
        assert_eq!(*ek, if *k == 0.0 { 255.0 } else { 2.0 });
    }

    // ---- report.json ----
    assert_eq!(rep["sharpedge"], env!("CARGO_PKG_VERSION"), "the version");
    assert_eq!(rep["counts"]["points"], n);
    assert_eq!(rep["input"]["points"], n);
    assert_eq!(rep["counts"]["edges"], edges.len());
    assert_eq!(rep["counts"]["corners"], corners.len());
    assert!(!edges.is_empty() && !corners.is_empty());
    for e in edges {
        let (s, t, dir) = (xyz(&e["start"]), xyz(&e["end"]), xyz(&e["direction"]));
        let len = dist(s, t);
        assert!(len > 0.0, "{e}");
        assert!(
            (dist(dir, [0.0; 3]) - 1.0).abs() < 1e-9,
            "unit direction {e}"
        );
        for k in 0..3 {
            assert!(
                (dir[k] - (t[k] - s[k]) / len).abs() < 1e-9,
                "direction start→end {e}"
            );
        }
        assert!(e["points"].as_u64().unwrap() > 0, "{e}");
        assert_eq!(e["kind"], "sharp", "{e}");
        let rms = e["rms"].as_f64().unwrap();
        assert!(rms.is_finite() && rms >= 0.0, "{e}");
    }
    let mut with_error = 0;
    for c in corners {
        xyz(&c["position"]);
        for id in c["edges"].as_array().unwrap() {
            assert!((id.as_u64().unwrap() as usize) < edges.len(), "{c}");
        }
        if let Some(err) = c.get("error") {
            with_error += 1;
            for k in ["scheme1", "pso", "exact"] {
                let x = err[k]
                    .as_f64()
                    .unwrap_or_else(|| panic!("error.{k} in {c}"));
                assert!(x.is_finite() && x >= 0.0, "{c}");
            }
            // The exact optimum is a lower bound of the PSO's error (a certificate).
            let (pso, exact) = (err["pso"].as_f64().unwrap(), err["exact"].as_f64().unwrap());
            assert!(exact <= pso * (1.0 + 1e-9), "{c}");
        }
    }
    assert!(with_error > 0, "at least one corner was fitted");
    let stages: Vec<&str> = rep["timings"]
        .as_array()
        .unwrap()
        .iter()
        .map(|t| {
            assert!(t["seconds"].as_f64().unwrap() >= 0.0);
            t["stage"].as_str().unwrap()
        })
        .collect();
    for s in [
        "read",
        "neighbours",
        "features",
        "segment",
        "edges",
        "corners",
        "rectify",
    ] {
        assert!(stages.contains(&s), "stage {s} timed: {stages:?}");
    }
    for k in [
        "points",
        "candidates",
        "outliers",
        "runs",
        "edges",
        "corners",
        "moved",
        "left_out",
        "failed_fits",
    ] {
        assert!(rep["counts"][k].is_u64(), "counts.{k}");
    }
    let cfg = &rep["config"];
    assert_eq!(cfg["seed"], 1);
    // Paths as resolved against the config's folder (here the working directory).
    assert_eq!(cfg["input"]["path"], "scan.ply");
    assert_eq!(cfg["output"]["dir"], "out");
    for table in ["features", "segment", "edges", "corners", "rectify", "fit"] {
        assert!(cfg[table].is_object(), "config.{table}");
    }
}

#[test]
fn large_coordinates_keep_double_precision() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let mut args = BOX.to_vec();
    args.extend(["--translate", "4000000", "4000000", "100"]);
    let scan = synth(d, "far.ply", &args);
    let input = read_cloud(&scan);
    let n = input.len();
    assert!(input.positions.iter().all(|p| p[0] > 3.9e6 && p[1] > 3.9e6));
    config(d, "[input]\npath = \"far.ply\"\n");
    sharpedge(d, &["-q", "run", "pipeline.toml"]).assert_ok();
    let out = d.join("out");
    let bytes = std::fs::read(out.join("rectified.ply")).unwrap();
    let v = parse_header(&bytes).element("vertex").clone();
    for c in ["x", "y", "z"] {
        assert_eq!(v.ty(c), Some("double"), "{c} must be double at 4e6");
    }
    let rect = read_cloud(&out.join("rectified.ply"));
    assert_eq!(rect.len(), n);
    let moved = column(&rect, "scalar_moved");
    let mut worst: f64 = 0.0;
    for ((r, p), m) in rect.positions.iter().zip(&input.positions).zip(&moved) {
        if *m == 0.0 {
            for k in 0..3 {
                worst = worst.max((r[k] - p[k]).abs());
            }
        }
    }
    assert!(worst <= 1e-6, "unmoved points drifted by {worst}");
    assert!(moved.contains(&1.0), "edge zones were rectified");
    // The moved points stay near their input (within the band around the edge), so nothing
    // was lost to float rounding (f32 steps are 0.25 at 4e6).
    let spacing = report(&out)["scale"]["spacing"].as_f64().unwrap();
    for i in 0..n {
        assert!(
            dist(rect.positions[i], input.positions[i]) < 5.0 * spacing,
            "point {i} jumped"
        );
    }
    // Report geometry is in the input's coordinates.
    let rep = report(&out);
    let edges = rep["edges"].as_array().unwrap();
    assert!(!edges.is_empty());
    for e in edges {
        let s = xyz(&e["start"]);
        assert!(s[0] > 3.9e6 && s[1] > 3.9e6, "{e}");
    }
    // features.ply is double too.
    let fbytes = std::fs::read(out.join("features.ply")).unwrap();
    assert_eq!(
        parse_header(&fbytes).element("vertex").ty("x"),
        Some("double")
    );
}
