//! The scan simulator: point clouds of parts with known sharp edges and corners.
//!
//! Input: [`SynthParams`] — a part (parametric shape, sphere, or a triangle mesh file), its
//! size, the sampling (point count or spacing) and its pattern ([`ScanPattern`]: uniform, scan
//! lines, structured-light grid, one or several views, density gradient, incidence noise), the
//! scan's disturbances (noise, edge rounding, extra noise near edges, outliers), a rigid
//! placement (random rotation, translation) and a seed. Output: a [`Scan`] — the [`Cloud`] of simulated scanner points, a [`PointTruth`] per
//! point (its noise-free place on the sharp part, its distance to the nearest sharp edge,
//! whether it lies in the abnormal zone or is an outlier), and the [`GroundTruth`] of the part
//! (edges, corners, faces, exact surface, transform; the sensors, cut planes and density
//! gradient of patterned scans) that serialises to JSON and answers exact distance queries
//! for the benchmark.
//!
//! How a point is made (details in the submodules; `scan_mesh` runs these steps by name):
//! 1. The part is a closed triangle mesh in model coordinates (the sphere is analytic), scaled
//!    to `size` and centred on the origin. Sharp edges, corners and planar charts come from
//!    [`features`]; for parametric parts every non-coplanar mesh edge is sharp, for meshes
//!    from files those whose normals differ by more than `sharp_angle`. A random part
//!    ([`random`], drawn from the seed) brings its own sharp edges: every non-coplanar edge
//!    but the facets of its wide fillets, which are sampled like curved patches and appear in
//!    the ground truth as [`TruthFillet`]s, not as edges.
//! 2. Each chart is sampled on a jittered square grid of pitch `h` (module `sample`), like the
//!    regular raster of a structured-light or laser scanner. The mean nearest-neighbour
//!    distance is [`NN_RATIO`]` · h` = 0.955 h with the default jitter 0.1 (measured on a
//!    1M-point box: 0.953; 200k: 0.951; 5k, where the edges weigh more: 0.928; a sphere
//!    0.93–0.94). On meshes whose planar charts are only a few spacings wide the independent
//!    grids of neighbouring charts bring points closer (fandisk: 0.77 at 5k points, 0.91 at
//!    200k, 0.935 at 1M). Given a point count `N`, `h = sqrt(area / N)`.
//!    Other patterns (module [`scanner`] documents each; `patterns` and [`raycast`] make them)
//!    replace this grid: scan lines (planes cut the triangles, points every `h` along each
//!    cut), a structured-light pixel grid from sensors (first hits of rays, so occlusion is
//!    real), the grid kept where a sensor sees it (one or several views, each misregistered a
//!    little), thinned by a smooth density gradient; `h` then follows from the points the
//!    pattern lays per h² of each triangle, so `N` is still about the total.
//! 3. Samples within the tangent distance of a sharp edge move onto a fillet of radius
//!    `round · h` (their closest point on the rounded part, [`fillet`]); samples within
//!    `edge_band · h` of an edge get extra Gaussian noise `edge_noise · h`. Both make the
//!    "abnormal zone" of the paper's Figure 1. Every point gets Gaussian noise `noise · h`
//!    (along the sensor's ray for sensor patterns; growing as 1 / cos of the incidence angle
//!    with `incidence_noise`); a misregistered view then moves its points rigidly.
//! 4. A fraction `outliers` of the points is replaced by uniform points in the part's world
//!    bounding box enlarged by 5 % per side.
//! 5. world = R · model + T, R uniform on SO(3) from the seed when `rotate` is set.
//!
//! Determinism: every random draw comes from an RNG seeded by (seed, chart, tile) — (seed,
//! chart, plane block) for scan lines, (seed, view, pixel tile) for sensor grids — or a hash
//! of (seed, chart, grid node / line sample / pixel), never from shared state, so the output
//! is identical for any number of rayon threads. Memory: two passes over the tiles (count, then fill into
//! preallocated arrays); nothing is allocated per point.

pub mod features;
pub mod fillet;
pub mod geom;
pub mod index;
pub mod parts;
mod patterns;
pub mod random;
pub mod raycast;
mod sample;
pub mod scanner;
pub mod subdivide;
pub mod truth;

use std::path::PathBuf;

use serde::{Deserialize, Serialize};

use crate::cloud::{Attribute, Cloud, Column, Source};
use crate::error::{Error, Result};
use crate::geometry::{self, V3, add, dist, mat_vec};
use crate::io::mesh::{Mesh, read_mesh};
use features::{FeatureOptions, Model, analyse, analyse_marked, analyse_with};
use geom::{derive, random_rotation};
pub use parts::Part;
pub use scanner::{Pattern, ScanPattern};
pub use truth::{
    GroundTruth, TruthCorner, TruthDensity, TruthEdge, TruthFace, TruthFillet, TruthLines,
    TruthPolyline, TruthSensor, TruthSurface,
};

