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
use crate::fit::{FitParams, ProfileFit, ProfileKnown, ProfileScratch, fit_profile_2d_zone};
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
    /// Half-width of the abnormal zone measured from the pooled residuals (distance from the
    /// corner along the faces where the scan leaves them); 0 when none was measured.
    pub zone: f64,
    /// Slab fits that failed (count) with the first reason.
    pub failed_slabs: usize,
    pub first_failure: Option<String>,
}

/// The scanned surface as the fitting stages see it: positions, the outlier mask of the
/// features stage, the neighbour grid and the measured scale.
#[derive(Clone, Copy)]
pub struct Surface<'a> {
    pub positions: &'a [[f64; 3]],
    pub outlier: &'a [bool],
    pub grid: &'a Grid,
    pub scale: &'a Scale,
}

/// Fits every run's edge in parallel. Each run gets its own RNG from (seed, run id), so the
/// result does not depend on the thread count.
pub fn fit_edges(
    surface: &Surface,
    segments: &Segments,
    params: &EdgeParams,
    fit: &FitParams,
    seed: u64,
) -> Vec<Result<EdgeFit, String>> {
    let Surface {
        positions,
        outlier,
        grid,
        scale,
    } = *surface;
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

/// What one pass of slab fits along a centre line gives.
struct Pass {
    slabs: Vec<SlabFit>,
    failed: usize,
    first_failure: Option<String>,
    /// (distance from the slab's corner along the face, signed distance to the face's local
    /// line towards the other face) of every side and corner-region point, for the zone
    /// estimate.
    residuals: Vec<(f64, f64, bool)>,
}

/// The per-run inputs that stay fixed across passes.
struct RunCtx<'a> {
    positions: &'a [[f64; 3]],
    outlier: &'a [bool],
    grid: &'a Grid,
    k: usize,
    scale: &'a Scale,
    params: &'a EdgeParams,
    fit: &'a FitParams,
    t0: f64,
    t1: f64,
    /// The run's line, which parametrises the slabs' positions.
    origin: [f64; 3],
    direction: [f64; 3],
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
    // The usable stretch of the run: its extent, pulled back from vertices.
    let mut t0 = run.t_range[0];
    let mut t1 = run.t_range[1];
    let band = params.band * r;
    for (e, t) in [(0, &mut t0), (1, &mut t1)] {
        if let Some(v) = run.vertices[e] {
            let vertex = &segments.vertices[v];
            let tv = dot(sub(vertex.position, run.origin), run.direction);
            // Our direction away from the vertex, and the other edges' directions away from it.
            let ours = if e == 0 {
                run.direction
            } else {
                run.direction.map(|x| -x)
            };
            // Where another edge leaves the vertex at an angle θ < 90° to ours, the face between
            // them is only L·tan θ wide at distance L: the band must not reach across it.
            let mut margin = params.vertex_margin * r;
            for &(j, ej) in &vertex.ends {
                if j == k {
                    continue;
                }
                let o = &segments.runs[j];
                let theirs = if ej == 0 {
                    o.direction
                } else {
                    o.direction.map(|x| -x)
                };
                let c = dot(ours, theirs).clamp(-1.0, 1.0);
                if c > 1e-6 {
                    let tan = (1.0 - c * c).sqrt() / c;
                    margin = margin.max(band / tan.max(1e-3) + 0.5 * r);
                }
            }
            *t = if e == 0 { tv + margin } else { tv - margin };
        }
    }
    if t1 - t0 < r {
        return Err(format!(
            "edge {k}: too short between its vertices ({:.3})",
            t1 - t0
        ));
    }
    let ctx = RunCtx {
        positions,
        outlier,
        grid,
        k,
        scale,
        params,
        fit,
        t0,
        t1,
        origin: run.origin,
        direction: run.direction,
    };
    // Pass 1 along the run's band axis: where the sharp edge is, roughly, and how wide its
    // abnormal zone is.
    let band = params.band * r;
    let first = slab_pass(
        &ctx,
        &Centreline::new(run),
        0.0,
        None,
        band,
        rng,
        scratch,
        out,
    )?;
    // Later passes go along the line (or curve) through the previous pass's rectified edge
    // points — slabs exactly across the edge, the approximate corner on it — and keep the
    // abnormal zone measured from the previous pass's pooled residuals out of the side fits,
    // with a band wide enough that the faces reach well beyond the zone (a sharp wedge's
    // fillet is several spacings wide). A third pass runs only when the zone moved.
    let mut pass = first;
    let mut zone_used = 0.0;
    let mut zone_raw = 0.0;
    for _ in 0..2 {
        let raw = abnormal_zone(
            &pass.residuals,
            scale,
            2.0 * band.max(2.0 * zone_used + 2.0 * r),
        );
        // Fitting keeps half a bin more out: a side point must be clearly on its face.
        let zone = if raw > 0.0 {
            raw + 0.25 * scale.spacing
        } else {
            0.0
        };
        if zone_used > 0.0 && (zone - zone_used).abs() <= scale.spacing {
            break;
        }
        let (line, _, straight) = edge_line(&pass.slabs, run.direction, scale, params);
        let centre = if straight {
            Centreline::straight(line, run.origin, run.direction, t0, t1, r)
        } else {
            Centreline::through(&robust_curve(&pass.slabs), run.origin, run.direction)
        };
        let wide = band.max(2.0 * zone + 2.0 * r);
        match slab_pass(&ctx, &centre, zone, None, wide, rng, scratch, out) {
            Ok(p) if p.slabs.len() >= 2 => {
                pass = p;
                zone_used = zone;
                zone_raw = raw;
            }
            _ => break,
        }
    }
    // A straight edge has the same two faces in every slab: a last pass gives every slab's
    // constrained lines the edge's mean face directions (see `ProfileKnown::slopes`), so a
    // slab's corner only carries the noise of its lines' offsets, not of their slopes.
    let (line, _, straight) = edge_line(&pass.slabs, run.direction, scale, params);
    if straight && let Some(faces) = mean_faces(&pass.slabs) {
        let centre = Centreline::straight(line, run.origin, run.direction, t0, t1, r);
        let wide = band.max(2.0 * zone_used + 2.0 * r);
        if let Ok(p) = slab_pass(
            &ctx,
            &centre,
            zone_used,
            Some(faces),
            wide,
            rng,
            scratch,
            out,
        ) && p.slabs.len() >= 2
        {
            pass = p;
        }
    }
    let (line, _, straight) = edge_line(&pass.slabs, run.direction, scale, params);
    if straight {
        // A slab far off the edge's line saw something else (a neighbouring face, a gap):
        // it must not feed the vertex fits or the rectification.
        let d: Vec<f64> = pass
            .slabs
            .iter()
            .map(|s| point_line_distance(s.corner, line))
            .collect();
        let mut sorted = d.clone();
        let mid = sorted.len() / 2;
        let cut = (4.0 * 1.4826 * *sorted.select_nth_unstable_by(mid, f64::total_cmp).1).max(1e-12);
        let before = pass.slabs.len();
        let mut i = 0;
        pass.slabs.retain(|_| {
            i += 1;
            d[i - 1] <= cut
        });
        let dropped = before - pass.slabs.len();
        if dropped > 0 {
            pass.failed += dropped;
            pass.first_failure.get_or_insert_with(|| {
                format!("edge {k}: {dropped} slab corner(s) off the edge's line left out")
            });
        }
    }
    let (line, rms, straight) = edge_line(&pass.slabs, run.direction, scale, params);
    let mut angles: Vec<f64> = pass
        .slabs
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
    tracing::debug!(
        "edge {k}: {} slabs ({} failed), abnormal zone {:.2} spacings, rms {:.3} spacings, \
         dihedral {dihedral_deg:.1}°, {}",
        pass.slabs.len(),
        pass.failed,
        zone_raw / scale.spacing,
        rms / scale.spacing,
        if straight { "straight" } else { "curved" }
    );
    Ok(EdgeFit {
        run: k,
        zone: zone_raw,
        straight,
        slabs: pass.slabs,
        line,
        rms,
        dihedral_deg,
        failed_slabs: pass.failed,
        first_failure: pass.first_failure,
    })
}

