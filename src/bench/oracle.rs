//! The "oracle": the best edges and corners a method could get from the same scan if it knew
//! which points belong to which face.
//!
//! Input: the scan's points with their per-point truth (face id, distance to the nearest
//! sharp edge, outlier flag) and the part's ground truth. Output: per true face a least-squares
//! plane fitted to its points far from any edge; per true edge the intersection line of its
//! two faces' planes, clipped to the true edge's extent; per true corner the least-squares
//! point of the planes of the faces meeting there. Defined for polyhedral parts only (curved
//! faces have no plane).

use nalgebra::{Matrix3, SymmetricEigen, Vector3};

use crate::geometry::{V3, add, cross, dot, norm, scale, sub};
use crate::synth::{GroundTruth, PointTruth};

/// A plane `{x : normal · (x − point) = 0}` with a unit normal.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Plane {
    pub normal: V3,
    pub point: V3,
}

/// Total least-squares plane through points (the centroid and the eigenvector of the
/// smallest eigenvalue of the scatter matrix; Pearson 1901). `None` for fewer than three
/// points or when the points are collinear (two equal smallest eigenvalues leave no unique
/// normal). Two passes — centroid, then scatter about it — so coordinates millions of units
/// from the origin lose no precision.
pub fn fit_plane(points: impl Iterator<Item = V3> + Clone) -> Option<Plane> {
    let mut n = 0usize;
    let mut c = [0.0; 3];
    for p in points.clone() {
        c = add(c, p);
        n += 1;
    }
    if n < 3 {
        return None;
    }
    let c = scale(c, 1.0 / n as f64);
    let mut m = Matrix3::<f64>::zeros();
    for p in points {
        let d = Vector3::from(sub(p, c));
        m += d * d.transpose();
    }
    let eig = SymmetricEigen::new(m);
    let mut order = [0usize, 1, 2];
    order.sort_by(|&a, &b| eig.eigenvalues[a].total_cmp(&eig.eigenvalues[b]));
    let (l0, l1) = (eig.eigenvalues[order[0]], eig.eigenvalues[order[1]]);
    if l1.is_nan() || l1 <= 0.0 || l0 > 0.5 * l1 {
        // Collinear (l1 ≈ 0) or no flat direction at all: no plane to speak of.
        return None;
    }
    let v = eig.eigenvectors.column(order[0]);
    let normal = [v[0], v[1], v[2]];
    let len = norm(normal);
    (len > 0.0 && len.is_finite()).then(|| Plane {
        normal: scale(normal, 1.0 / len),
        point: c,
    })
}

/// The line where two planes meet, as the point of it nearest to `near` and a unit
/// direction; `None` when the planes are (nearly) parallel. The point solves
/// `x = near + a n0 + b n1` with `n_i · x = n_i · p_i` (a 2×2 system).
pub fn plane_intersection(p0: &Plane, p1: &Plane, near: V3) -> Option<(V3, V3)> {
    let u = cross(p0.normal, p1.normal);
    let s = norm(u);
    if s.is_nan() || s <= 1e-9 {
        return None;
    }
    let dir = scale(u, 1.0 / s);
    // Right-hand sides relative to `near`, so large coordinates cancel first.
    let r0 = dot(p0.normal, sub(p0.point, near));
    let r1 = dot(p1.normal, sub(p1.point, near));
    let g = dot(p0.normal, p1.normal);
    let det = 1.0 - g * g; // = s², > 1e-18
    let a = (r0 - g * r1) / det;
    let b = (r1 - g * r0) / det;
    Some((
        add(near, add(scale(p0.normal, a), scale(p1.normal, b))),
        dir,
    ))
}

