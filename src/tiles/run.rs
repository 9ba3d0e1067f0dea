//! `sharpedge run CONFIG --plan DIR --tile I`: one tile of a plan.
//!
//! Input: the plan folder, the tile id, the validated settings of the pipeline file (whose
//! text must be the plan's). Output: `DIR/tiles/NNNN/partial.json` ([`Partial`]: every edge
//! and corner the tile found, with its rectified edge points, the tile's counts over the
//! points it owns, its scale, timings and left-out candidates) and `DIR/tiles/NNNN/
//! rectified.ply` (the points the tile owns, in input order, with their input index), published
//! together (`io::output_set`). On failure `DIR/tiles/NNNN.failed` holds the error; a later
//! success removes it.
//!
//! The tile streams the input (`io::stream_positions`) and keeps the points inside its halo
//! box, so its memory follows the tile, not the cloud; then it runs the stages of `run`
//! (`pipeline::process`) on them unchanged. Which edges and corners it keeps is `merge`'s
//! decision (by the owner rule of `tiles::Grid`), made on every tile's full results.

use std::path::{Path, PathBuf};
use std::time::Instant;

use serde::{Deserialize, Serialize};

use super::{Plan, SCALE_REACH_SPACINGS, failed_file, inside, tile_dir};
use crate::cloud::{Attribute, Cloud, Column, Source};
use crate::config::Settings;
use crate::error::{Error, Result};
use crate::io::{self, PlyWriteOptions};
use crate::outcome::{CornerOut, EdgeOut, FitErrors};
use crate::pipeline::LapClock;

/// The partial output file of a tile.
pub const PARTIAL_FILE: &str = "partial.json";
/// The rectified points a tile owns.
pub const RECTIFIED_FILE: &str = "rectified.ply";

/// One edge as a tile found it (the reported edge, with its rectified edge points).
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct PartEdge {
    pub id: usize,
    pub start: [f64; 3],
    pub end: [f64; 3],
    pub direction: [f64; 3],
    pub points: usize,
    pub rms: f64,
    pub corners: [Option<usize>; 2],
    pub convex: Option<bool>,
    /// Convex and concave votes.
    pub votes: [usize; 2],
    pub dihedral_deg: Option<f64>,
    pub polyline: Vec<[f64; 3]>,
    pub closed: bool,
    pub rectified: Vec<[f64; 3]>,
    /// Fit errors: Scheme 1, PSO, exact (the pipeline runs no GA).
    pub error: Option<[f64; 3]>,
}

impl PartEdge {
    fn of(e: &EdgeOut) -> Self {
        PartEdge {
            id: e.id,
            start: e.start,
            end: e.end,
            direction: e.direction,
            points: e.points,
            rms: e.rms,
            corners: e.corners,
            convex: e.convex,
            votes: [e.convex_votes.convex, e.convex_votes.concave],
            dihedral_deg: e.dihedral_deg,
            polyline: e.polyline.clone(),
            closed: e.closed,
            rectified: e.rectified.clone(),
            error: e.error.map(errors_of),
        }
    }
}

/// Fit errors as three numbers: Scheme 1, PSO, exact (the pipeline runs no GA: `ga` is
/// always absent in its reports).
pub fn errors_of(f: FitErrors) -> [f64; 3] {
    [f.scheme1, f.pso, f.exact]
}

/// Fit errors back from [`errors_of`].
pub fn errors_from(a: [f64; 3]) -> FitErrors {
    FitErrors {
        scheme1: a[0],
        pso: a[1],
        ga: None,
        exact: a[2],
    }
}

/// One corner as a tile found it.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct PartCorner {
    pub id: usize,
    pub position: [f64; 3],
    pub edges: Vec<usize>,
    pub error: Option<[f64; 3]>,
    pub scheme1: [f64; 3],
    pub exact: [f64; 3],
}

