//! Bad input to the readers and writers: each case must give an `Err` (never a panic) whose
//! message names the file and the problem, and writers must leave no file behind.

use std::path::{Path, PathBuf};

mod io_common;

use sharpedge::io::{self, NonFinite, PlyEncoding, PlyWriteOptions, Precision, ReadOptions};
use sharpedge::{Attribute, Column, Error};

use io_common::{assert_contains, message, read, write};

/// A valid binary little-endian PLY of `n` points (float xyz + uchar red) written by us.
fn good_ply(dir: &Path, name: &str, n: usize, encoding: PlyEncoding) -> PathBuf {
    let path = dir.join(name);
    let pos: Vec<[f64; 3]> = (0..n).map(|i| [i as f64, 0.5, -1.0]).collect();
    let red = Attribute {
        name: "red".into(),
        values: Column::U8((0..n).map(|i| i as u8).collect()),
    };
    let opts = PlyWriteOptions {
        encoding,
        precision: Precision::F32,
    };
    io::write_ply(&path, &pos, &[&red], &[], &opts).unwrap();
    path
}

fn truncate(path: &Path, keep: usize) {
    let bytes = std::fs::read(path).unwrap();
    std::fs::write(path, &bytes[..keep]).unwrap();
}

/// Whether the OS enforces file permissions on us (not when running as root).
fn permissions_enforced(dir: &Path) -> bool {
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        let probe = dir.join("probe");
        std::fs::write(&probe, b"x").unwrap();
        std::fs::set_permissions(&probe, std::fs::Permissions::from_mode(0o000)).unwrap();
        let enforced = std::fs::File::open(&probe).is_err();
        std::fs::set_permissions(&probe, std::fs::Permissions::from_mode(0o644)).unwrap();
        std::fs::remove_file(&probe).unwrap();
        enforced
    }
    #[cfg(not(unix))]
    {
        let _ = dir;
        false
    }
}

// ---- files that cannot be read ---------------------------------------------------------------

#[test]
fn missing_file() {
    let dir = tempfile::tempdir().unwrap();
    for name in ["nope.ply", "nope.las", "nope.laz", "nope.xyz"] {
        let path = dir.path().join(name);
        let r = read(&path);
        let err = r.as_ref().err().map(|e| {
            std::error::Error::source(e)
                .and_then(|s| s.downcast_ref::<std::io::Error>())
                .map(|io| io.kind())
        });
        assert_eq!(err, Some(Some(std::io::ErrorKind::NotFound)), "{name}");
        let e = message(r, &path);
        assert_eq!(e, format!("{}: cannot open", path.display()));
        let e = io::describe(&path).unwrap_err().to_string();
        assert_eq!(e, format!("{}: cannot open", path.display()));
    }
}

#[test]
fn unreadable_file() {
    let dir = tempfile::tempdir().unwrap();
    // A directory with a point-cloud name: opening succeeds on Unix, reading does not.
    let d = dir.path().join("folder.ply");
    std::fs::create_dir(&d).unwrap();
    let e = read(&d).unwrap_err();
    assert_eq!(e.to_string(), format!("{}: cannot read", d.display()));
    let cause = std::error::Error::source(&e).map(|s| s.to_string());
    assert_eq!(cause.as_deref(), Some("it is a directory, not a file"));

    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        if permissions_enforced(dir.path()) {
            let p = good_ply(dir.path(), "locked.ply", 3, PlyEncoding::BinaryLittleEndian);
            std::fs::set_permissions(&p, std::fs::Permissions::from_mode(0o000)).unwrap();
            let e = message(read(&p), &p);
            assert_eq!(e, format!("{}: cannot open", p.display()));
        } else {
            println!(
                "unreadable_file: running as root, permission bits are not enforced; checked the directory case only"
            );
        }
    }
}

#[test]
fn unknown_extension() {
    let dir = tempfile::tempdir().unwrap();
    for (name, ext) in [("part.stl", "stl"), ("scan", ""), ("cloud.ply.gz", "gz")] {
        let path = write(dir.path(), name, b"whatever");
        let e = message(read(&path), &path);
        assert_contains(
            &e,
            &[
                &format!("unknown file type {ext:?}"),
                ".ply",
                ".las",
                ".laz",
                ".xyz",
            ],
        );
    }
}

