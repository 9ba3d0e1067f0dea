//! The fixed order of the stages, their timings, the thread pool and the seed.
//!
//! Input: validated `Settings` (input path and output folder already resolved). Output: the
//! files of the output contract (rectified.ply or .las/.laz, features.ply, edges.geojson,
//! report.json in the output folder) and a `Summary` for the one-screen report. Each stage
//! is a plain function of the library; this module only calls them in order and times them.
//! The stages see each position once: exact copies of a point are set aside before them
//! (`neighbours::Distinct`) and get their first point's results after them.

use std::path::{Path, PathBuf};
use std::time::Instant;

use crate::cloud::Cloud;
use crate::config::Settings;
use crate::error::{Error, Result};
use crate::io;
use crate::left_out::{LeftOut, Reason, Tally};
use crate::neighbours::{self, Distinct, Grid, KdTree};
use crate::outcome::{self, Outcome, Timing, describe};
use crate::progress::Progress;
use crate::report;
use crate::stages::convexity;
use crate::stages::corners::{self, CornerFit};
use crate::stages::edges;
use crate::stages::faces;
use crate::stages::features::{self, Features, Scale};
use crate::stages::occlusion;
use crate::stages::pair_edges;
use crate::stages::plane_corners;
use crate::stages::rectify;
use crate::stages::scale;
use crate::stages::segment::{self, Segments};

/// What a run did, for the summary screen (report.json has the full detail).
#[derive(Debug, Clone)]
pub struct Summary {
    pub input: PathBuf,
    pub points: usize,
    pub scale: Scale,
    pub candidates: usize,
    pub outliers: usize,
    pub edges: usize,
    pub corners: usize,
    pub moved: usize,
    /// Candidates left out, by reason (failed fits under `Reason::Failed`).
    pub left_out: Tally,
    pub timings: Vec<Timing>,
    pub outputs: Vec<PathBuf>,
}

struct Clock {
    timings: Vec<Timing>,
    last: Instant,
}

impl Clock {
    fn new() -> Self {
        Clock {
            timings: Vec::new(),
            last: Instant::now(),
        }
    }
    fn lap(&mut self, stage: &'static str) {
        let now = Instant::now();
        let seconds = (now - self.last).as_secs_f64();
        tracing::info!("{stage}: {seconds:.3} s");
        self.timings.push(Timing { stage, seconds });
        self.last = now;
    }
}

/// Runs the whole pipeline and writes the outputs.
pub fn run(settings: &Settings) -> Result<Summary> {
    let input = settings.input.path.clone().ok_or_else(|| Error::Usage {
        option: "input".into(),
        message: "no input cloud: set input.path in the pipeline file or pass --input".into(),
    })?;
    let out_dir = settings.output.dir.clone();
    // The folders this run makes (the output folder and missing parents), deepest first.
    let created: Vec<PathBuf> = out_dir
        .ancestors()
        .take_while(|d| !d.as_os_str().is_empty() && !d.exists())
        .map(Path::to_path_buf)
        .collect();
    prepare_output_dir(&out_dir)?;
    let result = run_into(settings, input, &out_dir);
    if result.is_err() {
        // A failed run leaves no trace, not even the empty folders it made; `remove_dir`
        // removes only an empty folder, so nothing else can go.
        for d in &created {
            if std::fs::remove_dir(d).is_err() {
                break;
            }
        }
    }
    result
}

