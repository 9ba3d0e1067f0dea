//! Reading PCD (issue 16): every encoding of a hand-made organised frame with every kind of
//! field gives the same cloud (positions, typed attributes, packed colour split, COUNT > 1,
//! padding dropped, NaN slots skipped, grid positions and the VIEWPOINT pose); an old v0.5
//! header; the non-finite policy on unorganised NaN points (a dropped point is written back as
//! it was); a body of many decoding chunks, with one thread and two; 64-bit integer fields
//! read and written back byte for byte; and the real RGB-D frame against its PLY copy in
//! ../shared/data/rgbd.

mod pcd_common;

use std::path::Path;

use pcd_common::*;
use sharpedge::io::{self, NonFinite, ReadOptions};
use sharpedge::{Column, Pose};

fn read(path: &Path) -> sharpedge::Result<sharpedge::Cloud> {
    io::read(path, &ReadOptions::default())
}

fn col<'a>(c: &'a sharpedge::Cloud, name: &str) -> &'a Column {
    &c.attribute(name)
        .unwrap_or_else(|| panic!("no attribute {name}"))
        .values
}

#[test]
fn every_encoding_of_a_frame_with_every_field_reads_the_same() {
    let dir = tempfile::tempdir().unwrap();
    let frame = every_field_frame();
    let mut clouds = Vec::new();
    for data in ["ascii", "binary", "binary_compressed"] {
        let p = dir.path().join(format!("{data}.pcd"));
        write(&p, &frame.with_data(data));
        let c = read(&p).unwrap();
        assert_eq!(
            c.source.format,
            format!("PCD 0.7 {data}, organised 4 x 3"),
            "{data}"
        );
        clouds.push(c);
    }
    let c = &clouds[0];
    // Slots 5 and 10 are NaN: no points; the others in frame order.
    let slots: Vec<usize> = (0..12).filter(|&i| i != 5 && i != 10).collect();
    let expected: Vec<[f64; 3]> = slots.iter().map(|&i| frame.xyz(i).map(f64::from)).collect();
    assert_eq!(c.positions, expected);
    let names: Vec<&str> = c.attributes.iter().map(|a| a.name.as_str()).collect();
    assert_eq!(
        names,
        [
            "normal_x",
            "normal_y",
            "normal_z",
            "intensity",
            "label",
            "red",
            "green",
            "blue",
            "hist_0",
            "hist_1",
            "hist_2",
            "time"
        ]
    );
    let u8s = |f: &dyn Fn(usize) -> u8| slots.iter().map(|&i| f(i)).collect::<Vec<u8>>();
    assert_eq!(col(c, "red"), &Column::U8(u8s(&|i| (10 * i) as u8)));
    assert_eq!(col(c, "green"), &Column::U8(u8s(&|_| 20)));
    assert_eq!(col(c, "blue"), &Column::U8(u8s(&|i| (255 - i) as u8)));
    assert_eq!(
        col(c, "intensity"),
        &Column::U16(slots.iter().map(|&i| 1000 + i as u16).collect())
    );
    assert_eq!(
        col(c, "label"),
        &Column::I32(slots.iter().map(|&i| -(i as i32)).collect())
    );
    assert_eq!(
        col(c, "hist_1"),
        &Column::I8(slots.iter().map(|&i| i as i8 - 6).collect())
    );
    assert_eq!(
        col(c, "time"),
        &Column::F64(slots.iter().map(|&i| 1e9 + i as f64 * 0.001).collect())
    );
    assert_eq!(col(c, "normal_y"), &Column::F32(vec![0.6; 10]));
    let s = c.structure.as_ref().unwrap();
    assert_eq!(s.scans.len(), 1);
    assert_eq!(s.scans[0].grid_size, Some([3, 4]));
    assert_eq!(
        s.scans[0].pose,
        Pose {
            rotation: [0.6, 0.0, 0.8, 0.0],
            translation: [0.5, -1.0, 2.0],
        }
    );
    let grid: Vec<[u32; 2]> = slots
        .iter()
        .map(|&i| [(i / 4) as u32, (i % 4) as u32])
        .collect();
    assert_eq!(s.grid, grid);
    assert_eq!(s.scan, vec![0; 10]);
    for other in &clouds[1..] {
        assert_eq!(other.positions, c.positions);
        assert_eq!(other.attributes, c.attributes);
        let (o, s) = (other.structure.as_ref().unwrap(), s);
        assert_eq!((&o.grid, &o.scan), (&s.grid, &s.scan));
        assert_eq!(o.scans[0].pose, s.scans[0].pose);
        assert_eq!(o.scans[0].grid_size, s.scans[0].grid_size);
    }
}

