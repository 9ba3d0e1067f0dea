//! Real RGB-D frames of boxes on a table: reference edges built without the pipeline, and the
//! score of the pipeline's edges against them.
//!
//! Input: a frame as a [`Cloud`] whose points carry the dataset's object `label` (1–9 the
//! table, 20 and up one label per object, as in the mOSD frames of `../shared/data/rgbd`), and
//! the edges a run found ([`EdgeOut`]). Output: the [`RefEdge`]s of the frame and a
//! [`FrameScore`].
//!
//! The reference is deliberately independent of the pipeline's detection: planes are fitted to
//! the faces of each labelled object and to the table (normal-consistent consensus over
//! seeds, then least squares), and each pair of faces that meet becomes an edge on the line
//! where their planes intersect. A pair "meets" where both faces have points within
//! [`MEET_REACH`] of that line; the edge spans the longest stretch where they do (gaps of up
//! to [`MAX_GAP`] bridged). Two kinds are scored, the ones a user inspects on such a frame:
//! edges between two faces of one box ([`RefKind::BoxEdge`], convex) and edges where a box face
//! meets the table ([`RefKind::BaseEdge`], concave). Occlusion boundaries (a face seen to its
//! silhouette, with nothing of the other face beside it) give no reference edge, so a found
//! edge there counts against precision.
//!
//! The score, per reference edge: the share of its length within `tolerance` of any found
//! edge (coverage), and of a single found edge (the issue asks for "one edge", not fragments);
//! overall: the share of found edge length within `tolerance` of a reference edge.

use std::path::{Path, PathBuf};

use serde::Serialize;

use crate::cloud::Cloud;
use crate::config::Settings;
use crate::error::{Error, Result};
use crate::geometry::{V3, add, cross, dot, norm, point_line_distance, point_segment, scale, sub};
use crate::io::{self, ReadOptions};
use crate::neighbours::knn;
use crate::outcome::EdgeOut;
use crate::pipeline::{self, NoClock};
use crate::stages::features::{LocalPca, add_moments, pca_from_moments};

/// Neighbours of each point for its normal (PCA of the k nearest).
const NORMAL_K: usize = 24;
/// A point lies on a face's plane when it is this close to it (metres: the frames are Kinect
/// class, about 1–2 mm of depth noise at 0.7–1.2 m)...
const PLANE_DISTANCE: f64 = 0.004;
/// ...and its normal is within this angle of the plane's (degrees).
const PLANE_ANGLE_DEG: f64 = 20.0;
/// Smallest face kept (points).
const MIN_FACE_POINTS: usize = 400;
/// Most faces per object (a box shows at most three).
const MAX_FACES: usize = 3;
/// A face is at least this wide: the smaller in-plane standard deviation of its points
/// (metres). The sensor rounds a box edge over a band about a centimetre wide, which holds
/// enough points to pass for a 45° bevel face; a 2 cm wide face has 5.8 mm.
const MIN_FACE_STD: f64 = 0.005;
/// Two faces meet along their planes' line where both have points this close to it (metres,
/// about 5 spacings of these frames).
pub const MEET_REACH: f64 = 0.008;
/// Length of the bins along a line (metres).
const BIN: f64 = 0.002;
/// Runs of bins where both faces are present are joined across gaps of up to this (metres).
pub const MAX_GAP: f64 = 0.006;
/// Shortest reference edge kept (metres).
const MIN_EDGE: f64 = 0.02;
/// Faces closer to parallel than this do not form an edge (degrees).
const MIN_DIHEDRAL_TURN_DEG: f64 = 30.0;

/// A fitted face: plane `normal · x = offset`, normal towards the sensor at the origin.
#[derive(Debug, Clone)]
pub struct Face {
    pub label: u32,
    pub normal: V3,
    pub offset: f64,
    /// Ids of the points on it.
    pub points: Vec<u32>,
}

/// What a reference edge separates.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum RefKind {
    /// Two faces of one box.
    BoxEdge,
    /// A box face and the table.
    BaseEdge,
}

