//! Sharp features of a triangle mesh: sharp edges, their polylines, corners, and planar charts.
//!
//! Input: a [`Mesh`] and the thresholds in [`FeatureOptions`]. Output: a [`Model`] that holds
//! per-triangle normals, the sharp edges (mesh edges whose two face normals differ by more than
//! the sharp angle), the polylines they form, the corners and the charts (connected sets of
//! coplanar triangles) that the sampler lays one grid over.
//!
//! Orientation: normals follow the triangles' winding, flipped as a whole when the mesh
//! encloses a negative volume, so convex/concave is decided with outward normals. Edges whose
//! two triangles wind inconsistently are counted; their convexity is then unreliable.
//!
//! Corner rule. A vertex is a corner when three or more sharp edges meet there, or when it
//! joins exactly two sharp edges and the polyline *turns abruptly* there: its turning angle
//! `θ_v` (between the directions of the two edges) exceeds the turning of its neighbours by
//! more than the corner angle: `θ_v − min(θ_prev, θ_next) > corner_angle`, where the minimum
//! is over neighbouring vertices that themselves join two sharp edges (0 if there are none).
//! A smooth curved crease sampled by a mesh turns by about the same small angle at every
//! vertex, so its vertices cancel against their neighbours even when a coarse mesh makes
//! each turn large; a real corner turns much more than the vertices next to it. Vertices where
//! a single sharp edge ends are polyline ends, not corners.

use std::collections::{HashMap, HashSet};

use crate::geometry::{V3, angle, cross, dot, norm, sub, triangle_normal, unit};
use crate::io::mesh::Mesh;

/// Thresholds for feature extraction (angles in radians, distances in model units).
#[derive(Debug, Clone, Copy)]
pub struct FeatureOptions {
    /// An edge is sharp when its face normals differ by more than this.
    pub sharp_angle: f64,
    /// Excess turning that makes a two-edge vertex a corner (see the module comment).
    pub corner_angle: f64,
    /// Triangles join a chart when their normal is within this angle of the chart's seed…
    pub chart_angle: f64,
    /// …and their vertices within this distance of the seed's plane.
    pub chart_distance: f64,
}

/// A sharp edge of the model.
#[derive(Debug, Clone)]
pub struct SharpEdge {
    /// Mesh vertex ids of the ends.
    pub v: [u32; 2],
    pub a: V3,
    pub b: V3,
    /// The two triangles that meet here and their outward unit normals.
    pub tris: [u32; 2],
    pub normals: [V3; 2],
    /// Unit vectors in each triangle's plane, perpendicular to the edge, pointing into it.
    pub inward: [V3; 2],
    pub convex: bool,
    /// Angle between the normals (radians); the dihedral angle is π ∓ this.
    pub normal_angle: f64,
}

impl SharpEdge {
    /// Interior (material) dihedral angle in degrees: < 180 convex, > 180 concave.
    pub fn dihedral_deg(&self) -> f64 {
        let t = self.normal_angle.to_degrees();
        if self.convex { 180.0 - t } else { 180.0 + t }
    }
    pub fn length(&self) -> f64 {
        norm(sub(self.b, self.a))
    }
}

/// A chart: connected coplanar triangles sampled with one grid.
#[derive(Debug, Clone)]
pub struct Chart {
    pub tris: Vec<u32>,
    pub normal: V3,
    pub origin: V3,
    pub area: f64,
}

/// A corner: a vertex of the sharp-edge graph that is a corner by the module's rule.
#[derive(Debug, Clone)]
pub struct Corner {
    pub vertex: u32,
    pub position: V3,
    pub edges: Vec<usize>,
}

/// A maximal chain of sharp edges between corners or ends (or a closed loop).
#[derive(Debug, Clone)]
pub struct Polyline {
    /// Edge ids in chain order.
    pub edges: Vec<usize>,
    pub closed: bool,
}

/// Counts that tell how trustworthy the mesh's features are.
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct MeshStats {
    /// Edges with one triangle (holes or an open surface).
    pub boundary_edges: usize,
    /// Edges with three or more triangles (never sharp).
    pub nonmanifold_edges: usize,
    /// Edges whose two triangles wind the same way (convexity unreliable there).
    pub inconsistent_edges: usize,
    /// Triangles with (numerically) zero area.
    pub degenerate_triangles: usize,
    /// The mesh enclosed a negative volume and its normals were flipped.
    pub flipped: bool,
}

