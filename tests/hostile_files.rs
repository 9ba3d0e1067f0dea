//! Issue 12: hostile files. Every class of hostile input the campaign used (lying counts,
//! huge headers, elements with no bytes, duplicated names, degenerate clouds, far offsets,
//! tiny and huge scales, bad meshes and configs), made here, goes through every command that
//! reads it: each answers within 20 s with exit 0 or a clear error naming the file (exit 1,
//! one `error:` line, no panic, no abort), and a failed run writes no output folder.
//!
//! The 20 s bound is a hang guard, not a benchmark: every case takes well under a second.
//! Each command runs under a 3 GiB address-space limit, so an allocation the file cannot back
//! shows as an abort.

mod run_common;

use std::io::{Read, Seek, SeekFrom};
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use run_common::{BIN, config, synth};

const LIMIT: Duration = Duration::from_secs(20);

struct Answer {
    code: Option<i32>,
    stderr: String,
    took: Duration,
}

/// Runs `sharpedge ARGS` in `dir`; killed (and the test failed) past [`LIMIT`].
fn answer(dir: &Path, args: &[&str]) -> Answer {
    let mut err = tempfile::tempfile().unwrap();
    // Under a 3 GiB address-space limit: an allocation the file cannot back fails (and
    // aborts, which `check` reports) instead of swapping the machine.
    let mut child = Command::new("sh")
        .arg("-c")
        .arg("ulimit -v 3145728 && exec \"$0\" \"$@\"")
        .arg(BIN)
        .args(args)
        .current_dir(dir)
        .env_remove("RUST_LOG")
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(err.try_clone().unwrap())
        .spawn()
        .unwrap();
    let start = Instant::now();
    let status = loop {
        if let Some(s) = child.try_wait().unwrap() {
            break s;
        }
        if start.elapsed() > LIMIT {
            let _ = child.kill();
            let _ = child.wait();
            panic!("sharpedge {args:?} gave no answer within {LIMIT:?}");
        }
        std::thread::sleep(Duration::from_millis(10));
    };
    let mut stderr = String::new();
    err.seek(SeekFrom::Start(0)).unwrap();
    err.read_to_string(&mut stderr).unwrap();
    Answer {
        code: status.code(),
        stderr,
        took: start.elapsed(),
    }
}

/// Exit 0, or exit 1 with one clear `error:` naming `name`; never a panic or a signal.
fn check(a: &Answer, what: &str, name: &str) {
    assert!(
        !a.stderr.contains("panicked") && !a.stderr.contains("memory allocation"),
        "{what}: {}",
        a.stderr
    );
    match a.code {
        Some(0) => {}
        Some(1) => assert!(
            a.stderr.starts_with("error: ") && a.stderr.contains(name),
            "{what}: the error does not name the file: {}",
            a.stderr
        ),
        c => panic!("{what}: exit {c:?} (a signal or a panic): {}", a.stderr),
    }
}

/// `info FILE` and `run` on it (and nothing written when the run fails).
fn every_command(dir: &Path, name: &str) {
    let a = answer(dir, &["info", name]);
    check(&a, &format!("info {name}"), name);
    let out = dir.join(format!("out-{name}"));
    let out_s = out.to_string_lossy().into_owned();
    let r = answer(
        dir,
        &[
            "-q",
            "run",
            "pipeline.toml",
            "--input",
            name,
            "--out",
            &out_s,
        ],
    );
    check(&r, &format!("run {name}"), name);
    if r.code != Some(0) {
        assert!(
            !out.exists(),
            "run {name} failed but left {}",
            out.display()
        );
    }
    println!(
        "{name}: info exit {:?} in {:.2?}, run exit {:?} in {:.2?}",
        a.code, a.took, r.code, r.took
    );
}

fn put(dir: &Path, name: &str, bytes: impl AsRef<[u8]>) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, bytes).unwrap();
    p
}

fn ply_header(format: &str, elements: &str) -> String {
    format!("ply\nformat {format} 1.0\n{elements}end_header\n")
}

const XYZ_FLOAT: &str = "element vertex 3\nproperty float x\nproperty float y\nproperty float z\n";

