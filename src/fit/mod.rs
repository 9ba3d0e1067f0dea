//! The paper's method as pure geometry: line fits, line propagation, the constrained
//! multi-line objective, and the searchers for its corner (PSO, Scheme 1, GA, exact).
//!
//! No file I/O; every function is deterministic for a given RNG, and all random draws come
//! from the RNG the caller passes (derive it from the seed and the edge or corner id).
//!
//! # The two calls the pipeline makes
//!
//! ```text
//! fit_profile_2d(points: &[[f64; 2]], approx_corner: [f64; 2], params: &FitParams,
//!                rng: &mut impl Rng) -> Result<ProfileFit>
//! fit_corner_3d(sides: &[&[[f64; 3]]], approx: [f64; 3], params: &FitParams,
//!               rng: &mut impl Rng) -> Result<CornerFit>
//! ```
//!
//! - [`fit_profile_2d`] (paper §2.1, §3.1; one call per edge slab): an *unordered* 2D profile —
//!   two point arms meeting at a corner (V, L, obtuse, convex or concave) with a noisy or
//!   rounded abnormal zone — and the approximate corner (within the abnormal zone). Returns a
//!   [`ProfileFit`]: the side sets (`sides`, far end first), the corner region between C and D
//!   (`corner_region`), C and D, the local fits L2 and L4 (`local`, unit directions pointing
//!   away from the corner), the noise level used, the corner by Scheme 1, PSO and exactly
//!   (each a [`Search`] with point and error = sum of distances, Eq. 11), the PSO history, and
//!   `rectified`: for each corner-region point its nearest point on the two constrained
//!   half-lines from the corner chosen by `params.rectify_with`.
//! - [`fit_corner_3d`] (paper §2.2, §3.2; one call per vertex): k ≥ 2 sides (the rectified
//!   points of the edges meeting there) and the approximate vertex. Returns a [`CornerFit`]:
//!   per side the local line and the points used, the corner region, the common point by
//!   Scheme 1, PSO and exactly (errors by Eq. 13), the PSO history and rectified positions.
//! - Both have an allocation-free variant for hot loops, [`fit_profile_2d_with`] /
//!   [`fit_corner_3d_with`], which reuse a scratch struct and the output (one of each per rayon
//!   worker: `map_init(|| (ProfileScratch::default(), ProfileFit::default()), ...)`).
//! - [`FitParams`] is a plain serde struct with the paper's defaults (w = 0.6, c1 = c2 = 2,
//!   r1, r2 ~ U[0, 0.2], initial velocity ~ U[0, 0.2] × the corner region's extent, 20
//!   iterations in 2D and 10 in 3D, propagation tolerance 3σ); fill it from pipeline.toml and
//!   call [`FitParams::validate`] once.
//! - Degenerate input is an `Err`, never a panic or NaN: too few points on a side
//!   ([`crate::Error::TooFewPoints`], [`crate::Error::SideTooSmall`]), non-finite coordinates,
//!   coincident points, a single arm, parallel sides ([`crate::Error::Degenerate`]), and for the
//!   paper's raw line forms a line they cannot represent.
//!
//! # Invariances
//! Each fit works in a frame centred on the approximate corner and scaled by the points' RMS
//! radius, the swarm's random coefficients are scalars, and its initial velocities are drawn
//! along the sides' own directions. Translating, rotating or scaling the input (with the
//! approximate corner) therefore moves every found corner the same way (to rounding), and
//! permuting the sides of a 3D fit changes nothing.
//!
//! # The pieces (for tests, the experiment and other callers)
//! - [`line`]: TLS/PCA fits, the paper's forms (Eq. 2–8) with its rotation, [`LineAcc`].
//! - [`propagate`]: line propagation ([`propagate_run`], [`propagate_polyline`]).
//! - [`objective`]: [`FixedSlopes2`], [`FixedSlopes3`] (Eq. 11–14, k ≥ 2 lines) and
//!   [`JointSlopes`] (slopes re-fitted through q, for the joint refinement).
//! - [`pso`], [`ga`], [`scheme1`], [`exact`]: the searchers; each returns a [`Search`].
//! - [`prepare_profile_2d`] / [`prepare_corner_3d`] stop at the prepared [`Problem`]
//!   (`scratch.problem()`), so each searcher can be run and timed on its own.

pub mod corner;
pub mod exact;
pub mod ga;
pub mod line;
pub mod objective;
pub mod params;
pub mod problem;
pub mod profile;
pub mod propagate;
pub mod pso;
pub mod refine;
pub mod scheme1;
mod vec;

use rand::Rng;

pub use corner::{CornerFit, CornerScratch, SidePoint, prepare_corner_3d, solve_corner_3d};
pub use exact::{Exact, ExactParams, exact_2d, exact_3d};
pub use ga::{GaParams, GaScratch, ga, standard_normal};
pub use line::{
    Line, Line2, Line3, LineAcc, LineForm, PaperLine3, PaperRotation, fit_line, fit_line_2d_paper,
    fit_line_2d_paper_raw, fit_line_3d_paper, fit_line_3d_paper_raw, fit_line_form,
};
pub use objective::{FixedSlopes2, FixedSlopes3, JointSlopes, Objective, fitness};
pub use params::{FitParams, Searcher};
pub use problem::{Frame, Problem};
pub use profile::{ProfileFit, ProfileScratch, prepare_profile_2d, solve_profile_2d};
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
