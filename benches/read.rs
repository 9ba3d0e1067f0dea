//! Reading is never the slow stage: `io::read` of a 5,000,000-point binary little-endian PLY
//! (float x y z + uchar red green blue, 75 MB) against a plain `std::fs::read` of the same
//! bytes from the disk cache. The requirement is read <= 6x the plain read.
//!
//! Also measured: the same file through ply-rs-bw's typed path alone (`read_ply_via_crate`),
//! the reference for the hand-written binary decoder that `io::read` uses; the same 5,000,000
//! points as LAS and as LAZ (point format 2: xyz + rgb, written here with the las crate), each
//! against its own plain read; and LAS against LAZ of autzen_trim (when ../shared/data is
//! present).
//!
//! Criterion reports each timing; at the end the benchmark times both once more (median of 5)
//! and prints the ratio, so one run gives the number to report. Run with
//! `cargo bench --bench read`.

use std::hint::black_box;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use criterion::Criterion;
use sharpedge::io::{self, PlyWriteOptions, ReadOptions};
use sharpedge::{Attribute, Column};

const N: usize = 5_000_000;

/// The test cloud: a jittered 3D grid so the coordinates are not trivially compressible, and
/// random colours.
fn make_cloud() -> (Vec<[f64; 3]>, [Vec<u8>; 3]) {
    let mut positions = Vec::with_capacity(N);
    let mut rgb = [
        Vec::with_capacity(N),
        Vec::with_capacity(N),
        Vec::with_capacity(N),
    ];
    let mut s: u64 = 0x9E37_79B9_7F4A_7C15;
    for i in 0..N {
        s ^= s << 13;
        s ^= s >> 7;
        s ^= s << 17;
        let j = (s >> 40) as f64 / (1u64 << 24) as f64;
        positions.push([
            (i % 200) as f64 + j,
            ((i / 200) % 200) as f64 - j,
            (i / 40_000) as f64 * 0.5 + j,
        ]);
        for (k, c) in rgb.iter_mut().enumerate() {
            c.push((s >> (8 * k)) as u8);
        }
    }
    (positions, rgb)
}

fn make_ply(dir: &Path, positions: &[[f64; 3]], rgb: &[Vec<u8>; 3]) -> PathBuf {
    let path = dir.join("bench_5m.ply");
    let [r, g, b] = rgb.clone();
    let attrs = [
        Attribute {
            name: "red".into(),
            values: Column::U8(r),
        },
        Attribute {
            name: "green".into(),
            values: Column::U8(g),
        },
        Attribute {
            name: "blue".into(),
            values: Column::U8(b),
        },
    ];
    let refs: Vec<&Attribute> = attrs.iter().collect();
    io::write_ply(&path, positions, &refs, &[], &PlyWriteOptions::default())
        .expect("writing the benchmark file into a temp folder");
    path
}

/// The same points as LAS or LAZ (by the extension of `name`), point format 2 (xyz + 16-bit
/// rgb), coordinates in steps of 1e-4.
fn make_las(dir: &Path, name: &str, positions: &[[f64; 3]], rgb: &[Vec<u8>; 3]) -> PathBuf {
    let path = dir.join(name);
    let mut builder = las::Builder::from((1, 2));
    builder.point_format = las::point::Format::new(2).expect("point format 2");
    let t = las::Transform {
        scale: 1e-4,
        offset: 0.0,
    };
    builder.transforms = las::Vector { x: t, y: t, z: t };
    let header = builder.into_header().expect("LAS header");
    let mut w = las::Writer::from_path(&path, header).expect("creating the LAS file");
    for (i, p) in positions.iter().enumerate() {
        let c = |k: usize| u16::from(rgb[k][i]) * 257;
        w.write_point(las::Point {
            x: p[0],
            y: p[1],
            z: p[2],
            color: Some(las::Color::new(c(0), c(1), c(2))),
            ..Default::default()
        })
        .expect("writing a LAS point");
    }
    w.close().expect("closing the LAS file");
    path
}

fn median_secs(mut f: impl FnMut(), runs: usize) -> f64 {
    let mut t: Vec<f64> = (0..runs)
        .map(|_| {
            let s = Instant::now();
            f();
            s.elapsed().as_secs_f64()
        })
        .collect();
    t.sort_by(f64::total_cmp);
    t[runs / 2]
}

