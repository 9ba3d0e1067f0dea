//! The paper's 3D case as the pipeline meets it: k ≥ 2 edges meeting at a vertex (3 at a box
//! corner, 4 at a pyramid apex), each given as the 3D points of one edge (the rectified edge
//! points), plus an approximate vertex.
//!
//! The fit is the method of `method` (stated once for k lines in D dimensions: local frame,
//! sides ordered far end first, noise, propagation, local fits, the constrained problem, the
//! searches, rectification) with the 3D specifics here, all in the local frame centred on the
//! approximate vertex:
//! - The sides are the caller's k runs. They are taken in a canonical order (by point count,
//!   then by mean distance from the approximate vertex: `canonical_order`), so permuting the
//!   sides does not change the random draws or any sum over sides.
//! - Per side, a total-least-squares line orients the side away from the vertex and orders its
//!   points far end first (`order_sides`); line propagation (§2.1) runs along each side on
//!   its own and splits it into its straight part and its share of the corner region, and
//!   the local fit (PCA or the paper's Eq. 2–8 form) of the straight part fixes its slope
//!   (`propagate_and_fit_sides`).
//! - A corner-region point stays with its edge: it is scored against its own side's line
//!   (`assign_runs`) and rectified onto its own side's constrained half-line. The error is a
//!   sum of Euclidean norms (Eq. 13), minimised exactly by Weiszfeld/Newton; the swarm's
//!   frame is built from the k directions (10 PSO iterations); the local lines meet at their
//!   least-squares point (the `Case` implementation `Vertex`).
//!
//! Input: the sides, the approximate vertex, [`FitParams`], an RNG. Output: a [`CornerFit`]
//! whose per-side fields are in the caller's side order.

use rand::Rng;

use super::exact::{Exact, exact_3d};
use super::line::{Line, Line3, LineAcc};
use super::method::{self, Case, Prepared, Searches, local_fit, order_far_end_first, pose};
use super::objective::FixedSlopes3;
use super::params::FitParams;
use super::problem::{Frame, Problem};
use super::propagate::propagate_run;
use crate::geometry::{cross, finite, norm, norm2, sub};
use crate::{Error, Result};

const WHAT: &str = "3D corner fit";

/// The 3D specifics of the shared method (see `method`): k ≥ 2 lines, the objective of
/// Eq. 13.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Vertex;

/// A point of one side: (side, index within that side's slice), in the caller's numbering.
pub type SidePoint = (usize, usize);

/// Result of [`super::fit_corner_3d`], in input coordinates; per-side vectors follow the
/// caller's side order. Reuse one across calls with [`super::fit_corner_3d_with`].
#[derive(Clone, Debug, Default)]
pub struct CornerFit {
    /// Local fit of each side (direction pointing away from the vertex).
    pub lines: Vec<Line3>,
    /// Per side: indices of the points the local fit was made from (far end first).
    pub sides: Vec<Vec<usize>>,
    /// The corner-region points (left by the propagation near the vertex).
    pub corner_region: Vec<SidePoint>,
    /// The PSO's starting particles and Scheme 1's candidates.
    pub candidates: Vec<SidePoint>,
    /// Noise level σ used by the propagation, input units.
    pub noise: f64,
    /// Scheme 1's, the PSO's and the exact corner.
    pub searches: Searches<3>,
    /// Which data point Scheme 1's corner is.
    pub scheme1_point: SidePoint,
    /// For each corner-region point: its projection onto its own side's constrained
    /// half-line from the `rectify_with` corner.
    pub rectified: Vec<[f64; 3]>,
}

impl CornerFit {
    /// The constrained lines through `corner`: one per side, with the local slopes.
    pub fn lines_through(&self, corner: &[f64; 3]) -> impl Iterator<Item = Line3> + '_ {
        let c = *corner;
        self.lines.iter().map(move |l| Line {
            point: c,
            direction: l.direction,
        })
    }
}

