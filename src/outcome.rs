//! What a run computed: the pipeline's result and the writers' input, so the writers
//! (report.rs) need nothing from the pipeline that calls them.
//!
//! Input: the stages' fits (edges, their geometry, corners). Output: the edges and corners
//! as reported ([`describe`]), gathered with the cloud and the per-point arrays in an
//! [`Outcome`], and the stage [`Timing`]s.

use serde::Serialize;

use crate::cloud::Cloud;
use crate::geometry::{norm, sub};
use crate::left_out::LeftOut;
use crate::stages::convexity::{Convexity, Votes};
use crate::stages::corners::{CornerFit, EdgeGeometry};
use crate::stages::edges::{EdgeResult, traces_angle};
use crate::stages::features::{Features, Scale};
use crate::stages::plane_corners::FaceEdge;
use crate::stages::segment::Segments;

/// The `edge_kind` code of each point and edge, one table for the LAS extra bytes, the
/// PLY fields and the report (`lidar_out` writes it).
pub mod kind {
    /// On a face: no edge candidate, in no edge's zone.
    pub const FACE: u8 = 0;
    /// An edge candidate (high normal split) that belongs to no fitted edge.
    pub const CANDIDATE: u8 = 1;
    /// In a fitted sharp edge's abnormal zone (its `edge_id` is set).
    pub const EDGE: u8 = 2;
    /// Isolated (too few neighbours): never a candidate, never moved.
    pub const OUTLIER: u8 = 3;
    /// On an occlusion boundary (where the sensor's view of a surface ends: by a depth jump
    /// of the scan's grid, on a face seen edge-on, in a run judged a border): never moved
    /// unless it is in an edge's zone, which comes first.
    pub const BORDER: u8 = 4;
}

/// Wall time of one stage.
#[derive(Debug, Clone, serde::Serialize)]
pub struct Timing {
    pub stage: &'static str,
    pub seconds: f64,
}

/// Everything the stages computed, for the writers and for tests.
pub struct Outcome {
    pub cloud: Cloud,
    pub scale: Scale,
    pub features: Features,
    pub segments: Segments,
    /// Edges and corners as reported.
    pub edges: Vec<EdgeOut>,
    pub corners: Vec<CornerOut>,
    /// Rectified positions (equal to the input where nothing moved) and the moved flags.
    pub rectified: Vec<[f64; 3]>,
    pub moved: Vec<bool>,
    /// Edge id of every point (`u32::MAX` for none).
    pub edge_label: Vec<u32>,
    /// Points on an occlusion boundary (`kind::BORDER`): by a depth jump of the scan's grid,
    /// on a face seen edge-on from the sensor, or in a run judged an occlusion boundary.
    pub border: Vec<bool>,
    /// Every candidate that gave no edge or corner, with its reason: judged no sharp edge, or
    /// a fit that failed (counted and reported, never fatal).
    pub left_out: Vec<LeftOut>,
}

/// What kind of edge a reported edge is. Serialised as its name (report.json, edges.geojson);
/// features.ply and the LAS/LAZ `edge_kind` extra bytes carry [`EdgeKind::code`], one table
/// for both (`kind`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum EdgeKind {
    /// Where two faces of the part meet: fitted, its abnormal zone rectified.
    Sharp,
}

impl EdgeKind {
    /// The value of the `edge_kind` code table (`kind`) for this kind: a point in
    /// a sharp edge's zone has `edge_kind` 2 in a LAS/LAZ output, and so do the sharp edge's
    /// vertices in features.ply.
    pub fn code(self) -> u8 {
        match self {
            EdgeKind::Sharp => kind::EDGE,
        }
    }
}

/// One extracted edge as reported.
#[derive(Debug, Clone, Serialize)]
pub struct EdgeOut {
    pub id: usize,
    pub kind: EdgeKind,
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
    /// null when not determined (see `convex_votes`).
    pub convex: Option<bool>,
    /// The votes `convex` was decided on (rays through the scan, sensors; see
    /// `stages::convexity`): too few, or no two-thirds majority, leave it undetermined.
    pub convex_votes: Votes,
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
    convexity: &[Convexity],
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
            kind: EdgeKind::Sharp,
            start,
            end,
            direction,
            points: f.slabs.iter().map(|s| s.points).sum(),
            rms,
            corners: g.corners,
            convex: convexity[k].convex(),
            convex_votes: convexity[k].votes(),
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

/// An edge where two planar faces meet between two corners (`stages::plane_corners`): too
/// short for the edge stage's slabs, placed by the faces' planes. It has no slab fits, so no
/// rectified edge points and no fit errors.
pub fn plane_edge(id: usize, edge: &FaceEdge, convexity: &Convexity) -> EdgeOut {
    let (start, end) = (edge.start, edge.end);
    let d = sub(end, start);
    let len = norm(d);
    EdgeOut {
        id,
        kind: EdgeKind::Sharp,
        start,
        end,
        direction: d.map(|x| x / len.max(f64::MIN_POSITIVE)),
        points: edge.points,
        rms: 0.0,
        corners: edge.corners,
        convex: convexity.convex(),
        convex_votes: convexity.votes(),
        dihedral_deg: Some(traces_angle(&edge.traces)),
        polyline: vec![start, end],
        closed: false,
        rectified: Vec::new(),
        error: None,
    }
}

/// Adds every edge to the corners it ends at (an edge joined to a corner by its faces' planes
/// was not among the edges that met at the corner's vertex).
pub fn link_corners(edges: &[EdgeOut], corners: &mut [CornerOut]) {
    for e in edges {
        for c in e.corners.iter().flatten() {
            if let Some(c) = corners.get_mut(*c)
                && !c.edges.contains(&e.id)
            {
                c.edges.push(e.id);
            }
        }
    }
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