impl PartCorner {
    fn of(c: &CornerOut) -> Self {
        PartCorner {
            id: c.id,
            position: c.position,
            edges: c.edges.clone(),
            error: c.error.map(errors_of),
            scheme1: c.scheme1,
            exact: c.exact,
        }
    }
}

/// Counts over the points a tile owns.
#[derive(Debug, Clone, Copy, Default, Serialize, Deserialize)]
pub struct CoreCounts {
    pub points: u64,
    pub candidates: u64,
    pub outliers: u64,
    pub moved: u64,
}

/// What a tile hands to `merge`.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct Partial {
    pub tile: usize,
    /// Points read (core + halo) and the counts over the core's.
    pub read: u64,
    pub core: CoreCounts,
    /// Edge runs the tile's segment stage found (core and halo).
    pub runs: usize,
    /// The tile's scale (medians over the points read): spacing, pitch, noise, radius.
    pub scale: [f64; 4],
    /// The halo the plan gave and the one this tile's scale asks for.
    pub halo: f64,
    pub halo_needed: f64,
    pub edges: Vec<PartEdge>,
    pub corners: Vec<PartCorner>,
    /// The tile's left-out candidates as report.json lists them.
    pub left_out: Vec<serde_json::Value>,
    /// Stage timings, seconds.
    pub timings: Vec<(String, f64)>,
}

/// A stage clock that keeps the laps.
struct Laps {
    laps: Vec<(String, f64)>,
    last: Instant,
}

impl LapClock for Laps {
    fn lap(&mut self, stage: &'static str) {
        let now = Instant::now();
        self.laps
            .push((stage.to_string(), (now - self.last).as_secs_f64()));
        self.last = now;
    }
}

/// The pipeline file's text, checked against the plan's: the halo was derived from it.
pub fn check_config(plan: &Plan, plan_dir: &Path, config: &Path, text: &str) -> Result<()> {
    if text == plan.config_text {
        return Ok(());
    }
    Err(Error::Plan {
        path: config.to_path_buf(),
        what: format!(
            "this is not the pipeline file the plan in {} was made with (its halo follows from \
             it); run the tiles with the plan's copy {}, or make a new plan",
            plan_dir.display(),
            plan_dir.join(super::CONFIG_FILE).display()
        ),
    })
}

/// What [`run_tile`] did, for the summary line.
#[derive(Debug, Clone)]
pub struct TileSummary {
    pub tile: usize,
    pub read: u64,
    pub core: u64,
    pub edges: usize,
    pub corners: usize,
    pub outputs: Vec<PathBuf>,
}

/// Runs one tile; on failure records the error in `tiles/NNNN.failed` (and returns it).
pub fn run_tile(
    settings: &Settings,
    config: &Path,
    plan_dir: &Path,
    tile: usize,
) -> Result<TileSummary> {
    let plan = Plan::load(plan_dir)?;
    plan.tile(plan_dir, tile)?;
    let text = std::fs::read_to_string(config)
        .map_err(|e| Error::io(config, "cannot read pipeline file", e))?;
    check_config(&plan, plan_dir, config, &text)?;
    let failed = failed_file(plan_dir, tile);
    let result = run_checked(settings, &plan, plan_dir, tile);
    match &result {
        Ok(_) => {
            if failed.exists() {
                std::fs::remove_file(&failed)
                    .map_err(|e| Error::io(&failed, "cannot remove the old failure record", e))?;
            }
        }
        Err(e) => {
            // Best effort: the error itself is what the caller reports.
            let message = format!("{e}");
            if let Some(parent) = failed.parent() {
                let _ = std::fs::create_dir_all(parent);
            }
            let _ = io::write_atomic(&failed, |w| {
                w.write_all(message.as_bytes())
                    .map_err(|err| Error::io(&failed, "cannot write", err))
            });
        }
    }
    result
}

