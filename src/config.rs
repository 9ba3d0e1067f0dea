//! pipeline.toml in two steps: TOML → raw structs (`deny_unknown_fields`, every value
//! optional and spanned) → `validate()` → typed `Settings` that the core uses. The core never
//! sees TOML.
//!
//! Input: the text of a pipeline file and its path. Output: `Settings`, or an
//! `Error::Config` naming the file, the line, the dotted key and what is allowed, e.g.
//! `pipeline.toml:14: fit.swarm_size: must be ≥ 2, got 0`.
//!
//! Defaults live in one place, the `Default` impls of the typed settings (and of each
//! stage's parameter struct); the committed pipeline.toml repeats them in comments.

use std::ops::Range;
use std::path::{Path, PathBuf};

use serde::de::{self, Deserializer, Visitor};
use serde::{Deserialize, Serialize};
use toml::Spanned;

use crate::error::{Error, Result};
use crate::fit::FitParams;
use crate::io::{CloudFormat, NonFinite, PlyEncoding};
use crate::stages::corners::CornerParams;
use crate::stages::edges::EdgeParams;
use crate::stages::features::FeatureParams;
use crate::stages::rectify::RectifyParams;
use crate::stages::segment::SegmentParams;

/// A length in model units, or `"auto"`: derived from the cloud's measured spacing and noise.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Length {
    Auto,
    Value(f64),
}

impl<'de> Deserialize<'de> for Length {
    fn deserialize<D: Deserializer<'de>>(d: D) -> std::result::Result<Self, D::Error> {
        struct V;
        impl Visitor<'_> for V {
            type Value = Length;
            fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                f.write_str("a length in model units or \"auto\"")
            }
            fn visit_f64<E: de::Error>(self, v: f64) -> std::result::Result<Length, E> {
                Ok(Length::Value(v))
            }
            fn visit_i64<E: de::Error>(self, v: i64) -> std::result::Result<Length, E> {
                Ok(Length::Value(v as f64))
            }
            fn visit_u64<E: de::Error>(self, v: u64) -> std::result::Result<Length, E> {
                Ok(Length::Value(v as f64))
            }
            fn visit_str<E: de::Error>(self, v: &str) -> std::result::Result<Length, E> {
                if v == "auto" {
                    Ok(Length::Auto)
                } else {
                    Err(E::invalid_value(de::Unexpected::Str(v), &self))
                }
            }
        }
        d.deserialize_any(V)
    }
}

// ---- raw: what the file says, with spans for the messages ----

type Opt<T> = Option<Spanned<T>>;

#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawConfig {
    seed: Opt<i64>,
    threads: Opt<i64>,
    #[serde(default)]
    input: RawInput,
    #[serde(default)]
    output: RawOutput,
    #[serde(default)]
    features: RawFeatures,
    #[serde(default)]
    segment: RawSegment,
    #[serde(default)]
    edges: RawEdges,
    #[serde(default)]
    corners: RawCorners,
    #[serde(default)]
    rectify: RawRectify,
    /// The fit's own serde struct (nested tables `[fit.pso]`, `[fit.propagation]`, ...);
    /// unknown keys are refused by it, ranges checked by `FitParams::validate`.
    #[serde(default)]
    fit: FitParams,
}

#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawEdges {
    band: Opt<f64>,
    slab_points: Opt<i64>,
    vertex_margin: Opt<f64>,
    straight_tolerance: Opt<f64>,
    max_rounding: Opt<f64>,
    min_turn: Opt<f64>,
}

#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawCorners {
    reach: Opt<f64>,
}

#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawRectify {
    enabled: Opt<bool>,
    max_move: Opt<f64>,
    zone_margin: Opt<f64>,
}

#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawInput {
    path: Opt<String>,
    non_finite: Opt<String>,
    sensors: Opt<Vec<[f64; 3]>>,
}

#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawOutput {
    dir: Opt<String>,
    encoding: Opt<String>,
    precision: Opt<String>,
    format: Opt<String>,
    classify_edges: Opt<bool>,
    edge_class: Opt<i64>,
}

