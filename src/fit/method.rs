//! The paper's fit stated once, for k lines meeting at one point in D dimensions (§2, §3):
//! everything the 2D profile fit (`profile`: D = 2, k = 2) and the 3D vertex fit (`corner`:
//! D = 3, k ≥ 2) share, written generic over the dimension.
//!
//! The method, in a local frame centred on the approximate corner and scaled by the points'
//! RMS radius ([`local_frame`]; see `problem` for why):
//! 1. Sides. Each side's points are ordered from its far end towards the corner
//!    ([`order_far_end_first`]), and the noise σ is estimated from the far halves of the sides
//!    against their own lines, unless it is given ([`noise`]).
//! 2. Propagation (§2.1) keeps from each side the points on one straight line, from the far
//!    end on; what is left near the corner is the corner region (the abnormal zone).
//! 3. Local fits (the paper's L2, L4) fix one slope per side ([`local_fit`]).
//! 4. The constrained problem ([`pose`]): k lines with those slopes through one common point q,
//!    the error of q the sum of the distances of the points to their own line (Eq. 11 / 13).
//!    It needs sides that are not all parallel; its candidates (Scheme 1's data points and
//!    the swarm's start) are the corner region and each side's last accepted point, grown to
//!    `min_particles` with the points nearest to their centre.
//! 5. Searches ([`solve`]): Scheme 1, the PSO (§3) in a frame attached to the side
//!    directions, and the exact minimum; then the corner-region points are moved onto the
//!    constrained half-lines from the chosen corner ([`rectify`]).
//!
//! What differs between the two cases is small, and named: the steps of each case that come
//! before the shared ones, and the implementations of [`Case`].
//! - 2D (`profile::Profile`): the points come unordered and unlabelled, so step 1 first splits
//!   them into two arms (spherical 2-means of the far points' directions, a line per cluster,
//!   every point to the nearer line) put in a canonical order (arm 1 turns counter-clockwise
//!   into arm 2); step 2 reads the profile as one polyline A..corner..B and propagates from
//!   both ends; a corner-region point belongs to neither side, so it is scored against, and
//!   rectified onto, the nearer line. The objective is a sum of absolute values (exact
//!   minimum: medians), the swarm's first axis is the bisector towards the tip, and the local
//!   lines meet at their intersection.
//! - 3D (`corner::Vertex`): the caller gives the k sides (one per edge meeting at the vertex),
//!   taken in a canonical order so that permuting them changes no bit; propagation runs along
//!   each side on its own, and a corner-region point stays with its edge. The objective is a
//!   sum of Euclidean norms (exact minimum: Weiszfeld/Newton), the swarm frame is built from
//!   the k directions, and the local lines meet at their least-squares point.
//!
//! Input: what a case's own steps leave in [`Prepared`] (local points, local fits, the
//! canonical side order, the points scored against each line, the candidates' seeds).
//! Output: the prepared [`Problem`] and, from [`solve`], the three corners in input
//! coordinates ([`Searches`], which both fit results hold).

use std::fmt::Debug;

use rand::Rng;

use super::exact::Exact;
use super::line::Line;
use super::objective::FixedSlopes;
use super::params::{FitParams, Searcher};
use super::problem::{Frame, Problem, grow_and_cap, nearest_on_rays, rms_radius};
use super::propagate::{line_residuals, noise_from_residuals, side_fit};
use super::pso::{Search, SwarmScratch, pso};
use super::scheme1::scheme1;
use crate::geometry::{dot, finite};
use crate::{Error, Result};

/// What the 2D profile fit and the 3D vertex fit do differently once their sides are known:
/// the objective and its exact minimum, the swarm's frame, where the local lines meet, and
/// the words of their errors. Grouped by the step that uses them.
pub(crate) trait Case<const D: usize> {
    /// The fit's name in errors, and what its approximate point is called ("corner",
    /// "vertex"): the words of the local frame's errors.
    const WHAT: &'static str;
    const APPROX: &'static str;

    /// |sin| of the angle between two unit directions, and why sides less than
    /// `min_angle_deg` apart cannot be fitted (the non-parallel check).
    fn sine(a: &[f64; D], b: &[f64; D]) -> f64;
    const PARALLEL: &'static str;

    /// The swarm's orthonormal frame (rows) from the local lines taken in `canon` order.
    fn swarm_basis(lines: &[Line<D>], canon: &[usize]) -> [[f64; D]; D];
    /// Where the local lines meet (their intersection, or least-squares point); `None` when
    /// they are (nearly) parallel.
    fn meeting_point(lines: &[Line<D>]) -> Option<[f64; D]>;

