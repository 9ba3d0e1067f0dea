//! The accuracy benchmark: the pipeline on a suite of simulated scans, scored against their
//! ground truth (`sharpedge bench`).
//!
//! Input: [`BenchOptions`] — which cases, how many points, the seed of the simulated scans,
//! the pipeline settings, the thread count and where the CAD meshes are. Each case is made in
//! memory by [`crate::synth`], run through [`crate::pipeline::process`] and scored. Output: a
//! [`BenchReport`] with every metric per case (serialised as the bench JSON), and
//! [`table`], the text the command prints.
//!
//! All lengths are in units of the case's true spacing `h` (the synth grid pitch). Metrics
//! (see [`score`] for the geometry, [`oracle`] for the reference):
//! - corners: one-to-one matches within [`CORNER_TOL`] h; recall, precision, error of the
//!   particle swarm's corner and, on the same matches, of Scheme 1 and of the exact optimum;
//! - edges: recall = share of the true edge length within [`EDGE_TOL`] h of a found edge,
//!   precision = share of the found edge length within [`EDGE_TOL`] h of a true edge (both
//!   exact), RMS distance of the found edges' matched part to the true edges (sampled every
//!   [`SAMPLE_STEP`] h);
//! - rectification: mean distance of the true abnormal-zone points to the true surface before
//!   and after, and how many points far from every edge changed at all;
//! - the oracle (polyhedral parts only): planes fitted to each true face's points far from the
//!   edges, intersected; our errors are also given as ratios to it.
//!
//! A case that fails to generate or to run is reported with its error, not fatal: the bench
//! is an instrument, one broken case must not hide the others.

pub mod border;
pub mod frames;
pub mod oracle;
pub mod patterns;
pub mod random;
pub mod score;
pub mod seen;

use std::path::{Path, PathBuf};
use std::time::Instant;

use rayon::prelude::*;
use serde::Serialize;

use crate::config::Settings;
use crate::error::{Error, Result};
use crate::geometry::{V3, add, dist, dot, norm, point_segment};
use crate::left_out::LeftOut;
use crate::outcome::{CornerOut, Outcome};
use crate::pipeline::{self, LapClock};
use crate::progress::Progress;
use crate::synth::geom::derive;
use crate::synth::{self, GroundTruth, Part, PointTruth, Sampling, SynthParams};
use score::{EdgeScore, SegmentSet, polyline_segments, same_bits, score_edges, stats};
use seen::Stretches;

/// Points per case by default: the whole suite took 32–46 s on two shared cores when this was
/// chosen, three quarters of it in the pipeline's features stage (200,000 points: 16 s;
/// 1,000,000: 98 s).
pub const DEFAULT_POINTS: usize = 500_000;
/// A found corner matches a true one within this many spacings.
pub const CORNER_TOL: f64 = 3.0;
/// Edge recall and precision count length within this many spacings.
pub const EDGE_TOL: f64 = 2.0;
/// Points "away from edges", which must not move, are neither abnormal nor outliers and
/// lie farther from their nearest edge than that edge's abnormal zone (the rounding's tangent
/// distance) plus `AWAY_BEYOND` spacings plus `AWAY_SIGMAS` noise sigmas, and at least `AWAY`
/// spacings. The zone term matters for sharp wedges: a 1.5 h rounding of a 30° edge leaves
/// the faces 5.6 h from the edge, so a fixed 4 h would demand that rounded points stay put.
/// The noise term matters for noisy scans: a point's position along its face is uncertain by
/// σ, so at σ = 1 h no rectifier can tell a point 4 h from the edge from one on the rounding.
/// Five sigmas, not four: a box at 500,000 points has about 50,000 points within a few
/// spacings of its edges, and a Gaussian puts 3·10⁻⁵ of them more than 4σ inwards, about one
/// point that looks as if it lay on the rounding (seen at σ = 1 h: one point 7.9 h out moved
/// by its own 0.4 h of noise); beyond 5σ it is 3·10⁻⁷, none.
pub const AWAY: f64 = 4.0;
pub const AWAY_BEYOND: f64 = 2.0;
pub const AWAY_SIGMAS: f64 = 5.0;
/// Found edges are sampled this often (spacings) for their distance to the true edges.
pub const SAMPLE_STEP: f64 = 0.1;

/// The acceptance thresholds of issue 4.
pub mod limits {
    /// Polyhedral parts: corner recall and precision.
    pub const CORNER_RECALL: f64 = 1.0;
    pub const CORNER_PRECISION: f64 = 1.0;
    /// Polyhedral parts: edge recall and precision.
    pub const EDGE_RECALL: f64 = 0.98;
    pub const EDGE_PRECISION: f64 = 0.98;
    /// Polyhedral parts with noise 0.15 h: mean corner error and edge RMS, in spacings.
    pub const CORNER_ERROR: f64 = 0.05;
    pub const EDGE_RMS: f64 = 0.03;
    /// Every part: mean distance of abnormal points to the surface, after / before.
    pub const RECTIFY_RATIO: f64 = 0.3;
    /// Curved meshes (fandisk, anchor): edge recall and precision.
    pub const CURVED_EDGE: f64 = 0.9;
    /// Random parts (issue 17): corner and edge recall and precision, and the median corner
    /// error over the oracle's.
    pub const RANDOM_CORNER_RECALL: f64 = 0.98;
    pub const RANDOM_CORNER_PRECISION: f64 = 0.99;
    pub const RANDOM_EDGE_RECALL: f64 = 0.97;
    pub const RANDOM_EDGE_PRECISION: f64 = 0.99;
    pub const RANDOM_MEDIAN_CORNER_TO_ORACLE: f64 = 2.0;
    /// CAD meshes (issue 17): edge recall and precision, corner recall and precision.
    pub const CAD_EDGE: f64 = 0.95;
    pub const CAD_CORNER_RECALL: f64 = 0.9;
    pub const CAD_CORNER_PRECISION: f64 = 0.95;
    /// Scans with borders (issue 17): found edge length on scan borders, in spacings.
    pub const BORDER_LENGTH: f64 = 0.0;
}

/// What the thresholds expect of a case.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Kind {
    /// Flat faces and straight edges: every corner and edge found; the oracle is defined.
    Polyhedral,
    /// No sharp feature at all (the sphere): nothing may be found.
    Smooth,
    /// Curved faces and curved sharp edges (CAD meshes): edges found, no oracle.
    Curved,
    /// A random part (`--random`): issue 17's thresholds, the oracle on its flat faces.
    Random,
    /// A fixed part under a sampling pattern (`--patterns`): issue 17's thresholds.
    Pattern,
    /// A CAD mesh (`--cad`): issue 17's CAD thresholds (corner and edge recall and precision
    /// only), facet creases below the sharp angle left out of precision.
    Cad,
}

/// One case of the suite.
#[derive(Debug, Clone)]
pub struct Case {
    pub name: String,
    pub description: String,
    pub kind: Kind,
    /// Whether the accuracy thresholds (corner error, edge RMS) apply.
    pub accuracy: bool,
    pub params: SynthParams,
}

/// A case left out, and why.
#[derive(Debug, Clone, Serialize)]
pub struct Skipped {
    pub case: String,
    pub reason: String,
}

/// The cases in suite order: name, description, kind, whether accuracy thresholds apply.
const SUITE: [(&str, &str, Kind, bool); 14] = [
    (
        "box",
        "box, σ 0.15 h, rounded 1.5 h",
        Kind::Polyhedral,
        true,
    ),
    ("lblock", "L-block (concave edge)", Kind::Polyhedral, true),
    ("step", "stepped block, 3 steps", Kind::Polyhedral, true),
    ("wedge", "wedge, 30° apex edge", Kind::Polyhedral, true),
    (
        "prism6",
        "hexagonal prism, 120° edges",
        Kind::Polyhedral,
        true,
    ),
    (
        "prism8",
        "octagonal prism, 135° edges",
        Kind::Polyhedral,
        true,
    ),
    (
        "pyramid",
        "square pyramid, 4-edge apex",
        Kind::Polyhedral,
        true,
    ),
    ("sphere", "sphere, no sharp feature", Kind::Smooth, false),
    ("box-noise0.5", "box, σ 0.5 h", Kind::Polyhedral, false),
    ("box-noise1.0", "box, σ 1.0 h", Kind::Polyhedral, false),
    ("box-30k", "box, 30,000 points", Kind::Polyhedral, true),
    (
        "box-far",
        "box 4,000,000 units from the origin",
        Kind::Polyhedral,
        true,
    ),
    ("fandisk", "fandisk mesh (curved)", Kind::Curved, false),
    ("anchor", "anchor mesh (curved)", Kind::Curved, false),
];

