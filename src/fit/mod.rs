//! The paper's method as pure geometry: line fits, line propagation, the constrained
//! multi-line objective, and the searchers for its corner (PSO, Scheme 1, GA, exact).
//!
//! No file I/O; every function is deterministic for a given RNG, and all random draws come
//! from the RNG the caller passes (derive it from the seed and the edge or corner id).
//!
//! # The two calls the pipeline makes
//!
//! ```text
//! fit_profile_2d<R: Rng + ?Sized>(points: &[[f64; 2]], approx_corner: [f64; 2],
//!                params: &FitParams, rng: &mut R) -> Result<ProfileFit>
//! fit_profile_2d_with(points, approx_corner, params, rng,
//!                     scratch: &mut ProfileScratch, out: &mut ProfileFit) -> Result<()>
//! fit_corner_3d<R: Rng + ?Sized>(sides: &[&[[f64; 3]]], approx: [f64; 3],
//!               params: &FitParams, rng: &mut R) -> Result<CornerFit>
//! fit_corner_3d_with(sides, approx, params, rng,
//!                    scratch: &mut CornerScratch, out: &mut CornerFit) -> Result<()>
//! ```
//!
//! - [`fit_profile_2d`] (paper §2.1, §3.1; one call per edge slab): an *unordered* 2D profile —
//!   two point arms meeting at a corner (V, L, obtuse, convex or concave) with a noisy or
//!   rounded abnormal zone, maybe a few outliers — and the approximate corner (somewhere in
//!   the abnormal zone; it centres the work frame and splits the arms). Returns a
//!   [`ProfileFit`] (all indices into `points`, all coordinates in input units):
//!   `sides[0..2]` (the points A..C and B..D, far end first, the local fits' data),
//!   `corner_region` (between C and D: the points to rectify), `candidates` (the swarm's
//!   start), `c`, `d`, `local` (L2 and L4: point + unit direction pointing away from the
//!   corner), `noise` (σ used), `searches` (a [`Searches`]: `scheme1` / `pso` / `exact`, each
//!   a [`Search`]: `point`, `error` = sum of point-to-line distances, Eq. 11, `evaluations`,
//!   `converged_at`; `pso_history`, the best error per iteration; `corner(which)`),
//!   `scheme1_index`, and `rectified`: for each corner-region point, its nearest point on the
//!   two constrained half-lines from the corner chosen by `params.rectify_with` (PSO by
//!   default). `lines_through(&corner)` gives the constrained lines L1, L3.
//! - [`fit_corner_3d`] (paper §2.2, §3.2; one call per vertex): k ≥ 2 sides (the rectified
//!   points of the edges meeting there; 3 at a box corner, 4 at a pyramid apex) and the
//!   approximate vertex. Returns a [`CornerFit`] whose per-side fields follow the caller's
//!   side order: `lines` (local fit per side, direction pointing away from the vertex),
//!   `sides` (indices used per side), `corner_region` and `candidates` as (side, index),
//!   `noise`, `searches` (errors by Eq. 13), `scheme1_point` and `rectified` (corner-region
//!   points projected onto their own side's constrained half-line).
//! - The `_with` variants reuse a scratch struct and the output, so a hot loop does not
//!   allocate once the buffers have grown: one of each per rayon worker, e.g.
//!   `map_init(|| (ProfileScratch::default(), ProfileFit::default()), ...)`.
//! - [`FitParams`] is a plain serde struct (`#[serde(default, deny_unknown_fields)]`) with the
//!   paper's defaults: `pso.w = 0.6`, `pso.c1 = pso.c2 = 2`, `pso.r_max = 0.2` (r1, r2 ~
//!   U[0, 0.2]), `pso.v0_max = 0.2` (initial velocity ~ U[0, 0.2] × the corner region's
//!   extent), `pso.iterations_2d = 20`, `pso.iterations_3d = 10`, `propagation.tolerance = 3`
//!   (in units of the noise σ, estimated unless `propagation.noise` is set), and
//!   `min_particles = 20` (see its documentation for why). Fill it from pipeline.toml and call
//!   [`FitParams::validate`] once.
//! - Degenerate input is an `Err`, never a panic or NaN: too few points
//!   ([`crate::Error::TooFewPoints`]) or too few on one side after propagation
//!   ([`crate::Error::SideTooSmall`], naming the side); non-finite coordinates, coincident
//!   points, a single arm, and for the paper's raw line forms a line they cannot represent
//!   ([`crate::Error::Degenerate`]); parallel sides, all points on one line
//!   ([`crate::Error::Parallel`]); parameters out
//!   of range ([`crate::Error::InvalidParameter`]).
//!
//! # Invariances
//! Each fit works in a frame centred on the approximate corner and scaled by the points' RMS
//! radius, and the swarm runs in an orthonormal frame built from the side directions (its
//! random coefficients drawn per coordinate of that frame). Translating, rotating or scaling
//! the input (with the approximate corner) therefore moves every found corner the same way, to
//! rounding; the order of the input points does not matter, and permuting the sides of a 3D
//! fit changes no bit of the corners. Tested by property tests to 1e-9 relative.
//!
//! # One method, two cases
//! The paper states its fit once, for k lines meeting at a point in D dimensions; so does the
//! code. `method` (private) holds the steps both fits share, generic over the dimension:
//! the local frame, sides ordered far end first, the noise, the local fits, the constrained
//! problem (non-parallel check, candidates, swarm frame, objective, the lines' meeting point),
//! the three searches and the rectification. [`profile`] (2D) and [`corner`] (3D) hold only
//! what differs: the 2D fit must first split an unordered profile into two arms (spherical
//! 2-means, canonical counter-clockwise order) and propagates along the polyline A..corner..B
//! from both ends; the 3D fit takes the k sides the caller gives, in a canonical order, and
//! propagates along each. The rest of the difference (objective and its exact minimum, swarm
//! frame, meeting point, error words) is the small trait `method::Case`, implemented once per
//! case.
//!
//! # The pieces (for tests, the experiment and other callers)
//! - [`line`]: TLS/PCA fits, the paper's forms (Eq. 2–8) with its rotation, [`LineAcc`].
//! - [`propagate`]: line propagation ([`propagate_run`], [`propagate_polyline`] for ordered
//!   polylines in 2D or 3D).
//! - [`objective`]: [`FixedSlopes2`], [`FixedSlopes3`] (Eq. 11–14, k ≥ 2 lines; both built
//!   through [`FixedSlopes`]) and [`JointSlopes`] (slopes re-fitted through q).
//! - [`pso`], [`ga`], [`scheme1`], [`exact`] (medians / LAD edge descent in 2D,
//!   Weiszfeld–Newton in 3D), [`refine_joint`]: the searchers; each returns a [`Search`].
//! - [`prepare_profile_2d`] / [`prepare_corner_3d`] stop at the prepared [`Problem`]
//!   (`scratch.problem()`), in the fit's local [`Frame`], so each searcher can be run and timed
//!   on its own; [`solve_profile_2d`] / [`solve_corner_3d`] finish the fit.

