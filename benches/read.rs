//! Reading is never the slow stage: `io::read` of a 5,000,000-point binary little-endian PLY
//! (float x y z + uchar red green blue, 75 MB) against a plain `std::fs::read` of the same
//! bytes from the disk cache, and LAS against LAZ of autzen_trim (when ../shared/data is
//! present). The requirement is read <= 6x the plain read.
//!
//! Also measured: the same file through ply-rs-bw's typed path alone (`read_ply_via_crate`),
//! the reference for the hand-written binary decoder that `io::read` uses.
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

/// Writes the test cloud: a jittered 3D grid so the coordinates are not trivially compressible.
fn make_ply(dir: &Path) -> PathBuf {
    let path = dir.join("bench_5m.ply");
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
    let [r, g, b] = rgb;
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
    io::write_ply(&path, &positions, &refs, &[], &PlyWriteOptions::default())
        .expect("writing the benchmark file into a temp folder");
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
    let ply = make_ply(dir.path());
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
    if have_lidar {
        let a = median_secs(|| drop(black_box(io::read(&las, &opts).expect("las"))), 5);
        let b = median_secs(|| drop(black_box(io::read(&laz, &opts).expect("laz"))), 5);
        println!(
            "autzen_trim 110k points: LAS {a:.4} s, LAZ {b:.4} s, ratio LAZ/LAS {:.2}",
            b / a
        );
    }
}
