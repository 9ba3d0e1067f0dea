//! Edge rounding (the scan's "data abnormality at geometric discontinuity", the paper's
//! Figure 1): the geometry that moves samples near a sharp edge onto a rounded part.
//!
//! Input: a [`Model`] and the fillet radius `r` (model units). Output: per sharp edge the
//! cylinder of radius `r` tangent to both faces, the range along the edge where it applies,
//! and at suitable corners a ball of radius `r` tangent to all faces.
//!
//! Rule. A sample `P` on a face next to a sharp edge moves to the *closest point of the
//! rounded part*, treating the two faces locally as planes:
//! - In the cross-section perpendicular to the edge the two faces form a wedge of angle
//!   `β = 180° − (angle between the normals)`: the material wedge of a convex edge, the air
//!   wedge of a concave one. The fillet circle of radius `r` in that wedge has its centre on
//!   the bisector at `r / sin(β/2)` from the edge and touches each face at the tangent
//!   distance `t = r / tan(β/2)`. Samples with in-face distance `s < t` move radially onto the
//!   circle, `F = C + r (P − C) / |P − C|`, which is the nearest point of the circle: convex
//!   edges lose material, concave edges gain it. The density on the arc rises towards the
//!   bisector (by `1 / sin²(β/2)` at the very middle: 2× for 90°, 15× for a 30° wedge), as in
//!   real scans where points pile up on the rounded apex.
//! - Corners where three or more sharp edges of the same convexity meet between planar faces,
//!   and a point at distance `r` from all those faces exists (box corners, the pyramid apex),
//!   get a ball blend: the ball's centre lies on every edge's cylinder axis, so on each face
//!   the corner region (the kite bounded by the two edges and the perpendiculars through the
//!   ball centre's foot) maps radially onto the ball and joins the cylinders continuously;
//!   the cylinders stop at the cross-section through the ball centre. This is the surface a
//!   rolling-ball blend would make.
//! - Elsewhere (mixed convex/concave corners like the L-block's inner corner, corners of
//!   curved meshes) each cylinder runs to the end of its edge and the samples near the corner
//!   follow their nearest edge; the pieces meet with small seams, as a milled part with
//!   unblended fillets would.
//! - Along a polyline (a curved crease of a mesh) the cylinders of consecutive segments are
//!   not cut at their shared vertices; each sample follows its nearest segment.
//!
//! Radius limit: on an edge with ball corners at both ends, the two corner regions must not
//! overlap; [`build`] reports the largest radius the part allows otherwise.

use super::features::Model;
use crate::geometry::{V3, add, dot, scale, sub, unit};

/// The ball blend of one face at one end of an edge.
#[derive(Debug, Clone)]
pub struct Kite {
    /// Ball centre (at distance `r` from every face of the corner).
    pub centre: V3,
    /// The corner vertex.
    pub vertex: V3,
    /// Unit direction, from the vertex, of the face's other sharp edge at this corner, and the
    /// ball centre's coordinate along it.
    pub dir_other: V3,
    pub cut_other: f64,
}

/// The rounding of one sharp edge.
#[derive(Debug, Clone)]
pub struct EdgeFillet {
    /// Unit direction from `a` to `b` and the length.
    pub dir: V3,
    pub len: f64,
    /// Tangent distance `t` on each face; zero when the edge is not rounded.
    pub td: f64,
    /// Offset from the edge line to the cylinder axis (perpendicular to the edge).
    pub axis_off: V3,
    /// The cylinder applies for `lo <= λ <= hi`, λ measured from `a` along `dir`
    /// (infinite where the edge continues a polyline).
    pub lo: f64,
    pub hi: f64,
    /// Ball blends `[end][side]`.
    pub kites: [[Option<Kite>; 2]; 2],
}

/// Rounding of all sharp edges of a model.
#[derive(Debug, Clone)]
pub struct Fillets {
    pub r: f64,
    pub edges: Vec<EdgeFillet>,
    /// Largest tangent distance: samples farther than this from every edge never move.
    pub reach: f64,
    /// Number of corners that got a ball blend.
    pub ball_corners: usize,
    /// Their mesh vertex ids.
    pub ball_vertices: Vec<u32>,
}

/// The result of walking around a vertex from one side of a sharp edge.
struct Sector {
    other_edge: usize,
    planar: bool,
}

/// From edge `e`'s triangle on side `k`, turns around vertex `v` across smooth edges until
/// the next sharp edge; `None` when the walk leaves the manifold part of the mesh.
fn walk_sector(m: &Model, e: usize, k: usize, v: u32) -> Option<Sector> {
    let edge = &m.edges[e];
    let mut t = edge.tris[k];
    let mut x = if edge.v[0] == v { edge.v[1] } else { edge.v[0] };
    let n0 = m.tri_normals[t as usize];
    let mut planar = true;
    for _ in 0..512 {
        let tri = m.mesh.triangles[t as usize];
        let y = tri.iter().copied().find(|&w| w != v && w != x)?;
        let key = (v.min(y), v.max(y));
        if let Some(&other) = m.sharp_index.get(&key) {
            return Some(Sector {
                other_edge: other,
                planar,
            });
        }
        let pair = m.edge_tris.get(&key)?;
        t = if pair[0] == t { pair[1] } else { pair[0] };
        planar &= dot(m.tri_normals[t as usize], n0) > 1.0 - 1e-9;
        x = y;
    }
    None
}

