//! The paper's 2D case as the pipeline meets it: an unordered profile (the points around a
//! straight sharp edge, projected onto the plane perpendicular to the edge) with two face
//! traces meeting at a corner, a rounded or noisy abnormal zone there, noise and maybe a few
//! outliers.
//!
//! The fit is the method of `method` (stated once for k lines in D dimensions: local frame,
//! sides ordered far end first, noise, propagation, local fits, the constrained problem, the
//! searches, rectification) with the 2D specifics here, all in the local frame centred on the
//! approximate corner:
//! 1. Split into two arms (`split_into_arms`): the directions of the far half of the points
//!    (seen from the approximate corner) are clustered into two (spherical 2-means), a line is
//!    fitted to each cluster, and every point goes to the nearer line. Arms are ordered so
//!    that arm 1 turns counter-clockwise into arm 2, which does not depend on the input order.
//! 2. Read the profile as one polyline from the far end A of arm 1 through the corner to the
//!    far end B of arm 2, and propagate (§2.1) from A and from B
//!    (`propagate_from_both_ends`). The accepted points are the sides (A..C, D..B), the
//!    points between C and D the corner region (if the two runs crossed, the points both
//!    accepted); a known abnormal zone pulls the sides back (`pull_back_from_zone`).
//! 3. Local fits L2, L4, or the faces' known directions through the sides' centroids
//!    (`fit_local_lines`). A corner-region point belongs to neither side: it is scored
//!    against the nearer local line (`assign_points`) and rectified onto the nearer
//!    constrained half-line. The swarm's frame has its first axis along the bisector towards
//!    the tip, the local lines meet at their intersection, and the exact minimum of the error
//!    (a sum of absolute values) is a pair of medians (the `Case` implementation
//!    `Profile`).
//!
//! Input: points, approximate corner, [`FitParams`], an RNG. Output: a [`ProfileFit`].

use rand::Rng;

use super::exact::{Exact, exact_2d};
use super::line::{Line, Line2};
use super::method::{
    self, Case, Prepared, Searches, check_not_parallel, local_fit, order_far_end_first, pose,
};
use super::objective::FixedSlopes2;
use super::params::FitParams;
use super::problem::{Frame, Problem};
use super::propagate::propagate_run;
use crate::geometry::{dot, finite, norm2, scale, sub, unit};
use crate::{Error, Result};

const WHAT: &str = "2D profile fit";

/// A profile's arm is propagated and fitted at its own noise when that is more than this
/// many times the told one (see `prepare_profile_2d_zone`).
const SIDE_NOISE_RATIO: f64 = 2.0;

/// The 2D specifics of the shared method (see `method`): two lines, the objective of Eq. 11.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Profile;

/// Whether `e` is a profile fit's refusal of (nearly) parallel sides: a profile that does not
/// turn, one flat surface rather than a failed fit.
pub fn is_flat_profile(e: &Error) -> bool {
    matches!(e, Error::Parallel { what, .. } if *what == WHAT)
}

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
    /// Noise level σ used by the propagation (given or estimated), input units. An arm
    /// scattering more than twice a given σ is propagated at its own instead.
    pub noise: f64,
    /// Scheme 1's, the PSO's and the exact corner.
    pub searches: Searches<2>,
    /// Index (into the input points) of Scheme 1's corner.
    pub scheme1_index: usize,
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
    /// The smallest noise sigma the fit assumes (input units; 0 = none): an estimate from a
    /// noise-free profile can be far below what the slab's own tilt against the edge scatters
    /// a face by (see `stages::edges::NOISE_FLOOR`).
    pub noise_floor: f64,
}

/// Work buffers for the 2D profile fit; keep one per thread.
#[derive(Clone, Debug, Default)]
pub struct ProfileScratch {
    /// The shared method's problem and buffers.
    fit: Prepared<2, FixedSlopes2>,
    /// Squared distances of the local points from the approximate corner.
    r2: Vec<f64>,
    /// The far half of the points (sorted indices), which the arms are clustered from.
    far: Vec<usize>,
    /// Each far point's cluster (2 = not a far point).
    label: Vec<u8>,
    /// The two arms, far end first.
    arm: [Vec<usize>; 2],
    /// The profile as one polyline A..corner..B, and the same read from B.
    poly: Vec<usize>,
    rev: Vec<usize>,
}