/// The best line through the slabs' rectified edge points (oriented like `towards`), their
/// RMS distance to it, and whether the edge is straight. Slab corners farther than 4 robust
/// sigmas from a first line are left out of the final one. Straight unless a smoothed curve
/// through the corners fits clearly better than the line (curvature, not noise) and the line's
/// RMS exceeds `straight_tolerance` spacings.
fn edge_line(
    slabs: &[SlabFit],
    towards: [f64; 3],
    scale: &Scale,
    params: &EdgeParams,
) -> (([f64; 3], [f64; 3]), f64, bool) {
    let pts: Vec<[f64; 3]> = slabs.iter().map(|s| s.corner).collect();
    let all: Vec<usize> = (0..pts.len()).collect();
    let orient = |l: ([f64; 3], [f64; 3])| {
        (
            l.0,
            if dot(l.1, towards) < 0.0 {
                l.1.map(|x| -x)
            } else {
                l.1
            },
        )
    };
    let Some(first) = pca_line(&pts, &all).map(orient) else {
        return (
            (pts.first().copied().unwrap_or([0.0; 3]), towards),
            0.0,
            true,
        );
    };
    let keep = inliers(&pts, |p| point_line_distance(p, first));
    let line = if keep.len() >= 2 && keep.len() < pts.len() {
        pca_line(&pts, &keep).map(orient).unwrap_or(first)
    } else {
        first
    };
    let kept: Vec<[f64; 3]> = keep.iter().map(|&i| pts[i]).collect();
    let rms_of = |d: &mut dyn Iterator<Item = f64>| {
        let (mut s, mut n) = (0.0, 0usize);
        for x in d {
            s += x * x;
            n += 1;
        }
        (s / n.max(1) as f64).sqrt()
    };
    let rms = rms_of(&mut kept.iter().map(|p| point_line_distance(*p, line)));
    let smooth = smooth_polyline(&kept, 3);
    let rms_smooth = rms_of(&mut kept.iter().zip(&smooth).map(|(p, q)| norm(sub(*p, *q))));
    let straight = rms <= params.straight_tolerance * scale.spacing || rms <= 1.5 * rms_smooth;
    (line, rms, straight)
}