/// The names `--cases` accepts, in suite order.
pub fn case_names() -> Vec<&'static str> {
    SUITE.iter().map(|c| c.0).collect()
}

/// The suite's noise and rounding, in spacings.
const NOISE: f64 = 0.15;
const ROUND: f64 = 1.5;
/// Where the far box is: 4,000,000 units from the origin, in x and y like georeferenced data.
const FAR: V3 = [2_400_000.0, 3_200_000.0, 0.0];

/// FNV-1a of the case name, so a case keeps its seed whatever else is selected.
fn name_hash(name: &str) -> u64 {
    name.bytes().fold(0xcbf2_9ce4_8422_2325u64, |h, b| {
        (h ^ u64::from(b)).wrapping_mul(0x0100_0000_01b3)
    })
}

/// The data folder: `../shared/data` from the working directory, else next to the crate's
/// sources (the build's own checkout); `None` when neither exists.
pub fn default_data_dir() -> Option<PathBuf> {
    [
        PathBuf::from("../shared/data"),
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/data"),
    ]
    .into_iter()
    .find(|p| p.is_dir())
}

/// Builds the selected cases (all when `names` is `None`). Mesh cases whose file is missing
/// are skipped with a note; an unknown name is an error listing the valid ones.
pub fn suite(
    names: Option<&[String]>,
    points: usize,
    seed: u64,
    data: Option<&Path>,
) -> Result<(Vec<Case>, Vec<Skipped>)> {
    let selected: Vec<&(&str, &str, Kind, bool)> = match names {
        None => SUITE.iter().collect(),
        Some(list) => {
            let mut out = Vec::new();
            for n in list {
                let n = n.trim();
                let c = SUITE
                    .iter()
                    .find(|c| c.0 == n)
                    .ok_or_else(|| Error::Usage {
                        option: "--cases".into(),
                        message: format!(
                            "unknown case {n:?}; the cases are {}",
                            case_names().join(", ")
                        ),
                    })?;
                if !out.iter().any(|o: &&(&str, &str, Kind, bool)| o.0 == c.0) {
                    out.push(c);
                }
            }
            out
        }
    };
    let mut cases = Vec::new();
    let mut skipped = Vec::new();
    for &&(name, description, kind, accuracy) in &selected {
        let mut p = SynthParams {
            part: Part::Box,
            sampling: Sampling::Points(points),
            noise: NOISE,
            round: ROUND,
            rotate: true,
            seed: derive(seed, &[name_hash(name)]),
            ..SynthParams::default()
        };
        match name {
            "box" => {}
            "lblock" => p.part = Part::LBlock,
            "step" => {
                p.part = Part::Step;
                p.steps = 3;
            }
            "wedge" => {
                p.part = Part::Wedge;
                p.angle = 30.0;
            }
            "prism6" | "prism8" => {
                p.part = Part::Prism;
                p.sides = if name == "prism6" { 6 } else { 8 };
            }
            "pyramid" => p.part = Part::Pyramid,
            "sphere" => p.part = Part::Sphere,
            "box-noise0.5" => p.noise = 0.5,
            "box-noise1.0" => p.noise = 1.0,
            "box-30k" => p.sampling = Sampling::Points(30_000),
            "box-far" => p.translate = FAR,
            "fandisk" | "anchor" => {
                let file = if name == "fandisk" {
                    "fandisk.off"
                } else {
                    "anchor_dense.off"
                };
                let Some(path) = data
                    .map(|d| d.join("cad").join(file))
                    .filter(|f| f.is_file())
                else {
                    skipped.push(Skipped {
                        case: name.into(),
                        reason: match data {
                            Some(d) => format!("{} not found", d.join("cad").join(file).display()),
                            None => {
                                "no data folder (../shared/data absent; pass --data DIR)".into()
                            }
                        },
                    });
                    continue;
                };
                p.part = Part::Mesh(path);
            }
            _ => unreachable!("every SUITE name has a recipe"),
        }
        cases.push(Case {
            name: name.into(),
            description: description.into(),
            kind,
            accuracy,
            params: p,
        });
    }
    Ok((cases, skipped))
}

/// Mean, median and maximum of a set of errors (spacings).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Spread {
    pub mean: f64,
    pub median: f64,
    pub max: f64,
}

impl Spread {
    fn of(values: &[f64]) -> Option<Spread> {
        stats(values).map(|(mean, median, max)| Spread { mean, median, max })
    }
}

/// A true corner without a match, or a found one without.
#[derive(Debug, Clone, Serialize)]
pub struct LoneCorner {
    pub id: usize,
    pub position: V3,
    /// Distance to the nearest corner of the other set (spacings); `None` if it is empty.
    pub nearest_h: Option<f64>,
}

#[derive(Debug, Clone, Serialize)]
pub struct CornerMetrics {
    /// True corners required (module [`seen`]: all of them when the scan sees the whole part).
    #[serde(rename = "true")]
    pub truth: usize,
    /// True corners not required: some face meeting there was not scanned near it.
    pub unseen: usize,
    pub found: usize,
    pub matched: usize,
    /// `None` when there is nothing to find (recall) or nothing was found (precision).
    pub recall: Option<f64>,
    pub precision: Option<f64>,
    /// Distance of the matched corners (particle swarm) to the true ones.
    pub error_h: Option<Spread>,
    /// On the same matches: Scheme 1 (best data point) and the exact optimum.
    pub scheme1_h: Option<Spread>,
    pub exact_h: Option<Spread>,
    /// The oracle on the true corners we matched (all true corners when none matched).
    pub oracle_h: Option<Spread>,
    /// Our mean error / the oracle's mean error on the same true corners.
    pub ratio_to_oracle: Option<f64>,
    /// Our median error / the oracle's median error on the same true corners.
    pub median_ratio_to_oracle: Option<f64>,
    pub missed: Vec<LoneCorner>,
    pub spurious: Vec<LoneCorner>,
}

/// A true polyline or a found edge that is poorly matched.
#[derive(Debug, Clone, Serialize)]
pub struct PoorEdge {
    pub id: usize,
    pub length_h: f64,
    /// Recall of a true polyline, or precision of a found edge.
    pub matched_share: f64,
}

#[derive(Debug, Clone, Serialize)]
pub struct EdgeMetrics {
    /// True sharp-edge polylines (chains between corners) and their segments.
    pub true_polylines: usize,
    pub true_segments: usize,
    pub found: usize,
    pub true_length_h: f64,
    /// True edge length not required because the scan saw one face of it or none there
    /// (module [`seen`]); 0 when the scan sees the whole part.
    pub unseen_length_h: f64,
    pub found_length_h: f64,
    pub recall: Option<f64>,
    pub precision: Option<f64>,
    /// Matched found length / matched true length: how many found edges cover a true one on
    /// average (1 ideally; 2 when every edge is reported twice, which precision does not see).
    pub duplication: Option<f64>,
    /// Distance of the found edges' matched part to the true edges.
    pub rms_h: Option<f64>,
    pub mean_h: Option<f64>,
    pub max_h: Option<f64>,
    /// Mean signed offset of the matched part along the true edge's bisector, positive
    /// towards the edge's rounded surface (into the material at a convex edge, out of it at
    /// a concave one): a fit that follows the rounding instead of the sharp edge shows here.
    pub offset_to_rounding_h: Option<f64>,
    /// The oracle's edges, scored the same way.
    pub oracle_rms_h: Option<f64>,
    pub oracle_recall: Option<f64>,
    pub ratio_to_oracle: Option<f64>,
    /// CAD cases: found length along facet creases below the sharp angle and not near a
    /// required true edge, left out of `precision` (module [`border`]).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub crease_length_h: Option<f64>,
    /// True polylines with recall below the threshold, found edges with precision below it.
    pub poorly_found: Vec<PoorEdge>,
    pub spurious: Vec<PoorEdge>,
}

