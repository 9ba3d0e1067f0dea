//! Small dense linear algebra on `[[f64; N]; N]`: a symmetric eigen solver, 2x2 and 3x3
//! solvers and an orthonormal basis around a direction.
//!
//! Inputs and outputs are plain arrays so the fitting code stays allocation-free and generic
//! over the dimension.

// Index loops read like the formulas they implement (i, j, k over matrix entries).
#![allow(clippy::needless_range_loop)]

use super::vec::{cross, dot, norm};

/// Eigen decomposition of a symmetric D x D matrix by cyclic Jacobi rotations (Golub & Van
/// Loan, *Matrix Computations*, §8.5). Returns the eigenvalues in descending order and the
/// matching unit eigenvectors (`vectors[i]` belongs to `values[i]`). For D = 2 one rotation is
/// exact; for D = 3 it converges quadratically in a handful of sweeps, and unlike the closed
/// trigonometric formula it stays accurate when eigenvalues nearly coincide.
pub fn sym_eigen<const D: usize>(m: &[[f64; D]; D]) -> ([f64; D], [[f64; D]; D]) {
    let mut a = *m;
    let mut v = [[0.0; D]; D];
    for (k, row) in v.iter_mut().enumerate() {
        row[k] = 1.0;
    }
    let total: f64 = a.iter().flatten().map(|x| x * x).sum();
    for _sweep in 0..32 {
        let mut off = 0.0;
        for i in 0..D {
            for j in (i + 1)..D {
                off += a[i][j] * a[i][j];
            }
        }
        if off <= total * 1e-32 || off == 0.0 {
            break;
        }
        for p in 0..D {
            for q in (p + 1)..D {
                if a[p][q] == 0.0 {
                    continue;
                }
                // Rotation angle that zeroes a[p][q] (the stable tangent formula).
                let theta = (a[q][q] - a[p][p]) / (2.0 * a[p][q]);
                let t = theta.signum() / (theta.abs() + (theta * theta + 1.0).sqrt());
                let t = if theta == 0.0 { 1.0 } else { t };
                let c = 1.0 / (t * t + 1.0).sqrt();
                let s = t * c;
                for k in 0..D {
                    let akp = a[k][p];
                    let akq = a[k][q];
                    a[k][p] = c * akp - s * akq;
                    a[k][q] = s * akp + c * akq;
                }
                for k in 0..D {
                    let apk = a[p][k];
                    let aqk = a[q][k];
                    a[p][k] = c * apk - s * aqk;
                    a[q][k] = s * apk + c * aqk;
                }
                // v holds eigenvectors as rows: rotate rows p and q.
                for k in 0..D {
                    let vp = v[p][k];
                    let vq = v[q][k];
                    v[p][k] = c * vp - s * vq;
                    v[q][k] = s * vp + c * vq;
                }
            }
        }
    }
    let mut idx: [usize; D] = std::array::from_fn(|k| k);
    idx.sort_by(|&x, &y| a[y][y].total_cmp(&a[x][x]));
    (
        std::array::from_fn(|k| a[idx[k]][idx[k]]),
        std::array::from_fn(|k| v[idx[k]]),
    )
}

/// Solves the 2x2 system `[r0; r1] x = b`; `None` when the rows are (nearly) parallel, judged
/// relative to their lengths so the test does not depend on units.
pub fn solve2(r0: [f64; 2], r1: [f64; 2], b: [f64; 2]) -> Option<[f64; 2]> {
    let det = r0[0] * r1[1] - r0[1] * r1[0];
    if det.abs() <= 1e-14 * norm(r0) * norm(r1) || !det.is_finite() {
        return None;
    }
    Some([
        (b[0] * r1[1] - b[1] * r0[1]) / det,
        (r0[0] * b[1] - r1[0] * b[0]) / det,
    ])
}

/// Solves the symmetric 3x3 system `m x = b` by Cramer's rule; `None` when `m` is singular
/// relative to its scale.
pub fn solve3(m: &[[f64; 3]; 3], b: &[f64; 3]) -> Option<[f64; 3]> {
    let c0 = cross(m[1], m[2]);
    let det = dot(m[0], c0);
    let scale = norm(m[0]) * norm(m[1]) * norm(m[2]);
    if det.abs() <= 1e-14 * scale || !det.is_finite() || scale == 0.0 {
        return None;
    }
    // Columns of the inverse are the cross products of rows (m is symmetric).
    let c1 = cross(m[2], m[0]);
    let c2 = cross(m[0], m[1]);
    Some([dot(c0, b) / det, dot(c1, b) / det, dot(c2, b) / det])
}

/// An orthonormal pair spanning the plane perpendicular to the unit vector `d` (Frisvad's
/// branch-free construction as corrected by Duff et al., "Building an Orthonormal Basis,
/// Revisited", JCGT 2017).
pub fn perp_basis(d: &[f64; 3]) -> ([f64; 3], [f64; 3]) {
    let sign = 1.0_f64.copysign(d[2]);
    let a = -1.0 / (sign + d[2]);
    let b = d[0] * d[1] * a;
    (
        [1.0 + sign * d[0] * d[0] * a, sign * b, -sign * d[0]],
        [b, sign + d[1] * d[1] * a, -d[1]],
    )
}