/// Mean nearest-neighbour distance over the spacing `h` with the default jitter (0.1), on
/// planar faces large compared with `h` (measured; `tests/synth_sampling.rs` checks it).
pub const NN_RATIO: f64 = 0.955;

/// Upper limit on the number of generated points (about 7 GB of output).
pub const MAX_POINTS: usize = 100_000_000;

/// How densely to sample.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Sampling {
    /// About this many points (the grid pitch is derived from the surface area).
    Points(usize),
    /// This grid pitch, in model units.
    Spacing(f64),
}

/// Everything that defines a simulated scan. Lengths that describe the scan's disturbances are
/// in multiples of the spacing `h`, so the same settings mean the same thing at any density.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SynthParams {
    pub part: Part,
    /// Largest extent of the part in model units. `None`: 100 for parametric parts, the
    /// file's own units for meshes.
    pub size: Option<f64>,
    pub sampling: Sampling,
    /// Gaussian noise sigma (per axis), in spacings.
    pub noise: f64,
    /// Fillet radius of every sharp edge, in spacings (0: sharp).
    pub round: f64,
    /// Extra Gaussian noise sigma near sharp edges, in spacings.
    pub edge_noise: f64,
    /// Width of the band around sharp edges that gets `edge_noise`, in spacings.
    pub edge_band: f64,
    /// Fraction of points replaced by uniform outliers, in [0, 1).
    pub outliers: f64,
    /// Rotate the part by a uniformly random rotation drawn from the seed.
    pub rotate: bool,
    /// Translation added after the rotation (world = R · model + translate).
    pub translate: V3,
    pub seed: u64,
    /// Ask for double-precision output even when float would do.
    pub double: bool,
    /// Sides of the prism (>= 3).
    pub sides: usize,
    /// Dihedral angle of the wedge's sharp edge in degrees, in (0, 180).
    pub angle: f64,
    /// Number of steps of the stepped block (>= 2).
    pub steps: usize,
    /// For meshes: an edge is sharp when its face normals differ by more than this (degrees).
    pub sharp_angle: f64,
    /// For meshes with curved regions: levels of Loop subdivision (sharp edges kept as
    /// creases) before sampling, so a faceted curved patch is scanned as the smooth surface it
    /// stands for; 0 samples the facets as they are. At most 4.
    pub subdivide: u32,
    /// Grid jitter, full width per axis, in spacings, in [0, 1].
    pub jitter: f64,
    /// The sampling pattern (scanner.rs); left out of the JSON when it is the plain uniform
    /// scan, so truth files of uniform scans are unchanged.
    #[serde(skip_serializing_if = "ScanPattern::is_default")]
    pub scan: ScanPattern,
}

impl Default for SynthParams {
    fn default() -> Self {
        SynthParams {
            part: Part::Box,
            size: None,
            sampling: Sampling::Points(100_000),
            noise: 0.0,
            round: 0.0,
            edge_noise: 0.0,
            edge_band: 3.0,
            outliers: 0.0,
            rotate: false,
            translate: [0.0; 3],
            seed: 1,
            double: false,
            sides: 6,
            angle: 30.0,
            steps: 3,
            sharp_angle: 30.0,
            subdivide: 2,
            jitter: 0.1,
            scan: ScanPattern::default(),
        }
    }
}

/// What is known about one simulated point.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PointTruth {
    /// The sample's noise-free position on the sharp (unrounded) part, world coordinates.
    /// For an outlier: where the point was before it was replaced.
    pub surface: V3,
    /// Distance from `surface` to the nearest sharp edge segment (infinite without edges).
    pub edge_distance: f64,
    /// That edge's id (`u32::MAX` without edges).
    pub nearest_edge: u32,
    /// Id of the face (chart) it was sampled on (`u32::MAX` for the sphere).
    pub face: u32,
    /// Moved by the rounding or inside the extra-noise band (never set for outliers).
    pub abnormal: bool,
    pub outlier: bool,
    /// The view (sensor, `GroundTruth::sensors`) that saw it; `u32::MAX` for patterns
    /// without views (uniform, lines), which cover the whole surface.
    pub view: u32,
    /// The noise sigma this sample was given (model units; 0 for an outlier): the scan's,
    /// with the edge band's added inside it and grown as 1 / cos of the incidence angle
    /// under incidence noise (a face seen at grazing incidence gets up to `incidence_cap`
    /// times the scan's). Along the sensor's ray for sensor patterns, in every direction
    /// otherwise.
    pub noise: f64,
}

/// A simulated scan: the cloud, per-point truth (same order) and the part's ground truth.
#[derive(Debug, Clone)]
pub struct Scan {
    pub cloud: Cloud,
    pub truth: Vec<PointTruth>,
    pub ground_truth: GroundTruth,
}

