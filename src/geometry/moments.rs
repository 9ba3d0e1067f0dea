//! Moments of point offsets and the plane they fit (PCA): the one covariance routine behind
//! the features stage's normals, the local scale's noise and the bench's reference faces.
//!
//! Inputs: offsets from a query point (so the subtraction of the mean loses no precision at
//! georeferenced magnitudes). Outputs: raw moments and `LocalPca` (count, eigenvalues, normal,
//! centroid).

use crate::geometry::eigen3;

/// Covariance summary of one neighbourhood.
#[derive(Debug, Clone, Copy)]
pub struct LocalPca {
    pub count: u32,
    /// Eigenvalues ascending.
    pub eigenvalues: [f64; 3],
    /// Unit eigenvector of the smallest eigenvalue: the normal of the best plane.
    pub normal: [f64; 3],
    /// Centroid offset from the query point.
    pub centroid: [f64; 3],
}

/// A neighbourhood whose spread across its principal direction (middle eigenvalue) is below
/// this share of its spread along it (largest) lies on one scan line: see
/// [`LocalPca::spans_one_line`].
pub const ONE_LINE: f64 = 0.01;

impl LocalPca {
    /// The neighbourhood lies on one scan line: its points spread across their principal
    /// direction by less than [`ONE_LINE`] of their spread along it, so its plane is the
    /// noise's (the normal turns about the line at random) and it measures neither the
    /// surface's orientation nor the spacing across the lines. A second line holding a share
    /// a of the points g away spreads them a(1−a)·g² across, against about L²/3 along a
    /// stretch ±L long: two lines split about evenly pass from g ≈ 0.12 L, and a second line
    /// within a ball's radius fails the test only where it holds a few thousandths of the
    /// points (grazing the ball's rim). The line's own noise spreads it too: a lone line
    /// with noise σ across it is flagged only where it reaches L > √300·σ ≈ 17σ along, so
    /// on a scan whose radius is set by its noise (`noise_radius` = 6 sigmas) lone lines
    /// are not recognised and stay as they were.
    pub fn spans_one_line(&self) -> bool {
        self.eigenvalues[1] < ONE_LINE * self.eigenvalues[2]
    }
}

/// Adds an offset to the raw moments [n, Σx, Σy, Σz, Σxx, Σxy, Σxz, Σyy, Σyz, Σzz].
#[inline]
pub fn add_moments(m: &mut [f64; 10], d: [f64; 3]) {
    // Weight 1: every product as without it (x · 1 = x exactly, and the compiler drops it).
    add_moments_weighted(m, d, 1.0);
}

/// Adds an offset standing for `w` points: a crowded cloud's kept point
/// (`neighbours::Grid::crowd`), or 0/1 by distance in a branch-free neighbourhood sum
/// (`neighbours::Grid::for_each_in_block_weighted`).
#[inline]
pub fn add_moments_weighted(m: &mut [f64; 10], d: [f64; 3], w: f64) {
    m[0] += w;
    m[1] += w * d[0];
    m[2] += w * d[1];
    m[3] += w * d[2];
    m[4] += w * d[0] * d[0];
    m[5] += w * d[0] * d[1];
    m[6] += w * d[0] * d[2];
    m[7] += w * d[1] * d[1];
    m[8] += w * d[1] * d[2];
    m[9] += w * d[2] * d[2];
}

/// PCA from raw moments [n, Σx, Σy, Σz, Σxx, Σxy, Σxz, Σyy, Σyz, Σzz] (offsets from the query,
/// so the subtraction of the mean loses no precision at georeferenced magnitudes).
pub fn pca_from_moments(m: &[f64; 10]) -> Option<LocalPca> {
    let n = m[0];
    if n < 3.0 {
        return None;
    }
    let c = [m[1] / n, m[2] / n, m[3] / n];
    let cov = [
        m[4] / n - c[0] * c[0],
        m[5] / n - c[0] * c[1],
        m[6] / n - c[0] * c[2],
        m[7] / n - c[1] * c[1],
        m[8] / n - c[1] * c[2],
        m[9] / n - c[2] * c[2],
    ];
    let (values, normal) = eigen3::smallest(&cov)?;
    Some(LocalPca {
        count: n as u32,
        eigenvalues: values.map(|v| v.max(0.0)),
        normal,
        centroid: c,
    })
}

