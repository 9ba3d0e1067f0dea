//! The command line: clap definitions of every subcommand and the glue that turns parsed
//! arguments into library calls. No algorithm lives here; each subcommand's work is a library
//! function that tests can call directly.

use std::path::PathBuf;

use clap::{Args, Parser, Subcommand};

/// Finds the sharp edges and corners of 3D scans with sub-point accuracy and rectifies the
/// scan there.
#[derive(Debug, Parser)]
#[command(name = "sharpedge", version, about, long_about = None)]
pub struct Cli {
    /// Print only errors (no progress bars, no summary).
    #[arg(short, long, global = true, conflicts_with = "verbose")]
    pub quiet: bool,
    /// More log output: -v stage details, -vv debug, -vvv trace. RUST_LOG overrides.
    #[arg(short, long, global = true, action = clap::ArgAction::Count)]
    pub verbose: u8,
    #[command(subcommand)]
    pub command: Command,
}

#[derive(Debug, Subcommand)]
pub enum Command {
    /// Run the pipeline described by a pipeline.toml.
    Run(RunArgs),
    /// Simulate a scan of a part with known edges and corners (ground truth as JSON).
    Synth(Box<SynthArgs>),
    /// Describe a point cloud file: format, point count, properties, bounding box, spacing.
    Info(InfoArgs),
    /// Reproduce the paper's experiments (§4) on generated data.
    Experiment(ExperimentArgs),
    /// Score the pipeline against ground truth on a suite of simulated scans.
    Bench(BenchArgs),
    /// Cut a large cloud into tiles with halos for `run --plan DIR --tile I` (one streaming
    /// pass); writes DIR/plan.json and a Slurm array script DIR/sbatch.sh.
    Plan(PlanArgs),
    /// Join the tiles of a plan into one result (the output files of `run`).
    Merge(MergeArgs),
}

#[derive(Debug, Args)]
pub struct PlanArgs {
    /// The pipeline file (its copy goes into the plan; the tiles run with it).
    pub config: PathBuf,
    /// The cloud to cut; default: `input.path` of the config.
    #[arg(long)]
    pub input: Option<PathBuf>,
    /// The plan folder.
    #[arg(long)]
    pub out: PathBuf,
    /// Cubic tiles, as few as keep every tile's core + halo at or below N points.
    #[arg(long, value_name = "N", conflicts_with_all = ["tile_size", "grid"])]
    pub tile_points: Option<u64>,
    /// Cubic tiles of side L (model units).
    #[arg(long, value_name = "L", conflicts_with = "grid")]
    pub tile_size: Option<f64>,
    /// NX,NY,NZ tiles splitting the bounding box evenly.
    // clap counts `num_args` before splitting at the delimiter: 1..=3 takes `2,2,2` and
    // `2 2 2`; the count of three is checked after parsing.
    #[arg(long, value_name = "NX,NY,NZ", value_delimiter = ',', num_args = 1..=3)]
    pub grid: Option<Vec<usize>>,
    /// A corner X,Y,Z of the tile grid (default: the bounding box's minimum).
    #[arg(
        long,
        value_name = "X,Y,Z",
        value_delimiter = ',',
        num_args = 1..=3,
        allow_hyphen_values = true
    )]
    pub anchor: Option<Vec<f64>>,
    /// Halo width in model units (default: derived from the spacing and the pipeline file;
    /// see the README's "Tiles").
    #[arg(long, value_name = "L")]
    pub halo: Option<f64>,
}

#[derive(Debug, Args)]
pub struct MergeArgs {
    /// The plan folder whose tiles ran.
    pub plan: PathBuf,
    /// Output folder.
    #[arg(long)]
    pub out: PathBuf,
    /// Write what the finished tiles give even when some are missing or failed (they are
    /// listed in report.json).
    #[arg(long)]
    pub partial: bool,
}

