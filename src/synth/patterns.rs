//! The scan-line and structured-light patterns as [`Source`]s for the shared sampler.
//!
//! Input: the model, the resolved [`Lines`] or sensors (scanner.rs), the jitter and seeds.
//! Output: candidate samples (triangle, point on the sharp part, view, key) in a fixed order
//! per work unit; sample.rs keeps, rounds, disturbs and writes them.
//!
//! Lines. Work unit: one chart and a block of [`BLOCK`] consecutive cut planes. Each triangle
//! of the chart is cut by each plane of the block: its vertices' signed distances to the
//! plane split them into two sides (`>= 0` is one side, so a plane through a vertex is no
//! special case), the two edges that change side give the segment's ends. Along the line the
//! chart has one coordinate `s = x · l` (`l = n_chart × n_plane`, normalised), shared by all
//! its triangles, and samples sit at `s = (j + jitter (u − 1/2)) h` with `u` hashed from
//! (chart, plane, j); a triangle owns the samples in `[s_min, s_max)` of its segment, so
//! neighbouring triangles neither duplicate nor drop one. A sample is placed on the segment
//! by linear interpolation: on the plane to rounding error.
//!
//! Grid. Work unit: one view and a tile of [`PIXELS`]² pixels. Pixel (i, j) looks along
//! `f D + x r + y u` with `(x, y) = ((i, j) + jitter (u − 1/2)) · pitch` on the image plane at
//! the centre's distance `D`; its first hit on the mesh is the sample.

use super::features::Model;
use super::geom::{derive, mix, two_uniforms};
use super::raycast::Caster;
use super::sample::{Sample, Source, Work};
use super::scanner::{Camera, Lines, View};
use crate::geometry::{V3, add, axpy, cross, dot, norm, scale, sub, unit};

/// Cut planes per work unit of a line scan.
pub const BLOCK: i64 = 32;
/// Pixels per side of a grid scan's work unit.
pub const PIXELS: i64 = 64;
const TAG_LINE_UNIT: u64 = 0x114E_5017;
const TAG_LINE_CHART: u64 = 0x114E_C4A7;
const TAG_PIXEL_UNIT: u64 = 0x91CE_1017;

/// A line scan of the model.
pub struct LineScan<'a> {
    pub model: &'a Model,
    pub lines: Lines,
    pub h: f64,
    pub jitter: f64,
    pub seed: u64,
}

/// One chart's planes `k0..=k1` and the triangles they cut.
pub struct LineUnit {
    chart: u32,
    k0: i64,
    k1: i64,
    /// Along-line direction of the chart.
    l: V3,
    tris: Vec<u32>,
}

impl LineScan<'_> {
    /// Plane coordinate of `x`: plane k is where it equals k.
    #[inline]
    fn plane(&self, x: V3) -> f64 {
        (dot(x, self.lines.normal) - self.lines.offset) / self.lines.gap
    }

    /// The work units of every chart, in a fixed order. Charts parallel to the planes (their
    /// normal within 1e-9 of the planes') are cut by none.
    pub fn units(&self) -> Vec<Work<LineUnit>> {
        let model = self.model;
        let mut out = Vec::new();
        for (ci, chart) in model.charts.iter().enumerate() {
            let c = cross(chart.normal, self.lines.normal);
            let len = norm(c);
            if len.is_nan() || len < 1e-9 {
                continue;
            }
            let l = scale(c, 1.0 / len);
            let mut blocks: std::collections::BTreeMap<i64, Vec<u32>> = Default::default();
            for &t in &chart.tris {
                let c = model.mesh.triangles[t as usize]
                    .map(|v| self.plane(model.mesh.vertices[v as usize]));
                let (lo, hi) = (c[0].min(c[1]).min(c[2]), c[0].max(c[1]).max(c[2]));
                let (k0, k1) = (lo.ceil() as i64, hi.floor() as i64);
                if k0 > k1 {
                    continue;
                }
                for b in k0.div_euclid(BLOCK)..=k1.div_euclid(BLOCK) {
                    blocks.entry(b).or_default().push(t);
                }
            }
            out.extend(blocks.into_iter().map(|(b, tris)| {
                Work::new(LineUnit {
                    chart: ci as u32,
                    k0: b * BLOCK,
                    k1: b * BLOCK + BLOCK - 1,
                    l,
                    tris,
                })
            }));
        }
        out
    }
}