/// Work buffers for the 3D corner fit; keep one per thread.
#[derive(Clone, Debug, Default)]
pub struct CornerScratch {
    /// The shared method's problem and buffers; its points are all sides' points,
    /// concatenated in the caller's side order.
    fit: Prepared<3, FixedSlopes3>,
    /// Where each side starts among the local points (one more entry than sides).
    start: Vec<usize>,
    /// Per side (caller order): indices into the local points, far end first.
    runs: Vec<Vec<usize>>,
    /// Per side: Σ ‖p − approx‖², and the mean distance from the approximate vertex.
    sq: Vec<f64>,
    mean_r: Vec<f64>,
    /// Per side: its overall direction, pointing away from the vertex (the propagation's
    /// prior).
    prior: Vec<[f64; 3]>,
    /// Per side: how many of its points (far end first) the propagation accepted.
    accepted: Vec<usize>,
}

impl CornerScratch {
    /// The search problem prepared by the last successful [`prepare_corner_3d`]. Its lines
    /// (and `assigned`) are in the canonical side order.
    pub fn problem(&self) -> Option<Problem<'_, 3, FixedSlopes3>> {
        self.fit.problem()
    }

    /// Side and index of a point of the concatenated local array.
    fn side_point(&self, g: usize) -> SidePoint {
        let side = self.start.partition_point(|&s| s <= g) - 1;
        (side, g - self.start[side])
    }
}

/// Everything up to the prepared search problem (left in `scratch`); fills `out`'s lines,
/// sides, corner region, candidates and noise. The searches are [`solve_corner_3d`].
pub fn prepare_corner_3d(
    sides: &[&[[f64; 3]]],
    approx: [f64; 3],
    params: &FitParams,
    scratch: &mut CornerScratch,
    out: &mut CornerFit,
) -> Result<()> {
    let frame = to_local_frame(scratch, sides, approx, params)?;
    let s = scratch;

    order_sides(s, sides.len())?;
    let runs = s.runs.iter().map(Vec::as_slice);
    let sigma = method::noise(params, &frame, &s.fit.loc, runs, &mut s.fit.res);
    propagate_and_fit_sides(s, sigma, params, params.min_side(), &frame, out)?;
    seed_candidates(s, out);
    assign_runs(s, params.include_corner_region);
    pose::<3, Vertex>(&mut s.fit, params, sigma, frame)?;

    out.candidates.clear();
    out.candidates
        .extend(s.fit.cand_idx.iter().map(|&g| s.side_point(g)));
    out.noise = frame.length_to_input(sigma);
    Ok(())
}

/// Rejects what cannot be fitted: fewer than two sides, a side with fewer than `min_side`
/// points, a non-finite point or approximate vertex.
fn check_sides(sides: &[&[[f64; 3]]], approx: &[f64; 3], min_side: usize) -> Result<()> {
    if sides.len() < 2 {
        return Err(Error::TooFewPoints {
            what: "3D corner fit: sides (edges meeting at the vertex)",
            needed: 2,
            got: sides.len(),
        });
    }
    for (j, side) in sides.iter().enumerate() {
        if side.len() < min_side {
            return Err(Error::SideTooSmall {
                fit: WHAT,
                side: j + 1,
                needed: min_side,
                got: side.len(),
                hint: "give each edge more points near the vertex or lower min_side_points",
            });
        }
        if let Some(i) = side.iter().position(|p| !finite(p)) {
            return Err(Error::Degenerate {
                what: WHAT,
                why: format!(
                    "point {i} of side {} has a non-finite coordinate {:?}; remove it first",
                    j + 1,
                    side[i]
                ),
            });
        }
    }
    method::check_approx::<3, Vertex>(approx)
}

