//! First hits of rays on a triangle mesh: what a sensor sees.
//!
//! Input: the model's mesh (model coordinates). Output: [`Caster::first_hit`], the nearest
//! triangle a ray meets and the exact point on it, and [`Caster::visible`], whether a point
//! of the surface is seen from a sensor position (no other surface in between).
//!
//! The triangles sit in a [`GridIndex`] walked along the ray (see index.rs for why a grid and
//! not a crate BVH). The ray–triangle test is Möller & Trumbore, "Fast, minimum storage
//! ray/triangle intersection" (1997), in f64, with the barycentric bounds widened by 1e-12 so
//! a ray through an edge shared by two triangles cannot slip between them. Degenerate
//! (zero-area) triangles are never hit.

use super::index::GridIndex;
use crate::geometry::{V3, add, cross, dist, dot, scale, sub};
use crate::io::mesh::Mesh;

/// A ray's first hit: ray parameter (distance for a unit direction), triangle, point.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Hit {
    pub t: f64,
    pub tri: u32,
    pub point: V3,
}

/// The mesh's triangles with a grid over them.
pub struct Caster<'a> {
    mesh: &'a Mesh,
    grid: GridIndex,
}

/// Möller–Trumbore: `(t, u, v)` of the ray `o + t d` on triangle `abc` (point `a + u (b - a)
/// + v (c - a)`), for `t > 0`; `None` when it misses or the triangle is degenerate.
pub fn ray_triangle(o: V3, d: V3, a: V3, b: V3, c: V3) -> Option<(f64, f64, f64)> {
    const SLACK: f64 = 1e-12;
    let e1 = sub(b, a);
    let e2 = sub(c, a);
    let pv = cross(d, e2);
    let det = dot(e1, pv);
    let scale_ref = dot(e1, e1).max(dot(e2, e2)) * dot(d, d).sqrt();
    if det.is_nan() || det.abs() <= 1e-14 * scale_ref {
        return None; // parallel to the plane, or zero area
    }
    let inv = 1.0 / det;
    let tv = sub(o, a);
    let u = dot(tv, pv) * inv;
    if !(-SLACK..=1.0 + SLACK).contains(&u) {
        return None;
    }
    let qv = cross(tv, e1);
    let v = dot(d, qv) * inv;
    if v < -SLACK || u + v > 1.0 + SLACK {
        return None;
    }
    let t = dot(e2, qv) * inv;
    (t > 0.0).then_some((t, u, v))
}

impl<'a> Caster<'a> {
    pub fn new(mesh: &'a Mesh) -> Self {
        let boxes: Vec<(V3, V3)> = mesh
            .triangles
            .iter()
            .map(|t| {
                let p = t.map(|i| mesh.vertices[i as usize]);
                (
                    [0, 1, 2].map(|k| p[0][k].min(p[1][k]).min(p[2][k])),
                    [0, 1, 2].map(|k| p[0][k].max(p[1][k]).max(p[2][k])),
                )
            })
            .collect();
        Caster {
            mesh,
            grid: GridIndex::build(&boxes, 4.0),
        }
    }

    /// The first triangle the ray `o + t d` meets with `0 < t <= t_max`; ties go to the
    /// lower triangle id, so the answer never depends on the order cells are visited in.
    pub fn first_hit(&self, o: V3, d: V3, t_max: f64) -> Option<Hit> {
        let mut best: Option<(f64, u32, f64, f64)> = None;
        self.grid.ray_cells(o, d, t_max, |items, t_exit| {
            for &id in items {
                let [a, b, c] =
                    self.mesh.triangles[id as usize].map(|i| self.mesh.vertices[i as usize]);
                if let Some((t, u, v)) = ray_triangle(o, d, a, b, c) {
                    let better = best.is_none_or(|(bt, bi, _, _)| t < bt || (t == bt && id < bi));
                    if t <= t_max && better {
                        best = Some((t, id, u, v));
                    }
                }
            }
            best.is_some_and(|(t, _, _, _)| t <= t_exit)
        });
        best.map(|(t, tri, u, v)| {
            let [a, b, c] =
                self.mesh.triangles[tri as usize].map(|i| self.mesh.vertices[i as usize]);
            // On the triangle by its barycentric coordinates (exact to rounding), not o + t d.
            let point = add(a, add(scale(sub(b, a), u), scale(sub(c, a), v)));
            Hit { t, tri, point }
        })
    }

    /// Whether `p` (a point of the surface) is seen from `sensor`: nothing meets the line of
    /// sight before `p`, up to `tol` (model units) for the surface `p` lies on.
    pub fn visible(&self, sensor: V3, p: V3, tol: f64) -> bool {
        let l = dist(sensor, p);
        if l <= tol {
            return true;
        }
        let d = scale(sub(p, sensor), 1.0 / l);
        self.first_hit(sensor, d, l - tol).is_none()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::synth::parts::{Part, polyhedron};

    #[test]
    fn ray_hits_a_triangle_where_expected() {
        let (a, b, c) = ([0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]);
        let (t, u, v) = ray_triangle([0.25, 0.25, 2.0], [0.0, 0.0, -1.0], a, b, c).unwrap();
        assert!((t - 2.0).abs() < 1e-15 && (u - 0.25).abs() < 1e-15 && (v - 0.25).abs() < 1e-15);
        assert!(ray_triangle([0.8, 0.8, 2.0], [0.0, 0.0, -1.0], a, b, c).is_none());
        assert!(ray_triangle([0.25, 0.25, 2.0], [0.0, 0.0, 1.0], a, b, c).is_none());
        // Degenerate triangle: never hit.
        assert!(ray_triangle([0.5, 0.0, 1.0], [0.0, 0.0, -1.0], a, b, [2.0, 0.0, 0.0]).is_none());
    }

    /// The grid walk against a loop over every triangle, for rays from outside an L-block
    /// (non-convex: some rays cross it twice).
    #[test]
    fn first_hit_matches_brute_force() {
        use rand::rngs::SmallRng;
        use rand::{RngExt, SeedableRng};
        let mesh = polyhedron(&Part::LBlock, 6, 30.0, 3).unwrap();
        let caster = Caster::new(&mesh);
        let mut rng = SmallRng::seed_from_u64(9);
        let mut hits = 0;
        for _ in 0..3000 {
            let o: V3 = [0, 1, 2].map(|_| rng.random::<f64>() * 6.0 - 3.0);
            let target: V3 = [0, 1, 2].map(|_| rng.random::<f64>() * 2.0 - 0.5);
            let d = crate::geometry::unit(sub(target, o)).unwrap();
            let got = caster.first_hit(o, d, f64::INFINITY);
            let want = mesh
                .triangles
                .iter()
                .enumerate()
                .filter_map(|(i, t)| {
                    let [a, b, c] = t.map(|k| mesh.vertices[k as usize]);
                    ray_triangle(o, d, a, b, c).map(|(t, _, _)| (t, i as u32))
                })
                .min_by(|x, y| x.0.total_cmp(&y.0).then(x.1.cmp(&y.1)));
            assert_eq!(got.map(|h| (h.t, h.tri)), want);
            hits += got.is_some() as usize;
        }
        assert!(hits > 500, "{hits} hits");
    }
}