#[derive(Debug, Args)]
pub struct RunArgs {
    /// The pipeline file (see the commented pipeline.toml in the repository).
    pub config: PathBuf,
    /// Input cloud; overrides `input.path` of the config.
    #[arg(long)]
    pub input: Option<PathBuf>,
    /// Output folder; overrides `output.dir` of the config.
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Worker threads; overrides `threads` of the config (0 = all cores).
    #[arg(long)]
    pub threads: Option<usize>,
    /// File format of the rectified cloud; overrides `output.format` of the config (auto:
    /// LAS/LAZ/PCD/E57 as the input, COPC as LAZ, PLY otherwise).
    #[arg(long, value_parser = ["auto", "ply", "las", "laz", "pcd", "e57"])]
    pub format: Option<String>,
    /// Run one tile of this plan (see `sharpedge plan`) instead of the whole input; its
    /// partial outputs go into the plan folder.
    #[arg(long, requires = "tile", conflicts_with_all = ["input", "out", "format"])]
    pub plan: Option<PathBuf>,
    /// The tile of --plan to run (0-based).
    #[arg(long, requires = "plan")]
    pub tile: Option<usize>,
}

#[derive(Debug, Args)]
pub struct SynthArgs {
    /// Parametric part: box, lblock, step, wedge, prism, pyramid, sphere, or random: a part
    /// drawn from --seed (an extrusion of a random polygon with convex and concave vertical
    /// edges opening 20°-160°, sometimes tapered walls, chamfers, wide fillets (5-45 spacings,
    /// smooth: in the truth as fillets, not sharp edges), a stacked block, through-holes; the
    /// distribution is in the module comment of src/synth/random.rs and the README).
    #[arg(long, default_value = "box", conflicts_with = "mesh")]
    pub part: String,
    /// Sample this triangle mesh (OFF, PLY or OBJ) instead of a parametric part.
    #[arg(long)]
    pub mesh: Option<PathBuf>,
    /// Number of points (approximate; sampling is on a jittered grid). Default 100000.
    #[arg(long, conflicts_with = "spacing")]
    pub points: Option<usize>,
    /// Sampling pitch in model units (instead of --points).
    #[arg(long)]
    pub spacing: Option<f64>,
    /// Gaussian noise sigma, in multiples of the spacing.
    #[arg(long, default_value_t = 0.0)]
    pub noise: f64,
    /// Rounding radius of sharp edges, in multiples of the spacing (the scan's abnormality).
    #[arg(long, default_value_t = 0.0)]
    pub round: f64,
    /// Extra noise sigma near sharp edges, in multiples of the spacing.
    #[arg(long, default_value_t = 0.0)]
    pub edge_noise: f64,
    /// Width of the band around sharp edges that gets --edge-noise, in spacings.
    #[arg(long, default_value_t = 3.0)]
    pub edge_band: f64,
    /// Fraction of points replaced by outliers in the bounding box (0..1).
    #[arg(long, default_value_t = 0.0)]
    pub outliers: f64,
    /// Rotate the part by a random rotation (drawn from --seed).
    #[arg(long)]
    pub rotate: bool,
    /// Translate the part by X,Y,Z (e.g. a georeferenced offset 512345.1,4101234.5,80; three
    /// separate values are accepted too).
    // clap counts `num_args` before splitting at the delimiter: 1..=3 takes both `X,Y,Z`
    // and `X Y Z`; the count of three is checked after parsing.
    #[arg(
        long,
        value_delimiter = ',',
        num_args = 1..=3,
        allow_negative_numbers = true
    )]
    pub translate: Option<Vec<f64>>,
    /// Random seed.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Write double coordinates (default: float unless the translation needs double).
    #[arg(long)]
    pub double: bool,
    /// Write ascii PLY instead of binary little endian.
    #[arg(long)]
    pub ascii: bool,
    /// Part size (its largest extent) in model units. Default: 100 for parametric parts, the
    /// file's own units for meshes.
    #[arg(long)]
    pub size: Option<f64>,
    /// Number of sides of the prism.
    #[arg(long, default_value_t = 6)]
    pub sides: usize,
    /// Dihedral angle of the wedge's sharp edge, in degrees.
    #[arg(long, default_value_t = 30.0)]
    pub angle: f64,
    /// Number of steps of the stepped block.
    #[arg(long, default_value_t = 3)]
    pub steps: usize,
    /// Grid jitter (full width per axis) in spacings, 0..1.
    #[arg(long, default_value_t = 0.1)]
    pub jitter: f64,
    /// For --mesh: a mesh edge is sharp when its dihedral angle exceeds this many degrees.
    #[arg(long, default_value_t = 30.0)]
    pub sharp_angle: f64,
    /// For --mesh with curved regions: levels of Loop subdivision (sharp edges stay creases)
    /// before sampling, so faceted curved patches are scanned as the smooth surfaces they
    /// stand for; 0 samples the facets as they are (0..4).
    #[arg(long, default_value_t = 2)]
    pub subdivide: u32,
    /// Sampling pattern: uniform (a jittered grid on every face, the default), lines (parallel
    /// scan lines: cuts by planes --line-gap spacings apart, sampled every spacing along
    /// them), grid (structured light: a sensor casts a pixel grid of rays, the first hits are
    /// the points; pitch grows with incidence, noise lies along the ray), view (the uniform
    /// grid kept where a sensor sees it: faces turned away and hidden parts are missing).
    #[arg(long, default_value = "uniform")]
    pub pattern: String,
    /// For --pattern lines: gap between the lines in along-line spacings (1..100).
    #[arg(long, default_value_t = 3.0)]
    pub line_gap: f64,
    /// For --pattern lines: normal of the cut planes X,Y,Z (world; default drawn from --seed).
    #[arg(long, allow_hyphen_values = true)]
    pub line_direction: Option<String>,
    /// For --pattern grid|view: a sensor position X,Y,Z (world), once per view; default:
    /// drawn from --seed at 4 bounding radii from the part's centre.
    #[arg(long, allow_hyphen_values = true)]
    pub sensor: Vec<String>,
    /// For --pattern grid|view: number of overlapping views (1..16). View v samples with pitch
    /// spacing·2^(v/(views-1)), and every view after the first is misregistered.
    #[arg(long)]
    pub views: Option<usize>,
    /// Largest displacement of a view by its misregistration (a small random rigid motion per
    /// view, from --seed), in spacings.
    #[arg(long, default_value_t = 0.2)]
    pub misregistration: f64,
    /// Density ratio between the two ends of the part (1: uniform density); the density falls
    /// smoothly (exponentially) along --density-direction. Any pattern.
    #[arg(long, default_value_t = 1.0)]
    pub density_ratio: f64,
    /// Direction X,Y,Z (world) in which the density falls (default drawn from --seed).
    #[arg(long, allow_hyphen_values = true)]
    pub density_direction: Option<String>,
    /// Noise grows with the incidence angle θ at the sensor: sigma / cos θ, capped at
    /// --incidence-cap times sigma. Any pattern (without views: from one sensor).
    #[arg(long)]
    pub incidence_noise: bool,
    /// Largest noise factor of --incidence-noise (1..100).
    #[arg(long, default_value_t = 4.0)]
    pub incidence_cap: f64,
    /// Also write each point's truth (scalar_abnormal, scalar_outlier, scalar_edge_distance,
    /// and scalar_view for scans with views) into the PLY, for inspection.
    #[arg(long)]
    pub truth_fields: bool,
    /// Output cloud (PLY).
    #[arg(short, long)]
    pub out: PathBuf,
    /// Ground-truth JSON (default: the output path with .truth.json).
    #[arg(long)]
    pub truth: Option<PathBuf>,
}