// ---- PLY ------------------------------------------------------------------------------------

#[test]
fn truncated_binary_ply_body() {
    let dir = tempfile::tempdir().unwrap();
    let path = good_ply(dir.path(), "cut.ply", 10, PlyEncoding::BinaryLittleEndian);
    let len = std::fs::metadata(&path).unwrap().len() as usize;
    // Each vertex is 13 bytes; cutting 5 bytes breaks vertex 9, cutting 40 breaks vertex 6.
    for (cut, vertex) in [(5, 9), (40, 6), (130, 0)] {
        let p = dir.path().join(format!("cut{cut}.ply"));
        std::fs::copy(&path, &p).unwrap();
        truncate(&p, len - cut);
        for r in [read(&p), io::read_ply_via_crate(&p)] {
            let e = message(r, &p);
            assert_contains(
                &e,
                &[
                    &format!("vertex {vertex} of 10"),
                    "the file ends here",
                    "header declares 10 `vertex` items",
                ],
            );
        }
    }
}

#[test]
fn truncated_ascii_ply_body() {
    let dir = tempfile::tempdir().unwrap();
    let path = good_ply(dir.path(), "cut.ply", 10, PlyEncoding::Ascii);
    let text = std::fs::read_to_string(&path).unwrap();
    let header_lines = text.split("end_header\n").next().unwrap().lines().count() + 1;
    // Cut after 7 complete vertex lines: the 8th (index 7) is missing.
    let body_start = text.find("end_header\n").unwrap() + "end_header\n".len();
    let seven: usize = text[body_start..]
        .split_inclusive('\n')
        .take(7)
        .map(str::len)
        .sum();
    truncate(&path, body_start + seven);
    let e = message(read(&path), &path);
    assert_contains(
        &e,
        &[
            &format!("line {} (vertex 7 of 10)", header_lines + 8),
            "the file ends here",
        ],
    );
    // Cut inside a line: the values of vertex 6 are incomplete.
    truncate(&path, body_start + seven - 4);
    let e = message(read(&path), &path);
    assert_contains(
        &e,
        &[
            &format!("line {} (vertex 6 of 10)", header_lines + 7),
            "the file ends inside this vertex's line",
            "truncated",
        ],
    );
}

#[test]
fn header_promises_more_vertices_than_the_body_holds() {
    let dir = tempfile::tempdir().unwrap();
    let mut body = Vec::new();
    for i in 0..4 {
        for c in [i as f32, 1.0, 2.0] {
            body.extend_from_slice(&c.to_le_bytes());
        }
    }
    for (count, enc, body) in [
        ("1000", "binary_little_endian", body.clone()),
        ("1000", "binary_big_endian", body.clone()),
        ("1000", "ascii", b"0 1 2\n1 1 2\n2 1 2\n3 1 2\n".to_vec()),
    ] {
        let mut f = format!(
            "ply\nformat {enc} 1.0\nelement vertex {count}\nproperty float x\nproperty float y\nproperty float z\nend_header\n"
        )
        .into_bytes();
        f.extend_from_slice(&body);
        let p = write(dir.path(), &format!("lies_{enc}.ply"), &f);
        let e = message(read(&p), &p);
        assert_contains(
            &e,
            &["vertex 4 of 1000", "header declares 1000 `vertex` items"],
        );
    }
    // An absurd count must not make the reader allocate for it.
    let mut f = b"ply\nformat binary_little_endian 1.0\nelement vertex 9000000000000\nproperty double x\nproperty double y\nproperty double z\nend_header\n".to_vec();
    f.extend_from_slice(&[0u8; 48]);
    let p = write(dir.path(), "huge.ply", &f);
    let e = message(read(&p), &p);
    assert_contains(&e, &["vertex 2 of 9000000000000", "the file ends here"]);
    // A face element before the vertices that is cut short is reported as such.
    let p = write(
        dir.path(),
        "faces.ply",
        b"ply\nformat ascii 1.0\nelement face 3\nproperty list uchar int vertex_indices\nelement vertex 1\nproperty float x\nproperty float y\nproperty float z\nend_header\n3 0 1 2\n",
    );
    let e = message(read(&p), &p);
    assert_contains(
        &e,
        &["line 11 (face 1 of 3)", "header declares 3 `face` items"],
    );
}