#[test]
fn unorganised_nan_points_follow_the_non_finite_policy() {
    let dir = tempfile::tempdir().unwrap();
    let flat = every_field_frame().unorganised(|_| true);
    let p = dir.path().join("flat.pcd");
    write(&p, &flat.with_data("binary_compressed"));
    let e = read(&p).unwrap_err().to_string();
    assert!(
        e.contains("flat.pcd: point 5 (0-based, in file order) has a non-finite coordinate"),
        "{e}"
    );
    let c = io::read(
        &p,
        &ReadOptions {
            non_finite: NonFinite::Drop,
        },
    )
    .unwrap();
    assert_eq!(c.len(), 10);
    assert_eq!(c.source.format, "PCD 0.7 binary_compressed, unorganised");
    let s = c.structure.as_ref().unwrap();
    assert_eq!(s.scans[0].grid_size, None);
    assert!(s.grid.is_empty());
    // An infinite coordinate in an organised frame is no NaN slot: the policy applies.
    let mut frame = every_field_frame();
    frame.records[4..8].copy_from_slice(&f32::INFINITY.to_le_bytes());
    write(&p, &frame);
    let e = read(&p).unwrap_err().to_string();
    assert!(e.contains("point 0 (0-based"), "{e}");
}

#[test]
fn version_0_5_headers_without_type_count_or_viewpoint() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("old.pcd");
    std::fs::write(
        &p,
        "# .PCD v.5 - Point Cloud Data file format\nVERSION .5\nFIELDS x y z\nSIZE 4 4 4\n\
         WIDTH 3\nHEIGHT 1\nPOINTS 3\nDATA ascii\n1 2 3\n4 5 6\n\n7 8 9.5\n",
    )
    .unwrap();
    let c = read(&p).unwrap();
    assert_eq!(
        c.positions,
        vec![[1.0, 2.0, 3.0], [4.0, 5.0, 6.0], [7.0, 8.0, 9.5]]
    );
    assert_eq!(c.source.format, "PCD 0.5 ascii, unorganised");
    assert_eq!(c.structure.unwrap().scans[0].pose, Pose::default());
}

#[test]
fn the_real_frame_reads_as_its_ply_copy() {
    let Some(_) = real_frame("mosd_test0.pcd") else {
        return;
    };
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/data");
    let pcd = read(&root.join("pcd/mosd_test0.pcd")).unwrap();
    let ply = read(&root.join("rgbd/box.ply")).unwrap();
    assert_eq!(pcd.len(), 189_198);
    assert_eq!(pcd.positions, ply.positions);
    for name in ["red", "green", "blue", "label"] {
        assert_eq!(col(&pcd, name), col(&ply, name), "{name}");
    }
    let s = pcd.structure.as_ref().unwrap();
    assert_eq!(s.scans[0].grid_size, Some([480, 640]));
    assert_eq!(s.grid.len(), pcd.len());
    // Grid positions are increasing in frame order (row-major).
    assert!(
        s.grid
            .windows(2)
            .all(|w| (w[0][0], w[0][1]) < (w[1][0], w[1][1]))
    );
}

#[test]
fn a_truncated_binary_body_is_named_on_the_chunked_path_too() {
    // `io::read` decodes a binary body chunk by chunk (a run with a PCD output reads it
    // whole): both check the body's length against the header first.
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("cut.pcd");
    let b = bytes(&every_field_frame());
    std::fs::write(&p, &b[..b.len() - 1]).unwrap();
    let e = read(&p).unwrap_err().to_string();
    assert!(
        e.contains("cut.pcd: byte ")
            && e.contains(
                "the file is truncated: the header declares 12 points of 49 bytes (588 bytes), \
                 the file holds 587 bytes after the header"
            ),
        "{e}"
    );
}

