//! Scanner-like sampling of a [`Model`] (or of a sphere) with rounding, noise and outliers.
//!
//! Input: the model, its fillets, the sampling pitch `h` and the disturbance parameters.
//! Output: world positions and a [`PointTruth`] per point, written into preallocated arrays.
//!
//! Grid. Every chart (a set of coplanar triangles) gets one square grid of pitch `h` in its
//! plane, with a random in-plane orientation and offset drawn from (seed, chart id). Each node
//! is displaced by a uniform jitter of `jitter · h` (full width) per axis; the jitter comes from
//! a hash of (seed, chart, node), so it is the same whichever triangle looks at the node. A
//! jittered node becomes a point if it falls inside one of the chart's triangles; on an edge
//! shared by two triangles exactly one claims it (the edge function is evaluated in a canonical
//! vertex order, and a zero value goes to the triangle on its positive side), so there are no
//! duplicates and no gaps. The point is placed by its barycentric coordinates on the 3D
//! triangle, so it lies on the mesh to rounding error. The expected count on a face of area A
//! is A / h², because the grid offset is uniform.
//!
//! Work units. The grid of every chart is cut into tiles of `TILE × TILE` nodes. A first
//! parallel pass counts each tile's points (and their bounding box), a prefix sum gives every
//! tile its slice of the output, and a second parallel pass fills the slices. Each tile draws
//! noise and outliers from its own RNG seeded from (seed, chart, tile), so the output is the
//! same for any number of threads, and nothing is allocated per point.
//!
//! Sphere. A Fibonacci lattice (golden-angle spiral) with a tangential jitter, projected back
//! onto the sphere, one point per h² of area.

use rand::rngs::SmallRng;
use rand::{RngExt, SeedableRng};
use rayon::prelude::*;

use super::PointTruth;
use super::features::Model;
use super::fillet::Fillets;
use super::geom::{derive, gauss3, mix, two_uniforms};
use crate::geometry::{V3, add, axpy, cross, dist, dot, mat_vec, point_segment, scale, sub, unit};

/// Nodes per tile side.
const TILE: i64 = 48;
/// Seed stream tags, so no two uses of the seed collide.
const TAG_CHART: u64 = 0xC4A7;
const TAG_TILE: u64 = 0x711E;
const TAG_SPHERE: u64 = 0x5F4E;

/// Disturbances and placement, shared by both samplers (lengths in model units).
#[derive(Debug, Clone)]
pub struct Settings {
    pub h: f64,
    pub jitter: f64,
    pub seed: u64,
    pub noise_sigma: f64,
    pub edge_sigma: f64,
    pub band: f64,
    pub outliers: f64,
    pub outlier_lo: V3,
    pub outlier_hi: V3,
    pub rotation: [V3; 3],
    pub translation: V3,
    /// Tolerance for "on the plane of a face" tests (model units).
    pub eps: f64,
}

impl Settings {
    #[inline]
    fn world(&self, p: V3) -> V3 {
        add(mat_vec(&self.rotation, p), self.translation)
    }

    /// Noise, outlier replacement and the world transform of a sample: `surface` is its place
    /// on the sharp part, `moved` on the rounded part. Returns the world position and whether
    /// it became an outlier.
    #[inline]
    fn finish(&self, rng: &mut SmallRng, moved: V3, in_band: bool) -> (V3, bool) {
        let sigma = if in_band {
            (self.noise_sigma * self.noise_sigma + self.edge_sigma * self.edge_sigma).sqrt()
        } else {
            self.noise_sigma
        };
        let mut p = moved;
        if sigma > 0.0 {
            p = axpy(p, sigma, gauss3(rng));
        }
        if self.outliers > 0.0 && rng.random::<f64>() < self.outliers {
            let u: [f64; 3] = [rng.random(), rng.random(), rng.random()];
            let q = [0, 1, 2]
                .map(|k| self.outlier_lo[k] + u[k] * (self.outlier_hi[k] - self.outlier_lo[k]));
            return (q, true);
        }
        (self.world(p), false)
    }
}

/// A chart's grid: in-plane axes (scaled by 1/h), origin and seed.
struct Frame {
    u: V3,
    v: V3,
    origin: V3,
    seed: u64,
}