fn main() {
    let dir = tempfile::tempdir().expect("temp folder");
    let (positions, rgb) = make_cloud();
    let ply = make_ply(dir.path(), &positions, &rgb);
    let las_5m = make_las(dir.path(), "bench_5m.las", &positions, &rgb);
    let laz_5m = make_las(dir.path(), "bench_5m.laz", &positions, &rgb);
    drop((positions, rgb));
    let opts = ReadOptions::default();
    let mut c = Criterion::default()
        .sample_size(10)
        .warm_up_time(Duration::from_secs(1))
        .measurement_time(Duration::from_secs(8))
        .configure_from_args();

    let mut g = c.benchmark_group("read_5M_ply");
    g.bench_function("std_fs_read", |b| {
        b.iter(|| black_box(std::fs::read(&ply).expect("read")))
    });
    g.bench_function("io_read", |b| {
        b.iter(|| black_box(io::read(&ply, &opts).expect("io::read")))
    });
    // The crate's typed path alone: the reference that justified the binary fast path.
    g.bench_function("ply_rs_bw_typed_path", |b| {
        b.iter(|| black_box(io::read_ply_via_crate(&ply).expect("typed path")))
    });
    g.finish();

    let mut g = c.benchmark_group("read_5M_las_laz");
    for (name, path) in [("las", &las_5m), ("laz", &laz_5m)] {
        g.bench_function(format!("std_fs_read_{name}"), |b| {
            b.iter(|| black_box(std::fs::read(path).expect("read")))
        });
        g.bench_function(format!("io_read_{name}"), |b| {
            b.iter(|| black_box(io::read(path, &opts).expect("io::read")))
        });
    }
    g.finish();

    let data = Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/data/lidar");
    let las = data.join("autzen_trim.las");
    let laz = data.join("autzen_trim.laz");
    let have_lidar = las.is_file() && laz.is_file();
    if have_lidar {
        let mut g = c.benchmark_group("read_autzen");
        g.bench_function("las", |b| {
            b.iter(|| black_box(io::read(&las, &opts).expect("las")))
        });
        g.bench_function("laz", |b| {
            b.iter(|| black_box(io::read(&laz, &opts).expect("laz")))
        });
        g.finish();
    } else {
        eprintln!("skipped LAS vs LAZ: ../shared/data absent");
    }
    c.final_summary();

    // The ratio the requirement is about, measured here in the same process.
    let raw = median_secs(|| drop(black_box(std::fs::read(&ply).expect("read"))), 5);
    let ours = median_secs(|| drop(black_box(io::read(&ply, &opts).expect("read"))), 5);
    let typed = median_secs(
        || drop(black_box(io::read_ply_via_crate(&ply).expect("read"))),
        5,
    );
    println!(
        "5M-point binary PLY: std::fs::read {raw:.3} s, io::read {ours:.3} s (ratio {:.2}, \
         requirement <= 6), ply-rs-bw typed path {typed:.3} s (ratio {:.2})",
        ours / raw,
        typed / raw
    );
    for (name, path) in [("LAS", &las_5m), ("LAZ", &laz_5m)] {
        let bytes = std::fs::metadata(path).map(|m| m.len()).unwrap_or(0);
        let raw_l = median_secs(|| drop(black_box(std::fs::read(path).expect("read"))), 5);
        let ours_l = median_secs(|| drop(black_box(io::read(path, &opts).expect("read"))), 5);
        println!(
            "5M points as {name} ({:.0} MB): std::fs::read {raw_l:.3} s, io::read {ours_l:.3} s \
             (ratio {:.2} to its own plain read, {:.2} to the PLY's plain read)",
            bytes as f64 / 1e6,
            ours_l / raw_l,
            ours_l / raw
        );
    }
    if have_lidar {
        let a = median_secs(|| drop(black_box(io::read(&las, &opts).expect("las"))), 5);
        let b = median_secs(|| drop(black_box(io::read(&laz, &opts).expect("laz"))), 5);
        println!(
            "autzen_trim 110k points: LAS {a:.4} s, LAZ {b:.4} s, ratio LAZ/LAS {:.2}",
            b / a
        );
    }
}
