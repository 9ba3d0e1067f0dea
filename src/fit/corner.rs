//! The paper's 3D case as the pipeline meets it: k ≥ 2 edges meeting at a vertex (3 at a box
//! corner, 4 at a pyramid apex), each given as the 3D points of one edge (the rectified edge
//! points), plus an approximate vertex.
//!
//! Steps, all in a local frame centred on the approximate vertex (see `problem`): per side, a
//! total-least-squares line orients the side away from the vertex and orders its points far
//! end first; line propagation (§2.1) splits each side into its straight part and its share of
//! the corner region; the local fits (PCA or the paper's Eq. 2–8 form) fix the slopes; Scheme
//! 1, the PSO (§3, 10 iterations) and the exact Weiszfeld/Newton solver find the common point.
//! Sides are processed in a canonical order (by point count, then by mean distance from the
//! approximate vertex), so permuting the sides does not change the random draws.
//!
//! Input: the sides, the approximate vertex, [`FitParams`], an RNG. Output: a [`CornerFit`]
//! whose per-side fields are in the caller's side order.

use rand::Rng;

use super::exact::exact_3d;
use super::line::{Line, Line3, LineAcc};
use super::objective::FixedSlopes3;
use super::params::{FitParams, Searcher};
use super::problem::{Frame, Problem, grow_and_cap, nearest_on_rays, rms_radius};
use super::propagate::{line_residuals, noise_from_residuals, propagate_run, side_fit};
use super::pso::{Search, SwarmScratch, pso};
use super::scheme1::scheme1;
use crate::geometry::{cross, dot, finite, norm, norm2, sub};
use crate::{Error, Result};

const WHAT: &str = "3D corner fit";

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
    /// Scheme 1's corner (a data point) and which one it is.
    pub scheme1: Search<3>,
    pub scheme1_point: SidePoint,
    /// The particle swarm's corner.
    pub pso: Search<3>,
    /// Best error after each PSO iteration (index 0 = initial swarm), input units.
    pub pso_history: Vec<f64>,
    /// The exact minimum of the fixed-slope error.
    pub exact: Search<3>,
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

    /// The corner found by `which`.
    pub fn corner(&self, which: Searcher) -> &Search<3> {
        match which {
            Searcher::Pso => &self.pso,
            Searcher::Scheme1 => &self.scheme1,
            Searcher::Exact => &self.exact,
        }
    }
}

/// Work buffers for the 3D corner fit; keep one per thread.
#[derive(Clone, Debug, Default)]
pub struct CornerScratch {
    loc: Vec<[f64; 3]>,
    start: Vec<usize>,
    canon: Vec<usize>,
    order: Vec<Vec<usize>>,
    t: Vec<f64>,
    res: Vec<f64>,
    buf: Vec<[f64; 3]>,
    cand_idx: Vec<usize>,
    cand: Vec<[f64; 3]>,
    basis: [[f64; 3]; 3],
    assigned: Vec<Vec<usize>>,
    flag: Vec<bool>,
    tmp: Vec<usize>,
    sq: Vec<f64>,
    mean_r: Vec<f64>,
    prior: Vec<[f64; 3]>,
    accepted: Vec<usize>,
    local: Vec<Line3>,
    obj: FixedSlopes3,
    swarm: SwarmScratch<3>,
    frame: Option<Frame<3>>,
    cand_scale: f64,
    /// The swarm's starting positions (candidates, plus the lines' meeting point if asked).
    init: Vec<[f64; 3]>,
    /// The least-squares meeting point of the local lines (local frame).
    meeting: Option<[f64; 3]>,
}

