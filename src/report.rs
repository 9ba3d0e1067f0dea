//! The output contract: rectified.ply (or .las/.laz), features.ply, edges.geojson and
//! report.json.
//!
//! Input: the pipeline's `Outcome` (cloud, per-point side arrays, fitted edges and corners),
//! the LAS/LAZ input's header and records when there is one, the settings and the stage
//! timings. Output: four files in the output folder, written into a staging folder there and
//! moved into place together, so a failed run leaves none of them. The LAS/LAZ cloud and the
//! GeoJSON are made in `lidar_out.rs`.
//!
//! Field names are chosen for the viewers our users have: CloudCompare's command line loads a
//! custom vertex property only if its name contains `scalar`, MeshLab reads `quality` and
//! `red/green/blue` (uchar) but not custom names. `element edge` with `int vertex1, int
//! vertex2` is what MeshLab and Open3D draw as lines.

use std::path::{Path, PathBuf};

use serde::Serialize;

use crate::cloud::{Attribute, Column};
use crate::config::{Precision, Settings};
use crate::corners::{CornerFit, EdgeGeometry};
use crate::edges::EdgeResult;
use crate::error::{Error, Result};
use crate::io::{self, PlyWriteOptions};
use crate::pipeline::{Outcome, Timing};
use crate::segment::{norm, sub};

/// One extracted edge as reported.
#[derive(Debug, Clone, Serialize)]
pub struct EdgeOut {
    pub id: usize,
    pub start: [f64; 3],
    pub end: [f64; 3],
    /// Unit direction from start to end.
    pub direction: [f64; 3],
    /// Number of scan points used to fit the edge.
    pub points: usize,
    /// RMS distance of the rectified edge points to the reported edge line.
    pub rms: f64,
    /// Corners at the start and end (ids into `corners`), when the edge ends at one.
    pub corners: [Option<usize>; 2],
    /// True for a convex edge (material inside the smaller angle), false for a concave one;
    /// absent when not determined.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub convex: Option<bool>,
    /// Dihedral angle between the two faces, in degrees, when fitted.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub dihedral_deg: Option<f64>,
    /// The edge as a polyline, start to end (two points for a straight edge; a closed edge
    /// ends where it starts).
    pub polyline: Vec<[f64; 3]>,
    /// The edge goes round a closed curve (a hole's rim): `start` = `end`, no corners.
    pub closed: bool,
    /// Rectified edge points (one per slab), not serialised in the report (features.ply has
    /// them).
    #[serde(skip)]
    pub rectified: Vec<[f64; 3]>,
    /// Fit errors summed over the slabs, per searcher.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub error: Option<FitErrors>,
}

/// Errors of a constrained fit by searcher (sum of point-to-line distances, the paper's
/// Eq. 11/13).
#[derive(Debug, Clone, Copy, Serialize)]
pub struct FitErrors {
    pub scheme1: f64,
    pub pso: f64,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub ga: Option<f64>,
    pub exact: f64,
}

/// One extracted corner as reported.
#[derive(Debug, Clone, Serialize)]
pub struct CornerOut {
    pub id: usize,
    /// The corner: the particle swarm's constrained optimum.
    pub position: [f64; 3],
    /// Ids of the edges that meet here.
    pub edges: Vec<usize>,
    /// Errors of the constrained 3D fit by searcher; absent when the fit failed and the
    /// position is where the edges' lines meet.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub error: Option<FitErrors>,
    /// The corner by Scheme 1 (best data point) and by the exact optimum, for comparison.
    pub scheme1: [f64; 3],
    pub exact: [f64; 3],
}