/// The binary_compressed reader decodes in chunks, in a second thread when the pool has two:
/// a body of many chunks reads as its binary and ascii copies do, with one thread and two;
/// 64-bit integers are read (as f64, exact below 2^53).
#[test]
fn a_big_compressed_body_reads_as_binary_and_ascii_do() {
    let dir = tempfile::tempdir().unwrap();
    let n = 60_000;
    let cloud = big_cloud(n);
    let mut got = Vec::new();
    for data in ["binary", "binary_compressed", "ascii"] {
        let p = dir.path().join(format!("{data}.pcd"));
        write(&p, &cloud.with_data(data));
        for threads in [1, 2] {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            let c = pool.install(|| read(&p)).unwrap();
            got.push((format!("{data}, {threads} threads"), c));
        }
    }
    let (_, first) = &got[0];
    assert_eq!(first.len(), n);
    for i in [0, 1, 777, n - 1] {
        assert_eq!(first.positions[i], cloud.xyz(i).map(f64::from), "point {i}");
    }
    let f64s = |name: &str| match col(first, name) {
        Column::F64(v) => v.clone(),
        other => panic!("{name}: {other:?}"),
    };
    let stamp = f64s("stamp");
    let id = f64s("id");
    for i in [0, 5, 59_999] {
        assert_eq!(stamp[i], (-(i as i64) * 1_000_000_007) as f64);
        assert_eq!(id[i], ((1u64 << 52) + (i / 3) as u64) as f64);
    }
    assert_eq!(
        col(first, "ring"),
        &Column::U8((0..n).map(|i| (i % 32) as u8).collect())
    );
    assert_eq!(f64s("normal_2")[11], 2.0 * 0.125 - 2.0);
    for (what, c) in &got[1..] {
        assert_eq!(c.positions, first.positions, "{what}");
        assert_eq!(c.attributes, first.attributes, "{what}");
    }
}

/// 64-bit integer fields come back byte for byte in a PCD output, in every encoding.
#[test]
fn sixty_four_bit_integers_round_trip() {
    let dir = tempfile::tempdir().unwrap();
    let mut cloud = big_cloud(500);
    // Values f64 cannot hold: the output must still have them exactly.
    let o = cloud.offset("id");
    let ps = cloud.point_size();
    cloud.records[3 * ps + o..3 * ps + o + 8].copy_from_slice(&u64::MAX.to_le_bytes());
    let o = cloud.offset("stamp");
    cloud.records[4 * ps + o..4 * ps + o + 8].copy_from_slice(&(i64::MIN + 1).to_le_bytes());
    for data in ["binary", "binary_compressed", "ascii"] {
        let input = cloud.with_data(data);
        let p = dir.path().join(format!("{data}.pcd"));
        write(&p, &input);
        let (c, original) =
            io::read_for_output(&p, &ReadOptions::default(), io::CloudFormat::Pcd).unwrap();
        let Some(io::Original::Pcd(pcd)) = original else {
            panic!("no PcdFile");
        };
        let out = dir.path().join(format!("{data}-out.pcd"));
        io::write_pcd(&out, &pcd, &c.positions, &vec![false; c.len()]).unwrap();
        assert_eq!(pcd_common::read(&out), input, "{data}");
    }
}

/// A point `input.non_finite = "drop"` took out of the cloud keeps its slot and its original
/// bytes in a PCD output, while the points around it move.
#[test]
fn a_dropped_point_is_written_back_as_it_was() {
    let dir = tempfile::tempdir().unwrap();
    let flat = every_field_frame().unorganised(|_| true);
    for data in ["binary", "binary_compressed", "ascii"] {
        let input = flat.with_data(data);
        let p = dir.path().join(format!("{data}.pcd"));
        write(&p, &input);
        let drop = ReadOptions {
            non_finite: NonFinite::Drop,
        };
        let (c, original) = io::read_for_output(&p, &drop, io::CloudFormat::Pcd).unwrap();
        let Some(io::Original::Pcd(pcd)) = original else {
            panic!("no PcdFile");
        };
        assert_eq!(c.len(), 10, "{data}");
        let moved: Vec<[f64; 3]> = c
            .positions
            .iter()
            .map(|p| [p[0] + 1.0, p[1], p[2]])
            .collect();
        let out = dir.path().join(format!("{data}-out.pcd"));
        io::write_pcd(&out, &pcd, &moved, &vec![true; c.len()]).unwrap();
        let back = pcd_common::read(&out);
        assert_eq!(back.points(), 12, "{data}");
        for i in 0..12 {
            if i == 5 || i == 10 {
                assert_eq!(back.record(i), input.record(i), "{data}: dropped slot {i}");
                assert!(back.xyz(i).iter().all(|v| v.is_nan()));
            } else {
                assert_eq!(back.xyz(i)[0], input.xyz(i)[0] + 1.0, "{data}: slot {i}");
            }
        }
    }
}