impl CornerScratch {
    /// The search problem prepared by the last successful [`prepare_corner_3d`]. Its lines
    /// (and `assigned`) are in the canonical side order.
    pub fn problem(&self) -> Option<Problem<'_, 3, FixedSlopes3>> {
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
    let s = scratch;
    s.frame = None;
    let k = sides.len();
    if k < 2 {
        return Err(Error::TooFewPoints {
            what: "3D corner fit: sides (edges meeting at the vertex)",
            needed: 2,
            got: k,
        });
    }
    let min_side = params.min_side_points.max(2);
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
    if !finite(&approx) {
        return Err(Error::Degenerate {
            what: WHAT,
            why: format!("the approximate vertex {approx:?} is not finite"),
        });
    }
    // Canonical side order, from quantities that do not change under rotation, translation or
    // scaling: point count, then the mean distance from the approximate vertex. Everything
    // that sums over sides runs in this order, so permuting the sides changes no bit.
    s.sq.clear();
    s.sq.resize(k, 0.0);
    s.mean_r.clear();
    s.mean_r.resize(k, 0.0);
    for (j, side) in sides.iter().enumerate() {
        for p in side.iter() {
            let d2 = norm2(&sub(p, &approx));
            s.sq[j] += d2;
            s.mean_r[j] += d2.sqrt();
        }
        s.mean_r[j] /= side.len() as f64;
    }
    let mean_r = &s.mean_r;
    s.canon.clear();
    s.canon.extend(0..k);
    s.canon.sort_by(|&a, &b| {
        sides[a]
            .len()
            .cmp(&sides[b].len())
            .then(mean_r[a].total_cmp(&mean_r[b]))
            .then(a.cmp(&b))
    });
    let total: usize = sides.iter().map(|s| s.len()).sum();
    let rms = (s.canon.iter().map(|&j| s.sq[j]).sum::<f64>() / total as f64).sqrt();
    if !rms.is_finite() || rms <= 0.0 {
        return Err(Error::Degenerate {
            what: WHAT,
            why: "all points coincide with the approximate vertex".into(),
        });
    }
    let frame = Frame {
        origin: approx,
        unit: rms,
    };
    s.loc.clear();
    s.start.clear();
    for side in sides {
        s.start.push(s.loc.len());
        s.loc.extend(side.iter().map(|p| frame.to_local(p)));
    }
    s.start.push(s.loc.len());
    let loc = &s.loc;

    // Per side: overall direction (outward), order far end first.
    s.order.resize_with(k, Vec::new);
    s.t.clear();
    s.t.resize(loc.len(), 0.0);
    s.prior.clear();
    for j in 0..k {
        let r = s.start[j]..s.start[j + 1];
        let mut acc = LineAcc::default();
        let mut centroid = [0.0; 3];
        for p in &loc[r.clone()] {
            acc.push(p);
            for a in 0..3 {
                centroid[a] += p[a];
            }
        }
        let Some((_, line)) = acc.fit() else {
            return Err(Error::Degenerate {
                what: WHAT,
                why: format!(
                    "all points of side {} coincide; an edge needs a direction",
                    j + 1
                ),
            });
        };
        let d = line.oriented(&centroid).direction;
        s.prior.push(d);
        for g in r.clone() {
            s.t[g] = dot(&loc[g], &d);
        }
        let o = &mut s.order[j];
        o.clear();
        o.extend(r.clone());
        let t = &s.t;
        o.sort_by(|&a, &b| t[b].total_cmp(&t[a]).then(a.cmp(&b)));
    }

    let sigma = match params.propagation.noise {
        Some(sg) => sg / frame.unit,
        None => {
            s.res.clear();
            for j in 0..k {
                let o = &s.order[j];
                line_residuals(loc, &o[..o.len().div_ceil(2)], &mut s.res);
            }
            noise_from_residuals::<3>(&mut s.res).unwrap_or(0.0)
        }
    };
    let sigma = sigma.max(1e-12);

    // Propagation and local fits.
    out.sides.resize_with(k, Vec::new);
    out.lines.clear();
    s.local.clear();
    out.corner_region.clear();
    s.cand_idx.clear();
    s.accepted.clear();
    s.accepted.resize(k, 0);
    let accepted = &mut s.accepted;
    for j in 0..k {
        let o = &s.order[j];
        accepted[j] = propagate_run(loc, o, sigma, &params.propagation, Some(s.prior[j]));
        if accepted[j] < min_side {
            return Err(Error::SideTooSmall {
                fit: WHAT,
                side: j + 1,
                needed: min_side,
                got: accepted[j],
                hint: "the edge turns at once; check that it is straight near the vertex or \
                       lower min_side_points",
            });
        }
        let l = side_fit(
            loc,
            &o[..accepted[j]],
            params.line_form,
            params.trim,
            sigma,
            &mut s.buf,
        )?;
        let outward = sub(&loc[o[0]], &loc[o[accepted[j] - 1]]);
        let l = l.oriented(&outward);
        s.local.push(l);
        out.lines.push(frame.line_to_input(&l));
        out.sides[j].clear();
        out.sides[j].extend(o[..accepted[j]].iter().map(|&g| g - s.start[j]));
    }
    let sin_min = params.min_angle_deg.to_radians().sin();
    let mut widest: f64 = 0.0;
    for a in 0..k {
        for b in a + 1..k {
            widest = widest.max(norm(&cross(&s.local[a].direction, &s.local[b].direction)));
        }
    }
    if widest < sin_min {
        return Err(Error::Degenerate {
            what: WHAT,
            why: "all sides are parallel, so they have no unique common point; these edges \
                  continue each other rather than meet at a vertex"
                .into(),
        });
    }