#[test]
fn unknown_ply_type() {
    let dir = tempfile::tempdir().unwrap();
    let p = write(
        dir.path(),
        "int64.ply",
        b"ply\nformat ascii 1.0\nelement vertex 1\nproperty int64 x\nproperty float y\nproperty float z\nend_header\n1 2 3\n",
    );
    let e = message(read(&p), &p);
    assert_contains(
        &e,
        &[
            "header line 4",
            "unknown PLY type `int64` in `property int64 x`",
            "char uchar short ushort int uint float double",
        ],
    );
    let p = write(
        dir.path(),
        "listtype.ply",
        b"ply\nformat ascii 1.0\nelement face 0\nproperty list uchar integer vertex_indices\nelement vertex 0\nproperty float x\nproperty float y\nproperty float z\nend_header\n",
    );
    let e = message(read(&p), &p);
    assert_contains(&e, &["header line 4", "unknown PLY type `integer`"]);
}

#[test]
fn list_property_in_the_vertex_element() {
    let dir = tempfile::tempdir().unwrap();
    let p = write(
        dir.path(),
        "vlist.ply",
        b"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nproperty float z\nproperty list uchar float normals\nend_header\n1 2 3 3 0 0 1\n",
    );
    let e = message(read(&p), &p);
    assert_contains(
        &e,
        &[
            "element vertex",
            "vertex property `normals` is a list (list uchar float)",
            "only scalar vertex properties",
        ],
    );
}

#[test]
fn missing_coordinate_property() {
    let dir = tempfile::tempdir().unwrap();
    let p = write(
        dir.path(),
        "noz.ply",
        b"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nproperty float nz\nend_header\n1 2 3\n",
    );
    let e = message(read(&p), &p);
    assert_contains(
        &e,
        &["vertex property `z` missing; the vertex properties are: x, y, nz"],
    );
}

#[test]
fn no_vertex_element() {
    let dir = tempfile::tempdir().unwrap();
    let p = write(
        dir.path(),
        "points.ply",
        b"ply\nformat ascii 1.0\nelement point 1\nproperty float x\nproperty float y\nproperty float z\nend_header\n1 2 3\n",
    );
    let e = message(read(&p), &p);
    assert_contains(&e, &["no `vertex` element; elements are: point"]);
}

#[test]
fn not_a_ply_file_empty_file_and_unfinished_header() {
    let dir = tempfile::tempdir().unwrap();
    let p = write(dir.path(), "text.ply", b"hello world\n");
    let e = message(read(&p), &p);
    assert_contains(
        &e,
        &["line 1", "not a PLY file: the first line must be `ply`"],
    );
    let p = write(dir.path(), "empty.ply", b"");
    let e = message(read(&p), &p);
    assert_contains(&e, &["not a PLY file: the file is empty"]);
    let p = write(
        dir.path(),
        "nohead.ply",
        b"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\n",
    );
    let e = message(read(&p), &p);
    assert_contains(&e, &["the file ends inside the header"]);
    let p = write(
        dir.path(),
        "badformat.ply",
        b"ply\nformat binary 1.0\nelement vertex 0\nend_header\n",
    );
    let e = message(read(&p), &p);
    assert_contains(&e, &["header line 2", "cannot parse `format binary 1.0`"]);
}

/// A binary PLY with NaN at vertex 2 and infinity at vertex 4, and an id per vertex.
fn ply_with_non_finite(dir: &Path) -> PathBuf {
    let mut f = b"ply\nformat binary_little_endian 1.0\nelement vertex 6\nproperty double x\nproperty double y\nproperty double z\nproperty int id\nend_header\n".to_vec();
    for i in 0..6i32 {
        let y = match i {
            2 => f64::NAN,
            4 => f64::NEG_INFINITY,
            _ => 1.0,
        };
        for c in [f64::from(i), y, 0.0] {
            f.extend_from_slice(&c.to_le_bytes());
        }
        f.extend_from_slice(&(100 + i).to_le_bytes());
    }
    write(dir, "nan.ply", &f)
}

