//! All parameters of the corner fits in one plain struct with the paper's defaults, so the
//! pipeline can fill it from the `[fit]` table of pipeline.toml (serde, unknown keys refused)
//! and check it once with [`FitParams::validate`].

use serde::{Deserialize, Serialize};

use super::exact::ExactParams;
use super::ga::GaParams;
use super::line::LineForm;
use super::propagate::PropagationParams;
use super::pso::PsoParams;
use crate::{Error, Result};

/// Which corner the rectified positions are computed from.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Searcher {
    /// The particle swarm's corner (the paper's Scheme 2).
    #[default]
    Pso,
    /// The best corner-region data point (the paper's Scheme 1).
    Scheme1,
    /// The exact minimum of the fixed-slope error.
    Exact,
}

/// Parameters of [`super::fit_profile_2d`] and [`super::fit_corner_3d`].
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct FitParams {
    /// Particle swarm (paper §3).
    pub pso: PsoParams,
    /// Genetic algorithm (only used by the experiment's comparison).
    pub ga: GaParams,
    /// Line propagation (paper §2.1).
    pub propagation: PropagationParams,
    /// Tolerances of the exact solver.
    pub exact: ExactParams,
    /// Form of the local side fits L2, L4.
    pub line_form: LineForm,
    /// Fewest points a side may keep after propagation.
    pub min_side_points: usize,
    /// Side lines closer to parallel than this (degrees) have no well-defined corner.
    pub min_angle_deg: f64,
    /// Count the corner-region points in the error (each against its nearer local line), as
    /// the paper's "every discrete data point" does; `false` scores the side points only.
    pub include_corner_region: bool,
    /// Also start one particle at the meeting point of the local side lines (the piecewise
    /// estimate; least squares for k ≥ 3 lines in 3D). A scanned vertex lies beyond its data —
    /// the edges' rectified points stop short of it — and a swarm started on data points alone
    /// only contracts within them; on a narrow 2D profile the error is nearly flat along the
    /// bisector and a swarm started inside the V stops there (measured: 0.26 spacings of bias
    /// on a 54° edge). Scheme 1 still chooses among data points only. Off in the paper (and the
    /// experiment); on in the pipeline.
    pub seed_with_intersection: bool,
    /// Fewest particles / Scheme 1 candidates; a smaller corner region is grown by the data
    /// points nearest to its centre. The paper has one particle per corner-region point; with
    /// a clean propagation that region can be just C, D and a point or two, and a swarm that
    /// small (with the paper's r ≤ 0.2) rarely reaches the optimum. Measured with
    /// `sharpedge experiment --trials 1000 --min-particles N`: PSO within 1 % of the exact
    /// minimum in 80 % / 98 % / 100 % of 2D trials for N = 5 / 10 / 20, and in 41 % / 73 % /
    /// 91 % of 3D trials (10 iterations).
    pub min_particles: usize,
    /// Most particles (the ones nearest the corner region's centre are kept); `None` = no cap,
    /// as in the paper (one particle per corner-region point).
    pub max_particles: Option<usize>,
    /// Side points farther than `trim` · σ from the first local fit are left out of a second
    /// one (robustness to outliers); 0 disables.
    pub trim: f64,
    /// The corner the rectified positions are computed from.
    pub rectify_with: Searcher,
}

impl Default for FitParams {
    fn default() -> Self {
        FitParams {
            pso: PsoParams::default(),
            ga: GaParams::default(),
            propagation: PropagationParams::default(),
            exact: ExactParams::default(),
            line_form: LineForm::Tls,
            min_side_points: 3,
            min_angle_deg: 2.0,
            include_corner_region: true,
            seed_with_intersection: false,
            min_particles: 20,
            max_particles: None,
            trim: 4.0,
            rectify_with: Searcher::Pso,
        }
    }
}

fn check(name: &'static str, value: f64, ok: bool, expected: &'static str) -> Result<()> {
    if ok && value.is_finite() {
        Ok(())
    } else {
        Err(Error::InvalidParameter {
            name,
            value: value.to_string(),
            expected,
        })
    }
}

impl FitParams {
    /// The fewest points a side may keep: `min_side_points`, never below the two a line needs.
    pub fn min_side(&self) -> usize {
        self.min_side_points.max(2)
    }