fn run_into(settings: &Settings, input: PathBuf, out_dir: &Path) -> Result<Summary> {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(settings.threads)
        .build()
        .map_err(|e| Error::Usage {
            option: "threads".into(),
            message: format!("cannot start {} worker threads: {e}", settings.threads),
        })?;
    pool.install(|| {
        let mut clock = Clock::new();
        let format = settings.output.format.resolve(&input)?;
        let (cloud, original) = io::read_for_output(
            &input,
            &io::ReadOptions {
                non_finite: settings.input.non_finite,
            },
            format,
        )?;
        let lidar = original.as_ref().and_then(io::Original::lidar);
        if let (Some(l), true, true) = (lidar, format.is_lidar(), settings.output.classify_edges) {
            io::check_edge_class(l, settings.output.edge_class)?;
        }
        clock.lap("read");
        let outcome = process(cloud, settings, &mut clock)?;
        let outputs = report::write_all(
            &outcome,
            original.as_ref(),
            settings,
            out_dir,
            &clock.timings,
        )?;
        clock.lap("write");
        Ok(Summary {
            input,
            points: outcome.cloud.len(),
            scale: outcome.scale,
            candidates: outcome.features.candidate.iter().filter(|&&c| c).count(),
            outliers: outcome.features.outlier.iter().filter(|&&c| c).count(),
            edges: outcome.edges.len(),
            corners: outcome.corners.len(),
            moved: outcome.moved.iter().filter(|&&m| m).count(),
            left_out: Tally::of(&outcome.left_out),
            timings: clock.timings,
            outputs,
        })
    })
}

