//! Scanner-like sampling of a [`Model`] (or of a sphere) with rounding, noise and outliers.
//!
//! Input: the model, its fillets, the sampling pitch `h`, the disturbance parameters and the
//! resolved scanner (scanner.rs).
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
//! Work units. Every pattern is a [`Source`] of work units that lists its candidate samples in
//! a fixed order; the uniform grid of every chart is cut into tiles of `TILE × TILE` nodes
//! (the other patterns' units are in patterns.rs). [`Keep`] decides which candidates become
//! points (the density gradient's hashed draw; for one-view scans the face must turn towards
//! the sensor and the line of sight must be free, raycast.rs). A first parallel pass counts
//! each unit's points (and their bounding box), a prefix sum gives every unit its slice of
//! the output, and a second parallel pass fills the slices. Each unit draws noise and
//! outliers from its own RNG seeded from (seed, chart, tile) or the pattern's equivalent, so
//! the output is the same for any number of threads, and nothing is allocated per point.
//! Every candidate then goes through the same finishing step (nearest edge, rounding, band
//! noise, noise, outliers, misregistration, world transform).
//!
//! Sphere. A Fibonacci lattice (golden-angle spiral) with a tangential jitter, projected back
//! onto the sphere, one point per h² of area.

use rand::rngs::SmallRng;
use rand::{RngExt, SeedableRng};
use rayon::prelude::*;

use super::PointTruth;
use super::features::Model;
use super::fillet::Fillets;
use super::geom::{derive, gauss2, gauss3, mix, two_uniforms};
use super::raycast::Caster;
use super::scanner::{Density, Scanner};
use crate::geometry::{
    V3, add, axpy, cross, dist, dot, mat_vec, plane_axes, point_segment, scale, sub, unit,
};

/// Nodes per tile side.
const TILE: i64 = 48;
/// Seed stream tags, so no two uses of the seed collide.
const TAG_CHART: u64 = 0xC4A7;
const TAG_TILE: u64 = 0x711E;
const TAG_SPHERE: u64 = 0x5F4E;
const TAG_KEEP: u64 = 0x6B_EE_70;

/// The noise factor at incidence angle θ (between the surface normal and the ray):
/// `1 / cos θ`, at most `cap` (grazing rays, θ near 90°, would make it infinite).
#[inline]
pub fn incidence_factor(normal: V3, ray: V3, cap: f64) -> f64 {
    let c = dot(normal, ray).abs();
    if c * cap > 1.0 { 1.0 / c } else { cap }
}

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
    /// The pattern's sensors, density gradient and noise model (all off for the plain
    /// uniform scan).
    pub scanner: Scanner,
}

impl Settings {
    #[inline]
    pub(super) fn world(&self, p: V3) -> V3 {
        add(mat_vec(&self.rotation, p), self.translation)
    }

    /// Noise, outlier replacement and the world transform of a sample: `moved` is its place
    /// on the rounded part, `normal` the normal of its triangle, `view` the view it came from
    /// (`u32::MAX`: none). The noise sigma grows with the incidence angle when the scanner
    /// says so, and lies along the sensor's ray for depth sensors; a view's misregistration
    /// moves the point last. Returns the world position, whether it became an outlier and the
    /// sigma its noise was drawn with (0 for an outlier).
    #[inline]
    fn finish(
        &self,
        rng: &mut SmallRng,
        moved: V3,
        in_band: bool,
        normal: V3,
        view: u32,
    ) -> (V3, bool, f64) {
        let mut sigma = if in_band {
            (self.noise_sigma * self.noise_sigma + self.edge_sigma * self.edge_sigma).sqrt()
        } else {
            self.noise_sigma
        };
        let sensor = self.scanner.sensor_for(view);
        let ray = sensor.and_then(|v| unit(sub(moved, v.sensor)));
        if let (Some(cap), Some(ray)) = (self.scanner.incidence_cap, ray) {
            sigma *= incidence_factor(normal, ray, cap);
        }
        let mut p = moved;
        if sigma > 0.0 {
            p = match ray.filter(|_| self.scanner.along_ray) {
                Some(ray) => axpy(p, sigma * gauss2(rng).0, ray),
                None => axpy(p, sigma, gauss3(rng)),
            };
        }
        if self.outliers > 0.0 && rng.random::<f64>() < self.outliers {
            let u: [f64; 3] = [rng.random(), rng.random(), rng.random()];
            let q = [0, 1, 2]
                .map(|k| self.outlier_lo[k] + u[k] * (self.outlier_hi[k] - self.outlier_lo[k]));
            return (q, true, 0.0);
        }
        if let Some(m) = self
            .scanner
            .views
            .get(view as usize)
            .and_then(|v| v.motion.as_ref())
        {
            p = m.apply(p);
        }
        (self.world(p), false, sigma)
    }
}

