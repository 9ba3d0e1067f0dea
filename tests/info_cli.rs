//! `sharpedge info FILE [--json]`, run as the real binary: on a file this test writes, on bad
//! input, and on the files of ../shared/data when present.

use std::path::Path;
use std::process::Command;

use sharpedge::io::{self, PlyWriteOptions, Precision};
use sharpedge::{Attribute, Column};

fn info(args: &[&std::ffi::OsStr]) -> (bool, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_sharpedge"))
        .arg("info")
        .args(args)
        .output()
        .expect("running sharpedge");
    (
        out.status.success(),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

fn write_sample(path: &Path) {
    let pos = [
        [512345.25, 4101234.5, 80.0],
        [512346.0, 4101230.0, 81.5],
        [512344.0, 4101236.0, 79.0],
    ];
    let q = Attribute {
        name: "quality".into(),
        values: Column::F32(vec![0.1, 0.2, 0.3]),
    };
    let red = Attribute {
        name: "red".into(),
        values: Column::U8(vec![255, 0, 10]),
    };
    let opts = PlyWriteOptions {
        precision: Precision::F64,
        ..Default::default()
    };
    io::write_ply(path, &pos, &[&q, &red], &[[0, 1], [1, 2], [2, 0]], &opts).unwrap();
}

#[test]
fn info_text_on_a_written_file() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("sample.ply");
    write_sample(&p);
    let (ok, out, err) = info(&[p.as_os_str()]);
    assert!(ok, "{err}");
    let want = format!(
        "file:        {}\n\
         format:      PLY binary_little_endian 1.0\n\
         points:      3\n\
         properties:  x (double), y (double), z (double), quality (float), red (uchar)\n\
         not read:    edge 3\n\
         bbox min:    512344 4101230 79\n\
         bbox max:    512346 4101236 81.5\n\
         size:        2 6 2.5\n\
         precision:   double (the file is more precise than float at this magnitude)\n\
         spacing:     ",
        p.display()
    );
    assert!(out.starts_with(&want), "{out}");
    // Nearest distinct neighbours: 2.19373, 4.80234, 2.19373 → mean 3.06327.
    assert!(
        out.ends_with(" (mean nearest-neighbour distance)\n"),
        "{out}"
    );
    assert!(out[want.len()..].starts_with("3.0632"), "{out}");
}

#[test]
fn info_json_on_a_written_file() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("sample.ply");
    write_sample(&p);
    let (ok, out, err) = info(&[p.as_os_str(), "--json".as_ref()]);
    assert!(ok, "{err}");
    let v: serde_json::Value = serde_json::from_str(&out).expect("valid JSON");
    assert_eq!(v["points"], 3);
    assert_eq!(v["non_finite"], 0);
    assert_eq!(v["format"], "PLY binary_little_endian 1.0");
    assert_eq!(
        v["bbox"]["min"],
        serde_json::json!([512344.0, 4101230.0, 79.0])
    );
    assert_eq!(
        v["bbox"]["max"],
        serde_json::json!([512346.0, 4101236.0, 81.5])
    );
    assert_eq!(
        v["properties"][3],
        serde_json::json!({"name": "quality", "type": "float"})
    );
    assert_eq!(
        v["other_elements"],
        serde_json::json!([{"name": "edge", "count": 3}])
    );
    assert_eq!(v["double_precision"], true);
    let spacing = v["mean_spacing"].as_f64().expect("spacing computed");
    let d = |a: [f64; 3], b: [f64; 3]| {
        ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
    };
    let (p0, p1, p2) = (
        [512345.25, 4101234.5, 80.0],
        [512346.0, 4101230.0, 81.5],
        [512344.0, 4101236.0, 79.0],
    );
    let want = (d(p0, p2) + d(p0, p1) + d(p2, p0)) / 3.0;
    assert!((spacing - want).abs() < 1e-5, "{spacing} vs {want}");
}

#[test]
fn info_on_bad_input_fails_with_the_file_named() {
    let dir = tempfile::tempdir().unwrap();
    let missing = dir.path().join("missing.ply");
    let (ok, out, err) = info(&[missing.as_os_str()]);
    assert!(!ok);
    assert!(out.is_empty());
    assert_eq!(
        err.trim_end(),
        format!(
            "error: {}: cannot open: No such file or directory (os error 2)",
            missing.display()
        )
    );
    let bad = dir.path().join("bad.ply");
    std::fs::write(
        &bad,
        "ply\nformat ascii 1.0\nelement vertex 1\nproperty int64 x\nend_header\n",
    )
    .unwrap();
    let (ok, _, err) = info(&[bad.as_os_str()]);
    assert!(!ok);
    assert!(
        err.contains(&format!(
            "{}: header line 4: unknown PLY type `int64`",
            bad.display()
        )),
        "{err}"
    );
}

#[test]
fn info_on_shared_data() {
    let d = Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/data");
    if !d.is_dir() {
        println!("skipped: ../shared/data absent");
        return;
    }
    for (name, n, format) in [
        ("scan/bun_zipper.ply", 35947, "PLY ascii 1.0"),
        (
            "plyfmt/platonic_shelf_big_endian.ply",
            50,
            "PLY binary_big_endian 1.0",
        ),
        ("lidar/autzen_trim.laz", 110000, "LAZ 1.2, point format 3"),
        (
            "lidar/lone-star.copc.laz",
            518862,
            "COPC LAZ 1.4, point format 6",
        ),
        ("lidar/sample_c.las", 14408, "LAS 1.2, point format 3"),
        (
            "cad/cube.pwn",
            50000,
            "XYZ text, 6 columns (x y z nx ny nz)",
        ),
    ] {
        let p = d.join(name);
        let (ok, out, err) = info(&[p.as_os_str(), "--json".as_ref()]);
        assert!(ok, "{name}: {err}");
        let v: serde_json::Value = serde_json::from_str(&out).unwrap();
        assert_eq!(v["points"], n, "{name}");
        assert_eq!(v["format"], format, "{name}");
    }
    let p = d.join("plyfmt/all_atomic_types_ok_ascii.ply");
    let (ok, _, err) = info(&[p.as_os_str()]);
    assert!(!ok);
    assert!(
        err.contains("no `vertex` element; elements are: point"),
        "{err}"
    );
}