/// The stages between reading and writing, on a cloud in memory.
pub fn process(cloud: Cloud, settings: &Settings, clock: &mut impl LapClock) -> Result<Outcome> {
    let path = cloud.source.path.clone();
    let distinct = Distinct::of(&cloud.positions).map_err(|e| in_file(&path, e))?;
    check_cloud(&cloud, &distinct)?;
    // The stages see every position once (see `Distinct`); copies get their first point's
    // results when the per-point arrays are expanded at the end.
    let distinct_positions;
    let positions: &[[f64; 3]] = if distinct.has_duplicates() {
        distinct_positions = distinct.positions(&cloud.positions);
        &distinct_positions
    } else {
        &cloud.positions
    };
    check_extent(&path, positions)?;
    let tree = KdTree::new(positions).map_err(|e| in_file(&path, e))?;
    let spacing =
        neighbours::mean_spacing_in(&tree, positions, 50_000).ok_or_else(|| Error::BadCloud {
            path: path.clone(),
            what: "cannot measure the point spacing: no sampled point has a neighbour at a \
                   distance a float can hold"
                .into(),
        })?;
    check_spacing(&path, spacing)?;
    check_not_collinear(&path, positions, cloud.len(), spacing)?;
    check_given_lengths(&cloud, &settings.features)?;
    // Said once the cloud is accepted, so a refused one prints its error alone.
    if distinct.has_duplicates() {
        tracing::warn!(
            "{}: {} of {} points repeat the position of an earlier point; each position is \
             analysed once and its copies get its result",
            path.display(),
            cloud.len() - distinct.len(),
            cloud.len()
        );
    }
    let local = scale::local_scale_in(&tree, positions, spacing, &settings.features.scale_rules())
        .map_err(|e| in_file(&path, e))?;
    drop(tree);
    let scale = local.summary();
    let (radius_lo, radius_hi) = local.radius_range();
    tracing::info!(
        "spacing {:.6}, noise sigma {:.6} ({:.2} spacings), radius {:.6} (medians of the local \
         scale; radius from {:.6} to {:.6})",
        scale.spacing,
        scale.noise,
        scale.noise / scale.spacing,
        scale.radius,
        radius_lo,
        radius_hi
    );
    clock.lap("scale");
    // Cells as wide as nine radii in ten: the rest take the wider query.
    let grid = Grid::new(positions, local.radius_quantile(0.9)).map_err(|e| in_file(&path, e))?;
    clock.lap("neighbours");
    let progress = Progress::start("features", positions.len() as u64, "points");
    let mut features = features::features(positions, &grid, &local, &settings.features, &progress);
    drop(progress);
    clock.lap("features");
    // Edge runs are grown at the scale of the candidates (the points near edges), not of the
    // whole cloud.
    let run_scale = local
        .around((0..positions.len() as u32).filter(|&i| features.candidate[i as usize]))
        .unwrap_or(scale);
    let mut segments = segment::segment(positions, &features, &run_scale, &settings.segment);
    // Runs are grown: the edge directions, corner scores and sharpness are read no more.
    features.release_for_faces();
    clock.lap("segment");
    let mut planar = faces::planar_faces(positions, &grid, &features, &local);
    // Faces are grown: what the later stages and the outputs read of the features is the
    // labels and the split. Freeing the rest as soon as each is done keeps it out of the
    // faces stage's peak and of the fits', rectify's and convexity's (10M points: see
    // README, issue 11).
    features.release_shape();
    // Occlusion boundaries (a depth jump of the scan's grid, a face seen edge-on from the
    // sensor) are borders of the scan: no face, and their runs no sharp edge.
    let borders = Borders::new(&cloud, &distinct, &settings.input.sensors);
    let mut border = borders.jump.clone();
    borders.drop_faces(&mut planar, &mut border);
    tracing::info!("{} planar faces", planar.planes.len());
    for (k, p) in planar.planes.iter().enumerate() {
        tracing::debug!(
            "face {k}: {} points, normal {:?}, centroid {:?}, rms {:.3} spacings",
            p.points,
            p.normal,
            p.centroid,
            p.rms / p.spacing
        );
    }
    clock.lap("faces");
    let surface = edges::Surface {
        positions,
        outlier: &features.outlier,
        grid: &grid,
        scale: &local,
    };
    let mut fits = edges::fit_edges(
        &surface,
        &segments,
        &settings.edges,
        &settings.fit,
        settings.seed,
    );
    borders.judge(&mut fits, &segments, &mut border);
    let mut left_out: Vec<LeftOut> = Vec::new();
    // Runs that are no sharp edge (fillets, bending surfaces) took part in vertices: find
    // the vertices again without them and fit the edges that are left anew.
    let not_edge: Vec<bool> = fits
        .iter()
        .map(|f| f.as_ref().is_err_and(|e| e.not_an_edge))
        .collect();
    if not_edge.iter().any(|&d| d) {
        left_out.extend(fits.iter().filter_map(|f| match f {
            Err(e) if e.not_an_edge => Some(e.left_out()),
            _ => None,
        }));
        segments = segment::without_runs(
            positions,
            segments,
            &not_edge,
            &run_scale,
            &settings.segment,
        );
        fits = edges::fit_edges(
            &surface,
            &segments,
            &settings.edges,
            &settings.fit,
            settings.seed,
        );
        borders.judge(&mut fits, &segments, &mut border);
    }
    clock.lap("edges");
    let corner_fits = corners::fit_corners(
        &surface,
        &segments,
        &fits,
        &settings.corners,
        &settings.edges,
        &settings.fit,
        settings.seed,
    );
    clock.lap("corners");
    for f in &fits {
        match f {
            Err(e) => left_out.push(e.left_out()),
            Ok(e) if e.failed_slabs > 0 => {
                tracing::debug!(
                    "edge {}: {} of {} slab fits failed",
                    e.run,
                    e.failed_slabs,
                    e.failed_slabs + e.slabs.len()
                );
            }
            Ok(_) => {}
        }
    }
    // Reported corners: the fitted ones, and where the fit failed but the edges' end lines
    // meet (marked by an absent error).
    let mut corner_list: Vec<CornerFit> = Vec::new();
    let mut corner_of_vertex: Vec<Option<usize>> = vec![None; segments.vertices.len()];
    for (v, c) in corner_fits.into_iter().enumerate() {
        left_out.extend(c.left_out);
        if let Some(c) = c.corner {
            corner_of_vertex[v] = Some(corner_list.len());
            corner_list.push(c);
        }
    }
    // Corners where planar faces meet: they refine the fitted corners they coincide with
    // and add those whose edges were too short to fit.
    let plane_found = plane_corners::face_corners(
        positions,
        &grid,
        &features,
        &local,
        &planar,
        &settings.edges,
    );
    let mut plane_edges =
        plane_corners::face_edges(positions, &grid, &features, &planar, &plane_found);
    let more = pair_edges::pair_edges(
        positions,
        &grid,
        &features,
        &local,
        &planar,
        &plane_found,
        &plane_edges,
        &settings.edges,
    );
    plane_edges.extend(more);
    let mut plane_found = plane_found;
    pair_edges::meeting_corners(&planar, &mut plane_found, &mut plane_edges);
    let corner_of_plane = plane_corners::place_corners(&planar, &plane_found, &mut corner_list);
    let mut geometry = corners::edge_geometry(&segments, &fits, &corner_list, &corner_of_vertex);
    let new_edges =
        plane_corners::place_edges(&plane_edges, &plane_found, &corner_of_plane, &mut geometry);
    clock.lap("plane corners");
    // Reported edge ids: the fitted runs in run order.
    let mut edge_of_run: Vec<Option<u32>> = vec![None; fits.len()];
    let mut next = 0u32;
    for (k, g) in geometry.iter().enumerate() {
        if g.is_some() {
            edge_of_run[k] = Some(next);
            next += 1;
        }
    }
    let mut rect = rectify::rectify(
        positions,
        &grid,
        &fits,
        &geometry,
        &corner_list,
        &edge_of_run,
        &settings.rectify,
    );
    // Edges placed by planes are reported after the fitted ones.
    rectify::rectify_plane_edges(
        &mut rect,
        &surface,
        &features.candidate,
        &new_edges,
        &planar,
        next,
        &settings.edges,
        &settings.rectify,
    );
    clock.lap("rectify");
    let (convexity, plane_convexity) =
        convexity::convexity(&surface, &fits, &new_edges, &sensors(&cloud, settings));
    clock.lap("convexity");
    let (mut edges, mut corners) =
        describe(&fits, &geometry, &corner_list, &edge_of_run, &convexity);
    // Plane edges after the fitted ones.
    for (k, (fe, side)) in new_edges.iter().zip(&plane_convexity).enumerate() {
        edges.push(outcome::plane_edge(next as usize + k, fe, side));
    }
    debug_assert!(edges.iter().enumerate().all(|(i, e)| e.id == i));
    outcome::link_corners(&edges, &mut corners);
    // Back to every point of the cloud: a copy has its first point's results, and keeps its
    // own coordinates (bit for bit) where nothing moved.
    let moved = distinct.expand(rect.moved);
    let rectified = distinct
        .expand(rect.positions)
        .into_iter()
        .zip(&moved)
        .zip(&cloud.positions)
        .map(|((r, &m), &p)| if m { r } else { p })
        .collect();
    Ok(Outcome {
        features: expand_features(features, &distinct),
        segments: expand_segments(segments, &distinct),
        cloud,
        scale,
        edges,
        corners,
        rectified,
        moved,
        edge_label: distinct.expand(rect.label),
        border: distinct.expand(border),
        left_out,
    })
}

