//! Lines, rays and segments in 3D: closest points, distances, the best line through points
//! and a frame around a direction.
//!
//! A line is `(point, unit direction)`. Degenerate input is answered explicitly: parallel
//! rays and all-parallel lines give `None`, a zero-length segment is its end point.

use super::vec::{V3, add, axpy, dist, dot, neg, norm, sub};

/// Parameters along two rays (p + s·d) of their closest points and the distance between
/// them; `None` for (nearly) parallel rays, which never meet at a vertex.
/// Formula: the standard closest-points-of-two-lines solution (e.g. Eberly, "Distance Between
/// Two Lines", Geometric Tools).
pub fn closest_between_rays(
    pa: [f64; 3],
    da: [f64; 3],
    pb: [f64; 3],
    db: [f64; 3],
) -> Option<(f64, f64, f64)> {
    let w = sub(pa, pb);
    let b = dot(da, db);
    let denom = 1.0 - b * b;
    if denom < 1e-6 {
        return None;
    }
    let (d, e) = (dot(da, w), dot(db, w));
    let sa = (b * e - d) / denom;
    let sb = (e - b * d) / denom;
    let ca = add(pa, da.map(|c| c * sa));
    let cb = add(pb, db.map(|c| c * sb));
    Some((sa, sb, norm(sub(ca, cb))))
}

/// The point minimising the sum of squared distances to the lines (point, unit direction);
/// `None` when the lines are all parallel.
pub fn nearest_point_to_lines(lines: &[([f64; 3], [f64; 3])]) -> Option<[f64; 3]> {
    let mut a = nalgebra::Matrix3::<f64>::zeros();
    let mut b = nalgebra::Vector3::<f64>::zeros();
    for (p, d) in lines {
        let d = nalgebra::Vector3::from(*d);
        let m = nalgebra::Matrix3::identity() - d * d.transpose();
        a += m;
        b += m * nalgebra::Vector3::from(*p);
    }
    // Parallel lines make `a` singular in the shared direction.
    let eig = nalgebra::SymmetricEigen::new(a);
    if eig
        .eigenvalues
        .iter()
        .copied()
        .fold(f64::INFINITY, f64::min)
        < 1e-6 * lines.len() as f64
    {
        return None;
    }
    let x = a.lu().solve(&b)?;
    Some([x[0], x[1], x[2]])
}

/// Best line through the points (centroid, unit principal direction).
pub fn pca_line(pos: &[[f64; 3]], ids: &[usize]) -> Option<([f64; 3], [f64; 3])> {
    if ids.len() < 2 {
        return None;
    }
    let n = ids.len() as f64;
    let mut c = [0.0; 3];
    for &i in ids {
        c = add(c, pos[i]);
    }
    c = c.map(|v| v / n);
    let mut m = nalgebra::Matrix3::<f64>::zeros();
    for &i in ids {
        let v = nalgebra::Vector3::from(sub(pos[i], c));
        m += v * v.transpose();
    }
    let eig = nalgebra::SymmetricEigen::new(m);
    let k = (0..3).max_by(|&a, &b| eig.eigenvalues[a].total_cmp(&eig.eigenvalues[b]))?;
    if eig.eigenvalues[k] <= 0.0 {
        return None;
    }
    let v = eig.eigenvectors.column(k);
    // A fixed sign convention keeps results independent of the eigen solver's choice.
    let mut d = [v[0], v[1], v[2]];
    let big = (0..3)
        .max_by(|&a, &b| d[a].abs().total_cmp(&d[b].abs()))
        .unwrap_or(0);
    if d[big] < 0.0 {
        d = neg(d);
    }
    Some((c, d))
}

/// Distance from `p` to the line (point, unit direction).
pub fn point_line_distance(p: [f64; 3], line: ([f64; 3], [f64; 3])) -> f64 {
    let v = sub(p, line.0);
    let t = dot(v, line.1);
    norm(sub(v, line.1.map(|x| x * t)))
}

/// Two unit vectors completing `d` (unit) to a right-handed orthonormal frame. Built from the
/// axis least aligned with `d`, so it is well conditioned for every direction.
/// (The edge stage lays its slabs out in this frame; the fit uses [`super::perp_basis`], Duff's
/// branch-free frame. Both are valid; they differ, so swapping one for the other would move
/// every result's last bits.)
pub fn perpendicular_basis(d: [f64; 3]) -> ([f64; 3], [f64; 3]) {
    let k = (0..3)
        .min_by(|&a, &b| d[a].abs().total_cmp(&d[b].abs()))
        .unwrap_or(0);
    let mut a = [0.0; 3];
    a[k] = 1.0;
    let e1 = sub(a, d.map(|x| x * dot(a, d)));
    let e1 = e1.map(|x| x / norm(e1));
    let e2 = [
        d[1] * e1[2] - d[2] * e1[1],
        d[2] * e1[0] - d[0] * e1[2],
        d[0] * e1[1] - d[1] * e1[0],
    ];
    (e1, e2)
}

/// Two unit vectors spanning the plane perpendicular to the unit vector `n`, from the x axis
/// unless `n` is close to it. The simulator lays its sampling grids out in this frame; the
/// bundled samples and every simulated benchmark scan depend on its exact bits, which is why it
/// is not replaced by [`perpendicular_basis`] or [`super::perp_basis`].
pub fn plane_axes(n: [f64; 3]) -> ([f64; 3], [f64; 3]) {
    let e = if n[0].abs() < 0.6 {
        [1.0, 0.0, 0.0]
    } else {
        [0.0, 1.0, 0.0]
    };
    let u0 = super::unit(super::cross(e, n)).unwrap_or([1.0, 0.0, 0.0]);
    (u0, super::cross(n, u0))
}

/// `(distance, t)` from `p` to the segment `a + t (b - a)`, `t` in [0, 1]; a zero-length
/// segment is the point `a` (t = 0).
pub fn point_segment(p: V3, a: V3, b: V3) -> (f64, f64) {
    let ab = sub(b, a);
    let l2 = dot(ab, ab);
    let t = if l2 > 0.0 {
        (dot(sub(p, a), ab) / l2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    (dist(p, axpy(a, t, ab)), t)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn segment_distance_cases() {
        let (a, b) = ([0.0, 0.0, 0.0], [2.0, 0.0, 0.0]);
        assert_eq!(point_segment([1.0, 1.0, 0.0], a, b), (1.0, 0.5));
        assert_eq!(point_segment([-3.0, 4.0, 0.0], a, b), (5.0, 0.0));
        assert_eq!(point_segment([3.0, 0.0, 0.0], a, b), (1.0, 1.0));
        assert_eq!(point_segment([0.0, 3.0, 4.0], a, a), (5.0, 0.0));
    }
}
