//! Eigen-decomposition of symmetric 3×3 matrices in closed form, for the per-point PCA of the
//! features stage (two decompositions per point, millions of points).
//!
//! Input: the six distinct entries of a symmetric matrix. Output: its eigenvalues in
//! ascending order and the unit eigenvector of the smallest one.
//!
//! Why not nalgebra's `SymmetricEigen`: it is general (Householder tridiagonalisation, then QR
//! sweeps) and took a fifth of the whole pipeline on a 1,000,000-point scan (perf: 19 % in
//! `SymmetricEigen::new` and its tridiagonalisation). The eigenvalues here come from the
//! characteristic cubic by the trigonometric method (Smith, "Eigenvalues of a symmetric 3 × 3
//! matrix", CACM 4(4), 1961), the eigenvector as the largest cross product of two rows of
//! A − λI (Kopp, "Efficient numerical diagonalization of hermitian 3x3 matrices", 2008). When
//! that eigenvalue is (nearly) repeated the eigenvector is ill-determined that way and the
//! decomposition falls back to nalgebra's. Near a repeated eigenvalue the trigonometric method
//! loses half its digits (the arc cosine's slope is infinite at ±1): eigenvalues are then good
//! to about 1e-8 of the matrix, far below anything the features stage compares them with.

use nalgebra::{Matrix3, SymmetricEigen};

/// A symmetric 3×3 matrix by its entries `[a00, a01, a02, a11, a12, a22]`.
pub type Sym3 = [f64; 6];

/// Eigenvalues (ascending) and the unit eigenvector of the smallest; `None` for non-finite
/// input.
pub fn smallest(a: &Sym3) -> Option<([f64; 3], [f64; 3])> {
    if !a.iter().all(|x| x.is_finite()) {
        return None;
    }
    let [a00, a01, a02, a11, a12, a22] = *a;
    let scale = a.iter().fold(0.0f64, |m, x| m.max(x.abs()));
    if scale == 0.0 {
        return Some(([0.0; 3], [0.0, 0.0, 1.0]));
    }
    let p1 = a01 * a01 + a02 * a02 + a12 * a12;
    let q = (a00 + a11 + a22) / 3.0;
    let p2 = (a00 - q).powi(2) + (a11 - q).powi(2) + (a22 - q).powi(2) + 2.0 * p1;
    let p = (p2 / 6.0).sqrt();
    if p <= 1e-12 * scale {
        // A multiple of the identity: every direction is an eigenvector.
        return fallback(a);
    }
    let b = [
        (a00 - q) / p,
        a01 / p,
        a02 / p,
        (a11 - q) / p,
        a12 / p,
        (a22 - q) / p,
    ];
    let det = b[0] * (b[3] * b[5] - b[4] * b[4]) - b[1] * (b[1] * b[5] - b[4] * b[2])
        + b[2] * (b[1] * b[4] - b[3] * b[2]);
    let phi = (0.5 * det).clamp(-1.0, 1.0).acos() / 3.0;
    let hi = q + 2.0 * p * phi.cos();
    let lo = q + 2.0 * p * (phi + 2.0 * std::f64::consts::FRAC_PI_3).cos();
    let mid = 3.0 * q - hi - lo;
    let values = [lo, mid.clamp(lo, hi), hi];
    // The smallest eigenvalue's eigenvector is orthogonal to every row of A − λI.
    let rows = [
        [a00 - lo, a01, a02],
        [a01, a11 - lo, a12],
        [a02, a12, a22 - lo],
    ];
    let cross = |u: [f64; 3], v: [f64; 3]| {
        [
            u[1] * v[2] - u[2] * v[1],
            u[2] * v[0] - u[0] * v[2],
            u[0] * v[1] - u[1] * v[0],
        ]
    };
    let cands = [
        cross(rows[0], rows[1]),
        cross(rows[0], rows[2]),
        cross(rows[1], rows[2]),
    ];
    let (best, n2) = cands
        .iter()
        .map(|c| (*c, c[0] * c[0] + c[1] * c[1] + c[2] * c[2]))
        .fold(([0.0; 3], 0.0), |a, b| if b.1 > a.1 { b } else { a });
    // The rank of A − λI must be two, clearly: the cross product of its rows is of the order
    // of (λ₂ − λ₀)(λ₁ − λ₀); when the gap λ₁ − λ₀ is tiny against the matrix the direction is
    // noise, and the general solver decides.
    let gap = (mid - lo) * (hi - lo);
    if n2.is_nan() || n2 <= 0.0 || gap <= 1e-9 * scale * scale {
        return fallback(a);
    }
    let l = n2.sqrt();
    Some((values, best.map(|x| x / l)))
}