/// A binary float PLY of `points`.
fn float_ply(points: &[[f64; 3]]) -> Vec<u8> {
    let mut b = ply_header(
        "binary_little_endian",
        &format!(
            "element vertex {}\nproperty float x\nproperty float y\nproperty float z\n",
            points.len()
        ),
    )
    .into_bytes();
    for p in points {
        for c in p {
            b.extend_from_slice(&(*c as f32).to_le_bytes());
        }
    }
    b
}

fn setup() -> tempfile::TempDir {
    let d = tempfile::tempdir().unwrap();
    config(d.path(), "threads = 2\n");
    d
}

#[test]
fn hostile_ply_headers_and_counts() {
    let d = setup();
    let dir = d.path();
    let bin = "binary_little_endian";
    let cases: Vec<(&str, Vec<u8>)> = vec![
        // An element of no bytes before `vertex` with a count of 2^64-1.
        (
            "empty_element_huge_count.ply",
            ply_header(bin, &format!("element junk 18446744073709551615\n{XYZ_FLOAT}"))
                .into_bytes(),
        ),
        (
            "empty_element_huge_count_ascii.ply",
            ply_header("ascii", &format!("element junk 18446744073709551615\n{XYZ_FLOAT}"))
                .into_bytes(),
        ),
        // Counts far past the file's bytes.
        (
            "vertex_count_4e9.ply",
            [
                ply_header(bin, &XYZ_FLOAT.replace("vertex 3", "vertex 4000000000")).into_bytes(),
                vec![0; 36],
            ]
            .concat(),
        ),
        (
            "vertex_count_u64_max_ascii.ply",
            ply_header(
                "ascii",
                &XYZ_FLOAT.replace("vertex 3", "vertex 18446744073709551615"),
            )
            .into_bytes(),
        ),
        // count x record size overflows 64 bits.
        (
            "vertex_bytes_overflow.ply",
            [
                ply_header(
                    bin,
                    &XYZ_FLOAT.replace("vertex 3", "vertex 4611686018427387904"),
                )
                .into_bytes(),
                vec![0; 36],
            ]
            .concat(),
        ),
        // A face list whose length prefix claims 2^32-1 entries.
        (
            "face_list_huge.ply",
            [
                ply_header(
                    bin,
                    &format!(
                        "element face 1\nproperty list uint int vertex_indices\n{XYZ_FLOAT}"
                    ),
                )
                .into_bytes(),
                u32::MAX.to_le_bytes().to_vec(),
                vec![0; 36],
            ]
            .concat(),
        ),
        // Two properties named x: which one is x?
        (
            "two_x.ply",
            [
                ply_header(
                    bin,
                    "element vertex 2\nproperty float x\nproperty float x\nproperty float y\nproperty float z\n",
                )
                .into_bytes(),
                vec![0; 32],
            ]
            .concat(),
        ),
        // 50,000 properties before x y z; 50,000 empty elements before vertex.
        (
            "many_properties.ply",
            ply_header(
                bin,
                &format!(
                    "element vertex 1\n{}property float x\nproperty float y\nproperty float z\n",
                    (0..50_000)
                        .map(|i| format!("property float p{i}\n"))
                        .collect::<String>()
                ),
            )
            .into_bytes(),
        ),
        (
            "many_elements.ply",
            [
                ply_header(
                    "ascii",
                    &format!(
                        "{}{XYZ_FLOAT}",
                        (0..50_000)
                            .map(|i| format!("element e{i} 0\n"))
                            .collect::<String>()
                    ),
                ),
                "0 0 0\n1 0 0\n0 1 0\n".to_string(),
            ]
            .concat()
            .into_bytes(),
        ),
        // A header that never ends, 20 MB long.
        (
            "endless_header.ply",
            format!("ply\nformat ascii 1.0\ncomment {}", "a".repeat(20_000_000)).into_bytes(),
        ),
        // One ascii vertex line of 5,000,000 values.
        (
            "endless_vertex_line.ply",
            format!(
                "{}{}\n",
                ply_header("ascii", &XYZ_FLOAT.replace("vertex 3", "vertex 1")),
                "1 ".repeat(5_000_000)
            )
            .into_bytes(),
        ),
        (
            "negative_count.ply",
            ply_header(bin, &XYZ_FLOAT.replace("vertex 3", "vertex -1")).into_bytes(),
        ),
    ];
    for (name, bytes) in cases {
        put(dir, name, bytes);
        every_command(dir, name);
    }
}