impl Frame {
    fn new(model: &Model, chart: usize, s: &Settings) -> Frame {
        let c = &model.charts[chart];
        let seed = derive(s.seed, &[TAG_CHART, chart as u64]);
        let (a, b) = two_uniforms(mix(seed));
        let (off, _) = two_uniforms(mix(seed ^ 1));
        let n = c.normal;
        // Any unit vector perpendicular to n, then a random turn about n.
        let e = if n[0].abs() < 0.6 {
            [1.0, 0.0, 0.0]
        } else {
            [0.0, 1.0, 0.0]
        };
        let u0 = unit(cross(e, n)).unwrap_or([1.0, 0.0, 0.0]);
        let v0 = cross(n, u0);
        let (sn, cs) = (std::f64::consts::TAU * a).sin_cos();
        let u = add(scale(u0, cs), scale(v0, sn));
        let v = cross(n, u);
        // Offsetting the origin by a random fraction of a cell shifts the whole grid.
        let origin = sub(c.origin, add(scale(u, b * s.h), scale(v, off * s.h)));
        Frame {
            u: scale(u, 1.0 / s.h),
            v: scale(v, 1.0 / s.h),
            origin,
            seed,
        }
    }

    /// Grid coordinates of a model point.
    #[inline]
    fn grid(&self, p: V3) -> [f64; 2] {
        let d = sub(p, self.origin);
        [dot(d, self.u), dot(d, self.v)]
    }
}

/// One work unit: the nodes `[i0, i0 + TILE) × [j0, j0 + TILE)` of a chart's grid.
pub struct Tile {
    chart: u32,
    i0: i64,
    j0: i64,
    tris: Vec<u32>,
    pub count: usize,
    lo: V3,
    hi: V3,
}

/// Node range `[lo, hi]` (inclusive) whose jittered points can reach `[min, max]`.
fn node_range(min: f64, max: f64, half_jitter: f64) -> (i64, i64) {
    (
        (min - half_jitter).ceil() as i64,
        (max + half_jitter).floor() as i64,
    )
}

/// The tiles of every chart, in a fixed order.
pub fn tiles(model: &Model, s: &Settings) -> Vec<Tile> {
    let half = 0.5 * s.jitter;
    let per_chart: Vec<Vec<Tile>> = (0..model.charts.len())
        .into_par_iter()
        .map(|ci| {
            let frame = Frame::new(model, ci, s);
            let mut map: std::collections::BTreeMap<(i64, i64), Vec<u32>> = Default::default();
            for &t in &model.charts[ci].tris {
                let q = model.mesh.triangles[t as usize]
                    .map(|v| frame.grid(model.mesh.vertices[v as usize]));
                let (umin, umax) = (
                    q[0][0].min(q[1][0]).min(q[2][0]),
                    q[0][0].max(q[1][0]).max(q[2][0]),
                );
                let (vmin, vmax) = (
                    q[0][1].min(q[1][1]).min(q[2][1]),
                    q[0][1].max(q[1][1]).max(q[2][1]),
                );
                let (i0, i1) = node_range(umin, umax, half);
                let (j0, j1) = node_range(vmin, vmax, half);
                if i0 > i1 || j0 > j1 {
                    continue;
                }
                for tj in j0.div_euclid(TILE)..=j1.div_euclid(TILE) {
                    for ti in i0.div_euclid(TILE)..=i1.div_euclid(TILE) {
                        map.entry((tj, ti)).or_default().push(t);
                    }
                }
            }
            map.into_iter()
                .map(|((tj, ti), tris)| Tile {
                    chart: ci as u32,
                    i0: ti * TILE,
                    j0: tj * TILE,
                    tris,
                    count: 0,
                    lo: [f64::INFINITY; 3],
                    hi: [f64::NEG_INFINITY; 3],
                })
                .collect()
        })
        .collect();
    per_chart.into_iter().flatten().collect()
}

