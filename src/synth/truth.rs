//! The ground truth of a simulated scan, in world coordinates, and exact queries against it.
//!
//! [`GroundTruth`] is what `sharpedge synth` writes as JSON next to the cloud and what the
//! benchmark reads back: the part and every parameter, the spacing used, the sharp edges as
//! segments (convex flag, dihedral angle, the two faces), the corners, the polylines the edges
//! form, the planar faces, the exact surface (a triangle mesh or a sphere), and the rigid
//! transform from model to world coordinates; for scans with a sampling pattern also the
//! sensors (position, pitch, misregistration of each view), the cut planes of a line scan and
//! the density gradient (absent from the JSON of plain uniform scans).
//!
//! Queries are exact (no sampling): distance to the surface (closest point on a triangle,
//! Ericson 2005; or on the sphere), to the nearest sharp edge segment, and to the nearest
//! corner. For meshes with more than [`BRUTE_FORCE_LIMIT`] triangles or edges a uniform grid
//! ([`GridIndex`]) prunes the search; it is built on first use, also after [`GroundTruth::from_json`].

use std::sync::OnceLock;

use serde::{Deserialize, Serialize};

use super::SynthParams;
use super::features::MeshStats;
use super::index::GridIndex;
use crate::error::{Error, Result};
use crate::geometry::{V3, closest_on_triangle, dist, norm, point_segment, sub};

/// Up to this many primitives the queries loop over all of them.
pub const BRUTE_FORCE_LIMIT: usize = 64;

/// A sharp edge segment (world coordinates).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TruthEdge {
    pub id: usize,
    pub start: V3,
    pub end: V3,
    pub length: f64,
    /// True for a convex edge (material dihedral < 180°), false for a concave one.
    pub convex: bool,
    /// Material dihedral angle in degrees: 90 for a box edge, 270 for the L-block's inner edge.
    pub dihedral_deg: f64,
    /// The ids of the two faces (into `GroundTruth::faces`) that meet here…
    pub faces: [usize; 2],
    /// …and their outward unit normals at this edge.
    pub normals: [V3; 2],
    /// Width of the rounded band on each face (the fillet's tangent distance), 0 if unrounded.
    pub tangent_distance: f64,
    /// The polyline this segment belongs to.
    pub polyline: usize,
}

/// A corner (world coordinates).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TruthCorner {
    pub id: usize,
    pub position: V3,
    /// Ids of the sharp edges that meet here.
    pub edges: Vec<usize>,
    /// True when the rounding put a ball blend here.
    pub ball_blend: bool,
}

/// A chain of edge segments between corners or ends, or a closed loop.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TruthPolyline {
    pub id: usize,
    pub edges: Vec<usize>,
    pub closed: bool,
    pub length: f64,
}

/// A face: a connected set of coplanar triangles (one per planar face of a polyhedral part;
/// on curved mesh surfaces, small patches). `PointTruth::face` refers to these ids.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TruthFace {
    pub id: usize,
    /// Outward unit normal and a point of the plane (world coordinates).
    pub normal: V3,
    pub point: V3,
    pub area: f64,
    pub triangles: usize,
}

/// One sensor of a scan with views (`grid`, `view`), or the sensor incidence noise is
/// measured from (world coordinates).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TruthSensor {
    pub view: usize,
    pub position: V3,
    /// The view's pitch (model units): the pixel pitch on the plane through the part's centre
    /// facing the sensor (`grid`), or its grid pitch (`view`).
    pub pitch: f64,
    /// The view's misregistration: its points were moved from x to `R x + t` (world; the
    /// identity for the first view).
    pub registration_rotation: [V3; 3],
    pub registration_translation: V3,
}

/// The cut planes of a line scan: plane k is `normal · x = offset + k gap` (world).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TruthLines {
    pub normal: V3,
    pub offset: f64,
    pub gap: f64,
}

/// The density gradient: the density falls by `ratio` from `direction · x = lo` to `= hi`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TruthDensity {
    pub direction: V3,
    pub ratio: f64,
    pub lo: f64,
    pub hi: f64,
}

/// A wide fillet (a random part's rounded vertical edge): no sharp edge. A correct tool finds
/// no edge along it and moves none of its points; its points and those within the away
/// margin of its tangent lines do not count as "away from edges" (bench).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TruthFillet {
    pub id: usize,
    /// Radius in model units and in spacings.
    pub radius: f64,
    pub radius_h: f64,
    /// Interior angle of the edge it rounds off (degrees; 90 for a box's edge).
    pub angle_deg: f64,
    /// The faces (charts) of its curved surface: `PointTruth::face` of its points.
    pub faces: Vec<usize>,
    /// The two lines where it meets the flat faces (world coordinates, bottom to top).
    pub tangent_lines: [[V3; 2]; 2],
}