/// One sample a pattern hands to the shared finishing step: its triangle, its place on the
/// sharp part (model coordinates), the view it came from (`u32::MAX`: none) and a 64-bit key
/// fixed by where it is on the pattern (not by the work unit or thread), from which the
/// density gradient's keep-or-drop draw is made.
#[derive(Debug, Clone, Copy)]
pub struct Sample {
    pub tri: u32,
    pub p: V3,
    pub view: u32,
    pub key: u64,
}

/// A sampling pattern cut into work units. `for_each` must call `f` for the unit's candidate
/// samples in a fixed order (the same in the counting and the filling pass); `seed` seeds the
/// unit's noise RNG.
pub trait Source: Sync {
    type Unit: Send + Sync;
    fn for_each(&self, unit: &Self::Unit, f: &mut dyn FnMut(Sample));
    fn seed(&self, unit: &Self::Unit) -> u64;
}

/// A work unit with what the counting pass learnt about it.
pub struct Work<U> {
    pub unit: U,
    pub count: usize,
    lo: V3,
    hi: V3,
}

impl<U> Work<U> {
    pub fn new(unit: U) -> Self {
        Work {
            unit,
            count: 0,
            lo: [f64::INFINITY; 3],
            hi: [f64::NEG_INFINITY; 3],
        }
    }
}

/// Which candidate samples become points: the density gradient's draw and, for the
/// one-view pattern, the sensor's line of sight.
pub struct Keep<'a> {
    pub density: Option<&'a Density>,
    /// For one-view scans: the ray caster and the tolerance of the visibility test.
    pub sight: Option<(&'a Caster<'a>, f64)>,
    pub model: &'a Model,
    pub scanner: &'a Scanner,
}

impl Keep<'_> {
    fn keeps(&self, smp: &Sample) -> bool {
        if let Some(d) = self.density
            && two_uniforms(mix(smp.key ^ TAG_KEEP)).0 >= d.keep(smp.p)
        {
            return false;
        }
        if let Some((caster, tol)) = self.sight {
            let Some(view) = self.scanner.sensor_for(smp.view) else {
                return true;
            };
            let n = self.model.tri_normals[smp.tri as usize];
            if dot(n, sub(view.sensor, smp.p)) <= 0.0 {
                return false; // the face is turned away from the sensor
            }
            return caster.visible(view.sensor, smp.p, tol);
        }
        true
    }
}