impl Scan {
    /// Per-point truth as cloud attributes for inspection in CloudCompare/MeshLab:
    /// `scalar_abnormal`, `scalar_outlier` (0/1), `scalar_edge_distance` (f32, model units,
    /// -1 without edges), and `scalar_view` (u8) for scans with views. Not added to the cloud
    /// by [`generate`].
    pub fn truth_attributes(&self) -> Vec<Attribute> {
        let mut attrs = vec![
            Attribute {
                name: "scalar_abnormal".into(),
                values: Column::U8(self.truth.iter().map(|t| t.abnormal as u8).collect()),
            },
            Attribute {
                name: "scalar_outlier".into(),
                values: Column::U8(self.truth.iter().map(|t| t.outlier as u8).collect()),
            },
            Attribute {
                name: "scalar_edge_distance".into(),
                values: Column::F32(
                    self.truth
                        .iter()
                        .map(|t| {
                            if t.edge_distance.is_finite() {
                                t.edge_distance as f32
                            } else {
                                -1.0
                            }
                        })
                        .collect(),
                ),
            },
        ];
        if self.truth.iter().any(|t| t.view != u32::MAX) {
            attrs.push(Attribute {
                name: "scalar_view".into(),
                values: Column::U8(self.truth.iter().map(|t| t.view.min(255) as u8).collect()),
            });
        }
        attrs
    }
}

pub(crate) fn bad(
    name: &'static str,
    value: impl std::fmt::Display,
    allowed: impl Into<String>,
) -> Error {
    Error::SynthParam {
        name,
        value: value.to_string(),
        allowed: allowed.into(),
    }
}

/// Checks every parameter; the error names the parameter and the allowed range.
pub fn validate(p: &SynthParams) -> Result<()> {
    let nonneg = |name, v: f64, unit: &str| {
        if v.is_finite() && v >= 0.0 {
            Ok(())
        } else {
            Err(bad(
                name,
                v,
                format!("must be a finite number >= 0 ({unit})"),
            ))
        }
    };
    if let Some(size) = p.size
        && !(size.is_finite() && size > 0.0)
    {
        return Err(bad(
            "size",
            size,
            "must be a finite number > 0 (model units)",
        ));
    }
    match p.sampling {
        Sampling::Points(0) => return Err(bad("points", 0, "must be at least 1")),
        Sampling::Points(n) if n > MAX_POINTS => {
            return Err(bad("points", n, format!("must be at most {MAX_POINTS}")));
        }
        Sampling::Spacing(h) if !(h.is_finite() && h > 0.0) => {
            return Err(bad(
                "spacing",
                h,
                "must be a finite number > 0 (model units)",
            ));
        }
        _ => {}
    }
    nonneg("noise", p.noise, "in spacings")?;
    nonneg("round", p.round, "in spacings")?;
    nonneg("edge_noise", p.edge_noise, "in spacings")?;
    if !(p.edge_band.is_finite() && p.edge_band > 0.0) {
        return Err(bad(
            "edge_band",
            p.edge_band,
            "must be a finite number > 0 (in spacings)",
        ));
    }
    if !(p.outliers.is_finite() && (0.0..1.0).contains(&p.outliers)) {
        return Err(bad("outliers", p.outliers, "must be a fraction in [0, 1)"));
    }
    if p.translate.iter().any(|c| !c.is_finite()) {
        return Err(bad(
            "translate",
            format!("{:?}", p.translate),
            "every component must be a finite number",
        ));
    }
    if !(p.jitter.is_finite() && (0.0..=1.0).contains(&p.jitter)) {
        return Err(bad("jitter", p.jitter, "must be in [0, 1] (in spacings)"));
    }
    p.scan.validate()?;
    if p.subdivide > 4 {
        return Err(bad(
            "subdivide",
            p.subdivide,
            "must be at most 4 (each level makes four triangles of one)",
        ));
    }
    match &p.part {
        Part::Prism if !(3..=100_000).contains(&p.sides) => {
            return Err(bad("sides", p.sides, "a prism needs 3 to 100000 sides"));
        }
        Part::Wedge if !(p.angle.is_finite() && p.angle > 0.0 && p.angle < 180.0) => {
            return Err(bad(
                "angle",
                p.angle,
                "the wedge angle must be in (0, 180) degrees",
            ));
        }
        Part::Step if !(2..=1000).contains(&p.steps) => {
            return Err(bad(
                "steps",
                p.steps,
                "a stepped block needs 2 to 1000 steps",
            ));
        }
        Part::Mesh(_)
            if !(p.sharp_angle.is_finite() && p.sharp_angle > 0.0 && p.sharp_angle < 180.0) =>
        {
            return Err(bad(
                "sharp_angle",
                p.sharp_angle,
                "must be in (0, 180) degrees",
            ));
        }
        _ => {}
    }
    Ok(())
}