/// The local frame (centred on the approximate vertex, unit = the points' RMS distance from
/// it, summed in canonical side order), and all sides' points in it. First forgets the last
/// prepared problem (a failed preparation leaves none for the searches) and rejects what
/// cannot be fitted ([`check_sides`]).
fn to_local_frame(
    s: &mut CornerScratch,
    sides: &[&[[f64; 3]]],
    approx: [f64; 3],
    params: &FitParams,
) -> Result<Frame<3>> {
    s.fit.frame = None;
    check_sides(sides, &approx, params.min_side())?;
    canonical_order(s, sides, &approx);
    let total: usize = sides.iter().map(|s| s.len()).sum();
    let sum_sq = s.fit.canon.iter().map(|&j| s.sq[j]).sum::<f64>();
    let frame = method::local_frame::<3, Vertex>(approx, sum_sq, total)?;
    to_local(s, sides, &frame);
    Ok(frame)
}

/// Canonical side order (`s.fit.canon`), from quantities that do not change under rotation,
/// translation or scaling: point count, then the mean distance from the approximate vertex.
/// Everything that sums over sides runs in this order, so permuting the sides changes no bit.
/// Leaves each side's Σ ‖p − approx‖² in `s.sq`.
fn canonical_order(s: &mut CornerScratch, sides: &[&[[f64; 3]]], approx: &[f64; 3]) {
    let k = sides.len();
    s.sq.clear();
    s.sq.resize(k, 0.0);
    s.mean_r.clear();
    s.mean_r.resize(k, 0.0);
    for (j, side) in sides.iter().enumerate() {
        for p in side.iter() {
            let d2 = norm2(sub(p, approx));
            s.sq[j] += d2;
            s.mean_r[j] += d2.sqrt();
        }
        s.mean_r[j] /= side.len() as f64;
    }
    let mean_r = &s.mean_r;
    let canon = &mut s.fit.canon;
    canon.clear();
    canon.extend(0..k);
    canon.sort_by(|&a, &b| {
        sides[a]
            .len()
            .cmp(&sides[b].len())
            .then(mean_r[a].total_cmp(&mean_r[b]))
            .then(a.cmp(&b))
    });
}

/// All sides' points in the local frame, concatenated in the caller's order; `s.start` marks
/// where each side starts.
fn to_local(s: &mut CornerScratch, sides: &[&[[f64; 3]]], frame: &Frame<3>) {
    s.fit.loc.clear();
    s.start.clear();
    for side in sides {
        s.start.push(s.fit.loc.len());
        s.fit.loc.extend(side.iter().map(|p| frame.to_local(p)));
    }
    s.start.push(s.fit.loc.len());
}

/// Per side: its overall direction (`s.prior`, pointing away from the vertex) and its points
/// ordered far end first along it (`s.runs`). Fails on a side whose points all coincide.
fn order_sides(s: &mut CornerScratch, k: usize) -> Result<()> {
    let loc = &s.fit.loc;
    s.runs.resize_with(k, Vec::new);
    s.fit.t.clear();
    s.fit.t.resize(loc.len(), 0.0);
    s.prior.clear();
    for j in 0..k {
        let r = s.start[j]..s.start[j + 1];
        let Some(d) = outward_direction(&loc[r.clone()]) else {
            return Err(Error::Degenerate {
                what: WHAT,
                why: format!(
                    "all points of side {} coincide; an edge needs a direction",
                    j + 1
                ),
            });
        };
        s.prior.push(d);
        let o = &mut s.runs[j];
        o.clear();
        o.extend(r);
        order_far_end_first(loc, o, &d, &mut s.fit.t);
    }
    Ok(())
}

/// The direction of the total-least-squares line of one side's points, pointing from the
/// vertex (the local origin) towards their centroid; `None` when the points coincide.
fn outward_direction(pts: &[[f64; 3]]) -> Option<[f64; 3]> {
    let mut acc = LineAcc::default();
    let mut centroid = [0.0; 3];
    for p in pts {
        acc.push(p);
        for a in 0..3 {
            centroid[a] += p[a];
        }
    }
    let (_, line) = acc.fit()?;
    Some(line.oriented(&centroid).direction)
}