/// Turns the fits into the reported edges and corners.
pub fn describe(
    fits: &[EdgeResult],
    geometry: &[Option<EdgeGeometry>],
    corners: &[CornerFit],
    edge_of_run: &[Option<u32>],
) -> (Vec<EdgeOut>, Vec<CornerOut>) {
    let mut edges = Vec::new();
    for (k, g) in geometry.iter().enumerate() {
        let (Some(g), Ok(f), Some(id)) = (g, &fits[k], edge_of_run[k]) else {
            continue;
        };
        let start = g.polyline[0];
        let end = g.polyline[g.polyline.len() - 1];
        let d = sub(end, start);
        let len = norm(d);
        let direction = if len > 0.0 {
            d.map(|x| x / len)
        } else {
            f.line.1
        };
        let rectified: Vec<[f64; 3]> = f.slabs.iter().map(|s| s.corner).collect();
        let rms = (rectified
            .iter()
            .map(|p| norm(sub(*p, g.nearest(*p).0)).powi(2))
            .sum::<f64>()
            / rectified.len().max(1) as f64)
            .sqrt();
        let sum = |j: usize| f.slabs.iter().map(|s| s.errors[j]).sum::<f64>();
        edges.push(EdgeOut {
            id: id as usize,
            start,
            end,
            direction,
            points: f.slabs.iter().map(|s| s.points).sum(),
            rms,
            corners: g.corners,
            convex: None,
            dihedral_deg: Some(f.dihedral_deg),
            polyline: g.polyline.clone(),
            closed: f.closed,
            rectified,
            error: Some(FitErrors {
                scheme1: sum(0),
                pso: sum(1),
                ga: None,
                exact: sum(2),
            }),
        });
    }
    let corners = corners
        .iter()
        .enumerate()
        .map(|(id, c)| CornerOut {
            id,
            position: c.position,
            edges: c
                .edges
                .iter()
                .filter_map(|&k| edge_of_run[k].map(|e| e as usize))
                .collect(),
            error: c.errors[1].is_finite().then_some(FitErrors {
                scheme1: c.errors[0],
                pso: c.errors[1],
                ga: None,
                exact: c.errors[2],
            }),
            scheme1: c.scheme1,
            exact: c.exact,
        })
        .collect();
    (edges, corners)
}

#[derive(Serialize)]
struct Report<'a> {
    sharpedge: &'static str,
    input: InputReport<'a>,
    scale: crate::features::Scale,
    counts: Counts,
    timings: &'a [Timing],
    edges: &'a [EdgeOut],
    corners: &'a [CornerOut],
    failures: &'a [String],
    config: &'a Settings,
}

#[derive(Serialize)]
struct InputReport<'a> {
    path: String,
    format: &'a str,
    points: usize,
}

#[derive(Serialize)]
struct Counts {
    points: usize,
    candidates: usize,
    outliers: usize,
    runs: usize,
    edges: usize,
    corners: usize,
    moved: usize,
    failed_fits: usize,
}

/// An I/O error on a file in the staging folder, reported against the output the user asked
/// for (`out/rectified.ply`, not `out/.sharpedge-run-XXXX/rectified.ply`).
fn at_destination(e: Error, staging: &Path, to: &Path) -> Error {
    match e {
        Error::Io {
            path,
            action,
            source,
        } if path.starts_with(staging) => Error::Io {
            path: to.to_path_buf(),
            action,
            source,
        },
        e => e,
    }
}