#[derive(Debug, Clone, Serialize)]
pub struct RectifyMetrics {
    /// True abnormal-zone points (not outliers) of the required edge stretches.
    pub abnormal_points: usize,
    /// Abnormal points left out: on the rounding of edges the scan did not see whole.
    pub abnormal_unseen: usize,
    /// How many of them the pipeline moved.
    pub abnormal_moved: usize,
    /// Their mean distance to the true surface before and after, and after / before.
    pub before_h: Option<f64>,
    pub after_h: Option<f64>,
    pub ratio: Option<f64>,
    /// Points neither abnormal nor outliers, away from every edge (see [`AWAY_BEYOND`])…
    pub away_points: usize,
    /// …and how many of them changed coordinates (must be 0).
    pub away_moved: usize,
    /// Points flagged as moved, in total.
    pub moved_points: usize,
}

/// Scan borders of a scan that does not see the whole part (module [`border`]).
#[derive(Debug, Clone, Serialize)]
pub struct BorderMetrics {
    /// Scan points on a border (or beside a seen sharp edge, which cuts a face the same way).
    pub border_points: usize,
    /// Found edge length within `EDGE_TOL` h of a border point and not within `EDGE_TOL` h
    /// of a required true edge: scan borders reported as sharp edges (0 expected).
    pub found_on_border_h: f64,
    /// That length over the found edge length.
    pub share: Option<f64>,
}

/// The candidate edge points against the true points within `EDGE_TOL` of an edge.
#[derive(Debug, Clone, Serialize)]
pub struct CandidateMetrics {
    pub count: usize,
    pub recall: Option<f64>,
    pub precision: Option<f64>,
}

/// The scale the pipeline measured, in true spacings.
#[derive(Debug, Clone, Copy, Serialize)]
pub struct Measured {
    pub spacing_h: f64,
    pub noise_h: f64,
    pub radius_h: f64,
}

#[derive(Debug, Clone, Serialize)]
pub struct Seconds {
    pub synth: f64,
    pub pipeline: f64,
    pub score: f64,
    pub total: f64,
    /// The pipeline's stages.
    pub stages: Vec<StageTime>,
}

#[derive(Debug, Clone, Serialize)]
pub struct StageTime {
    pub stage: &'static str,
    pub seconds: f64,
}

/// One threshold of the issue applied to a case.
#[derive(Debug, Clone, Serialize)]
pub struct Check {
    pub name: &'static str,
    /// `None` when the metric is undefined (e.g. precision with nothing found): a failure.
    pub value: Option<f64>,
    /// `">="`, `"<="` or `"=="`.
    pub op: &'static str,
    pub limit: f64,
    pub pass: bool,
}

impl Check {
    fn new(name: &'static str, value: Option<f64>, op: &'static str, limit: f64) -> Check {
        let pass = value.is_some_and(|v| match op {
            ">=" => v >= limit,
            "<=" => v <= limit,
            _ => v == limit,
        });
        Check {
            name,
            value,
            op,
            limit,
            pass,
        }
    }
}

/// Everything measured on one case.
#[derive(Debug, Clone, Serialize)]
pub struct CaseResult {
    pub name: String,
    pub description: String,
    pub kind: Kind,
    pub params: SynthParams,
    /// Set when the case could not be generated or run; the metrics are then absent.
    pub error: Option<String>,
    pub points: usize,
    /// The true spacing h in model units (every `_h` value is in these).
    pub spacing: f64,
    pub noise_h: f64,
    pub round_h: f64,
    pub measured: Option<Measured>,
    pub candidates: Option<CandidateMetrics>,
    pub corners: Option<CornerMetrics>,
    pub edges: Option<EdgeMetrics>,
    pub rectify: Option<RectifyMetrics>,
    /// One-view and multi-view scans (`view` pattern): scan borders reported as edges.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub border: Option<BorderMetrics>,
    pub failed_fits: usize,
    /// The first few messages of the pipeline's failed fits.
    pub failures: Vec<String>,
    /// Points that fed the oracle's plane fits: margin from the edges (spacings), the fewest
    /// points of any face; `None` for non-polyhedral parts.
    pub oracle_margin_h: Option<f64>,
    pub oracle_min_face_points: Option<usize>,
    pub seconds: Seconds,
    pub checks: Vec<Check>,
    pub pass: bool,
    /// Random cases: the command that makes this case's scan alone, and what the part
    /// generator drew.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub reproduce: Option<String>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub part: Option<synth::random::RandomDraw>,
}

impl CaseResult {
    /// A result with the case's identity and no metrics yet.
    pub fn unscored(case: &Case) -> CaseResult {
        CaseResult {
            name: case.name.clone(),
            description: case.description.clone(),
            kind: case.kind,
            params: case.params.clone(),
            error: None,
            points: 0,
            spacing: 0.0,
            noise_h: case.params.noise,
            round_h: case.params.round,
            measured: None,
            candidates: None,
            corners: None,
            edges: None,
            rectify: None,
            border: None,
            failed_fits: 0,
            failures: Vec::new(),
            oracle_margin_h: None,
            oracle_min_face_points: None,
            seconds: Seconds {
                synth: 0.0,
                pipeline: 0.0,
                score: 0.0,
                total: 0.0,
                stages: Vec::new(),
            },
            checks: Vec::new(),
            pass: false,
            reproduce: (case.kind == Kind::Random).then(|| random::reproduce(&case.params)),
            part: None,
        }
    }
}

/// The bench's JSON.
#[derive(Debug, Clone, Serialize)]
pub struct BenchReport {
    pub sharpedge: &'static str,
    /// `suite`, `random`, `patterns` or `cad`.
    pub mode: &'static str,
    pub points: usize,
    pub seed: u64,
    pub threads: usize,
    pub config: Option<PathBuf>,
    pub data: Option<PathBuf>,
    pub tolerances: Tolerances,
    pub cases: Vec<CaseResult>,
    pub skipped: Vec<Skipped>,
    pub seconds: f64,
    pub slowest_case: Option<String>,
    pub passed: usize,
    pub failed: usize,
    pub settings: Settings,
    /// `--random N`: the aggregate over the N random cases.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub summary: Option<random::Summary>,
}

#[derive(Debug, Clone, Serialize)]
pub struct Tolerances {
    pub corner_h: f64,
    pub edge_h: f64,
    pub away_h: f64,
    pub away_beyond_h: f64,
    pub away_sigmas: f64,
    pub sample_step_h: f64,
}

/// What to run.
#[derive(Debug, Clone)]
pub struct BenchOptions {
    /// Case names; `None` for the whole suite.
    pub cases: Option<Vec<String>>,
    pub points: usize,
    pub seed: u64,
    pub settings: Settings,
    /// The pipeline file the settings came from (reported only).
    pub config: Option<PathBuf>,
    /// Worker threads (0 = all cores).
    pub threads: usize,
    /// The shared data folder (with `cad/`); `None` skips the mesh cases.
    pub data: Option<PathBuf>,
    /// Run this many random parts (module [`random`]) instead of the suite; `points` is then
    /// the cap of their drawn point counts.
    pub random: Option<usize>,
    /// Random cases draw their sampling pattern (false: every one uniform).
    pub random_patterns: bool,
    /// Run the sampling-pattern check instead (module [`patterns`]).
    pub patterns: bool,
    /// Run the CAD check instead (module [`patterns`]; needs `data`).
    pub cad: bool,
}

impl BenchOptions {
    /// The mode's name (as in [`BenchReport::mode`]).
    pub fn mode(&self) -> &'static str {
        match (self.random, self.patterns, self.cad) {
            (Some(_), _, _) => "random",
            (None, true, _) => "patterns",
            (None, false, true) => "cad",
            (None, false, false) => "suite",
        }
    }
}