pub mod corner;
pub mod exact;
pub mod ga;
pub mod line;
mod method;
pub mod objective;
pub mod params;
pub mod problem;
pub mod profile;
pub mod propagate;
pub mod pso;
pub mod refine;
pub mod scheme1;

use rand::Rng;

pub use corner::{CornerFit, CornerScratch, SidePoint, prepare_corner_3d, solve_corner_3d};
pub use exact::{Exact, ExactParams, exact_2d, exact_3d};
pub use ga::{GaParams, GaScratch, ga, standard_normal};
pub use line::{
    Line, Line2, Line3, LineAcc, LineForm, PaperLine3, PaperRotation, fit_line, fit_line_2d_paper,
    fit_line_2d_paper_raw, fit_line_3d_paper, fit_line_3d_paper_raw, fit_line_form,
};
pub use method::Searches;
pub use objective::{FixedSlopes, FixedSlopes2, FixedSlopes3, JointSlopes, Objective, fitness};
pub use params::{FitParams, Searcher};
pub use problem::{Frame, Problem};
pub use profile::{ProfileFit, ProfileKnown, ProfileScratch, prepare_profile_2d, solve_profile_2d};
pub use propagate::{PolylineSplit, PropagationParams, propagate_polyline, propagate_run};
pub use pso::{PsoParams, Search, SwarmScratch, converged_at, pso};
pub use refine::refine_joint;
pub use scheme1::scheme1;

use crate::Result;

/// Fits the corner of an unordered 2D profile (see the module documentation).
pub fn fit_profile_2d<R: Rng + ?Sized>(
    points: &[[f64; 2]],
    approx_corner: [f64; 2],
    params: &FitParams,
    rng: &mut R,
) -> Result<ProfileFit> {
    let mut out = ProfileFit::default();
    fit_profile_2d_with(
        points,
        approx_corner,
        params,
        rng,
        &mut ProfileScratch::default(),
        &mut out,
    )?;
    Ok(out)
}

/// [`fit_profile_2d`] reusing `scratch` and `out` (no allocation once their buffers have
/// grown). On error `out` holds partial results and must not be used.
pub fn fit_profile_2d_with<R: Rng + ?Sized>(
    points: &[[f64; 2]],
    approx_corner: [f64; 2],
    params: &FitParams,
    rng: &mut R,
    scratch: &mut ProfileScratch,
    out: &mut ProfileFit,
) -> Result<()> {
    prepare_profile_2d(points, approx_corner, params, scratch, out)?;
    solve_profile_2d(params, rng, scratch, out)
}

/// [`fit_profile_2d_with`] with what the rest of the edge tells: the abnormal zone around the
/// approximate corner, and possibly the faces' directions (see [`ProfileKnown`]).
#[allow(clippy::too_many_arguments)]
pub fn fit_profile_2d_zone<R: Rng + ?Sized>(
    points: &[[f64; 2]],
    approx_corner: [f64; 2],
    known: &ProfileKnown,
    params: &FitParams,
    rng: &mut R,
    scratch: &mut ProfileScratch,
    out: &mut ProfileFit,
) -> Result<()> {
    profile::prepare_profile_2d_zone(points, approx_corner, known, params, scratch, out)?;
    solve_profile_2d(params, rng, scratch, out)
}

/// Fits the common point of k ≥ 2 edges meeting at a vertex (see the module documentation).
pub fn fit_corner_3d<R: Rng + ?Sized>(
    sides: &[&[[f64; 3]]],
    approx: [f64; 3],
    params: &FitParams,
    rng: &mut R,
) -> Result<CornerFit> {
    let mut out = CornerFit::default();
    fit_corner_3d_with(
        sides,
        approx,
        params,
        rng,
        &mut CornerScratch::default(),
        &mut out,
    )?;
    Ok(out)
}

/// [`fit_corner_3d`] reusing `scratch` and `out`.
pub fn fit_corner_3d_with<R: Rng + ?Sized>(
    sides: &[&[[f64; 3]]],
    approx: [f64; 3],
    params: &FitParams,
    rng: &mut R,
    scratch: &mut CornerScratch,
    out: &mut CornerFit,
) -> Result<()> {
    prepare_corner_3d(sides, approx, params, scratch, out)?;
    solve_corner_3d(params, rng, scratch, out)
}