/// Writes the four output files; `lidar` is the LAS/LAZ input (with its point records when
/// the rectified cloud is LAS/LAZ). Returns their paths.
pub fn write_all(
    outcome: &Outcome,
    lidar: Option<&io::Lidar>,
    settings: &Settings,
    dir: &Path,
    timings: &[Timing],
) -> Result<Vec<PathBuf>> {
    let precision = match settings.output.precision {
        Precision::Float => io::Precision::F32,
        Precision::Double => io::Precision::F64,
        Precision::Auto => auto_precision(outcome),
    };
    let opts = PlyWriteOptions {
        encoding: settings.output.encoding,
        precision,
    };
    // Each file is atomic on its own, but the four are one result: a run that fails on the
    // second must not leave the first beside an older second. So all are written into a
    // staging folder inside `dir` (same file system: renames are atomic) and moved into place
    // only when all exist, after checking that nothing can stop the renames.
    let format = settings.output.format.resolve(&outcome.cloud.source.path)?;
    let rectified_name = format!("rectified.{}", format.extension());
    let names = [
        rectified_name.as_str(),
        "features.ply",
        "edges.geojson",
        "report.json",
    ];
    for name in names {
        let to = dir.join(name);
        if std::fs::symlink_metadata(&to).is_ok_and(|m| m.is_dir()) {
            return Err(Error::io(
                &to,
                "cannot write this output",
                std::io::Error::other(
                    "a folder of that name is in the way; move it or choose another output folder",
                ),
            ));
        }
    }
    let staging = tempfile::Builder::new()
        .prefix(".sharpedge-run-")
        .tempdir_in(dir)
        .map_err(|e| {
            Error::io(
                dir,
                "cannot create a temporary folder in the output folder (is it writable?)",
                e,
            )
        })?;
    let staged: Vec<PathBuf> = names.iter().map(|n| staging.path().join(n)).collect();
    let staging_dir = staging.path().to_path_buf();
    let named = |i: usize| {
        let to = dir.join(names[i]);
        let st = staging_dir.clone();
        move |e| at_destination(e, &st, &to)
    };
    match (format.is_lidar(), lidar) {
        (true, Some(l)) => crate::lidar_out::write_rectified(
            &staged[0],
            outcome,
            l,
            &io::LasWriteOptions {
                compressed: format == io::CloudFormat::Laz,
                edge_class: settings
                    .output
                    .classify_edges
                    .then_some(settings.output.edge_class),
            },
        ),
        (true, None) => Err(Error::BadOutput {
            path: dir.join(&rectified_name),
            what: "a LAS/LAZ output is written from the LAS/LAZ input's records, which were \
                   not given"
                .into(),
        }),
        (false, _) => write_rectified(&staged[0], outcome, &opts),
    }
    .map_err(named(0))?;
    write_features(&staged[1], outcome, &opts).map_err(named(1))?;
    crate::lidar_out::write_edges(&staged[2], outcome, lidar.and_then(io::Lidar::crs).as_ref())
        .map_err(named(2))?;
    write_report(&staged[3], outcome, settings, timings).map_err(named(3))?;
    let mut placed: Vec<PathBuf> = Vec::new();
    for (from, name) in staged.iter().zip(names) {
        let to = dir.join(name);
        if let Err(e) = std::fs::rename(from, &to) {
            // Only a race can get here (checked above). Take back what this run already
            // placed: no output beats a mixed one.
            for p in &placed {
                let _ = std::fs::remove_file(p);
            }
            return Err(Error::io(
                &to,
                "cannot move the finished output to this name; no output was written",
                e,
            ));
        }
        placed.push(to);
    }
    Ok(placed)
}

/// Double coordinates when the input had them, or when float's step at the cloud's magnitude
/// exceeds a thousandth of the spacing (float keeps 24 bits).
fn auto_precision(outcome: &Outcome) -> io::Precision {
    let max_abs = outcome
        .cloud
        .positions
        .iter()
        .flat_map(|p| p.iter())
        .fold(0.0f64, |m, c| m.max(c.abs()));
    let step = max_abs * f64::powi(2.0, -23);
    if outcome.cloud.source.double_precision || step > 1e-3 * outcome.scale.spacing {
        io::Precision::F64
    } else {
        io::Precision::F32
    }
}

/// Names sharpedge writes per point; carried attributes with the same name are renamed
/// `input_<name>` so both survive.
const OWN_FIELDS: [&str; 8] = [
    "scalar_edge_id",
    "scalar_moved",
    "scalar_displacement",
    "scalar_sharpness",
    "quality",
    "red",
    "green",
    "blue",
];

/// Whether a carried attribute would be taken by a viewer for sharpedge's own fields, so it
/// must be renamed: one of sharpedge's names, `alpha` (MeshLab joins it to the edge colours)
/// or a float `intensity` (MeshLab paints it over the colours as grey; other types it
/// ignores, and CloudCompare shows any `intensity` as a scalar field).
fn clashes_with_own(a: &Attribute) -> bool {
    let name = a.name.as_str();
    OWN_FIELDS.contains(&name)
        || name == "alpha"
        || (name == "intensity" && matches!(a.values, Column::F32(_)))
}

/// The carried attributes as written: in input order, each clashing one renamed
/// `input_<name>` (`input_input_<name>`... when that is taken too, e.g. when the input is a
/// rectified.ply that already has `input_red` beside `red`).
fn carried_names(attributes: &[Attribute]) -> Vec<String> {
    let mut taken: std::collections::HashSet<String> = OWN_FIELDS
        .iter()
        .map(|s| s.to_string())
        .chain(attributes.iter().map(|a| a.name.clone()))
        .collect();
    attributes
        .iter()
        .map(|a| {
            if !clashes_with_own(a) {
                return a.name.clone();
            }
            let mut name = format!("input_{}", a.name);
            while taken.contains(&name) {
                name = format!("input_{name}");
            }
            taken.insert(name.clone());
            name
        })
        .collect()
}