/// Stage timings of one pipeline run.
struct StageClock {
    last: Instant,
    stages: Vec<StageTime>,
}

impl LapClock for StageClock {
    fn lap(&mut self, stage: &'static str) {
        let now = Instant::now();
        self.stages.push(StageTime {
            stage,
            seconds: (now - self.last).as_secs_f64(),
        });
        self.last = now;
    }
}

/// Runs the selected cases on a pool of `threads` workers.
pub fn run(opts: &BenchOptions) -> Result<BenchReport> {
    if opts.points == 0 {
        return Err(Error::Usage {
            option: "--points".into(),
            message: "must be at least 1".into(),
        });
    }
    let (cases, skipped) = match (opts.random, opts.patterns, opts.cad) {
        (Some(n), _, _) => (
            random::select(
                random::cases(n, opts.seed, opts.points, opts.random_patterns),
                opts.cases.as_deref(),
            )?,
            Vec::new(),
        ),
        (None, true, _) => (patterns::cases(opts.points, opts.seed), Vec::new()),
        (None, false, true) => patterns::cad_cases(opts.points, opts.seed, opts.data.as_deref()),
        (None, false, false) => suite(
            opts.cases.as_deref(),
            opts.points,
            opts.seed,
            opts.data.as_deref(),
        )?,
    };
    for s in &skipped {
        tracing::warn!("skipped {}: {}", s.case, s.reason);
    }
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(opts.threads)
        .build()
        .map_err(|e| Error::Usage {
            option: "--threads".into(),
            message: format!("cannot start {} worker threads: {e}", opts.threads),
        })?;
    let start = Instant::now();
    let results: Vec<CaseResult> = pool.install(|| {
        let progress = Progress::start("bench", cases.len() as u64, "cases");
        cases
            .iter()
            .map(|c| {
                let r = run_case(c, &opts.settings);
                tracing::info!(
                    "{}: {} in {:.1} s",
                    r.name,
                    if r.pass { "pass" } else { "FAIL" },
                    r.seconds.total
                );
                progress.inc(1);
                r
            })
            .collect()
    });
    let slowest_case = results
        .iter()
        .max_by(|a, b| a.seconds.total.total_cmp(&b.seconds.total))
        .map(|r| r.name.clone());
    let passed = results.iter().filter(|r| r.pass).count();
    Ok(BenchReport {
        sharpedge: env!("CARGO_PKG_VERSION"),
        mode: opts.mode(),
        points: opts.points,
        seed: opts.seed,
        threads: pool.current_num_threads(),
        config: opts.config.clone(),
        data: opts.data.clone(),
        tolerances: Tolerances {
            corner_h: CORNER_TOL,
            edge_h: EDGE_TOL,
            away_h: AWAY,
            away_beyond_h: AWAY_BEYOND,
            away_sigmas: AWAY_SIGMAS,
            sample_step_h: SAMPLE_STEP,
        },
        failed: results.len() - passed,
        passed,
        summary: opts.random.map(|_| random::summary(&results)),
        cases: results,
        skipped,
        seconds: start.elapsed().as_secs_f64(),
        slowest_case,
        settings: opts.settings.clone(),
    })
}

/// Generates, runs and scores one case. Errors end up in the result, not in an `Err`.
pub fn run_case(case: &Case, settings: &Settings) -> CaseResult {
    let t0 = Instant::now();
    let mut result = CaseResult::unscored(case);
    let generated = if case.kind == Kind::Random {
        random::generate(&case.params).map(|(scan, params)| {
            result.reproduce = Some(random::reproduce(&params));
            result.round_h = params.round;
            result.part = scan.ground_truth.random.clone();
            result.params = params;
            scan
        })
    } else {
        synth::generate(&case.params)
    };
    let scan = match generated {
        Ok(s) => s,
        Err(e) => {
            result.error = Some(format!("synth: {e}"));
            result.seconds.total = t0.elapsed().as_secs_f64();
            return result;
        }
    };
    result.seconds.synth = t0.elapsed().as_secs_f64();
    result.points = scan.cloud.len();
    result.spacing = scan.ground_truth.spacing;
    let truth = scan.truth;
    let gt = scan.ground_truth;
    let t1 = Instant::now();
    let mut clock = StageClock {
        last: t1,
        stages: Vec::new(),
    };
    let outcome = pipeline::process(scan.cloud, settings, &mut clock);
    result.seconds.pipeline = t1.elapsed().as_secs_f64();
    result.seconds.stages = clock.stages;
    match outcome {
        Ok(outcome) => {
            let t2 = Instant::now();
            if let Err(e) = score_case(case, &gt, &truth, &outcome, &mut result) {
                result.error = Some(e);
            }
            result.seconds.score = t2.elapsed().as_secs_f64();
        }
        Err(e) => result.error = Some(format!("pipeline: {e}")),
    }
    result.checks = checks(case.kind, case.accuracy, &result);
    result.pass = result.error.is_none() && result.checks.iter().all(|c| c.pass);
    result.seconds.total = t0.elapsed().as_secs_f64();
    result
}

/// Fills the metrics of `r` from the pipeline's outcome.
fn score_case(
    case: &Case,
    gt: &GroundTruth,
    truth: &[PointTruth],
    out: &Outcome,
    r: &mut CaseResult,
) -> std::result::Result<(), String> {
    let h = gt.spacing;
    let n = out.cloud.len();
    if out.rectified.len() != n || out.moved.len() != n || truth.len() != n {
        return Err(format!(
            "outcome has {} rectified positions and {} moved flags for {n} points ({} truths)",
            out.rectified.len(),
            out.moved.len(),
            truth.len()
        ));
    }
    r.measured = Some(Measured {
        spacing_h: out.scale.spacing / h,
        noise_h: out.scale.noise / h,
        radius_h: out.scale.radius / h,
    });
    // Failed fits only: candidates judged no sharp edge (fillets, ...) are outcomes.
    let failed: Vec<&LeftOut> = out.left_out.iter().filter(|l| l.is_failure()).collect();
    r.failed_fits = failed.len();
    r.failures = failed.iter().take(5).map(|l| l.message.clone()).collect();
    r.candidates = Some(candidate_metrics(&out.features.candidate, truth, h));

    let oracle = matches!(case.kind, Kind::Polyhedral | Kind::Random | Kind::Pattern)
        .then(|| oracle::fit(gt, &out.cloud.positions, truth));
    let true_corners: Vec<V3> = gt.corners.iter().map(|c| c.position).collect();
    let pitch = seen::pitch(gt);
    let required = seen::required(gt, truth, pitch);
    r.corners = Some(corner_metrics_on(
        &out.corners,
        &true_corners,
        &seen::required_corners(gt, &required, pitch),
        oracle.as_ref().map(|o| o.corners.as_slice()),
        h,
    ));
    let polylines: Vec<Vec<V3>> = out.edges.iter().map(|e| e.polyline.clone()).collect();
    let mut edges = edge_metrics_on(
        &polylines,
        gt,
        &required,
        oracle.as_ref().map(|o| o.edges.as_slice()),
        h,
    );
    let found = polyline_segments(&polylines);
    let seen_edges = SegmentSet::new(required.segments.clone(), EDGE_TOL * h);
    if case.kind == Kind::Cad {
        let creases = SegmentSet::new(border::creases(gt, gt.params.sharp_angle), EDGE_TOL * h);
        let on = border::found_length_near(&found, &creases, &seen_edges, SAMPLE_STEP * h);
        edges.crease_length_h = Some(on / h);
        // Precision over the found length that is not on a facet crease.
        let counted = edges.found_length_h - on / h;
        edges.precision = edges
            .precision
            .map(|p| p * edges.found_length_h)
            .and_then(|covered| (counted > 0.0).then(|| (covered / counted).min(1.0)));
    }
    if gt.params.scan.pattern == synth::Pattern::View {
        let on_border = border::border_points(gt, truth, pitch);
        let (near, count) = border::border_set(truth, &on_border, EDGE_TOL * h);
        let on = border::found_length_near(&found, &near, &seen_edges, SAMPLE_STEP * h);
        r.border = Some(BorderMetrics {
            border_points: count,
            found_on_border_h: on / h,
            share: (edges.found_length_h > 0.0).then(|| on / h / edges.found_length_h),
        });
    }
    r.edges = Some(edges);
    // Rectification, over the abnormal zones of the required stretches: a scan that sees one
    // face of an edge gives no tool the means to rectify its rounding.
    let (abnormal, unseen) = scored_abnormal(gt, truth, &required);
    let rect = rectify_metrics(
        &out.cloud.positions,
        &out.rectified,
        &out.moved,
        (&abnormal, unseen),
        &away_mask(truth, gt, r.params.noise, h),
        h,
        |p| gt.distance_to_surface(p),
    );
    r.rectify = Some(rect);
    if let Some(o) = &oracle {
        r.oracle_margin_h = Some(o.margin / h);
        r.oracle_min_face_points = o.face_points.iter().copied().min();
    }
    Ok(())
}