/// The exact surface of the sharp (unrounded) part, in world coordinates.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum TruthSurface {
    Mesh {
        vertices: Vec<V3>,
        triangles: Vec<[u32; 3]>,
    },
    Sphere {
        centre: V3,
        radius: f64,
    },
}

/// Search structures, rebuilt on demand (not serialised).
#[derive(Debug, Clone)]
struct Indexes {
    triangles: Option<GridIndex>,
    edges: Option<GridIndex>,
}

/// Everything known about a simulated scan. See the module comment.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct GroundTruth {
    /// Identifies the JSON layout.
    pub format: String,
    /// Part name: box, lblock, step, wedge, prism, pyramid, sphere, random, or the mesh file's
    /// name.
    pub part: String,
    pub params: SynthParams,
    /// Sampling pitch actually used (model units = world units).
    pub spacing: f64,
    /// Fillet radius actually used (model units).
    pub round_radius: f64,
    pub points: usize,
    pub abnormal_points: usize,
    pub outlier_points: usize,
    /// world = rotation · model + translation (rotation rows).
    pub rotation: [V3; 3],
    pub translation: V3,
    /// For meshes read from a file: model = (file − model_centre) · model_scale.
    pub model_centre: V3,
    pub model_scale: f64,
    pub edges: Vec<TruthEdge>,
    pub corners: Vec<TruthCorner>,
    pub polylines: Vec<TruthPolyline>,
    pub faces: Vec<TruthFace>,
    pub surface: TruthSurface,
    pub mesh_stats: MeshStats,
    /// The sensors of the scan (absent for patterns without any).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub sensors: Vec<TruthSensor>,
    /// The cut planes of a line scan.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub lines: Option<TruthLines>,
    /// The density gradient.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub density: Option<TruthDensity>,
    /// Wide fillets (random parts): smooth, not sharp edges.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub fillets: Vec<TruthFillet>,
    /// What the random part's generator drew (random parts only).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub random: Option<super::random::RandomDraw>,
    #[serde(skip)]
    index: OnceLock<Indexes>,
}

pub const FORMAT: &str = "sharpedge-synth-truth/1";

impl PartialEq for GroundTruth {
    fn eq(&self, o: &Self) -> bool {
        // The search index is a cache derived from the rest.
        (
            &self.format,
            &self.part,
            &self.params,
            self.spacing,
            self.round_radius,
            self.points,
            self.abnormal_points,
            self.outlier_points,
            &self.rotation,
            &self.translation,
            &self.model_centre,
            self.model_scale,
        ) == (
            &o.format,
            &o.part,
            &o.params,
            o.spacing,
            o.round_radius,
            o.points,
            o.abnormal_points,
            o.outlier_points,
            &o.rotation,
            &o.translation,
            &o.model_centre,
            o.model_scale,
        ) && self.edges == o.edges
            && self.corners == o.corners
            && self.polylines == o.polylines
            && self.faces == o.faces
            && self.surface == o.surface
            && self.mesh_stats == o.mesh_stats
            && self.sensors == o.sensors
            && self.lines == o.lines
            && self.density == o.density
            && self.fillets == o.fillets
            && self.random == o.random
    }
}

fn bbox_of(pts: &[V3]) -> (V3, V3) {
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    for p in pts {
        for k in 0..3 {
            lo[k] = lo[k].min(p[k]);
            hi[k] = hi[k].max(p[k]);
        }
    }
    (lo, hi)
}

impl GroundTruth {
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn new(
        part: String,
        params: SynthParams,
        spacing: f64,
        round_radius: f64,
        rotation: [V3; 3],
        translation: V3,
        model_centre: V3,
        model_scale: f64,
        edges: Vec<TruthEdge>,
        corners: Vec<TruthCorner>,
        polylines: Vec<TruthPolyline>,
        faces: Vec<TruthFace>,
        surface: TruthSurface,
        mesh_stats: MeshStats,
    ) -> Self {
        GroundTruth {
            format: FORMAT.to_owned(),
            part,
            params,
            spacing,
            round_radius,
            points: 0,
            abnormal_points: 0,
            outlier_points: 0,
            rotation,
            translation,
            model_centre,
            model_scale,
            edges,
            corners,
            polylines,
            faces,
            surface,
            mesh_stats,
            sensors: Vec::new(),
            lines: None,
            density: None,
            fillets: Vec::new(),
            random: None,
            index: OnceLock::new(),
        }
    }

    /// Pretty JSON (points and triangles one a line).
    pub fn to_json(&self) -> Result<String> {
        crate::json::pretty(self).map_err(|e| Error::Degenerate {
            what: "ground-truth JSON",
            why: e.to_string(),
        })
    }

    /// Reads the JSON written by [`GroundTruth::to_json`].
    pub fn from_json(text: &str) -> Result<Self> {
        Self::parse(text, std::path::Path::new("<ground-truth JSON>"))
    }