/// First pass: the number of kept samples of each unit and their bounding box.
pub fn count<S: Source>(src: &S, keep: &Keep, work: &mut [Work<S::Unit>]) {
    work.par_iter_mut().for_each(|w| {
        let (mut n, mut lo, mut hi) = (0usize, [f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
        src.for_each(&w.unit, &mut |smp| {
            if keep.keeps(&smp) {
                n += 1;
                for k in 0..3 {
                    lo[k] = lo[k].min(smp.p[k]);
                    hi[k] = hi[k].max(smp.p[k]);
                }
            }
        });
        w.count = n;
        w.lo = lo;
        w.hi = hi;
    });
}

/// Second pass: every unit fills its slice of the preallocated outputs (the slices follow
/// the units' order, so the output does not depend on the thread count).
pub fn fill<S: Source>(
    src: &S,
    keep: &Keep,
    fil: &Fillets,
    s: &Settings,
    work: &[Work<S::Unit>],
    positions: &mut [V3],
    truth: &mut [PointTruth],
) {
    let model = keep.model;
    let mut jobs = Vec::with_capacity(work.len());
    let (mut pos_rest, mut truth_rest) = (positions, truth);
    for w in work {
        let (p, pr) = std::mem::take(&mut pos_rest).split_at_mut(w.count);
        let (t, tr) = std::mem::take(&mut truth_rest).split_at_mut(w.count);
        pos_rest = pr;
        truth_rest = tr;
        if w.count > 0 {
            jobs.push((w, p, t));
        }
    }
    jobs.into_par_iter()
        .for_each_init(Vec::new, |cands, (w, out_pos, out_truth)| {
            let reach = fil.reach.max(s.band);
            candidate_edges(model, w.lo, w.hi, reach, cands);
            let mut rng = SmallRng::seed_from_u64(src.seed(&w.unit));
            let mut idx = 0;
            src.for_each(&w.unit, &mut |smp| {
                if !keep.keeps(&smp) {
                    return;
                }
                let (pos, t) = finish_sample(model, fil, s, cands, &mut rng, smp);
                out_pos[idx] = pos;
                out_truth[idx] = t;
                idx += 1;
            });
            debug_assert_eq!(idx, out_pos.len());
        });
}

/// A chart's grid: in-plane axes (scaled by 1/h), origin and seed.
struct Frame {
    u: V3,
    v: V3,
    origin: V3,
    seed: u64,
}

impl Frame {
    fn new(model: &Model, chart: usize, h: f64, seed: u64) -> Frame {
        let c = &model.charts[chart];
        let seed = derive(seed, &[TAG_CHART, chart as u64]);
        let (a, b) = two_uniforms(mix(seed));
        let (off, _) = two_uniforms(mix(seed ^ 1));
        let n = c.normal;
        let (u0, v0) = plane_axes(n);
        let (sn, cs) = (std::f64::consts::TAU * a).sin_cos();
        let u = add(scale(u0, cs), scale(v0, sn));
        let v = cross(n, u);
        // Offsetting the origin by a random fraction of a cell shifts the whole grid.
        let origin = sub(c.origin, add(scale(u, b * h), scale(v, off * h)));
        Frame {
            u: scale(u, 1.0 / h),
            v: scale(v, 1.0 / h),
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

/// One work unit of the uniform pattern: the nodes `[i0, i0 + TILE) × [j0, j0 + TILE)` of a
/// chart's grid, for one grid (one view of a multi-view scan; grid 0 otherwise).
pub struct Tile {
    grid: u32,
    chart: u32,
    i0: i64,
    j0: i64,
    tris: Vec<u32>,
}

/// The uniform pattern: a jittered square grid per chart, one set of grids per view (pitch
/// and seed of each in `grids`; the plain scan has one, with the scan's own seed).
pub struct Uniform<'a> {
    pub model: &'a Model,
    pub jitter: f64,
    pub grids: Vec<(f64, u64)>,
    /// Whether grid `g` is view `g` (one-view and multi-view scans) or no view at all.
    pub views: bool,
}

/// Node range `[lo, hi]` (inclusive) whose jittered points can reach `[min, max]`.
fn node_range(min: f64, max: f64, half_jitter: f64) -> (i64, i64) {
    (
        (min - half_jitter).ceil() as i64,
        (max + half_jitter).floor() as i64,
    )
}

impl Uniform<'_> {
    /// The tiles of every chart of every grid, in a fixed order.
    pub fn tiles(&self) -> Vec<Work<Tile>> {
        let model = self.model;
        let half = 0.5 * self.jitter;
        let jobs: Vec<(usize, usize)> = (0..self.grids.len())
            .flat_map(|g| (0..model.charts.len()).map(move |c| (g, c)))
            .collect();
        let per_chart: Vec<Vec<Work<Tile>>> = jobs
            .into_par_iter()
            .map(|(g, ci)| {
                let (h, seed) = self.grids[g];
                let frame = Frame::new(model, ci, h, seed);
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
                    .map(|((tj, ti), tris)| {
                        Work::new(Tile {
                            grid: g as u32,
                            chart: ci as u32,
                            i0: ti * TILE,
                            j0: tj * TILE,
                            tris,
                        })
                    })
                    .collect()
            })
            .collect();
        per_chart.into_iter().flatten().collect()
    }
}

impl Source for Uniform<'_> {
    type Unit = Tile;

    fn seed(&self, tile: &Tile) -> u64 {
        let (_, seed) = self.grids[tile.grid as usize];
        derive(
            seed,
            &[TAG_TILE, tile.chart as u64, tile.i0 as u64, tile.j0 as u64],
        )
    }

    /// Every jittered node of the tile that falls inside one of its triangles, placed on the
    /// 3D triangle by its barycentric coordinates.
    fn for_each(&self, tile: &Tile, f: &mut dyn FnMut(Sample)) {
        let model = self.model;
        let (h, seed) = self.grids[tile.grid as usize];
        let frame = Frame::new(model, tile.chart as usize, h, seed);
        let view = if self.views { tile.grid } else { u32::MAX };
        let half = 0.5 * self.jitter;
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
                    let key = mix(frame.seed ^ mix(node));
                    let (ju, jv) = two_uniforms(key);
                    let p = [
                        i as f64 + self.jitter * (ju - 0.5),
                        j as f64 + self.jitter * (jv - 0.5),
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
                    f(Sample {
                        tri: t,
                        p: pt,
                        view,
                        key,
                    });
                }
            }
        }
    }
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

/// What every pattern does to a sample: its nearest sharp edge, the rounding, the extra noise
/// near edges, the noise, outliers and the world transform. Returns the point and its truth.
#[inline]
fn finish_sample(
    model: &Model,
    fil: &Fillets,
    s: &Settings,
    cands: &[u32],
    rng: &mut SmallRng,
    smp: Sample,
) -> (V3, PointTruth) {
    let Sample {
        tri: t, p, view, ..
    } = smp;
    let n = model.tri_normals[t as usize];
    let mut nearest = (f64::INFINITY, u32::MAX);
    let mut pick: Option<(f64, usize, usize)> = None;
    for &e in cands {
        let ed = &model.edges[e as usize];
        let (d, _) = point_segment(p, ed.a, ed.b);
        if d < nearest.0 {
            nearest = (d, e);
        }
        let fe = &fil.edges[e as usize];
        if d < fe.td
            && pick.is_none_or(|(bd, _, _)| d < bd)
            && let Some(k) = side_of(model, e as usize, p, n, s.eps)
        {
            pick = Some((d, e as usize, k));
        }
    }
    let moved = pick.and_then(|(_, e, k)| round(model, fil, e, k, p));
    let in_band = s.edge_sigma > 0.0 && nearest.0 < s.band;
    let (world, outlier, noise) = s.finish(rng, moved.unwrap_or(p), in_band, n, view);
    let truth = PointTruth {
        surface: s.world(p),
        edge_distance: nearest.0,
        nearest_edge: nearest.1,
        face: model.tri_chart[t as usize],
        abnormal: !outlier && (moved.is_some() || in_band),
        outlier,
        view,
        noise,
    };
    (world, truth)
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
                let (world, outlier, noise) = s.finish(&mut rng, p, false, dir, u32::MAX);
                *po = world;
                *t = PointTruth {
                    surface: s.world(p),
                    edge_distance: f64::INFINITY,
                    nearest_edge: u32::MAX,
                    face: 0,
                    abnormal: false,
                    outlier,
                    view: u32::MAX,
                    noise,
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