/// The sensor positions: `input.sensors` when given, else the origins of the gridded scans
/// the file records (an organised PCD's VIEWPOINT, a structured E57 scan's pose: a grid of
/// rays is in its sensor's frame by construction; an unstructured scan's pose need not be
/// where a scanner stood).
fn sensors(cloud: &Cloud, settings: &Settings) -> Vec<[f64; 3]> {
    match &cloud.structure {
        Some(s) if settings.input.sensors.is_empty() => {
            let mut v: Vec<[f64; 3]> = s
                .scans
                .iter()
                .filter(|sc| sc.grid_size.is_some())
                .map(|sc| sc.pose.translation)
                .collect();
            v.dedup();
            v
        }
        _ => settings.input.sensors.clone(),
    }
}

/// What tells occlusion boundaries in one cloud (`stages::occlusion`), by distinct position.
struct Borders<'a> {
    /// Points next to a depth jump of the scan's grid, by distinct position.
    jump: Vec<bool>,
    structure: Option<&'a crate::cloud::ScanStructure>,
    sensors: &'a [[f64; 3]],
    distinct: &'a Distinct,
}

impl<'a> Borders<'a> {
    fn new(cloud: &'a Cloud, distinct: &'a Distinct, sensors: &'a [[f64; 3]]) -> Self {
        let structure = cloud.structure.as_ref();
        let mut jump = occlusion::depth_jumps(&cloud.positions, structure);
        if distinct.has_duplicates() {
            jump = distinct.first.iter().map(|&i| jump[i as usize]).collect();
        }
        let n = jump.iter().filter(|&&j| j).count();
        if n > 0 {
            tracing::debug!("{n} points lie by a depth jump of the scan's grid");
        }
        Borders {
            jump,
            structure,
            sensors,
            distinct,
        }
    }