/// Least-squares parabola z = a + b·u + c·u² through `(x, z)` samples (u = x minus the mean
/// x): the curvature coefficient `c` and its standard error from the residuals (the ordinary
/// least-squares covariance s²·(XᵀX)⁻¹, e.g. Draper & Smith, *Applied Regression Analysis*,
/// §2.6). `None` for fewer than six samples or x values that do not spread over three
/// distinct places (a singular system). A strip of a curved surface of radius R sags as
/// u²/(2R) across: c = 1/(2R); a plane gives c = 0 within its standard error.
pub fn parabola_curvature(samples: &[(f64, f64)]) -> Option<(f64, f64)> {
    let n = samples.len();
    if n < 6 {
        return None;
    }
    let mx = samples.iter().map(|s| s.0).sum::<f64>() / n as f64;
    let mut xtx = nalgebra::Matrix3::<f64>::zeros();
    let mut xtz = nalgebra::Vector3::<f64>::zeros();
    for &(x, z) in samples {
        let u = x - mx;
        let row = nalgebra::Vector3::new(1.0, u, u * u);
        xtx += row * row.transpose();
        xtz += row * z;
    }
    let inv = xtx.try_inverse()?;
    let coef = inv * xtz;
    if !coef.iter().all(|c| c.is_finite()) {
        return None;
    }
    let ssr: f64 = samples
        .iter()
        .map(|&(x, z)| {
            let u = x - mx;
            let r = z - (coef[0] + coef[1] * u + coef[2] * u * u);
            r * r
        })
        .sum();
    let var = ssr / (n - 3) as f64;
    let se = (var * inv[(2, 2)]).max(0.0).sqrt();
    se.is_finite().then_some((coef[2], se))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn jacobi_matches_known_eigenpairs() {
        // diag(3, 2, 1) rotated: eigenvalues must come back sorted, vectors orthonormal.
        let r = [[0.36, 0.48, -0.8], [-0.8, 0.6, 0.0], [0.48, 0.64, 0.6]];
        let l = [3.0, 1.0, 2.0];
        let mut m = [[0.0; 3]; 3];
        for i in 0..3 {
            for j in 0..3 {
                for k in 0..3 {
                    m[i][j] += r[k][i] * l[k] * r[k][j];
                }
            }
        }
        let (vals, vecs) = sym_eigen(&m);
        assert!((vals[0] - 3.0).abs() < 1e-14 && (vals[1] - 2.0).abs() < 1e-14);
        assert!((vals[2] - 1.0).abs() < 1e-14);
        assert!((dot(vecs[0], r[0]).abs() - 1.0).abs() < 1e-14);
        assert!((dot(vecs[1], r[2]).abs() - 1.0).abs() < 1e-14);
        let (v2, _) = sym_eigen(&[[2.0, 1.0], [1.0, 2.0]]);
        assert!((v2[0] - 3.0).abs() < 1e-15 && (v2[1] - 1.0).abs() < 1e-15);
    }

    #[test]
    fn perp_basis_is_orthonormal_for_all_octants() {
        for d in [
            [0.0, 0.0, 1.0],
            [0.0, 0.0, -1.0],
            [1.0, 0.0, 0.0],
            [0.6, -0.8, 0.0],
            [-0.48, 0.6, -0.64],
        ] {
            let (e1, e2) = perp_basis(&d);
            assert!(dot(e1, d).abs() < 1e-15 && dot(e2, d).abs() < 1e-15);
            assert!(dot(e1, e2).abs() < 1e-15);
            assert!((norm(e1) - 1.0).abs() < 1e-15 && (norm(e2) - 1.0).abs() < 1e-15);
        }
    }

    #[test]
    fn solvers_reject_singular_systems() {
        assert!(solve2([1.0, 2.0], [2.0, 4.0], [1.0, 1.0]).is_none());
        assert_eq!(solve2([1.0, 0.0], [0.0, 2.0], [3.0, 4.0]), Some([3.0, 2.0]));
        let m = [[2.0, 0.0, 0.0], [0.0, 3.0, 0.0], [0.0, 0.0, 4.0]];
        assert_eq!(solve3(&m, &[2.0, 3.0, 4.0]), Some([1.0, 1.0, 1.0]));
        let s = [[1.0, 1.0, 0.0], [1.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
        assert!(solve3(&s, &[1.0, 1.0, 1.0]).is_none());
    }

    #[test]
    fn parabola_curvature_recovers_an_arc_and_finds_none_on_a_plane() {
        // Exact parabola z = 1 + 0.5 x + 0.25 x² sampled on [-2, 3]: c = 0.25, no residual.
        let exact: Vec<(f64, f64)> = (0..=50)
            .map(|i| {
                let x = -2.0 + 0.1 * i as f64;
                (x, 1.0 + 0.5 * x + 0.25 * x * x)
            })
            .collect();
        let (c, se) = parabola_curvature(&exact).unwrap();
        assert!((c - 0.25).abs() < 1e-12 && se < 1e-9, "{c} {se}");
        // A tilted plane with deterministic ±0.1 noise: c within three standard errors of 0,
        // and the error about σ·√180/(w²·√n) for x uniform over a width w.
        let noisy: Vec<(f64, f64)> = (0..400)
            .map(|i| {
                let x = 5.0 * i as f64 / 399.0;
                let noise = if (i * 7919) % 13 < 6 { 0.1 } else { -0.1 };
                (x, 0.3 * x + noise)
            })
            .collect();
        let (c, se) = parabola_curvature(&noisy).unwrap();
        let expected_se = 0.1 * 180f64.sqrt() / (25.0 * 20.0);
        assert!(c.abs() < 3.0 * se, "{c} {se}");
        assert!(
            se > 0.5 * expected_se && se < 2.0 * expected_se,
            "{se} {expected_se}"
        );
    }

    #[test]
    fn parabola_curvature_needs_six_samples_over_three_places() {
        let few: Vec<(f64, f64)> = (0..5).map(|i| (i as f64, 0.0)).collect();
        assert!(parabola_curvature(&few).is_none());
        // Twelve samples on two x values: a line fits, a parabola is undetermined.
        let two: Vec<(f64, f64)> = (0..12).map(|i| ((i % 2) as f64, i as f64)).collect();
        assert!(parabola_curvature(&two).is_none());
    }
}