/// Σ ((d − d̄) · a)² from raw moments [n, Σx, …, Σzz]: the offsets' sum of squared deviations
/// along the unit direction `a` (n times their variance along it); 0 without offsets.
pub fn spread_along(m: &[f64; 10], a: [f64; 3]) -> f64 {
    let n = m[0];
    if n <= 0.0 {
        return 0.0;
    }
    let second = a[0] * a[0] * m[4]
        + 2.0 * a[0] * a[1] * m[5]
        + 2.0 * a[0] * a[2] * m[6]
        + a[1] * a[1] * m[7]
        + 2.0 * a[1] * a[2] * m[8]
        + a[2] * a[2] * m[9];
    let first = a[0] * m[1] + a[1] * m[2] + a[2] * m[3];
    (second - first * first / n).max(0.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn spread_along_is_the_sum_of_squared_deviations_along_the_direction() {
        let pts = [
            [1.0, 2.0, 3.0],
            [4.0, -1.0, 0.5],
            [-2.0, 0.0, 7.0],
            [0.3, 5.0, -1.0],
        ];
        let mut m = [0.0; 10];
        for p in pts {
            add_moments(&mut m, p);
        }
        let l = (1.0f64 + 4.0 + 0.25).sqrt();
        let a = [1.0 / l, -2.0 / l, 0.5 / l];
        let x: Vec<f64> = pts
            .iter()
            .map(|p| p[0] * a[0] + p[1] * a[1] + p[2] * a[2])
            .collect();
        let mean = x.iter().sum::<f64>() / x.len() as f64;
        let brute: f64 = x.iter().map(|v| (v - mean) * (v - mean)).sum();
        assert!((spread_along(&m, a) - brute).abs() < 1e-12 * brute.max(1.0));
        assert_eq!(spread_along(&[0.0; 10], a), 0.0);
    }

    #[test]
    fn one_line_means_no_second_line_within_0_116_of_the_reach() {
        // Two lines g apart, each 201 points evenly along ±L (L = 10): the middle eigenvalue
        // is g²/4, the largest 33.67 (L²/3 and the discrete steps'): the test flips at
        // g = √(0.04 · 33.67) ≈ 1.16, 0.116 L.
        let two_lines = |g: f64| {
            let mut m = [0.0; 10];
            for k in -100..=100 {
                let x = f64::from(k) * 0.1;
                add_moments(&mut m, [x, -g / 2.0, 0.0]);
                add_moments(&mut m, [x, g / 2.0, 0.0]);
            }
            pca_from_moments(&m).unwrap()
        };
        assert!(two_lines(0.0).spans_one_line());
        assert!(two_lines(1.10).spans_one_line());
        assert!(!two_lines(1.25).spans_one_line());
        assert!(!two_lines(3.0).spans_one_line());
        // A uniform patch (a grid of 21 x 21) is a surface, not a line.
        let mut m = [0.0; 10];
        for i in -10..=10 {
            for j in -10..=10 {
                add_moments(&mut m, [f64::from(i), f64::from(j), 0.0]);
            }
        }
        assert!(!pca_from_moments(&m).unwrap().spans_one_line());
    }

    #[test]
    fn pca_needs_three_points() {
        let mut m = [0.0; 10];
        m[0] = 2.0;
        assert!(pca_from_moments(&m).is_none());
    }

    #[test]
    fn pca_of_a_tilted_plane_is_its_normal() {
        let n = [0.0, 0.6, 0.8];
        let mut m = [0.0; 10];
        for a in -3..=3 {
            for b in -3..=3 {
                let (u, v) = ([1.0, 0.0, 0.0], [0.0, 0.8, -0.6]);
                let (a, b) = (f64::from(a), f64::from(b));
                add_moments(&mut m, [0, 1, 2].map(|k| a * u[k] + b * v[k] + 2.0 * n[k]));
            }
        }
        let p = pca_from_moments(&m).unwrap();
        assert_eq!(p.count, 49);
        assert!(p.eigenvalues[0].abs() < 1e-12);
        let c = (0..3).map(|k| p.normal[k] * n[k]).sum::<f64>();
        assert!((c.abs() - 1.0).abs() < 1e-12);
        assert!((p.centroid[2] - 1.6).abs() < 1e-12);
    }
}