/// The abnormal points rectification is scored on (abnormal and no outlier), and how many
/// abnormal points are left out of it: when some true edge length is not required, those
/// farther from every required stretch than the widest abnormal zone (rounding's tangent
/// distance, extra-noise band).
fn scored_abnormal(
    gt: &GroundTruth,
    truth: &[PointTruth],
    required: &Stretches,
) -> (Vec<bool>, usize) {
    let scored = |t: &PointTruth| t.abnormal && !t.outlier;
    if required.unseen_length == 0.0 {
        return (truth.iter().map(scored).collect(), 0);
    }
    let h = gt.spacing;
    let widest = gt
        .edges
        .iter()
        .map(|e| e.tangent_distance)
        .fold(0.0, f64::max)
        .max(gt.params.edge_band * h)
        + EDGE_TOL * h;
    let near = SegmentSet::new(required.segments.clone(), widest);
    let mut left_out = 0;
    let mask = truth
        .iter()
        .map(|t| {
            if t.abnormal && near.nearest_within(t.surface).is_none() {
                left_out += 1;
                return false;
            }
            scored(t)
        })
        .collect();
    (mask, left_out)
}

fn ratio(a: Option<f64>, b: Option<f64>) -> Option<f64> {
    match (a, b) {
        (Some(a), Some(b)) if b > 0.0 => Some(a / b),
        _ => None,
    }
}

/// Corner metrics of the found corners against the true ones, all of them required;
/// `oracle` holds the oracle's corner per true corner (polyhedral parts only).
pub fn corner_metrics(
    found: &[CornerOut],
    true_corners: &[V3],
    oracle: Option<&[Option<V3>]>,
    h: f64,
) -> CornerMetrics {
    // An empty `required` requires every corner.
    corner_metrics_on(found, true_corners, &[], oracle, h)
}

/// Corner metrics against the `required` true corners (module [`seen`]). Found corners are
/// matched against every true corner; one matched to a corner that is not required (its
/// faces were not all scanned) counts neither for recall nor against precision: it stands
/// on a real corner, but no scan can demand it.
pub fn corner_metrics_on(
    found: &[CornerOut],
    true_corners: &[V3],
    required: &[bool],
    oracle: Option<&[Option<V3>]>,
    h: f64,
) -> CornerMetrics {
    let positions: Vec<V3> = found.iter().map(|c| c.position).collect();
    let all = score::match_corners(&positions, true_corners, CORNER_TOL * h);
    let is_required = |j: usize| required.get(j).copied().unwrap_or(true);
    let (matches, exempt): (Vec<&score::CornerMatch>, Vec<&score::CornerMatch>) =
        all.iter().partition(|m| is_required(m.truth));
    let wanted = (0..true_corners.len()).filter(|&j| is_required(j)).count();
    let counted = found.len() - exempt.len();
    let err = |f: &dyn Fn(&CornerOut) -> V3| -> Vec<f64> {
        matches
            .iter()
            .map(|m| dist(f(&found[m.found]), true_corners[m.truth]) / h)
            .collect()
    };
    let error_h = Spread::of(&err(&|c| c.position));
    // Like for like: the oracle on the true corners we matched (all required ones if none).
    let oracle_h = oracle.and_then(|o| {
        let ids: Vec<usize> = if matches.is_empty() {
            (0..true_corners.len())
                .filter(|&j| is_required(j))
                .collect()
        } else {
            matches.iter().map(|m| m.truth).collect()
        };
        let e: Vec<f64> = ids
            .iter()
            .filter_map(|&j| {
                o.get(j)
                    .copied()
                    .flatten()
                    .map(|p| dist(p, true_corners[j]) / h)
            })
            .collect();
        Spread::of(&e)
    });
    let lone = |set: &[V3], other: &[V3], lonely: &dyn Fn(usize) -> bool| -> Vec<LoneCorner> {
        (0..set.len())
            .filter(|&i| lonely(i))
            .map(|i| LoneCorner {
                id: i,
                position: set[i],
                nearest_h: other
                    .iter()
                    .map(|q| dist(*q, set[i]) / h)
                    .min_by(f64::total_cmp),
            })
            .collect()
    };
    CornerMetrics {
        truth: wanted,
        unseen: true_corners.len() - wanted,
        found: found.len(),
        matched: matches.len(),
        recall: (wanted > 0).then(|| matches.len() as f64 / wanted as f64),
        precision: (counted > 0).then(|| matches.len() as f64 / counted as f64),
        error_h,
        scheme1_h: Spread::of(&err(&|c| c.scheme1)),
        exact_h: Spread::of(&err(&|c| c.exact)),
        oracle_h,
        ratio_to_oracle: ratio(error_h.map(|s| s.mean), oracle_h.map(|s| s.mean)),
        median_ratio_to_oracle: ratio(error_h.map(|s| s.median), oracle_h.map(|s| s.median)),
        missed: lone(true_corners, &positions, &|j| {
            is_required(j) && !matches.iter().any(|m| m.truth == j)
        }),
        spurious: lone(&positions, true_corners, &|i| {
            !all.iter().any(|m| m.found == i)
        }),
    }
}

/// Edge metrics of the found edge polylines against the true edges of `gt`, all of them
/// required; `oracle` holds the oracle's segment per true edge (polyhedral parts only).
pub fn edge_metrics(
    polylines: &[Vec<V3>],
    gt: &GroundTruth,
    oracle: Option<&[Option<(V3, V3)>]>,
    h: f64,
) -> EdgeMetrics {
    edge_metrics_on(polylines, gt, &Stretches::all(gt), oracle, h)
}

/// Edge metrics against the `required` stretches of the true edges (module [`seen`]): recall
/// over them, and found length near any other place of a true edge counts against precision.
pub fn edge_metrics_on(
    polylines: &[Vec<V3>],
    gt: &GroundTruth,
    required: &Stretches,
    oracle: Option<&[Option<(V3, V3)>]>,
    h: f64,
) -> EdgeMetrics {
    let true_segments = required.segments.clone();
    let found_segments = polyline_segments(polylines);
    let es = score_edges(
        &found_segments,
        &true_segments,
        EDGE_TOL * h,
        SAMPLE_STEP * h,
    );
    let oracle_score: Option<EdgeScore> = oracle.map(|o| {
        // The oracle's line of each true edge that is required at all.
        let mut edges = required.edge.clone();
        edges.dedup();
        let segs: Vec<(V3, V3)> = edges
            .iter()
            .filter_map(|&e| o.get(e).copied().flatten())
            .collect();
        score_edges(&segs, &true_segments, EDGE_TOL * h, SAMPLE_STEP * h)
    });
    let rms_h = es.distance.map(|d| d.0 / h);
    let oracle_rms_h = oracle_score
        .as_ref()
        .and_then(|o| o.distance.map(|d| d.0 / h));
    EdgeMetrics {
        true_polylines: gt.polylines.len(),
        true_segments: gt.edges.len(),
        found: polylines.len(),
        true_length_h: es.true_length / h,
        unseen_length_h: required.unseen_length / h,
        found_length_h: es.found_length / h,
        recall: es.recall(),
        precision: es.precision(),
        duplication: (es.true_covered > 0.0).then(|| es.found_covered / es.true_covered),
        rms_h,
        mean_h: es.distance.map(|d| d.1 / h),
        max_h: es.distance.map(|d| d.2 / h),
        offset_to_rounding_h: offset_to_rounding(gt, &required.edge, &es.samples).map(|o| o / h),
        crease_length_h: None,
        oracle_rms_h,
        oracle_recall: oracle_score.as_ref().and_then(EdgeScore::recall),
        ratio_to_oracle: ratio(rms_h, oracle_rms_h),
        poorly_found: poorly_found(gt, required, &es, h),
        spurious: spurious(polylines, &es, h),
    }
}

