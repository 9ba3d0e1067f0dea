//! Why the features stage finds its radius neighbourhoods with `neighbours::Grid` and not
//! with kiddo: on a 1,000,000-point simulated box scan (σ 0.15 spacing), the covariance of
//! every point's neighbourhood at the pipeline's default radius (4 spacings), found
//! (a) with the grid and (b) with kiddo 6's immutable f32 tree (`within_unsorted`, the
//! covariance accumulated from the returned ids), both in parallel on the rayon pool; and
//! (c) kiddo's k nearest neighbours at k = 16 and 32, the fixed-k alternative CRATES.md
//! measured against the tools users have.
//!
//! Criterion reports each timing; at the end the benchmark times (a) and (b) once more
//! (median of 3) and prints the ratio. Run with `cargo bench --bench neighbours`.

use std::hint::black_box;
use std::num::NonZeroUsize;
use std::time::{Duration, Instant};

use criterion::Criterion;
use kiddo::{ImmutableKdTree, SquaredEuclidean};
use rayon::prelude::*;
use sharpedge::neighbours::{self, Grid};
use sharpedge::synth::{self, Sampling, SynthParams};

const N: usize = 1_000_000;

/// Upper triangle of the neighbourhood's second moments about the query point.
type Moments = [f64; 6];

fn add(m: &mut Moments, d: [f64; 3]) {
    m[0] += d[0] * d[0];
    m[1] += d[0] * d[1];
    m[2] += d[0] * d[2];
    m[3] += d[1] * d[1];
    m[4] += d[1] * d[2];
    m[5] += d[2] * d[2];
}

fn with_grid(pos: &[[f64; 3]], r: f64) -> Vec<Moments> {
    let grid = Grid::new(pos, r).expect("grid");
    pos.par_iter()
        .map(|p| {
            let mut m = [0.0; 6];
            grid.for_each_within(*p, r, |_, d, _| add(&mut m, d));
            m
        })
        .collect()
}

fn local_f32(pos: &[[f64; 3]]) -> Vec<[f32; 3]> {
    let c = pos[0];
    pos.par_iter()
        .map(|p| [0, 1, 2].map(|k| (p[k] - c[k]) as f32))
        .collect()
}

fn with_kiddo(pos: &[[f64; 3]], local: &[[f32; 3]], r: f64) -> Vec<Moments> {
    let tree = ImmutableKdTree::<f32, 3>::new_from_slice(local).expect("tree");
    let r2 = (r * r) as f32;
    local
        .par_iter()
        .enumerate()
        .map(|(i, q)| {
            let mut m = [0.0; 6];
            for nb in tree
                .query(q)
                .within::<SquaredEuclidean<f32>>(r2)
                .unsorted()
                .execute()
            {
                let p = pos[nb.item as usize];
                add(&mut m, [0, 1, 2].map(|k| p[k] - pos[i][k]));
            }
            m
        })
        .collect()
}

fn knn_kiddo(local: &[[f32; 3]], k: usize) -> usize {
    let tree = ImmutableKdTree::<f32, 3>::new_from_slice(local).expect("tree");
    let k = NonZeroUsize::new(k).expect("k > 0");
    local
        .par_iter()
        .map(|q| {
            tree.query(q)
                .nearest_n::<SquaredEuclidean<f32>>(k)
                .execute()
                .len()
        })
        .sum()
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
    let scan = synth::generate(&SynthParams {
        sampling: Sampling::Points(N),
        noise: 0.15,
        round: 1.5,
        rotate: true,
        ..SynthParams::default()
    })
    .expect("synthetic box");
    let pos = scan.cloud.positions;
    let spacing = neighbours::mean_spacing(&pos, 50_000).expect("spacing");
    let r = 4.0 * spacing;
    let local = local_f32(&pos);
    // Both find the same neighbourhoods (up to f32 rounding at the boundary).
    let a = with_grid(&pos, r);
    let b = with_kiddo(&pos, &local, r);
    let rel = a
        .iter()
        .zip(&b)
        .map(|(x, y)| ((x[0] + x[3] + x[5]) - (y[0] + y[3] + y[5])).abs() / (x[0] + x[3] + x[5]))
        .fold(0.0, f64::max);
    assert!(rel < 0.05, "grid and kiddo neighbourhoods differ by {rel}");

    let mut c = Criterion::default()
        .sample_size(10)
        .warm_up_time(Duration::from_secs(1))
        .measurement_time(Duration::from_secs(10))
        .configure_from_args();
    let mut g = c.benchmark_group("neighbourhood_covariance_1M_r4h");
    g.bench_function("grid", |bch| bch.iter(|| black_box(with_grid(&pos, r))));
    g.bench_function("kiddo_within", |bch| {
        bch.iter(|| black_box(with_kiddo(&pos, &local, r)))
    });
    g.finish();
    let mut g = c.benchmark_group("knn_1M");
    for k in [16, 32] {
        g.bench_function(format!("kiddo_k{k}"), |bch| {
            bch.iter(|| black_box(knn_kiddo(&local, k)))
        });
    }
    g.finish();
    c.final_summary();

    let grid = median_secs(|| drop(black_box(with_grid(&pos, r))), 3);
    let kiddo = median_secs(|| drop(black_box(with_kiddo(&pos, &local, r))), 3);
    println!(
        "1M points, covariance of r = 4 spacings neighbourhoods ({} threads): grid {grid:.3} s, \
         kiddo within {kiddo:.3} s (kiddo / grid = {:.2})",
        rayon::current_num_threads(),
        kiddo / grid
    );
}
