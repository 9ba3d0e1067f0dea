//! Criterion benchmarks of the corner fits at the sizes the pipeline calls them with:
//! one 3D vertex of 3 edges with 201 points (PSO, exact, Scheme 1, GA as a reference, and the
//! whole fit), and one 2D edge profile of 100 points (the whole fit and its parts).
//!
//! Run: `cargo bench --bench fit`.

use std::hint::black_box;
use std::time::Duration;

use criterion::{Criterion, criterion_group, criterion_main};
use rand::SeedableRng;
use rand::rngs::SmallRng;
use sharpedge::fit::{
    self, CornerFit, CornerScratch, FitParams, GaScratch, ProfileFit, ProfileScratch, SwarmScratch,
    standard_normal,
};

/// A noisy box corner at (10, 10, 10): three edges of length 10, `per_side` points each,
/// noise 0.1, the vertex itself missing.
fn box_corner(per_side: usize) -> Vec<Vec<[f64; 3]>> {
    let mut rng = SmallRng::seed_from_u64(11);
    let dirs = [[0.8, 0.6, 0.0], [-0.6, 0.8, 0.0], [0.0, 0.0, 1.0]];
    dirs.iter()
        .map(|d| {
            (1..=per_side)
                .map(|i| {
                    let t = 10.0 * i as f64 / per_side as f64;
                    std::array::from_fn(|k| 10.0 + t * d[k] + 0.1 * standard_normal(&mut rng))
                })
                .collect()
        })
        .collect()
}

/// A noisy unordered 2D profile: a 100° V, 50 points per side, noise 0.1.
fn profile() -> Vec<[f64; 2]> {
    let mut rng = SmallRng::seed_from_u64(12);
    let h = 50f64.to_radians();
    let dirs = [[h.sin(), -h.cos()], [-h.sin(), -h.cos()]];
    let mut pts = Vec::new();
    for i in 1..=50 {
        for d in &dirs {
            let t = 0.2 * i as f64;
            pts.push([
                10.0 + t * d[0] + 0.1 * standard_normal(&mut rng),
                10.0 + t * d[1] + 0.1 * standard_normal(&mut rng),
            ]);
        }
    }
    pts
}

fn corner_3d(c: &mut Criterion) {
    let params = FitParams::default();
    let sides = box_corner(67);
    let slices: Vec<&[[f64; 3]]> = sides.iter().map(|s| s.as_slice()).collect();
    let approx = [10.2, 9.9, 10.1];
    let mut scratch = CornerScratch::default();
    let mut out = CornerFit::default();
    fit::prepare_corner_3d(&slices, approx, &params, &mut scratch, &mut out).unwrap();
    let p = scratch.problem().unwrap();
    let mut g = c.benchmark_group("corner_3d_3lines_201pts");
    g.measurement_time(Duration::from_secs(4));
    let mut swarm = SwarmScratch::default();
    let mut hist = Vec::new();
    g.bench_function("pso", |b| {
        let mut rng = SmallRng::seed_from_u64(1);
        b.iter(|| {
            black_box(fit::pso(
                p.objective,
                p.candidates,
                &p.basis,
                p.scale,
                &params.pso,
                params.pso.iterations_3d,
                &mut rng,
                &mut swarm,
                &mut hist,
            ))
        })
    });
    g.bench_function("exact", |b| {
        b.iter(|| black_box(fit::exact_3d(p.objective, p.scale, &params.exact).unwrap()))
    });
    g.bench_function("scheme1", |b| {
        b.iter(|| black_box(fit::scheme1(p.objective, p.candidates)))
    });
    let mut ga = GaScratch::default();
    g.bench_function("ga", |b| {
        let mut rng = SmallRng::seed_from_u64(2);
        b.iter(|| {
            black_box(fit::ga(
                p.objective,
                p.candidates,
                &p.basis,
                p.scale,
                &params.ga,
                params.pso.iterations_3d,
                &mut rng,
                &mut ga,
                &mut hist,
            ))
        })
    });
    let mut s2 = CornerScratch::default();
    let mut o2 = CornerFit::default();
    g.bench_function("fit_corner_3d_whole", |b| {
        let mut rng = SmallRng::seed_from_u64(3);
        b.iter(|| {
            fit::fit_corner_3d_with(&slices, approx, &params, &mut rng, &mut s2, &mut o2).unwrap();
            black_box(o2.searches.pso.error)
        })
    });
    g.finish();
}

fn profile_2d(c: &mut Criterion) {
    let params = FitParams::default();
    let pts = profile();
    let approx = [10.1, 10.2];
    let mut scratch = ProfileScratch::default();
    let mut out = ProfileFit::default();
    fit::prepare_profile_2d(&pts, approx, &params, &mut scratch, &mut out).unwrap();
    let mut g = c.benchmark_group("profile_2d_100pts");
    g.measurement_time(Duration::from_secs(4));
    {
        let p = scratch.problem().unwrap();
        let mut swarm = SwarmScratch::default();
        let mut hist = Vec::new();
        g.bench_function("pso", |b| {
            let mut rng = SmallRng::seed_from_u64(1);
            b.iter(|| {
                black_box(fit::pso(
                    p.objective,
                    p.candidates,
                    &p.basis,
                    p.scale,
                    &params.pso,
                    params.pso.iterations_2d,
                    &mut rng,
                    &mut swarm,
                    &mut hist,
                ))
            })
        });
        let mut med = Vec::new();
        g.bench_function("exact", |b| {
            b.iter(|| black_box(fit::exact_2d(p.objective, &mut med).unwrap()))
        });
    }
    let mut s2 = ProfileScratch::default();
    g.bench_function("prepare", |b| {
        b.iter(|| {
            fit::prepare_profile_2d(&pts, approx, &params, &mut s2, &mut out).unwrap();
            black_box(out.c)
        })
    });
    g.bench_function("fit_profile_2d_whole", |b| {
        let mut rng = SmallRng::seed_from_u64(3);
        b.iter(|| {
            fit::fit_profile_2d_with(&pts, approx, &params, &mut rng, &mut s2, &mut out).unwrap();
            black_box(out.searches.pso.error)
        })
    });
    g.finish();
}

criterion_group!(benches, corner_3d, profile_2d);
criterion_main!(benches);