#[test]
fn non_finite_coordinates_reject_or_drop() {
    let dir = tempfile::tempdir().unwrap();
    let p = ply_with_non_finite(dir.path());
    let e = message(read(&p), &p);
    assert_contains(
        &e,
        &[
            "point 2 (0-based, in file order)",
            "(x = 2, y = NaN, z = 0)",
            "2 of 6 points are NaN or infinite",
        ],
    );
    let drop = ReadOptions {
        non_finite: NonFinite::Drop,
    };
    let c = io::read(&p, &drop).unwrap();
    assert_eq!(
        c.positions.iter().map(|q| q[0]).collect::<Vec<_>>(),
        [0.0, 1.0, 3.0, 5.0]
    );
    assert_eq!(
        c.attributes[0].values,
        Column::I32(vec![100, 101, 103, 105])
    );
    // describe counts them and leaves them out of the bounding box.
    let info = io::describe(&p).unwrap();
    assert_eq!((info.points, info.non_finite), (6, 2));
    assert_eq!(info.bbox.unwrap().max, [5.0, 1.0, 0.0]);

    // Text files spell them out.
    let x = write(
        dir.path(),
        "nan.xyz",
        b"0 0 0 7\n1 nan 0 8\n2 0 inf 9\n3 0 0 10\n",
    );
    let e = message(read(&x), &x);
    assert_contains(&e, &["point 1 (0-based", "2 of 4 points"]);
    let c = io::read(&x, &drop).unwrap();
    assert_eq!(c.positions, vec![[0.0; 3], [3.0, 0.0, 0.0]]);
    assert_eq!(c.attributes[0].values, Column::F64(vec![7.0, 10.0]));
}

/// Regression (issue 2): ply-rs-bw's ascii grammar has no spelling for NaN, so an ascii PLY
/// with invalid points written as `nan` (as PCL writes them) failed to parse instead of
/// obeying `input.non_finite`.
#[test]
fn ascii_ply_nan_tokens_reject_or_drop_like_binary_ones() {
    let dir = tempfile::tempdir().unwrap();
    let p = write(
        dir.path(),
        "nan_ascii.ply",
        b"ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\nproperty uchar k\nend_header\n0 0 0 1\nnan 0 0 2\n2 -inf 0 3\n3 0 -nan 4\n",
    );
    let e = message(read(&p), &p);
    assert_contains(
        &e,
        &["point 1 (0-based", "3 of 4 points are NaN or infinite"],
    );
    let drop = ReadOptions {
        non_finite: NonFinite::Drop,
    };
    let c = io::read(&p, &drop).unwrap();
    assert_eq!(c.positions, vec![[0.0; 3]]);
    assert_eq!(c.attributes[0].values, Column::U8(vec![1]));
}

/// A bad token names its line, vertex, property and type; so do short and long lines and an
/// integer out of its type's range.
#[test]
fn ascii_ply_bad_values_name_line_vertex_and_property() {
    let dir = tempfile::tempdir().unwrap();
    let head = "ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty float y\nproperty float z\nproperty uchar k\nend_header\n";
    for (body, want) in [
        (
            "0 0 0 1\n1 abc 0 2\n",
            vec![
                "line 10 (vertex 1 of 2)",
                "cannot read `abc` as the float property `y`",
            ],
        ),
        (
            "0 0 0 1\n1 0 0\n",
            vec![
                "line 10 (vertex 1 of 2)",
                "the line ends before property `k`",
            ],
        ),
        (
            "0 0 0 1 9\n1 0 0 2\n",
            vec!["line 9 (vertex 0 of 2)", "`9` after the 4 values"],
        ),
        (
            "0 0 0 256\n1 0 0 2\n",
            vec![
                "line 9 (vertex 0 of 2)",
                "cannot read `256` as the uchar property `k`",
            ],
        ),
        (
            "0 0 0 1\n",
            vec!["line 10 (vertex 1 of 2)", "the file ends here"],
        ),
    ] {
        let p = write(
            dir.path(),
            "bad_ascii.ply",
            format!("{head}{body}").as_bytes(),
        );
        let e = message(read(&p), &p);
        assert_contains(&e, &want);
    }
}