    /// The fixed-slope objective of this dimension (Eq. 11 or Eq. 13), and its exact minimum.
    type Objective: FixedSlopes<D> + Clone + Debug + Default;
    fn exact(p: &mut Prepared<D, Self::Objective>, params: &FitParams) -> Result<Exact<D>>;
    /// The searches' errors: the candidates' name when there are none, the preparing
    /// function when there is no problem, and what is too degenerate when the swarm leaves
    /// the finite range ("the profile is").
    const CANDIDATES: &'static str;
    const PREPARE: &'static str;
    const DIVERGED: &'static str;
}

/// The shared state of a fit: the prepared problem in the local frame, and the work buffers
/// both cases use. A case keeps one in its scratch struct.
#[derive(Clone, Debug)]
pub(crate) struct Prepared<const D: usize, O> {
    /// The map back to input coordinates; `None` until a preparation succeeds.
    pub(crate) frame: Option<Frame<D>>,
    /// All input points, local frame.
    pub(crate) loc: Vec<[f64; D]>,
    /// The local fit of each side (direction pointing away from the corner), side order.
    pub(crate) lines: Vec<Line<D>>,
    /// The order in which the objective and the swarm frame take the sides.
    pub(crate) canon: Vec<usize>,
    /// Per objective line (canonical order): indices into `loc` of the points scored
    /// against it.
    pub(crate) assigned: Vec<Vec<usize>>,
    /// Indices into `loc` of the candidates: the case writes the seeds (corner region, then
    /// each side's last accepted point), [`pose`] grows or caps them.
    pub(crate) cand_idx: Vec<usize>,
    /// Scratch: positions along a side (indexed like `loc`), residuals, points, indices.
    pub(crate) t: Vec<f64>,
    pub(crate) res: Vec<f64>,
    pub(crate) buf: Vec<[f64; D]>,
    pub(crate) order: Vec<usize>,
    /// The objective, and the candidates' extent (the exact solvers' scale).
    pub(crate) obj: O,
    pub(crate) cand_scale: f64,
    /// Scratch of the exact solver.
    pub(crate) exact: Vec<f64>,
    cand: Vec<[f64; D]>,
    basis: [[f64; D]; D],
    meeting: Option<[f64; D]>,
    flag: Vec<bool>,
    /// The swarm's starting positions (candidates, plus the lines' meeting point if asked).
    init: Vec<[f64; D]>,
    swarm: SwarmScratch<D>,
}

impl<const D: usize, O: Default> Default for Prepared<D, O> {
    fn default() -> Self {
        Prepared {
            frame: None,
            loc: Vec::new(),
            lines: Vec::new(),
            canon: Vec::new(),
            assigned: Vec::new(),
            cand_idx: Vec::new(),
            t: Vec::new(),
            res: Vec::new(),
            buf: Vec::new(),
            order: Vec::new(),
            obj: O::default(),
            cand_scale: 0.0,
            exact: Vec::new(),
            cand: Vec::new(),
            basis: [[0.0; D]; D],
            meeting: None,
            flag: Vec::new(),
            init: Vec::new(),
            swarm: SwarmScratch::default(),
        }
    }
}

impl<const D: usize, O> Prepared<D, O> {
    /// The search problem prepared by the last successful preparation.
    pub(crate) fn problem(&self) -> Option<Problem<'_, D, O>> {
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

/// Rejects a non-finite approximate corner.
pub(crate) fn check_approx<const D: usize, C: Case<D>>(approx: &[f64; D]) -> Result<()> {
    if finite(approx) {
        return Ok(());
    }
    Err(Error::Degenerate {
        what: C::WHAT,
        why: format!("the approximate {} {approx:?} is not finite", C::APPROX),
    })
}

/// The local frame: centred on `approx`, unit = the RMS distance of the `n` points from it.
/// `sum_sq` is Σ ‖p − approx‖², summed in the order the case fixes.
pub(crate) fn local_frame<const D: usize, C: Case<D>>(
    approx: [f64; D],
    sum_sq: f64,
    n: usize,
) -> Result<Frame<D>> {
    let rms = (sum_sq / n as f64).sqrt();
    if !rms.is_finite() || rms <= 0.0 {
        return Err(Error::Degenerate {
            what: C::WHAT,
            why: format!("all points coincide with the approximate {}", C::APPROX),
        });
    }
    Ok(Frame {
        origin: approx,
        unit: rms,
    })
}

/// Orders `run` (indices into `loc`) from its far end: by decreasing position along
/// `direction`, ties by index, so the input order does not matter. `t` (indexed like `loc`)
/// receives the positions.
pub(crate) fn order_far_end_first<const D: usize>(
    loc: &[[f64; D]],
    run: &mut [usize],
    direction: &[f64; D],
    t: &mut [f64],
) {
    for &i in run.iter() {
        t[i] = dot(loc[i], direction);
    }
    run.sort_by(|&a, &b| t[b].total_cmp(&t[a]).then(a.cmp(&b)));
}

/// The noise σ in local units: the given one, or the median distance of the far half of each
/// run (ordered far end first) from its own line, over the factor of the dimension. Never
/// below 1e-12, so the propagation's threshold is never zero.
pub(crate) fn noise<'a, const D: usize>(
    params: &FitParams,
    frame: &Frame<D>,
    loc: &[[f64; D]],
    runs: impl Iterator<Item = &'a [usize]>,
    res: &mut Vec<f64>,
) -> f64 {
    let sigma = match params.propagation.noise {
        Some(sg) => sg / frame.unit,
        None => far_half_noise(loc, runs, res),
    };
    sigma.max(1e-12)
}

