//! The paper's 2D case as the pipeline meets it: an unordered profile (the points around a
//! straight sharp edge, projected onto the plane perpendicular to the edge) with two face
//! traces meeting at a corner, a rounded or noisy abnormal zone there, noise and maybe a few
//! outliers.
//!
//! Steps, all in a local frame centred on the approximate corner (see `problem`):
//! 1. Split into two arms: the directions of the far half of the points (seen from the
//!    approximate corner) are clustered into two (spherical 2-means), a line is fitted to each
//!    cluster, and every point goes to the nearer line. Arms are ordered so that arm 1 turns
//!    counter-clockwise into arm 2, which does not depend on the input order.
//! 2. Order each arm by its position along the arm and read the profile as one polyline from
//!    the far end A of arm 1 through the corner to the far end B of arm 2; propagate (§2.1)
//!    from A and from B. The accepted points are the sides (A..C, D..B), the points between C
//!    and D the corner region (if the two runs crossed, the points both accepted).
//! 3. Fit L2 and L4 to the sides; build the constrained objective (§2) with every point scored
//!    against its side's line (corner-region points against the nearer one); search the corner
//!    with Scheme 1, PSO (in a frame whose first axis runs along the bisector towards the tip)
//!    and exactly; rectify the corner-region points onto the constrained half-lines.
//!
//! Input: points, approximate corner, [`FitParams`], an RNG. Output: a [`ProfileFit`].

use rand::Rng;

use super::exact::exact_2d;
use super::line::{Line, Line2};
use super::objective::FixedSlopes2;
use super::params::{FitParams, Searcher};
use super::problem::{Frame, Problem, grow_and_cap, nearest_on_rays, rms_radius};
use super::propagate::{line_residuals, noise_from_residuals, propagate_run, side_fit};
use super::pso::{Search, SwarmScratch, pso};
use super::scheme1::scheme1;
use crate::geometry::{dot, finite, norm2, scale, sub, unit};
use crate::{Error, Result};

const WHAT: &str = "2D profile fit";

/// Result of [`super::fit_profile_2d`], in input coordinates. Reuse one across calls with
/// [`super::fit_profile_2d_with`] to avoid allocating.
#[derive(Clone, Debug, Default)]
pub struct ProfileFit {
    /// Indices of the side points (A..C and D..B), far end first: the points the local fits
    /// L2 and L4 were made from.
    pub sides: [Vec<usize>; 2],
    /// Indices of the corner-region points (between C and D, the abnormal zone): the points
    /// to rectify.
    pub corner_region: Vec<usize>,
    /// Indices of the PSO's starting particles and Scheme 1's candidates: the corner region,
    /// C and D, grown to `min_particles` with the points nearest to their centre.
    pub candidates: Vec<usize>,
    /// Index of C (the last point accepted from side 1) and of D (from side 2).
    pub c: usize,
    pub d: usize,
    /// The local fits L2 and L4, directions pointing away from the corner.
    pub local: [Line2; 2],
    /// Noise level σ used by the propagation (given or estimated), input units.
    pub noise: f64,
    /// Scheme 1: the best candidate data point, with its error.
    pub scheme1: Search<2>,
    /// Index (into the input points) of Scheme 1's corner.
    pub scheme1_index: usize,
    /// The particle swarm's corner.
    pub pso: Search<2>,
    /// Best error after each PSO iteration (index 0 = initial swarm), input units.
    pub pso_history: Vec<f64>,
    /// The exact minimum of the fixed-slope error.
    pub exact: Search<2>,
    /// For each corner-region point (same order as `corner_region`): its rectified position,
    /// the nearest point on the two constrained half-lines from the `rectify_with` corner.
    pub rectified: Vec<[f64; 2]>,
}

impl ProfileFit {
    /// The constrained lines (the paper's L1 and L3) through `corner`: the local slopes.
    pub fn lines_through(&self, corner: &[f64; 2]) -> [Line2; 2] {
        [0, 1].map(|j| Line {
            point: *corner,
            direction: self.local[j].direction,
        })
    }