/// Per side (caller order): line propagation (§2.1) from the far end, then the local fit of
/// the accepted points, pointing away from the vertex (from the last accepted point towards
/// the far end). Fills `s.accepted`, the local lines, `out.lines` and `out.sides`. Fails on a
/// side that keeps fewer than `min_side` points, before fitting the sides after it.
fn propagate_and_fit_sides(
    s: &mut CornerScratch,
    sigma: f64,
    params: &FitParams,
    min_side: usize,
    frame: &Frame<3>,
    out: &mut CornerFit,
) -> Result<()> {
    let k = s.runs.len();
    let loc = &s.fit.loc;
    out.sides.resize_with(k, Vec::new);
    out.lines.clear();
    s.fit.lines.clear();
    s.accepted.clear();
    s.accepted.resize(k, 0);
    for j in 0..k {
        let o = &s.runs[j];
        let accepted = propagate_run(loc, o, sigma, &params.propagation, Some(s.prior[j]));
        s.accepted[j] = accepted;
        if accepted < min_side {
            return Err(Error::SideTooSmall {
                fit: WHAT,
                side: j + 1,
                needed: min_side,
                got: accepted,
                hint: "the edge turns at once; check that it is straight near the vertex or \
                       lower min_side_points",
            });
        }
        let outward = sub(loc[o[0]], loc[o[accepted - 1]]);
        let l = local_fit(loc, &o[..accepted], params, sigma, &mut s.fit.buf, &outward)?;
        s.fit.lines.push(l);
        out.lines.push(frame.line_to_input(&l));
        out.sides[j].clear();
        out.sides[j].extend(o[..accepted].iter().map(|&g| g - s.start[j]));
    }
    Ok(())
}

/// The candidates' seeds, in canonical side order: every side's corner-region points, then
/// every side's last accepted point. Also the corner region into `out` (caller order).
fn seed_candidates(s: &mut CornerScratch, out: &mut CornerFit) {
    let (runs, accepted) = (&s.runs, &s.accepted);
    let cand = &mut s.fit.cand_idx;
    cand.clear();
    for &j in &s.fit.canon {
        cand.extend_from_slice(&runs[j][accepted[j]..]);
    }
    for &j in &s.fit.canon {
        cand.push(runs[j][accepted[j] - 1]);
    }
    out.corner_region.clear();
    for (j, o) in runs.iter().enumerate() {
        out.corner_region
            .extend(o[accepted[j]..].iter().map(|&g| (j, g - s.start[j])));
    }
}

/// The points each constrained line (canonical order) is scored against: its side's accepted
/// points and, with `include_corner_region`, the rest of its side too (a corner-region point
/// stays with its edge).
fn assign_runs(s: &mut CornerScratch, include_corner_region: bool) {
    s.fit.assigned.resize_with(s.runs.len(), Vec::new);
    for (slot, &j) in s.fit.canon.iter().enumerate() {
        let o = &s.runs[j];
        let a = &mut s.fit.assigned[slot];
        a.clear();
        let upto = if include_corner_region {
            o.len()
        } else {
            s.accepted[j]
        };
        a.extend_from_slice(&o[..upto]);
    }
}

/// The searches on the problem prepared in `scratch`: Scheme 1, PSO, exact, and the
/// rectified corner-region points. Fills the rest of `out`.
pub fn solve_corner_3d<R: Rng + ?Sized>(
    params: &FitParams,
    rng: &mut R,
    scratch: &mut CornerScratch,
    out: &mut CornerFit,
) -> Result<()> {
    let s = scratch;
    let solved = method::solve::<3, Vertex, R>(&mut s.fit, params, rng, &mut out.searches)?;
    out.scheme1_point = s.side_point(solved.scheme1_at);
    // A corner-region point stays with its edge: it goes onto its own side's half-line.
    let (start, lines) = (&s.start, &s.fit.lines);
    method::rectify(
        &solved.frame,
        &s.fit.loc,
        &out.searches.corner(params.rectify_with).point,
        out.corner_region
            .iter()
            .map(|&(j, i)| (start[j] + i, std::slice::from_ref(&lines[j].direction))),
        &mut out.rectified,
    );
    Ok(())
}

