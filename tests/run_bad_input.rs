//! `sharpedge run` on bad input, through the real binary: every case must exit with code 1, print
//! one `error:` line naming the file (and the place, where there is one) and the problem, never
//! panic, and leave nothing in the output folder. Degenerate but valid clouds (a flat plane,
//! duplicated points) must succeed.

mod run_common;

use std::path::{Path, PathBuf};

use run_common::*;
use sharpedge::io::{self, PlyEncoding, PlyWriteOptions, Precision};

// ---- files that cannot be read ------------------------------------------------------------------

#[test]
fn missing_input_file() {
    let c = Case::new();
    let r = c.run("nope.ply", &[]);
    assert_failed_cleanly(
        &r,
        &["nope.ply: cannot open", "No such file or directory"],
        &c.out(),
    );
}

#[test]
fn unreadable_input_file() {
    let c = Case::new();
    // A folder with a cloud's name: opening it succeeds on Unix, reading does not. This works
    // even as root, where permission bits are not enforced.
    std::fs::create_dir(c.path().join("folder.ply")).unwrap();
    let r = c.run("folder.ply", &[]);
    assert_failed_cleanly(
        &r,
        &["folder.ply: cannot read", "it is a directory, not a file"],
        &c.out(),
    );

    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        let locked = c.path().join("locked.ply");
        c.write("locked.ply", &ascii_ply(&flat_plane(10)));
        std::fs::set_permissions(&locked, std::fs::Permissions::from_mode(0o000)).unwrap();
        if std::fs::File::open(&locked).is_ok() {
            println!(
                "unreadable_input_file: permission bits not enforced (root); checked the folder case only"
            );
        } else {
            let r = c.run("locked.ply", &[]);
            assert_failed_cleanly(
                &r,
                &["locked.ply: cannot open", "Permission denied"],
                &c.out(),
            );
        }
    }
}

#[test]
fn unknown_extension() {
    let c = Case::new();
    c.write("part.stl", "solid part\nendsolid part\n");
    let r = c.run("part.stl", &[]);
    assert_failed_cleanly(
        &r,
        &[
            "part.stl: unknown file type \"stl\"",
            "sharpedge reads .ply, .las, .laz",
        ],
        &c.out(),
    );
}

// ---- malformed PLY ------------------------------------------------------------------------------

#[test]
fn truncated_ply_body() {
    let c = Case::new();
    let scan = synth(c.path(), "box.ply", BOX);
    let bytes = std::fs::read(&scan).unwrap();
    let h = parse_header(&bytes);
    let n = h.element("vertex").count;
    // Cut in the middle of vertex n/2 (12 bytes per float x, y, z vertex).
    assert_eq!(bytes.len(), h.body + 12 * n);
    let cut = h.body + 12 * (n / 2) + 5;
    std::fs::write(c.path().join("cut.ply"), &bytes[..cut]).unwrap();
    let r = c.run("cut.ply", &[]);
    assert_failed_cleanly(
        &r,
        &[
            &format!("cut.ply: vertex {} of {n}: the file ends here", n / 2),
            "truncated",
        ],
        &c.out(),
    );
}

#[test]
fn header_promises_more_vertices_than_the_body_holds() {
    let c = Case::new();
    // ascii: 5 declared, 2 present; the message gives the line and the vertex.
    c.write(
        "lies.ply",
        &(XYZ_HEADER.replace("{n}", "5") + "1 2 3\n4 5 6\n"),
    );
    let r = c.run("lies.ply", &[]);
    assert_failed_cleanly(
        &r,
        &[
            "lies.ply: line 10 (vertex 2 of 5): the file ends here",
            "header declares 5 `vertex` items",
        ],
        &c.out(),
    );

    // binary: a real scan whose header claims 10 more vertices than it holds.
    let scan = synth(c.path(), "box.ply", BOX);
    let bytes = std::fs::read(&scan).unwrap();
    let n = parse_header(&bytes).element("vertex").count;
    let text = String::from_utf8_lossy(&bytes).into_owned();
    let at = text.find("element vertex ").unwrap();
    let old = format!("element vertex {n}\n");
    let new = format!("element vertex {}\n", n + 10);
    assert_eq!(&text[at..at + old.len()], old);
    let mut lied = bytes[..at].to_vec();
    lied.extend_from_slice(new.as_bytes());
    lied.extend_from_slice(&bytes[at + old.len()..]);
    std::fs::write(c.path().join("lies_bin.ply"), lied).unwrap();
    let r = c.run("lies_bin.ply", &[]);
    assert_failed_cleanly(
        &r,
        &[
            &format!("lies_bin.ply: vertex {n} of {}: the file ends here", n + 10),
            &format!("header declares {} `vertex` items", n + 10),
        ],
        &c.out(),
    );
}