    /// The sensor of these points (distinct positions).
    fn sensor(&self, points: &[u32]) -> Option<[f64; 3]> {
        // The scan structure counts points of the cloud, the stages distinct positions.
        let ids: Vec<u32> = points
            .iter()
            .map(|&p| self.distinct.first[p as usize])
            .collect();
        occlusion::sensor_of(&ids, self.structure, self.sensors)
    }

    /// Drops the planar faces on an occlusion boundary (a veil grown as a face) and marks
    /// their points in `border`.
    fn drop_faces(&self, planar: &mut faces::Faces, border: &mut [bool]) {
        let members = planar.members();
        let keep: Vec<bool> = planar
            .planes
            .iter()
            .zip(&members)
            .enumerate()
            .map(|(k, (plane, pts))| {
                let why = occlusion::is_border_face(plane, pts, &self.jump, self.sensor(pts));
                if let Some(why) = &why {
                    tracing::debug!("face {k} is an occlusion boundary: {why}");
                    for &p in pts {
                        border[p as usize] = true;
                    }
                }
                why.is_none()
            })
            .collect();
        planar.retain(&keep);
    }

    /// Turns the fitted edges on an occlusion boundary into runs judged no sharp edge, and
    /// marks their points in `border`.
    fn judge(&self, fits: &mut [edges::EdgeResult], segments: &Segments, border: &mut [bool]) {
        for f in fits.iter_mut() {
            let Ok(fit) = f else { continue };
            let run = &segments.runs[fit.run].points;
            if let Some(why) = occlusion::is_border(fit, run, &self.jump, self.sensor(run)) {
                for &p in run {
                    border[p as usize] = true;
                }
                *f = Err(edges::EdgeError::judged(
                    Reason::Occlusion,
                    format!("edge {}: {why}", fit.run),
                ));
            }
        }
    }
}

/// The per-point features of the distinct positions, for every point of the cloud.
/// Arrays released after segmentation (empty) stay empty.
fn expand_features(f: Features, distinct: &Distinct) -> Features {
    fn kept<T: Clone>(distinct: &Distinct, v: Vec<T>) -> Vec<T> {
        if v.is_empty() { v } else { distinct.expand(v) }
    }
    Features {
        normal: kept(distinct, f.normal),
        sharpness: kept(distinct, f.sharpness),
        variation: kept(distinct, f.variation),
        count: kept(distinct, f.count),
        split: distinct.expand(f.split),
        direction: kept(distinct, f.direction),
        corner: kept(distinct, f.corner),
        candidate: distinct.expand(f.candidate),
        outlier: distinct.expand(f.outlier),
        split_threshold: f.split_threshold,
    }
}

/// The runs of the distinct positions with point ids of the cloud (a run lists each
/// position's first point), and every point's run label.
fn expand_segments(mut s: Segments, distinct: &Distinct) -> Segments {
    if distinct.has_duplicates() {
        for run in &mut s.runs {
            for p in &mut run.points {
                *p = distinct.first[*p as usize];
            }
        }
    }
    s.label = distinct.expand(s.label);
    s
}

