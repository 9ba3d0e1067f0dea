//! The 3D vertex fit (`fit_corner_3d`) on synthetic corners with known vertices: box corners,
//! pyramid apexes, two-edge corners; side permutations; degenerate input.

use rand::rngs::SmallRng;
use rand::{RngExt, SeedableRng};
use sharpedge::Error;
use sharpedge::fit::{
    CornerFit, CornerScratch, FitParams, LineForm, fit_corner_3d, fit_corner_3d_with,
    standard_normal,
};

fn unit(v: [f64; 3]) -> [f64; 3] {
    let n = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
    [v[0] / n, v[1] / n, v[2] / n]
}

fn dist(a: [f64; 3], b: [f64; 3]) -> f64 {
    (0..3).map(|k| (a[k] - b[k]).powi(2)).sum::<f64>().sqrt()
}

/// Edges from `v` along `dirs`, `n` points each at spacing `h`, noise `sigma`, shuffled.
fn corner(
    v: [f64; 3],
    dirs: &[[f64; 3]],
    n: usize,
    h: f64,
    sigma: f64,
    seed: u64,
) -> Vec<Vec<[f64; 3]>> {
    let mut rng = SmallRng::seed_from_u64(seed);
    dirs.iter()
        .map(|d| {
            let mut side: Vec<[f64; 3]> = (0..n)
                .map(|i| {
                    let t = (i as f64 + 0.5) * h;
                    std::array::from_fn(|k| v[k] + t * d[k] + sigma * standard_normal(&mut rng))
                })
                .collect();
            for i in (1..side.len()).rev() {
                let j = rng.random_range(0..=i);
                side.swap(i, j);
            }
            side
        })
        .collect()
}

fn fit(sides: &[Vec<[f64; 3]>], approx: [f64; 3], params: &FitParams, seed: u64) -> CornerFit {
    let s: Vec<&[[f64; 3]]> = sides.iter().map(|x| x.as_slice()).collect();
    fit_corner_3d(&s, approx, params, &mut SmallRng::seed_from_u64(seed)).unwrap()
}

const BOX: [[f64; 3]; 3] = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];

#[test]
fn noise_free_box_corner_is_exact() {
    let v = [1.0, 2.0, 3.0];
    let sides = corner(v, &BOX, 30, 0.2, 0.0, 1);
    let f = fit(&sides, [1.2, 2.1, 2.8], &FitParams::default(), 1);
    assert!(
        dist(f.searches.exact.point, v) < 1e-9,
        "{:?}",
        f.searches.exact.point
    );
    assert!(f.searches.exact.error < 1e-8);
    for (l, d) in f.lines.iter().zip(BOX) {
        let c = l.direction[0] * d[0] + l.direction[1] * d[1] + l.direction[2] * d[2];
        assert!(c > 1.0 - 1e-12, "{:?}", l.direction);
    }
    assert_eq!(f.lines.len(), 3);
    assert_eq!(f.sides.len(), 3);
}

#[test]
fn noisy_corners_of_two_three_and_four_edges() {
    let apex: Vec<[f64; 3]> = (0..4)
        .map(|i| {
            let a = i as f64 * std::f64::consts::FRAC_PI_2 + 0.3;
            unit([a.cos(), a.sin(), -1.2])
        })
        .collect();
    let cases: Vec<Vec<[f64; 3]>> = vec![
        BOX.to_vec(),
        apex,
        vec![unit([1.0, 0.2, 0.0]), unit([-0.3, 1.0, 0.4])],
        vec![
            unit([1.0, 1.0, 0.1]),
            unit([1.0, -1.0, 0.0]),
            unit([-0.2, 0.1, 1.0]),
        ],
    ];
    let v = [10.0, -5.0, 2.0];
    for (k, dirs) in cases.iter().enumerate() {
        for seed in 0..4 {
            let sides = corner(v, dirs, 50, 0.2, 0.05, seed);
            let f = fit(&sides, [10.3, -5.2, 2.2], &FitParams::default(), seed);
            assert!(
                dist(f.searches.exact.point, v) < 0.05,
                "case {k} seed {seed}: {:?}",
                f.searches.exact.point
            );
            assert!(
                dist(f.searches.pso.point, v) < 0.06,
                "case {k} seed {seed}: {:?}",
                f.searches.pso.point
            );
            assert!(f.searches.pso.error <= f.searches.scheme1.error);
            assert!(f.searches.exact.error <= f.searches.pso.error * (1.0 + 1e-12));
            assert_eq!(f.searches.pso_history.len(), 11);
            assert_eq!(f.rectified.len(), f.corner_region.len());
        }
    }
}

