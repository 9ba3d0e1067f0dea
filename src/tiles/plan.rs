//! `sharpedge plan`: cuts a cloud into tiles with halos after one streaming pass.
//!
//! Input: the pipeline file (its text and validated settings), the cloud, how to size the
//! tiles (`--tile-points N`, `--tile-size L` or `--grid NX,NY,NZ`), an optional grid anchor
//! and halo. Output: the plan folder with `plan.json` ([`super::Plan`]), a copy of the
//! pipeline file and `sbatch.sh`, a Slurm array script running one tile per task; all three
//! published as one set (`io::output_set`).
//!
//! The pass streams the points (`io::stream_positions`: PLY and LAS/LAZ/COPC chunk by chunk)
//! and keeps the bounding box, the count and a uniform sample of at most [`SAMPLE`] points
//! (reservoir sampling, seeded by the pipeline's seed). The sample gives the expected point
//! count of every tile and halo, and the mean spacing: the sample's points occupy cells of
//! a grid as a surface of area A does, A ≈ occupied cells × cell², at the finest grid whose
//! occupied cells hold [`MIN_PER_CELL`] sample points on average; spacing ≈ √(A / points).
//! The halo derives from it (see the module comment of `tiles`); every tile checks it
//! against the scale it measures.

use std::path::{Path, PathBuf};

use rand::rngs::SmallRng;
use rand::{RngExt, SeedableRng};

use super::{Bounds, Grid, Plan, SCALE_REACH_SPACINGS, Tile};
use crate::config::Settings;
use crate::error::{Error, Result};
use crate::io;

/// Sample size of the pass: 1M points (24 MB) count a tile of 1 % of the cloud to ±1 %.
pub const SAMPLE: usize = 1 << 20;
/// Sample points an occupied cell holds on average at the grid the spacing is measured on:
/// enough that a cell crossed by the surface is seen occupied.
const MIN_PER_CELL: f64 = 30.0;
/// At most this many tiles (a plan of more is a typo of --tile-points or --tile-size).
const MAX_TILES: usize = 100_000;

/// How the tiles are sized.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Sizing {
    /// Cubes, as few as keep every tile's core + halo at or below this many points.
    Points(u64),
    /// Cubes of this side.
    Size(f64),
    /// This many tiles along x, y, z, splitting the bounding box evenly.
    Cells([usize; 3]),
}

/// What `plan` needs besides the pipeline file.
#[derive(Debug, Clone)]
pub struct PlanOptions {
    pub input: PathBuf,
    pub out: PathBuf,
    pub sizing: Sizing,
    /// A corner of the grid (default: the bounding box's minimum), e.g. to put a seam along
    /// a known edge.
    pub anchor: Option<[f64; 3]>,
    /// Halo width in model units (default: derived).
    pub halo: Option<f64>,
    /// The `sharpedge` executable the generated script runs.
    pub exe: PathBuf,
}

/// What the streaming pass learnt.
struct Pass {
    points: u64,
    format: String,
    bounds: Bounds,
    sample: Vec<[f64; 3]>,
}

fn stream_pass(input: &Path, settings: &Settings) -> Result<Pass> {
    let mut rng = SmallRng::seed_from_u64(settings.seed ^ 0x7469_6c65_735f_706c);
    let mut sample: Vec<[f64; 3]> = Vec::new();
    let mut seen = 0u64;
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    let opts = io::ReadOptions {
        non_finite: settings.input.non_finite,
    };
    let streamed = io::stream_positions(input, &opts, &mut |_, chunk| {
        for p in chunk {
            for k in 0..3 {
                lo[k] = lo[k].min(p[k]);
                hi[k] = hi[k].max(p[k]);
            }
            // Reservoir sampling (Algorithm R): every point is kept with probability
            // SAMPLE / seen.
            if sample.len() < SAMPLE {
                sample.push(*p);
            } else {
                let j = rng.random_range(0..=seen);
                if (j as usize) < SAMPLE {
                    sample[j as usize] = *p;
                }
            }
            seen += 1;
        }
        Ok(())
    })?;
    if seen < 10 {
        return Err(Error::BadCloud {
            path: input.to_path_buf(),
            what: format!(
                "the cloud has {seen} finite points; there is nothing to cut into tiles \
                 (edge extraction needs thousands of points)"
            ),
        });
    }
    Ok(Pass {
        points: seen,
        format: streamed.format,
        bounds: [lo, hi],
        sample,
    })
}