/// Unit direction of edge `e` pointing away from its vertex `v`.
fn dir_from(m: &Model, e: usize, v: u32) -> V3 {
    let edge = &m.edges[e];
    let d = unit(sub(edge.b, edge.a)).unwrap_or([0.0; 3]);
    if edge.v[0] == v { d } else { scale(d, -1.0) }
}

/// Solves the 3x3 system `M x = b` by Cramer's rule; `None` when `M` is ill-conditioned
/// (relative to a matrix of unit normals, whose trace is the number of faces).
fn solve3(m: [[f64; 3]; 3], b: V3) -> Option<V3> {
    let det = |a: [[f64; 3]; 3]| {
        a[0][0] * (a[1][1] * a[2][2] - a[1][2] * a[2][1])
            - a[0][1] * (a[1][0] * a[2][2] - a[1][2] * a[2][0])
            + a[0][2] * (a[1][0] * a[2][1] - a[1][1] * a[2][0])
    };
    let d = det(m);
    if d.abs() < 1e-6 {
        return None;
    }
    let mut x = [0.0; 3];
    for (c, xc) in x.iter_mut().enumerate() {
        let mut mc = m;
        for r in 0..3 {
            mc[r][c] = b[r];
        }
        *xc = det(mc) / d;
    }
    Some(x)
}

/// Ball blend at vertex `v` if it qualifies (see the module comment): per incident edge and
/// side, the kite; `None` otherwise.
#[allow(clippy::type_complexity)]
fn ball_corner(m: &Model, v: u32, r: f64) -> Option<(V3, Vec<(usize, usize, usize)>)> {
    let inc = m.vertex_edges.get(&v)?;
    if inc.len() < 3 {
        return None;
    }
    let convex = m.edges[inc[0]].convex;
    if inc.iter().any(|&e| m.edges[e].convex != convex) {
        return None;
    }
    // (edge, side, other edge) for every sector, and the sector planes' normals.
    let mut sectors = Vec::new();
    let mut normals: Vec<V3> = Vec::new();
    for &e in inc {
        for k in 0..2 {
            let s = walk_sector(m, e, k, v)?;
            if !s.planar || s.other_edge == e {
                return None;
            }
            sectors.push((e, k, s.other_edge));
            let n = m.edges[e].normals[k];
            if !normals.iter().any(|q| dot(*q, n) > 1.0 - 1e-9) {
                normals.push(n);
            }
        }
    }
    // Least squares for n·C = n·V − σ r over all faces (σ = +1 puts C inside the material).
    let p = m.mesh.vertices[v as usize];
    let sigma = if convex { 1.0 } else { -1.0 };
    let mut mm = [[0.0; 3]; 3];
    let mut b = [0.0; 3];
    for n in &normals {
        let rhs = dot(*n, p) - sigma * r;
        for i in 0..3 {
            for j in 0..3 {
                mm[i][j] += n[i] * n[j];
            }
            b[i] += n[i] * rhs;
        }
    }
    let c = solve3(mm, b)?;
    let consistent = normals
        .iter()
        .all(|n| (dot(*n, c) - (dot(*n, p) - sigma * r)).abs() <= 1e-7 * r);
    if !consistent {
        return None;
    }
    // The ball must project forwards onto every incident edge.
    if inc
        .iter()
        .any(|&e| dot(sub(c, p), dir_from(m, e, v)) <= 0.0)
    {
        return None;
    }
    Some((c, sectors))
}