/// A mesh with its sharp features, in model coordinates.
#[derive(Debug, Clone)]
pub struct Model {
    pub mesh: Mesh,
    /// Outward unit normal per triangle (zero for degenerate triangles).
    pub tri_normals: Vec<V3>,
    pub tri_chart: Vec<u32>,
    pub charts: Vec<Chart>,
    pub edges: Vec<SharpEdge>,
    /// Sharp edge ids incident to each mesh vertex (empty for most vertices).
    pub vertex_edges: HashMap<u32, Vec<usize>>,
    pub corners: Vec<Corner>,
    pub polylines: Vec<Polyline>,
    pub stats: MeshStats,
    /// The two triangles of every manifold edge, keyed by (smaller, larger) vertex id.
    pub edge_tris: HashMap<(u32, u32), [u32; 2]>,
    /// Sharp edge id by (smaller, larger) vertex id.
    pub sharp_index: HashMap<(u32, u32), usize>,
}

/// Builds the [`Model`] of a mesh; an edge is sharp when its normals differ by more than
/// `opt.sharp_angle`.
pub fn analyse(mesh: Mesh, opt: &FeatureOptions) -> Model {
    analyse_with(mesh, opt, None)
}

/// Like [`analyse`], but when `creases` is given exactly those manifold edges are sharp (a
/// subdivided mesh keeps its original sharp edges, whatever the angles of their pieces).
pub fn analyse_with(
    mesh: Mesh,
    opt: &FeatureOptions,
    creases: Option<&HashSet<(u32, u32)>>,
) -> Model {
    analyse_marked(mesh, opt, creases, None)
}

/// Like [`analyse_with`]; besides, the manifold edges in `breaks` that are not sharp still end
/// the charts on their two sides (a wide fillet's tangent lines: the flat face next to it
/// stays one exact plane, the fillet gets charts of its own).
pub fn analyse_marked(
    mesh: Mesh,
    opt: &FeatureOptions,
    creases: Option<&HashSet<(u32, u32)>>,
    breaks: Option<&HashSet<(u32, u32)>>,
) -> Model {
    let nt = mesh.triangles.len();
    let verts = &mesh.vertices;
    let tri_pts = |t: usize| mesh.triangles[t].map(|i| verts[i as usize]);

    let mut stats = MeshStats::default();
    let mut normals: Vec<V3> = (0..nt)
        .map(|t| {
            let [a, b, c] = tri_pts(t);
            triangle_normal(a, b, c).unwrap_or_else(|| {
                stats.degenerate_triangles += 1;
                [0.0; 3]
            })
        })
        .collect();
    // Signed volume (divergence theorem): negative means the normals point inwards.
    let volume: f64 = (0..nt)
        .map(|t| {
            let [a, b, c] = tri_pts(t);
            dot(a, cross(b, c))
        })
        .sum();
    if volume < 0.0 {
        stats.flipped = true;
        for n in &mut normals {
            *n = n.map(|c| -c);
        }
    }

    // Edge → incident triangles, with the direction each triangle traverses it.
    let mut edge_tris: HashMap<(u32, u32), Vec<(u32, bool)>> = HashMap::with_capacity(nt * 3 / 2);
    for (t, tri) in mesh.triangles.iter().enumerate() {
        for k in 0..3 {
            let (i, j) = (tri[k], tri[(k + 1) % 3]);
            if i == j {
                continue;
            }
            let key = (i.min(j), i.max(j));
            edge_tris.entry(key).or_default().push((t as u32, i < j));
        }
    }
    let mut keys: Vec<(u32, u32)> = edge_tris.keys().copied().collect();
    keys.sort_unstable();

    let mut edges = Vec::new();
    let mut manifold: HashMap<(u32, u32), [u32; 2]> = HashMap::with_capacity(nt * 3 / 2);
    let mut sharp_index = HashMap::new();
    // Non-sharp manifold adjacency for the charts.
    let mut smooth_adj: Vec<Vec<u32>> = vec![Vec::new(); nt];
    for key in keys {
        let inc = &edge_tris[&key];
        match inc.len() {
            1 => {
                stats.boundary_edges += 1;
                continue;
            }
            2 => {}
            _ => {
                stats.nonmanifold_edges += 1;
                continue;
            }
        }
        let (t0, fwd0) = inc[0];
        let (t1, fwd1) = inc[1];
        manifold.insert(key, [t0, t1]);
        let n0 = normals[t0 as usize];
        let mut n1 = normals[t1 as usize];
        if fwd0 == fwd1 {
            stats.inconsistent_edges += 1;
            n1 = n1.map(|c| -c);
        }
        if n0 == [0.0; 3] || n1 == [0.0; 3] {
            continue; // a degenerate triangle has no normal to compare
        }
        let theta = angle(n0, n1);
        let sharp = match creases {
            Some(c) => c.contains(&key),
            None => theta > opt.sharp_angle,
        };
        if !sharp {
            if !breaks.is_some_and(|b| b.contains(&key)) {
                smooth_adj[t0 as usize].push(t1);
                smooth_adj[t1 as usize].push(t0);
            }
            continue;
        }
        let (a, b) = (verts[key.0 as usize], verts[key.1 as usize]);
        let opp = |t: u32| {
            let tri = mesh.triangles[t as usize];
            let o = tri
                .iter()
                .copied()
                .find(|&v| v != key.0 && v != key.1)
                .unwrap_or(tri[0]);
            verts[o as usize]
        };
        let (o0, o1) = (opp(t0), opp(t1));
        // Convex when each triangle's far vertex lies behind the other's plane.
        let convex = dot(n0, sub(o1, a)) + dot(n1, sub(o0, a)) < 0.0;
        let dir = unit(sub(b, a)).unwrap_or([0.0; 3]);
        let inward = |n: V3, o: V3| {
            let d = unit(cross(n, dir)).unwrap_or([0.0; 3]);
            if dot(d, sub(o, a)) < 0.0 {
                d.map(|c| -c)
            } else {
                d
            }
        };
        sharp_index.insert(key, edges.len());
        edges.push(SharpEdge {
            v: [key.0, key.1],
            a,
            b,
            tris: [t0, t1],
            normals: [n0, n1],
            inward: [inward(n0, o0), inward(n1, o1)],
            convex,
            normal_angle: theta,
        });
    }

    let charts_tri = build_charts(&mesh, &normals, &smooth_adj, opt);
    let (charts, tri_chart) = charts_tri;

    let mut vertex_edges: HashMap<u32, Vec<usize>> = HashMap::new();
    for (i, e) in edges.iter().enumerate() {
        for v in e.v {
            vertex_edges.entry(v).or_default().push(i);
        }
    }
    let corners = find_corners(&edges, &vertex_edges, verts, opt.corner_angle);
    let polylines = trace_polylines(&edges, &vertex_edges, &corners);

    Model {
        tri_normals: normals,
        tri_chart,
        charts,
        edges,
        vertex_edges,
        corners,
        polylines,
        stats,
        edge_tris: manifold,
        sharp_index,
        mesh,
    }
}