/// Simulates a scan of `params.part`. Reads the mesh file for [`Part::Mesh`].
pub fn generate(params: &SynthParams) -> Result<Scan> {
    validate(params)?;
    match &params.part {
        Part::Mesh(path) => {
            let mesh = read_mesh(path)?;
            // A mesh that reads but cannot be scanned (no area, ...) is named like a bad file.
            scan_mesh(params, mesh, Origin::File).map_err(|e| match e {
                Error::Degenerate { .. } => Error::BadCloud {
                    path: path.clone(),
                    what: e.to_string(),
                },
                e => e,
            })
        }
        Part::Sphere if !params.scan.is_default() => Err(bad(
            "pattern",
            params.scan.pattern.name(),
            "the sphere is sampled by its own uniform lattice only; scan a sphere mesh with --mesh for other patterns",
        )),
        Part::Sphere => scan_sphere(params),
        Part::Random => {
            let part = random::build(params.seed)?;
            scan_mesh(params, part.mesh.clone(), Origin::Random(&part))
        }
        part => {
            let mesh = parts::polyhedron(part, params.sides, params.angle, params.steps)
                .ok_or_else(|| bad("part", part.name(), "not a polyhedral part"))?;
            scan_mesh(params, mesh, Origin::Parametric)
        }
    }
}

/// Simulates a scan of a mesh already in memory (treated like a mesh file: `sharp_angle`
/// decides which edges are sharp; `size`, if set, rescales it).
pub fn generate_from_mesh(params: &SynthParams, mesh: Mesh) -> Result<Scan> {
    let mut p = params.clone();
    if !matches!(p.part, Part::Mesh(_)) {
        p.part = Part::Mesh(PathBuf::from("mesh"));
    }
    validate(&p)?;
    if mesh.triangles.is_empty() {
        return Err(Error::Degenerate {
            what: "synth mesh",
            why: "the mesh has no triangles".into(),
        });
    }
    let n = mesh.vertices.len();
    if mesh.triangles.iter().flatten().any(|&i| i as usize >= n) {
        return Err(Error::Degenerate {
            what: "synth mesh",
            why: "a triangle refers to a vertex that does not exist".into(),
        });
    }
    if mesh.vertices.iter().flatten().any(|c| !c.is_finite()) {
        return Err(Error::Degenerate {
            what: "synth mesh",
            why: "a vertex has a non-finite coordinate".into(),
        });
    }
    scan_mesh(&p, mesh, Origin::File)
}

/// Where a mesh to scan comes from: it decides the size and which edges are sharp.
#[derive(Clone, Copy)]
enum Origin<'a> {
    /// A parametric part: every non-coplanar edge is sharp.
    Parametric,
    /// A mesh file: `sharp_angle` decides, curved patches may be subdivided.
    File,
    /// A random part: its own sharp edges, fillets and chart borders.
    Random(&'a random::RandomPart),
}

const TAG_ROTATION: u64 = 0x0207_0A7E;
const IDENTITY: [V3; 3] = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];

fn rotation(p: &SynthParams) -> [V3; 3] {
    if p.rotate {
        use rand::SeedableRng;
        let mut rng = rand::rngs::SmallRng::seed_from_u64(derive(p.seed, &[TAG_ROTATION]));
        random_rotation(&mut rng)
    } else {
        IDENTITY
    }
}

/// Outlier box (world bounding box enlarged by 5 % per side) and whether coordinates of this
/// magnitude need double precision to stay well below the spacing.
fn outlier_box_and_precision(world_pts: &[V3], h: f64, want_double: bool) -> (V3, V3, bool) {
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    for p in world_pts {
        for k in 0..3 {
            lo[k] = lo[k].min(p[k]);
            hi[k] = hi[k].max(p[k]);
        }
    }
    let diag = dist(lo, hi);
    for k in 0..3 {
        let pad = 0.05 * (hi[k] - lo[k]).max(0.01 * diag);
        lo[k] -= pad;
        hi[k] += pad;
    }
    let magnitude = (0..3)
        .map(|k| lo[k].abs().max(hi[k].abs()))
        .fold(0.0, f64::max);
    // Half an f32 step (2^-24 relative) must stay below 1/1000 of the spacing.
    let double = want_double || magnitude * 2f64.powi(-24) > 1e-3 * h;
    (lo, hi, double)
}

fn too_many(p: &SynthParams, expected: f64) -> Error {
    match p.sampling {
        Sampling::Spacing(h) => bad(
            "spacing",
            h,
            format!(
                "would give about {expected:.3e} points, more than {MAX_POINTS}; use a larger spacing"
            ),
        ),
        Sampling::Points(n) => bad("points", n, format!("must be at most {MAX_POINTS}")),
    }
}

/// Whether two neighbouring triangles that are not split by a sharp edge meet at an angle:
/// the mesh approximates a curved surface with facets.
fn curved(model: &Model, flat: f64) -> bool {
    model.edge_tris.iter().any(|(key, t)| {
        if model.sharp_index.contains_key(key) {
            return false;
        }
        let (a, b) = (
            model.tri_normals[t[0] as usize],
            model.tri_normals[t[1] as usize],
        );
        // Winding may be inconsistent: compare the lines of the normals.
        let c = (a[0] * b[0] + a[1] * b[1] + a[2] * b[2]).abs();
        a != [0.0; 3] && b != [0.0; 3] && c < flat.cos()
    })
}