/// Mean spacing of a surface sampled by `points` points of which `sample` is a uniform
/// sample: the area from the occupied cells of the finest grid whose occupied cells hold
/// [`MIN_PER_CELL`] sample points on average.
fn spacing_estimate(bounds: &Bounds, points: u64, sample: &[[f64; 3]]) -> f64 {
    let extent = (0..3)
        .map(|k| bounds[1][k] - bounds[0][k])
        .fold(0.0, f64::max);
    if extent <= 0.0 {
        return 0.0;
    }
    let mut cells_along = 1024usize;
    loop {
        let c = extent / cells_along as f64;
        let mut occupied: Vec<u64> = sample
            .iter()
            .map(|p| {
                let i = |k: usize| (((p[k] - bounds[0][k]) / c) as u64).min(cells_along as u64);
                i(0) | (i(1) << 21) | (i(2) << 42)
            })
            .collect();
        occupied.sort_unstable();
        occupied.dedup();
        let per_cell = sample.len() as f64 / occupied.len() as f64;
        if per_cell >= MIN_PER_CELL || cells_along <= 2 {
            let area = occupied.len() as f64 * c * c;
            return (area / points as f64).sqrt();
        }
        cells_along /= 2;
    }
}

/// Expected points of the sample in every tile's core and halo box, scaled to the cloud.
fn expected_counts(grid: &Grid, halo: f64, sample: &[[f64; 3]], points: u64) -> Vec<[u64; 2]> {
    let mut counts = vec![[0u64; 2]; grid.len()];
    for p in sample {
        counts[grid.owner(*p)][0] += 1;
        // The cells whose halo box holds p.
        let mut range = [[0usize; 2]; 3];
        for k in 0..3 {
            let mut lo = *p;
            let mut hi = *p;
            lo[k] -= halo;
            hi[k] += halo;
            range[k] = [grid.cell(lo)[k], grid.cell(hi)[k]];
        }
        for z in range[2][0]..=range[2][1] {
            for y in range[1][0]..=range[1][1] {
                for x in range[0][0]..=range[0][1] {
                    counts[grid.id([x, y, z])][1] += 1;
                }
            }
        }
    }
    let scale = points as f64 / sample.len().max(1) as f64;
    counts
        .into_iter()
        .map(|[a, b]| {
            [
                (a as f64 * scale).round() as u64,
                (b as f64 * scale).round() as u64,
            ]
        })
        .collect()
}

/// A grid of cubes of side `size` with a corner at `anchor` covering `bounds`: the grid's
/// origin is the anchor moved down by whole cells to the bounds' minimum, so seams lie at
/// the anchor plus multiples of `size` on both sides of it.
fn cube_grid(bounds: &Bounds, anchor: [f64; 3], size: f64) -> Grid {
    let mut cells = [1usize; 3];
    let mut origin = anchor;
    for k in 0..3 {
        if origin[k] > bounds[0][k] {
            origin[k] -= ((origin[k] - bounds[0][k]) / size).ceil() * size;
        }
        let n = ((bounds[1][k] - origin[k]) / size).ceil();
        cells[k] = if n > 1.0 { n.min(1e9) as usize } else { 1 };
    }
    Grid {
        origin,
        size: [size; 3],
        cells,
    }
}

fn usage(option: &str, message: String) -> Error {
    Error::Usage {
        option: option.into(),
        message,
    }
}

