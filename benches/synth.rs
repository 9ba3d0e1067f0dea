//! Speed of the scan simulator and of the ground truth's queries.
//!
//! References measured in the same run: `reference/uniform_1M` fills the same output arrays
//! (positions and per-point truth) with uniform random points, the least work any generator
//! can do; `truth/brute_force_1k` answers surface-distance queries on fandisk by looping over
//! all triangles, against `truth/grid_100k` with the grid index.

use std::hint::black_box;
use std::path::Path;
use std::time::Duration;

use criterion::{Criterion, criterion_group, criterion_main};
use rand::rngs::SmallRng;
use rand::{RngExt, SeedableRng};
use sharpedge::geometry::point_triangle;
use sharpedge::synth::{Part, PointTruth, Sampling, SynthParams, TruthSurface, generate};

fn scan_params(part: Part, n: usize) -> SynthParams {
    SynthParams {
        part,
        sampling: Sampling::Points(n),
        noise: 0.15,
        round: 1.5,
        edge_noise: 0.3,
        outliers: 0.001,
        rotate: true,
        ..Default::default()
    }
}

fn generator(c: &mut Criterion) {
    let mut g = c.benchmark_group("synth");
    g.sample_size(10).measurement_time(Duration::from_secs(8));
    g.bench_function("reference/uniform_1M", |b| {
        b.iter(|| {
            let n = 1_000_000;
            let mut rng = SmallRng::seed_from_u64(1);
            let pos: Vec<[f64; 3]> = (0..n)
                .map(|_| [rng.random(), rng.random(), rng.random()])
                .collect();
            let truth: Vec<PointTruth> = pos
                .iter()
                .map(|&p| PointTruth {
                    surface: p,
                    edge_distance: 0.0,
                    nearest_edge: 0,
                    face: 0,
                    abnormal: false,
                    outlier: false,
                    view: u32::MAX,
                    noise: 0.0,
                })
                .collect();
            black_box((pos, truth))
        })
    });
    g.bench_function("box_1M", |b| {
        b.iter(|| black_box(generate(&scan_params(Part::Box, 1_000_000)).unwrap()))
    });
    let fandisk = Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/data/cad/fandisk.off");
    if fandisk.is_file() {
        g.bench_function("fandisk_1M", |b| {
            b.iter(|| {
                black_box(generate(&scan_params(Part::Mesh(fandisk.clone()), 1_000_000)).unwrap())
            })
        });
    } else {
        eprintln!("skipped fandisk: ../shared/data absent");
    }
    g.bench_function("box_10M", |b| {
        b.iter(|| black_box(generate(&scan_params(Part::Box, 10_000_000)).unwrap()))
    });
    g.finish();
}

fn queries(c: &mut Criterion) {
    let fandisk = Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/data/cad/fandisk.off");
    if !fandisk.is_file() {
        eprintln!("skipped queries: ../shared/data absent");
        return;
    }
    let scan = generate(&SynthParams {
        noise: 0.5,
        ..scan_params(Part::Mesh(fandisk), 100_000)
    })
    .unwrap();
    let gt = scan.ground_truth;
    let pts = scan.cloud.positions;
    gt.distance_to_surface(pts[0]); // build the index outside the timing
    let mut g = c.benchmark_group("truth");
    g.sample_size(10);
    g.bench_function("grid_100k", |b| {
        b.iter(|| {
            let s: f64 = pts
                .iter()
                .map(|&p| {
                    gt.distance_to_surface(p) + gt.distance_to_nearest_edge(p).map_or(0.0, |d| d.0)
                })
                .sum();
            black_box(s)
        })
    });
    let TruthSurface::Mesh {
        vertices,
        triangles,
    } = &gt.surface
    else {
        return;
    };
    g.bench_function("brute_force_1k", |b| {
        b.iter(|| {
            let s: f64 = pts[..1000]
                .iter()
                .map(|&p| {
                    triangles
                        .iter()
                        .map(|t| {
                            let [a, b, c] = t.map(|i| vertices[i as usize]);
                            point_triangle(p, a, b, c)
                        })
                        .fold(f64::INFINITY, f64::min)
                })
                .sum();
            black_box(s)
        })
    });
    g.finish();
}

criterion_group!(benches, generator, queries);
criterion_main!(benches);