/// A LAS 1.2 point format 3 file of the synthetic box (a cloud every stage accepts).
fn box_las(c: &Case, name: &str) -> PathBuf {
    let cloud = read_cloud(&synth(c.path(), "box.ply", BOX));
    let mut b = las::Builder::from((1, 2));
    b.point_format = las::point::Format::new(3).unwrap();
    let path = c.path().join(name);
    let mut w = las::Writer::from_path(&path, b.into_header().unwrap()).unwrap();
    for p in &cloud.positions {
        w.write_point(las::Point {
            x: p[0],
            y: p[1],
            z: p[2],
            gps_time: Some(1.0),
            color: Some(las::Color::default()),
            ..Default::default()
        })
        .unwrap();
    }
    w.close().unwrap();
    path
}

/// A LAS header that lies (about its point count, its record length, where its points start)
/// stops the run with the file and the problem named; no output, not even a partial
/// rectified.las. The same file with an honest header runs.
#[test]
fn las_header_that_lies() {
    let c = Case::new();
    let good = box_las(&c, "good.las");
    run_las(&c, "good.las", "ok").assert_ok();
    assert!(c.path().join("ok/rectified.las").is_file());
    let bytes = std::fs::read(&good).unwrap();
    let n = u32::from_le_bytes(bytes[107..111].try_into().unwrap());
    let patched = |name: &str, at: usize, value: &[u8]| {
        let mut b = bytes.clone();
        b[at..at + value.len()].copy_from_slice(value);
        std::fs::write(c.path().join(name), b).unwrap();
    };
    // LAS 1.2 header: point count at byte 107, record length at 105, offset to points at 96.
    patched("count.las", 107, &(n + 1000).to_le_bytes());
    let r = run_las(&c, "count.las", "out_count");
    assert_failed_cleanly(
        &r,
        &["count.las", "declares more points than it holds"],
        &c.path().join("out_count"),
    );
    patched("reclen.las", 105, &20u16.to_le_bytes());
    let r = run_las(&c, "reclen.las", "out_reclen");
    assert_failed_cleanly(
        &r,
        &["reclen.las: header: the point data record length 20 is too small"],
        &c.path().join("out_reclen"),
    );
    patched("offset.las", 96, &(bytes.len() as u32 + 10).to_le_bytes());
    let r = run_las(&c, "offset.las", "out_offset");
    assert_failed_cleanly(
        &r,
        &["offset.las: point 0 of", "the point data ends early"],
        &c.path().join("out_offset"),
    );
    for out in ["out_count", "out_reclen", "out_offset"] {
        assert!(!c.path().join(out).exists(), "{out} left behind");
    }
}

fn run_las(c: &Case, input: &str, out: &str) -> Run {
    sharpedge(
        c.path(),
        &["-q", "run", "pipeline.toml", "--input", input, "--out", out],
    )
}

#[test]
fn unknown_ply_type() {
    let c = Case::new();
    c.write(
        "type.ply",
        "ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty float y\nproperty flot z\nend_header\n1 2 3\n4 5 6\n",
    );
    let r = c.run("type.ply", &[]);
    assert_failed_cleanly(
        &r,
        &[
            "type.ply: header line 6: unknown PLY type `flot` in `property flot z`",
            "the PLY types are char uchar",
        ],
        &c.out(),
    );
}

#[test]
fn list_property_in_the_vertex_element() {
    let c = Case::new();
    c.write(
        "list.ply",
        "ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty float y\nproperty float z\nproperty list uchar int idx\nend_header\n1 2 3 1 0\n4 5 6 1 1\n",
    );
    let r = c.run("list.ply", &[]);
    assert_failed_cleanly(
        &r,
        &[
            "list.ply: header, element vertex: vertex property `idx` is a list",
            "sharpedge reads only scalar vertex properties",
        ],
        &c.out(),
    );
}