#[derive(Debug, Args)]
pub struct InfoArgs {
    /// A PLY, LAS, LAZ or XYZ file.
    pub file: PathBuf,
    /// Print JSON instead of text.
    #[arg(long)]
    pub json: bool,
}

#[derive(Debug, Args)]
pub struct ExperimentArgs {
    /// 2 or 3; both when omitted.
    #[arg(long, value_parser = clap::value_parser!(u8).range(2..=3))]
    pub dim: Option<u8>,
    /// Trials per dimension.
    #[arg(long, default_value_t = 1000)]
    pub trials: usize,
    /// Random seed.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Write SVG figures (convergence, PSO vs GA, one fit) into this folder.
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// PSO / GA iterations (default: the paper's 20 in 2D, 10 in 3D).
    #[arg(long)]
    pub iterations: Option<usize>,
    /// Fewest particles (the corner region is grown to this many data points; default 20).
    #[arg(long)]
    pub min_particles: Option<usize>,
    /// Start the swarm on corner-region data points only, as the paper does. By default one
    /// more particle starts at the meeting point of the local side fits, as in the pipeline:
    /// with the paper's 10 iterations in 3D that takes PSO from 91 % to 99.9 % of trials
    /// within 1 % of the exact optimum (1000 trials, seed 1).
    #[arg(long)]
    pub paper_init: bool,
    /// Round the generated corners with a fillet (2D) or blunting (3D) of up to this size
    /// (the sides are 10 long). Not in the paper's data; a stress test of the search.
    #[arg(long, default_value_t = 0.0)]
    pub rounding: f64,
    /// Print one JSON object instead of tables (with both dimensions, their objects are in an
    /// "experiments" array).
    #[arg(long)]
    pub json: bool,
}

