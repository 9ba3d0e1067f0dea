//! PCD in, PCD out through the real binary (issue 16): the real organised RGB-D frame, in each
//! encoding and organised or not, runs with the automatic format and comes back as
//! rectified.pcd with the same fields, WIDTH x HEIGHT, VIEWPOINT, encoding and slot order;
//! every byte of every slot is as read except x, y, z of the points sharpedge moved (as many
//! as report.json counts), NaN slots included. PCL's own tools (Debian's pcl-tools) read the
//! outputs back to the same records; without them the test says so and skips, unless
//! SHARPEDGE_REQUIRE_PCL_TOOLS=1 (set by CI). Also: `--format pcd` on another input, and
//! every kind of lying or broken PCD with the message it must print, no output, exit 1.

mod pcd_common;
mod run_common;

use std::path::Path;
use std::process::Command;

use pcd_common::*;
use run_common::*;

/// Runs the frame `input` (written as `name`) and returns the output read back.
fn run_frame(c: &Case, name: &str, input: &Pcd) -> Pcd {
    write(&c.path().join(name), input);
    c.run(name, &[]).assert_ok();
    assert!(c.out().join("rectified.pcd").is_file());
    read(&c.out().join("rectified.pcd"))
}

/// Checks `out` against `input`: same header, every slot's bytes as read except x, y, z of
/// the moved points. Returns the number of slots whose x, y, z changed.
fn assert_same_but_moved(input: &Pcd, out: &Pcd, what: &str) -> usize {
    assert_eq!(out.fields, input.fields, "{what}");
    assert_eq!(
        (out.width, out.height),
        (input.width, input.height),
        "{what}"
    );
    assert_eq!(out.viewpoint, input.viewpoint, "{what}");
    assert_eq!(out.data, input.data, "{what}");
    let xyz: Vec<usize> = ["x", "y", "z"].iter().map(|a| input.offset(a)).collect();
    let mut moved = 0;
    for i in 0..input.points() {
        let (a, b) = (input.record(i), out.record(i));
        if a == b {
            continue;
        }
        moved += 1;
        let (pa, pb) = (input.xyz(i), out.xyz(i));
        assert!(
            pa.iter().all(|v| v.is_finite()) && pb.iter().all(|v| v.is_finite()),
            "{what}: slot {i} changed from {pa:?} to {pb:?}"
        );
        let mut a = a.to_vec();
        for &o in &xyz {
            a[o..o + 4].copy_from_slice(&b[o..o + 4]);
        }
        assert_eq!(a, b, "{what}: slot {i} changed beyond x, y, z");
    }
    moved
}

#[test]
fn the_real_frame_round_trips_in_every_encoding() {
    let Some(frame) = real_frame("mosd_test0.pcd") else {
        return;
    };
    let nan_slot = |i: usize| frame.xyz(i).iter().all(|v| v.is_nan());
    let flat = frame.unorganised(|i| !nan_slot(i));
    for (input, kind) in [(&frame, "organised"), (&flat, "unorganised")] {
        for data in ["ascii", "binary", "binary_compressed"] {
            let what = format!("{kind} {data}");
            let c = Case::new();
            let input = input.with_data(data);
            let out = run_frame(&c, "frame.pcd", &input);
            let moved = assert_same_but_moved(&input, &out, &what);
            let counted = report(&c.out())["counts"]["moved"].as_u64().unwrap() as usize;
            assert_eq!(moved, counted, "{what}: moved slots vs report.json");
            assert!(
                moved > 0 && moved < input.points() / 10,
                "{what}: {moved} moved"
            );
            if kind == "organised" {
                let nan = (0..out.points())
                    .filter(|&i| out.xyz(i).iter().all(|v| v.is_nan()))
                    .count();
                assert_eq!(nan, 118_002, "{what}: NaN slots kept");
            }
            // And the output reads as the input does: same point count and structure.
            let back = read_cloud(&c.out().join("rectified.pcd"));
            let orig = read_cloud(&c.path().join("frame.pcd"));
            assert_eq!(back.len(), orig.len(), "{what}");
            let (sb, so) = (back.structure.unwrap(), orig.structure.unwrap());
            assert_eq!((sb.grid, sb.scan), (so.grid, so.scan), "{what}");
            assert_eq!(sb.scans[0].grid_size, so.scans[0].grid_size, "{what}");
            assert_eq!(back.attributes, orig.attributes, "{what}");
        }
    }
}