#[test]
fn permuting_the_sides_permutes_the_output_and_keeps_the_corner() {
    let dirs = [
        unit([1.0, 0.1, 0.0]),
        unit([0.1, 1.0, 0.2]),
        unit([0.0, -0.2, 1.0]),
    ];
    let sides = corner([0.0, 0.0, 0.0], &dirs, 40, 0.25, 0.05, 3);
    let params = FitParams::default();
    let a = fit(&sides, [0.1, 0.1, -0.1], &params, 5);
    for perm in [[1, 2, 0], [2, 1, 0], [0, 2, 1]] {
        let p: Vec<Vec<[f64; 3]>> = perm.iter().map(|&i| sides[i].clone()).collect();
        let b = fit(&p, [0.1, 0.1, -0.1], &params, 5);
        for (x, y) in [
            (a.searches.pso.point, b.searches.pso.point),
            (a.searches.exact.point, b.searches.exact.point),
            (a.searches.scheme1.point, b.searches.scheme1.point),
        ] {
            assert!(dist(x, y) < 1e-12, "{perm:?}: {x:?} vs {y:?}");
        }
        for (j, &i) in perm.iter().enumerate() {
            assert_eq!(b.sides[j], a.sides[i]);
            assert_eq!(b.lines[j].direction, a.lines[i].direction);
        }
    }
}

#[test]
fn the_papers_form_and_scratch_reuse() {
    let sides = corner([1.0, 1.0, 1.0], &BOX, 40, 0.25, 0.03, 8);
    let params = FitParams {
        line_form: LineForm::Paper,
        ..FitParams::default()
    };
    let a = fit(&sides, [1.1, 0.9, 1.0], &params, 2);
    assert!(dist(a.searches.exact.point, [1.0, 1.0, 1.0]) < 0.03);
    let s: Vec<&[[f64; 3]]> = sides.iter().map(|x| x.as_slice()).collect();
    let other = corner([0.0; 3], &BOX[..2], 20, 0.3, 0.1, 9);
    let o: Vec<&[[f64; 3]]> = other.iter().map(|x| x.as_slice()).collect();
    let mut scratch = CornerScratch::default();
    let mut out = CornerFit::default();
    fit_corner_3d_with(
        &o,
        [0.0; 3],
        &params,
        &mut SmallRng::seed_from_u64(1),
        &mut scratch,
        &mut out,
    )
    .unwrap();
    fit_corner_3d_with(
        &s,
        [1.1, 0.9, 1.0],
        &params,
        &mut SmallRng::seed_from_u64(2),
        &mut scratch,
        &mut out,
    )
    .unwrap();
    assert_eq!(a.searches.pso, out.searches.pso);
    assert_eq!(a.searches.exact, out.searches.exact);
    assert_eq!(a.corner_region, out.corner_region);
    assert_eq!(a.sides, out.sides);
}

#[test]
fn degenerate_corners_are_clear_errors() {
    let p = FitParams::default();
    let rng = &mut SmallRng::seed_from_u64(1);
    let good = corner([0.0; 3], &BOX, 10, 0.3, 0.0, 1);
    // One side only.
    let e = fit_corner_3d(&[&good[0][..]], [0.0; 3], &p, rng).unwrap_err();
    assert!(
        matches!(
            e,
            Error::TooFewPoints {
                needed: 2,
                got: 1,
                ..
            }
        ),
        "{e}"
    );
    // A side with two points names the side.
    let e = fit_corner_3d(&[&good[0][..], &good[1][..2]], [0.0; 3], &p, rng)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("side 2 has 2 usable points, needs at least 3"),
        "{e}"
    );
    // Parallel sides: two edges along the same line (a straight edge split in two).
    let a: Vec<[f64; 3]> = (1..10).map(|i| [i as f64 * 0.3, 0.0, 0.0]).collect();
    let b: Vec<[f64; 3]> = (1..10).map(|i| [-(i as f64) * 0.3, 0.0, 0.0]).collect();
    let e = fit_corner_3d(&[&a[..], &b[..]], [0.0; 3], &p, rng)
        .unwrap_err()
        .to_string();
    assert!(e.contains("parallel"), "{e}");
    // Coincident points on a side.
    let same = [[1.0, 1.0, 1.0]; 5];
    let e = fit_corner_3d(&[&good[0][..], &same[..]], [0.0; 3], &p, rng)
        .unwrap_err()
        .to_string();
    assert!(e.contains("side 2") && e.contains("coincide"), "{e}");
    // NaN.
    let mut nan = good[1].clone();
    nan[3][2] = f64::NAN;
    let e = fit_corner_3d(&[&good[0][..], &nan[..]], [0.0; 3], &p, rng)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("point 3 of side 2") && e.contains("non-finite"),
        "{e}"
    );
}