/// The part as the sampler needs it: analysed, scaled and centred (model coordinates).
struct Prepared {
    model: Model,
    model_centre: V3,
    model_scale: f64,
    /// Largest extent of the bounding box.
    extent: f64,
    /// Radius of the bounding sphere about the origin (the part's centre).
    radius: f64,
}

/// Scales and centres the mesh, finds its sharp edges, corners and charts, and smooths
/// faceted curved patches by subdivision when asked to.
fn prepare_part(p: &SynthParams, mut mesh: Mesh, origin: Origin) -> Result<Prepared> {
    let parametric = !matches!(origin, Origin::File);
    let size = if parametric {
        Some(p.size.unwrap_or(100.0))
    } else {
        p.size
    };
    let (model_centre, model_scale) = parts::normalise(&mut mesh, size);
    let extent = mesh
        .bbox()
        .map(|(lo, hi)| (0..3).map(|k| hi[k] - lo[k]).fold(0.0, f64::max))
        .unwrap_or(0.0);
    let opts = if parametric {
        FeatureOptions {
            sharp_angle: 1e-6,
            corner_angle: 30f64.to_radians(),
            // cos(1e-7) is still below 1 in f64, unlike cos(1e-9).
            chart_angle: 1e-7,
            chart_distance: 1e-9 * extent,
        }
    } else {
        FeatureOptions {
            sharp_angle: p.sharp_angle.to_radians(),
            corner_angle: p.sharp_angle.to_radians(),
            chart_angle: 0.01,
            chart_distance: 1e-4 * extent,
        }
    };
    let mut model = match origin {
        // A fillet's facets are sampled like a curved mesh's patches (one grid per 15°); its
        // tangent lines end the flat faces' charts, so those stay exact planes.
        Origin::Random(part) => analyse_marked(
            mesh,
            &FeatureOptions {
                chart_angle: 15f64.to_radians(),
                chart_distance: f64::INFINITY,
                ..opts
            },
            Some(&part.creases),
            Some(&part.breaks),
        ),
        _ => analyse(mesh, &opts),
    };
    if !parametric && p.subdivide > 0 && curved(&model, opts.chart_angle) {
        let creases: std::collections::HashSet<(u32, u32)> =
            model.sharp_index.keys().copied().collect();
        let corners: std::collections::HashSet<u32> =
            model.corners.iter().map(|c| c.vertex).collect();
        let (mesh, creases) =
            subdivide::loop_subdivide(&model.mesh, &creases, &corners, p.subdivide);
        // A curved patch is sampled with one grid in its seed's plane, like a height field:
        // within 15° the sampled density stays within 4 % of a flat face's (cos 15°), and the
        // patch cannot fold over in projection.
        let curved_opts = FeatureOptions {
            chart_angle: 15f64.to_radians(),
            chart_distance: f64::INFINITY,
            ..opts
        };
        model = analyse_with(mesh, &curved_opts, Some(&creases));
    }
    let area = model.mesh.area();
    if !(area > 0.0 && area.is_finite()) {
        return Err(Error::Degenerate {
            what: "synth mesh",
            why: format!("surface area is {area}; nothing to sample"),
        });
    }
    let radius = model
        .mesh
        .vertices
        .iter()
        .map(|v| geometry::norm(*v))
        .fold(0.0, f64::max);
    Ok(Prepared {
        model,
        model_centre,
        model_scale,
        extent,
        radius,
    })
}

/// The spacing `h`: given, or the pitch at which the pattern lays about the requested number
/// of points (scanner.rs: the pattern's points per h² of each triangle, times the density
/// gradient's mean keep). Fails when the scan would exceed [`MAX_POINTS`].
fn spacing(p: &SynthParams, model: &Model, lay: &scanner::Layout) -> Result<f64> {
    let plain = p.scan.pattern == Pattern::Uniform && lay.density.is_none();
    // Area weighted by the points the pattern puts there, per h².
    let weighted = if plain {
        model.mesh.area()
    } else {
        (0..model.mesh.triangles.len())
            .map(|t| {
                let [a, b, c] = model.mesh.triangles[t].map(|i| model.mesh.vertices[i as usize]);
                let area =
                    0.5 * geometry::norm(geometry::cross(geometry::sub(b, a), geometry::sub(c, a)));
                let keep = lay.density.map_or(1.0, |d| d.mean_keep(a, b, c));
                area * keep * scanner::pitch_weight(model, lay, &p.scan, t)
            })
            .sum()
    };
    if !(weighted > 0.0 && weighted.is_finite()) {
        return Err(Error::Degenerate {
            what: "synth scan",
            why: format!(
                "the {} pattern puts no points on this part (no face is cut or seen)",
                p.scan.pattern.name()
            ),
        });
    }
    let h = match p.sampling {
        Sampling::Spacing(h) => h,
        Sampling::Points(n) => (weighted / n as f64).sqrt(),
    };
    let expected = weighted / (h * h);
    if expected > MAX_POINTS as f64 {
        return Err(too_many(p, expected));
    }
    Ok(h)
}