    /// Checks every value's range; the error names the parameter and the accepted range.
    pub fn validate(&self) -> Result<()> {
        let p = &self.pso;
        check(
            "pso.w",
            p.w,
            p.w >= 0.0 && p.w < 1.0,
            "0 <= w < 1 (a stable swarm)",
        )?;
        check("pso.c1", p.c1, p.c1 >= 0.0, "a finite value >= 0")?;
        check("pso.c2", p.c2, p.c2 >= 0.0, "a finite value >= 0")?;
        check("pso.r_max", p.r_max, p.r_max >= 0.0, "a finite value >= 0")?;
        check(
            "pso.v0_max",
            p.v0_max,
            p.v0_max >= 0.0,
            "a finite value >= 0",
        )?;
        let g = &self.ga;
        check("ga.alpha", g.alpha, g.alpha >= 0.0, "a finite value >= 0")?;
        check(
            "ga.mutation_rate",
            g.mutation_rate,
            (0.0..=1.0).contains(&g.mutation_rate),
            "a probability in [0, 1]",
        )?;
        check(
            "ga.mutation_scale",
            g.mutation_scale,
            g.mutation_scale >= 0.0,
            "a finite value >= 0",
        )?;
        let q = &self.propagation;
        check(
            "propagation.tolerance",
            q.tolerance,
            q.tolerance > 0.0,
            "a finite value > 0",
        )?;
        check(
            "propagation.backoff",
            q.backoff,
            q.backoff >= 0.0,
            "a finite value >= 0",
        )?;
        check(
            "propagation.patience",
            q.patience as f64,
            q.patience >= 1,
            "at least 1",
        )?;
        check(
            "propagation.init_points",
            q.init_points as f64,
            q.init_points >= 2,
            "at least 2",
        )?;
        check(
            "propagation.init_elongation",
            q.init_elongation,
            q.init_elongation >= 1.0,
            "a finite value >= 1",
        )?;
        if let Some(n) = q.noise {
            check(
                "propagation.noise",
                n,
                n > 0.0,
                "a finite noise level > 0 (or leave it out)",
            )?;
        }
        let e = &self.exact;
        check(
            "exact.tolerance",
            e.tolerance,
            e.tolerance > 0.0,
            "a finite value > 0",
        )?;
        check(
            "exact.max_iterations",
            e.max_iterations as f64,
            e.max_iterations >= 1,
            "at least 1",
        )?;
        check(
            "min_side_points",
            self.min_side_points as f64,
            self.min_side_points >= 2,
            "at least 2 (a line needs two points)",
        )?;
        check(
            "min_angle_deg",
            self.min_angle_deg,
            self.min_angle_deg > 0.0 && self.min_angle_deg < 90.0,
            "an angle in (0, 90) degrees",
        )?;
        check(
            "min_particles",
            self.min_particles as f64,
            self.min_particles >= 1,
            "at least 1",
        )?;
        if let Some(m) = self.max_particles {
            check(
                "max_particles",
                m as f64,
                m >= self.min_particles.max(1),
                "at least min_particles",
            )?;
        }
        check(
            "trim",
            self.trim,
            self.trim >= 0.0,
            "a finite value >= 0 (0 = off)",
        )?;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_are_the_papers_and_valid() {
        let p = FitParams::default();
        p.validate().unwrap();
        assert_eq!((p.pso.w, p.pso.c1, p.pso.c2), (0.6, 2.0, 2.0));
        assert_eq!((p.pso.r_max, p.pso.v0_max), (0.2, 0.2));
        assert_eq!((p.pso.iterations_2d, p.pso.iterations_3d), (20, 10));
    }

    #[test]
    fn a_toml_table_fills_the_params_and_bad_values_are_named() {
        let p: FitParams = toml::from_str(
            "min_particles = 8\nline_form = \"paper\"\n[pso]\nw = 0.5\n[propagation]\nnoise = 0.02\n",
        )
        .unwrap();
        assert_eq!(p.min_particles, 8);
        assert_eq!(p.line_form, LineForm::Paper);
        assert_eq!(p.pso.w, 0.5);
        assert_eq!(p.pso.c1, 2.0);
        assert_eq!(p.propagation.noise, Some(0.02));
        assert!(toml::from_str::<FitParams>("[pso]\nomega = 1\n").is_err());
        let mut bad = FitParams::default();
        bad.pso.w = 1.5;
        let e = bad.validate().unwrap_err().to_string();
        assert_eq!(
            e,
            "fit parameter pso.w = 1.5: expected 0 <= w < 1 (a stable swarm)"
        );
        let mut bad = FitParams::default();
        bad.propagation.noise = Some(f64::NAN);
        assert!(
            bad.validate()
                .unwrap_err()
                .to_string()
                .contains("propagation.noise = NaN")
        );
    }
}