#[derive(Debug, Args)]
pub struct BenchArgs {
    /// Points per case (the 30k box keeps 30,000; default 500,000, with --patterns 100,000);
    /// with --random, the cap of the drawn point counts (30,000 up to this).
    #[arg(long)]
    pub points: Option<usize>,
    /// Run N random parts under random scan settings instead of the suite: the parts and the
    /// settings (points log-uniform from 30,000 to --points, noise 0..0.3 h, edge rounding
    /// 0..2 h, a random rotation, a sampling pattern: uniform, scan lines 1-10 h apart,
    /// structured-light grid or views, sometimes a density gradient or incidence noise) are
    /// drawn from --seed; each case prints its own seed and the `sharpedge synth` command that
    /// makes its scan alone, and a summary row aggregates them.
    #[arg(long, value_name = "N", conflicts_with_all = ["patterns", "cad"])]
    pub random: Option<usize>,
    /// With --random: scan every part uniformly (the same parts, points, noise and rounding as
    /// without it; no pattern, gradient or incidence noise drawn).
    #[arg(long, requires = "random")]
    pub uniform: bool,
    /// Instead of the suite, issue 17's pattern check: box, L-block and octagonal prism each
    /// scanned uniformly, in scan lines 3 and 10 spacings apart, as a structured-light grid,
    /// from 3 overlapping views, from one view and with the density falling 4x, scored with
    /// what each scan saw; prints a part x pattern table.
    #[arg(long, conflicts_with_all = ["cases", "cad"])]
    pub patterns: bool,
    /// Instead of the suite, issue 17's CAD check: fandisk, anchor and joint from the data
    /// folder's cad/, sampled with their facets as they are and subdivided twice; sharp =
    /// dihedral beyond 30°, facet creases below it not counted against precision.
    #[arg(long, conflicts_with = "cases")]
    pub cad: bool,
    /// Cases to run, comma-separated (default: all): box, lblock, step, wedge, prism6,
    /// prism8, pyramid, sphere, box-noise0.5, box-noise1.0, box-30k, box-far, fandisk, anchor;
    /// with --random the drawn cases' names (r000, r007, ...): the same draws, only those run.
    #[arg(long, value_delimiter = ',')]
    pub cases: Option<Vec<String>>,
    /// Pipeline file (default: the built-in defaults, the same as pipeline.toml's).
    #[arg(long)]
    pub config: Option<PathBuf>,
    /// Worker threads; overrides `threads` of the config (0 = all cores).
    #[arg(long)]
    pub threads: Option<usize>,
    /// Seed of the simulated scans (each case derives its own from it and its name).
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Print the JSON on stdout instead of the table.
    #[arg(long)]
    pub json: bool,
    /// Write the JSON (every metric per case) to this file.
    #[arg(long, default_value = "bench.json")]
    pub out: PathBuf,
    /// The shared data folder holding cad/fandisk.off and cad/anchor_dense.off (default:
    /// ../shared/data); the mesh cases are skipped when it is absent.
    #[arg(long)]
    pub data: Option<PathBuf>,
    /// Instead of the simulated suite: real RGB-D frames of boxes on a table (PLY with a
    /// per-point object `label`, e.g. ../shared/data/rgbd/box.ply), comma-separated. Each
    /// gets reference edges from planes fitted to its labelled faces, and the run's edges are
    /// scored against them (coverage per edge, as one edge, and precision).
    #[arg(long, value_delimiter = ',')]
    pub frames: Option<Vec<PathBuf>>,
    /// With --frames: draw each frame with its reference (green) and found (red) edges as
    /// FOLDER/<frame>.svg.
    #[arg(long, requires = "frames")]
    pub figures: Option<PathBuf>,
}