    /// The corner found by `which`.
    pub fn corner(&self, which: Searcher) -> &Search<2> {
        match which {
            Searcher::Pso => &self.pso,
            Searcher::Scheme1 => &self.scheme1,
            Searcher::Exact => &self.exact,
        }
    }
}

/// Work buffers for the 2D profile fit; keep one per thread.
#[derive(Clone, Debug, Default)]
pub struct ProfileScratch {
    /// The swarm's starting positions (candidates, plus the lines' meeting point if asked).
    init: Vec<[f64; 2]>,
    loc: Vec<[f64; 2]>,
    r2: Vec<f64>,
    far: Vec<usize>,
    label: Vec<u8>,
    arm: [Vec<usize>; 2],
    poly: Vec<usize>,
    rev: Vec<usize>,
    t: Vec<f64>,
    res: Vec<f64>,
    buf: Vec<[f64; 2]>,
    cand_idx: Vec<usize>,
    cand: Vec<[f64; 2]>,
    basis: [[f64; 2]; 2],
    assigned: Vec<Vec<usize>>,
    flag: Vec<bool>,
    order: Vec<usize>,
    med: Vec<f64>,
    obj: FixedSlopes2,
    swarm: SwarmScratch<2>,
    frame: Option<Frame<2>>,
    cand_scale: f64,
    /// The local fits' intersection (local frame), if they meet.
    meeting: Option<[f64; 2]>,
}

impl ProfileScratch {
    /// The search problem prepared by the last successful [`prepare_profile_2d`].
    pub fn problem(&self) -> Option<Problem<'_, 2, FixedSlopes2>> {
        Some(Problem {
            objective: &self.obj,
            candidates: &self.cand,
            basis: self.basis,
            scale: self.cand_scale,
            meeting: self.meeting,
            points: &self.loc,
            assigned: &self.assigned,
            frame: self.frame?,
        })
    }
}

fn cross2(a: &[f64; 2], b: &[f64; 2]) -> f64 {
    a[0] * b[1] - a[1] * b[0]
}

/// Steps 1–3 up to the prepared search problem (left in `scratch`): arms, propagation, local
/// fits, objective, candidates. Fills `out`'s sides, corner region, candidates, C, D, local
/// fits and noise; the searches are [`solve_profile_2d`].
pub fn prepare_profile_2d(
    points: &[[f64; 2]],
    approx_corner: [f64; 2],
    params: &FitParams,
    scratch: &mut ProfileScratch,
    out: &mut ProfileFit,
) -> Result<()> {
    prepare_profile_2d_zone(
        points,
        approx_corner,
        &ProfileKnown::default(),
        params,
        scratch,
        out,
    )
}

/// What the caller already knows about a profile, from the other slabs of the same edge.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ProfileKnown {
    /// The abnormal zone: points closer than this (input units) to the approximate corner
    /// are never side points, whatever the propagation says. The 3D pipeline measures it once
    /// per edge from the residuals of all its slabs, which sees where a tangent-continuous
    /// fillet leaves the faces far better than one slab can. 0 = unknown.
    pub zone: f64,
    /// The directions of the two faces (unit, in the profile's plane, either orientation):
    /// the slopes of the constrained lines. The paper takes them from the two local fits of
    /// the profile; along a straight edge every slab sees the same faces, and their mean
    /// over all slabs is far steadier than one slab's fit (measured on a 30,000-point box:
    /// per-slab corners scatter 0.11 spacings with their own slopes). Each side's local line
    /// then keeps this direction through the centroid of its points (the total least squares
    /// line of given direction).
    pub slopes: Option<[[f64; 2]; 2]>,
}

