//! A synthetic box 4,000,000 units from the origin (a georeferenced offset), written by the
//! real `sharpedge synth` in binary and ascii, reads back within 1e-6 of the simulator's own
//! positions; `--translate` takes `X,Y,Z` as the README documents (and `X Y Z`).

mod run_common;

use run_common::*;
use sharpedge::io::{self, PlyWriteOptions, Precision, ReadOptions};
use sharpedge::synth::{Part, Sampling, SynthParams, generate};

const FAR: [f64; 3] = [4_000_000.0, 4_000_000.0, 100.0];

/// The CLI's `--part box --points 50000 --noise 0.15 --round 1.5 --rotate` with `FAR`.
fn far_box() -> SynthParams {
    SynthParams {
        part: Part::Box,
        sampling: Sampling::Points(50_000),
        noise: 0.15,
        round: 1.5,
        rotate: true,
        translate: FAR,
        ..Default::default()
    }
}

fn worst_difference(a: &[[f64; 3]], b: &[[f64; 3]]) -> f64 {
    assert_eq!(a.len(), b.len());
    a.iter()
        .zip(b)
        .flat_map(|(p, q)| (0..3).map(move |k| (p[k] - q[k]).abs()))
        .fold(0.0, f64::max)
}

#[test]
fn far_offset_box_written_by_synth_reads_back_within_1e_6() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let expected = generate(&far_box()).unwrap().cloud.positions;
    assert!(expected.iter().all(|p| p[0] > 3.9e6 && p[1] > 3.9e6));
    for (name, extra) in [("far.ply", None), ("far_ascii.ply", Some("--ascii"))] {
        let mut args = BOX.to_vec();
        args.extend(["--translate", "4000000,4000000,100"]);
        args.extend(extra);
        let path = synth(d, name, &args);
        let bytes = std::fs::read(&path).unwrap();
        let h = parse_header(&bytes);
        assert_eq!(
            h.format,
            if extra.is_some() {
                "ascii"
            } else {
                "binary_little_endian"
            }
        );
        for c in ["x", "y", "z"] {
            assert_eq!(h.element("vertex").ty(c), Some("double"), "{name}: {c}");
        }
        let back = read_cloud(&path);
        assert!(back.source.double_precision, "{name}");
        let worst = worst_difference(&back.positions, &expected);
        assert!(worst <= 1e-6, "{name}: points moved by up to {worst}");
    }
}

#[test]
fn float_coordinates_would_fail_the_far_offset_check() {
    // The 1e-6 check above can fail: the same points written as float are centimetres off.
    let dir = tempfile::tempdir().unwrap();
    let scan = generate(&far_box()).unwrap();
    assert_eq!(Precision::for_source(&scan.cloud.source), Precision::F64);
    let path = dir.path().join("float.ply");
    let opts = PlyWriteOptions {
        precision: Precision::F32,
        ..Default::default()
    };
    io::write_ply(&path, &scan.cloud.positions, &[], &[], &opts).unwrap();
    let back = io::read(&path, &ReadOptions::default()).unwrap();
    let worst = worst_difference(&back.positions, &scan.cloud.positions);
    assert!(
        worst > 1e-2,
        "float at 4e6 should lose centimetres, lost {worst}"
    );
}

#[test]
fn translate_takes_x_y_z_with_commas_or_spaces() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let base = ["--part", "box", "--points", "2000", "--noise", "0.1"];
    let mut comma = base.to_vec();
    comma.extend(["--translate", "512345.123,4101234.567,-80"]);
    let mut spaced = base.to_vec();
    spaced.extend(["--translate", "512345.123", "4101234.567", "-80"]);
    let a = std::fs::read(synth(d, "comma.ply", &comma)).unwrap();
    let b = std::fs::read(synth(d, "spaced.ply", &spaced)).unwrap();
    assert!(a == b, "the two spellings wrote different files");
    let c = read_cloud(&d.join("comma.ply"));
    let lo = c
        .positions
        .iter()
        .fold([f64::INFINITY; 3], |m, p| [0, 1, 2].map(|k| m[k].min(p[k])));
    assert!(
        lo[0] > 512_000.0 && lo[1] > 4_101_000.0 && lo[2] < -80.0,
        "{lo:?}"
    );
    // Two numbers are refused with a message, and nothing is written.
    let mut short = base.to_vec();
    short.extend(["-o", "short.ply", "--translate", "1,2"]);
    let mut all = vec!["-q", "synth"];
    all.extend(short);
    let run = sharpedge(d, &all);
    assert_eq!(run.code, Some(1), "{run:#?}");
    assert!(
        run.stderr
            .contains("--translate takes three numbers X,Y,Z, got 2"),
        "{}",
        run.stderr
    );
    assert!(!d.join("short.ply").exists());
}