/// Runs the parsed command.
pub fn dispatch(cli: &Cli) -> anyhow::Result<()> {
    match &cli.command {
        Command::Run(a) => run(cli, a),
        Command::Synth(a) => synth(cli, a),
        Command::Info(a) => info(cli, a),
        Command::Experiment(a) => experiment(cli, a),
        Command::Bench(a) => bench(cli, a),
        Command::Plan(a) => plan(cli, a),
        Command::Merge(a) => merge(cli, a),
    }
}

fn plan(cli: &Cli, a: &PlanArgs) -> anyhow::Result<()> {
    use sharpedge::tiles::plan::{PlanOptions, Sizing};
    let settings = sharpedge::config::load(&a.config)?;
    let input = a
        .input
        .clone()
        .or_else(|| settings.input.path.clone())
        .ok_or_else(|| sharpedge::Error::Usage {
            option: "--input".into(),
            message: "no input cloud: set input.path in the pipeline file or pass --input".into(),
        })?;
    for (option, n) in [
        ("--grid", a.grid.as_ref().map(Vec::len)),
        ("--anchor", a.anchor.as_ref().map(Vec::len)),
    ] {
        if let Some(n) = n
            && n != 3
        {
            return Err(sharpedge::Error::Usage {
                option: option.into(),
                message: format!("needs three values X,Y,Z, got {n}"),
            }
            .into());
        }
    }
    let sizing = match (a.tile_points, a.tile_size, &a.grid) {
        (Some(n), _, _) => Sizing::Points(n),
        (_, Some(l), _) => Sizing::Size(l),
        (_, _, Some(g)) => Sizing::Cells([g[0], g[1], g[2]]),
        _ => {
            return Err(sharpedge::Error::Usage {
                option: "--tile-points".into(),
                message: "say how large the tiles are: --tile-points N, --tile-size L or \
                          --grid NX,NY,NZ"
                    .into(),
            }
            .into());
        }
    };
    let exe = std::env::current_exe().unwrap_or_else(|_| PathBuf::from("sharpedge"));
    let plan = sharpedge::tiles::plan::make_plan(
        &a.config,
        &settings,
        &PlanOptions {
            input,
            out: a.out.clone(),
            sizing,
            anchor: a.anchor.as_ref().map(|v| [v[0], v[1], v[2]]),
            halo: a.halo,
            exe,
        },
    )?;
    if !cli.quiet {
        let most = plan.tiles.iter().map(|t| t.halo_points).max().unwrap_or(0);
        eprintln!(
            "plan: {} points, {} tiles ({} x {} x {}), halo {:.6} (spacing about {:.6}); the \
             largest tile reads about {most} points\n  run:   {}/sbatch.sh with sbatch, or \
             seq 0 {} | xargs -P 2 -I{{}} sharpedge -q run {}/pipeline.toml --plan {} --tile {{}}\n  \
             then:  sharpedge merge {} --out RESULT",
            plan.points,
            plan.tiles.len(),
            plan.grid.cells[0],
            plan.grid.cells[1],
            plan.grid.cells[2],
            plan.halo,
            plan.spacing,
            a.out.display(),
            plan.tiles.len() - 1,
            a.out.display(),
            a.out.display(),
            a.out.display(),
        );
    }
    Ok(())
}

fn merge(cli: &Cli, a: &MergeArgs) -> anyhow::Result<()> {
    let s = sharpedge::tiles::merge::merge(
        &a.plan,
        &sharpedge::tiles::merge::MergeOptions {
            out: a.out.clone(),
            partial: a.partial,
        },
    )?;
    if !cli.quiet {
        eprintln!(
            "merge: {} of {} tiles, {} points, {} edges ({} joined across seams), {} corners -> {}",
            s.tiles - s.missing.len() - s.failed.len(),
            s.tiles,
            s.points,
            s.edges,
            s.joined,
            s.corners,
            a.out.display()
        );
    }
    Ok(())
}