/// Indices of the points whose `dist` is within 4 robust sigmas (1.4826 · median).
fn inliers(pts: &[[f64; 3]], dist: impl Fn([f64; 3]) -> f64) -> Vec<usize> {
    let d: Vec<f64> = pts.iter().map(|p| dist(*p)).collect();
    let mut sorted = d.clone();
    if sorted.is_empty() {
        return Vec::new();
    }
    let mid = sorted.len() / 2;
    let cut = (4.0 * 1.4826 * *sorted.select_nth_unstable_by(mid, f64::total_cmp).1).max(1e-12);
    (0..pts.len()).filter(|&i| d[i] <= cut).collect()
}

/// Moving average over ±`half` neighbours (shorter windows at the ends).
pub fn smooth_polyline(pts: &[[f64; 3]], half: usize) -> Vec<[f64; 3]> {
    (0..pts.len())
        .map(|i| {
            let lo = i.saturating_sub(half);
            let hi = (i + half + 1).min(pts.len());
            let mut s = [0.0; 3];
            for p in &pts[lo..hi] {
                s = add(s, *p);
            }
            s.map(|x| x / (hi - lo) as f64)
        })
        .collect()
}

/// The slab corners without the ones far off their smoothed neighbours, smoothed: the centre
/// line of a curving edge for the next pass.
fn robust_curve(slabs: &[SlabFit]) -> Vec<[f64; 3]> {
    let pts: Vec<[f64; 3]> = slabs.iter().map(|s| s.corner).collect();
    let smooth = smooth_polyline(&pts, 3);
    let keep = inliers(&pts, |p| {
        let i = pts.iter().position(|q| *q == p).unwrap_or(0);
        norm(sub(p, smooth[i]))
    });
    let kept: Vec<[f64; 3]> = keep.iter().map(|&i| pts[i]).collect();
    smooth_polyline(&kept, 3)
}