fn run_checked(
    settings: &Settings,
    plan: &Plan,
    plan_dir: &Path,
    tile: usize,
) -> Result<TileSummary> {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(settings.threads)
        .build()
        .map_err(|e| Error::Usage {
            option: "threads".into(),
            message: format!("cannot start {} worker threads: {e}", settings.threads),
        })?;
    pool.install(|| run_in_pool(settings, plan, plan_dir, tile))
}

fn run_in_pool(
    settings: &Settings,
    plan: &Plan,
    plan_dir: &Path,
    tile: usize,
) -> Result<TileSummary> {
    let mut clock = Laps {
        laps: Vec::new(),
        last: Instant::now(),
    };
    let halo_box = plan.tiles[tile].halo;
    let mut positions: Vec<[f64; 3]> = Vec::new();
    let mut index: Vec<u64> = Vec::new();
    let opts = io::ReadOptions {
        non_finite: settings.input.non_finite,
    };
    io::stream_positions(&plan.input, &opts, &mut |first, chunk| {
        for (k, p) in chunk.iter().enumerate() {
            if inside(&halo_box, *p) {
                positions.push(*p);
                index.push(first + k as u64);
            }
        }
        Ok(())
    })?;
    clock.lap("read");
    let grid = plan.grid;
    let core: Vec<bool> = positions.iter().map(|p| grid.owner(*p) == tile).collect();
    let core_points = core.iter().filter(|&&c| c).count() as u64;
    let dir = tile_dir(plan_dir, tile);
    std::fs::create_dir_all(&dir).map_err(|e| Error::io(&dir, "cannot create", e))?;
    if core_points == 0 {
        // Nothing to own: an empty partial (the halo's points belong to other tiles).
        let partial = Partial {
            tile,
            read: positions.len() as u64,
            core: CoreCounts::default(),
            runs: 0,
            scale: [0.0; 4],
            halo: plan.halo,
            halo_needed: 0.0,
            edges: Vec::new(),
            corners: Vec::new(),
            left_out: Vec::new(),
            timings: clock.laps,
        };
        let empty = rectified_columns(Vec::new(), Vec::new(), Vec::new(), Vec::new(), Vec::new());
        let outputs = publish(&dir, &partial, &[], &empty)?;
        return Ok(TileSummary {
            tile,
            read: partial.read,
            core: 0,
            edges: 0,
            corners: 0,
            outputs,
        });
    }
    let cloud = Cloud {
        positions,
        attributes: Vec::new(),
        source: Source {
            path: plan.input.clone(),
            format: plan.format.clone(),
            double_precision: true,
        },
        structure: None,
    };
    let outcome = crate::pipeline::process(cloud, settings, &mut clock)?;
    let s = outcome.scale;
    let halo_needed = SCALE_REACH_SPACINGS * s.spacing
        + (1.0 + settings.corners.reach + settings.edges.band) * s.radius;
    // A halo a few percent short of the rule is the spacing estimate's error, not a
    // different cloud: the rule has margins of whole radii.
    if plan.halo < 0.9 * halo_needed {
        return Err(Error::Plan {
            path: plan_dir.join(super::PLAN_FILE),
            what: format!(
                "tile {tile}: the halo {:.6} is narrower than this tile's scale needs, \
                 {halo_needed:.6} ({SCALE_REACH_SPACINGS} spacings of {:.6} + (1 + corners.reach \
                 + edges.band) radii of {:.6}); make the plan again with --halo {:.6} or more",
                plan.halo, s.spacing, s.radius, halo_needed
            ),
        });
    }
    let count = |v: &[bool]| v.iter().zip(&core).filter(|&(&a, &c)| a && c).count() as u64;
    let counts = CoreCounts {
        points: core_points,
        candidates: count(&outcome.features.candidate),
        outliers: count(&outcome.features.outlier),
        moved: count(&outcome.moved),
    };
    let left_out = outcome
        .left_out
        .iter()
        .map(|l| serde_json::to_value(l).unwrap_or(serde_json::Value::Null))
        .collect();
    clock.lap("tile");
    let partial = Partial {
        tile,
        read: outcome.cloud.len() as u64,
        core: counts,
        runs: outcome.segments.runs.len(),
        scale: [s.spacing, s.pitch, s.noise, s.radius],
        halo: plan.halo,
        halo_needed,
        edges: outcome.edges.iter().map(PartEdge::of).collect(),
        corners: outcome.corners.iter().map(PartCorner::of).collect(),
        left_out,
        timings: clock.laps,
    };
    // The points the tile owns, in input order, with their index in the input.
    let mut pos = Vec::with_capacity(core_points as usize);
    let mut idx = Vec::with_capacity(core_points as usize);
    let mut label = Vec::with_capacity(core_points as usize);
    let mut moved = Vec::with_capacity(core_points as usize);
    let mut disp = Vec::with_capacity(core_points as usize);
    let mut sharp = Vec::with_capacity(core_points as usize);
    for i in (0..core.len()).filter(|&i| core[i]) {
        let (a, b) = (outcome.cloud.positions[i], outcome.rectified[i]);
        pos.push(b);
        idx.push(index[i] as f64);
        let l = outcome.edge_label[i];
        label.push(if l == u32::MAX { -1 } else { l as i32 });
        moved.push(u8::from(outcome.moved[i]));
        disp.push(crate::geometry::dist(a, b) as f32);
        sharp.push(outcome.features.split[i]);
    }
    let columns = rectified_columns(idx, label, moved, disp, sharp);
    let outputs = publish(&dir, &partial, &pos, &columns)?;
    Ok(TileSummary {
        tile,
        read: partial.read,
        core: core_points,
        edges: partial.edges.len(),
        corners: partial.corners.len(),
        outputs,
    })
}