fn run(cli: &Cli, a: &RunArgs) -> anyhow::Result<()> {
    let mut settings = sharpedge::config::load(&a.config)?;
    // Command-line paths are relative to the working directory, like any shell argument.
    if let Some(input) = &a.input {
        settings.input.path = Some(input.clone());
    }
    if let Some(out) = &a.out {
        settings.output.dir = out.clone();
    }
    if let Some(t) = a.threads {
        // The range pipeline.toml allows for `threads`: a typo like 40000 must not spawn
        // 40000 OS threads.
        if t > 4096 {
            return Err(sharpedge::Error::Usage {
                option: "--threads".into(),
                message: format!("must be in [0, 4096] (0 = all cores), got {t}"),
            }
            .into());
        }
        settings.threads = t;
    }
    if let (Some(plan), Some(tile)) = (&a.plan, a.tile) {
        let s = sharpedge::tiles::run::run_tile(&settings, &a.config, plan, tile)?;
        if !cli.quiet {
            eprintln!(
                "tile {}: {} points read, {} owned, {} edges, {} corners -> {}",
                s.tile,
                s.read,
                s.core,
                s.edges,
                s.corners,
                sharpedge::tiles::tile_dir(plan, tile).display()
            );
        }
        return Ok(());
    }
    if let Some(f) = &a.format {
        use sharpedge::io::CloudFormat;
        settings.output.format = match f.as_str() {
            "ply" => CloudFormat::Ply,
            "las" => CloudFormat::Las,
            "laz" => CloudFormat::Laz,
            "pcd" => CloudFormat::Pcd,
            "e57" => CloudFormat::E57,
            _ => CloudFormat::Auto,
        };
    }
    let summary = sharpedge::pipeline::run(&settings)?;
    if !cli.quiet {
        eprint!("{}", summary_text(&summary));
    }
    Ok(())
}

/// The one-screen summary printed at the end of `run`.
fn summary_text(s: &sharpedge::pipeline::Summary) -> String {
    use std::fmt::Write;
    let mut t = String::new();
    let total: f64 = s.timings.iter().map(|t| t.seconds).sum();
    let _ = writeln!(
        t,
        "sharpedge {}: {}",
        env!("CARGO_PKG_VERSION"),
        s.input.display()
    );
    let _ = writeln!(
        t,
        "  points {}   spacing {:.4}   noise sigma {:.4} ({:.2} spacings)   radius {:.4}",
        s.points,
        s.scale.spacing,
        s.scale.noise,
        s.scale.noise / s.scale.spacing,
        s.scale.radius
    );
    let _ = writeln!(
        t,
        "  candidates {}   outliers {}   moved points {}",
        s.candidates, s.outliers, s.moved
    );
    let _ = writeln!(
        t,
        "  {} edges, {} corners; {}",
        s.edges,
        s.corners,
        s.left_out.summary()
    );
    let stages: Vec<String> = s
        .timings
        .iter()
        .map(|x| format!("{} {:.2}s", x.stage, x.seconds))
        .collect();
    let _ = writeln!(t, "  time {total:.2} s: {}", stages.join(", "));
    for o in &s.outputs {
        let _ = writeln!(t, "  wrote {}", o.display());
    }
    t
}