/// The fillets of radius `round · h`; a radius the part cannot take is a parameter error.
fn round_edges(p: &SynthParams, model: &Model, h: f64) -> Result<fillet::Fillets> {
    fillet::build(model, p.round * h).map_err(|max_r| {
        bad(
            "round",
            p.round,
            format!(
                "at most {:.4} spacings for this part: a larger radius makes the corner blends of its shortest edge overlap",
                max_r / h
            ),
        )
    })
}

/// Counts the pattern's points, allocates the outputs once and fills them.
fn run_source<S: sample::Source>(
    p: &SynthParams,
    src: &S,
    keep: &sample::Keep,
    fillets: &fillet::Fillets,
    settings: &sample::Settings,
    mut work: Vec<sample::Work<S::Unit>>,
) -> Result<(Vec<V3>, Vec<PointTruth>)> {
    sample::count(src, keep, &mut work);
    let total: usize = work.iter().map(|w| w.count).sum();
    if total > MAX_POINTS {
        return Err(too_many(p, total as f64));
    }
    let mut positions = vec![[0.0; 3]; total];
    let mut truth = vec![
        PointTruth {
            surface: [0.0; 3],
            edge_distance: 0.0,
            nearest_edge: 0,
            face: 0,
            abnormal: false,
            outlier: false,
            view: u32::MAX,
            noise: 0.0,
        };
        total
    ];
    sample::fill(
        src,
        keep,
        fillets,
        settings,
        &work,
        &mut positions,
        &mut truth,
    );
    Ok((positions, truth))
}

/// Samples the model with the scanner's pattern: points (world) and their truth.
fn sample_pattern(
    p: &SynthParams,
    part: &Prepared,
    fillets: &fillet::Fillets,
    s: &sample::Settings,
) -> Result<(Vec<V3>, Vec<PointTruth>)> {
    let (model, extent, radius) = (&part.model, part.extent, part.radius);
    let sc = &s.scanner;
    let needs_rays = matches!(sc.pattern, Pattern::Grid | Pattern::View);
    let caster = needs_rays.then(|| raycast::Caster::new(&model.mesh));
    let keep = sample::Keep {
        density: sc.density.as_ref(),
        sight: match (&caster, sc.pattern) {
            (Some(c), Pattern::View) => Some((c, 1e-7 * extent.max(s.h))),
            _ => None,
        },
        model,
        scanner: sc,
    };
    match (sc.pattern, &caster, sc.lines) {
        (Pattern::Lines, _, Some(lines)) => {
            let src = patterns::LineScan {
                model,
                lines,
                h: s.h,
                jitter: s.jitter,
                seed: s.seed,
            };
            let work = src.units();
            run_source(p, &src, &keep, fillets, s, work)
        }
        (Pattern::Grid, Some(caster), _) => {
            let cams: Vec<(scanner::Camera, &scanner::View)> = sc
                .views
                .iter()
                .map(|v| (scanner::Camera::new(v.sensor, v.seed), v))
                .collect();
            let half_width: Vec<f64> = cams
                .iter()
                .map(|(c, _)| {
                    // The bounding sphere's silhouette on the plane at the centre's distance.
                    radius * c.dist / (c.dist * c.dist - radius * radius).max(1e-300).sqrt()
                })
                .collect();
            let src = patterns::GridScan {
                caster,
                cams,
                half_width,
                jitter: s.jitter,
            };
            // Rays that miss cost time but no points; bound them too.
            if src.rays() > 4.0 * MAX_POINTS as f64 {
                return Err(too_many(p, src.rays()));
            }
            let work = src.units();
            run_source(p, &src, &keep, fillets, s, work)
        }
        _ => {
            let views = sc.pattern == Pattern::View;
            let src = sample::Uniform {
                model,
                jitter: s.jitter,
                grids: if views {
                    sc.views.iter().map(|v| (v.pitch, v.seed)).collect()
                } else {
                    vec![(s.h, s.seed)]
                },
                views,
            };
            let work = src.tiles();
            run_source(p, &src, &keep, fillets, s, work)
        }
    }
}

