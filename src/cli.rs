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
    /// More log output: -v for debug, -vv for trace. RUST_LOG overrides.
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
    Synth(SynthArgs),
    /// Describe a point cloud file: format, point count, properties, bounding box, spacing.
    Info(InfoArgs),
    /// Reproduce the paper's experiments (§4) on generated data.
    Experiment(ExperimentArgs),
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
}

#[derive(Debug, Args)]
pub struct SynthArgs {
    /// Parametric part: box, lblock, step, wedge, prism, pyramid, sphere.
    #[arg(long, default_value = "box", conflicts_with = "mesh")]
    pub part: String,
    /// Sample this triangle mesh (OFF, PLY or OBJ) instead of a parametric part.
    #[arg(long)]
    pub mesh: Option<PathBuf>,
    /// Number of points (approximate; sampling is on a jittered grid).
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
    /// Fraction of points replaced by outliers in the bounding box (0..1).
    #[arg(long, default_value_t = 0.0)]
    pub outliers: f64,
    /// Rotate the part by a random rotation (drawn from --seed).
    #[arg(long)]
    pub rotate: bool,
    /// Translate the part by X,Y,Z (e.g. a georeferenced offset 512345.1,4101234.5,80).
    #[arg(long, value_delimiter = ',', num_args = 3)]
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
    /// Part size (its largest extent) in model units.
    #[arg(long, default_value_t = 100.0)]
    pub size: f64,
    /// Number of sides of the prism.
    #[arg(long, default_value_t = 6)]
    pub sides: usize,
    /// Dihedral angle of the wedge's sharp edge, in degrees.
    #[arg(long, default_value_t = 30.0)]
    pub angle: f64,
    /// For --mesh: a mesh edge is sharp when its dihedral angle exceeds this many degrees.
    #[arg(long, default_value_t = 30.0)]
    pub sharp_angle: f64,
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
    /// Round the generated corners with a fillet (2D) or blunting (3D) of up to this size
    /// (the sides are 10 long). Not in the paper's data; a stress test of the search.
    #[arg(long, default_value_t = 0.0)]
    pub rounding: f64,
    /// Print one JSON object instead of tables (with both dimensions, their objects are in an
    /// "experiments" array).
    #[arg(long)]
    pub json: bool,
}

/// Runs the parsed command.
pub fn dispatch(cli: &Cli) -> anyhow::Result<()> {
    match &cli.command {
        Command::Run(a) => run(cli, a),
        Command::Synth(a) => synth(cli, a),
        Command::Info(a) => info(cli, a),
        Command::Experiment(a) => experiment(cli, a),
    }
}

fn run(_cli: &Cli, _a: &RunArgs) -> anyhow::Result<()> {
    anyhow::bail!("`run` is being built")
}

fn synth(_cli: &Cli, _a: &SynthArgs) -> anyhow::Result<()> {
    anyhow::bail!("`synth` is being built")
}

fn info(_cli: &Cli, _a: &InfoArgs) -> anyhow::Result<()> {
    anyhow::bail!("`info` is being built")
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