/// The point minimising the sum of squared distances to the planes, solved relative to
/// `near` (any point close to the answer, for precision far from the origin); `None` with
/// fewer than three planes or when their normals do not span space (the smallest eigenvalue
/// of `Σ n nᵀ` below 1e-6 of the largest).
pub fn planes_point(planes: &[Plane], near: V3) -> Option<V3> {
    if planes.len() < 3 {
        return None;
    }
    let mut a = Matrix3::<f64>::zeros();
    let mut b = Vector3::<f64>::zeros();
    for p in planes {
        let n = Vector3::from(p.normal);
        a += n * n.transpose();
        b += n * dot(p.normal, sub(p.point, near));
    }
    let eig = SymmetricEigen::new(a);
    let (lo, hi) = eig
        .eigenvalues
        .iter()
        .fold((f64::INFINITY, 0.0f64), |(lo, hi), &l| {
            (lo.min(l), hi.max(l))
        });
    if !(lo.is_finite() && hi.is_finite()) || lo <= 1e-6 * hi {
        return None;
    }
    let x = a.lu().solve(&b)?;
    let x = add(near, [x[0], x[1], x[2]]);
    x.iter().all(|c| c.is_finite()).then_some(x)
}

/// The oracle's answer for one scan.
#[derive(Debug, Clone)]
pub struct Oracle {
    /// Per true face: its plane, if enough points were far from the edges.
    pub planes: Vec<Option<Plane>>,
    /// Points used per face.
    pub face_points: Vec<usize>,
    /// Per true edge: the oracle segment (clipped to the true edge's extent).
    pub edges: Vec<Option<(V3, V3)>>,
    /// Per true corner: the least-squares point of its faces' planes.
    pub corners: Vec<Option<V3>>,
    /// Points closer than this to a sharp edge were left out of the plane fits.
    pub margin: f64,
}

/// Points closer than this many spacings beyond the widest rounded band are left out.
pub const MARGIN_SPACINGS: f64 = 3.0;