fn build_charts(
    mesh: &Mesh,
    normals: &[V3],
    smooth_adj: &[Vec<u32>],
    opt: &FeatureOptions,
) -> (Vec<Chart>, Vec<u32>) {
    let nt = mesh.triangles.len();
    let mut tri_chart = vec![u32::MAX; nt];
    let mut charts = Vec::new();
    let mut stack = Vec::new();
    let cos_tol = opt.chart_angle.cos();
    let area = |t: usize| {
        let [a, b, c] = mesh.triangles[t].map(|i| mesh.vertices[i as usize]);
        0.5 * norm(cross(sub(b, a), sub(c, a)))
    };
    for seed in 0..nt {
        if tri_chart[seed] != u32::MAX {
            continue;
        }
        let id = charts.len() as u32;
        let n = normals[seed];
        let origin = mesh.vertices[mesh.triangles[seed][0] as usize];
        let mut tris = vec![seed as u32];
        tri_chart[seed] = id;
        stack.push(seed as u32);
        // Degenerate triangles stay alone: they carry no area and no normal.
        if n != [0.0; 3] {
            while let Some(t) = stack.pop() {
                for &u in &smooth_adj[t as usize] {
                    let u = u as usize;
                    if tri_chart[u] != u32::MAX || dot(normals[u], n) < cos_tol {
                        continue;
                    }
                    let near_plane = mesh.triangles[u].iter().all(|&v| {
                        dot(sub(mesh.vertices[v as usize], origin), n).abs() <= opt.chart_distance
                    });
                    if near_plane {
                        tri_chart[u] = id;
                        tris.push(u as u32);
                        stack.push(u as u32);
                    }
                }
            }
        }
        stack.clear();
        tris.sort_unstable();
        let a = tris.iter().map(|&t| area(t as usize)).sum();
        charts.push(Chart {
            tris,
            normal: n,
            origin,
            area: a,
        });
    }
    (charts, tri_chart)
}