#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawFeatures {
    radius: Opt<Length>,
    noise: Opt<Length>,
    min_radius: Opt<f64>,
    noise_radius: Opt<f64>,
    normal_radius: Opt<f64>,
    plane_threshold: Opt<f64>,
    split_threshold: Opt<f64>,
    split_noise_factor: Opt<f64>,
    outlier_share: Opt<f64>,
}

#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawSegment {
    direction_tolerance: Opt<f64>,
    turn_angle: Opt<f64>,
    tube: Opt<f64>,
    min_length: Opt<f64>,
    corner_ratio: Opt<f64>,
    vertex_gap: Opt<f64>,
    vertex_reach: Opt<f64>,
    corner_angle: Opt<f64>,
    min_density: Opt<f64>,
    absorb: Opt<f64>,
}

// ---- typed: what the core uses ----

/// Coordinate type of the written clouds.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Precision {
    /// Double when the input stored more precision than float holds, or when float would
    /// lose more than a thousandth of the spacing at the cloud's magnitude.
    Auto,
    Float,
    Double,
}

#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct InputSettings {
    /// The cloud to read; relative paths in the file are relative to the file's folder.
    pub path: Option<PathBuf>,
    #[serde(serialize_with = "ser_non_finite")]
    pub non_finite: NonFinite,
    /// Where the scanner stood, in the cloud's coordinates (an RGB-D frame in its camera's
    /// frame: the origin), one per view; empty when unknown. Tells the side of the material of
    /// edges an open scan leaves undecided (see `stages::convexity`).
    pub sensors: Vec<[f64; 3]>,
}

#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct OutputSettings {
    pub dir: PathBuf,
    #[serde(serialize_with = "ser_encoding")]
    pub encoding: PlyEncoding,
    pub precision: Precision,
    /// File format of the rectified cloud (`auto`: LAS/LAZ, PCD or E57 as the input, PLY otherwise).
    pub format: CloudFormat,
    /// Give edge points the class `edge_class` in a LAS/LAZ output.
    pub classify_edges: bool,
    /// Class code of edge points when `classify_edges` (0–255; 0–31 for point formats 0–5,
    /// checked against the input once it is read).
    pub edge_class: u8,
}

/// Everything a run needs, validated.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Settings {
    pub seed: u64,
    /// Worker threads; 0 = all cores.
    pub threads: usize,
    pub input: InputSettings,
    pub output: OutputSettings,
    pub features: FeatureParams,
    pub segment: SegmentParams,
    pub edges: EdgeParams,
    pub corners: CornerParams,
    pub rectify: RectifyParams,
    pub fit: FitParams,
}

impl Default for Settings {
    fn default() -> Self {
        Settings {
            seed: 1,
            threads: 0,
            input: InputSettings {
                path: None,
                non_finite: NonFinite::Reject,
                sensors: Vec::new(),
            },
            output: OutputSettings {
                dir: PathBuf::from("out"),
                encoding: PlyEncoding::BinaryLittleEndian,
                precision: Precision::Auto,
                format: CloudFormat::Auto,
                classify_edges: false,
                edge_class: 31,
            },
            features: FeatureParams::default(),
            segment: SegmentParams::default(),
            edges: EdgeParams::default(),
            corners: CornerParams::default(),
            rectify: RectifyParams::default(),
            fit: pipeline_fit_default(),
        }
    }
}

fn ser_non_finite<S: serde::Serializer>(
    v: &NonFinite,
    s: S,
) -> std::result::Result<S::Ok, S::Error> {
    s.serialize_str(match v {
        NonFinite::Reject => "reject",
        NonFinite::Drop => "drop",
    })
}

fn ser_encoding<S: serde::Serializer>(
    v: &PlyEncoding,
    s: S,
) -> std::result::Result<S::Ok, S::Error> {
    s.serialize_str(match v {
        PlyEncoding::BinaryLittleEndian => "binary",
        PlyEncoding::Ascii => "ascii",
    })
}

/// Reads and validates a pipeline file.
pub fn load(path: &Path) -> Result<Settings> {
    let text = std::fs::read_to_string(path)
        .map_err(|e| Error::io(path, "cannot read pipeline file", e))?;
    parse(&text, path)
}