// ---- LAS / LAZ ------------------------------------------------------------------------------

fn small_las(path: &Path, n: usize) {
    let mut b = las::Builder::from((1, 2));
    b.point_format = las::point::Format::new(3).unwrap();
    let mut w = las::Writer::from_path(path, b.into_header().unwrap()).unwrap();
    for i in 0..n {
        // Varied values, so the LAZ copy is not compressed to almost nothing.
        w.write_point(las::Point {
            x: i as f64,
            y: (i * 7919 % 1000) as f64 * 0.01,
            z: (i * 104729 % 517) as f64 * 0.01,
            intensity: (i * 31 % 65536) as u16,
            gps_time: Some(0.0),
            color: Some(las::Color::default()),
            ..Default::default()
        })
        .unwrap();
    }
    w.close().unwrap();
}

#[test]
fn truncated_or_corrupt_las_and_laz() {
    let dir = tempfile::tempdir().unwrap();
    for ext in ["las", "laz"] {
        let p = dir.path().join(format!("good.{ext}"));
        small_las(&p, 20_000);
        let len = std::fs::metadata(&p).unwrap().len() as usize;
        // Truncated in the point data.
        let t = dir.path().join(format!("cut.{ext}"));
        std::fs::copy(&p, &t).unwrap();
        truncate(&t, len * 2 / 3);
        let e = message(read(&t), &t);
        if ext == "las" {
            // The count is checked against the file before any point is read.
            let whole = (len * 2 / 3 - 227) / 34;
            assert_contains(
                &e,
                &[
                    &format!("point {whole} of 20000"),
                    "the point data ends early",
                ],
            );
        } else {
            // LAZ keeps its chunk table at the end: the loss shows when the file is opened.
            assert_contains(&e, &["the LAZ chunk table is said to start", "truncated"]);
        }
        // Truncated in the header.
        let h = dir.path().join(format!("head.{ext}"));
        std::fs::copy(&p, &h).unwrap();
        truncate(&h, 100);
        let e = message(read(&h), &h);
        assert_contains(&e, &["header", "the file ends inside its header"]);
        // Not a LAS file at all.
        let g = write(dir.path(), &format!("garbage.{ext}"), &[7u8; 4000]);
        let e = message(read(&g), &g);
        assert_contains(
            &e,
            &[
                "header",
                "the file signature is not 'LASF'",
                "not a valid LAS/LAZ",
            ],
        );
        // A bad point format number.
        let mut bytes = std::fs::read(&p).unwrap();
        bytes[104] = 99;
        let f = write(dir.path(), &format!("format.{ext}"), &bytes);
        let e = message(read(&f), &f);
        assert_contains(&e, &["header", "99"]);
    }
}

#[test]
fn damaged_laz_data_is_an_error_not_a_panic() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("good.laz");
    small_las(&p, 20_000);
    let mut bytes = std::fs::read(&p).unwrap();
    // Overwrite a stretch of compressed points (after header and VLRs, before the chunk table).
    let (start, end) = (bytes.len() / 3, bytes.len() / 2);
    for b in &mut bytes[start..end] {
        *b = 0xff;
    }
    let d = write(dir.path(), "damaged.laz", &bytes);
    // Corrupt arithmetic-coded data may decode to garbage without an error, or fail; what
    // must never happen is a panic or a silent change of the point count.
    match read(&d) {
        Ok(c) => assert_eq!(c.len(), 20_000),
        Err(e) => assert!(e.to_string().starts_with(&d.display().to_string()), "{e}"),
    }
}

// ---- XYZ ------------------------------------------------------------------------------------