impl ProfileScratch {
    /// The search problem prepared by the last successful [`prepare_profile_2d`].
    pub fn problem(&self) -> Option<Problem<'_, 2, FixedSlopes2>> {
        self.fit.problem()
    }
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
    let frame = to_local_frame(s, points, approx_corner, params)?;

    let arm_line = split_into_arms(s, params)?;
    // Noise: far halves of the arms against their own lines.
    let arms = s.arm.iter().map(Vec::as_slice);
    let sigma = method::noise(params, &frame, &s.fit.loc, arms, &mut s.fit.res)
        .max(known.noise_floor / frame.unit);
    // A told noise is the surface's around the edge; where one face is seen nearly edge-on,
    // its noise runs along the rays and the edge reads the quieter face's. Each arm's far
    // half then scatters well beyond it, and that arm is propagated and fitted at its own.
    let side_sigma: [f64; 2] = std::array::from_fn(|k| {
        if params.propagation.noise.is_none() {
            return sigma;
        }
        let arm = std::iter::once(s.arm[k].as_slice());
        let own = method::far_half_noise(&s.fit.loc, arm, &mut s.fit.res);
        if own > SIDE_NOISE_RATIO * sigma {
            own
        } else {
            sigma
        }
    });
    let ends = propagate_from_both_ends(s, side_sigma, params, &arm_line);
    let (s1_end, s2_start) = pull_back_from_zone(&s.fit.loc, &s.poly, known.zone, &frame, ends);
    check_side_sizes([s1_end, s.poly.len() - s2_start], params.min_side())?;
    record_sides(s, s1_end, s2_start, out);

    fit_local_lines(s, &arm_line, known, params, side_sigma, &out.sides)?;
    assign_points(&mut s.fit, out, params.include_corner_region);
    // The candidates' seeds: the corner region, C and D.
    s.fit.cand_idx.clear();
    s.fit.cand_idx.extend_from_slice(&out.corner_region);
    s.fit.cand_idx.push(out.c);
    s.fit.cand_idx.push(out.d);
    pose::<2, Profile>(&mut s.fit, params, sigma, frame)?;

    out.local = [
        frame.line_to_input(&s.fit.lines[0]),
        frame.line_to_input(&s.fit.lines[1]),
    ];
    out.noise = frame.length_to_input(sigma);
    out.candidates.clear();
    out.candidates.extend_from_slice(&s.fit.cand_idx);
    Ok(())
}

/// Rejects what cannot be fitted: fewer points than two sides need, a non-finite approximate
/// corner or point.
fn check_profile(points: &[[f64; 2]], approx_corner: &[f64; 2], min_side: usize) -> Result<()> {
    let n = points.len();
    if n < 2 * min_side {
        return Err(Error::TooFewPoints {
            what: WHAT,
            needed: 2 * min_side,
            got: n,
        });
    }
    method::check_approx::<2, Profile>(approx_corner)?;
    if let Some(i) = points.iter().position(|p| !finite(p)) {
        return Err(Error::Degenerate {
            what: WHAT,
            why: format!(
                "point {i} has a non-finite coordinate {:?}; remove it first",
                points[i]
            ),
        });
    }
    Ok(())
}

/// The local frame (centred on the approximate corner, unit = the points' RMS distance from
/// it), and the points in it (`s.fit.loc`). First forgets the last prepared problem (a failed
/// preparation leaves none for the searches) and rejects what cannot be fitted
/// ([`check_profile`]).
fn to_local_frame(
    s: &mut ProfileScratch,
    points: &[[f64; 2]],
    approx_corner: [f64; 2],
    params: &FitParams,
) -> Result<Frame<2>> {
    s.fit.frame = None;
    check_profile(points, &approx_corner, params.min_side())?;
    let sum_sq = points
        .iter()
        .map(|p| norm2(sub(p, approx_corner)))
        .sum::<f64>();
    let frame = method::local_frame::<2, Profile>(approx_corner, sum_sq, points.len())?;
    s.fit.loc.clear();
    s.fit.loc.extend(points.iter().map(|p| frame.to_local(p)));
    Ok(frame)
}