/// One reference edge: a segment of the line where two fitted face planes meet.
#[derive(Debug, Clone, Serialize)]
pub struct RefEdge {
    pub kind: RefKind,
    /// Object labels of the two faces (the table's label for a base edge's second face).
    pub labels: [u32; 2],
    pub start: V3,
    pub end: V3,
    /// Angle between the faces' normals, degrees (90 for a box edge seen square).
    pub normal_angle_deg: f64,
}

impl RefEdge {
    pub fn length(&self) -> f64 {
        norm(sub(self.end, self.start))
    }
}

/// Score of one reference edge.
#[derive(Debug, Clone, Serialize)]
pub struct RefEdgeScore {
    pub edge: RefEdge,
    pub length: f64,
    /// Share of the length within the tolerance of any found edge.
    pub coverage: f64,
    /// Share of the length within the tolerance of the single found edge that covers most.
    pub one_edge: f64,
    /// Mean distance of the covered samples to the nearest found edge (metres).
    pub mean_distance: f64,
}

/// Score of one frame.
#[derive(Debug, Clone, Serialize)]
pub struct FrameScore {
    pub tolerance: f64,
    pub edges: Vec<RefEdgeScore>,
    /// Found edge length (metres) and the share of it within the tolerance of a reference
    /// edge; the rest lies elsewhere (an occlusion boundary, a table rim, a false edge).
    pub found_length: f64,
    pub found_precision: f64,
    /// The `convex` flags of the found edges that lie along a reference edge (most of their
    /// length within the tolerance of it): box edges are convex, base edges concave.
    pub convex: ConvexScore,
}

/// Found edges along a reference edge by their `convex` flag.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize)]
pub struct ConvexScore {
    pub correct: usize,
    pub wrong: usize,
    pub undecided: usize,
}

impl FrameScore {
    /// Median coverage over the reference edges of `kind` (`None` when the frame has none).
    pub fn median_coverage(&self, kind: RefKind) -> Option<f64> {
        let mut v: Vec<f64> = self
            .edges
            .iter()
            .filter(|e| e.edge.kind == kind)
            .map(|e| e.coverage)
            .collect();
        if v.is_empty() {
            return None;
        }
        v.sort_by(f64::total_cmp);
        Some(v[v.len() / 2])
    }
}

/// The label column of a frame as integers, or an error naming what is missing.
fn labels(cloud: &Cloud, name: &str) -> Result<Vec<u32>> {
    let a = cloud.attribute(name).ok_or_else(|| Error::Degenerate {
        what: "reference edges",
        why: format!(
            "the frame has no per-point `{name}` property (the object label of the mOSD \
             frames); reference edges need it"
        ),
    })?;
    Ok((0..cloud.len())
        .map(|i| a.values.get_f64(i).max(0.0) as u32)
        .collect())
}

/// PCA of the points `ids`, offsets taken from `origin` (one of them, so no precision is lost).
fn pca(positions: &[[f64; 3]], origin: V3, ids: &[u32]) -> Option<LocalPca> {
    let mut m = [0.0; 10];
    for &j in ids {
        add_moments(&mut m, sub(positions[j as usize], origin));
    }
    pca_from_moments(&m)
}

/// The normal `n` or its opposite, whichever faces the sensor at the origin from `at`.
fn towards_sensor(n: V3, at: V3) -> V3 {
    if dot(n, at) > 0.0 { scale(n, -1.0) } else { n }
}

/// Unit normals of every point (PCA of its k nearest neighbours), turned towards the sensor
/// at the origin.
fn normals(positions: &[[f64; 3]]) -> Result<Vec<V3>> {
    let nn = knn(positions, NORMAL_K)?;
    Ok(positions
        .iter()
        .enumerate()
        .map(|(i, p)| match pca(positions, *p, nn.of(i)) {
            Some(l) => towards_sensor(l.normal, *p),
            None => [0.0; 3],
        })
        .collect())
}

/// Least-squares plane through `ids` (normal towards the sensor) and the standard deviation
/// of the points along the plane's narrower direction; `None` if degenerate.
fn fit_plane(positions: &[[f64; 3]], ids: &[u32]) -> Option<(V3, f64, f64)> {
    let o = positions[*ids.first()? as usize];
    let l = pca(positions, o, ids)?;
    let centroid = add(o, l.centroid);
    let n = towards_sensor(l.normal, centroid);
    Some((n, dot(n, centroid), l.eigenvalues[1].sqrt()))
}