/// Weighted mean of the samples' offsets along the unit vector from each true edge towards
/// its rounding: `−(n0 + n1)` at a convex edge, `n0 + n1` at a concave one (`n` the faces'
/// outward normals). `None` without samples.
fn offset_to_rounding(
    gt: &GroundTruth,
    edge_of: &[usize],
    samples: &[score::EdgeSample],
) -> Option<f64> {
    let (mut sum, mut w) = (0.0, 0.0);
    for s in samples {
        let e = &gt.edges[edge_of[s.segment]];
        let b = add(e.normals[0], e.normals[1]);
        let len = norm(b);
        if len.is_nan() || len <= 1e-12 {
            continue; // faces back to back: no bisector
        }
        let sign = if e.convex { -1.0 } else { 1.0 };
        sum += s.weight * sign * dot(s.offset, b) / len;
        w += s.weight;
    }
    (w > 0.0).then(|| sum / w)
}

/// True polylines whose recall (over their required length) is below the edge threshold.
fn poorly_found(gt: &GroundTruth, required: &Stretches, es: &EdgeScore, h: f64) -> Vec<PoorEdge> {
    let whole = required.unseen_length == 0.0 && required.segments.len() == gt.edges.len();
    let mut covered = vec![0.0; gt.polylines.len()];
    let mut length = vec![0.0; gt.polylines.len()];
    for (k, (&e, &(a, b))) in required.edge.iter().zip(&required.segments).enumerate() {
        let p = gt.edges[e].polyline;
        if let (Some(c), Some(l)) = (covered.get_mut(p), length.get_mut(p)) {
            *c += es.true_covered_each[k];
            *l += dist(a, b);
        }
    }
    gt.polylines
        .iter()
        .zip(covered.iter().zip(&length))
        // A scan that sees everything keeps the polyline's own length (the same sums as
        // before the visibility rule).
        .map(|(p, (c, l))| (p, *c, if whole { p.length } else { *l }))
        .filter(|(_, c, l)| *l > 0.0 && c / l < limits::EDGE_RECALL)
        .map(|(p, c, l)| PoorEdge {
            id: p.id,
            length_h: l / h,
            matched_share: c / l,
        })
        .collect()
}

/// Found edges whose precision is below the edge threshold.
fn spurious(polylines: &[Vec<V3>], es: &EdgeScore, h: f64) -> Vec<PoorEdge> {
    let mut out = Vec::new();
    let mut k = 0;
    for (id, pl) in polylines.iter().enumerate() {
        let nseg = match pl.len() {
            0 => 0,
            1 => 1,
            n => n - 1,
        };
        let covered: f64 = es.found_covered_each[k..k + nseg].iter().sum();
        k += nseg;
        let len = score::polyline_length(pl);
        let share = if len > 0.0 { covered / len } else { 0.0 };
        if share < limits::EDGE_PRECISION {
            out.push(PoorEdge {
                id,
                length_h: len / h,
                matched_share: share,
            });
        }
    }
    out
}

/// Candidates against the true edge points (not outliers, within `EDGE_TOL` h of an edge).
pub fn candidate_metrics(candidate: &[bool], truth: &[PointTruth], h: f64) -> CandidateMetrics {
    let near = |t: &PointTruth| !t.outlier && t.edge_distance <= EDGE_TOL * h;
    let count = candidate.iter().filter(|&&c| c).count();
    let true_near = truth.iter().filter(|t| near(t)).count();
    let hits = candidate
        .iter()
        .zip(truth)
        .filter(|(c, t)| **c && near(t))
        .count();
    CandidateMetrics {
        count,
        recall: (true_near > 0).then(|| hits as f64 / true_near as f64),
        precision: (count > 0).then(|| hits as f64 / count as f64),
    }
}

/// Distance from an edge (model units) beyond which a point is "away" from it (see
/// [`AWAY_BEYOND`]): `tangent_distance` in model units, `noise` in spacings.
pub fn away_limit(tangent_distance: f64, noise: f64, h: f64) -> f64 {
    (AWAY * h).max(tangent_distance + AWAY_BEYOND * h + AWAY_SIGMAS * noise * h)
}

/// The points away from every edge: neither abnormal nor outliers, and beyond each edge's own
/// [`away_limit`] (near a vertex the nearest edge is not always the one whose zone reaches
/// farthest: beside a 30° edge, a point 6 h out on its face is 4.5 h from the end face's
/// edge). Distances are from the points' noise-free positions. `noise` in spacings: the
/// scan's; a point given more (`PointTruth::noise`: incidence noise on a face seen at a
/// grazing angle, up to four times the scan's) is uncertain by its own. Issue 17: seed 3's
/// r006 of `bench --random 100` (incidence noise) counted 222 points "away" that lay within
/// five of their own sigmas of an edge's reach.
pub fn away_mask(truth: &[PointTruth], gt: &GroundTruth, noise: f64, h: f64) -> Vec<bool> {
    let noise_of = |t: &PointTruth| noise.max(t.noise / h);
    // `away_limit` grows with the tangent distance: the widest edge's is the widest limit.
    let widest_td = gt
        .edges
        .iter()
        .map(|e| e.tangent_distance)
        .fold(0.0, f64::max);
    // A wide fillet is no edge, but its points and those near its tangent lines are not
    // "away" either: only beyond it.
    let fillet_faces: std::collections::HashSet<u32> = gt
        .fillets
        .iter()
        .flat_map(|f| f.faces.iter().map(|&c| c as u32))
        .collect();
    let near_fillet = |t: &PointTruth, noise: f64| {
        let limit = away_limit(0.0, noise, h);
        fillet_faces.contains(&t.face)
            || gt.fillets.iter().any(|f| {
                f.tangent_lines
                    .iter()
                    .any(|[a, b]| point_segment(t.surface, *a, *b).0 <= limit)
            })
    };
    truth
        .par_iter()
        .map(|t| {
            let noise = noise_of(t);
            if t.abnormal || t.outlier || near_fillet(t, noise) {
                return false;
            }
            t.edge_distance > away_limit(widest_td, noise, h)
                || gt.edges.iter().all(|e| {
                    point_segment(t.surface, e.start, e.end).0
                        > away_limit(e.tangent_distance, noise, h)
                })
        })
        .collect()
}

/// Rectification against the true surface: the abnormal points' mean distance to it before
/// (`positions`) and after (`rectified`), and the points marked `away` from edges (see
/// [`away_mask`]) that changed at all.
/// Distances are computed in parallel and summed in point order (the same total for any
/// thread count). `abnormal` is the mask of the abnormal points scored, with the count of
/// those left out of it.
#[allow(clippy::too_many_arguments)]
pub fn rectify_metrics(
    positions: &[V3],
    rectified: &[V3],
    moved: &[bool],
    (abnormal, unseen): (&[bool], usize),
    away: &[bool],
    h: f64,
    distance_to_surface: impl Fn(V3) -> f64 + Sync,
) -> RectifyMetrics {
    let abnormal: Vec<usize> = (0..abnormal.len()).filter(|&i| abnormal[i]).collect();
    let d: Vec<(f64, f64)> = abnormal
        .par_iter()
        .map(|&i| {
            (
                distance_to_surface(positions[i]),
                distance_to_surface(rectified[i]),
            )
        })
        .collect();
    let (before, after) = d.iter().fold((0.0, 0.0), |(b, a), &(x, y)| (b + x, a + y));
    let m = abnormal.len() as f64;
    let before_h = (!abnormal.is_empty()).then(|| before / m / h);
    let after_h = (!abnormal.is_empty()).then(|| after / m / h);
    let away: Vec<usize> = (0..away.len()).filter(|&i| away[i]).collect();
    RectifyMetrics {
        abnormal_points: abnormal.len(),
        abnormal_unseen: unseen,
        abnormal_moved: abnormal.iter().filter(|&&i| moved[i]).count(),
        before_h,
        after_h,
        ratio: ratio(after_h, before_h),
        away_points: away.len(),
        away_moved: away
            .iter()
            .filter(|&&i| !same_bits(positions[i], rectified[i]))
            .count(),
        moved_points: moved.iter().filter(|&&m| m).count(),
    }
}