/// Parses and validates the text of a pipeline file; `path` is used for messages and to
/// resolve relative paths.
pub fn parse(text: &str, path: &Path) -> Result<Settings> {
    let raw = parse_raw(text, path)?;
    Checker { text, path }.validate(raw)
}

fn parse_raw(text: &str, path: &Path) -> Result<RawConfig> {
    let de =
        toml::Deserializer::parse(text).map_err(|e| toml_error(text, path, &e, String::new()))?;
    serde_path_to_error::deserialize(de).map_err(|e| {
        // Spanned<T> shows up as a private map key in the path; users know the key only.
        let key = e
            .path()
            .to_string()
            .replace(".$__serde_spanned_private_value", "");
        toml_error(
            text,
            path,
            e.inner(),
            if key == "." { String::new() } else { key },
        )
    })
}

fn toml_error(text: &str, path: &Path, e: &toml::de::Error, key: String) -> Error {
    let line = e.span().map(|s| line_of(text, s.start)).unwrap_or(0);
    let mut message = plain_types(e.message().trim());
    if message.starts_with("unknown field") {
        message.push_str("; see the commented pipeline.toml for every key");
    }
    Error::Config {
        path: path.to_path_buf(),
        line,
        key: if key.is_empty() { "(file)".into() } else { key },
        message,
    }
}

/// serde names Rust types in type errors ("expected i64"); users write TOML, where those are
/// integers and numbers.
fn plain_types(message: &str) -> String {
    let Some((head, tail)) = message.rsplit_once(", expected ") else {
        return message.to_string();
    };
    let plain = match tail {
        "i8" | "i16" | "i32" | "i64" | "u8" | "u16" | "u32" | "u64" | "usize" | "isize" => {
            "an integer"
        }
        "f32" | "f64" => "a number",
        _ => return message.to_string(),
    };
    format!("{head}, expected {plain}")
}

fn line_of(text: &str, offset: usize) -> usize {
    text.as_bytes()[..offset.min(text.len())]
        .iter()
        .filter(|&&b| b == b'\n')
        .count()
        + 1
}

/// The fit parameters a run uses unless the file says otherwise: the paper's, except that
/// the constrained corner is scored on the side points only, the swarm also starts at the
/// local fits' meeting point (a scanned vertex lies beyond its data), and a vertex's swarm
/// gets 40 iterations instead of 10. A vertex's side points are its edges' rectified edge
/// points, whose scatter is a few hundredths of a spacing: the error's valley is narrow and
/// a swarm started far from it (the points stop 5 spacings short of the vertex)
/// needs the iterations. Measured on an octagonal prism at 500k points: with 20 iterations
/// one vertex of 16 stopped 8 % above the exact optimum, 0.14 spacings off it; with 40 every
/// vertex was within 0.01 %. Vertices are few, so this costs nothing measurable. The paper
/// counts every point, but on a scan the abnormal-zone points are exactly the ones the
/// corner must not follow (they pull it into the rounding); `sharpedge experiment` keeps
/// the paper's choice.
pub fn pipeline_fit_default() -> FitParams {
    let mut fit = FitParams {
        include_corner_region: false,
        seed_with_intersection: true,
        ..FitParams::default()
    };
    fit.pso.iterations_3d = 40;
    fit
}

/// The line of `name` (e.g. `pso.w`) in the `[fit]` part of a pipeline file: under
/// `[fit.pso]` as `w = …`, or under `[fit]` as `pso.w = …`; 0 when not found.
fn line_of_fit_key(text: &str, name: &str) -> usize {
    let (table, key) = match name.rsplit_once('.') {
        Some((t, k)) => (format!("fit.{t}"), k),
        None => ("fit".to_string(), name),
    };
    let mut section = String::new();
    for (i, line) in text.lines().enumerate() {
        let l = line.trim();
        if let Some(h) = l.strip_prefix('[').and_then(|h| h.strip_suffix(']')) {
            section = h.trim().to_string();
            continue;
        }
        let Some((k, _)) = l.split_once('=') else {
            continue;
        };
        let full = format!("{section}.{}", k.trim());
        if full == format!("{table}.{key}") || (section == table && k.trim() == key) {
            return i + 1;
        }
    }
    0
}