/// The ground truth in world coordinates: edges, corners, polylines, faces, the surface, and
/// the scanner's sensors, cut planes and density gradient when the pattern has them.
#[allow(clippy::too_many_arguments)]
fn ground_truth(
    p: &SynthParams,
    part: &Prepared,
    fillets: &fillet::Fillets,
    s: &sample::Settings,
    world_vertices: Vec<V3>,
) -> GroundTruth {
    let model = &part.model;
    let rot = s.rotation;
    let world = |q: V3| s.world(q);
    let mut edge_polyline = vec![0usize; model.edges.len()];
    let polylines: Vec<TruthPolyline> = model
        .polylines
        .iter()
        .enumerate()
        .map(|(id, pl)| {
            for &e in &pl.edges {
                edge_polyline[e] = id;
            }
            TruthPolyline {
                id,
                edges: pl.edges.clone(),
                closed: pl.closed,
                length: pl.edges.iter().map(|&e| model.edges[e].length()).sum(),
            }
        })
        .collect();
    let edges: Vec<TruthEdge> = model
        .edges
        .iter()
        .enumerate()
        .map(|(id, e)| TruthEdge {
            id,
            start: world(e.a),
            end: world(e.b),
            length: e.length(),
            convex: e.convex,
            dihedral_deg: e.dihedral_deg(),
            faces: e.tris.map(|t| model.tri_chart[t as usize] as usize),
            normals: e.normals.map(|n| mat_vec(&rot, n)),
            tangent_distance: fillets.edges[id].td,
            polyline: edge_polyline[id],
        })
        .collect();
    let corners: Vec<TruthCorner> = model
        .corners
        .iter()
        .enumerate()
        .map(|(id, c)| TruthCorner {
            id,
            position: world(c.position),
            edges: c.edges.clone(),
            ball_blend: fillets.ball_vertices.contains(&c.vertex),
        })
        .collect();
    let faces: Vec<TruthFace> = model
        .charts
        .iter()
        .enumerate()
        .map(|(id, c)| TruthFace {
            id,
            normal: mat_vec(&rot, c.normal),
            point: world(c.origin),
            area: c.area,
            triangles: c.tris.len(),
        })
        .collect();
    let mut gt = GroundTruth::new(
        p.part.name(),
        p.clone(),
        s.h,
        fillets.r,
        rot,
        p.translate,
        part.model_centre,
        part.model_scale,
        edges,
        corners,
        polylines,
        faces,
        TruthSurface::Mesh {
            vertices: world_vertices,
            triangles: model.mesh.triangles.clone(),
        },
        model.stats.clone(),
    );
    scanner_truth(&mut gt, s);
    gt
}

/// The product of two 3x3 matrices (rows).
fn mat_mul(a: &[V3; 3], b: &[V3; 3]) -> [V3; 3] {
    [0, 1, 2].map(|i| [0, 1, 2].map(|j| (0..3).map(|k| a[i][k] * b[k][j]).sum()))
}

/// The scanner's part of the ground truth, in world coordinates.
fn scanner_truth(gt: &mut GroundTruth, s: &sample::Settings) {
    let rot = s.rotation;
    let t = s.translation;
    let sc = &s.scanner;
    let rt = [0, 1, 2].map(|k| [rot[0][k], rot[1][k], rot[2][k]]);
    gt.sensors = sc
        .views
        .iter()
        .enumerate()
        .map(|(v, view)| {
            // A view's world points x were moved to R M Rᵀ (x − T) + R m + T.
            let (rv, tv) = match &view.motion {
                Some(m) => {
                    let rv = mat_mul(&mat_mul(&rot, &m.rot), &rt);
                    let tv =
                        geometry::add(geometry::sub(t, mat_vec(&rv, t)), mat_vec(&rot, m.trans));
                    (rv, tv)
                }
                None => (IDENTITY, [0.0; 3]),
            };
            TruthSensor {
                view: v,
                position: s.world(view.sensor),
                pitch: view.pitch,
                registration_rotation: rv,
                registration_translation: tv,
            }
        })
        .collect();
    gt.lines = sc.lines.map(|l| {
        let normal = mat_vec(&rot, l.normal);
        TruthLines {
            normal,
            offset: l.offset + geometry::dot(normal, t),
            gap: l.gap,
        }
    });
    gt.density = sc.density.map(|d| {
        let direction = mat_vec(&rot, d.dir);
        let shift = geometry::dot(direction, t);
        TruthDensity {
            direction,
            ratio: d.ln_ratio.exp(),
            lo: d.lo + shift,
            hi: d.lo + d.span + shift,
        }
    });
}

/// Simulates the scan of a mesh part: prepare the part, lay out the scanner, choose the
/// spacing, round the edges, sample with the pattern, and write down the truth.
fn scan_mesh(p: &SynthParams, mesh: Mesh, origin: Origin) -> Result<Scan> {
    let part = prepare_part(p, mesh, origin)?;
    let model = &part.model;
    let rot = rotation(p);
    let frame = scanner::Frame {
        rotation: &rot,
        translation: p.translate,
        radius: part.radius,
        seed: p.seed,
    };
    let lay = scanner::layout(&p.scan, model, &frame)?;
    let h = spacing(p, model, &lay)?;
    let fillets = round_edges(p, model, h)?;
    let world = |q: V3| geometry::add(mat_vec(&rot, q), p.translate);
    let world_vertices: Vec<V3> = model.mesh.vertices.iter().map(|&v| world(v)).collect();
    let (out_lo, out_hi, double) = outlier_box_and_precision(&world_vertices, h, p.double);
    let settings = sample::Settings {
        h,
        jitter: p.jitter,
        seed: p.seed,
        noise_sigma: p.noise * h,
        edge_sigma: p.edge_noise * h,
        band: p.edge_band * h,
        outliers: p.outliers,
        outlier_lo: out_lo,
        outlier_hi: out_hi,
        rotation: rot,
        translation: p.translate,
        eps: 1e-9 * part.extent.max(h),
        scanner: scanner::resolve(&p.scan, lay, h, &frame),
    };
    let (positions, truth) = sample_pattern(p, &part, &fillets, &settings)?;
    let mut gt = ground_truth(p, &part, &fillets, &settings, world_vertices);
    if let Origin::Random(random_part) = origin {
        gt.fillets = truth_fillets(model, random_part, part.model_scale, h, world);
        gt.random = Some(random_part.draw.clone());
    }
    gt_counts(&mut gt, &truth);
    Ok(finish_scan(p, gt, positions, truth, double))
}