/// Fits the oracle to a scan of a polyhedral part. A face's points are those sampled on it
/// (`PointTruth::face`), not outliers, not abnormal, and farther than
/// `max tangent distance + MARGIN_SPACINGS · h` from every sharp edge (noise, not the
/// rounding, is then all that disturbs them).
pub fn fit(gt: &GroundTruth, positions: &[V3], truth: &[PointTruth]) -> Oracle {
    let td = gt
        .edges
        .iter()
        .map(|e| e.tangent_distance)
        .fold(0.0, f64::max);
    let margin = td + MARGIN_SPACINGS * gt.spacing;
    let nf = gt.faces.len();
    let mut members: Vec<Vec<u32>> = vec![Vec::new(); nf];
    for (i, t) in truth.iter().enumerate() {
        let f = t.face as usize;
        if f < nf && !t.outlier && !t.abnormal && t.edge_distance > margin {
            members[f].push(i as u32);
        }
    }
    // A fillet's faces are curved: no plane (its edges and corners get no oracle).
    let curved: std::collections::HashSet<usize> = gt
        .fillets
        .iter()
        .flat_map(|f| f.faces.iter().copied())
        .collect();
    let planes: Vec<Option<Plane>> = members
        .iter()
        .enumerate()
        .map(|(f, ids)| {
            if curved.contains(&f) {
                return None;
            }
            fit_plane(ids.iter().map(|&i| positions[i as usize]))
        })
        .collect();
    let edges = gt
        .edges
        .iter()
        .map(|e| {
            let [f0, f1] = e.faces;
            let (p0, p1) = (planes.get(f0)?.as_ref()?, planes.get(f1)?.as_ref()?);
            let mid = scale(add(e.start, e.end), 0.5);
            let (q, d) = plane_intersection(p0, p1, mid)?;
            // Clip: the projections of the true end points onto the oracle line.
            let at = |p: V3| add(q, scale(d, dot(sub(p, q), d)));
            Some((at(e.start), at(e.end)))
        })
        .collect();
    let corners = gt
        .corners
        .iter()
        .map(|c| {
            let mut faces: Vec<usize> = c.edges.iter().flat_map(|&e| gt.edges[e].faces).collect();
            faces.sort_unstable();
            faces.dedup();
            let ps: Option<Vec<Plane>> = faces.iter().map(|&f| *planes.get(f)?).collect();
            let ps = ps?;
            // Any point near the answer will do as the frame; the mean of the planes' points
            // is independent of the true corner.
            let near = scale(
                ps.iter().fold([0.0; 3], |s, p| add(s, p.point)),
                1.0 / ps.len() as f64,
            );
            planes_point(&ps, near)
        })
        .collect();
    Oracle {
        planes,
        face_points: members.iter().map(Vec::len).collect(),
        edges,
        corners,
        margin,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::dist;

    fn plane(normal: V3, point: V3) -> Plane {
        let l = norm(normal);
        Plane {
            normal: scale(normal, 1.0 / l),
            point,
        }
    }

    #[test]
    fn plane_fit_recovers_an_exact_plane() {
        // z = 0.5 x − 0.25 y + 4e6 (far from the origin): normal ∝ (0.5, −0.25, −1).
        let pts: Vec<V3> = (0..50)
            .flat_map(|i| (0..50).map(move |j| (i as f64 * 0.3, j as f64 * 0.7)))
            .map(|(x, y)| [x + 4e6, y, 0.5 * x - 0.25 * y + 4e6])
            .collect();
        let p = fit_plane(pts.iter().copied()).unwrap();
        let expected = scale([0.5, -0.25, -1.0], 1.0 / norm([0.5, -0.25, -1.0]));
        let cosine = dot(p.normal, expected).abs();
        assert!((1.0 - cosine).abs() < 1e-12, "{cosine}");
        for q in &pts {
            assert!(dot(p.normal, sub(*q, p.point)).abs() < 1e-6);
        }
    }

    #[test]
    fn plane_fit_rejects_collinear_and_too_few_points() {
        let line: Vec<V3> = (0..10).map(|i| [i as f64, 2.0 * i as f64, 0.0]).collect();
        assert_eq!(fit_plane(line.iter().copied()), None);
        assert_eq!(fit_plane([[0.0; 3], [1.0, 0.0, 0.0]].into_iter()), None);
    }

    #[test]
    fn two_planes_meet_in_their_common_line() {
        // x = 1 and y = 2 meet in the line (1, 2, t).
        let a = plane([1.0, 0.0, 0.0], [1.0, 7.0, 3.0]);
        let b = plane([0.0, 1.0, 0.0], [-5.0, 2.0, 9.0]);
        let (q, d) = plane_intersection(&a, &b, [0.0, 0.0, 5.0]).unwrap();
        assert!(dist(q, [1.0, 2.0, 5.0]) < 1e-12, "{q:?}");
        assert!((d[2].abs() - 1.0).abs() < 1e-12);
        assert_eq!(plane_intersection(&a, &a, [0.0; 3]), None);
    }

    #[test]
    fn corner_of_three_and_four_planes() {
        let c = [3.0, -2.0, 7.0];
        let three = [
            plane([1.0, 0.0, 0.0], c),
            plane([0.0, 1.0, 0.0], c),
            plane([0.0, 0.0, 1.0], c),
        ];
        assert!(dist(planes_point(&three, [0.0; 3]).unwrap(), c) < 1e-12);
        // A pyramid apex: four slanted faces through one point.
        let four = [
            plane([0.7, 0.0, 0.5], c),
            plane([-0.7, 0.0, 0.5], c),
            plane([0.0, 0.7, 0.5], c),
            plane([0.0, -0.7, 0.5], c),
        ];
        assert!(dist(planes_point(&four, [1.0, 1.0, 1.0]).unwrap(), c) < 1e-12);
        // Three faces around one axis (a prism's side faces) do not fix a point.
        let around = [
            plane([1.0, 0.0, 0.0], c),
            plane([0.0, 1.0, 0.0], c),
            plane([1.0, 1.0, 0.0], c),
        ];
        assert_eq!(planes_point(&around, [0.0; 3]), None);
        assert_eq!(planes_point(&three[..2], [0.0; 3]), None);
    }
}