/// Step 1: the two arms. Returns a line through each arm's cluster of far points (direction
/// pointing away from the corner), arm 0 turning counter-clockwise into arm 1; leaves every
/// point on the nearer arm in `s.arm`, each arm ordered far end first. Fails on a single arm
/// or parallel arms.
fn split_into_arms(s: &mut ProfileScratch, params: &FitParams) -> Result<[Line2; 2]> {
    far_half(s)?;
    let means = cluster_directions(&s.fit.loc, &s.r2, &s.far, &mut s.label);
    let mut arm_line = arm_lines(&s.fit.loc, &s.far, &s.label, &means, &mut s.fit.buf)?;
    check_not_parallel::<2, Profile>(&arm_line, params)?;
    // Canonical arm order: arm 0 turns counter-clockwise into arm 1.
    if cross2(&arm_line[0].direction, &arm_line[1].direction) < 0.0 {
        arm_line.swap(0, 1);
    }
    assign_to_arms(s, &arm_line);
    Ok(arm_line)
}

/// The far half of the points by distance from the approximate corner, without points at
/// the corner itself: `s.far` (sorted indices), with `s.r2` the squared distances.
fn far_half(s: &mut ProfileScratch) -> Result<()> {
    let loc = &s.fit.loc;
    let n = loc.len();
    s.r2.clear();
    s.r2.extend(loc.iter().map(norm2));
    let order = &mut s.fit.order;
    order.clear();
    order.extend(0..n);
    let r2 = &s.r2;
    let mid = n / 2;
    order.select_nth_unstable_by(mid, |&a, &b| r2[a].total_cmp(&r2[b]).then(a.cmp(&b)));
    s.far.clear();
    s.far.extend_from_slice(&order[mid..]);
    s.far.retain(|&i| r2[i] > 0.0);
    s.far.sort_unstable();
    if s.far.len() < 2 {
        return Err(Error::Degenerate {
            what: WHAT,
            why: "fewer than two points away from the approximate corner".into(),
        });
    }
    Ok(())
}

/// Spherical 2-means of the directions of the `far` points seen from the approximate corner,
/// seeded with the farthest point's direction and the direction most opposite to it. Returns
/// the two mean directions; `label` receives each far point's cluster.
fn cluster_directions(
    loc: &[[f64; 2]],
    r2: &[f64],
    far: &[usize],
    label: &mut Vec<u8>,
) -> [[f64; 2]; 2] {
    let dir_of = |i: usize| scale(loc[i], 1.0 / r2[i].sqrt());
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
            dot(dir_of(a), seed1)
                .total_cmp(&dot(dir_of(b), seed1))
                .then(a.cmp(&b))
        })
        .map(dir_of)
        .unwrap_or([-1.0, 0.0]);
    let mut means = [seed1, seed2];
    label.clear();
    label.resize(loc.len(), 2);
    for _ in 0..32 {
        let mut changed = false;
        let mut sums = [[0.0; 2]; 2];
        for &i in far {
            let u = dir_of(i);
            let l = u8::from(dot(u, means[1]) > dot(u, means[0]));
            if label[i] != l {
                label[i] = l;
                changed = true;
            }
            let sm = &mut sums[l as usize];
            sm[0] += u[0];
            sm[1] += u[1];
        }
        for k in 0..2 {
            if let Some(m) = unit(sums[k]) {
                means[k] = m;
            }
        }
        if !changed {
            break;
        }
    }
    means
}

/// A line through each cluster of far points, pointing along the cluster's mean direction.
/// Fails when a cluster has fewer than two points: the profile is a single arm.
fn arm_lines(
    loc: &[[f64; 2]],
    far: &[usize],
    label: &[u8],
    means: &[[f64; 2]; 2],
    buf: &mut Vec<[f64; 2]>,
) -> Result<[Line2; 2]> {
    let mut arm_line = [Line2::default(); 2];
    for k in 0..2 {
        buf.clear();
        buf.extend(
            far.iter()
                .filter(|&&i| label[i] == k as u8)
                .map(|&i| loc[i]),
        );
        if buf.len() < 2 {
            return Err(Error::Degenerate {
                what: WHAT,
                why: "the points form a single arm, not two sides meeting at a corner; \
                      check the approximate corner and the slab"
                    .into(),
            });
        }
        arm_line[k] = super::line::fit_line(buf)?.oriented(&means[k]);
    }
    Ok(arm_line)
}