/// Timing of stages; tests pass a clock that ignores them.
pub trait LapClock {
    fn lap(&mut self, stage: &'static str);
}

impl LapClock for Clock {
    fn lap(&mut self, stage: &'static str) {
        Clock::lap(self, stage)
    }
}

/// A clock that records nothing.
pub struct NoClock;

impl LapClock for NoClock {
    fn lap(&mut self, _: &'static str) {}
}

/// Rejects clouds no stage can work on, with the reason and the file. Copies of a point count
/// once: 100,000 points at two positions are no surface.
fn check_cloud(cloud: &Cloud, distinct: &Distinct) -> Result<()> {
    let path = cloud.source.path.clone();
    let copies = if distinct.has_duplicates() {
        format!(" ({} points)", cloud.len())
    } else {
        String::new()
    };
    match distinct.len() {
        0 => Err(Error::BadCloud {
            path,
            what: "the cloud has no points".into(),
        }),
        1 if cloud.len() > 1 => {
            let first = cloud.positions[0];
            Err(Error::BadCloud {
                path,
                what: format!(
                    "all {} points are identical ({}, {}, {}): there is no surface to analyse",
                    cloud.len(),
                    first[0],
                    first[1],
                    first[2]
                ),
            })
        }
        n if n < 10 => Err(Error::BadCloud {
            path,
            what: format!(
                "the cloud has only {n} {}{copies}; edge extraction needs a scanned surface \
                 (thousands of points)",
                if distinct.has_duplicates() {
                    "distinct positions"
                } else {
                    "point(s)"
                }
            ),
        }),
        _ => Ok(()),
    }
}

/// The lengths the stages can work with, in model units. Each point's spacing, noise sigma and
/// radius are kept as f32 (`LocalScale`), normal between 1.2e-38 and 3.4e38, and the noise is
/// a small share of the spacing. A noisy box (100,000 points, 100 units wide, spacing 0.49)
/// scaled by every power of ten from 1e-38 (spacing 4.9e-39) to 1e37 (extent 1e39) gave the
/// unscaled box's 12 edges and 8 corners (within 3e-14 of its size) and moved the same
/// points; scaled by 1e38 (extent 1e40) its corners moved by 2 % of the spacing, by 1e-45
/// (spacing 4.9e-46) it found 13 edges and no corner, and beyond either the grid's cells
/// became 0 or infinite. The limits keep three decades from where it breaks.
const MIN_SPACING: f64 = 1e-35;
const MAX_EXTENT: f64 = 1e35;

/// Rejects a cloud wider than [`MAX_EXTENT`] (its largest bounding box side).
fn check_extent(path: &Path, positions: &[[f64; 3]]) -> Result<()> {
    let (lo, hi) = crate::geometry::bounds(positions);
    let extent = (0..3).map(|k| hi[k] - lo[k]).fold(0.0, f64::max);
    if extent <= MAX_EXTENT {
        return Ok(());
    }
    Err(Error::BadCloud {
        path: path.to_path_buf(),
        what: format!(
            "the cloud spans {extent:.3e} model units, more than the {MAX_EXTENT:e} sharpedge \
             can compute with (per-point lengths are 32-bit floats); scale the coordinates \
             down (other units)"
        ),
    })
}

/// Rejects a mean spacing below [`MIN_SPACING`].
fn check_spacing(path: &Path, spacing: f64) -> Result<()> {
    if spacing >= MIN_SPACING {
        return Ok(());
    }
    Err(Error::BadCloud {
        path: path.to_path_buf(),
        what: format!(
            "the points are {spacing:.3e} model units apart, less than the {MIN_SPACING:e} \
             sharpedge can compute with (per-point lengths are 32-bit floats); scale the \
             coordinates up (other units)"
        ),
    })
}

/// Rejects a cloud whose points all lie on one straight line: no surface, so no edge, and
/// the scale estimate would fail later with a message about density that misleads.
/// A radius or noise given in the config must fit the cloud: one larger than the cloud's
/// bounding box would make every neighbourhood the whole cloud (quadratic time), and one past
/// f32's range cannot be stored per point.
fn check_given_lengths(cloud: &Cloud, f: &features::FeatureParams) -> Result<()> {
    let (lo, hi) = crate::geometry::bounds(&cloud.positions);
    let diagonal = crate::geometry::dist(lo, hi);
    for (key, value) in [("features.radius", f.radius), ("features.noise", f.noise)] {
        if let Some(v) = value
            && v > diagonal
        {
            // 1e308 as written, not as 309 digits.
            let v = if v >= 1e15 {
                format!("{v:e}")
            } else {
                v.to_string()
            };
            return Err(Error::Usage {
                option: key.into(),
                message: format!(
                    "{v} is larger than the whole cloud ({}: bounding box diagonal {diagonal:.6}); \
                     give a length of a few point spacings, or \"auto\"",
                    cloud.source.path.display()
                ),
            });
        }
    }
    Ok(())
}

/// "On the line" means within a thousandth of the spacing of the principal axis (total least
/// squares line through the centroid), far above f32 rounding of stored coordinates and far
/// below the width of any scanned strip.
/// `points` is the cloud's count (`positions` may be its distinct positions).
fn check_not_collinear(
    path: &Path,
    positions: &[[f64; 3]],
    points: usize,
    spacing: f64,
) -> Result<()> {
    let n = positions.len() as f64;
    let mut c = [0.0f64; 3];
    for p in positions {
        for k in 0..3 {
            c[k] += p[k] / n;
        }
    }
    // Two passes (centroid, then moments about it) keep georeferenced offsets out of the sums.
    let mut m = nalgebra::Matrix3::<f64>::zeros();
    for p in positions {
        let d = nalgebra::Vector3::new(p[0] - c[0], p[1] - c[1], p[2] - c[2]);
        m += d * d.transpose();
    }
    let eig = nalgebra::SymmetricEigen::new(m);
    let axis = eig.eigenvectors.column(eig.eigenvalues.imax()).into_owned();
    let tolerance = 1e-3 * spacing;
    let off_line = positions.iter().any(|p| {
        let d = nalgebra::Vector3::new(p[0] - c[0], p[1] - c[1], p[2] - c[2]);
        (d - axis * d.dot(&axis)).norm() > tolerance
    });
    if off_line {
        return Ok(());
    }
    Err(Error::BadCloud {
        path: path.to_path_buf(),
        what: format!(
            "all {} points lie on one straight line (collinear within {tolerance:.3e}, through \
             ({:.6}, {:.6}, {:.6}) along ({:.6}, {:.6}, {:.6})): there is no surface to analyse",
            points, c[0], c[1], c[2], axis[0], axis[1], axis[2]
        ),
    })
}

/// Stage errors that do not say which file they are about (a degenerate neighbourhood, too
/// few points) get the input file, so a batch log names the culprit.
fn in_file(path: &Path, e: Error) -> Error {
    match e {
        Error::Degenerate { .. } | Error::Parallel { .. } | Error::TooFewPoints { .. } => {
            Error::BadCloud {
                path: path.to_path_buf(),
                what: e.to_string(),
            }
        }
        e => e,
    }
}

/// Creates the output folder and checks that it is writable before any work is done, so a
/// typo in `--out` costs a second, not a whole run.
fn prepare_output_dir(dir: &Path) -> Result<()> {
    if dir.exists() && !dir.is_dir() {
        return Err(Error::io(
            dir,
            "cannot use as output folder",
            std::io::Error::other("it is a file, not a folder; choose another --out or output.dir"),
        ));
    }
    std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, "cannot create output folder", e))?;
    // Named like write_atomic's temporary files, so that one left by a kill in this instant
    // is cleaned by a later run.
    tempfile::Builder::new()
        .prefix(".sharpedge-")
        .suffix(".part")
        .tempfile_in(dir)
        .map(drop)
        .map_err(|e| Error::io(dir, "cannot write into output folder", e))
}