/// The ground truth of a random part's fillets: their charts (those of the facets between
/// their inner arc vertices) and tangent lines.
fn truth_fillets(
    model: &Model,
    part: &random::RandomPart,
    model_scale: f64,
    h: f64,
    world: impl Fn(V3) -> V3,
) -> Vec<TruthFillet> {
    part.fillets
        .iter()
        .enumerate()
        .map(|(id, f)| {
            let mut faces: Vec<usize> = (1..f.bottom.len().saturating_sub(1))
                .filter_map(|k| {
                    let (a, b) = (f.bottom[k], f.top[k]);
                    model.edge_tris.get(&(a.min(b), a.max(b)))
                })
                .flatten()
                .map(|&t| model.tri_chart[t as usize] as usize)
                .collect();
            faces.sort_unstable();
            faces.dedup();
            let line =
                |k: usize| [f.bottom[k], f.top[k]].map(|v| world(model.mesh.vertices[v as usize]));
            let last = f.bottom.len().saturating_sub(1);
            let radius = f.radius * model_scale;
            TruthFillet {
                id,
                radius,
                radius_h: radius / h,
                angle_deg: f.angle_deg,
                faces,
                tangent_lines: [line(0), line(last)],
            }
        })
        .collect()
}

fn gt_counts(gt: &mut GroundTruth, truth: &[PointTruth]) {
    gt.points = truth.len();
    gt.abnormal_points = truth.iter().filter(|t| t.abnormal).count();
    gt.outlier_points = truth.iter().filter(|t| t.outlier).count();
}

fn finish_scan(
    p: &SynthParams,
    ground_truth: GroundTruth,
    positions: Vec<V3>,
    truth: Vec<PointTruth>,
    double: bool,
) -> Scan {
    Scan {
        cloud: Cloud {
            positions,
            attributes: Vec::new(),
            source: Source {
                path: PathBuf::new(),
                format: format!("sharpedge synth {} (seed {})", p.part.name(), p.seed),
                double_precision: double,
            },
            structure: None,
        },
        truth,
        ground_truth,
    }
}

fn scan_sphere(p: &SynthParams) -> Result<Scan> {
    let radius = 0.5 * p.size.unwrap_or(100.0);
    let area = 4.0 * std::f64::consts::PI * radius * radius;
    let h = match p.sampling {
        Sampling::Spacing(h) => h,
        Sampling::Points(n) => (area / n as f64).sqrt(),
    };
    let expected = area / (h * h);
    if expected > MAX_POINTS as f64 {
        return Err(too_many(p, expected));
    }
    let n = sample::sphere_count(radius, h);
    let rot = rotation(p);
    let corners_of_box: Vec<V3> = (0..8)
        .map(|i| {
            let c = [0, 1, 2].map(|k| if (i >> k) & 1 == 1 { radius } else { -radius });
            add(c, p.translate) // a sphere's world box does not depend on R
        })
        .collect();
    let (out_lo, out_hi, double) = outlier_box_and_precision(&corners_of_box, h, p.double);
    let settings = sample::Settings {
        h,
        jitter: p.jitter,
        seed: p.seed,
        noise_sigma: p.noise * h,
        edge_sigma: 0.0,
        band: 0.0,
        outliers: p.outliers,
        outlier_lo: out_lo,
        outlier_hi: out_hi,
        rotation: rot,
        translation: p.translate,
        eps: 1e-9 * radius,
        scanner: scanner::Scanner::default(),
    };
    let mut positions = vec![[0.0; 3]; n];
    let mut truth = vec![
        PointTruth {
            surface: [0.0; 3],
            edge_distance: f64::INFINITY,
            nearest_edge: u32::MAX,
            face: u32::MAX,
            abnormal: false,
            outlier: false,
            view: u32::MAX,
            noise: 0.0,
        };
        n
    ];
    sample::fill_sphere(radius, &settings, &mut positions, &mut truth);
    let mut gt = GroundTruth::new(
        p.part.name(),
        p.clone(),
        h,
        0.0,
        rot,
        p.translate,
        [0.0; 3],
        1.0,
        Vec::new(),
        Vec::new(),
        Vec::new(),
        Vec::new(),
        TruthSurface::Sphere {
            centre: p.translate,
            radius,
        },
        features::MeshStats::default(),
    );
    gt_counts(&mut gt, &truth);
    Ok(finish_scan(p, gt, positions, truth, double))
}