/// Every point to the nearer arm line (`s.arm`), each arm ordered far end first.
fn assign_to_arms(s: &mut ProfileScratch, arm_line: &[Line2; 2]) {
    let loc = &s.fit.loc;
    for a in s.arm.iter_mut() {
        a.clear();
    }
    for (i, p) in loc.iter().enumerate() {
        let k = usize::from(arm_line[1].distance(p) < arm_line[0].distance(p));
        s.arm[k].push(i);
    }
    s.fit.t.clear();
    s.fit.t.resize(loc.len(), 0.0);
    for (arm, line) in s.arm.iter_mut().zip(arm_line) {
        order_far_end_first(loc, arm, &line.direction, &mut s.fit.t);
    }
}

/// Step 2: propagation (§2.1) along the profile read as one polyline, A = far end of arm 1 ...
/// corner ... B = far end of arm 2, from both ends (the paper's Figure 3). Each run goes
/// towards the corner and, until it sees the turn, past it; where the two runs overlap, the
/// points both accepted surround the corner and go to the corner region, so the side fits
/// only use points that clearly belong to one side. A run that never sees the turn (an
/// obtuse corner in strong noise) is stopped halfway down the other arm, so it cannot
/// swallow the other side. Returns where side 1 ends and side 2 starts in `s.poly`.
fn propagate_from_both_ends(
    s: &mut ProfileScratch,
    sigma: [f64; 2],
    params: &FitParams,
    arm_line: &[Line2; 2],
) -> (usize, usize) {
    let loc = &s.fit.loc;
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
        sigma[0],
        &params.propagation,
        Some(arm_line[0].direction),
    )
    .min(j + (m - j) / 2);
    let b = propagate_run(
        loc,
        &s.rev,
        sigma[1],
        &params.propagation,
        Some(arm_line[1].direction),
    )
    .min(m - j + j / 2);
    // Side 1 = poly[..s1_end], side 2 = poly[s2_start..].
    (a.min(m - b), a.max(m - b))
}

/// With a known abnormal zone (`zone` > 0, input units): pulls each side back to its last
/// point outside the zone (far end first, so the side is a prefix of the polyline read from
/// its end).
fn pull_back_from_zone(
    loc: &[[f64; 2]],
    poly: &[usize],
    zone: f64,
    frame: &Frame<2>,
    (mut s1_end, mut s2_start): (usize, usize),
) -> (usize, usize) {
    if zone > 0.0 {
        let z2 = (zone / frame.unit).powi(2);
        while s1_end > 0 && norm2(loc[poly[s1_end - 1]]) < z2 {
            s1_end -= 1;
        }
        while s2_start < poly.len() && norm2(loc[poly[s2_start]]) < z2 {
            s2_start += 1;
        }
    }
    (s1_end, s2_start)
}