/// The thresholds for a case of this kind.
pub fn checks(kind: Kind, accuracy: bool, r: &CaseResult) -> Vec<Check> {
    let mut out = Vec::new();
    let (Some(c), Some(e), Some(rect)) = (&r.corners, &r.edges, &r.rectify) else {
        return out;
    };
    match kind {
        Kind::Polyhedral => {
            out.push(Check::new(
                "corner recall",
                c.recall,
                ">=",
                limits::CORNER_RECALL,
            ));
            out.push(Check::new(
                "corner precision",
                c.precision,
                ">=",
                limits::CORNER_PRECISION,
            ));
            out.push(Check::new(
                "edge recall",
                e.recall,
                ">=",
                limits::EDGE_RECALL,
            ));
            out.push(Check::new(
                "edge precision",
                e.precision,
                ">=",
                limits::EDGE_PRECISION,
            ));
            if accuracy {
                out.push(Check::new(
                    "mean corner error (h)",
                    c.error_h.map(|s| s.mean),
                    "<=",
                    limits::CORNER_ERROR,
                ));
                out.push(Check::new("edge RMS (h)", e.rms_h, "<=", limits::EDGE_RMS));
            }
        }
        Kind::Smooth => {
            out.push(Check::new("edges found", Some(e.found as f64), "==", 0.0));
            out.push(Check::new("corners found", Some(c.found as f64), "==", 0.0));
        }
        Kind::Random | Kind::Pattern => {
            // A one-sided scan may leave no corner to require (a box seen across one edge):
            // then nothing is missed; nothing counted as found misplaces nothing either. (A
            // random case scanned uniformly always has corners to require.)
            let vacuous = |v: Option<f64>, empty: bool| match v {
                None if empty => Some(1.0),
                v => v,
            };
            out.push(Check::new(
                "corner recall",
                vacuous(c.recall, c.truth == 0),
                ">=",
                limits::RANDOM_CORNER_RECALL,
            ));
            out.push(Check::new(
                "corner precision",
                vacuous(c.precision, c.truth == 0),
                ">=",
                limits::RANDOM_CORNER_PRECISION,
            ));
            out.push(Check::new(
                "edge recall",
                vacuous(e.recall, e.true_length_h == 0.0),
                ">=",
                limits::RANDOM_EDGE_RECALL,
            ));
            out.push(Check::new(
                "edge precision",
                vacuous(e.precision, e.true_length_h == 0.0),
                ">=",
                limits::RANDOM_EDGE_PRECISION,
            ));
            if kind == Kind::Random {
                out.push(Check::new(
                    "median corner error / oracle",
                    match c.median_ratio_to_oracle {
                        // No corner required: no error to compare (a ratio of 1 passes).
                        None if c.truth == 0 => Some(1.0),
                        v => v,
                    },
                    "<=",
                    limits::RANDOM_MEDIAN_CORNER_TO_ORACLE,
                ));
            }
        }
        Kind::Cad => {
            out.push(Check::new(
                "corner recall",
                c.recall,
                ">=",
                limits::CAD_CORNER_RECALL,
            ));
            out.push(Check::new(
                "corner precision",
                c.precision,
                ">=",
                limits::CAD_CORNER_PRECISION,
            ));
            out.push(Check::new("edge recall", e.recall, ">=", limits::CAD_EDGE));
            out.push(Check::new(
                "edge precision",
                e.precision,
                ">=",
                limits::CAD_EDGE,
            ));
            // The CAD check is these four: rectification is reported, not judged
            // (edges found along facet creases, which precision leaves out, move their
            // points, and those points count as away from the sharp edges).
            return out;
        }
        Kind::Curved => {
            out.push(Check::new(
                "edge recall",
                e.recall,
                ">=",
                limits::CURVED_EDGE,
            ));
            out.push(Check::new(
                "edge precision",
                e.precision,
                ">=",
                limits::CURVED_EDGE,
            ));
        }
    }
    if let Some(b) = &r.border {
        out.push(Check::new(
            "found edge on scan borders (h)",
            Some(b.found_on_border_h),
            "<=",
            limits::BORDER_LENGTH,
        ));
    }
    if rect.abnormal_points > 0 {
        out.push(Check::new(
            "rectified / raw distance",
            rect.ratio,
            "<=",
            limits::RECTIFY_RATIO,
        ));
    }
    out.push(Check::new(
        "points away from edges moved",
        Some(rect.away_moved as f64),
        "==",
        0.0,
    ));
    out
}

fn opt(v: Option<f64>, width: usize, prec: usize) -> String {
    match v {
        Some(x) => format!("{x:>width$.prec$}"),
        None => format!("{:>width$}", "n/a"),
    }
}