#[test]
fn format_option_for_pcd() {
    let c = Case::new();
    synth(c.path(), "scan.ply", BOX);
    let r = c.run("scan.ply", &["--format", "pcd"]);
    assert_failed_cleanly(
        &r,
        &["a PCD output is written from a PCD input", "scan.ply"],
        &c.out(),
    );
    let mut frame = every_field_frame();
    // A bigger organised frame than the hand-made one: a flat 60 x 50 grid.
    frame.width = 60;
    frame.height = 50;
    let rec = frame.record(0).to_vec();
    frame.records.clear();
    for i in 0..3000 {
        let mut r = rec.clone();
        let p = [(i % 60) as f32 * 0.01, (i / 60) as f32 * 0.01, 0.5];
        for (k, v) in p.iter().enumerate() {
            r[4 * k..4 * k + 4].copy_from_slice(&v.to_le_bytes());
        }
        frame.records.extend_from_slice(&r);
    }
    write(&c.path().join("grid.pcd"), &frame);
    c.run("grid.pcd", &["--format", "ply"]).assert_ok();
    assert!(c.out().join("rectified.ply").is_file());
    assert!(!c.out().join("rectified.pcd").exists());
    c.run("grid.pcd", &[]).assert_ok();
    let out = read(&c.out().join("rectified.pcd"));
    assert_eq!(
        out, frame,
        "a flat grid: nothing moves, the file comes back as it was"
    );
}

/// PCL's tools, or `None` when they are absent and not required.
fn pcl_tools() -> Option<()> {
    let found = Command::new("pcl_pcd2ply").output().is_ok()
        && Command::new("pcl_convert_pcd_ascii_binary")
            .output()
            .is_ok();
    if found {
        return Some(());
    }
    let required = std::env::var("SHARPEDGE_REQUIRE_PCL_TOOLS").is_ok_and(|v| v == "1");
    assert!(
        !required,
        "SHARPEDGE_REQUIRE_PCL_TOOLS=1 but pcl_pcd2ply / pcl_convert_pcd_ascii_binary are not \
         on PATH (Debian: apt-get install pcl-tools)"
    );
    eprintln!("skipped: PCL's tools (pcl-tools) absent");
    None
}

#[test]
fn pcl_reads_the_outputs_back() {
    let Some(frame) = real_frame("mosd_test0.pcd") else {
        return;
    };
    if pcl_tools().is_none() {
        return;
    }
    for data in ["ascii", "binary", "binary_compressed"] {
        let c = Case::new();
        let out = run_frame(&c, "frame.pcd", &frame.with_data(data));
        let rect = c.out().join("rectified.pcd");
        // PCL re-encodes our output as binary: the same records, bit for bit.
        let again = c.path().join("pcl.pcd");
        let r = Command::new("pcl_convert_pcd_ascii_binary")
            .arg(&rect)
            .arg(&again)
            .arg("1")
            .output()
            .unwrap();
        assert!(r.status.success(), "{data}: {r:?}");
        let pcl = read(&again);
        assert_eq!(pcl.data, "binary");
        assert_eq!(pcl.records, out.records, "{data}: PCL reads other records");
        assert_eq!((pcl.width, pcl.height), (640, 480), "{data}");
        // And converts it to PLY with every slot.
        let ply = c.path().join("pcl.ply");
        let r = Command::new("pcl_pcd2ply")
            .arg(&rect)
            .arg(&ply)
            .output()
            .unwrap();
        assert!(r.status.success(), "{data}: {r:?}");
        let text = std::fs::read(&ply).unwrap();
        let head = String::from_utf8_lossy(&text[..200]);
        assert!(head.contains("element vertex 307200"), "{data}: {head}");
    }
}

/// A broken input: the run fails with exit 1, names the file and says `parts`, writes nothing.
fn assert_rejected(bytes: &[u8], parts: &[&str]) {
    let c = Case::new();
    std::fs::write(c.path().join("bad.pcd"), bytes).unwrap();
    let r = c.run("bad.pcd", &[]);
    let mut all = vec!["bad.pcd"];
    all.extend_from_slice(parts);
    assert_failed_cleanly(&r, &all, &c.out());
}

fn small() -> Pcd {
    every_field_frame()
}

#[test]
fn truncated_files() {
    for data in ["binary", "ascii"] {
        let b = bytes(&small().with_data(data));
        assert_rejected(&b[..b.len() - 20], &["the file is truncated"]);
    }
    let b = bytes(&small().with_data("binary_compressed"));
    let head = header_text(&small().with_data("binary_compressed"), 12).len();
    assert_rejected(
        &b[..head + 5],
        &["the file is truncated: it ends before the compressed"],
    );
    assert_rejected(
        b"VERSION 0.7\nFIELDS x y z\n",
        &["the file ends before the DATA line"],
    );
}