/// sharpedge's per-point fields, shared by the PLY and the LAS/LAZ output.
pub(crate) struct PointFields {
    /// Reported edge id, -1 for none.
    pub edge_id: Vec<i32>,
    /// 1 where rectification moved the point.
    pub moved: Vec<u8>,
    /// Distance moved, in model units.
    pub displacement: Vec<f32>,
    /// The normal split: the score that separates edges from faces.
    pub sharpness: Vec<f32>,
}

impl PointFields {
    pub(crate) fn of(outcome: &Outcome) -> Self {
        let cloud = &outcome.cloud;
        PointFields {
            edge_id: outcome
                .edge_label
                .iter()
                .map(|&l| if l == u32::MAX { -1 } else { l as i32 })
                .collect(),
            moved: outcome.moved.iter().map(|&m| u8::from(m)).collect(),
            displacement: cloud
                .positions
                .iter()
                .zip(&outcome.rectified)
                .map(|(a, b)| {
                    ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
                        as f32
                })
                .collect(),
            sharpness: outcome.features.split.clone(),
        }
    }
}

fn write_rectified(path: &Path, outcome: &Outcome, opts: &PlyWriteOptions) -> Result<()> {
    let cloud = &outcome.cloud;
    let n = cloud.len();
    let label = &outcome.edge_label;
    let fields = PointFields::of(outcome);
    let (mut red, mut green, mut blue) = (vec![0u8; n], vec![0u8; n], vec![0u8; n]);
    for i in 0..n {
        let c = colour(label[i]);
        (red[i], green[i], blue[i]) = (c[0], c[1], c[2]);
    }
    // MeshLab shows quality: the sharpness again.
    let sharp = fields.sharpness;
    let own = [
        Attribute {
            name: "scalar_edge_id".into(),
            values: Column::I32(fields.edge_id),
        },
        Attribute {
            name: "scalar_moved".into(),
            values: Column::U8(fields.moved),
        },
        Attribute {
            name: "scalar_displacement".into(),
            values: Column::F32(fields.displacement),
        },
        Attribute {
            name: "scalar_sharpness".into(),
            values: Column::F32(sharp.clone()),
        },
        Attribute {
            name: "quality".into(),
            values: Column::F32(sharp),
        },
        Attribute {
            name: "red".into(),
            values: Column::U8(red),
        },
        Attribute {
            name: "green".into(),
            values: Column::U8(green),
        },
        Attribute {
            name: "blue".into(),
            values: Column::U8(blue),
        },
    ];
    let names = carried_names(&cloud.attributes);
    let renamed: Vec<Attribute> = cloud
        .attributes
        .iter()
        .zip(&names)
        .filter(|(a, name)| a.name != **name)
        .map(|(a, name)| Attribute {
            name: name.clone(),
            values: a.values.clone(),
        })
        .collect();
    // sharpedge's own fields first: CloudCompare takes the first property whose name
    // contains `red` (`green`, `blue`) as the colour, which would otherwise be `input_red`.
    let mut attrs: Vec<&Attribute> = own.iter().collect();
    let mut renamed_iter = renamed.iter();
    for (a, name) in cloud.attributes.iter().zip(&names) {
        if a.name == *name {
            attrs.push(a);
        } else if let Some(r) = renamed_iter.next() {
            attrs.push(r);
        }
    }
    io::write_ply(path, &outcome.rectified, &attrs, &[], opts)
}

