//! The output contract: rectified.ply (or .las/.laz), features.ply, edges.geojson and
//! report.json.
//!
//! Input: the pipeline's `Outcome` (cloud, per-point side arrays, fitted edges and corners),
//! the LAS/LAZ input's header and records when there is one, the settings and the stage
//! timings. Output: four files in the output folder, written into a run folder there and
//! published together (`io::output_set`), so a failed or killed run leaves none of them and
//! a reader never sees files of two runs side by side. The LAS/LAZ cloud and the
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
use crate::error::{Error, Result};
use crate::io::{self, PlyWriteOptions};
use crate::left_out::{LeftOut, Tally};
use crate::outcome::{CornerOut, EdgeOut, Outcome, PointFields, Timing};

#[derive(Serialize)]
struct Report<'a> {
    sharpedge: &'static str,
    input: InputReport<'a>,
    scale: crate::stages::features::Scale,
    counts: Counts,
    timings: &'a [Timing],
    edges: &'a [EdgeOut],
    corners: &'a [CornerOut],
    left_out: LeftOutReport<'a>,
    config: &'a Settings,
}

/// The candidates that gave no edge or corner: counted by reason, then each with its message.
#[derive(Serialize)]
struct LeftOutReport<'a> {
    by_reason: Tally,
    candidates: &'a [LeftOut],
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
    /// Candidates judged no sharp edge or corner (a fillet, a surface bending, ...).
    left_out: usize,
    /// Fits that could not be computed.
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

/// Writes the four output files; `original` is what the input kept for its own format: the
/// LAS/LAZ input (with its point records when the rectified cloud is LAS/LAZ), the PCD
/// input's records (for a PCD output) or the E57 input's scans and records (for an E57
/// output). Returns their paths.
pub fn write_all(
    outcome: &Outcome,
    original: Option<&io::Original>,
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
    // Each file is atomic on its own, but the four are one result: a run that fails or is
    // killed on the second must not leave the first beside an older second. So all are
    // written into a run folder inside `dir` and published together (io::output_set).
    let format = settings.output.format.resolve(&outcome.cloud.source.path)?;
    let rectified_name = format!("rectified.{}", format.extension());
    let names = [
        rectified_name.as_str(),
        "features.ply",
        "edges.geojson",
        "report.json",
    ];
    let staging = io::output_set::stage(dir, &names)?;
    let staged: Vec<PathBuf> = (0..names.len()).map(|i| staging.file(i)).collect();
    let staging_dir = staging.run_dir().to_path_buf();
    let named = |i: usize| {
        let to = dir.join(names[i]);
        let st = staging_dir.clone();
        move |e| at_destination(e, &st, &to)
    };
    let lidar = original.and_then(io::Original::lidar);
    let missing = |what: &str| Error::BadOutput {
        path: dir.join(&rectified_name),
        what: format!("{what} output is written from the input's records, which were not given"),
    };
    match (format, original) {
        (io::CloudFormat::Pcd, Some(io::Original::Pcd(p))) => {
            io::write_pcd(&staged[0], p, &outcome.rectified, &outcome.moved)
        }
        (io::CloudFormat::Pcd, _) => Err(missing("a PCD")),
        (io::CloudFormat::E57, Some(io::Original::E57(e))) => {
            io::write_e57(&staged[0], e, &outcome.rectified, &outcome.moved)
        }
        (io::CloudFormat::E57, _) => Err(missing("an E57")),
        (f, Some(io::Original::Lidar(l))) if f.is_lidar() => crate::lidar_out::write_rectified(
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
        (f, _) if f.is_lidar() => Err(missing("a LAS/LAZ")),
        _ => write_rectified(&staged[0], outcome, &opts),
    }
    .map_err(named(0))?;
    write_features(&staged[1], outcome, &opts).map_err(named(1))?;
    crate::lidar_out::write_edges(&staged[2], outcome, lidar.and_then(io::Lidar::crs).as_ref())
        .map_err(named(2))?;
    write_report(&staged[3], outcome, settings, timings).map_err(named(3))?;
    staging.publish()
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

/// `scalar_edge_kind` of a corner in features.ply: no edge's kind.
const NO_EDGE_KIND: u8 = 255;

fn write_features(path: &Path, outcome: &Outcome, opts: &PlyWriteOptions) -> Result<()> {
    write_features_of(path, &outcome.edges, &outcome.corners, opts)
}

/// Writes features.ply of these edges and corners (`run`'s, or the ones `merge` joined from
/// tiles).
pub fn write_features_of(
    path: &Path,
    edges: &[EdgeOut],
    corners: &[CornerOut],
    opts: &PlyWriteOptions,
) -> Result<()> {
    // Vertices: corners, then each edge's polyline, then its rectified edge points.
    let mut pos: Vec<[f64; 3]> = Vec::new();
    let mut kind: Vec<u8> = Vec::new();
    let mut edge_id: Vec<i32> = Vec::new();
    // The edge's kind by the `edge_kind` code table (2 sharp); a corner belongs to no one edge.
    let mut edge_kind: Vec<u8> = Vec::new();
    let mut lines: Vec<[u32; 2]> = Vec::new();
    for c in corners {
        pos.push(c.position);
        kind.push(0);
        edge_id.push(-1);
        edge_kind.push(NO_EDGE_KIND);
    }
    for e in edges {
        let first = pos.len() as u32;
        for (k, p) in e.polyline.iter().enumerate() {
            pos.push(*p);
            kind.push(1);
            edge_id.push(e.id as i32);
            edge_kind.push(e.kind.code());
            if k > 0 {
                lines.push([first + k as u32 - 1, first + k as u32]);
            }
        }
    }
    for e in edges {
        for p in &e.rectified {
            pos.push(*p);
            kind.push(2);
            edge_id.push(e.id as i32);
            edge_kind.push(e.kind.code());
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
            name: "scalar_edge_kind".into(),
            values: Column::U8(edge_kind),
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
    let tally = Tally::of(&outcome.left_out);
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
            left_out: tally.judged(),
            failed_fits: tally.failed(),
        },
        timings,
        edges: &outcome.edges,
        corners: &outcome.corners,
        left_out: LeftOutReport {
            by_reason: tally,
            candidates: &outcome.left_out,
        },
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