    /// Reads a ground-truth JSON file.
    pub fn read(path: &std::path::Path) -> Result<Self> {
        let text = std::fs::read_to_string(path).map_err(|e| Error::io(path, "cannot read", e))?;
        Self::parse(&text, path)
    }

    /// Parses and checks the JSON; `origin` names the source in errors.
    fn parse(text: &str, origin: &std::path::Path) -> Result<Self> {
        let gt: GroundTruth = serde_json::from_str(text).map_err(|e| {
            Error::malformed(
                origin,
                format!("line {}, column {}", e.line(), e.column()),
                format!("not a sharpedge ground truth: {e}"),
            )
        })?;
        if gt.format != FORMAT {
            return Err(Error::malformed(
                origin,
                "format",
                format!(
                    "ground-truth format {:?} is not {FORMAT:?}; regenerate it with this version",
                    gt.format
                ),
            ));
        }
        if let TruthSurface::Mesh {
            vertices,
            triangles,
        } = &gt.surface
        {
            let n = vertices.len() as u64;
            if let Some(i) = triangles
                .iter()
                .position(|t| t.iter().any(|&v| v as u64 >= n))
            {
                return Err(Error::malformed(
                    origin,
                    format!("surface.triangles[{i}]"),
                    format!("vertex index out of range ({n} vertices)"),
                ));
            }
        }
        if let Some(e) = gt
            .corners
            .iter()
            .flat_map(|c| &c.edges)
            .find(|&&e| e >= gt.edges.len())
        {
            return Err(Error::malformed(
                origin,
                "corners",
                format!("edge id {e} out of range ({} edges)", gt.edges.len()),
            ));
        }
        Ok(gt)
    }

    fn indexes(&self) -> &Indexes {
        self.index.get_or_init(|| {
            let triangles = match &self.surface {
                TruthSurface::Mesh {
                    vertices,
                    triangles,
                } if triangles.len() > BRUTE_FORCE_LIMIT => {
                    let boxes: Vec<(V3, V3)> = triangles
                        .iter()
                        .map(|t| bbox_of(&t.map(|i| vertices[i as usize])))
                        .collect();
                    Some(GridIndex::build(&boxes, 4.0))
                }
                _ => None,
            };
            let edges = (self.edges.len() > BRUTE_FORCE_LIMIT).then(|| {
                let boxes: Vec<(V3, V3)> = self
                    .edges
                    .iter()
                    .map(|e| bbox_of(&[e.start, e.end]))
                    .collect();
                GridIndex::build(&boxes, 2.0)
            });
            Indexes { triangles, edges }
        })
    }

    /// The closest point of the true (sharp) surface to `p`.
    pub fn closest_surface_point(&self, p: V3) -> V3 {
        match &self.surface {
            TruthSurface::Sphere { centre, radius } => {
                let d = sub(p, *centre);
                let n = norm(d);
                if n > 0.0 {
                    [0, 1, 2].map(|k| centre[k] + d[k] * radius / n)
                } else {
                    [centre[0] + radius, centre[1], centre[2]] // every point is closest
                }
            }
            TruthSurface::Mesh {
                vertices,
                triangles,
            } => {
                let close = |i: usize| {
                    let [a, b, c] = triangles[i].map(|v| vertices[v as usize]);
                    closest_on_triangle(p, a, b, c)
                };
                let best = match &self.indexes().triangles {
                    Some(g) => g.nearest(p, |i| dist(p, close(i))).map(|(_, i)| i),
                    None => (0..triangles.len())
                        .map(|i| (dist(p, close(i)), i))
                        .min_by(|a, b| a.0.total_cmp(&b.0))
                        .map(|(_, i)| i),
                };
                best.map_or(p, close)
            }
        }
    }

    /// Distance from `p` to the true (sharp, noise-free) surface.
    pub fn distance_to_surface(&self, p: V3) -> f64 {
        dist(p, self.closest_surface_point(p))
    }

    /// Distance from `p` to the nearest sharp edge segment and that edge's id; `None` for a
    /// part without sharp edges (the sphere).
    pub fn distance_to_nearest_edge(&self, p: V3) -> Option<(f64, usize)> {
        let d = |i: usize| point_segment(p, self.edges[i].start, self.edges[i].end).0;
        match &self.indexes().edges {
            Some(g) => g.nearest(p, d),
            None => (0..self.edges.len())
                .map(|i| (d(i), i))
                .min_by(|a, b| a.0.total_cmp(&b.0)),
        }
    }

    /// Distance from `p` to the nearest corner and that corner's id; `None` without corners.
    pub fn nearest_corner(&self, p: V3) -> Option<(f64, usize)> {
        self.corners
            .iter()
            .map(|c| (dist(p, c.position), c.id))
            .min_by(|a, b| a.0.total_cmp(&b.0))
    }

    /// Total length of the sharp edges.
    pub fn edge_length(&self) -> f64 {
        self.edges.iter().map(|e| e.length).sum()
    }
}