#[test]
fn hostile_xyz_columns_and_lines() {
    let d = setup();
    let dir = d.path();
    let cases: Vec<(&str, String)> = vec![
        // 20,000 equal column names (80 KB).
        (
            "equal_columns.xyz",
            format!("{}\n1 2 3\n", vec!["x"; 20_000].join(" ")),
        ),
        // 100,000 distinct columns and one row of them (more than a line may have).
        (
            "wide.xyz",
            format!(
                "x y z {}\n{}\n",
                (0..100_000)
                    .map(|i| format!("c{i}"))
                    .collect::<Vec<_>>()
                    .join(" "),
                vec!["1"; 100_003].join(" ")
            ),
        ),
        // One line of 10,000,000 numbers, no header.
        (
            "one_long_line.xyz",
            format!("1 2 3 {}\n", "4 ".repeat(10_000_000)),
        ),
        ("nul_bytes.xyz", "1 2 3\n\0\0\0\0\n4 5 6\n".to_string()),
    ];
    for (name, text) in cases {
        put(dir, name, text);
        every_command(dir, name);
    }
}

/// A LAS 1.2 header (point format 0) with the given counts and offsets, and `body` after it.
fn las(points: u32, offset: u32, record: u16, vlrs: u32, body: &[u8]) -> Vec<u8> {
    let mut h = vec![0u8; 227];
    h[0..4].copy_from_slice(b"LASF");
    h[24] = 1;
    h[25] = 2;
    h[94..96].copy_from_slice(&227u16.to_le_bytes());
    h[96..100].copy_from_slice(&offset.to_le_bytes());
    h[100..104].copy_from_slice(&vlrs.to_le_bytes());
    h[105..107].copy_from_slice(&record.to_le_bytes());
    h[107..111].copy_from_slice(&points.to_le_bytes());
    for i in 0..3 {
        h[131 + 8 * i..139 + 8 * i].copy_from_slice(&0.001f64.to_le_bytes());
    }
    [h, body.to_vec()].concat()
}

#[test]
fn hostile_las_headers() {
    let d = setup();
    let dir = d.path();
    let cases: Vec<(&str, Vec<u8>)> = vec![
        ("count_4e9.las", las(4_000_000_000, 227, 20, 0, &[0; 40])),
        ("offset_past_end.las", las(2, 1 << 31, 20, 0, &[0; 40])),
        ("record_length_0.las", las(1_000_000, 227, 0, 0, &[0; 40])),
        ("vlr_count_4e9.las", las(0, 227, 20, 4_000_000_000, &[])),
        ("header_only.las", las(0, 227, 20, 0, &[])[..100].to_vec()),
    ];
    for (name, bytes) in cases {
        put(dir, name, bytes);
        every_command(dir, name);
    }
}

#[test]
fn degenerate_clouds() {
    let d = setup();
    let dir = d.path();
    // Points on the surface of a 100 x 60 x 40 box, from a fixed generator.
    let mut state = 0x9e37_79b9_7f4a_7c15u64;
    let mut unit = move || {
        state = state
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1);
        (state >> 11) as f64 / (1u64 << 53) as f64
    };
    let size = [100.0, 60.0, 40.0];
    let pts: Vec<[f64; 3]> = (0..20_000)
        .map(|i| {
            let axis = i % 3;
            let mut p = [unit() * size[0], unit() * size[1], unit() * size[2]];
            p[axis] = if (i / 3) % 2 == 0 { 0.0 } else { size[axis] };
            p
        })
        .collect();
    let mut dup: Vec<[f64; 3]> = vec![[1.0, 2.0, 3.0]; 50_000];
    dup.extend(pts.iter().take(1000));
    let far: Vec<[f64; 3]> = pts.iter().map(|p| p.map(|c| c + 1e12)).collect();
    let scaled = |s: f64| -> Vec<[f64; 3]> { pts.iter().map(|p| p.map(|c| c * s)).collect() };
    let plane: Vec<[f64; 3]> = pts.iter().map(|p| [p[0], p[1], 0.0]).collect();
    let line: Vec<[f64; 3]> = pts.iter().map(|p| [p[0], 0.0, 0.0]).collect();
    let two: Vec<[f64; 3]> = (0..20_000).map(|i| [(i % 2) as f64, 0.0, 0.0]).collect();
    // 100,000 distinct points within 1e-3 of one point of the box (issue 12: 50,000 took 15 s
    // of quadratic work before crowded cells were thinned).
    let mut crowded = pts.clone();
    crowded.extend((0..100_000).map(|_| {
        let o = [unit(), unit(), unit()].map(|u| (u - 0.5) * 2e-3);
        [0, 1, 2].map(|k| pts[0][k] + o[k])
    }));
    let cases: Vec<(&str, Vec<[f64; 3]>)> = vec![
        ("duplicates_50k.ply", dup),
        ("far_1e12.ply", far),
        ("tiny_1e-30.ply", scaled(1e-30)),
        ("huge_1e30.ply", scaled(1e30)),
        ("denormal.ply", scaled(1e-40)),
        ("plane.ply", plane),
        ("line.ply", line),
        ("one_point_20k.ply", vec![[5.0, 5.0, 5.0]; 20_000]),
        ("two_positions.ply", two),
        ("crowded_100k.ply", crowded),
    ];
    for (name, p) in cases {
        put(dir, name, float_ply(&p));
        every_command(dir, name);
    }
}