/// Builds the rounding of every sharp edge with radius `r` (model units). `Err(max_r)` when
/// `r` is so large that two corner blends on one edge would overlap; `max_r` is the largest
/// radius this part allows.
pub fn build(m: &Model, r: f64) -> Result<Fillets, f64> {
    let mut edges: Vec<EdgeFillet> = m
        .edges
        .iter()
        .map(|e| {
            let d = sub(e.b, e.a);
            let len = dot(d, d).sqrt();
            let half_beta_sin = (0.5 * e.normal_angle).cos(); // sin(β/2), β = π − θ
            let half_beta_tan = (0.5 * e.normal_angle).cos() / (0.5 * e.normal_angle).sin();
            let w = unit(add(e.inward[0], e.inward[1]));
            let rounded = r > 0.0 && half_beta_sin > 1e-6 && w.is_some();
            EdgeFillet {
                dir: unit(d).unwrap_or([0.0; 3]),
                len,
                td: if rounded { r / half_beta_tan } else { 0.0 },
                axis_off: match (rounded, w) {
                    (true, Some(w)) => scale(w, r / half_beta_sin),
                    _ => [0.0; 3],
                },
                lo: 0.0,
                hi: len,
                kites: [[None, None], [None, None]],
            }
        })
        .collect();
    let mut ball_vertices = Vec::new();
    if r > 0.0 {
        let corner_set: std::collections::HashSet<u32> =
            m.corners.iter().map(|c| c.vertex).collect();
        // Polyline continuations: the cylinder is not cut there.
        for (i, e) in m.edges.iter().enumerate() {
            for (end, &v) in e.v.iter().enumerate() {
                let deg = m.vertex_edges.get(&v).map_or(0, Vec::len);
                if deg == 2 && !corner_set.contains(&v) {
                    if end == 0 {
                        edges[i].lo = f64::NEG_INFINITY;
                    } else {
                        edges[i].hi = f64::INFINITY;
                    }
                }
            }
        }
        for corner in &m.corners {
            let v = corner.vertex;
            let Some((c, sectors)) = ball_corner(m, v, r) else {
                continue;
            };
            ball_vertices.push(v);
            let p = m.mesh.vertices[v as usize];
            for (e, k, other) in sectors {
                let end = if m.edges[e].v[0] == v { 0 } else { 1 };
                let cut_self = dot(sub(c, p), dir_from(m, e, v));
                let dir_other = dir_from(m, other, v);
                let f = &mut edges[e];
                if end == 0 {
                    f.lo = cut_self;
                } else {
                    f.hi = f.len - cut_self;
                }
                f.kites[end][k] = Some(Kite {
                    centre: c,
                    vertex: p,
                    dir_other,
                    cut_other: dot(sub(c, p), dir_other),
                });
            }
        }
        // Corner blends at both ends of one edge must not overlap.
        let mut max_r = f64::INFINITY;
        for f in &edges {
            if f.lo > f.hi {
                let used = f.lo.max(0.0) + (f.len - f.hi).max(0.0);
                max_r = max_r.min(r * f.len / used);
            }
        }
        if max_r.is_finite() {
            return Err(max_r);
        }
    }
    let reach = edges.iter().map(|f| f.td).fold(0.0, f64::max);
    Ok(Fillets {
        r,
        edges,
        reach,
        ball_corners: ball_vertices.len(),
        ball_vertices,
    })
}

#[cfg(test)]
mod tests {
    use super::super::features::{FeatureOptions, analyse};
    use super::super::parts::{Part, normalise, polyhedron};
    use super::*;

    fn model(shape: Part) -> Model {
        let mut mesh = polyhedron(&shape, 6, 30.0, 3).unwrap();
        normalise(&mut mesh, Some(10.0));
        analyse(
            mesh,
            &FeatureOptions {
                sharp_angle: 1e-6,
                corner_angle: 30f64.to_radians(),
                chart_angle: 1e-7,
                chart_distance: 1e-9,
            },
        )
    }

    #[test]
    fn box_corners_are_balls_with_cuts_equal_to_the_radius() {
        let m = model(Part::Box);
        let f = build(&m, 0.5).unwrap();
        assert_eq!(f.ball_corners, 8);
        for (e, fe) in m.edges.iter().zip(&f.edges) {
            assert!((fe.td - 0.5).abs() < 1e-12);
            assert!((fe.lo - 0.5).abs() < 1e-12 && (fe.len - fe.hi - 0.5).abs() < 1e-12);
            // The axis is at distance r from both faces, inside the material.
            for k in 0..2 {
                let off = dot(fe.axis_off, e.normals[k]);
                assert!((off + 0.5).abs() < 1e-12, "{off}");
            }
            assert!(fe.kites.iter().flatten().all(Option::is_some));
        }
    }

    #[test]
    fn l_block_inner_corners_are_not_balls() {
        let m = model(Part::LBlock);
        let f = build(&m, 0.2).unwrap();
        // 12 corners, the two at the ends of the concave edge mix convexities.
        assert_eq!(m.corners.len(), 12);
        assert_eq!(f.ball_corners, 10);
    }

    #[test]
    fn pyramid_apex_is_a_ball_corner() {
        let m = model(Part::Pyramid);
        let f = build(&m, 0.2).unwrap();
        assert_eq!(f.ball_corners, 5);
    }

    #[test]
    fn too_large_a_radius_is_refused_with_the_limit() {
        let m = model(Part::Box); // 10 x 8 x 6: the shortest edge is 6
        let max_r = build(&m, 4.0).unwrap_err();
        assert!((max_r - 3.0).abs() < 1e-9, "{max_r}");
        assert!(build(&m, 2.99).is_ok());
    }

    #[test]
    fn wedge_tangent_distance_follows_the_angle() {
        let m = model(Part::Wedge);
        let f = build(&m, 0.1).unwrap();
        let sharp = m
            .edges
            .iter()
            .position(|e| (e.dihedral_deg() - 30.0).abs() < 1e-9)
            .unwrap();
        assert!((f.edges[sharp].td - 0.1 / 15f64.to_radians().tan()).abs() < 1e-12);
    }
}