/// Fails when a side kept fewer than `min_side` points.
fn check_side_sizes(sizes: [usize; 2], min_side: usize) -> Result<()> {
    for (k, got) in sizes.into_iter().enumerate() {
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
    Ok(())
}

/// The sides (far end first), C, D and the corner region into `out`.
fn record_sides(s: &ProfileScratch, s1_end: usize, s2_start: usize, out: &mut ProfileFit) {
    let m = s.poly.len();
    out.sides[0].clear();
    out.sides[0].extend_from_slice(&s.poly[..s1_end]);
    out.sides[1].clear();
    out.sides[1].extend_from_slice(&s.rev[..m - s2_start]);
    out.c = s.poly[s1_end - 1];
    out.d = s.poly[s2_start];
    out.corner_region.clear();
    out.corner_region
        .extend_from_slice(&s.poly[s1_end..s2_start]);
}

/// Step 3: the local lines L2, L4 (`s.fit.lines`), pointing away from the corner along their
/// arms: the given face nearer to each arm through the centroid of its side when the faces
/// are known, the shared local fit of the side otherwise.
fn fit_local_lines(
    s: &mut ProfileScratch,
    arm_line: &[Line2; 2],
    known: &ProfileKnown,
    params: &FitParams,
    sigma: [f64; 2],
    sides: &[Vec<usize>; 2],
) -> Result<()> {
    s.fit.lines.clear();
    for k in 0..2 {
        let away = &arm_line[k].direction;
        let line = match known.slopes {
            Some(slopes) => {
                let d = nearest_face(&slopes, away)?;
                line_through_centroid(&s.fit.loc, &sides[k], d).oriented(away)
            }
            None => local_fit(
                &s.fit.loc,
                &sides[k],
                params,
                sigma[k],
                &mut s.fit.buf,
                away,
            )?,
        };
        s.fit.lines.push(line);
    }
    Ok(())
}

/// Of the given face directions, the one most nearly along `arm` (unit).
fn nearest_face(slopes: &[[f64; 2]; 2], arm: &[f64; 2]) -> Result<[f64; 2]> {
    slopes
        .iter()
        .copied()
        .max_by(|a, b| dot(a, arm).abs().total_cmp(&dot(b, arm).abs()))
        .and_then(unit)
        .ok_or_else(|| Error::Degenerate {
            what: WHAT,
            why: "a given face direction is zero or not finite".into(),
        })
}

/// The points each constrained line is scored against: its side's points and, with
/// `include_corner_region`, the corner-region points nearer to its local line.
fn assign_points(p: &mut Prepared<2, FixedSlopes2>, out: &ProfileFit, include_corner_region: bool) {
    p.canon.clear();
    p.canon.extend([0, 1]);
    p.assigned.resize_with(2, Vec::new);
    for k in 0..2 {
        p.assigned[k].clear();
        p.assigned[k].extend_from_slice(&out.sides[k]);
    }
    if include_corner_region {
        let local = &p.lines;
        for &i in &out.corner_region {
            let k = usize::from(local[1].distance(&p.loc[i]) < local[0].distance(&p.loc[i]));
            p.assigned[k].push(i);
        }
    }
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

/// The searches on the problem prepared in `scratch`: Scheme 1, PSO, exact, and the
/// rectified corner-region points. Fills the rest of `out`.
pub fn solve_profile_2d<R: Rng + ?Sized>(
    params: &FitParams,
    rng: &mut R,
    scratch: &mut ProfileScratch,
    out: &mut ProfileFit,
) -> Result<()> {
    let p = &mut scratch.fit;
    let solved = method::solve::<2, Profile, R>(p, params, rng, &mut out.searches)?;
    out.scheme1_index = solved.scheme1_at;
    // A corner-region point belongs to neither side: it goes to the nearer half-line.
    let rays = [out.local[0].direction, out.local[1].direction];
    method::rectify(
        &solved.frame,
        &p.loc,
        &out.searches.corner(params.rectify_with).point,
        out.corner_region.iter().map(|&i| (i, &rays[..])),
        &mut out.rectified,
    );
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

fn cross2(a: &[f64; 2], b: &[f64; 2]) -> f64 {
    a[0] * b[1] - a[1] * b[0]
}

impl Case<2> for Profile {
    const WHAT: &'static str = WHAT;
    const APPROX: &'static str = "corner";

    fn sine(a: &[f64; 2], b: &[f64; 2]) -> f64 {
        cross2(a, b).abs()
    }
    const PARALLEL: &'static str = "the two sides are parallel (all points on one line?), so \
        there is no corner to fit; lower min_angle_deg only if the profile really is this flat";

    /// First axis along the bisector towards the tip (the abnormal zone lies inside the angle,
    /// the corner at its tip), second axis 90° counter-clockwise from it.
    fn swarm_basis(lines: &[Line2], canon: &[usize]) -> [[f64; 2]; 2] {
        let (a, b) = (lines[canon[0]].direction, lines[canon[1]].direction);
        let tip = unit(scale([a[0] + b[0], a[1] + b[1]], -1.0)).unwrap_or([-a[1], a[0]]);
        [tip, [-tip[1], tip[0]]]
    }

    /// On a narrow V the error is nearly flat along the bisector: a swarm started only on
    /// corner-region points (inside the V) stops inside it. The local fits' intersection
    /// centres it on the optimum region (`seed_with_intersection`).
    fn meeting_point(lines: &[Line2]) -> Option<[f64; 2]> {
        intersection(&lines[0], &lines[1])
    }

    type Objective = FixedSlopes2;
    /// The pair of medians (`exact_2d`).
    fn exact(p: &mut Prepared<2, FixedSlopes2>, _params: &FitParams) -> Result<Exact<2>> {
        exact_2d(&p.obj, &mut p.exact)
    }
    const CANDIDATES: &'static str = "2D profile fit: corner candidates";
    const PREPARE: &'static str = "prepare_profile_2d";
    const DIVERGED: &'static str = "the profile is";
}