#[test]
fn bad_text_files() {
    let dir = tempfile::tempdir().unwrap();
    let p = write(dir.path(), "ragged.xyz", b"0 0 0\n1 1 1\n2 2\n");
    let e = message(read(&p), &p);
    assert_contains(&e, &["line 3", "2 values, but line 1 has 3"]);
    let p = write(dir.path(), "word.txt", b"0 0 0\n1 one 1\n");
    let e = message(read(&p), &p);
    assert_contains(&e, &["line 2, column 2", "`one` is not a number"]);
    let p = write(dir.path(), "two.xyz", b"0 0\n1 1\n");
    let e = message(read(&p), &p);
    assert_contains(&e, &["line 1", "2 columns; a point needs at least x y z"]);
    let p = write(dir.path(), "binary.xyz", &[0xff, 0xfe, 0x00, 0x41, 0x0a]);
    let e = message(read(&p), &p);
    assert_contains(&e, &["line 1", "not text"]);
    let p = write(dir.path(), "hdr.xyz", b"x y z nx\n1 2 3\n");
    let e = message(read(&p), &p);
    assert_contains(
        &e,
        &["line 2", "3 values, but the header line names 4 columns"],
    );
}

// ---- unwritable outputs ---------------------------------------------------------------------

fn try_write(path: &Path) -> Result<(), Error> {
    let q = Attribute {
        name: "quality".into(),
        values: Column::F32(vec![1.0, 2.0]),
    };
    io::write_ply(
        path,
        &[[0.0; 3], [1.0; 3]],
        &[&q],
        &[[0, 1]],
        &PlyWriteOptions::default(),
    )
}

#[test]
fn unwritable_output_folder_leaves_nothing_behind() {
    let dir = tempfile::tempdir().unwrap();
    // A folder that does not exist.
    let p = dir.path().join("missing").join("out.ply");
    let e = try_write(&p).unwrap_err().to_string();
    assert_eq!(
        e,
        format!(
            "{}: cannot create a temporary file in the output folder (does it exist, is it writable?)",
            p.display()
        )
    );
    assert!(!dir.path().join("missing").exists());
    // A "folder" that is a regular file.
    let f = write(dir.path(), "file", b"x");
    let p = f.join("out.ply");
    let e = try_write(&p).unwrap_err().to_string();
    assert!(
        e.contains("cannot create a temporary file in the output folder"),
        "{e}"
    );
    // The destination is an existing folder: the rename fails, the temporary file is removed.
    let sub = dir.path().join("sub.ply");
    std::fs::create_dir(&sub).unwrap();
    let e = try_write(&sub).unwrap_err().to_string();
    assert!(
        e.contains("cannot rename the finished temporary file"),
        "{e}"
    );
    let mut left: Vec<_> = std::fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap().file_name().into_string().unwrap())
        .collect();
    left.sort();
    assert_eq!(left, ["file", "sub.ply"]);
    assert_eq!(std::fs::read_dir(&sub).unwrap().count(), 0);
}

#[test]
fn read_only_output_folder() {
    let dir = tempfile::tempdir().unwrap();
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        let target = if permissions_enforced(dir.path()) {
            let ro = dir.path().join("ro");
            std::fs::create_dir(&ro).unwrap();
            std::fs::set_permissions(&ro, std::fs::Permissions::from_mode(0o555)).unwrap();
            ro
        } else {
            // Root ignores permission bits; /proc refuses new files to everyone.
            println!(
                "read_only_output_folder: running as root, using /proc as the read-only folder"
            );
            PathBuf::from("/proc")
        };
        let p = target.join("out.ply");
        let e = try_write(&p).unwrap_err().to_string();
        assert!(
            e.starts_with(&format!(
                "{}: cannot create a temporary file in the output folder",
                p.display()
            )),
            "{e}"
        );
        assert!(!p.exists());
        if target.starts_with(dir.path()) {
            assert_eq!(std::fs::read_dir(&target).unwrap().count(), 0);
            std::fs::set_permissions(&target, std::fs::Permissions::from_mode(0o755)).unwrap();
        }
    }
}