/// The σ of the far halves of `runs` (each ordered far end first) against their own lines,
/// in the units of `loc`; 0 when they hold too few points. `res` is scratch.
pub(crate) fn far_half_noise<'a, const D: usize>(
    loc: &[[f64; D]],
    runs: impl Iterator<Item = &'a [usize]>,
    res: &mut Vec<f64>,
) -> f64 {
    res.clear();
    for run in runs {
        line_residuals(loc, &run[..run.len().div_ceil(2)], res);
    }
    noise_from_residuals::<D>(res).unwrap_or(0.0)
}

/// The local fit of one side's accepted points `run` (the paper's L2 / L4, in the form
/// `params` asks for, trimmed), its direction pointing towards `away` (away from the corner).
pub(crate) fn local_fit<const D: usize>(
    loc: &[[f64; D]],
    run: &[usize],
    params: &FitParams,
    sigma: f64,
    buf: &mut Vec<[f64; D]>,
    away: &[f64; D],
) -> Result<Line<D>> {
    Ok(side_fit(loc, run, params.line_form, params.trim, sigma, buf)?.oriented(away))
}

/// Step 4: the constrained problem from the local fits. Expects `lines`, `canon`, `assigned`
/// and the candidates' seeds in `cand_idx`; checks that the sides are not all parallel,
/// chooses the candidates, the swarm's frame and the scale of its initial velocities, builds
/// the objective and the lines' meeting point, and marks the problem prepared.
pub(crate) fn pose<const D: usize, C: Case<D>>(
    p: &mut Prepared<D, C::Objective>,
    params: &FitParams,
    sigma: f64,
    frame: Frame<D>,
) -> Result<()> {
    check_not_parallel::<D, C>(&p.lines, params)?;
    choose_candidates(p, params, sigma);
    p.basis = C::swarm_basis(&p.lines, &p.canon);
    p.obj.clear();
    for (&j, assigned) in p.canon.iter().zip(&p.assigned) {
        p.obj
            .add_line(&p.lines[j].direction, assigned.iter().map(|&i| &p.loc[i]));
    }
    p.meeting = C::meeting_point(&p.lines);
    p.frame = Some(frame);
    Ok(())
}

/// Fails when no two sides are at least `min_angle_deg` apart: (nearly) parallel sides have
/// no unique common point.
pub(crate) fn check_not_parallel<const D: usize, C: Case<D>>(
    lines: &[Line<D>],
    params: &FitParams,
) -> Result<()> {
    let sin_min = params.min_angle_deg.to_radians().sin();
    let mut widest: f64 = 0.0;
    for (a, la) in lines.iter().enumerate() {
        for lb in &lines[a + 1..] {
            widest = widest.max(C::sine(&la.direction, &lb.direction));
        }
    }
    if widest < sin_min {
        return Err(Error::Parallel {
            what: C::WHAT,
            why: C::PARALLEL,
        });
    }
    Ok(())
}

/// The candidates: the seeds grown to `min_particles` (and capped at `max_particles`) with
/// the points nearest to their centre; their extent (never below σ) scales the swarm's
/// initial velocities.
fn choose_candidates<const D: usize, O>(p: &mut Prepared<D, O>, params: &FitParams, sigma: f64) {
    grow_and_cap(
        &p.loc,
        &mut p.cand_idx,
        params.min_particles,
        params.max_particles,
        &mut p.flag,
        &mut p.order,
    );
    p.cand.clear();
    p.cand.extend(p.cand_idx.iter().map(|&i| p.loc[i]));
    p.cand_scale = rms_radius(&p.loc, p.cand_idx.iter().copied()).max(sigma);
}