    // Corner region and candidates, in canonical side order.
    for &j in &s.canon {
        let o = &s.order[j];
        s.cand_idx.extend_from_slice(&o[accepted[j]..]);
    }
    for &j in &s.canon {
        s.cand_idx.push(s.order[j][accepted[j] - 1]);
    }
    for j in 0..k {
        let o = &s.order[j];
        out.corner_region
            .extend(o[accepted[j]..].iter().map(|&g| (j, g - s.start[j])));
    }
    grow_and_cap(
        loc,
        &mut s.cand_idx,
        params.min_particles,
        params.max_particles,
        &mut s.flag,
        &mut s.tmp,
    );
    s.cand.clear();
    s.cand.extend(s.cand_idx.iter().map(|&g| loc[g]));
    s.cand_scale = rms_radius(loc, s.cand_idx.iter().copied()).max(sigma);
    s.basis = swarm_basis(&s.canon, &s.local);

    // Objective, lines in canonical order: each side's points against its own line.
    s.assigned.resize_with(k, Vec::new);
    s.obj.clear();
    for (slot, &j) in s.canon.iter().enumerate() {
        let o = &s.order[j];
        let a = &mut s.assigned[slot];
        a.clear();
        let upto = if params.include_corner_region {
            o.len()
        } else {
            accepted[j]
        };
        a.extend_from_slice(&o[..upto]);
        s.obj
            .add_line(&s.local[j].direction, a.iter().map(|&g| &loc[g]));
    }
    out.candidates.clear();
    out.candidates
        .extend(s.cand_idx.iter().map(|&g| s.side_point(g)));
    out.noise = frame.length_to_input(sigma);
    s.meeting = lines_meeting_point(&s.local);
    s.frame = Some(frame);
    Ok(())
}

/// The swarm's orthonormal frame, from the side directions taken in canonical order (so it
/// turns with the data and does not depend on the caller's side order): the first axis points
/// from the inside of the corner towards its tip (minus the sum of the outward directions),
/// the second is the first canonical side's direction made perpendicular to it, the third
/// completes a right-handed frame.
fn swarm_basis(canon: &[usize], local: &[Line3]) -> [[f64; 3]; 3] {
    let mut sum = [0.0; 3];
    for &j in canon {
        sum = super::vec::add(&sum, &local[j].direction);
    }
    let first = local[canon[0]].direction;
    let e1 = if norm(&sum) > 0.05 * canon.len() as f64 {
        super::vec::scale(&sum, -1.0 / norm(&sum))
    } else {
        // The directions (nearly) cancel, e.g. a flat cross: use the normal of two of them.
        canon[1..]
            .iter()
            .map(|&j| cross(&first, &local[j].direction))
            .max_by(|a, b| norm(a).total_cmp(&norm(b)))
            .and_then(|c| super::vec::unit(&c))
            .unwrap_or([0.0, 0.0, 1.0])
    };
    let e2 = canon
        .iter()
        .map(|&j| super::vec::reject(&local[j].direction, &e1))
        .find(|v| norm(v) > 0.1)
        .and_then(|v| super::vec::unit(&v))
        .unwrap_or_else(|| super::vec::perp_basis(&e1).0);
    [e1, e2, cross(&e1, &e2)]
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
    let Some(frame) = s.frame else {
        return Err(Error::Degenerate {
            what: WHAT,
            why: "no prepared problem; call prepare_corner_3d first".into(),
        });
    };
    let (ci, s1) = scheme1(&s.obj, &s.cand).ok_or(Error::TooFewPoints {
        what: "3D corner fit: corner candidates",
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
        params.pso.iterations_3d,
        rng,
        &mut s.swarm,
        &mut hist,
    );
    s.init = init;
    let ex = exact_3d(&s.obj, s.cand_scale, &params.exact)?;
    let to_input = |r: Search<3>| Search {
        point: frame.to_input(&r.point),
        error: frame.length_to_input(r.error),
        ..r
    };
    out.scheme1 = to_input(s1);
    out.scheme1_point = s.side_point(s.cand_idx[ci]);
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
            why: "the swarm left the finite range; the sides are too degenerate to fit".into(),
        });
    }
    let q = frame.to_local(&out.corner(params.rectify_with).point);
    out.rectified.clear();
    for &(j, i) in &out.corner_region {
        let p = s.loc[s.start[j] + i];
        let (foot, _) = nearest_on_rays(&p, &q, std::slice::from_ref(&s.local[j].direction));
        out.rectified.push(frame.to_input(&foot));
    }
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