/// [`prepare_profile_2d`] with what is known from the rest of the edge (see
/// [`ProfileKnown`]).
pub fn prepare_profile_2d_zone(
    points: &[[f64; 2]],
    approx_corner: [f64; 2],
    known: &ProfileKnown,
    params: &FitParams,
    scratch: &mut ProfileScratch,
    out: &mut ProfileFit,
) -> Result<()> {
    let s = scratch;
    s.frame = None;
    let zone = known.zone;
    let n = points.len();
    let min_side = params.min_side_points.max(2);
    if n < 2 * min_side {
        return Err(Error::TooFewPoints {
            what: WHAT,
            needed: 2 * min_side,
            got: n,
        });
    }
    if !finite(&approx_corner) {
        return Err(Error::Degenerate {
            what: WHAT,
            why: format!("the approximate corner {approx_corner:?} is not finite"),
        });
    }
    if let Some(i) = points.iter().position(|p| !finite(p)) {
        return Err(Error::Degenerate {
            what: WHAT,
            why: format!(
                "point {i} has a non-finite coordinate {:?}; remove it first",
                points[i]
            ),
        });
    }
    // Local frame: centred on the approximate corner, unit = RMS radius around it.
    let rms = (points
        .iter()
        .map(|p| norm2(&sub(p, &approx_corner)))
        .sum::<f64>()
        / n as f64)
        .sqrt();
    if !rms.is_finite() || rms <= 0.0 {
        return Err(Error::Degenerate {
            what: WHAT,
            why: "all points coincide with the approximate corner".into(),
        });
    }
    let frame = Frame {
        origin: approx_corner,
        unit: rms,
    };
    s.loc.clear();
    s.loc.extend(points.iter().map(|p| frame.to_local(p)));
    let loc = &s.loc;

    // 1. Arms. Far half by distance from the approximate corner.
    s.r2.clear();
    s.r2.extend(loc.iter().map(norm2));
    s.order.clear();
    s.order.extend(0..n);
    let r2 = &s.r2;
    let mid = n / 2;
    s.order
        .select_nth_unstable_by(mid, |&a, &b| r2[a].total_cmp(&r2[b]).then(a.cmp(&b)));
    s.far.clear();
    s.far.extend_from_slice(&s.order[mid..]);
    s.far.retain(|&i| r2[i] > 0.0);
    s.far.sort_unstable();
    let far = &s.far;
    if far.len() < 2 {
        return Err(Error::Degenerate {
            what: WHAT,
            why: "fewer than two points away from the approximate corner".into(),
        });
    }
    let dir_of = |i: usize| scale(&loc[i], 1.0 / r2[i].sqrt());
    let seed1 = far
        .iter()
        .copied()
        .max_by(|&a, &b| r2[a].total_cmp(&r2[b]).then(b.cmp(&a)))
        .map(dir_of)
        .unwrap_or([1.0, 0.0]);
    let seed2 = far
        .iter()
        .copied()
        .min_by(|&a, &b| {
            dot(&dir_of(a), &seed1)
                .total_cmp(&dot(&dir_of(b), &seed1))
                .then(a.cmp(&b))
        })
        .map(dir_of)
        .unwrap_or([-1.0, 0.0]);
    let mut means = [seed1, seed2];
    s.label.clear();
    s.label.resize(n, 2);
    for _ in 0..32 {
        let mut changed = false;
        let mut sums = [[0.0; 2]; 2];
        for &i in far {
            let u = dir_of(i);
            let l = u8::from(dot(&u, &means[1]) > dot(&u, &means[0]));
            if s.label[i] != l {
                s.label[i] = l;
                changed = true;
            }
            let sm = &mut sums[l as usize];
            sm[0] += u[0];
            sm[1] += u[1];
        }
        for k in 0..2 {
            if let Some(m) = unit(&sums[k]) {
                means[k] = m;
            }
        }
        if !changed {
            break;
        }
    }
    // Lines through each cluster of far points.
    let mut arm_line = [Line {
        point: [0.0; 2],
        direction: [1.0, 0.0],
    }; 2];
    for k in 0..2 {
        s.buf.clear();
        s.buf.extend(
            far.iter()
                .filter(|&&i| s.label[i] == k as u8)
                .map(|&i| loc[i]),
        );
        if s.buf.len() < 2 {
            return Err(Error::Degenerate {
                what: WHAT,
                why: "the points form a single arm, not two sides meeting at a corner; \
                      check the approximate corner and the slab"
                    .into(),
            });
        }
        arm_line[k] = super::line::fit_line(&s.buf)?.oriented(&means[k]);
    }
    let sin_min = params.min_angle_deg.to_radians().sin();
    if cross2(&arm_line[0].direction, &arm_line[1].direction).abs() < sin_min {
        return Err(parallel_sides());
    }
    // Canonical arm order: arm 0 turns counter-clockwise into arm 1.
    if cross2(&arm_line[0].direction, &arm_line[1].direction) < 0.0 {
        arm_line.swap(0, 1);
    }
    // Every point to the nearer arm line; order each arm far end first.
    for a in s.arm.iter_mut() {
        a.clear();
    }
    for (i, p) in loc.iter().enumerate() {
        let k = usize::from(arm_line[1].distance(p) < arm_line[0].distance(p));
        s.arm[k].push(i);
    }
    s.t.clear();
    s.t.resize(n, 0.0);
    for (arm, line) in s.arm.iter_mut().zip(&arm_line) {
        for &i in arm.iter() {
            s.t[i] = dot(&loc[i], &line.direction);
        }
        let t = &s.t;
        arm.sort_by(|&a, &b| t[b].total_cmp(&t[a]).then(a.cmp(&b)));
    }

    // Noise: far halves of the arms against their own lines.
    let sigma = match params.propagation.noise {
        Some(sg) => sg / frame.unit,
        None => {
            s.res.clear();
            for k in 0..2 {
                let a = &s.arm[k];
                line_residuals(loc, &a[..a.len().div_ceil(2)], &mut s.res);
            }
            noise_from_residuals::<2>(&mut s.res).unwrap_or(0.0)
        }
    };
    let sigma = sigma.max(1e-12);

    // 2. Propagation (§2.1) along the profile read as one polyline, A = far end of arm 1 ...
    // corner ... B = far end of arm 2, from both ends (the paper's Figure 3). Each run goes
    // towards the corner and, until it sees the turn, past it; where the two runs overlap, the
    // points both accepted surround the corner and go to the corner region, so the side fits
    // only use points that clearly belong to one side. A run that never sees the turn (an
    // obtuse corner in strong noise) is stopped halfway down the other arm, so it cannot
    // swallow the other side.
    let j = s.arm[0].len();
    s.poly.clear();
    s.poly.extend_from_slice(&s.arm[0]);
    s.poly.extend(s.arm[1].iter().rev());
    s.rev.clear();
    s.rev.extend(s.poly.iter().rev());
    let m = s.poly.len();
    let a = propagate_run(
        loc,
        &s.poly,
        sigma,
        &params.propagation,
        Some(arm_line[0].direction),
    )
    .min(j + (m - j) / 2);
    let b = propagate_run(
        loc,
        &s.rev,
        sigma,
        &params.propagation,
        Some(arm_line[1].direction),
    )
    .min(m - j + j / 2);
    // Side 1 = poly[..s1_end], side 2 = poly[s2_start..].
    let (mut s1_end, mut s2_start) = (a.min(m - b), a.max(m - b));
    if zone > 0.0 {
        // Pull each side back to its last point outside the zone (far end first, so the side
        // is a prefix of the polyline read from its end).
        let z2 = (zone / frame.unit).powi(2);
        while s1_end > 0 && norm2(&loc[s.poly[s1_end - 1]]) < z2 {
            s1_end -= 1;
        }
        while s2_start < m && norm2(&loc[s.poly[s2_start]]) < z2 {
            s2_start += 1;
        }
    }
    for (k, got) in [(0, s1_end), (1, m - s2_start)] {
        if got < min_side {
            return Err(Error::SideTooSmall {
                fit: WHAT,
                side: k + 1,
                needed: min_side,
                got,
                hint: "the side is too short or turns at once; widen the slab or lower \
                       min_side_points",
            });
        }
    }
    out.sides[0].clear();
    out.sides[0].extend_from_slice(&s.poly[..s1_end]);
    out.sides[1].clear();
    out.sides[1].extend_from_slice(&s.rev[..m - s2_start]);
    out.c = s.poly[s1_end - 1];
    out.d = s.poly[s2_start];
    out.corner_region.clear();
    out.corner_region
        .extend_from_slice(&s.poly[s1_end..s2_start]);

    // 3. Local fits L2, L4 (outward).
    let mut local = [arm_line[0]; 2];
    for k in 0..2 {
        local[k] = match known.slopes {
            // The given face nearer to this arm, through the centroid of the side.
            Some(slopes) => {
                let d = slopes
                    .iter()
                    .copied()
                    .max_by(|a, b| {
                        dot(a, &arm_line[k].direction)
                            .abs()
                            .total_cmp(&dot(b, &arm_line[k].direction).abs())
                    })
                    .and_then(|d| unit(&d))
                    .ok_or_else(|| Error::Degenerate {
                        what: WHAT,
                        why: "a given face direction is zero or not finite".into(),
                    })?;
                line_through_centroid(loc, &out.sides[k], d)
            }
            None => side_fit(
                loc,
                &out.sides[k],
                params.line_form,
                params.trim,
                sigma,
                &mut s.buf,
            )?,
        }
        .oriented(&arm_line[k].direction);
    }
    if cross2(&local[0].direction, &local[1].direction).abs() < sin_min {
        return Err(parallel_sides());
    }

    // Candidates: the corner region, C and D, grown / capped.
    s.cand_idx.clear();
    s.cand_idx.extend_from_slice(&out.corner_region);
    s.cand_idx.push(out.c);
    s.cand_idx.push(out.d);
    grow_and_cap(
        loc,
        &mut s.cand_idx,
        params.min_particles,
        params.max_particles,
        &mut s.flag,
        &mut s.order,
    );
    s.cand.clear();
    s.cand.extend(s.cand_idx.iter().map(|&i| loc[i]));
    s.cand_scale = rms_radius(loc, s.cand_idx.iter().copied()).max(sigma);
    // The swarm's frame: first axis along the bisector towards the tip (the abnormal zone lies
    // inside the angle, the corner at its tip), second axis 90° counter-clockwise from it.
    let tip = unit(&scale(
        &[
            local[0].direction[0] + local[1].direction[0],
            local[0].direction[1] + local[1].direction[1],
        ],
        -1.0,
    ))
    .unwrap_or([-local[0].direction[1], local[0].direction[0]]);
    s.basis = [tip, [-tip[1], tip[0]]];

    // Objective: side points to their own line, corner-region points to the nearer local line.
    s.assigned.resize_with(2, Vec::new);
    for k in 0..2 {
        s.assigned[k].clear();
        s.assigned[k].extend_from_slice(&out.sides[k]);
    }
    if params.include_corner_region {
        for &i in &out.corner_region {
            let k = usize::from(local[1].distance(&loc[i]) < local[0].distance(&loc[i]));
            s.assigned[k].push(i);
        }
    }
    s.obj.clear();
    for (line, assigned) in local.iter().zip(&s.assigned) {
        s.obj
            .add_line(&line.direction, assigned.iter().map(|&i| &loc[i]));
    }

    // On a narrow V the error is nearly flat along the bisector: a swarm started only on
    // corner-region points (inside the V) stops inside it. The local fits' intersection
    // centres it on the optimum region (`seed_with_intersection`).
    s.meeting = intersection(&local[0], &local[1]);
    out.local = [
        frame.line_to_input(&local[0]),
        frame.line_to_input(&local[1]),
    ];
    out.noise = frame.length_to_input(sigma);
    out.candidates.clear();
    out.candidates.extend_from_slice(&s.cand_idx);
    s.frame = Some(frame);
    Ok(())
}