/// The three searches' corners of a solved problem, in input coordinates: the part of the
/// result the 2D profile fit and the 3D vertex fit share.
#[derive(Clone, Debug, Default)]
pub struct Searches<const D: usize> {
    /// Scheme 1: the best candidate data point, with its error.
    pub scheme1: Search<D>,
    /// The particle swarm's corner.
    pub pso: Search<D>,
    /// Best error after each PSO iteration (index 0 = initial swarm), input units.
    pub pso_history: Vec<f64>,
    /// The exact minimum of the fixed-slope error.
    pub exact: Search<D>,
}

impl<const D: usize> Searches<D> {
    /// The corner found by `which`.
    pub fn corner(&self, which: Searcher) -> &Search<D> {
        match which {
            Searcher::Pso => &self.pso,
            Searcher::Scheme1 => &self.scheme1,
            Searcher::Exact => &self.exact,
        }
    }
}

/// What [`solve`] returns besides the [`Searches`] it fills: which local point Scheme 1
/// chose, and the frame the problem was solved in (to rectify in).
#[derive(Clone, Copy, Debug)]
pub(crate) struct Solved<const D: usize> {
    pub(crate) scheme1_at: usize,
    pub(crate) frame: Frame<D>,
}

/// Step 5: Scheme 1, the PSO (started from the candidates, plus the lines' meeting point when
/// `seed_with_intersection` asks) and the exact minimum on the prepared problem, written to
/// `out` (its `pso_history` reused). Fails on an unprepared problem, no candidates, or a
/// swarm that left the finite range; then only `out.pso_history` has been overwritten.
pub(crate) fn solve<const D: usize, C: Case<D>, R: Rng + ?Sized>(
    p: &mut Prepared<D, C::Objective>,
    params: &FitParams,
    rng: &mut R,
    out: &mut Searches<D>,
) -> Result<Solved<D>> {
    let Some(frame) = p.frame else {
        return Err(Error::Degenerate {
            what: C::WHAT,
            why: format!("no prepared problem; call {} first", C::PREPARE),
        });
    };
    let (ci, s1) = scheme1(&p.obj, &p.cand).ok_or(Error::TooFewPoints {
        what: C::CANDIDATES,
        needed: 1,
        got: 0,
    })?;
    p.init.clear();
    p.init.extend_from_slice(&p.cand);
    if params.seed_with_intersection
        && let Some(q) = p.meeting
    {
        p.init.push(q);
    }
    let swarm = pso(
        &p.obj,
        &p.init,
        &p.basis,
        p.cand_scale,
        &params.pso,
        params.pso.iterations(D),
        rng,
        &mut p.swarm,
        &mut out.pso_history,
    );
    let ex = C::exact(p, params)?;
    let to_input = |r: Search<D>| Search {
        point: frame.to_input(&r.point),
        error: frame.length_to_input(r.error),
        ..r
    };
    let swarm = to_input(swarm);
    for h in out.pso_history.iter_mut() {
        *h = frame.length_to_input(*h);
    }
    if !(swarm.error.is_finite() && finite(swarm.point)) {
        return Err(Error::Degenerate {
            what: C::WHAT,
            why: format!(
                "the swarm left the finite range; {} too degenerate to fit",
                C::DIVERGED
            ),
        });
    }
    out.scheme1 = to_input(s1);
    out.pso = swarm;
    out.exact = to_input(Search {
        point: ex.point,
        error: ex.error,
        evaluations: ex.iterations,
        converged_at: ex.iterations,
    });
    Ok(Solved {
        scheme1_at: p.cand_idx[ci],
        frame,
    })
}

/// Rectification: each corner-region point (an index into `loc`, with the directions of the
/// half-lines it may go to) moved to its nearest point on those half-lines from `corner`
/// (input coordinates), appended to `out` in input coordinates.
pub(crate) fn rectify<'a, const D: usize>(
    frame: &Frame<D>,
    loc: &[[f64; D]],
    corner: &[f64; D],
    region: impl Iterator<Item = (usize, &'a [[f64; D]])>,
    out: &mut Vec<[f64; D]>,
) {
    let q = frame.to_local(corner);
    out.clear();
    for (i, rays) in region {
        let (foot, _) = nearest_on_rays(&loc[i], &q, rays);
        out.push(frame.to_input(&foot));
    }
}