// ---- NaN and infinity ---------------------------------------------------------------------------

/// The synth box with NaN at point 17 and +inf / -inf at points 40 and 41, as double PLY.
fn box_with_non_finite(c: &Case) -> (PathBuf, Vec<[f64; 3]>) {
    let scan = synth(c.path(), "box.ply", BOX);
    let mut pts = read_cloud(&scan).positions;
    pts[17][1] = f64::NAN;
    pts[40][0] = f64::INFINITY;
    pts[41][2] = f64::NEG_INFINITY;
    let path = c.path().join("nan.ply");
    write_raw_ply(&path, &pts);
    (path, pts)
}

#[test]
fn non_finite_coordinates_are_rejected_by_default() {
    let c = Case::new();
    let (_, pts) = box_with_non_finite(&c);
    let r = c.run("nan.ply", &[]);
    assert_failed_cleanly(
        &r,
        &[
            "nan.ply: point 17 (0-based, in file order) has a non-finite coordinate",
            "y = NaN",
            &format!("3 of {} points are NaN or infinite", pts.len()),
        ],
        &c.out(),
    );
    // The same in a text file.
    let text: String = pts
        .iter()
        .map(|p| format!("{} {} {}\n", p[0], p[1], p[2]))
        .collect();
    c.write("nan.xyz", &text);
    let r = c.run("nan.xyz", &[]);
    assert_failed_cleanly(
        &r,
        &["nan.xyz: point 17 (0-based, in file order) has a non-finite coordinate"],
        &c.out(),
    );
    // The same in an ascii PLY (its `nan` tokens once failed to parse at all).
    c.write("nan_ascii.ply", &ascii_ply(&pts[..100]));
    let r = c.run("nan_ascii.ply", &[]);
    assert_failed_cleanly(
        &r,
        &[
            "nan_ascii.ply: point 17 (0-based, in file order) has a non-finite coordinate",
            "3 of 100 points are NaN or infinite",
        ],
        &c.out(),
    );
}

#[test]
fn non_finite_coordinates_are_dropped_when_configured() {
    let c = Case::new();
    let (_, pts) = box_with_non_finite(&c);
    config(
        c.path(),
        "[input]\npath = \"nan.ply\"\nnon_finite = \"drop\"\n[output]\ndir = \"out\"\n",
    );
    let r = sharpedge(c.path(), &["run", "pipeline.toml"]);
    r.assert_ok();
    assert!(
        r.stderr
            .contains(&format!("nan.ply: dropped 3 of {} points", pts.len())),
        "a warning with the count: {}",
        r.stderr
    );
    let finite: Vec<[f64; 3]> = pts
        .iter()
        .copied()
        .filter(|p| p.iter().all(|c| c.is_finite()))
        .collect();
    assert_eq!(finite.len(), pts.len() - 3);
    let rep = report(&c.out());
    assert_eq!(rep["counts"]["points"], finite.len());
    assert_eq!(rep["input"]["points"], finite.len());
    assert_eq!(rep["config"]["input"]["non_finite"], "drop");
    let rect = read_cloud(&c.out().join("rectified.ply"));
    assert_eq!(rect.len(), finite.len());
    // The kept points are the finite ones in order: the unmoved ones are exactly them.
    let moved = column(&rect, "scalar_moved");
    let mut unmoved = 0;
    for (i, p) in finite.iter().enumerate() {
        if moved[i] == 0.0 {
            assert_eq!(rect.positions[i], *p, "point {i}");
            unmoved += 1;
        }
    }
    assert!(unmoved > finite.len() / 2, "{unmoved} unmoved points");
}

// ---- clouds with no surface ---------------------------------------------------------------------

#[test]
fn empty_cloud() {
    let c = Case::new();
    c.write("empty.ply", &ascii_ply(&[]));
    let r = c.run("empty.ply", &[]);
    assert_failed_cleanly(&r, &["empty.ply: the cloud has no points"], &c.out());
}

#[test]
fn single_point() {
    let c = Case::new();
    c.write("one.ply", &ascii_ply(&[[1.0, 2.0, 3.0]]));
    let r = c.run("one.ply", &[]);
    assert_failed_cleanly(
        &r,
        &[
            "one.ply: the cloud has only 1 point(s)",
            "needs a scanned surface",
        ],
        &c.out(),
    );
}

