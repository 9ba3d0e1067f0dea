//! Edge fit (the paper's 2D case, per edge, in parallel): slabs across each edge run → a
//! constrained line–line fit per slab → rectified edge points → the edge as a 3D line, or a
//! polyline for a gently curving edge.
//!
//! Inputs: positions, the outlier mask, a `Grid`, the `Segments` (runs and vertices), `Scale`,
//! `EdgeParams`, the fit's `FitParams`, the run's seed. Output: one `EdgeFit` per run (or the
//! reason it failed, which the pipeline counts and reports).
//!
//! Per slab, the points within the band around the run's centre line, seen along the local
//! edge direction, form a 2D profile: two face traces meeting at the edge, with the rounded
//! or noisy abnormal zone in between (the paper's Figure 1). `fit::fit_profile_2d` propagates
//! from both far ends to find the sides and the abnormal zone (C..D), fits the local lines L2
//! and L4, and searches the constrained corner with the particle swarm (Scheme 1 and the exact
//! optimum beside it). That corner, lifted back to 3D at the slab's position along the edge,
//! is a *rectified edge point*: it lies on the sharp edge the raw points miss. Slabs are kept
//! clear of vertices, where a third face enters the band; the corner stage covers those.

use rand::SeedableRng;
use rand::rngs::SmallRng;
use rayon::prelude::*;

use crate::features::Scale;
use crate::fit::{FitParams, ProfileFit, ProfileScratch, fit_profile_2d_with};
use crate::neighbours::Grid;
use crate::segment::{Run, Segments, add, dot, norm, pca_line, sub};

/// Settings of the edge stage (validated by `config`).
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct EdgeParams {
    /// Half-width of the band of points around an edge that forms its profiles, in
    /// neighbourhood radii: it must reach well past the abnormal zone onto both faces.
    pub band: f64,
    /// Target number of points per slab (the slab's thickness follows the band's density).
    pub slab_points: usize,
    /// Slabs stay this many neighbourhood radii away from a vertex.
    pub vertex_margin: f64,
    /// An edge whose rectified points stay within this many spacings (RMS) of one line is
    /// reported as a straight line; otherwise as a polyline.
    pub straight_tolerance: f64,
}

impl Default for EdgeParams {
    fn default() -> Self {
        EdgeParams {
            band: 3.0,
            slab_points: 80,
            vertex_margin: 1.5,
            straight_tolerance: 0.3,
        }
    }
}

/// One slab's fit.
#[derive(Debug, Clone)]
pub struct SlabFit {
    /// Position of the slab's centre along the run's line (`Run::origin`, `Run::direction`).
    pub t: f64,
    /// The slab's local edge direction (unit).
    pub tangent: [f64; 3],
    /// The constrained corner found by PSO, in 3D: a rectified edge point.
    pub corner: [f64; 3],
    /// The same by Scheme 1 and exactly.
    pub corner_scheme1: [f64; 3],
    pub corner_exact: [f64; 3],
    /// The two face traces (unit 3D directions perpendicular to `tangent`, pointing away
    /// from the edge): the slopes of the local fits L2 and L4.
    pub faces: [[f64; 3]; 2],
    /// Errors (sum of point-to-line distances) of Scheme 1, PSO and exact.
    pub errors: [f64; 3],
    /// Point ids of the abnormal zone (between C and D): the points to rectify.
    pub abnormal: Vec<u32>,
    /// Largest distance of an abnormal point from the corner (the zone's half-width).
    pub abnormal_reach: f64,
    /// Points in the slab's profile.
    pub points: usize,
}

/// The fitted edge of one run.
#[derive(Debug, Clone)]
pub struct EdgeFit {
    /// The run this edge comes from.
    pub run: usize,
    pub slabs: Vec<SlabFit>,
    /// Best line through the rectified edge points (point, unit direction).
    pub line: ([f64; 3], [f64; 3]),
    /// RMS distance of the rectified edge points to `line`.
    pub rms: f64,
    /// Straight (a line) or gently curving (a polyline through the smoothed rectified points).
    pub straight: bool,
    /// Interior angle between the two faces, in degrees (median over slabs).
    pub dihedral_deg: f64,
    /// Slab fits that failed (count) with the first reason.
    pub failed_slabs: usize,
    pub first_failure: Option<String>,
}

/// Fits every run's edge in parallel. Each run gets its own RNG from (seed, run id), so the
/// result does not depend on the thread count.
pub fn fit_edges(
    positions: &[[f64; 3]],
    outlier: &[bool],
    grid: &Grid,
    segments: &Segments,
    scale: &Scale,
    params: &EdgeParams,
    fit: &FitParams,
    seed: u64,
) -> Vec<Result<EdgeFit, String>> {
    let mut fit = fit.clone();
    // The profile fit estimates the noise itself unless told; the cloud's measured sigma is a
    // better estimate than one slab's.
    if fit.propagation.noise.is_none() && scale.noise > 0.0 {
        fit.propagation.noise = Some(scale.noise.max(1e-3 * scale.spacing));
    }
    (0..segments.runs.len())
        .into_par_iter()
        .map_init(
            || (ProfileScratch::default(), ProfileFit::default()),
            |(scratch, out), k| {
                let mut rng =
                    SmallRng::seed_from_u64(seed ^ (k as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15));
                fit_run(
                    positions, outlier, grid, segments, k, scale, params, &fit, &mut rng, scratch,
                    out,
                )
            },
        )
        .collect()
}