fn synth(cli: &Cli, a: &SynthArgs) -> anyhow::Result<()> {
    use sharpedge::io::{PlyEncoding, PlyWriteOptions, Precision};
    use sharpedge::synth::{Part, Sampling, SynthParams};
    let part = match &a.mesh {
        Some(m) => Part::Mesh(m.clone()),
        None => a.part.parse::<Part>()?,
    };
    let sampling = match (a.points, a.spacing) {
        (_, Some(h)) => Sampling::Spacing(h),
        (Some(n), None) => Sampling::Points(n),
        (None, None) => Sampling::Points(100_000),
    };
    let triple = |name: &str, v: Option<&[f64]>| -> anyhow::Result<Option<[f64; 3]>> {
        match v {
            None => Ok(None),
            Some([x, y, z]) => Ok(Some([*x, *y, *z])),
            Some(v) => anyhow::bail!("--{name} takes three numbers X,Y,Z, got {}", v.len()),
        }
    };
    let translate = triple("translate", a.translate.as_deref())?.unwrap_or([0.0; 3]);
    // "X,Y,Z" as one value, so a leading minus is not taken for an option.
    let point = |name: &str, s: &str| -> anyhow::Result<[f64; 3]> {
        let v: Vec<f64> = s
            .split(',')
            .map(|c| c.trim().parse::<f64>())
            .collect::<Result<_, _>>()
            .map_err(|e| anyhow::anyhow!("--{name} {s:?}: {e}"))?;
        triple(name, Some(&v)).map(|t| t.unwrap_or([0.0; 3]))
    };
    let sensors = a
        .sensor
        .iter()
        .map(|s| point("sensor", s))
        .collect::<anyhow::Result<Vec<_>>>()?;
    let scan = sharpedge::synth::ScanPattern {
        pattern: a.pattern.parse()?,
        line_gap: a.line_gap,
        line_direction: a
            .line_direction
            .as_deref()
            .map(|s| point("line-direction", s))
            .transpose()?,
        views: a.views.unwrap_or(sensors.len().max(1)),
        sensors,
        misregistration: a.misregistration,
        density_ratio: a.density_ratio,
        density_direction: a
            .density_direction
            .as_deref()
            .map(|s| point("density-direction", s))
            .transpose()?,
        incidence_noise: a.incidence_noise,
        incidence_cap: a.incidence_cap,
    };
    let params = SynthParams {
        part,
        size: a.size,
        sampling,
        noise: a.noise,
        round: a.round,
        edge_noise: a.edge_noise,
        edge_band: a.edge_band,
        outliers: a.outliers,
        rotate: a.rotate,
        translate,
        seed: a.seed,
        double: a.double,
        sides: a.sides,
        angle: a.angle,
        steps: a.steps,
        sharp_angle: a.sharp_angle,
        subdivide: a.subdivide,
        jitter: a.jitter,
        scan,
    };
    let scan = sharpedge::synth::generate(&params)?;
    let truth_path = a
        .truth
        .clone()
        .unwrap_or_else(|| a.out.with_extension("truth.json"));
    let extra = if a.truth_fields {
        scan.truth_attributes()
    } else {
        Vec::new()
    };
    let attrs: Vec<&sharpedge::Attribute> =
        scan.cloud.attributes.iter().chain(extra.iter()).collect();
    let opts = PlyWriteOptions {
        encoding: if a.ascii {
            PlyEncoding::Ascii
        } else {
            PlyEncoding::BinaryLittleEndian
        },
        precision: Precision::for_source(&scan.cloud.source),
    };
    sharpedge::io::write_ply(&a.out, &scan.cloud.positions, &attrs, &[], &opts)?;
    let json = scan.ground_truth.to_json()?;
    sharpedge::io::write_atomic(&truth_path, |w| {
        w.write_all(json.as_bytes())
            .map_err(|e| sharpedge::Error::io(&truth_path, "cannot write ground truth", e))
    })?;
    if !cli.quiet {
        let g = &scan.ground_truth;
        eprintln!(
            "{}: {} points of a {} (spacing {:.6}, {} sharp edges, {} corners); truth in {}",
            a.out.display(),
            scan.cloud.len(),
            g.part,
            g.spacing,
            g.edges.len(),
            g.corners.len(),
            truth_path.display()
        );
    }
    Ok(())
}

fn info(_cli: &Cli, a: &InfoArgs) -> anyhow::Result<()> {
    let info = sharpedge::io::describe(&a.file)?;
    if a.json {
        println!("{}", serde_json::to_string_pretty(&info)?);
    } else {
        print!("{info}");
    }
    Ok(())
}