#[test]
fn all_points_identical() {
    let c = Case::new();
    c.write("same.ply", &ascii_ply(&[[1.5, -2.0, 3.25]; 500]));
    let r = c.run("same.ply", &[]);
    assert_failed_cleanly(
        &r,
        &[
            "same.ply: all 500 points are identical (1.5, -2, 3.25)",
            "no surface",
        ],
        &c.out(),
    );
}

// ---- degenerate but valid: must succeed ---------------------------------------------------------

#[test]
fn flat_plane_succeeds_with_no_edges_and_nothing_moved() {
    let c = Case::new();
    let plane = flat_plane(60);
    write_raw_ply(&c.path().join("plane.ply"), &plane);
    let r = c.run("plane.ply", &["-q"]);
    r.assert_ok();
    assert_eq!(entries(&c.out()), PLY_OUTPUTS);
    let rep = report(&c.out());
    assert_eq!(rep["counts"]["points"], plane.len());
    assert_eq!(rep["counts"]["edges"], 0);
    assert_eq!(rep["counts"]["corners"], 0);
    assert_eq!(rep["counts"]["moved"], 0);
    assert_eq!(rep["edges"], serde_json::json!([]));
    assert_eq!(rep["corners"], serde_json::json!([]));
    // rectified == input, bit for bit (the input is double, so is the output).
    let bytes = std::fs::read(c.out().join("rectified.ply")).unwrap();
    let h = parse_header(&bytes);
    assert_eq!(h.element("vertex").ty("x"), Some("double"));
    let rect = read_cloud(&c.out().join("rectified.ply"));
    assert_eq!(rect.positions, plane);
    assert!(column(&rect, "scalar_moved").iter().all(|&m| m == 0.0));
    assert!(column(&rect, "scalar_edge_id").iter().all(|&e| e == -1.0));
    assert!(
        column(&rect, "scalar_displacement")
            .iter()
            .all(|&d| d == 0.0)
    );
    // features.ply: a valid file with no edges.
    let (vertices, edges) = read_edges(&c.out().join("features.ply"));
    assert_eq!((vertices, edges.len()), (0, 0));
}

#[test]
fn duplicate_points_succeed() {
    let c = Case::new();
    let scan = synth(c.path(), "box.ply", BOX);
    let once = read_cloud(&scan).positions;
    let twice: Vec<[f64; 3]> = once.iter().flat_map(|p| [*p, *p]).collect();
    let opts = PlyWriteOptions {
        encoding: PlyEncoding::BinaryLittleEndian,
        precision: Precision::F32,
    };
    io::write_ply(&c.path().join("twice.ply"), &twice, &[], &[], &opts).unwrap();
    let r = c.run("twice.ply", &["-q"]);
    r.assert_ok();
    let rep = report(&c.out());
    assert_eq!(rep["counts"]["points"], twice.len());
    let rect = read_cloud(&c.out().join("rectified.ply"));
    assert_eq!(rect.len(), twice.len());
    let moved = column(&rect, "scalar_moved");
    for (i, p) in twice.iter().enumerate() {
        if moved[i] == 0.0 {
            assert_eq!(rect.positions[i], *p, "unmoved point {i}");
        }
    }
    assert_eq!(
        moved.iter().filter(|&&m| m != 0.0).count(),
        rep["counts"]["moved"].as_u64().unwrap() as usize
    );
}

// ---- output folders that cannot be written ------------------------------------------------------

#[test]
fn output_folder_inside_a_regular_file() {
    let c = Case::new();
    synth(c.path(), "scan.ply", BOX);
    c.write("afile", "not a folder\n");
    let r = sharpedge(c.path(), &["run", "pipeline.toml", "--out", "afile/sub"]);
    assert_failed_cleanly(
        &r,
        &["afile/sub: cannot create output folder", "Not a directory"],
        &c.path().join("afile/sub"),
    );
    assert_eq!(
        std::fs::read_to_string(c.path().join("afile")).unwrap(),
        "not a folder\n"
    );
}