fn fallback(a: &Sym3) -> Option<([f64; 3], [f64; 3])> {
    let m = Matrix3::new(a[0], a[1], a[2], a[1], a[3], a[4], a[2], a[4], a[5]);
    let eig = SymmetricEigen::new(m);
    let mut o = [0usize, 1, 2];
    o.sort_by(|&x, &y| eig.eigenvalues[x].total_cmp(&eig.eigenvalues[y]));
    let v = eig.eigenvectors.column(o[0]);
    let values = o.map(|k| eig.eigenvalues[k]);
    values
        .iter()
        .all(|x| x.is_finite())
        .then_some((values, [v[0], v[1], v[2]]))
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn check(a: Sym3) {
        let (values, v) = smallest(&a).unwrap();
        let (want, _) = fallback(&a).unwrap();
        let scale = a.iter().fold(1e-300f64, |m, x| m.max(x.abs()));
        for k in 0..3 {
            assert!(
                (values[k] - want[k]).abs() <= 1e-7 * scale,
                "{a:?}: eigenvalue {k} {} vs {}",
                values[k],
                want[k]
            );
        }
        // A v = λ v for the smallest.
        let m = [[a[0], a[1], a[2]], [a[1], a[3], a[4]], [a[2], a[4], a[5]]];
        let av: Vec<f64> = (0..3)
            .map(|i| (0..3).map(|j| m[i][j] * v[j]).sum::<f64>())
            .collect();
        let l = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
        assert!((l - 1.0).abs() < 1e-9);
        for i in 0..3 {
            assert!(
                (av[i] - values[0] * v[i]).abs() <= 1e-7 * scale,
                "{a:?}: residual {}",
                av[i] - values[0] * v[i]
            );
        }
    }

    #[test]
    fn flat_and_thin_neighbourhoods_and_degenerate_matrices() {
        // A noisy plane patch (tiny smallest eigenvalue), a line, a rotated plane, diagonal,
        // repeated eigenvalues, the identity and zero.
        check([4.0, 0.0, 0.0, 4.0, 0.0, 0.0225]);
        check([10.0, 0.1, 0.0, 1e-6, 0.0, 1e-6]);
        check([2.0, 1.0, 0.3, 2.5, -0.4, 0.7]);
        check([1.0, 0.0, 0.0, 2.0, 0.0, 3.0]);
        check([1.0, 0.0, 0.0, 1.0, 0.0, 3.0]);
        check([3.0, 0.0, 0.0, 1.0, 0.0, 1.0]);
        check([5.0, 0.0, 0.0, 5.0, 0.0, 5.0]);
        assert_eq!(smallest(&[0.0; 6]).unwrap().0, [0.0; 3]);
        assert!(smallest(&[f64::NAN, 0.0, 0.0, 1.0, 0.0, 1.0]).is_none());
    }

    proptest! {
        #[test]
        fn agrees_with_nalgebra_on_covariances(
            pts in prop::collection::vec(
                (-10.0f64..10.0, -10.0f64..10.0, -0.5f64..0.5), 3..40),
            angle in 0.0f64..6.3,
        ) {
            // Covariance of points near a tilted plane.
            let (s, c) = angle.sin_cos();
            let q: Vec<[f64; 3]> = pts
                .iter()
                .map(|&(x, y, z)| [c * x - s * z, y, s * x + c * z])
                .collect();
            let n = q.len() as f64;
            let m = [0, 1, 2].map(|k| q.iter().map(|p| p[k]).sum::<f64>() / n);
            let cov = |i: usize, j: usize| {
                q.iter().map(|p| (p[i] - m[i]) * (p[j] - m[j])).sum::<f64>() / n
            };
            check([cov(0, 0), cov(0, 1), cov(0, 2), cov(1, 1), cov(1, 2), cov(2, 2)]);
        }
    }
}