fn experiment(cli: &Cli, a: &ExperimentArgs) -> anyhow::Result<()> {
    use sharpedge::experiment::{ExperimentConfig, plots, run};
    if !(a.rounding >= 0.0 && a.rounding <= 5.0) {
        return Err(sharpedge::Error::Usage {
            option: "--rounding".into(),
            message: format!(
                "must be between 0 and 5 (the sides are 10 long), got {}",
                a.rounding
            ),
        }
        .into());
    }
    if a.trials == 0 {
        return Err(sharpedge::Error::Usage {
            option: "--trials".into(),
            message: "must be at least 1".into(),
        }
        .into());
    }
    let dims = a.dim.map_or(vec![2, 3], |d| vec![d]);
    let mut reports = Vec::with_capacity(dims.len());
    for dim in dims {
        let progress = if cli.quiet {
            sharpedge::progress::Progress::hidden()
        } else {
            let stage = if dim == 2 { "2D trials" } else { "3D trials" };
            sharpedge::progress::Progress::start(stage, a.trials as u64, "trials")
        };
        let mut params = sharpedge::fit::FitParams::default();
        if let Some(n) = a.iterations {
            params.pso.iterations_2d = n;
            params.pso.iterations_3d = n;
        }
        if let Some(n) = a.min_particles {
            params.min_particles = n;
        }
        params.seed_with_intersection = !a.paper_init;
        let cfg = ExperimentConfig {
            dim,
            trials: a.trials,
            seed: a.seed,
            params,
            abnormality: sharpedge::experiment::data::Abnormality {
                rounding: a.rounding,
            },
        };
        let report = run(&cfg, &progress)?;
        if let Some(dir) = &a.out {
            for path in plots::write_figures(&report, dir)? {
                tracing::info!("wrote {}", path.display());
            }
        }
        reports.push(report);
    }
    if a.json {
        // Exactly one JSON object: the dimension's own, or both under "experiments".
        let value = match reports.as_slice() {
            [one] => one.json(),
            many => serde_json::json!({
                "experiments": many.iter().map(|r| r.json()).collect::<Vec<_>>()
            }),
        };
        println!("{}", serde_json::to_string_pretty(&value)?);
    } else {
        for r in &reports {
            println!("{}", r.table());
        }
    }
    Ok(())
}

fn bench(_cli: &Cli, a: &BenchArgs) -> anyhow::Result<()> {
    let mut settings = match &a.config {
        Some(path) => sharpedge::config::load(path)?,
        None => sharpedge::config::Settings::default(),
    };
    if let Some(t) = a.threads {
        settings.threads = t;
    }
    // Fail on an unwritable --out now, not after the whole suite.
    let dir = match a.out.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => std::path::Path::new("."),
    };
    tempfile::NamedTempFile::new_in(dir)
        .map_err(|e| sharpedge::Error::io(dir, "cannot write into the folder of --out", e))?;
    if let Some(frames) = &a.frames {
        use sharpedge::bench::frames;
        let results = frames::run_frames(
            frames,
            &settings,
            frames::DEFAULT_TOLERANCE,
            a.figures.as_deref(),
        )?;
        return write_bench(a, &results, || frames::table(&results));
    }
    let points = a.points.unwrap_or(if a.patterns {
        sharpedge::bench::patterns::DEFAULT_POINTS
    } else {
        sharpedge::bench::DEFAULT_POINTS
    });
    let report = sharpedge::bench::run(&sharpedge::bench::BenchOptions {
        cases: a.cases.clone(),
        points,
        seed: a.seed,
        threads: settings.threads,
        config: a.config.clone(),
        data: a.data.clone().or_else(sharpedge::bench::default_data_dir),
        random: a.random,
        random_patterns: !a.uniform,
        patterns: a.patterns,
        cad: a.cad,
        settings,
    })?;
    write_bench(a, &report, || sharpedge::bench::table(&report))
}

/// Writes bench results as JSON to `--out` (atomically) and prints them: the JSON with
/// `--json`, the table otherwise.
fn write_bench<T: serde::Serialize>(
    a: &BenchArgs,
    results: &T,
    table: impl FnOnce() -> String,
) -> anyhow::Result<()> {
    let text = sharpedge::json::pretty(results)? + "\n";
    sharpedge::io::write_atomic(&a.out, |w| {
        w.write_all(text.as_bytes())
            .map_err(|e| sharpedge::Error::io(&a.out, "cannot write bench results", e))
    })?;
    if a.json {
        print!("{text}");
    } else {
        print!("{}", table());
        println!("wrote {}", a.out.display());
    }
    Ok(())
}
