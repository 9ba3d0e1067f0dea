//! The outputs for GIS and lidar tools: the rectified cloud as LAS/LAZ with sharpedge's
//! per-point fields as extra bytes, and the edges and corners as GeoJSON.
//!
//! Input: the pipeline's `Outcome` and the LAS/LAZ input's [`Lidar`] (header, EVLRs, raw
//! records), or its CRS for the GeoJSON. Output: `rectified.las`/`.laz` (see
//! `io::write_las`) and `edges.geojson` (see `io::write_geojson`). The formats themselves
//! stay in `io`; this module only decides what goes in.

use std::path::Path;

use serde_json::{Map, Value, json};

use crate::cloud::{Attribute, Column};
use crate::error::Result;
use crate::io::{self, Crs, ExtraField, GeoFeature, Geometry, LasWriteOptions, Lidar};
use crate::outcome::{CornerOut, EdgeOut, Outcome, PointFields};

/// What a point is to sharpedge, in the `edge_kind` extra bytes; the edges' own kinds use the
/// same table (`EdgeKind::code`: the vertices of a sharp edge in features.ply have 2).
pub use crate::outcome::kind;

/// Writes the rectified cloud as LAS/LAZ in the input's layout with the per-point fields as
/// extra bytes: `edge_id`, `edge_kind`, `moved`, `displacement`, `sharpness`.
pub fn write_rectified(
    path: &Path,
    outcome: &Outcome,
    lidar: &Lidar,
    opts: &LasWriteOptions,
) -> Result<()> {
    let fields = PointFields::of(outcome);
    let f = &outcome.features;
    // A point in an edge's zone has that edge's kind (edges are reported with id = index).
    let edge_code = |l: u32| {
        (l != u32::MAX).then(|| {
            outcome
                .edges
                .get(l as usize)
                .map_or(kind::EDGE, |e| e.kind.code())
        })
    };
    let edge: Vec<bool> = outcome.edge_label.iter().map(|&l| l != u32::MAX).collect();
    let kinds: Vec<u8> = (0..outcome.cloud.len())
        .map(|i| {
            if let Some(e) = edge_code(outcome.edge_label[i]) {
                e
            } else if outcome.border[i] {
                kind::BORDER
            } else if f.outlier[i] {
                kind::OUTLIER
            } else if f.candidate[i] {
                kind::CANDIDATE
            } else {
                kind::FACE
            }
        })
        .collect();
    let named = |name: &str, values: Column| Attribute {
        name: name.into(),
        values,
    };
    let columns = [
        (
            named("edge_id", Column::I32(fields.edge_id)),
            "sharpedge edge id, -1 = none",
        ),
        (
            named("edge_kind", Column::U8(kinds)),
            "0face 1candidate 2edge 3outlier",
        ),
        (
            named("moved", Column::U8(fields.moved)),
            "1 = moved onto the fitted edge",
        ),
        (
            named("displacement", Column::F32(fields.displacement)),
            "distance moved, in model units",
        ),
        (
            named("sharpness", Column::F32(fields.sharpness)),
            "normal split: edge score",
        ),
    ];
    let extra: Vec<ExtraField> = columns
        .iter()
        .map(|(attribute, description)| ExtraField {
            attribute,
            description,
        })
        .collect();
    io::write_las(
        path,
        lidar,
        &outcome.rectified,
        &outcome.moved,
        &edge,
        &extra,
        opts,
    )
}

/// Writes the edges (a 3D line string each: a curved edge's polyline, a closed one ending
/// where it starts) and corners (3D points) as GeoJSON in `crs`. Properties: `id`, `kind`
/// (`edge` or `corner`), `edge_kind` (the edge's kind, `sharp`; null for corners), `dihedral`
/// (degrees), `rms`, `convex` (null when not determined), and for corners the ids of their
/// `edges`.
pub fn write_edges(path: &Path, outcome: &Outcome, crs: Option<&Crs>) -> Result<()> {
    write_edges_of(path, &outcome.edges, &outcome.corners, crs)
}

/// [`write_edges`] of these edges and corners (`run`'s, or the ones `merge` joined).
pub fn write_edges_of(
    path: &Path,
    edges: &[EdgeOut],
    corners: &[CornerOut],
    crs: Option<&Crs>,
) -> Result<()> {
    let mut features = Vec::with_capacity(edges.len() + corners.len());
    let props = |pairs: [(&str, Value); 6]| -> Map<String, Value> {
        pairs.into_iter().map(|(k, v)| (k.to_string(), v)).collect()
    };
    for e in edges {
        features.push(GeoFeature {
            geometry: Geometry::LineString(e.polyline.clone()),
            properties: props([
                ("id", json!(e.id)),
                ("kind", json!("edge")),
                ("edge_kind", json!(e.kind)),
                ("dihedral", json!(e.dihedral_deg)),
                ("rms", json!(e.rms)),
                ("convex", json!(e.convex)),
            ]),
        });
    }
    for c in corners {
        let mut p = props([
            ("id", json!(c.id)),
            ("kind", json!("corner")),
            ("edge_kind", Value::Null),
            ("dihedral", Value::Null),
            ("rms", Value::Null),
            ("convex", Value::Null),
        ]);
        p.insert("edges".into(), json!(c.edges));
        features.push(GeoFeature {
            geometry: Geometry::Point(c.position),
            properties: p,
        });
    }
    io::write_geojson(path, &features, crs)
}