#[allow(clippy::too_many_arguments)]
fn fit_run(
    positions: &[[f64; 3]],
    outlier: &[bool],
    grid: &Grid,
    segments: &Segments,
    k: usize,
    scale: &Scale,
    params: &EdgeParams,
    fit: &FitParams,
    rng: &mut SmallRng,
    scratch: &mut ProfileScratch,
    out: &mut ProfileFit,
) -> Result<EdgeFit, String> {
    let run = &segments.runs[k];
    let r = scale.radius;
    let band = params.band * r;
    // The usable stretch of the run: its extent, pulled back from vertices.
    let mut t0 = run.t_range[0];
    let mut t1 = run.t_range[1];
    for (e, t) in [(0, &mut t0), (1, &mut t1)] {
        if let Some(v) = run.vertices[e] {
            let tv = dot(
                sub(segments.vertices[v].position, run.origin),
                run.direction,
            );
            let margin = params.vertex_margin * r;
            *t = if e == 0 { tv + margin } else { tv - margin };
        }
    }
    if t1 - t0 < r {
        return Err(format!(
            "edge {k}: too short between its vertices ({:.3})",
            t1 - t0
        ));
    }
    let centre = Centreline::new(run);
    // Band points: within `band` of the centre line, inside the usable stretch.
    let mut ids: Vec<u32> = Vec::new();
    for w in centre.points.windows(2) {
        grid.for_each_near_segment(w[0], w[1], band, |i| ids.push(i));
    }
    if centre.points.len() == 1 {
        grid.for_each_near_segment(centre.points[0], centre.points[0], band, |i| ids.push(i));
    }
    ids.sort_unstable();
    ids.dedup();
    let mut band_pts: Vec<(f64, u32)> = ids
        .into_iter()
        .filter(|&i| !outlier[i as usize])
        .map(|i| {
            (
                dot(sub(positions[i as usize], run.origin), run.direction),
                i,
            )
        })
        .filter(|&(t, _)| t >= t0 && t <= t1)
        .collect();
    band_pts.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
    if band_pts.len() < 2 * params.slab_points.min(20) {
        return Err(format!(
            "edge {k}: only {} points in its band",
            band_pts.len()
        ));
    }
    // Slabs of equal thickness, about `slab_points` points each.
    let density = band_pts.len() as f64 / (t1 - t0);
    let thickness = (params.slab_points as f64 / density)
        .max(0.5 * scale.spacing)
        .min(t1 - t0);
    let nslab = ((t1 - t0) / thickness).floor().max(1.0) as usize;
    let thickness = (t1 - t0) / nslab as f64;
    let mut slabs = Vec::with_capacity(nslab);
    let mut failed = 0usize;
    let mut first_failure = None;
    let mut start = 0usize;
    let mut profile: Vec<[f64; 2]> = Vec::new();
    let mut members: Vec<u32> = Vec::new();
    for s in 0..nslab {
        let (ta, tb) = (t0 + s as f64 * thickness, t0 + (s + 1) as f64 * thickness);
        let end = start
            + band_pts[start..].partition_point(|p| p.0 < tb || (s + 1 == nslab && p.0 <= tb));
        let slab = &band_pts[start..end];
        start = end;
        let tc = 0.5 * (ta + tb);
        let (c, tangent) = centre.at(tc);
        let (e1, e2) = perpendicular_basis(tangent);
        profile.clear();
        members.clear();
        for &(_, i) in slab {
            let v = sub(positions[i as usize], c);
            profile.push([dot(v, e1), dot(v, e2)]);
            members.push(i);
        }
        let res = fit_profile_2d_with(&profile, [0.0, 0.0], fit, rng, scratch, out);
        if let Ok(spec) = std::env::var("SHARPEDGE_DUMP") {
            if spec == format!("{k},{s}") {
                let j = serde_json::json!({"profile": profile, "ok": res.is_ok(), "sides": out.sides, "corner_region": out.corner_region, "local": [[out.local[0].point, out.local[0].direction],[out.local[1].point, out.local[1].direction]], "pso": out.pso.point, "exact": out.exact.point, "scheme1": out.scheme1.point, "errors": [out.scheme1.error, out.pso.error, out.exact.error], "noise": out.noise, "c": out.c, "d": out.d, "e1": e1, "e2": e2, "c3": c});
                let _ = std::fs::write("/tmp/slab.json", j.to_string());
            }
        }
        match res {
            Ok(()) => {
                let lift = |q: [f64; 2]| add(c, add(e1.map(|x| x * q[0]), e2.map(|x| x * q[1])));
                let faces = [0, 1].map(|j| {
                    let d = out.local[j].direction;
                    let f = add(e1.map(|x| x * d[0]), e2.map(|x| x * d[1]));
                    f.map(|x| x / norm(f))
                });
                let pso = out.pso.point;
                let abnormal_reach = out
                    .corner_region
                    .iter()
                    .map(|&j| {
                        ((profile[j][0] - pso[0]).powi(2) + (profile[j][1] - pso[1]).powi(2)).sqrt()
                    })
                    .fold(0.0, f64::max);
                slabs.push(SlabFit {
                    t: tc,
                    tangent,
                    corner: lift(pso),
                    corner_scheme1: lift(out.scheme1.point),
                    corner_exact: lift(out.exact.point),
                    faces,
                    errors: [out.scheme1.error, out.pso.error, out.exact.error],
                    abnormal: out.corner_region.iter().map(|&j| members[j]).collect(),
                    abnormal_reach,
                    points: profile.len(),
                });
            }
            Err(e) => {
                failed += 1;
                first_failure.get_or_insert_with(|| format!("edge {k} slab at t = {tc:.4}: {e}"));
            }
        }
    }
    if slabs.len() < 2 {
        return Err(
            first_failure.unwrap_or_else(|| format!("edge {k}: fewer than two slabs fitted"))
        );
    }
    let rectified: Vec<[f64; 3]> = slabs.iter().map(|s| s.corner).collect();
    let all: Vec<usize> = (0..rectified.len()).collect();
    let line =
        pca_line(&rectified, &all).ok_or_else(|| format!("edge {k}: rectified points coincide"))?;
    let line = (
        line.0,
        if dot(line.1, run.direction) < 0.0 {
            line.1.map(|x| -x)
        } else {
            line.1
        },
    );
    let rms = (rectified
        .iter()
        .map(|p| point_line_distance(*p, line).powi(2))
        .sum::<f64>()
        / rectified.len() as f64)
        .sqrt();
    let mut angles: Vec<f64> = slabs
        .iter()
        .map(|s| {
            dot(s.faces[0], s.faces[1])
                .clamp(-1.0, 1.0)
                .acos()
                .to_degrees()
        })
        .collect();
    let mid = angles.len() / 2;
    let dihedral_deg = *angles.select_nth_unstable_by(mid, f64::total_cmp).1;
    Ok(EdgeFit {
        run: k,
        straight: rms <= params.straight_tolerance * scale.spacing,
        slabs,
        line,
        rms,
        dihedral_deg,
        failed_slabs: failed,
        first_failure,
    })
}