struct Checker<'a> {
    text: &'a str,
    path: &'a Path,
}

impl Checker<'_> {
    fn err(&self, span: Range<usize>, key: &str, message: String) -> Error {
        Error::Config {
            path: self.path.to_path_buf(),
            line: line_of(self.text, span.start),
            key: key.to_string(),
            message,
        }
    }

    /// A number in `lo..=hi` (or `lo < v` when `open_lo`).
    fn number(
        &self,
        v: &Opt<f64>,
        key: &str,
        default: f64,
        lo: f64,
        hi: f64,
        open_lo: bool,
    ) -> Result<f64> {
        let Some(v) = v else { return Ok(default) };
        let x = *v.get_ref();
        let ok = x.is_finite() && x <= hi && if open_lo { x > lo } else { x >= lo };
        if ok {
            return Ok(x);
        }
        let range = match (open_lo, hi.is_finite()) {
            (true, true) => format!("in ({lo}, {hi}]"),
            (true, false) => format!("> {lo}"),
            (false, true) => format!("in [{lo}, {hi}]"),
            (false, false) => format!("≥ {lo}"),
        };
        Err(self.err(v.span(), key, format!("must be {range}, got {x}")))
    }

    fn length(&self, v: &Opt<Length>, key: &str) -> Result<Option<f64>> {
        match v.as_ref().map(|s| (*s.get_ref(), s.span())) {
            None | Some((Length::Auto, _)) => Ok(None),
            Some((Length::Value(x), _)) if x.is_finite() && x > 0.0 => Ok(Some(x)),
            Some((Length::Value(x), span)) => Err(self.err(
                span,
                key,
                format!("must be a positive length in model units or \"auto\", got {x}"),
            )),
        }
    }

    fn choice<T: Copy>(
        &self,
        v: &Opt<String>,
        key: &str,
        default: T,
        allowed: &[(&str, T)],
    ) -> Result<T> {
        let Some(v) = v else { return Ok(default) };
        allowed
            .iter()
            .find(|(name, _)| *name == v.get_ref().as_str())
            .map(|(_, t)| *t)
            .ok_or_else(|| {
                let names: Vec<String> = allowed.iter().map(|(n, _)| format!("\"{n}\"")).collect();
                self.err(
                    v.span(),
                    key,
                    format!(
                        "must be one of {}, got \"{}\"",
                        names.join(", "),
                        v.get_ref()
                    ),
                )
            })
    }

    fn relative(&self, p: &str) -> PathBuf {
        let p = PathBuf::from(p);
        if p.is_absolute() {
            return p;
        }
        match self.path.parent() {
            Some(dir) if !dir.as_os_str().is_empty() => dir.join(p),
            _ => p,
        }
    }

    fn validate(&self, raw: RawConfig) -> Result<Settings> {
        let d = Settings::default();
        let seed = match &raw.seed {
            None => d.seed,
            Some(s) if *s.get_ref() >= 0 => *s.get_ref() as u64,
            Some(s) => {
                return Err(self.err(
                    s.span(),
                    "seed",
                    format!("must be ≥ 0, got {}", s.get_ref()),
                ));
            }
        };
        let threads = match &raw.threads {
            None => d.threads,
            Some(t) if (0..=4096).contains(t.get_ref()) => *t.get_ref() as usize,
            Some(t) => {
                return Err(self.err(
                    t.span(),
                    "threads",
                    format!("must be in [0, 4096] (0 = all cores), got {}", t.get_ref()),
                ));
            }
        };
        let input = InputSettings {
            path: match &raw.input.path {
                Some(p) if p.get_ref().is_empty() => {
                    return Err(self.err(p.span(), "input.path", "must not be empty".into()));
                }
                Some(p) => Some(self.relative(p.get_ref())),
                None => None,
            },
            non_finite: self.choice(
                &raw.input.non_finite,
                "input.non_finite",
                d.input.non_finite,
                &[("reject", NonFinite::Reject), ("drop", NonFinite::Drop)],
            )?,
            sensors: match &raw.input.sensors {
                Some(v) if v.get_ref().iter().flatten().any(|x| !x.is_finite()) => {
                    return Err(self.err(
                        v.span(),
                        "input.sensors",
                        "must be finite [x, y, z] positions".into(),
                    ));
                }
                Some(v) => v.get_ref().clone(),
                None => Vec::new(),
            },
        };
        let output = OutputSettings {
            dir: match &raw.output.dir {
                Some(p) if p.get_ref().is_empty() => {
                    return Err(self.err(p.span(), "output.dir", "must not be empty".into()));
                }
                Some(p) => self.relative(p.get_ref()),
                None => self.relative("out"),
            },
            encoding: self.choice(
                &raw.output.encoding,
                "output.encoding",
                d.output.encoding,
                &[
                    ("binary", PlyEncoding::BinaryLittleEndian),
                    ("ascii", PlyEncoding::Ascii),
                ],
            )?,
            precision: self.choice(
                &raw.output.precision,
                "output.precision",
                d.output.precision,
                &[
                    ("auto", Precision::Auto),
                    ("float", Precision::Float),
                    ("double", Precision::Double),
                ],
            )?,
            format: self.choice(
                &raw.output.format,
                "output.format",
                d.output.format,
                &[
                    ("auto", CloudFormat::Auto),
                    ("ply", CloudFormat::Ply),
                    ("las", CloudFormat::Las),
                    ("laz", CloudFormat::Laz),
                    ("pcd", CloudFormat::Pcd),
                    ("e57", CloudFormat::E57),
                ],
            )?,
            classify_edges: raw
                .output
                .classify_edges
                .as_ref()
                .map(|v| *v.get_ref())
                .unwrap_or(d.output.classify_edges),
            edge_class: match &raw.output.edge_class {
                None => d.output.edge_class,
                Some(v) if (0..=255).contains(v.get_ref()) => *v.get_ref() as u8,
                Some(v) => {
                    return Err(self.err(
                        v.span(),
                        "output.edge_class",
                        format!(
                            "must be a LAS class code in [0, 255] ([0, 31] for point formats \
                             0-5), got {}",
                            v.get_ref()
                        ),
                    ));
                }
            },
        };
        let f = &raw.features;
        let fd = &d.features;
        let features = FeatureParams {
            radius: self.length(&f.radius, "features.radius")?,
            noise: match &f.noise {
                Some(s) if matches!(s.get_ref(), Length::Value(x) if *x == 0.0) => Some(0.0),
                _ => self.length(&f.noise, "features.noise")?,
            },
            min_radius: self.number(
                &f.min_radius,
                "features.min_radius",
                fd.min_radius,
                1.0,
                100.0,
                false,
            )?,
            noise_radius: self.number(
                &f.noise_radius,
                "features.noise_radius",
                fd.noise_radius,
                1.0,
                100.0,
                false,
            )?,
            normal_radius: self.number(
                &f.normal_radius,
                "features.normal_radius",
                fd.normal_radius,
                0.0,
                100.0,
                false,
            )?,
            threshold: self.number(
                &f.plane_threshold,
                "features.plane_threshold",
                fd.threshold,
                1.0,
                f64::INFINITY,
                true,
            )?,
            split_threshold: self.number(
                &f.split_threshold,
                "features.split_threshold",
                fd.split_threshold,
                0.0,
                0.25,
                true,
            )?,
            split_noise_factor: self.number(
                &f.split_noise_factor,
                "features.split_noise_factor",
                fd.split_noise_factor,
                1.0,
                f64::INFINITY,
                false,
            )?,
            outlier_share: self.number(
                &f.outlier_share,
                "features.outlier_share",
                fd.outlier_share,
                0.0,
                1.0,
                false,
            )?,
        };
        let g = &raw.segment;
        let gd = &d.segment;
        let segment = SegmentParams {
            direction_tolerance: self.number(
                &g.direction_tolerance,
                "segment.direction_tolerance",
                gd.direction_tolerance,
                0.0,
                89.0,
                true,
            )?,
            turn_angle: self.number(
                &g.turn_angle,
                "segment.turn_angle",
                gd.turn_angle,
                0.0,
                89.0,
                true,
            )?,
            tube: self.number(&g.tube, "segment.tube", gd.tube, 0.0, 10.0, true)?,
            min_length: self.number(
                &g.min_length,
                "segment.min_length",
                gd.min_length,
                0.0,
                f64::INFINITY,
                false,
            )?,
            corner_ratio: self.number(
                &g.corner_ratio,
                "segment.corner_ratio",
                gd.corner_ratio,
                0.0,
                1.0,
                true,
            )?,
            vertex_gap: self.number(
                &g.vertex_gap,
                "segment.vertex_gap",
                gd.vertex_gap,
                0.0,
                10.0,
                true,
            )?,
            vertex_reach: self.number(
                &g.vertex_reach,
                "segment.vertex_reach",
                gd.vertex_reach,
                0.0,
                100.0,
                true,
            )?,
            corner_angle: self.number(
                &g.corner_angle,
                "segment.corner_angle",
                gd.corner_angle,
                0.0,
                90.0,
                true,
            )?,
            min_density: self.number(
                &g.min_density,
                "segment.min_density",
                gd.min_density,
                0.0,
                1.0,
                false,
            )?,
            absorb: self.number(&g.absorb, "segment.absorb", gd.absorb, 0.0, 20.0, false)?,
        };
        let e = &raw.edges;
        let ed = &d.edges;
        let edges = EdgeParams {
            band: self.number(&e.band, "edges.band", ed.band, 0.5, 50.0, false)?,
            slab_points: match &e.slab_points {
                None => ed.slab_points,
                Some(v) if (10..=100_000).contains(v.get_ref()) => *v.get_ref() as usize,
                Some(v) => {
                    return Err(self.err(
                        v.span(),
                        "edges.slab_points",
                        format!("must be in [10, 100000], got {}", v.get_ref()),
                    ));
                }
            },
            vertex_margin: self.number(
                &e.vertex_margin,
                "edges.vertex_margin",
                ed.vertex_margin,
                0.0,
                50.0,
                false,
            )?,
            straight_tolerance: self.number(
                &e.straight_tolerance,
                "edges.straight_tolerance",
                ed.straight_tolerance,
                0.0,
                f64::INFINITY,
                false,
            )?,
            max_rounding: self.number(
                &e.max_rounding,
                "edges.max_rounding",
                ed.max_rounding,
                0.0,
                f64::INFINITY,
                true,
            )?,
            min_turn: self.number(&e.min_turn, "edges.min_turn", ed.min_turn, 0.0, 90.0, false)?,
        };
        let corners = CornerParams {
            reach: self.number(
                &raw.corners.reach,
                "corners.reach",
                d.corners.reach,
                1.0,
                f64::INFINITY,
                false,
            )?,
        };
        let rectify = RectifyParams {
            enabled: raw
                .rectify
                .enabled
                .as_ref()
                .map(|v| *v.get_ref())
                .unwrap_or(d.rectify.enabled),
            max_move: self.number(
                &raw.rectify.max_move,
                "rectify.max_move",
                d.rectify.max_move,
                0.0,
                100.0,
                true,
            )?,
            zone_margin: self.number(
                &raw.rectify.zone_margin,
                "rectify.zone_margin",
                d.rectify.zone_margin,
                0.0,
                100.0,
                false,
            )?,
        };
        raw.fit.validate().map_err(|err| match &err {
            Error::InvalidParameter { name, .. } => Error::Config {
                path: self.path.to_path_buf(),
                line: line_of_fit_key(self.text, name),
                key: format!("fit.{name}"),
                message: err.to_string(),
            },
            _ => err,
        })?;
        let mut fit = raw.fit;
        // Keys the file does not set take the pipeline's defaults, not the library's.
        if line_of_fit_key(self.text, "include_corner_region") == 0 {
            fit.include_corner_region = pipeline_fit_default().include_corner_region;
        }
        if line_of_fit_key(self.text, "pso.iterations_3d") == 0 {
            fit.pso.iterations_3d = pipeline_fit_default().pso.iterations_3d;
        }
        if line_of_fit_key(self.text, "seed_with_intersection") == 0 {
            fit.seed_with_intersection = pipeline_fit_default().seed_with_intersection;
        }
        Ok(Settings {
            seed,
            threads,
            input,
            output,
            features,
            segment,
            edges,
            corners,
            rectify,
            fit,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse_str(s: &str) -> Result<Settings> {
        parse(s, Path::new("pipeline.toml"))
    }

    fn err(s: &str) -> String {
        parse_str(s).unwrap_err().to_string()
    }

    #[test]
    fn empty_file_gives_defaults() {
        let s = parse_str("").unwrap();
        assert_eq!(
            s,
            Settings {
                output: OutputSettings {
                    dir: "out".into(),
                    ..Settings::default().output
                },
                ..Settings::default()
            }
        );
    }

    #[test]
    fn values_are_read() {
        let s = parse_str(
            "seed = 7\nthreads = 2\n[input]\npath = \"a/b.ply\"\nnon_finite = \"drop\"\n[output]\ndir = \"res\"\nencoding = \"ascii\"\nprecision = \"double\"\n[features]\nradius = 2.5\nnoise = \"auto\"\n",
        )
        .unwrap();
        assert_eq!(s.seed, 7);
        assert_eq!(s.threads, 2);
        assert_eq!(s.input.path, Some(PathBuf::from("a/b.ply")));
        assert_eq!(s.input.non_finite, NonFinite::Drop);
        assert_eq!(s.output.dir, PathBuf::from("res"));
        assert_eq!(s.output.encoding, PlyEncoding::Ascii);
        assert_eq!(s.output.precision, Precision::Double);
        assert_eq!(s.features.radius, Some(2.5));
        assert_eq!(s.features.noise, None);
    }

    #[test]
    fn relative_paths_follow_the_config_file() {
        let s = parse(
            "[input]\npath = \"scan.ply\"\n[output]\ndir = \"res\"\n",
            Path::new("jobs/a/pipeline.toml"),
        )
        .unwrap();
        assert_eq!(s.input.path, Some(PathBuf::from("jobs/a/scan.ply")));
        assert_eq!(s.output.dir, PathBuf::from("jobs/a/res"));
    }

    #[test]
    fn unknown_key_names_line_and_key() {
        let e = err("seed = 1\n\n[features]\nradius = \"auto\"\nradios = 3\n");
        assert!(e.starts_with("pipeline.toml:5: features"), "{e}");
        assert!(e.contains("radios"), "{e}");
    }

    #[test]
    fn unknown_table_is_rejected() {
        let e = err("[featurez]\nradius = 1\n");
        assert!(e.starts_with("pipeline.toml:1:"), "{e}");
        assert!(e.contains("featurez"), "{e}");
    }

    #[test]
    fn out_of_range_value_names_line_key_range_and_value() {
        let e = err("[features]\n\noutlier_share = 1.5\n");
        assert_eq!(
            e,
            "pipeline.toml:3: features.outlier_share: must be in [0, 1], got 1.5"
        );
        let e = err("threads = -1\n");
        assert_eq!(
            e,
            "pipeline.toml:1: threads: must be in [0, 4096] (0 = all cores), got -1"
        );
    }

    #[test]
    fn bad_choice_lists_the_allowed_values() {
        let e = err("[output]\nencoding = \"binary_big_endian\"\n");
        assert_eq!(
            e,
            "pipeline.toml:2: output.encoding: must be one of \"binary\", \"ascii\", got \"binary_big_endian\""
        );
    }

    #[test]
    fn sensors_are_read_and_must_be_finite() {
        let s = parse_str("[input]\nsensors = [[0, 0, 0], [1.5, -2, 3e2]]\n").unwrap();
        assert_eq!(s.input.sensors, vec![[0.0; 3], [1.5, -2.0, 300.0]]);
        assert!(parse_str("").unwrap().input.sensors.is_empty());
        let e = err("[input]\nsensors = [[0, nan, 0]]\n");
        assert_eq!(
            e,
            "pipeline.toml:2: input.sensors: must be finite [x, y, z] positions"
        );
        let e = err("[input]\nsensors = [[0, 0]]\n");
        assert!(e.starts_with("pipeline.toml:2: "), "{e}");
    }

    #[test]
    fn bad_length() {
        let e = err("[features]\nradius = -2\n");
        assert_eq!(
            e,
            "pipeline.toml:2: features.radius: must be a positive length in model units or \"auto\", got -2"
        );
        let e = err("[features]\nradius = \"big\"\n");
        assert!(e.starts_with("pipeline.toml:2: features.radius:"), "{e}");
        assert!(e.contains("\"auto\""), "{e}");
    }

    #[test]
    fn wrong_type_names_line_and_key() {
        let e = err("seed = \"one\"\n");
        assert!(e.starts_with("pipeline.toml:1: seed:"), "{e}");
    }

    #[test]
    fn syntax_error_names_the_line() {
        let e = err("seed = 1\n[features\n");
        assert!(e.starts_with("pipeline.toml:2:"), "{e}");
    }

    #[test]
    fn fit_table_is_read_and_checked_with_its_line() {
        let s = parse_str("[fit.pso]\nw = 0.5\niterations_2d = 30\n[edges]\nslab_points = 40\n")
            .unwrap();
        assert_eq!(s.fit.pso.w, 0.5);
        assert_eq!(s.fit.pso.iterations_2d, 30);
        assert_eq!(s.edges.slab_points, 40);
        let e = err("seed = 1\n[fit.pso]\nc1 = 2\nw = 1.5\n");
        assert!(e.starts_with("pipeline.toml:4: fit.pso.w: "), "{e}");
        assert!(e.contains("1.5"), "{e}");
        let e = err("[fit.pso]\nswarm = 3\n");
        assert!(e.starts_with("pipeline.toml:2: fit.pso"), "{e}");
        assert!(e.contains("swarm"), "{e}");
        let e = err("[rectify]\nenabled = \"yes\"\n");
        assert!(e.starts_with("pipeline.toml:2: rectify.enabled:"), "{e}");
    }

    #[test]
    fn output_format_and_edge_class() {
        let s = parse_str("[output]\nformat = \"laz\"\nclassify_edges = true\nedge_class = 64\n")
            .unwrap();
        assert_eq!(s.output.format, CloudFormat::Laz);
        assert!(s.output.classify_edges);
        assert_eq!(s.output.edge_class, 64);
        let d = parse_str("").unwrap();
        assert_eq!(d.output.format, CloudFormat::Auto);
        assert!(!d.output.classify_edges);
        let e = err("[output]\n\nformat = \"copc\"\n");
        assert_eq!(
            e,
            "pipeline.toml:3: output.format: must be one of \"auto\", \"ply\", \"las\", \"laz\", \"pcd\", \"e57\", got \"copc\""
        );
        let e57 = parse_str("[output]\nformat = \"e57\"\n").unwrap();
        assert_eq!(e57.output.format, CloudFormat::E57);
        let e = err("[output]\nedge_class = 256\n");
        assert!(
            e.starts_with(
                "pipeline.toml:2: output.edge_class: must be a LAS class code in [0, 255]"
            ),
            "{e}"
        );
        let e = err("[output]\nclassify_edges = 1\n");
        assert!(
            e.starts_with("pipeline.toml:2: output.classify_edges:"),
            "{e}"
        );
        let j = serde_json::to_value(&s).unwrap();
        assert_eq!(j["output"]["format"], "laz");
    }

    #[test]
    fn settings_serialise_for_the_report() {
        let s = parse_str("").unwrap();
        let j = serde_json::to_value(&s).unwrap();
        assert_eq!(j["output"]["encoding"], "binary");
        assert_eq!(j["input"]["non_finite"], "reject");
        assert_eq!(j["features"]["min_radius"], 4.0);
    }
}