#[test]
fn hostile_meshes() {
    let d = setup();
    let dir = d.path();
    let cases: Vec<(&str, String)> = vec![
        (
            "counts_huge.off",
            "OFF\n4000000000 4000000000 0\n0 0 0\n".into(),
        ),
        (
            "face_past_vertices.off",
            "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 99\n".into(),
        ),
        (
            "face_huge_arity.off",
            "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n4000000000 0 1 2\n".into(),
        ),
        (
            "index_out_of_range.obj",
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4000000000\n".into(),
        ),
        (
            "negative_index.obj",
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nf -1 -2 -9\n".into(),
        ),
        ("no_faces.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\n".into()),
        (
            "degenerate_faces.off",
            "OFF\n3 2 0\n0 0 0\n0 0 0\n0 0 0\n3 0 1 2\n3 0 0 0\n".into(),
        ),
    ];
    for (name, text) in cases {
        put(dir, name, text);
        let a = answer(dir, &["-q", "synth", "--mesh", name, "-o", "m.ply"]);
        check(&a, &format!("synth --mesh {name}"), name);
        if a.code != Some(0) {
            assert!(
                !dir.join("m.ply").exists(),
                "synth --mesh {name} failed but wrote"
            );
        }
        let _ = std::fs::remove_file(dir.join("m.ply"));
    }
}

#[test]
fn hostile_configs() {
    let d = setup();
    let dir = d.path();
    synth(dir, "box.ply", &["--part", "box", "--points", "5000"]);
    // The config and what its error must name: the file, or the key when the value is valid
    // on its own but not for this cloud.
    let cases: Vec<(&str, String, &str)> = vec![
        (
            "nested.toml",
            format!("x = {}{}\n", "[".repeat(10_000), "]".repeat(10_000)),
            "nested.toml",
        ),
        (
            "big_radius.toml",
            "[features]\nradius = 1e308\n".into(),
            "features.radius: 1e308 is larger than the whole cloud",
        ),
        (
            "big_noise.toml",
            "[features]\nnoise = 1e30\n".into(),
            "features.noise: 1e30 is larger than the whole cloud",
        ),
        ("nan.toml", "[features]\nradius = nan\n".into(), "nan.toml"),
        (
            "threads.toml",
            "threads = 1000000000\n".into(),
            "threads.toml",
        ),
        (
            "long_key.toml",
            format!("{} = 1\n", "k".repeat(1_000_000)),
            "long_key.toml",
        ),
        (
            "binary.toml",
            "\u{0}\u{1}\u{2}garbage".into(),
            "binary.toml",
        ),
    ];
    for (name, text, names) in cases {
        put(dir, name, text);
        let a = answer(
            dir,
            &["-q", "run", name, "--input", "box.ply", "--out", "cfg-out"],
        );
        check(&a, &format!("run {name}"), names);
        assert_eq!(a.code, Some(1), "run {name} accepted a hostile config");
        assert!(!dir.join("cfg-out").exists());
    }
}