/// Distance from `p` to the line (point, unit direction).
pub fn point_line_distance(p: [f64; 3], line: ([f64; 3], [f64; 3])) -> f64 {
    let v = sub(p, line.0);
    let t = dot(v, line.1);
    norm(sub(v, line.1.map(|x| x * t)))
}

/// Two unit vectors completing `d` (unit) to a right-handed orthonormal frame. Built from the
/// axis least aligned with `d`, so it is well conditioned for every direction.
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

/// A run's centre line as a function of the run's line parameter t: position and local
/// tangent, for gently curving runs as well as straight ones.
struct Centreline {
    points: Vec<[f64; 3]>,
    ts: Vec<f64>,
    origin: [f64; 3],
    direction: [f64; 3],
}

impl Centreline {
    fn new(run: &Run) -> Self {
        let mut points = run.centreline.clone();
        if points.is_empty() {
            points.push(run.origin);
        }
        let ts = points
            .iter()
            .map(|p| dot(sub(*p, run.origin), run.direction))
            .collect();
        Centreline {
            points,
            ts,
            origin: run.origin,
            direction: run.direction,
        }
    }

    /// Position (interpolated) and tangent (from the centre-line points within two windows)
    /// at parameter t; straight beyond the ends.
    fn at(&self, t: f64) -> ([f64; 3], [f64; 3]) {
        if self.points.len() < 3 {
            return (
                add(self.origin, self.direction.map(|x| x * t)),
                self.direction,
            );
        }
        let j = self
            .ts
            .partition_point(|&x| x < t)
            .clamp(1, self.ts.len() - 1);
        let (ta, tb) = (self.ts[j - 1], self.ts[j]);
        let u = if tb > ta {
            ((t - ta) / (tb - ta)).clamp(0.0, 1.0)
        } else {
            0.0
        };
        let (a, b) = (self.points[j - 1], self.points[j]);
        let mut p = add(a, sub(b, a).map(|x| x * u));
        if t < self.ts[0] || t > self.ts[self.ts.len() - 1] {
            // Beyond the end samples: continue along the run's line from the nearest sample.
            let (e, te) = if t < self.ts[0] {
                (self.points[0], self.ts[0])
            } else {
                (
                    self.points[self.points.len() - 1],
                    self.ts[self.ts.len() - 1],
                )
            };
            p = add(e, self.direction.map(|x| x * (t - te)));
        }
        let lo = j.saturating_sub(3);
        let hi = (j + 3).min(self.points.len());
        let ids: Vec<usize> = (lo..hi).collect();
        let tangent = match pca_line(&self.points, &ids) {
            Some((_, d)) if ids.len() >= 3 => {
                if dot(d, self.direction) < 0.0 {
                    d.map(|x| -x)
                } else {
                    d
                }
            }
            _ => self.direction,
        };
        (p, tangent)
    }
}