/// The printed tables: detection, then accuracy, then the failed checks.
pub fn table(rep: &BenchReport) -> String {
    use std::fmt::Write;
    let mut t = String::new();
    let _ = writeln!(
        t,
        "sharpedge {} bench: {}, seed {}, {} threads{}",
        rep.sharpedge,
        match &rep.summary {
            Some(s) => format!(
                "{} random parts, {}..{} points",
                s.cases,
                random::MIN_POINTS.min(rep.points),
                rep.points
            ),
            None => match rep.mode {
                "patterns" => format!("sampling patterns, {} points per case", rep.points),
                "cad" => format!("CAD meshes, {} points per case", rep.points),
                _ => format!("{} points per case", rep.points),
            },
        },
        rep.seed,
        rep.threads,
        rep.config
            .as_ref()
            .map(|c| format!(", config {}", c.display()))
            .unwrap_or_else(|| ", default settings".into())
    );
    let _ = writeln!(
        t,
        "lengths in true spacings h; corners match within {CORNER_TOL} h, edges within {EDGE_TOL} h"
    );
    let _ = writeln!(t);
    if rep.summary.is_some() {
        let _ = writeln!(t, "cases (part and scan drawn from each case's seed):");
        for r in &rep.cases {
            let _ = writeln!(t, "  {}", random::describe(r));
        }
        let _ = writeln!(t);
    }
    let _ = writeln!(
        t,
        "{:<13} {:>7} {:>9} {:>6} {:>5} {:>5} {:>6} {:>5} {:>5} {:>5} {:>4}  {:>5} {:>5} {:>5}  {:>6}",
        "detection",
        "points",
        "edges f/t",
        "recall",
        "prec",
        "dup",
        "crn f/t",
        "rec",
        "prec",
        "cand",
        "fail",
        "spc",
        "noise",
        "rad",
        "time s"
    );
    for r in &rep.cases {
        let (Some(c), Some(e)) = (&r.corners, &r.edges) else {
            let _ = writeln!(
                t,
                "{:<13} {:>7}  error: {}",
                r.name,
                r.points,
                r.error.as_deref().unwrap_or("not scored")
            );
            continue;
        };
        let m = r.measured;
        let _ = writeln!(
            t,
            "{:<13} {:>7} {:>9} {} {} {} {:>6} {} {} {} {:>4}  {} {} {}  {:>6.1}",
            r.name,
            r.points,
            format!("{}/{}", e.found, e.true_polylines),
            opt(e.recall, 6, 3),
            opt(e.precision, 5, 3),
            opt(e.duplication, 5, 2),
            format!("{}/{}", c.found, c.truth),
            opt(c.recall, 5, 2),
            opt(c.precision, 5, 2),
            opt(r.candidates.as_ref().and_then(|x| x.recall), 5, 2),
            r.failed_fits,
            opt(m.map(|m| m.spacing_h), 5, 3),
            opt(m.map(|m| m.noise_h), 5, 3),
            opt(m.map(|m| m.radius_h), 5, 2),
            r.seconds.total
        );
    }
    let _ = writeln!(t);
    let _ = writeln!(
        t,
        "{:<13} {:>23} {:>6} {:>6} {:>6} {:>6}  {:>6} {:>6} {:>6} {:>6} {:>6}  {:>17} {:>5} {:>4}  verdict",
        "accuracy",
        "corner err mean/med/max",
        "schm1",
        "exact",
        "oracle",
        "x orc",
        "E rms",
        "E max",
        "bias",
        "oracle",
        "x orc",
        "rectify raw→after",
        "ratio",
        "away",
    );
    for r in &rep.cases {
        let (Some(c), Some(e), Some(x)) = (&r.corners, &r.edges, &r.rectify) else {
            let _ = writeln!(t, "{:<13} {:>23}  FAIL (error)", r.name, "n/a");
            continue;
        };
        let spread = |s: Option<Spread>| match s {
            Some(s) => format!("{:.3}/{:.3}/{:.3}", s.mean, s.median, s.max),
            None => "n/a".into(),
        };
        let failed = r.checks.iter().filter(|c| !c.pass).count();
        let verdict = if r.pass {
            "PASS".to_string()
        } else {
            format!("FAIL {failed}/{}", r.checks.len())
        };
        let _ = writeln!(
            t,
            "{:<13} {:>23} {} {} {} {}  {} {} {} {} {}  {:>17} {} {:>4}  {}",
            r.name,
            spread(c.error_h),
            opt(c.scheme1_h.map(|s| s.mean), 6, 3),
            opt(c.exact_h.map(|s| s.mean), 6, 3),
            opt(c.oracle_h.map(|s| s.mean), 6, 4),
            opt(c.ratio_to_oracle, 6, 1),
            opt(e.rms_h, 6, 3),
            opt(e.max_h, 6, 3),
            opt(e.offset_to_rounding_h, 6, 3),
            opt(e.oracle_rms_h, 6, 4),
            opt(e.ratio_to_oracle, 6, 1),
            match (x.before_h, x.after_h) {
                (Some(b), Some(a)) => format!("{b:.3}→{a:.3}"),
                _ => "n/a".into(),
            },
            opt(x.ratio, 5, 2),
            x.away_moved,
            verdict
        );
    }
    let _ = writeln!(t);
    let _ = writeln!(
        t,
        "detection: edges/corners found/true; dup = found edge length per true edge length (matched parts, 1 ideally);"
    );
    let _ = writeln!(
        t,
        "  cand = share of true edge points (≤ {EDGE_TOL} h) that are candidates; fail = failed fits;\n  spc, noise, rad = spacing, noise sigma and neighbourhood radius the pipeline measured (h)."
    );
    let _ = writeln!(
        t,
        "accuracy: corner errors of the swarm, Scheme 1, the exact optimum and the oracle (h); x orc = ours / oracle;"
    );
    let _ = writeln!(
        t,
        "  E rms/max = distance of found edges to true ones (matched part); bias = their mean offset towards the rounding;"
    );
    let _ = writeln!(
        t,
        "  rectify = abnormal points' mean distance to the true surface; away = points beyond an edge's rounding + {AWAY_BEYOND} h + {AWAY_SIGMAS} σ (≥ {AWAY} h) that moved (must be 0)."
    );
    let partial = |r: &CaseResult| {
        r.border.is_some()
            || r.edges
                .as_ref()
                .is_some_and(|e| e.unseen_length_h > 0.0 || e.crease_length_h.is_some())
            || r.corners.as_ref().is_some_and(|c| c.unseen > 0)
    };
    if rep.cases.iter().any(partial) {
        let _ = writeln!(t);
        let _ = writeln!(
            t,
            "{:<16} {:>12} {:>14} {:>13} {:>12} {:>12}",
            "not required",
            "unseen edge h",
            "unseen corners",
            "border points",
            "on border h",
            "on crease h"
        );
        for r in rep.cases.iter().filter(|r| partial(r)) {
            let _ = writeln!(
                t,
                "{:<16} {} {:>14} {:>13} {} {}",
                r.name,
                opt(r.edges.as_ref().map(|e| e.unseen_length_h), 13, 1),
                r.corners.as_ref().map_or(0, |c| c.unseen),
                r.border
                    .as_ref()
                    .map_or("n/a".into(), |b| b.border_points.to_string()),
                opt(r.border.as_ref().map(|b| b.found_on_border_h), 12, 1),
                opt(r.edges.as_ref().and_then(|e| e.crease_length_h), 12, 1),
            );
        }
        let _ = writeln!(
            t,
            "  unseen = true edge length and corners a face of which the scan did not sample nearby (not required);\n  on border = found edge length on scan borders, not on a seen sharp edge (must be 0); on crease = found length on facet creases below the sharp angle (left out of precision)."
        );
    }
    if rep.mode == "patterns" {
        let _ = writeln!(t);
        let _ = write!(t, "{}", patterns::grid(&rep.cases));
    }
    let failing: Vec<&CaseResult> = rep.cases.iter().filter(|r| !r.pass).collect();
    if !failing.is_empty() {
        let _ = writeln!(t);
        let _ = writeln!(t, "failed checks:");
        for r in failing {
            if let Some(e) = &r.error {
                let _ = writeln!(t, "  {:<13} error: {e}", r.name);
            }
            let list: Vec<String> = r
                .checks
                .iter()
                .filter(|c| !c.pass)
                .map(|c| {
                    format!(
                        "{} {} (need {} {})",
                        c.name,
                        c.value.map_or("n/a".into(), |v| format!("{v:.4}")),
                        c.op,
                        c.limit
                    )
                })
                .collect();
            if !list.is_empty() {
                let _ = writeln!(t, "  {:<13} {}", r.name, list.join("; "));
            }
            if let Some(cmd) = &r.reproduce {
                let _ = writeln!(t, "  {:<13} reproduce: {cmd}", "");
            }
        }
    }
    for s in &rep.skipped {
        let _ = writeln!(t, "skipped {}: {}", s.case, s.reason);
    }
    if let Some(s) = &rep.summary {
        let _ = writeln!(t);
        let _ = writeln!(
            t,
            "summary over {} random cases ({} scored): corners recall {} precision {}; edges recall {} precision {}; median corner error / oracle {}; median rectified / raw {}; points away from edges moved {} (in {} cases); found edges on scan borders {:.1} h (in {} cases); {} of {} pass ({:.0} %)",
            s.cases,
            s.scored,
            opt(s.corner_recall, 0, 3),
            opt(s.corner_precision, 0, 3),
            opt(s.edge_recall, 0, 3),
            opt(s.edge_precision, 0, 3),
            opt(s.median_corner_error_to_oracle, 0, 2),
            opt(s.median_rectify_ratio, 0, 3),
            s.away_moved,
            s.cases_with_away_moved,
            s.found_on_border_h,
            s.cases_with_border_edges,
            s.passed,
            s.cases,
            100.0 * s.pass_share
        );
        let fails: Vec<String> = s
            .failed_checks
            .iter()
            .map(|f| format!("{} {}", f.check, f.cases))
            .collect();
        if !fails.is_empty() {
            let _ = writeln!(t, "cases failing each check: {}", fails.join(", "));
        }
    }
    let _ = writeln!(t);
    let _ = writeln!(
        t,
        "{} of {} cases pass; {:.1} s in total{}",
        rep.passed,
        rep.cases.len(),
        rep.seconds,
        rep.slowest_case
            .as_ref()
            .and_then(|n| rep.cases.iter().find(|r| &r.name == n))
            .map(|r| format!(
                ", slowest {} {:.1} s (synth {:.1}, pipeline {:.1}, scoring {:.1})",
                r.name, r.seconds.total, r.seconds.synth, r.seconds.pipeline, r.seconds.score
            ))
            .unwrap_or_default()
    );
    t
}

#[cfg(test)]
mod tests;