/// Points of `pool` on the plane (distance and normal agreement).
fn inliers(positions: &[[f64; 3]], normals: &[V3], pool: &[u32], n: V3, d: f64) -> Vec<u32> {
    let cos = PLANE_ANGLE_DEG.to_radians().cos();
    pool.iter()
        .copied()
        .filter(|&j| {
            let j = j as usize;
            (dot(n, positions[j]) - d).abs() < PLANE_DISTANCE && dot(n, normals[j]) > cos
        })
        .collect()
}

/// Faces of the points `pool` (one object, or the table): repeatedly the plane with the most
/// points among seeds spread over the pool, refitted to its points, which then leave the pool.
fn faces(
    positions: &[[f64; 3]],
    normals: &[V3],
    mut pool: Vec<u32>,
    label: u32,
    max_faces: usize,
) -> Vec<Face> {
    let mut out = Vec::new();
    // Every attempt takes its points out of the pool, a face or not, so this ends.
    for _ in 0..3 * max_faces {
        if out.len() == max_faces || pool.len() < MIN_FACE_POINTS {
            break;
        }
        // Seeds and the counting sample: a few hundred of each, spread evenly over the pool.
        let seed_step = (pool.len() / 300).max(1);
        let count_step = (pool.len() / 5000).max(1);
        let sample: Vec<u32> = pool.iter().copied().step_by(count_step).collect();
        let best = pool
            .iter()
            .step_by(seed_step)
            .filter(|&&s| norm(normals[s as usize]) > 0.5)
            .map(|&s| {
                let n = normals[s as usize];
                let d = dot(n, positions[s as usize]);
                (inliers(positions, normals, &sample, n, d).len(), s)
            })
            .max_by(|a, b| a.0.cmp(&b.0).then(b.1.cmp(&a.1)));
        let Some((_, s)) = best else { break };
        let mut n = normals[s as usize];
        let mut d = dot(n, positions[s as usize]);
        let mut pts = inliers(positions, normals, &pool, n, d);
        let mut width = 0.0;
        for _ in 0..3 {
            match fit_plane(positions, &pts) {
                Some((n2, d2, w)) => (n, d, width) = (n2, d2, w),
                None => break,
            }
            pts = inliers(positions, normals, &pool, n, d);
        }
        if pts.len() < MIN_FACE_POINTS {
            break;
        }
        let taken: std::collections::HashSet<u32> = pts.iter().copied().collect();
        pool.retain(|j| !taken.contains(j));
        if width < MIN_FACE_STD {
            continue;
        }
        out.push(Face {
            label,
            normal: n,
            offset: d,
            points: pts,
        });
    }
    out
}

/// The line where two planes meet: a point on it and its unit direction; `None` for planes
/// within [`MIN_DIHEDRAL_TURN_DEG`] of parallel.
fn plane_line(a: &Face, b: &Face) -> Option<(V3, V3)> {
    let u = cross(a.normal, b.normal);
    let s = norm(u);
    if s < MIN_DIHEDRAL_TURN_DEG.to_radians().sin() {
        return None;
    }
    let u = scale(u, 1.0 / s);
    // The point of the line nearest the origin: p = (d_a (n_b × u) + d_b (u × n_a)) / s.
    // (Plane–plane intersection, e.g. Real-Time Collision Detection §5.4.4.)
    let p = scale(
        add(
            scale(cross(b.normal, u), a.offset),
            scale(cross(u, a.normal), b.offset),
        ),
        1.0 / s,
    );
    Some((p, u))
}