/// Chooses the grid for `sizing`.
fn choose_grid(
    sizing: Sizing,
    bounds: &Bounds,
    anchor: Option<[f64; 3]>,
    halo: f64,
    pass: &Pass,
) -> Result<Grid> {
    let origin = anchor.unwrap_or(bounds[0]);
    let extent = (0..3)
        .map(|k| bounds[1][k] - bounds[0][k])
        .fold(0.0, f64::max);
    let grid = match sizing {
        Sizing::Cells(n) => {
            if n.contains(&0) {
                return Err(usage(
                    "--grid",
                    format!("tiles per axis must be at least 1, got {n:?}"),
                ));
            }
            let mut size = [0.0; 3];
            for k in 0..3 {
                let e = bounds[1][k] - origin[k];
                size[k] = if e > 0.0 { e / n[k] as f64 } else { 1.0 };
            }
            Grid {
                origin,
                size,
                cells: n,
            }
        }
        Sizing::Size(l) => {
            if !(l.is_finite() && l > 0.0) {
                return Err(usage(
                    "--tile-size",
                    format!("must be a positive length, got {l}"),
                ));
            }
            cube_grid(bounds, origin, l)
        }
        Sizing::Points(n) => {
            // The fewest cubes along the longest axis whose largest tile + halo fits.
            let mut best = None;
            let mut smallest = u64::MAX;
            for m in 1..=1000usize {
                let size = extent / m as f64;
                let g = cube_grid(bounds, origin, size);
                if g.len() > MAX_TILES {
                    break;
                }
                let most = expected_counts(&g, halo, &pass.sample, pass.points)
                    .iter()
                    .map(|c| c[1])
                    .max()
                    .unwrap_or(0);
                smallest = smallest.min(most);
                if most <= n {
                    best = Some(g);
                    break;
                }
                if size < halo / 4.0 {
                    // Tiles far thinner than their halo read mostly halo: no point in more.
                    break;
                }
            }
            best.ok_or_else(|| {
                usage(
                    "--tile-points",
                    format!(
                        "{n} points per tile cannot be reached: with a halo of {halo:.6} the \
                         smallest tiles tried still read {smallest} points; allow more \
                         points per tile, or give a narrower --halo"
                    ),
                )
            })?
        }
    };
    if grid.len() > MAX_TILES {
        let option = match sizing {
            Sizing::Points(_) => "--tile-points",
            Sizing::Size(_) => "--tile-size",
            Sizing::Cells(_) => "--grid",
        };
        return Err(usage(
            option,
            format!(
                "{:.0} tiles ({} x {} x {}) are more than the {MAX_TILES} a plan may have; give \
                 larger tiles",
                grid.cells.iter().map(|&c| c as f64).product::<f64>(),
                grid.cells[0],
                grid.cells[1],
                grid.cells[2]
            ),
        ));
    }
    Ok(grid)
}

/// Makes the plan and writes the plan folder. `config_path` is the pipeline file `settings`
/// came from.
pub fn make_plan(config_path: &Path, settings: &Settings, opts: &PlanOptions) -> Result<Plan> {
    let config_text = std::fs::read_to_string(config_path)
        .map_err(|e| Error::io(config_path, "cannot read pipeline file", e))?;
    let tiles_dir = opts.out.join("tiles");
    if tiles_dir.exists() {
        return Err(Error::Plan {
            path: tiles_dir,
            what: "the folder holds the tiles of an earlier plan, which a new plan would mix \
                   with its own; remove it or choose another --out"
                .into(),
        });
    }
    let pass = stream_pass(&opts.input, settings)?;
    let spacing = spacing_estimate(&pass.bounds, pass.points, &pass.sample);
    let f = &settings.features;
    let radius = f.radius.unwrap_or(f.min_radius * spacing);
    let reach_radii = 1.0 + settings.corners.reach + settings.edges.band;
    let (halo, halo_rule) = match opts.halo {
        Some(h) if h.is_finite() && h >= 0.0 => (h, "given (--halo)".to_string()),
        Some(h) => {
            return Err(usage("--halo", format!("must be a length >= 0, got {h}")));
        }
        None => (
            SCALE_REACH_SPACINGS * spacing + reach_radii * radius,
            format!(
                "{SCALE_REACH_SPACINGS} spacings (local scale) + (1 + corners.reach {} + \
                 edges.band {}) radii of {radius:.6} (features.radius, or min_radius {} x the \
                 estimated spacing {spacing:.6})",
                settings.corners.reach, settings.edges.band, f.min_radius
            ),
        ),
    };
    let grid = choose_grid(opts.sizing, &pass.bounds, opts.anchor, halo, &pass)?;
    let counts = expected_counts(&grid, halo, &pass.sample, pass.points);
    let tiles: Vec<Tile> = (0..grid.len())
        .map(|id| {
            let core = grid.core(id);
            let halo_box = [core[0].map(|x| x - halo), core[1].map(|x| x + halo)];
            Tile {
                id,
                cell: grid.cell_of(id),
                core,
                halo: halo_box,
                points: counts[id][0],
                halo_points: counts[id][1],
            }
        })
        .collect();
    let input = std::path::absolute(&opts.input)
        .map_err(|e| Error::io(&opts.input, "cannot resolve the path of", e))?;
    let config = std::path::absolute(config_path)
        .map_err(|e| Error::io(config_path, "cannot resolve the path of", e))?;
    let plan = Plan {
        sharpedge: env!("CARGO_PKG_VERSION").to_string(),
        input,
        format: pass.format,
        points: pass.points,
        config,
        config_text,
        bounds: pass.bounds,
        spacing,
        radius,
        halo,
        halo_rule,
        grid,
        tiles,
    };
    write_plan(&plan, &opts.out, &opts.exe)?;
    Ok(plan)
}