/// The other end of edge `e` seen from vertex `v`.
fn other_end(e: &SharpEdge, v: u32) -> u32 {
    if e.v[0] == v { e.v[1] } else { e.v[0] }
}

/// Turning angle at a vertex joining exactly two sharp edges (radians), else `None`.
fn turning(
    v: u32,
    edges: &[SharpEdge],
    vertex_edges: &HashMap<u32, Vec<usize>>,
    verts: &[V3],
) -> Option<f64> {
    let inc = vertex_edges.get(&v)?;
    if inc.len() != 2 {
        return None;
    }
    let p = verts[v as usize];
    let u = verts[other_end(&edges[inc[0]], v) as usize];
    let w = verts[other_end(&edges[inc[1]], v) as usize];
    Some(angle(sub(p, u), sub(w, p)))
}

fn find_corners(
    edges: &[SharpEdge],
    vertex_edges: &HashMap<u32, Vec<usize>>,
    verts: &[V3],
    corner_angle: f64,
) -> Vec<Corner> {
    let mut vs: Vec<u32> = vertex_edges.keys().copied().collect();
    vs.sort_unstable();
    let mut corners = Vec::new();
    for v in vs {
        let inc = &vertex_edges[&v];
        let is_corner = match inc.len() {
            0 | 1 => false,
            2 => {
                let theta = turning(v, edges, vertex_edges, verts).unwrap_or(0.0);
                let baseline = inc
                    .iter()
                    .filter_map(|&e| turning(other_end(&edges[e], v), edges, vertex_edges, verts))
                    .fold(None, |m: Option<f64>, t| Some(m.map_or(t, |m| m.min(t))))
                    .unwrap_or(0.0);
                theta - baseline > corner_angle
            }
            _ => true,
        };
        if is_corner {
            corners.push(Corner {
                vertex: v,
                position: verts[v as usize],
                edges: inc.clone(),
            });
        }
    }
    corners
}