/// The stretch of the line (p, u) where both faces come within [`MEET_REACH`], as (t0, t1).
fn meeting_stretch(positions: &[[f64; 3]], a: &Face, b: &Face, p: V3, u: V3) -> Option<(f64, f64)> {
    let near = |f: &Face| -> Vec<f64> {
        f.points
            .iter()
            .filter_map(|&j| {
                let q = positions[j as usize];
                (point_line_distance(q, (p, u)) < MEET_REACH).then(|| dot(sub(q, p), u))
            })
            .collect()
    };
    let (ta, tb) = (near(a), near(b));
    if ta.is_empty() || tb.is_empty() {
        return None;
    }
    let lo = ta.iter().chain(&tb).copied().fold(f64::INFINITY, f64::min);
    let hi = ta
        .iter()
        .chain(&tb)
        .copied()
        .fold(f64::NEG_INFINITY, f64::max);
    let nb = (((hi - lo) / BIN).floor() as usize + 1).min(1_000_000);
    let mut has = vec![[false; 2]; nb];
    for (k, ts) in [&ta, &tb].into_iter().enumerate() {
        for &t in ts {
            let i = (((t - lo) / BIN) as usize).min(nb - 1);
            has[i][k] = true;
        }
    }
    // A bin is met when both faces have a point in it or a neighbouring bin.
    let met: Vec<bool> = (0..nb)
        .map(|i| {
            let w = i.saturating_sub(1)..(i + 2).min(nb);
            has[w.clone()].iter().any(|h| h[0]) && has[w].iter().any(|h| h[1])
        })
        .collect();
    let max_gap = (MAX_GAP / BIN).round() as usize;
    let mut best: Option<Run> = None;
    let mut cur: Option<Run> = None;
    let mut gap = 0;
    for (i, &m) in met.iter().enumerate() {
        if m {
            cur = Some(match cur {
                Some((s, _)) => (s, i),
                None => (i, i),
            });
            gap = 0;
        } else if cur.is_some() {
            gap += 1;
            if gap > max_gap {
                best = longer(best, cur.take());
            }
        }
    }
    best = longer(best, cur);
    let (s, e) = best?;
    let (t0, t1) = (lo + s as f64 * BIN, lo + (e + 1) as f64 * BIN);
    (t1 - t0 >= MIN_EDGE).then_some((t0, t1))
}

/// First and last bin of a run of met bins.
type Run = (usize, usize);

fn longer(a: Option<Run>, b: Option<Run>) -> Option<Run> {
    match (a, b) {
        (Some(x), Some(y)) => Some(if y.1 - y.0 > x.1 - x.0 { y } else { x }),
        (x, None) => x,
        (None, y) => y,
    }
}

/// The reference edges of a frame: every pair of faces of one object that meet, and every
/// object face that meets the table. `label` names the per-point object label property.
pub fn reference_edges(cloud: &Cloud, label: &str) -> Result<Vec<RefEdge>> {
    let labels = labels(cloud, label)?;
    let positions = &cloud.positions;
    let normals = normals(positions)?;
    let table: Vec<u32> = (0..labels.len() as u32)
        .filter(|&i| (1..=9).contains(&labels[i as usize]))
        .collect();
    let table_face = faces(positions, &normals, table, 1, 1).into_iter().next();
    let mut objects: Vec<u32> = labels.iter().copied().filter(|&l| l >= 20).collect();
    objects.sort_unstable();
    objects.dedup();
    let mut out = Vec::new();
    for &obj in &objects {
        let pool: Vec<u32> = (0..labels.len() as u32)
            .filter(|&i| labels[i as usize] == obj)
            .collect();
        let fs = faces(positions, &normals, pool, obj, MAX_FACES);
        let mut pairs: Vec<(&Face, &Face, RefKind)> = Vec::new();
        for i in 0..fs.len() {
            for j in i + 1..fs.len() {
                pairs.push((&fs[i], &fs[j], RefKind::BoxEdge));
            }
            if let Some(t) = &table_face {
                pairs.push((&fs[i], t, RefKind::BaseEdge));
            }
        }
        for (a, b, kind) in pairs {
            let Some((p, u)) = plane_line(a, b) else {
                continue;
            };
            if let Some((t0, t1)) = meeting_stretch(positions, a, b, p, u) {
                out.push(RefEdge {
                    kind,
                    labels: [a.label, b.label],
                    start: add(p, scale(u, t0)),
                    end: add(p, scale(u, t1)),
                    normal_angle_deg: dot(a.normal, b.normal).clamp(-1.0, 1.0).acos().to_degrees(),
                });
            }
        }
    }
    Ok(out)
}