#[test]
fn points_not_width_times_height() {
    let p = small();
    let mut b = header_text(&p, 13).into_bytes();
    b.extend_from_slice(&body(&p));
    assert_rejected(
        &b,
        &["header: POINTS 13 is not WIDTH 4 x HEIGHT 3: the header contradicts itself"],
    );
}

#[test]
fn compressed_size_past_the_end() {
    let p = small().with_data("binary_compressed");
    let mut b = bytes(&p);
    let at = header_text(&p, 12).len();
    b[at..at + 4].copy_from_slice(&1_000_000u32.to_le_bytes());
    assert_rejected(
        &b,
        &["the compressed size 1000000 runs past the end of the file"],
    );
}

#[test]
fn uncompressed_size_that_does_not_match() {
    let p = small().with_data("binary_compressed");
    let mut b = bytes(&p);
    let at = header_text(&p, 12).len();
    b[at + 4..at + 8].copy_from_slice(&4_000_000_000u32.to_le_bytes());
    assert_rejected(
        &b,
        &["the uncompressed size 4000000000 does not match the header's 12 points of 45 bytes"],
    );
    // Sizes that agree with the header, LZF data that does not: a damaged stream.
    let mut b = bytes(&p);
    let n = b.len();
    b[n - 30..].fill(0xff);
    assert_rejected(&b, &["the LZF data"]);
}

#[test]
fn unknown_type_size_pairs() {
    let mut p = small();
    p.fields[7] = field("intensity", 'U', 3, 1);
    assert_rejected(
        header_text(&p, 12).as_bytes(),
        &[
            "field `intensity` has TYPE U SIZE 3, which is no PCD type (sharpedge reads I 1, I 2, I 4, I 8, U 1, U 2, U 4, U 8, F 4, F 8)",
        ],
    );
    let mut p = small();
    p.fields[7] = field("intensity", 'Q', 2, 1);
    assert_rejected(header_text(&p, 12).as_bytes(), &["unknown TYPE `Q`"]);
}

#[test]
fn missing_coordinates() {
    let mut p = small();
    p.fields[1].name = "yy".into();
    assert_rejected(
        &bytes(&p),
        &[
            "no `y` field (FIELDS x yy z _ normal_x",
            "sharpedge needs x, y and z",
        ],
    );
}

#[test]
fn bad_header_lines() {
    let good = header_text(&small(), 12);
    for (from, to, msg) in [
        (
            "WIDTH 4",
            "WIDTH four",
            "line 7: WIDTH `four` is not a whole number",
        ),
        ("VERSION 0.7", "VERSION 0.9", "unknown PCD version `0.9`"),
        (
            "HEIGHT 3",
            "HEIGHT 3\nCOLOUR red",
            "`COLOUR red` is no PCD header line",
        ),
        (
            "SIZE 4 4 4 1",
            "SIZE 4 4 1",
            "SIZE has 11 values but FIELDS names 12 fields",
        ),
        (
            "VIEWPOINT 0.5",
            "VIEWPOINT nan",
            "VIEWPOINT takes 7 finite numbers",
        ),
        (
            "DATA binary",
            "DATA binary_zip",
            "unknown DATA `binary_zip`",
        ),
        ("COUNT 1", "COUNT 0", "field `x` has COUNT 0"),
        (
            "FIELDS x y z _",
            "FIELDS x y z x",
            "field `x` is named twice",
        ),
    ] {
        assert!(good.contains(from), "{from}");
        let mut b = good.replacen(from, to, 1).into_bytes();
        b.extend_from_slice(&body(&small()));
        assert_rejected(&b, &[msg]);
    }
}

#[test]
fn info_describes_a_frame() {
    let c = Case::new();
    write(
        &c.path().join("frame.pcd"),
        &small().with_data("binary_compressed"),
    );
    let r = sharpedge(c.path(), &["info", "frame.pcd"]);
    r.assert_ok();
    for line in [
        "format:      PCD 0.7 binary_compressed, organised 4 x 3",
        "encoding:    binary_compressed",
        "organisation: organised 4 x 3 (WIDTH x HEIGHT), 2 of 12 slots NaN (no return, not points)",
        "viewpoint:   origin 0.5 -1 2, orientation (w x y z) 0.6 0 0.8 0",
        "points:      10",
        "properties:  x (F 4), y (F 4), z (F 4), _ (U 1 x 4), normal_x (F 4)",
        "rgb (F 4, packed colour: red, green, blue), hist (I 1 x 3), time (F 8)",
    ] {
        assert!(r.stdout.contains(line), "`{line}` not in\n{}", r.stdout);
    }
    let _ = Path::new("");
}