fn write_features(path: &Path, outcome: &Outcome, opts: &PlyWriteOptions) -> Result<()> {
    // Vertices: corners, then each edge's polyline, then its rectified edge points.
    let mut pos: Vec<[f64; 3]> = Vec::new();
    let mut kind: Vec<u8> = Vec::new();
    let mut edge_id: Vec<i32> = Vec::new();
    let mut lines: Vec<[u32; 2]> = Vec::new();
    for c in &outcome.corners {
        pos.push(c.position);
        kind.push(0);
        edge_id.push(-1);
    }
    for e in &outcome.edges {
        let first = pos.len() as u32;
        for (k, p) in e.polyline.iter().enumerate() {
            pos.push(*p);
            kind.push(1);
            edge_id.push(e.id as i32);
            if k > 0 {
                lines.push([first + k as u32 - 1, first + k as u32]);
            }
        }
    }
    for e in &outcome.edges {
        for p in &e.rectified {
            pos.push(*p);
            kind.push(2);
            edge_id.push(e.id as i32);
        }
    }
    if pos.len() > i32::MAX as usize {
        return Err(Error::Degenerate {
            what: "features.ply",
            why: "more vertices than a PLY int index can address".into(),
        });
    }
    let (mut red, mut green, mut blue) = (Vec::new(), Vec::new(), Vec::new());
    for (k, &id) in kind.iter().zip(&edge_id) {
        let c = if *k == 0 {
            [255, 0, 0]
        } else {
            colour(id as u32)
        };
        red.push(c[0]);
        green.push(c[1]);
        blue.push(c[2]);
    }
    let attrs = [
        Attribute {
            name: "scalar_kind".into(),
            values: Column::U8(kind),
        },
        Attribute {
            name: "scalar_edge_id".into(),
            values: Column::I32(edge_id),
        },
        Attribute {
            name: "red".into(),
            values: Column::U8(red),
        },
        Attribute {
            name: "green".into(),
            values: Column::U8(green),
        },
        Attribute {
            name: "blue".into(),
            values: Column::U8(blue),
        },
    ];
    let refs: Vec<&Attribute> = attrs.iter().collect();
    io::write_ply(path, &pos, &refs, &lines, opts)
}

fn write_report(
    path: &Path,
    outcome: &Outcome,
    settings: &Settings,
    timings: &[Timing],
) -> Result<()> {
    let f = &outcome.features;
    let report = Report {
        sharpedge: env!("CARGO_PKG_VERSION"),
        input: InputReport {
            path: outcome.cloud.source.path.display().to_string(),
            format: &outcome.cloud.source.format,
            points: outcome.cloud.len(),
        },
        scale: outcome.scale,
        counts: Counts {
            points: outcome.cloud.len(),
            candidates: f.candidate.iter().filter(|&&c| c).count(),
            outliers: f.outlier.iter().filter(|&&c| c).count(),
            runs: outcome.segments.runs.len(),
            edges: outcome.edges.len(),
            corners: outcome.corners.len(),
            moved: outcome.moved.iter().filter(|&&m| m).count(),
            failed_fits: outcome.failures.len(),
        },
        timings,
        edges: &outcome.edges,
        corners: &outcome.corners,
        failures: &outcome.failures,
        config: settings,
    };
    let text = crate::json::pretty(&report)
        .map_err(|e| Error::io(path, "cannot write report", e.into()))?
        + "\n";
    io::write_atomic(path, |w| {
        w.write_all(text.as_bytes())
            .map_err(|e| Error::io(path, "cannot write report", e))
    })
}

/// A distinct, stable colour per edge id (golden-ratio hue steps); grey for no edge.
pub fn colour(id: u32) -> [u8; 3] {
    if id == u32::MAX {
        return [170, 170, 170];
    }
    let h = (f64::from(id) * 0.618_033_988_749_895).fract() * 6.0;
    let x = 1.0 - (h % 2.0 - 1.0).abs();
    let (r, g, b) = match h as u32 {
        0 => (1.0, x, 0.0),
        1 => (x, 1.0, 0.0),
        2 => (0.0, 1.0, x),
        3 => (0.0, x, 1.0),
        4 => (x, 0.0, 1.0),
        _ => (1.0, 0.0, x),
    };
    [r, g, b].map(|c: f64| (40.0 + 215.0 * c) as u8)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn staging_errors_name_the_final_output() {
        let staging = Path::new("out/.sharpedge-run-abc");
        let to = Path::new("out/rectified.ply");
        let e = Error::io(
            staging.join(".tmp123"),
            "cannot write",
            std::io::Error::other("No space left on device"),
        );
        let msg = at_destination(e, staging, to).to_string();
        assert!(msg.contains("out/rectified.ply"), "{msg}");
        assert!(!msg.contains("sharpedge-run"), "{msg}");
        // Errors about other files keep their path.
        let e = Error::io("in/scan.ply", "cannot open", std::io::Error::other("gone"));
        assert!(
            at_destination(e, staging, to)
                .to_string()
                .contains("in/scan.ply")
        );
    }
}