/// Default tolerance of the score: 5 mm, about 3.5 spacings of these frames (PCL's
/// organised edge detection was credited with its points within 5 spacings).
pub const DEFAULT_TOLERANCE: f64 = 0.005;

/// One frame's reference, the run's counts and the score.
#[derive(Debug, Clone, Serialize)]
pub struct FrameResult {
    pub path: PathBuf,
    pub points: usize,
    /// The frame came with its sensor grid (an organised PCD): depth jumps were looked for.
    pub organised: bool,
    /// Points on an occlusion boundary, and edge candidates left out as one
    /// (`stages::occlusion`).
    pub border_points: usize,
    pub occlusion_runs: usize,
    pub found_edges: usize,
    pub found_corners: usize,
    pub score: FrameScore,
}

/// Runs the pipeline with `settings` on each frame (a PLY with a per-point `label`) and scores
/// its edges against the frame's reference edges.
/// With `figures`, also draws each frame with its reference and found edges as
/// `<figures>/<frame name>.svg` (see [`write_figure`]).
pub fn run_frames(
    paths: &[PathBuf],
    settings: &Settings,
    tolerance: f64,
    figures: Option<&Path>,
) -> Result<Vec<FrameResult>> {
    if let Some(dir) = figures {
        std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, "cannot create folder", e))?;
    }
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(settings.threads)
        .build()
        .map_err(|e| Error::Usage {
            option: "--threads".into(),
            message: format!("cannot start {} worker threads: {e}", settings.threads),
        })?;
    pool.install(|| {
        paths
            .iter()
            .map(|p| run_frame(p, settings, tolerance, figures))
            .collect()
    })
}

fn run_frame(
    path: &Path,
    settings: &Settings,
    tolerance: f64,
    figures: Option<&Path>,
) -> Result<FrameResult> {
    let cloud = io::read(
        path,
        &ReadOptions {
            non_finite: settings.input.non_finite,
        },
    )?;
    // A frame without object labels (PCL's organised-edge test frame) has no reference: it
    // is run and drawn, and scored on its border points only.
    let refs = if cloud.attribute("label").is_some() {
        reference_edges(&cloud, "label").map_err(|e| Error::BadCloud {
            path: path.to_path_buf(),
            what: e.to_string(),
        })?
    } else {
        Vec::new()
    };
    let points = cloud.len();
    let organised = cloud.structure.as_ref().is_some_and(|s| !s.grid.is_empty());
    // The frames are organised RGB-D frames in their camera's coordinates: the sensor stood
    // at the origin (it tells convex box edges from concave base edges).
    let mut settings = settings.clone();
    if settings.input.sensors.is_empty() {
        settings.input.sensors.push([0.0; 3]);
    }
    let outcome = pipeline::process(cloud, &settings, &mut NoClock)?;
    if let Some(dir) = figures {
        let name = path
            .file_stem()
            .map_or("frame".into(), |s| s.to_string_lossy());
        write_figure(
            &dir.join(format!("{name}.svg")),
            &outcome.cloud,
            &refs,
            &outcome.edges,
            &outcome.border,
        )?;
    }
    Ok(FrameResult {
        path: path.to_path_buf(),
        points,
        organised,
        border_points: outcome.border.iter().filter(|&&b| b).count(),
        occlusion_runs: outcome
            .left_out
            .iter()
            .filter(|l| l.reason == crate::left_out::Reason::Occlusion)
            .count(),
        found_edges: outcome.edges.len(),
        found_corners: outcome.corners.len(),
        score: score_frame(&refs, &outcome.edges, tolerance),
    })
}