#[test]
fn output_folder_in_proc() {
    if !Path::new("/proc/self").exists() {
        println!("skipped: no /proc on this system");
        return;
    }
    let c = Case::new();
    synth(c.path(), "scan.ply", BOX);
    let leftovers = || -> Vec<String> {
        entries(Path::new("/proc"))
            .into_iter()
            .filter(|n| n.starts_with(".tmp") || n.starts_with(".sharpedge"))
            .collect()
    };
    let r = sharpedge(c.path(), &["run", "pipeline.toml", "--out", "/proc"]);
    assert_failed_cleanly(&r, &["/proc: cannot write into output folder"], &c.out());
    assert_eq!(leftovers(), Vec::<String>::new());
    let r = sharpedge(
        c.path(),
        &["run", "pipeline.toml", "--out", "/proc/sharpedge-out"],
    );
    assert_failed_cleanly(
        &r,
        &["/proc/sharpedge-out: cannot create output folder"],
        &c.out(),
    );
    assert!(!Path::new("/proc/sharpedge-out").exists());
}

// ---- bad pipeline files -------------------------------------------------------------------------

#[test]
fn config_unknown_key() {
    let e = bad_config(
        "[input]\npath = \"scan.ply\"\n\n[features]\nradios = 3\n",
        "pipeline.toml:5: features.radios: unknown field `radios`, expected one of `radius`",
    );
    assert!(
        e.contains("see the commented pipeline.toml for every key"),
        "{e}"
    );
    bad_config(
        "seed = 1\nsed = 2\n",
        "pipeline.toml:2: sed: unknown field `sed`, expected one of `seed`",
    );
    bad_config(
        "[featurez]\nradius = 1\n",
        "pipeline.toml:1: featurez: unknown field `featurez`",
    );
    bad_config(
        "[fit.pso]\nswarm = 3\n",
        "pipeline.toml:2: fit.pso.swarm: unknown field `swarm`, expected one of `w`",
    );
}

#[test]
fn config_wrong_type() {
    bad_config(
        "[input]\npath = \"scan.ply\"\n[features]\nradius = true\n",
        "pipeline.toml:4: features.radius: invalid type: boolean `true`, expected a length in model units or \"auto\"",
    );
    bad_config(
        "[input]\npath = 3\n",
        "pipeline.toml:2: input.path: invalid type: integer `3`, expected a string",
    );
}

#[test]
fn config_value_out_of_range() {
    bad_config(
        "[input]\npath = \"scan.ply\"\n[features]\n\noutlier_share = 1.5\n",
        "pipeline.toml:5: features.outlier_share: must be in [0, 1], got 1.5",
    );
    bad_config("seed = -3\n", "pipeline.toml:1: seed: must be ≥ 0, got -3");
    bad_config(
        "[fit.pso]\nw = 1.5\n",
        "pipeline.toml:2: fit.pso.w: fit parameter pso.w = 1.5: expected 0 <= w < 1",
    );
}

#[test]
fn config_bad_enum_value() {
    bad_config(
        "[input]\npath = \"scan.ply\"\nnon_finite = \"keep\"\n",
        "pipeline.toml:3: input.non_finite: must be one of \"reject\", \"drop\", got \"keep\"",
    );
    bad_config(
        "[output]\nprecision = \"half\"\n",
        "pipeline.toml:2: output.precision: must be one of \"auto\", \"float\", \"double\", got \"half\"",
    );
}

#[test]
fn config_syntax_error() {
    bad_config(
        "seed = 1\n[input\npath = \"scan.ply\"\n",
        "pipeline.toml:2: (file): unclosed table, expected `]`",
    );
    bad_config("[input]\npath = \"scan.ply\n", "pipeline.toml:2: (file): ");
}

#[test]
fn config_file_missing() {
    let c = Case::new();
    let r = sharpedge(c.path(), &["run", "nope.toml"]);
    assert_failed_cleanly(
        &r,
        &[
            "nope.toml: cannot read pipeline file",
            "No such file or directory",
        ],
        &c.out(),
    );
}

#[test]
fn no_input_in_config_or_on_the_command_line() {
    let c = Case::new();
    config(c.path(), "seed = 3\n");
    let r = sharpedge(c.path(), &["run", "pipeline.toml"]);
    assert_failed_cleanly(
        &r,
        &["input: no input cloud: set input.path in the pipeline file or pass --input"],
        &c.out(),
    );
}