/// Writes plan.json, the pipeline file's copy and sbatch.sh into `dir` as one set.
fn write_plan(plan: &Plan, dir: &Path, exe: &Path) -> Result<()> {
    std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, "cannot create plan folder", e))?;
    // Slurm opens a task's log before the script runs: the folder must exist.
    let logs = dir.join("logs");
    std::fs::create_dir_all(&logs).map_err(|e| Error::io(&logs, "cannot create", e))?;
    let names = [super::PLAN_FILE, super::CONFIG_FILE, super::SBATCH_FILE];
    let staging = io::output_set::stage(dir, &names)?;
    let text = crate::json::pretty(plan)
        .map_err(|e| Error::io(dir.join(names[0]), "cannot write plan", e.into()))?
        + "\n";
    let put = |path: PathBuf, text: &str| {
        io::write_atomic(&path, |w| {
            w.write_all(text.as_bytes())
                .map_err(|e| Error::io(&path, "cannot write", e))
        })
    };
    put(staging.file(0), &text)?;
    put(staging.file(1), &plan.config_text)?;
    put(staging.file(2), &sbatch_script(plan, dir, exe)?)?;
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        let f = staging.file(2);
        std::fs::set_permissions(&f, std::fs::Permissions::from_mode(0o755))
            .map_err(|e| Error::io(&f, "cannot make executable", e))?;
    }
    staging.publish()?;
    Ok(())
}

/// Quotes a path for a POSIX shell.
fn shell_quote(p: &Path) -> String {
    format!("'{}'", p.display().to_string().replace('\'', r"'\''"))
}

/// The Slurm array script: one task per tile, each running `sharpedge run` on its tile with
/// the plan's copy of the pipeline file; logs in `DIR/logs/`. Submit with `sbatch
/// DIR/sbatch.sh` (add `--wait` to block until every task ended), then `sharpedge merge`.
fn sbatch_script(plan: &Plan, dir: &Path, exe: &Path) -> Result<String> {
    let dir =
        std::path::absolute(dir).map_err(|e| Error::io(dir, "cannot resolve the path of", e))?;
    let most = plan.tiles.iter().map(|t| t.halo_points).max().unwrap_or(0);
    Ok(format!(
        "#!/bin/sh\n\
         # sharpedge tiles of {input} ({points} points, {n} tiles): one Slurm array task per tile.\n\
         # Submit: sbatch {script}   (sbatch --wait ... blocks until all tasks ended)\n\
         # Then:   {exe_q} merge {dir_q} --out RESULT_DIR\n\
         # A failed tile is named by merge and rerun alone: sbatch --array=I {script}\n\
         # The largest tile reads about {most} points (core + halo); a worker's peak memory grows\n\
         # with it (README, \"Tiles\"): set --mem accordingly.\n\
         #SBATCH --job-name=sharpedge-tiles\n\
         #SBATCH --array=0-{last}\n\
         #SBATCH --cpus-per-task=1\n\
         #SBATCH --output={logs}/tile-%a.log\n\
         exec {exe_q} -q run {config_q} --plan {dir_q} --tile \"$SLURM_ARRAY_TASK_ID\" --threads \"${{SLURM_CPUS_PER_TASK:-1}}\"\n",
        input = plan.input.display(),
        points = plan.points,
        n = plan.tiles.len(),
        script = dir.join(super::SBATCH_FILE).display(),
        last = plan.tiles.len() - 1,
        logs = dir.join("logs").display(),
        exe_q = shell_quote(exe),
        config_q = shell_quote(&dir.join(super::CONFIG_FILE)),
        dir_q = shell_quote(&dir),
    ))
}