/// Draws a frame as the sensor saw it (perspective from the origin, x right, y down): one
/// point in 12 (a hashed choice: a regular step would draw moiré on the sensor's grid) in
/// grey (objects darker than the table), the points on an occlusion boundary (`border`) in
/// orange, the reference edges in green, the found edges in red over them.
pub fn write_figure(
    path: &Path,
    cloud: &Cloud,
    refs: &[RefEdge],
    found: &[EdgeOut],
    border: &[bool],
) -> Result<()> {
    use plotters::prelude::*;
    let err = |e: &dyn std::fmt::Display| {
        Error::io(
            path,
            "cannot draw figure",
            std::io::Error::other(e.to_string()),
        )
    };
    let proj = |p: V3| (p[0] / p[2], -p[1] / p[2]);
    let label = cloud.attribute("label");
    let pts: Vec<((f64, f64), bool)> = cloud
        .positions
        .iter()
        .enumerate()
        .filter(|(i, p)| p[2] > 0.0 && (*i as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15) >> 60 < 2)
        .map(|(i, p)| (proj(*p), label.is_some_and(|a| a.values.get_f64(i) >= 20.0)))
        .collect();
    // Border points: one in 3, so the boundary reads as a line.
    let rims: Vec<(f64, f64)> = cloud
        .positions
        .iter()
        .enumerate()
        .filter(|(i, p)| {
            p[2] > 0.0
                && border.get(*i).copied().unwrap_or(false)
                && (*i as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15) >> 62 < 2
        })
        .map(|(_, p)| proj(*p))
        .collect();
    let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
    for ((u, v), _) in &pts {
        lo = [lo[0].min(*u), lo[1].min(*v)];
        hi = [hi[0].max(*u), hi[1].max(*v)];
    }
    if !(lo[0] < hi[0] && lo[1] < hi[1]) {
        return Err(err(&"no point in front of the sensor"));
    }
    let w = 900u32;
    let h = ((f64::from(w) * (hi[1] - lo[1]) / (hi[0] - lo[0])).round() as u32).clamp(200, 1400);
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (w, h)).into_drawing_area();
        root.fill(&WHITE).map_err(|e| err(&e))?;
        let mut chart = ChartBuilder::on(&root)
            .margin(5)
            .build_cartesian_2d(lo[0]..hi[0], lo[1]..hi[1])
            .map_err(|e| err(&e))?;
        let grey = |object: bool| {
            if object {
                RGBColor(90, 90, 90)
            } else {
                RGBColor(200, 200, 200)
            }
        };
        chart
            .draw_series(
                pts.iter()
                    .map(|&(p, object)| Circle::new(p, 1, grey(object).filled())),
            )
            .map_err(|e| err(&e))?;
        chart
            .draw_series(
                rims.iter()
                    .map(|&p| Circle::new(p, 1, RGBColor(255, 140, 0).filled())),
            )
            .map_err(|e| err(&e))?;
        for r in refs {
            chart
                .draw_series(std::iter::once(PathElement::new(
                    vec![proj(r.start), proj(r.end)],
                    RGBColor(0, 170, 0).stroke_width(7),
                )))
                .map_err(|e| err(&e))?;
        }
        for f in found {
            chart
                .draw_series(std::iter::once(PathElement::new(
                    edge_polyline(f).into_iter().map(proj).collect::<Vec<_>>(),
                    RGBColor(220, 0, 0).stroke_width(2),
                )))
                .map_err(|e| err(&e))?;
        }
        root.present().map_err(|e| err(&e))?;
    }
    std::fs::write(path, svg).map_err(|e| Error::io(path, "cannot write", e))
}