/// Radius of the abnormal zone around the corner, from the pooled residuals of every slab of
/// an edge: going out from the corner, the outer end of the last stretch (half-spacing bins)
/// whose mean residual towards the other face stands clearly above the faces' own level. Faces are
/// straight in the profile; a fillet or a lip bends towards the inside of the angle. 0 when no
/// stretch deviates (a sharp edge).
fn abnormal_zone(res: &[(f64, f64, bool)], scale: &Scale, band: f64) -> f64 {
    // The band's reach along the faces: a high percentile of the side points' distances (a
    // corner-region point of a failed side can sit anywhere).
    let mut s_side: Vec<f64> = res
        .iter()
        .filter(|x| x.2 && x.0 >= 0.0)
        .map(|x| x.0)
        .collect();
    if s_side.len() < 50 {
        return 0.0;
    }
    let k = ((s_side.len() * 95) / 100).min(s_side.len() - 1);
    let s_max = *s_side.select_nth_unstable_by(k, f64::total_cmp).1;
    let w = 0.5 * scale.spacing;
    let limit = (0.5 * s_max).min(0.5 * band);
    let nbin = ((limit / w).ceil() as usize).clamp(1, 4096);
    let mut sum = vec![0.0f64; nbin];
    let mut cnt = vec![0usize; nbin];
    for &(s, r, _) in res {
        if s < 0.0 || s >= nbin as f64 * w {
            continue;
        }
        let b = ((s / w) as usize).min(nbin - 1);
        sum[b] += r;
        cnt[b] += 1;
    }
    // The faces' level and spread: side points in the outer half of the band. The level is a
    // line in s, not a constant: pooled slabs whose face fits lean one way would otherwise
    // read as a deviation growing towards the corner (seen at σ = 1 h as 6 h zones).
    let outer: Vec<(f64, f64)> = res
        .iter()
        .filter(|x| x.2 && x.0 > 0.5 * s_max && x.0 <= s_max)
        .map(|x| (x.0, x.1))
        .collect();
    if outer.len() < 20 {
        return 0.0;
    }
    let n = outer.len() as f64;
    let (ms, mr) = outer
        .iter()
        .fold((0.0, 0.0), |(a, b), &(s, r)| (a + s / n, b + r / n));
    let (sxx, sxy) = outer.iter().fold((0.0, 0.0), |(a, b), &(s, r)| {
        (a + (s - ms) * (s - ms), b + (s - ms) * (r - mr))
    });
    let slope = if sxx > 0.0 { sxy / sxx } else { 0.0 };
    let level = |s: f64| mr + slope * (s - ms);
    let mut dev: Vec<f64> = outer.iter().map(|&(s, r)| (r - level(s)).abs()).collect();
    let mid = dev.len() / 2;
    let sigma = 1.4826 * *dev.select_nth_unstable_by(mid, f64::total_cmp).1;
    // The zone is contiguous from the corner: its outer end is where the deviation stops
    // (the first quiet bin ends it), not the last bin that happens to deviate: a slight bend
    // of a face a few spacings out (0.05 h, seen on an L-block) is not the edge's rounding.
    let mut zone = 0.0;
    let mut quiet = 0;
    for b in 0..nbin {
        if cnt[b] < 5 {
            continue;
        }
        let mean = sum[b] / cnt[b] as f64 - level((b as f64 + 0.5) * w);
        let se = sigma / (cnt[b] as f64).sqrt();
        if mean > 3.0 * se && mean > 0.1 * sigma {
            zone = (b as f64 + 1.0) * w;
            quiet = 0;
        } else if zone > 0.0 {
            quiet += 1;
            if quiet > 0 {
                break;
            }
        }
    }
    zone.min(0.5 * band)
}