/// The line of direction `d` through the centroid of `pts[idx]` (`idx` not empty).
fn line_through_centroid(pts: &[[f64; 2]], idx: &[usize], d: [f64; 2]) -> Line2 {
    let mut c = [0.0; 2];
    for &i in idx {
        c[0] += pts[i][0];
        c[1] += pts[i][1];
    }
    let n = idx.len().max(1) as f64;
    Line {
        point: [c[0] / n, c[1] / n],
        direction: d,
    }
}

fn parallel_sides() -> Error {
    Error::Degenerate {
        what: WHAT,
        why: "the two sides are parallel (all points on one line?), so there is no corner to \
              fit; lower min_angle_deg only if the profile really is this flat"
            .into(),
    }
}

/// The searches on the problem prepared in `scratch`: Scheme 1, PSO, exact, and the
/// rectified corner-region points. Fills the rest of `out`.
pub fn solve_profile_2d<R: Rng + ?Sized>(
    params: &FitParams,
    rng: &mut R,
    scratch: &mut ProfileScratch,
    out: &mut ProfileFit,
) -> Result<()> {
    let s = scratch;
    let Some(frame) = s.frame else {
        return Err(Error::Degenerate {
            what: WHAT,
            why: "no prepared problem; call prepare_profile_2d first".into(),
        });
    };
    let (ci, s1) = scheme1(&s.obj, &s.cand).ok_or(Error::TooFewPoints {
        what: "2D profile fit: corner candidates",
        needed: 1,
        got: 0,
    })?;
    let mut hist = std::mem::take(&mut out.pso_history);
    let mut init = std::mem::take(&mut s.init);
    init.clear();
    init.extend_from_slice(&s.cand);
    if params.seed_with_intersection
        && let Some(q) = s.meeting
    {
        init.push(q);
    }
    let p = pso(
        &s.obj,
        &init,
        &s.basis,
        s.cand_scale,
        &params.pso,
        params.pso.iterations_2d,
        rng,
        &mut s.swarm,
        &mut hist,
    );
    s.init = init;
    let ex = exact_2d(&s.obj, &mut s.med)?;
    let to_input = |r: Search<2>| Search {
        point: frame.to_input(&r.point),
        error: frame.length_to_input(r.error),
        ..r
    };
    out.scheme1 = to_input(s1);
    out.scheme1_index = s.cand_idx[ci];
    out.pso = to_input(p);
    out.exact = to_input(Search {
        point: ex.point,
        error: ex.error,
        evaluations: ex.iterations,
        converged_at: ex.iterations,
    });
    for h in hist.iter_mut() {
        *h = frame.length_to_input(*h);
    }
    out.pso_history = hist;
    if !(out.pso.error.is_finite() && finite(&out.pso.point)) {
        return Err(Error::Degenerate {
            what: WHAT,
            why: "the swarm left the finite range; the profile is too degenerate to fit".into(),
        });
    }
    // Rectify in the local frame, towards the chosen corner.
    let q = frame.to_local(&out.corner(params.rectify_with).point);
    let dirs = [out.local[0].direction, out.local[1].direction];
    out.rectified.clear();
    for &i in &out.corner_region {
        let (foot, _) = nearest_on_rays(&s.loc[i], &q, &dirs);
        out.rectified.push(frame.to_input(&foot));
    }
    Ok(())
}

/// Intersection of two 2D lines; `None` when (nearly) parallel.
fn intersection(a: &Line2, b: &Line2) -> Option<[f64; 2]> {
    let (d, e) = (a.direction, b.direction);
    let det = d[0] * (-e[1]) - (-e[0]) * d[1];
    if det.abs() < 1e-12 {
        return None;
    }
    let w = [b.point[0] - a.point[0], b.point[1] - a.point[1]];
    let t = (w[0] * (-e[1]) - (-e[0]) * w[1]) / det;
    let q = [a.point[0] + t * d[0], a.point[1] + t * d[1]];
    q.iter().all(|x| x.is_finite()).then_some(q)
}