/// The per-point fields of a tile's rectified points (the names of rectified.ply, plus the
/// input index as a double: exact to 2^53 points).
pub fn rectified_columns(
    index: Vec<f64>,
    label: Vec<i32>,
    moved: Vec<u8>,
    displacement: Vec<f32>,
    sharpness: Vec<f32>,
) -> Vec<Attribute> {
    let (mut red, mut green, mut blue) = (Vec::new(), Vec::new(), Vec::new());
    for &l in &label {
        let c = crate::report::colour(if l < 0 { u32::MAX } else { l as u32 });
        red.push(c[0]);
        green.push(c[1]);
        blue.push(c[2]);
    }
    let named = |name: &str, values: Column| Attribute {
        name: name.into(),
        values,
    };
    vec![
        named("scalar_edge_id", Column::I32(label)),
        named("scalar_moved", Column::U8(moved)),
        named("scalar_displacement", Column::F32(displacement)),
        named("scalar_sharpness", Column::F32(sharpness.clone())),
        named("quality", Column::F32(sharpness)),
        named("red", Column::U8(red)),
        named("green", Column::U8(green)),
        named("blue", Column::U8(blue)),
        named("scalar_index", Column::F64(index)),
    ]
}

/// Publishes a tile's two files as one set.
fn publish(
    dir: &Path,
    partial: &Partial,
    positions: &[[f64; 3]],
    columns: &[Attribute],
) -> Result<Vec<PathBuf>> {
    let names = [PARTIAL_FILE, RECTIFIED_FILE];
    let staging = io::output_set::stage(dir, &names)?;
    let text = crate::json::pretty(partial)
        .map_err(|e| Error::io(dir.join(PARTIAL_FILE), "cannot write", e.into()))?
        + "\n";
    let f = staging.file(0);
    io::write_atomic(&f, |w| {
        w.write_all(text.as_bytes())
            .map_err(|e| Error::io(&f, "cannot write", e))
    })?;
    let refs: Vec<&Attribute> = columns.iter().collect();
    io::write_ply(
        &staging.file(1),
        positions,
        &refs,
        &[],
        &PlyWriteOptions {
            encoding: io::PlyEncoding::BinaryLittleEndian,
            precision: io::Precision::F64,
        },
    )?;
    staging.publish()
}