/// Calls `f(triangle, point on the sharp surface)` for every sample of the tile, in a fixed
/// order.
fn for_each_sample(
    model: &Model,
    s: &Settings,
    frame: &Frame,
    tile: &Tile,
    mut f: impl FnMut(u32, V3),
) {
    let half = 0.5 * s.jitter;
    for &t in &tile.tris {
        let ids = model.mesh.triangles[t as usize];
        let x = ids.map(|v| model.mesh.vertices[v as usize]);
        let q = x.map(|p| frame.grid(p));
        // Edge k is opposite vertex k; evaluate it from its lower to its higher vertex id.
        let mut base = [[0.0; 2]; 3];
        let mut dirv = [[0.0; 2]; 3];
        let mut sign = [0.0f64; 3];
        let mut degenerate = false;
        for k in 0..3 {
            let (a, b) = ((k + 1) % 3, (k + 2) % 3);
            let (lo, hi) = if ids[a] < ids[b] { (a, b) } else { (b, a) };
            base[k] = q[lo];
            dirv[k] = [q[hi][0] - q[lo][0], q[hi][1] - q[lo][1]];
            let e = dirv[k][0] * (q[k][1] - base[k][1]) - dirv[k][1] * (q[k][0] - base[k][0]);
            if e == 0.0 || !e.is_finite() {
                degenerate = true;
            }
            sign[k] = e.signum();
        }
        if degenerate {
            continue; // zero area in the plane: no samples
        }
        let umin = q[0][0].min(q[1][0]).min(q[2][0]);
        let umax = q[0][0].max(q[1][0]).max(q[2][0]);
        let vmin = q[0][1].min(q[1][1]).min(q[2][1]);
        let vmax = q[0][1].max(q[1][1]).max(q[2][1]);
        let (i0, i1) = node_range(umin, umax, half);
        let (j0, j1) = node_range(vmin, vmax, half);
        let (i0, i1) = (i0.max(tile.i0), i1.min(tile.i0 + TILE - 1));
        let (j0, j1) = (j0.max(tile.j0), j1.min(tile.j0 + TILE - 1));
        for j in j0..=j1 {
            for i in i0..=i1 {
                let node = (i as u32 as u64) | ((j as u32 as u64) << 32);
                let (ju, jv) = two_uniforms(mix(frame.seed ^ mix(node)));
                let p = [
                    i as f64 + s.jitter * (ju - 0.5),
                    j as f64 + s.jitter * (jv - 0.5),
                ];
                let mut w = [0.0; 3];
                let mut inside = true;
                for k in 0..3 {
                    let e = dirv[k][0] * (p[1] - base[k][1]) - dirv[k][1] * (p[0] - base[k][0]);
                    let se = sign[k] * e;
                    if se > 0.0 || (e == 0.0 && sign[k] > 0.0) {
                        w[k] = se;
                    } else {
                        inside = false;
                        break;
                    }
                }
                if !inside {
                    continue;
                }
                let sum = w[0] + w[1] + w[2];
                let pt =
                    [0, 1, 2].map(|c| (w[0] * x[0][c] + w[1] * x[1][c] + w[2] * x[2][c]) / sum);
                f(t, pt);
            }
        }
    }
}