/// The frames' scores as a table: one row per reference edge.
pub fn table(results: &[FrameResult]) -> String {
    use std::fmt::Write;
    let mut s = String::new();
    for r in results {
        if r.score.edges.is_empty() {
            let _ = writeln!(
                s,
                "{}: {} points, {} edges and {} corners found; {:.0} mm of found edge",
                r.path.display(),
                r.points,
                r.found_edges,
                r.found_corners,
                r.score.found_length * 1e3,
            );
        } else {
            let _ = writeln!(
                s,
                "{}: {} points, {} edges and {} corners found; {:.0} mm of found edge, {:.0} % of it \
                 within {:.0} mm of a reference edge",
                r.path.display(),
                r.points,
                r.found_edges,
                r.found_corners,
                r.score.found_length * 1e3,
                r.score.found_precision * 100.0,
                r.score.tolerance * 1e3,
            );
        }
        let _ = writeln!(
            s,
            "  {}: {} points on an occlusion boundary, {} edge candidates left out as one",
            if r.organised {
                "organised (depth jumps on its grid, sensor at its viewpoint)"
            } else {
                "unorganised (sensor at the origin)"
            },
            r.border_points,
            r.occlusion_runs
        );
        if r.score.edges.is_empty() {
            let _ = writeln!(s, "  no object labels: no reference edges");
            continue;
        }
        let _ = writeln!(
            s,
            "  {:<9} {:>7} {:>9} {:>8} {:>9}",
            "kind", "length", "coverage", "one edge", "mean dist"
        );
        for e in &r.score.edges {
            let kind = match e.edge.kind {
                RefKind::BoxEdge => "box",
                RefKind::BaseEdge => "base",
            };
            let _ = writeln!(
                s,
                "  {:<9} {:>5.0}mm {:>8.0}% {:>7.0}% {:>7.1}mm",
                kind,
                e.length * 1e3,
                e.coverage * 100.0,
                e.one_edge * 100.0,
                e.mean_distance * 1e3
            );
        }
        for kind in [RefKind::BoxEdge, RefKind::BaseEdge] {
            if let Some(m) = r.score.median_coverage(kind) {
                let _ = writeln!(s, "  median coverage ({kind:?}): {:.0} %", m * 100.0);
            }
        }
        let c = r.score.convex;
        let _ = writeln!(
            s,
            "  convex flags of found edges along a reference edge: {} correct, {} wrong, {} \
             undecided",
            c.correct, c.wrong, c.undecided
        );
    }
    s
}

/// Distance from `q` to a polyline.
fn polyline_distance(q: V3, pl: &[V3]) -> f64 {
    match pl {
        [] => f64::INFINITY,
        [a] => norm(sub(q, *a)),
        _ => pl
            .windows(2)
            .map(|w| point_segment(q, w[0], w[1]).0)
            .fold(f64::INFINITY, f64::min),
    }
}

/// Points every `step` along a polyline, both ends included.
fn samples(pl: &[V3], step: f64) -> Vec<V3> {
    let mut out = Vec::new();
    for w in pl.windows(2) {
        let l = norm(sub(w[1], w[0]));
        let n = ((l / step).ceil() as usize).max(1);
        out.extend((0..n).map(|k| add(w[0], scale(sub(w[1], w[0]), k as f64 / n as f64))));
    }
    out.extend(pl.last().copied());
    out
}

/// The polyline of a found edge: its polyline when it has one, else start to end.
fn edge_polyline(e: &EdgeOut) -> Vec<V3> {
    if e.polyline.len() >= 2 {
        e.polyline.clone()
    } else {
        vec![e.start, e.end]
    }
}

