//! Triangles in 3D: the closest point, the distance and the normal.

use super::lines::point_segment;
use super::vec::{V3, add, axpy, cross, dist, dist2, dot, scale, sub, unit};

/// Closest point to `p` on triangle `abc`: Ericson, *Real-Time Collision Detection* (2005),
/// §5.1.5 `ClosestPtPointTriangle` (Voronoi regions of vertices, edges, face). Degenerate
/// triangles need no special case: the region tests then select a vertex or an edge.
pub fn closest_on_triangle(p: V3, a: V3, b: V3, c: V3) -> V3 {
    let ab = sub(b, a);
    let ac = sub(c, a);
    let ap = sub(p, a);
    let d1 = dot(ab, ap);
    let d2 = dot(ac, ap);
    if d1 <= 0.0 && d2 <= 0.0 {
        return a;
    }
    let bp = sub(p, b);
    let d3 = dot(ab, bp);
    let d4 = dot(ac, bp);
    if d3 >= 0.0 && d4 <= d3 {
        return b;
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        let v = d1 / (d1 - d3);
        return axpy(a, v, ab);
    }
    let cp = sub(p, c);
    let d5 = dot(ab, cp);
    let d6 = dot(ac, cp);
    if d6 >= 0.0 && d5 <= d6 {
        return c;
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        let w = d2 / (d2 - d6);
        return axpy(a, w, ac);
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        let w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
        return axpy(b, w, sub(c, b));
    }
    let denom = va + vb + vc;
    if denom.abs() < 1e-300 || !denom.is_finite() {
        // Zero area but p projects inside: the closest of the three edges is exact.
        let cands = [
            axpy(a, point_segment(p, a, b).1, ab),
            axpy(a, point_segment(p, a, c).1, ac),
            axpy(b, point_segment(p, b, c).1, sub(c, b)),
        ];
        return cands
            .into_iter()
            .min_by(|x, y| dist2(p, *x).total_cmp(&dist2(p, *y)))
            .unwrap_or(a);
    }
    let v = vb / denom;
    let w = vc / denom;
    add(a, add(scale(ab, v), scale(ac, w)))
}

/// Distance from `p` to triangle `abc`.
pub fn point_triangle(p: V3, a: V3, b: V3, c: V3) -> f64 {
    dist(p, closest_on_triangle(p, a, b, c))
}

/// Unit normal of triangle `abc` (counter-clockwise = outward), `None` if degenerate.
pub fn triangle_normal(a: V3, b: V3, c: V3) -> Option<V3> {
    unit(cross(sub(b, a), sub(c, a)))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::vec::scale;
    use rand::rngs::SmallRng;
    use rand::{RngExt, SeedableRng};

    /// The closed form against a dense brute-force sampling of the triangle.
    #[test]
    fn triangle_closest_point_matches_brute_force() {
        let mut rng = SmallRng::seed_from_u64(7);
        for _ in 0..200 {
            let mut r = || -> V3 { [rng.random(), rng.random(), rng.random()] };
            let (a, b, c, p) = (r(), r(), r(), scale(r(), 3.0));
            let d = point_triangle(p, a, b, c);
            let mut best = f64::INFINITY;
            let n = 200;
            for i in 0..=n {
                for j in 0..=(n - i) {
                    let (u, v) = (i as f64 / n as f64, j as f64 / n as f64);
                    let q = add(a, add(scale(sub(b, a), u), scale(sub(c, a), v)));
                    best = best.min(dist(p, q));
                }
            }
            assert!(d <= best + 1e-12 && best - d < 1e-2, "{d} vs {best}");
        }
    }

    #[test]
    fn degenerate_triangle_falls_back_to_edges() {
        let (a, b, c) = ([0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [2.0, 0.0, 0.0]);
        assert!((point_triangle([1.5, 1.0, 0.0], a, b, c) - 1.0).abs() < 1e-15);
        assert!(triangle_normal(a, b, c).is_none());
    }
}