impl Source for LineScan<'_> {
    type Unit = LineUnit;

    fn seed(&self, u: &LineUnit) -> u64 {
        derive(self.seed, &[TAG_LINE_UNIT, u.chart as u64, u.k0 as u64])
    }

    fn for_each(&self, u: &LineUnit, f: &mut dyn FnMut(Sample)) {
        let model = self.model;
        let chart_seed = derive(self.seed, &[TAG_LINE_CHART, u.chart as u64]);
        let half = 0.5 * self.jitter;
        for &t in &u.tris {
            let x = model.mesh.triangles[t as usize].map(|v| model.mesh.vertices[v as usize]);
            let c = x.map(|p| self.plane(p));
            let (lo, hi) = (c[0].min(c[1]).min(c[2]), c[0].max(c[1]).max(c[2]));
            let (k0, k1) = ((lo.ceil() as i64).max(u.k0), (hi.floor() as i64).min(u.k1));
            for k in k0..=k1 {
                let s = c.map(|ci| ci - k as f64);
                // The two edges whose ends lie on different sides give the segment's ends.
                let mut ends = [[0.0; 3]; 2];
                let mut m = 0;
                for (i, j) in [(0, 1), (1, 2), (2, 0)] {
                    if (s[i] >= 0.0) != (s[j] >= 0.0) && m < 2 {
                        ends[m] = axpy(x[i], s[i] / (s[i] - s[j]), sub(x[j], x[i]));
                        m += 1;
                    }
                }
                if m < 2 {
                    continue;
                }
                let (mut a, mut b) = (ends[0], ends[1]);
                let (mut sa, mut sb) = (dot(a, u.l) / self.h, dot(b, u.l) / self.h);
                if sb < sa {
                    std::mem::swap(&mut a, &mut b);
                    std::mem::swap(&mut sa, &mut sb);
                }
                if (sb - sa).is_nan() || sb <= sa {
                    continue;
                }
                let line_key = mix(chart_seed ^ mix(k as u64));
                for j in (sa - half).ceil() as i64..=(sb + half).floor() as i64 {
                    let key = mix(line_key ^ mix(j as u64));
                    let sj = j as f64 + self.jitter * (two_uniforms(key).0 - 0.5);
                    if sj < sa || sj >= sb {
                        continue;
                    }
                    let p = axpy(a, (sj - sa) / (sb - sa), sub(b, a));
                    f(Sample {
                        tri: t,
                        p,
                        view: u32::MAX,
                        key,
                    });
                }
            }
        }
    }
}

/// A structured-light scan: one pixel grid per view.
pub struct GridScan<'a> {
    pub caster: &'a Caster<'a>,
    pub cams: Vec<(Camera, &'a View)>,
    /// Half-width of every view's image (model units, on the plane at the centre's distance).
    pub half_width: Vec<f64>,
    pub jitter: f64,
}

/// One view's pixels `[i0, i0 + PIXELS) × [j0, j0 + PIXELS)`.
pub struct PixelTile {
    view: u32,
    i0: i64,
    j0: i64,
    n: i64,
}

impl GridScan<'_> {
    /// Pixels per view: `2 n + 1` per side with pixel centres from `-n` to `n`.
    fn half_count(&self, v: usize) -> i64 {
        (self.half_width[v] / self.cams[v].1.pitch).ceil() as i64 + 1
    }

    /// The number of rays the scan casts.
    pub fn rays(&self) -> f64 {
        (0..self.cams.len())
            .map(|v| (2 * self.half_count(v) + 1) as f64)
            .map(|s| s * s)
            .sum()
    }

    pub fn units(&self) -> Vec<Work<PixelTile>> {
        let mut out = Vec::new();
        for v in 0..self.cams.len() {
            let n = self.half_count(v);
            let (b0, b1) = ((-n).div_euclid(PIXELS), n.div_euclid(PIXELS));
            for tj in b0..=b1 {
                for ti in b0..=b1 {
                    out.push(Work::new(PixelTile {
                        view: v as u32,
                        i0: ti * PIXELS,
                        j0: tj * PIXELS,
                        n,
                    }));
                }
            }
        }
        out
    }
}

impl Source for GridScan<'_> {
    type Unit = PixelTile;

    fn seed(&self, u: &PixelTile) -> u64 {
        let view = self.cams[u.view as usize].1;
        derive(view.seed, &[TAG_PIXEL_UNIT, u.i0 as u64, u.j0 as u64])
    }

    fn for_each(&self, u: &PixelTile, f: &mut dyn FnMut(Sample)) {
        let (cam, view) = self.cams[u.view as usize];
        let view_key = derive(view.seed, &[TAG_PIXEL_UNIT]);
        let (i0, i1) = (u.i0.max(-u.n), (u.i0 + PIXELS - 1).min(u.n));
        let (j0, j1) = (u.j0.max(-u.n), (u.j0 + PIXELS - 1).min(u.n));
        for j in j0..=j1 {
            for i in i0..=i1 {
                let key = mix(view_key ^ mix((i as u32 as u64) | ((j as u32 as u64) << 32)));
                let (ju, jv) = two_uniforms(key);
                let x = (i as f64 + self.jitter * (ju - 0.5)) * view.pitch;
                let y = (j as f64 + self.jitter * (jv - 0.5)) * view.pitch;
                let Some(d) = unit(add(
                    scale(cam.f, cam.dist),
                    add(scale(cam.r, x), scale(cam.u, y)),
                )) else {
                    continue;
                };
                if let Some(hit) = self.caster.first_hit(cam.sensor, d, f64::INFINITY) {
                    f(Sample {
                        tri: hit.tri,
                        p: hit.point,
                        view: u.view,
                        key,
                    });
                }
            }
        }
    }
}