fn trace_polylines(
    edges: &[SharpEdge],
    vertex_edges: &HashMap<u32, Vec<usize>>,
    corners: &[Corner],
) -> Vec<Polyline> {
    let stop: std::collections::HashSet<u32> = corners.iter().map(|c| c.vertex).collect();
    // A chain passes through a vertex only if it joins exactly two edges and is no corner.
    let passes = |v: u32| !stop.contains(&v) && vertex_edges.get(&v).is_some_and(|e| e.len() == 2);
    let mut used = vec![false; edges.len()];
    let mut out = Vec::new();
    let walk = |start_edge: usize, start_vertex: u32, used: &mut Vec<bool>| -> Polyline {
        // Walk from `start_vertex` through `start_edge` onwards.
        let mut chain = vec![start_edge];
        used[start_edge] = true;
        let mut v = other_end(&edges[start_edge], start_vertex);
        let mut closed = false;
        while passes(v) {
            let next = vertex_edges[&v].iter().copied().find(|&e| !used[e]);
            match next {
                Some(e) => {
                    used[e] = true;
                    chain.push(e);
                    v = other_end(&edges[e], v);
                }
                None => {
                    closed = v == start_vertex;
                    break;
                }
            }
        }
        Polyline {
            edges: chain,
            closed,
        }
    };
    // Open chains start at vertices the chains cannot pass through.
    for (i, e) in edges.iter().enumerate() {
        for v in e.v {
            if !used[i] && !passes(v) {
                out.push(walk(i, v, &mut used));
            }
        }
    }
    // What is left are closed loops of pass-through vertices.
    for i in 0..edges.len() {
        if !used[i] {
            let mut p = walk(i, edges[i].v[0], &mut used);
            p.closed = true;
            out.push(p);
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn opts() -> FeatureOptions {
        FeatureOptions {
            sharp_angle: 30f64.to_radians(),
            corner_angle: 30f64.to_radians(),
            chart_angle: 1e-6,
            chart_distance: 1e-9,
        }
    }

    fn cube() -> Mesh {
        let v = (0..8)
            .map(|i| [(i & 1) as f64, ((i >> 1) & 1) as f64, ((i >> 2) & 1) as f64])
            .collect();
        // Outward-wound quads of the unit cube, split into triangles.
        let quads = [
            [0, 2, 3, 1],
            [4, 5, 7, 6],
            [0, 1, 5, 4],
            [2, 6, 7, 3],
            [0, 4, 6, 2],
            [1, 3, 7, 5],
        ];
        let mut t = Vec::new();
        for q in quads {
            t.push([q[0], q[1], q[2]]);
            t.push([q[0], q[2], q[3]]);
        }
        Mesh {
            vertices: v,
            triangles: t,
        }
    }

    #[test]
    fn cube_has_12_convex_edges_8_corners_6_charts() {
        let m = analyse(cube(), &opts());
        assert_eq!(m.edges.len(), 12);
        assert!(m.edges.iter().all(|e| e.convex));
        assert!(
            m.edges
                .iter()
                .all(|e| (e.dihedral_deg() - 90.0).abs() < 1e-9)
        );
        assert_eq!(m.corners.len(), 8);
        assert!(m.corners.iter().all(|c| c.edges.len() == 3));
        assert_eq!(m.charts.len(), 6);
        assert_eq!(m.polylines.len(), 12);
        assert!(!m.stats.flipped);
        for e in &m.edges {
            for k in 0..2 {
                assert!(dot(e.inward[k], e.normals[k]).abs() < 1e-12);
                assert!((norm(e.inward[k]) - 1.0).abs() < 1e-12);
            }
        }
    }

    #[test]
    fn inside_out_cube_is_flipped_and_still_convex() {
        let mut c = cube();
        for t in &mut c.triangles {
            t.swap(1, 2);
        }
        let m = analyse(c, &opts());
        assert!(m.stats.flipped);
        assert!(m.edges.iter().all(|e| e.convex));
    }

    /// Sharp edges along a polyline through `pts` (closed when `closed`).
    fn chain(pts: &[V3], closed: bool) -> (Vec<SharpEdge>, HashMap<u32, Vec<usize>>) {
        let n = pts.len() as u32;
        let m = if closed { n } else { n - 1 };
        let edges: Vec<SharpEdge> = (0..m)
            .map(|i| SharpEdge {
                v: [i, (i + 1) % n],
                a: pts[i as usize],
                b: pts[((i + 1) % n) as usize],
                tris: [0, 0],
                normals: [[0.0; 3]; 2],
                inward: [[0.0; 3]; 2],
                convex: true,
                normal_angle: 1.0,
            })
            .collect();
        let mut ve: HashMap<u32, Vec<usize>> = HashMap::new();
        for (i, e) in edges.iter().enumerate() {
            for v in e.v {
                ve.entry(v).or_default().push(i);
            }
        }
        (edges, ve)
    }

    /// A regular octagon turns by 45° (> 30°) at every vertex, yet no vertex stands out.
    #[test]
    fn uniform_turning_makes_no_corners() {
        let pts: Vec<V3> = (0..8)
            .map(|i| {
                let a = std::f64::consts::TAU * i as f64 / 8.0;
                [a.cos(), a.sin(), 0.0]
            })
            .collect();
        let (e, ve) = chain(&pts, true);
        assert!(find_corners(&e, &ve, &pts, 30f64.to_radians()).is_empty());
        let lines = trace_polylines(&e, &ve, &[]);
        assert_eq!(lines.len(), 1);
        assert!(lines[0].closed);
        assert_eq!(lines[0].edges.len(), 8);
    }

    /// A finely sampled arc (3° per vertex) then a 60° kink then a straight run: only the kink.
    #[test]
    fn a_kink_between_an_arc_and_a_line_is_the_only_corner() {
        let mut pts: Vec<V3> = (0..=20)
            .map(|i| {
                let a = (3.0 * i as f64).to_radians();
                [a.cos(), a.sin(), 0.0]
            })
            .collect();
        let last = pts[20];
        let tangent = [-(60f64.to_radians()).sin(), 60f64.to_radians().cos(), 0.0];
        // Turn 60° away from the arc's tangent at the last arc vertex.
        let dir = {
            let c = 60f64.to_radians().cos();
            let s = 60f64.to_radians().sin();
            [
                c * tangent[0] - s * tangent[1],
                s * tangent[0] + c * tangent[1],
                0.0,
            ]
        };
        for k in 1..=5 {
            pts.push([
                last[0] + 0.05 * k as f64 * dir[0],
                last[1] + 0.05 * k as f64 * dir[1],
                0.0,
            ]);
        }
        let (e, ve) = chain(&pts, false);
        let c = find_corners(&e, &ve, &pts, 30f64.to_radians());
        assert_eq!(c.len(), 1);
        assert_eq!(c[0].vertex, 20);
        let lines = trace_polylines(&e, &ve, &c);
        assert_eq!(lines.len(), 2);
        assert_eq!(lines[0].edges.len() + lines[1].edges.len(), 25);
    }
}