/// The point with the least sum of squared distances to the lines (point, unit direction);
/// `None` when they are (nearly) parallel. Normal equations of Σ‖(I − d dᵀ)(q − p)‖².
fn lines_meeting_point(lines: &[Line3]) -> Option<[f64; 3]> {
    let mut a = [[0.0f64; 3]; 3];
    let mut b = [0.0f64; 3];
    for l in lines {
        let d = l.direction;
        for r in 0..3 {
            for c in 0..3 {
                let m = f64::from(u8::from(r == c)) - d[r] * d[c];
                a[r][c] += m;
                b[r] += m * l.point[c];
            }
        }
    }
    let det = a[0][0] * (a[1][1] * a[2][2] - a[1][2] * a[2][1])
        - a[0][1] * (a[1][0] * a[2][2] - a[1][2] * a[2][0])
        + a[0][2] * (a[1][0] * a[2][1] - a[1][1] * a[2][0]);
    // The matrix is a sum of projectors: its determinant vanishes for parallel lines.
    if det.abs() < 1e-9 * (lines.len() as f64).powi(3) {
        return None;
    }
    let solve = |col: usize| {
        let mut m = a;
        for r in 0..3 {
            m[r][col] = b[r];
        }
        m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
            - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
            + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0])
    };
    let q = [solve(0) / det, solve(1) / det, solve(2) / det];
    q.iter().all(|x| x.is_finite()).then_some(q)
}

impl Case<3> for Vertex {
    const WHAT: &'static str = WHAT;
    const APPROX: &'static str = "vertex";

    fn sine(a: &[f64; 3], b: &[f64; 3]) -> f64 {
        norm(cross(a, b))
    }
    const PARALLEL: &'static str = "all sides are parallel, so they have no unique common \
        point; these edges continue each other rather than meet at a vertex";

    /// The swarm's orthonormal frame, from the side directions taken in canonical order (so it
    /// turns with the data and does not depend on the caller's side order): the first axis points
    /// from the inside of the corner towards its tip (minus the sum of the outward directions),
    /// the second is the first canonical side's direction made perpendicular to it, the third
    /// completes a right-handed frame.
    fn swarm_basis(local: &[Line3], canon: &[usize]) -> [[f64; 3]; 3] {
        let mut sum = [0.0; 3];
        for &j in canon {
            sum = crate::geometry::add(sum, local[j].direction);
        }
        let first = local[canon[0]].direction;
        let e1 = if norm(sum) > 0.05 * canon.len() as f64 {
            crate::geometry::scale(sum, -1.0 / norm(sum))
        } else {
            // The directions (nearly) cancel, e.g. a flat cross: use the normal of two of them.
            canon[1..]
                .iter()
                .map(|&j| cross(first, local[j].direction))
                .max_by(|a, b| norm(a).total_cmp(&norm(b)))
                .and_then(crate::geometry::unit)
                .unwrap_or([0.0, 0.0, 1.0])
        };
        let e2 = canon
            .iter()
            .map(|&j| crate::geometry::reject(local[j].direction, e1))
            .find(|v| norm(v) > 0.1)
            .and_then(crate::geometry::unit)
            .unwrap_or_else(|| crate::geometry::perp_basis(&e1).0);
        [e1, e2, cross(e1, e2)]
    }

    fn meeting_point(lines: &[Line3]) -> Option<[f64; 3]> {
        lines_meeting_point(lines)
    }

    type Objective = FixedSlopes3;
    /// Weiszfeld / IRLS with Newton steps (`exact_3d`), tolerances relative to the
    /// candidates' extent.
    fn exact(p: &mut Prepared<3, FixedSlopes3>, params: &FitParams) -> Result<Exact<3>> {
        exact_3d(&p.obj, p.cand_scale, &params.exact)
    }
    const CANDIDATES: &'static str = "3D corner fit: corner candidates";
    const PREPARE: &'static str = "prepare_corner_3d";
    const DIVERGED: &'static str = "the sides are";
}
