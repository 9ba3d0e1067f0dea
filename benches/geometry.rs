//! The benchmark behind the crate's geometry vocabulary (see `src/geometry/mod.rs`): the
//! arithmetic of the two hot paths, written once with our functions on `[f64; N]` and once
//! with nalgebra's `Vector3`/`Vector2` (converted from the `[f64; 3]` data, as they would be).
//!
//! - features: the per-point moments of the neighbour offsets (2,000 queries x 32 neighbours
//!   in a 20,000-point cloud): offset, outer product, sums.
//! - fit: the objective's inner loop, the sum of point-to-line distances of 201 points to 3
//!   lines in 3D and of 100 points to 2 lines in 2D.
//!
//! Run: `cargo bench --bench geometry`.

use std::hint::black_box;
use std::time::Duration;

use criterion::{Criterion, criterion_group, criterion_main};
use nalgebra::{Matrix3, SVector, Vector3};
use rand::rngs::SmallRng;
use rand::{RngExt, SeedableRng};
use sharpedge::features::add_moments;
use sharpedge::geometry::{norm, reject, sub};

fn cloud(n: usize, seed: u64) -> Vec<[f64; 3]> {
    let mut rng = SmallRng::seed_from_u64(seed);
    (0..n)
        .map(|_| {
            [
                rng.random::<f64>(),
                rng.random::<f64>(),
                rng.random::<f64>(),
            ]
        })
        .collect()
}

/// Query points and, per query, 32 neighbour indices (the arithmetic alone, no search).
fn neighbourhoods(n: usize, queries: usize) -> Vec<(usize, Vec<usize>)> {
    let mut rng = SmallRng::seed_from_u64(5);
    (0..queries)
        .map(|_| {
            let q = rng.random_range(0..n);
            (q, (0..32).map(|_| rng.random_range(0..n)).collect())
        })
        .collect()
}

/// The features stage's own accumulation (`features::add_moments`) on our offsets.
fn moments_ours(pts: &[[f64; 3]], hoods: &[(usize, Vec<usize>)]) -> f64 {
    let mut acc = 0.0;
    for (q, ids) in hoods {
        let mut m = [0.0f64; 10];
        for &i in ids {
            add_moments(&mut m, sub(pts[i], pts[*q]));
        }
        acc += m.iter().sum::<f64>();
    }
    acc
}

fn moments_nalgebra(pts: &[[f64; 3]], hoods: &[(usize, Vec<usize>)]) -> f64 {
    let mut acc = 0.0;
    for (q, ids) in hoods {
        let q = Vector3::from(pts[*q]);
        let (mut n, mut s, mut m) = (0.0, Vector3::zeros(), Matrix3::zeros());
        for &i in ids {
            let d = Vector3::from(pts[i]) - q;
            n += 1.0;
            s += d;
            m += d * d.transpose();
        }
        acc += n + s.sum() + m.sum();
    }
    acc
}

type Line3 = ([f64; 3], [f64; 3]);

fn lines_3d() -> (Vec<[f64; 3]>, Vec<Line3>) {
    let pts = cloud(201, 7);
    let lines = vec![
        ([0.5, 0.5, 0.5], [0.8, 0.6, 0.0]),
        ([0.5, 0.5, 0.5], [-0.6, 0.8, 0.0]),
        ([0.5, 0.5, 0.5], [0.0, 0.0, 1.0]),
    ];
    (pts, lines)
}

fn distances_ours<const N: usize>(pts: &[[f64; N]], lines: &[([f64; N], [f64; N])]) -> f64 {
    let mut s = 0.0;
    for (o, d) in lines {
        for p in pts {
            s += norm(reject(sub(p, o), d));
        }
    }
    s
}

fn distances_nalgebra<const N: usize>(pts: &[[f64; N]], lines: &[([f64; N], [f64; N])]) -> f64 {
    let mut s = 0.0;
    for (o, d) in lines {
        let (o, d) = (SVector::<f64, N>::from(*o), SVector::<f64, N>::from(*d));
        for p in pts {
            let v = SVector::<f64, N>::from(*p) - o;
            s += (v - d * v.dot(&d)).norm();
        }
    }
    s
}

fn bench(c: &mut Criterion) {
    let pts = cloud(20_000, 3);
    let hoods = neighbourhoods(pts.len(), 2_000);
    let mut g = c.benchmark_group("features_moments");
    g.bench_function("ours", |b| b.iter(|| moments_ours(black_box(&pts), &hoods)));
    g.bench_function("nalgebra", |b| {
        b.iter(|| moments_nalgebra(black_box(&pts), &hoods))
    });
    g.finish();

    let (p3, l3) = lines_3d();
    let mut g = c.benchmark_group("fit_distances_3d");
    g.bench_function("ours", |b| b.iter(|| distances_ours(black_box(&p3), &l3)));
    g.bench_function("nalgebra", |b| {
        b.iter(|| distances_nalgebra(black_box(&p3), &l3))
    });
    g.finish();

    let p2: Vec<[f64; 2]> = p3[..100].iter().map(|p| [p[0], p[1]]).collect();
    let l2 = vec![([0.5, 0.5], [0.8, 0.6]), ([0.5, 0.5], [-0.6, 0.8])];
    let mut g = c.benchmark_group("fit_distances_2d");
    g.bench_function("ours", |b| b.iter(|| distances_ours(black_box(&p2), &l2)));
    g.bench_function("nalgebra", |b| {
        b.iter(|| distances_nalgebra(black_box(&p2), &l2))
    });
    g.finish();
}

criterion_group! {
    name = benches;
    config = Criterion::default()
        .warm_up_time(Duration::from_millis(500))
        .measurement_time(Duration::from_secs(2));
    targets = bench
}
criterion_main!(benches);