/// Scores found edges against reference edges (see the module comment).
pub fn score_frame(refs: &[RefEdge], found_edges: &[EdgeOut], tolerance: f64) -> FrameScore {
    let step = tolerance / 5.0;
    let found: Vec<Vec<V3>> = found_edges.iter().map(edge_polyline).collect();
    let edges = refs
        .iter()
        .map(|r| {
            let pts = samples(&[r.start, r.end], step);
            let dists: Vec<Vec<f64>> = pts
                .iter()
                .map(|&q| found.iter().map(|f| polyline_distance(q, f)).collect())
                .collect();
            let nearest: Vec<f64> = dists
                .iter()
                .map(|d| d.iter().copied().fold(f64::INFINITY, f64::min))
                .collect();
            let covered = nearest.iter().filter(|&&d| d <= tolerance).count();
            let one = (0..found.len())
                .map(|k| dists.iter().filter(|d| d[k] <= tolerance).count())
                .max()
                .unwrap_or(0);
            let n = pts.len().max(1) as f64;
            let mean_distance = if covered > 0 {
                nearest.iter().filter(|&&d| d <= tolerance).sum::<f64>() / covered as f64
            } else {
                f64::NAN
            };
            RefEdgeScore {
                length: r.length(),
                edge: r.clone(),
                coverage: covered as f64 / n,
                one_edge: one as f64 / n,
                mean_distance,
            }
        })
        .collect();
    let mut total = 0usize;
    let mut near = 0usize;
    let mut found_length = 0.0;
    let mut convex = ConvexScore::default();
    for (f, e) in found.iter().zip(found_edges) {
        found_length += f.windows(2).map(|w| norm(sub(w[1], w[0]))).sum::<f64>();
        let qs = samples(f, step);
        let mut along = vec![0usize; refs.len()];
        for &q in &qs {
            total += 1;
            let mut any = false;
            for (r, n) in refs.iter().zip(&mut along) {
                if point_segment(q, r.start, r.end).0 <= tolerance {
                    *n += 1;
                    any = true;
                }
            }
            near += usize::from(any);
        }
        let best = (0..refs.len()).max_by_key(|&k| (along[k], std::cmp::Reverse(k)));
        if let Some(k) = best.filter(|&k| 2 * along[k] > qs.len()) {
            match e.convex {
                None => convex.undecided += 1,
                Some(c) if c == (refs[k].kind == RefKind::BoxEdge) => convex.correct += 1,
                Some(_) => convex.wrong += 1,
            }
        }
    }
    FrameScore {
        tolerance,
        edges,
        found_length,
        found_precision: if total > 0 {
            near as f64 / total as f64
        } else {
            1.0
        },
        convex,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::unit;

    fn edge(polyline: Vec<V3>) -> EdgeOut {
        EdgeOut {
            id: 0,
            kind: crate::outcome::EdgeKind::Sharp,
            start: polyline[0],
            end: *polyline.last().unwrap(),
            direction: [1.0, 0.0, 0.0],
            points: 0,
            rms: 0.0,
            corners: [None, None],
            convex: None,
            convex_votes: Default::default(),
            dihedral_deg: None,
            polyline,
            closed: false,
            rectified: vec![],
            error: None,
        }
    }

    #[test]
    fn plane_line_meets_both_planes() {
        let a = Face {
            label: 20,
            normal: [0.0, 0.0, -1.0],
            offset: -0.8,
            points: vec![],
        };
        let b = Face {
            label: 20,
            normal: unit([1.0, 0.0, -1.0]).unwrap(),
            offset: 0.1,
            points: vec![],
        };
        let (p, u) = plane_line(&a, &b).unwrap();
        for t in [-1.0, 0.0, 2.5] {
            let q = add(p, scale(u, t));
            assert!((dot(a.normal, q) - a.offset).abs() < 1e-12);
            assert!((dot(b.normal, q) - b.offset).abs() < 1e-12);
        }
        let c = Face {
            normal: [0.0, 0.0, -1.0],
            offset: -0.5,
            ..a.clone()
        };
        assert!(plane_line(&a, &c).is_none(), "parallel planes have no line");
    }

    #[test]
    fn coverage_counts_one_edge_and_fragments_apart() {
        let r = RefEdge {
            kind: RefKind::BoxEdge,
            labels: [20, 20],
            start: [0.0, 0.0, 1.0],
            end: [0.1, 0.0, 1.0],
            normal_angle_deg: 90.0,
        };
        // Two fragments 1 mm off the edge, along 0–30 mm and 60–100 mm (each covers the
        // edge up to 4.9 mm past its ends); a stray edge far away.
        let found = vec![
            edge(vec![[0.0, 0.001, 1.0], [0.03, 0.001, 1.0]]),
            edge(vec![[0.06, 0.001, 1.0], [0.1, 0.001, 1.0]]),
            edge(vec![[0.0, 0.1, 1.0], [0.1, 0.1, 1.0]]),
        ];
        let s = score_frame(&[r], &found, 0.005);
        let e = &s.edges[0];
        assert!((e.coverage - 0.80).abs() < 0.02, "coverage {}", e.coverage);
        assert!((e.one_edge - 0.45).abs() < 0.02, "one edge {}", e.one_edge);
        assert!(e.mean_distance > 0.001 && e.mean_distance < 0.0025);
        // 70 of the 170 mm found lie on the reference edge.
        let p = s.found_precision;
        assert!((p - 70.0 / 170.0).abs() < 0.02, "{p}");
    }
}