/// One pass of slab fits along `centre`, with the abnormal zone `zone` (0: the propagation
/// alone decides) and, if known, the directions of the two faces in 3D (the slopes of every
/// slab's constrained lines).
#[allow(clippy::too_many_arguments)]
fn slab_pass(
    ctx: &RunCtx,
    centre: &Centreline,
    zone: f64,
    faces: Option<[[f64; 3]; 2]>,
    band: f64,
    rng: &mut SmallRng,
    scratch: &mut ProfileScratch,
    out: &mut ProfileFit,
) -> Result<Pass, String> {
    let (k, scale, params) = (ctx.k, ctx.scale, ctx.params);
    let (t0, t1) = (ctx.t0, ctx.t1);
    // Band points: within `band` of the centre line, inside the usable stretch.
    let mut ids: Vec<u32> = Vec::new();
    for w in centre.points.windows(2) {
        ctx.grid
            .for_each_near_segment(w[0], w[1], band, |i| ids.push(i));
    }
    if centre.points.len() == 1 {
        ctx.grid
            .for_each_near_segment(centre.points[0], centre.points[0], band, |i| ids.push(i));
    }
    ids.sort_unstable();
    ids.dedup();
    let mut band_pts: Vec<(f64, u32)> = ids
        .into_iter()
        .filter(|&i| !ctx.outlier[i as usize])
        .map(|i| {
            (
                dot(sub(ctx.positions[i as usize], ctx.origin), ctx.direction),
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
    let mut pass = Pass {
        slabs: Vec::with_capacity(nslab),
        failed: 0,
        first_failure: None,
        residuals: Vec::new(),
    };
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
            let v = sub(ctx.positions[i as usize], c);
            // Along-edge offsets are dropped: the profile is the slab seen along the edge.
            profile.push([dot(v, e1), dot(v, e2)]);
            members.push(i);
        }
        let known = ProfileKnown {
            zone,
            slopes: faces.map(|f| f.map(|d| [dot(d, e1), dot(d, e2)])),
        };
        let res = fit_profile_2d_zone(&profile, [0.0, 0.0], &known, ctx.fit, rng, scratch, out);
        match res {
            Ok(()) => {
                let lift = |q: [f64; 2]| add(c, add(e1.map(|x| x * q[0]), e2.map(|x| x * q[1])));
                let faces = [0, 1].map(|j| {
                    let d = out.local[j].direction;
                    let f = add(e1.map(|x| x * d[0]), e2.map(|x| x * d[1]));
                    f.map(|x| x / norm(f))
                });
                let pso = out.pso.point;
                // The points to rectify: the fit's corner region and every point of the slab
                // within the zone (with noise and spacing to spare) of the corner; rectify
                // decides along the faces which of them really leave their face.
                let reach = zone + 0.5 * scale.spacing + 2.0 * scale.noise;
                let mut abnormal: Vec<u32> =
                    out.corner_region.iter().map(|&j| members[j]).collect();
                if zone > 0.0 {
                    for (j, q) in profile.iter().enumerate() {
                        if (q[0] - pso[0]).powi(2) + (q[1] - pso[1]).powi(2) <= reach * reach {
                            abnormal.push(members[j]);
                        }
                    }
                    abnormal.sort_unstable();
                    abnormal.dedup();
                }
                let abnormal_reach = out
                    .corner_region
                    .iter()
                    .map(|&j| {
                        ((profile[j][0] - pso[0]).powi(2) + (profile[j][1] - pso[1]).powi(2)).sqrt()
                    })
                    .fold(zone, f64::max);
                collect_residuals(&profile, out, &mut pass.residuals);
                pass.slabs.push(SlabFit {
                    t: tc,
                    tangent,
                    corner: lift(pso),
                    corner_scheme1: lift(out.scheme1.point),
                    corner_exact: lift(out.exact.point),
                    faces,
                    errors: [out.scheme1.error, out.pso.error, out.exact.error],
                    abnormal,
                    abnormal_reach,
                    points: profile.len(),
                });
            }
            Err(e) => {
                pass.failed += 1;
                pass.first_failure
                    .get_or_insert_with(|| format!("edge {k} slab at t = {tc:.4}: {e}"));
            }
        }
    }
    if pass.slabs.len() < 2 {
        return Err(pass
            .first_failure
            .unwrap_or_else(|| format!("edge {k}: fewer than two slabs fitted")));
    }
    Ok(pass)
}

/// Appends (distance along the face from the exact corner, signed distance to the face's
/// local line towards the other face) for every side and corner-region point of a fit.
fn collect_residuals(profile: &[[f64; 2]], fit: &ProfileFit, out: &mut Vec<(f64, f64, bool)>) {
    let q = fit.exact.point;
    let dirs = [fit.local[0].direction, fit.local[1].direction];
    // Normal of each face line pointing to the other face's side.
    let normals = [0, 1].map(|j| {
        let d = dirs[j];
        let n = [-d[1], d[0]];
        let o = dirs[1 - j];
        if n[0] * o[0] + n[1] * o[1] < 0.0 {
            [-n[0], -n[1]]
        } else {
            n
        }
    });
    let mut push = |i: usize, j: usize, side: bool| {
        let p = profile[i];
        let l = &fit.local[j];
        let s = (p[0] - q[0]) * dirs[j][0] + (p[1] - q[1]) * dirs[j][1];
        let r = (p[0] - l.point[0]) * normals[j][0] + (p[1] - l.point[1]) * normals[j][1];
        out.push((s, r, side));
    };
    for j in 0..2 {
        for &i in &fit.sides[j] {
            push(i, j, true);
        }
    }
    for &i in &fit.corner_region {
        let j =
            usize::from(fit.local[1].distance(&profile[i]) < fit.local[0].distance(&profile[i]));
        push(i, j, false);
    }
}

/// The mean of the slabs' face directions (each slab's two faces matched to the first slab's),
/// normalised; `None` without slabs or when a mean vanishes.
pub fn mean_faces(slabs: &[SlabFit]) -> Option<[[f64; 3]; 2]> {
    let first = slabs.first()?.faces;
    let mut acc = [[0.0; 3]; 2];
    for s in slabs {
        let swap = dot(s.faces[0], first[0]) + dot(s.faces[1], first[1])
            < dot(s.faces[0], first[1]) + dot(s.faces[1], first[0]);
        let f = if swap {
            [s.faces[1], s.faces[0]]
        } else {
            s.faces
        };
        acc[0] = add(acc[0], f[0]);
        acc[1] = add(acc[1], f[1]);
    }
    let out = acc.map(|f| {
        let l = norm(f);
        f.map(|x| x / l)
    });
    out.iter()
        .all(|f| f.iter().all(|x| x.is_finite()))
        .then_some(out)
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
        Self::through(&run.centreline, run.origin, run.direction)
    }

    /// Through `points` (ordered along the run), parametrised by the run's line.
    fn through(points: &[[f64; 3]], origin: [f64; 3], direction: [f64; 3]) -> Self {
        let mut points = points.to_vec();
        if points.is_empty() {
            points.push(origin);
        }
        let ts = points
            .iter()
            .map(|p| dot(sub(*p, origin), direction))
            .collect();
        Centreline {
            points,
            ts,
            origin,
            direction,
        }
    }

    /// A straight centre line along `line` from the run's t0 to t1, sampled every `step`.
    fn straight(
        line: ([f64; 3], [f64; 3]),
        origin: [f64; 3],
        direction: [f64; 3],
        t0: f64,
        t1: f64,
        step: f64,
    ) -> Self {
        let n = (((t1 - t0) / step).ceil() as usize).clamp(1, 100_000);
        let c = dot(line.1, direction);
        let at = |t: f64| {
            // The point of `line` whose position along the run's line is t.
            let s = if c.abs() > 1e-9 {
                (t - dot(sub(line.0, origin), direction)) / c
            } else {
                0.0
            };
            add(line.0, line.1.map(|x| x * s))
        };
        let points: Vec<[f64; 3]> = (0..=n)
            .map(|i| at(t0 + (t1 - t0) * i as f64 / n as f64))
            .collect();
        let ts = points
            .iter()
            .map(|p| dot(sub(*p, origin), direction))
            .collect();
        Centreline {
            points,
            ts,
            origin,
            direction: line.1,
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