/// First pass: the number of samples of each tile and their bounding box.
pub fn count(model: &Model, s: &Settings, tiles: &mut [Tile]) {
    tiles.par_iter_mut().for_each(|tile| {
        let frame = Frame::new(model, tile.chart as usize, s);
        let (mut n, mut lo, mut hi) = (0usize, [f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
        for_each_sample(model, s, &frame, tile, |_, p| {
            n += 1;
            for k in 0..3 {
                lo[k] = lo[k].min(p[k]);
                hi[k] = hi[k].max(p[k]);
            }
        });
        tile.count = n;
        tile.lo = lo;
        tile.hi = hi;
    });
}

/// Distance between two axis-aligned boxes (0 when they overlap).
fn box_box_distance(alo: V3, ahi: V3, blo: V3, bhi: V3) -> f64 {
    let d = [0, 1, 2].map(|k| (blo[k] - ahi[k]).max(alo[k] - bhi[k]).max(0.0));
    dot(d, d).sqrt()
}

/// The sharp edges that can matter to a point in the box `[lo, hi]`: every edge that might
/// be the nearest one, and every edge within `reach` (fillet or noise band).
fn candidate_edges(model: &Model, lo: V3, hi: V3, reach: f64, out: &mut Vec<u32>) {
    out.clear();
    if model.edges.is_empty() {
        return;
    }
    let centre = scale(add(lo, hi), 0.5);
    let half_diag = 0.5 * dist(lo, hi);
    // Any point of the box is within `upper` of the edge nearest to the centre.
    let upper = model
        .edges
        .iter()
        .map(|e| point_segment(centre, e.a, e.b).0)
        .fold(f64::INFINITY, f64::min)
        + half_diag;
    let limit = upper.max(reach);
    for (i, e) in model.edges.iter().enumerate() {
        let elo = [0, 1, 2].map(|k| e.a[k].min(e.b[k]));
        let ehi = [0, 1, 2].map(|k| e.a[k].max(e.b[k]));
        if box_box_distance(lo, hi, elo, ehi) <= limit {
            out.push(i as u32);
        }
    }
}

/// Which side (face) of edge `e` the sample `p` on a triangle with normal `n` lies on: its
/// normal must be the closer of the two, and `p` must lie in front of the edge and near that
/// face's plane. `None` when `p` is not on either face.
#[inline]
fn side_of(model: &Model, e: usize, p: V3, n: V3, eps: f64) -> Option<usize> {
    let edge = &model.edges[e];
    let k = if dot(n, edge.normals[0]) >= dot(n, edge.normals[1]) {
        0
    } else {
        1
    };
    let rel = sub(p, edge.a);
    let u = dot(rel, edge.inward[k]);
    let w = dot(rel, edge.normals[k]);
    (u >= -eps && w.abs() <= eps + 0.2 * u).then_some(k)
}

/// Second pass for one tile: writes its points and their truth.
fn fill_tile(
    model: &Model,
    fil: &Fillets,
    s: &Settings,
    tile: &Tile,
    out_pos: &mut [V3],
    out_truth: &mut [PointTruth],
    cands: &mut Vec<u32>,
) {
    let frame = Frame::new(model, tile.chart as usize, s);
    let reach = fil.reach.max(s.band);
    candidate_edges(model, tile.lo, tile.hi, reach, cands);
    let mut rng = SmallRng::seed_from_u64(derive(
        s.seed,
        &[TAG_TILE, tile.chart as u64, tile.i0 as u64, tile.j0 as u64],
    ));
    let mut idx = 0;
    let edge_band = s.edge_sigma > 0.0;
    for_each_sample(model, s, &frame, tile, |t, p| {
        let n = model.tri_normals[t as usize];
        let mut nearest = (f64::INFINITY, u32::MAX);
        let mut pick: Option<(f64, usize, usize)> = None;
        for &e in cands.iter() {
            let ed = &model.edges[e as usize];
            let (d, _) = point_segment(p, ed.a, ed.b);
            if d < nearest.0 {
                nearest = (d, e);
            }
            let fe = &fil.edges[e as usize];
            if d < fe.td && pick.is_none_or(|(bd, _, _)| d < bd) {
                if let Some(k) = side_of(model, e as usize, p, n, s.eps) {
                    pick = Some((d, e as usize, k));
                }
            }
        }
        let moved = pick.and_then(|(_, e, k)| round(model, fil, e, k, p));
        let in_band = edge_band && nearest.0 < s.band;
        let (world, outlier) = s.finish(&mut rng, moved.unwrap_or(p), in_band);
        out_pos[idx] = world;
        out_truth[idx] = PointTruth {
            surface: s.world(p),
            edge_distance: nearest.0,
            nearest_edge: nearest.1,
            face: tile.chart,
            abnormal: !outlier && (moved.is_some() || in_band),
            outlier,
        };
        idx += 1;
    });
    debug_assert_eq!(idx, out_pos.len());
}

/// Where the rounded part puts the sample `p` on side `k` of edge `e` (see fillet.rs), or
/// `None` if the rounding does not move it.
#[inline]
fn round(model: &Model, fil: &Fillets, e: usize, k: usize, p: V3) -> Option<V3> {
    let edge = &model.edges[e];
    let f = &fil.edges[e];
    let lambda = dot(sub(p, edge.a), f.dir);
    let onto = |c: V3| {
        let d = sub(p, c);
        let l = dot(d, d).sqrt();
        (l > 0.0).then(|| axpy(c, fil.r / l, d))
    };
    let end = if lambda < f.lo {
        Some(0)
    } else if lambda > f.hi {
        Some(1)
    } else {
        None
    };
    if let Some(end) = end {
        let kite = f.kites[end][k].as_ref()?;
        if dot(sub(p, kite.vertex), kite.dir_other) < kite.cut_other {
            return onto(kite.centre);
        }
        // Numerically outside the kite: the cylinder is the nearer surface.
    }
    onto(add(axpy(edge.a, lambda, f.dir), f.axis_off))
}

/// Samples the model into preallocated outputs; returns `(abnormal, outliers)` counts.
pub fn fill(
    model: &Model,
    fil: &Fillets,
    s: &Settings,
    tiles: &[Tile],
    positions: &mut [V3],
    truth: &mut [PointTruth],
) {
    let mut work = Vec::with_capacity(tiles.len());
    let (mut pos_rest, mut truth_rest) = (positions, truth);
    for tile in tiles {
        let (p, pr) = std::mem::take(&mut pos_rest).split_at_mut(tile.count);
        let (t, tr) = std::mem::take(&mut truth_rest).split_at_mut(tile.count);
        pos_rest = pr;
        truth_rest = tr;
        if tile.count > 0 {
            work.push((tile, p, t));
        }
    }
    work.into_par_iter()
        .for_each_init(Vec::new, |cands, (tile, p, t)| {
            fill_tile(model, fil, s, tile, p, t, cands);
        });
}

/// Points of a Fibonacci sphere lattice for pitch `h`: one per h², like the square grid.
/// (The lattice is less regular than a hexagonal one; at this density its mean
/// nearest-neighbour distance matches the square grid's within about 1 %.)
pub fn sphere_count(radius: f64, h: f64) -> usize {
    let area = 4.0 * std::f64::consts::PI * radius * radius;
    (area / (h * h)).round().max(1.0) as usize
}

/// Samples a sphere of `radius` centred on the model origin.
pub fn fill_sphere(radius: f64, s: &Settings, positions: &mut [V3], truth: &mut [PointTruth]) {
    const CHUNK: usize = 4096;
    let n = positions.len();
    let golden = std::f64::consts::PI * (3.0 - 5f64.sqrt());
    let phase = std::f64::consts::TAU * two_uniforms(derive(s.seed, &[TAG_SPHERE])).0;
    positions
        .par_chunks_mut(CHUNK)
        .zip(truth.par_chunks_mut(CHUNK))
        .enumerate()
        .for_each(|(c, (pos, tr))| {
            let mut rng = SmallRng::seed_from_u64(derive(s.seed, &[TAG_SPHERE, c as u64]));
            for (k, (po, t)) in pos.iter_mut().zip(tr.iter_mut()).enumerate() {
                let i = c * CHUNK + k;
                let z = 1.0 - (2.0 * i as f64 + 1.0) / n as f64;
                let rxy = (1.0 - z * z).max(0.0).sqrt();
                let (sn, cs) = (golden * i as f64 + phase).sin_cos();
                let dir = [rxy * cs, rxy * sn, z];
                // Tangential jitter, then back onto the sphere.
                let east = unit(cross([0.0, 0.0, 1.0], dir)).unwrap_or([1.0, 0.0, 0.0]);
                let north = cross(dir, east);
                let (ju, jv) = two_uniforms(mix(derive(s.seed, &[TAG_SPHERE, i as u64])));
                let jit = add(
                    scale(east, s.jitter * s.h * (ju - 0.5)),
                    scale(north, s.jitter * s.h * (jv - 0.5)),
                );
                let p = scale(unit(add(scale(dir, radius), jit)).unwrap_or(dir), radius);
                let (world, outlier) = s.finish(&mut rng, p, false);
                *po = world;
                *t = PointTruth {
                    surface: s.world(p),
                    edge_distance: f64::INFINITY,
                    nearest_edge: u32::MAX,
                    face: 0,
                    abnormal: false,
                    outlier,
                };
            }
        });
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn box_distances() {
        let (lo, hi) = ([0.0; 3], [1.0; 3]);
        assert_eq!(
            box_box_distance(lo, hi, [3.0, 0.0, 0.0], [4.0, 1.0, 1.0]),
            2.0
        );
        assert_eq!(box_box_distance(lo, hi, [0.5; 3], [4.0; 3]), 0.0);
    }

    #[test]
    fn node_range_includes_jitter_reach() {
        assert_eq!(node_range(0.2, 2.7, 0.15), (1, 2));
        assert_eq!(node_range(0.2, 2.7, 0.5), (0, 3));
        assert_eq!(node_range(-1.2, -0.1, 0.0), (-1, -1));
    }
}
