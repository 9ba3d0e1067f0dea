//! Reading and writing point clouds. Format details (PLY, LAS/LAZ, XYZ, meshes) stay in here;
//! the rest of the library sees only `Cloud`.
//!
//! Inputs: a path whose extension names the format (`.ply`, `.las`, `.laz` including COPC
//! `.copc.laz`, PCL's `.pcd`, `.e57`, and the text formats `.xyz`, `.txt`, `.pts`, `.pwn`). Outputs: a [`Cloud`] with
//! f64 positions in file order, every per-point property as a typed [`Attribute`], and a
//! [`Source`](crate::Source) saying where it came from and whether its coordinates need double
//! precision. Writers produce PLY (binary little endian or ascii, float or double
//! coordinates, an optional `element edge`) and arbitrary files, always atomically: a
//! temporary file in the destination folder is renamed into place only once complete, so a
//! failure leaves no partial output behind.
//!
//! A LAS/LAZ input read for a LAS/LAZ output ([`read_for_output`]) also hands back a
//! [`Lidar`]: its header, EVLRs and raw point records, which [`write_las`] writes back with
//! the rectified positions and sharpedge's fields as extra bytes; a PCD input read for a PCD
//! output hands back a [`PcdFile`] the same way, which [`write_pcd`] writes back, and an E57
//! input read for an E57 output an [`E57File`] (every scan's records and metadata), which
//! [`write_e57`] writes back scan by scan. All are an [`Original`]. Edges and corners are also
//! written as GeoJSON ([`write_geojson`]) in the input's [`Crs`].
//!
//! Points with NaN or infinite coordinates are rejected (error naming the first bad point) or
//! dropped with a warning, as the caller chooses in [`ReadOptions`].

pub mod mesh;

mod crs;
mod e57;
mod e57_packets;
mod geojson;
mod las;
mod las_check;
mod las_write;
mod lzf_stream;
pub mod output_set;
mod pcd;
mod ply;
mod xyz;

use std::io::Write;
use std::path::{Path, PathBuf};

use serde::Serialize;

use crate::cloud::{Attribute, Cloud};
use crate::error::{Error, Result};

pub use self::las::Lidar;
pub use crs::Crs;
pub use e57::{E57File, NO_CELL, write_e57};
pub use geojson::{GeoFeature, Geometry, NO_CRS, write_geojson};
pub use las_write::{ExtraField, LasWriteOptions, check_edge_class, max_class, write_las};
pub use pcd::{PcdEncoding, PcdFile, write_pcd};
pub use ply::{PlyEncoding, PlyWriteOptions, Precision, write_ply};

/// File format of the rectified cloud (`output.format`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum CloudFormat {
    /// LAS in → LAS out, LAZ (and COPC) in → LAZ out, PCD in → PCD out, E57 in → E57 out, PLY
    /// otherwise.
    #[default]
    Auto,
    Ply,
    Las,
    Laz,
    Pcd,
    E57,
}

impl CloudFormat {
    /// The format written for this input: `Auto` resolved by the input's extension and
    /// header (COPC is LAZ). LAS/LAZ output needs a LAS/LAZ input (its header, CRS and point
    /// records are what is written back).
    pub fn resolve(self, input: &Path) -> Result<CloudFormat> {
        let is_las = format_of(input).ok() == Some(Format::Las);
        let is_pcd = format_of(input).ok() == Some(Format::Pcd);
        let is_e57 = format_of(input).ok() == Some(Format::E57);
        let is_laz = is_las
            && input
                .extension()
                .is_some_and(|e| e.eq_ignore_ascii_case("laz"));
        match self {
            CloudFormat::Auto if is_laz => Ok(CloudFormat::Laz),
            CloudFormat::Auto if is_las => Ok(CloudFormat::Las),
            CloudFormat::Auto if is_pcd => Ok(CloudFormat::Pcd),
            CloudFormat::Auto if is_e57 => Ok(CloudFormat::E57),
            CloudFormat::Auto => Ok(CloudFormat::Ply),
            CloudFormat::Pcd if !is_pcd => Err(Error::Usage {
                option: "output.format (--format)".into(),
                message: format!(
                    "{}: a PCD output is written from a PCD input (its fields, organisation \
                     and NaN slots are written back); this input is no PCD file. Use \"ply\" \
                     or \"auto\"",
                    input.display()
                ),
            }),
            CloudFormat::Las | CloudFormat::Laz if !is_las => Err(Error::Usage {
                option: "output.format (--format)".into(),
                message: format!(
                    "{}: a LAS or LAZ output is written from a LAS or LAZ input (its header, \
                     CRS and point records are written back); this input is no LAS/LAZ file. \
                     Use \"ply\" or \"auto\"",
                    input.display()
                ),
            }),
            CloudFormat::E57 if !is_e57 => Err(Error::Usage {
                option: "output.format (--format)".into(),
                message: format!(
                    "{}: an E57 output is written from an E57 input (its scans, poses and \
                     records are written back); this input is no E57 file. Use \"ply\" or \
                     \"auto\"",
                    input.display()
                ),
            }),
            f => Ok(f),
        }
    }

    /// The extension of the rectified cloud (`ply`, `las`, `laz`, `pcd`; `Auto` unresolved:
    /// `ply`).
    pub fn extension(self) -> &'static str {
        match self {
            CloudFormat::Las => "las",
            CloudFormat::Laz => "laz",
            CloudFormat::Pcd => "pcd",
            CloudFormat::E57 => "e57",
            CloudFormat::Ply | CloudFormat::Auto => "ply",
        }
    }

    /// True for LAS and LAZ.
    pub fn is_lidar(self) -> bool {
        matches!(self, CloudFormat::Las | CloudFormat::Laz)
    }
}

/// What to do with points whose coordinates are NaN or infinite.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize)]
pub enum NonFinite {
    /// Fail with an error naming the first such point (the default: bad data is not silent).
    #[default]
    Reject,
    /// Remove those points (and their attribute values) and log a warning with their count.
    Drop,
}

/// Options of [`read`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct ReadOptions {
    pub non_finite: NonFinite,
}

/// The extensions [`read`] accepts, for error messages.
const READ_EXTENSIONS: &str = "sharpedge reads .ply, .las, .laz (also .copc.laz), .pcd, .e57, and text .xyz, .txt, .pts, .pwn";

/// The same for a triangle mesh, which is no scan but can be made into one.
const READ_EXTENSIONS_MESH: &str = "sharpedge reads .ply, .las, .laz (also .copc.laz), .pcd, .e57, \
    and text .xyz, .txt, .pts, .pwn; a triangle mesh is sampled into a scan with `sharpedge synth \
    --mesh FILE --out scan.ply`";

/// Point counts from which readers show a progress bar (small files would only flicker).
pub(crate) const PROGRESS_MIN_POINTS: u64 = 1 << 20;

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Format {
    Ply,
    Las,
    Pcd,
    Xyz,
    E57,
}

fn format_of(path: &Path) -> Result<Format> {
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().to_ascii_lowercase())
        .unwrap_or_default();
    let ext = name.rsplit_once('.').map(|(_, e)| e).unwrap_or("");
    match ext {
        "ply" => Ok(Format::Ply),
        // The las crate tells LAS from LAZ (and COPC, which is LAZ 1.4) by the header.
        "las" | "laz" => Ok(Format::Las),
        "pcd" => Ok(Format::Pcd),
        "xyz" | "txt" | "pts" | "pwn" => Ok(Format::Xyz),
        "e57" => Ok(Format::E57),
        _ => Err(Error::UnknownFormat {
            path: path.to_path_buf(),
            ext: ext.to_string(),
            allowed: if matches!(ext, "off" | "obj") {
                READ_EXTENSIONS_MESH
            } else {
                READ_EXTENSIONS
            },
        }),
    }
}

/// What a format reader hands back: the cloud with every point (finite or not) and the
/// description of the file that `describe` prints.
pub(crate) struct Loaded {
    pub cloud: Cloud,
    /// The coordinate properties with their stored types, then one entry per attribute.
    pub properties: Vec<PropertyInfo>,
    /// Elements of the file that are not points (PLY faces, edges, ...), with their counts.
    pub other_elements: Vec<ElementInfo>,
    /// Format-specific facts for `info` (label, value): a PCD's encoding, organisation and
    /// viewpoint.
    pub details: Vec<(String, String)>,
}

fn load(path: &Path) -> Result<Loaded> {
    let format = format_of(path)?;
    let loaded = match format {
        Format::Ply => ply::read(path, ply::VertexPath::Fast)?,
        Format::Las => las::read(path)?,
        Format::Pcd => pcd::read(path)?,
        Format::Xyz => xyz::read(path)?,
        Format::E57 => e57::read(path, false)?.0,
    };
    debug_assert!(
        loaded.cloud.is_consistent(),
        "reader bug: attribute lengths"
    );
    Ok(loaded)
}

/// Reads a cloud by extension: `.ply`, `.las`, `.laz` (incl. COPC `.copc.laz`),
/// `.xyz`/`.txt`/`.pts`/`.pwn` (whitespace or comma separated `x y z [more columns]`). Shows a
/// progress bar for big files. An empty file (0 points) is not an error here; the pipeline
/// decides what to do with it.
pub fn read(path: &Path, opts: &ReadOptions) -> Result<Cloud> {
    let _span = tracing::debug_span!("read", path = %path.display()).entered();
    let mut cloud = load(path)?.cloud;
    apply_non_finite(&mut cloud, opts.non_finite)?;
    tracing::debug!(
        points = cloud.len(),
        format = %cloud.source.format,
        "read {}",
        path.display()
    );
    Ok(cloud)
}

/// The receiver of [`stream_positions`]: the index of a chunk's first point and the chunk.
pub type PositionSink<'a> = dyn FnMut(u64, &[[f64; 3]]) -> Result<()> + Send + 'a;

/// What [`stream_positions`] learnt of a file besides its points.
#[derive(Debug, Clone)]
pub struct Streamed {
    /// Point records in the file (non-finite ones included).
    pub records: u64,
    /// The format's description, as `Source::format`.
    pub format: String,
    /// The header's bounding box (min, max) where the format has one (LAS/LAZ/COPC).
    pub header_bounds: Option<[[f64; 3]; 2]>,
}

/// Streams the positions of a cloud file in file order to `f` in chunks, each with the
/// index (0-based, in file order) of its first record: PLY (binary and ascii) and LAS, LAZ
/// and COPC (sequentially) chunk by chunk without holding the cloud; PCD, E57 and XYZ text
/// are read whole first (their readers hold the cloud), then handed over in chunks.
/// Non-finite points follow `opts.non_finite`: refused with the first one's index, or
/// skipped (the indices of the others stay those of the file).
pub fn stream_positions(path: &Path, opts: &ReadOptions, f: &mut PositionSink) -> Result<Streamed> {
    let mut next = 0u64;
    let mut dropped = 0u64;
    let mut finite: Vec<[f64; 3]> = Vec::new();
    let mut pass = |chunk: &[[f64; 3]]| -> Result<()> {
        let first = next;
        next += chunk.len() as u64;
        if chunk.iter().all(is_finite_point) {
            return f(first, chunk);
        }
        // A chunk with non-finite points: refused, or split around them.
        if opts.non_finite == NonFinite::Reject {
            let k = chunk.iter().position(|p| !is_finite_point(p)).unwrap_or(0);
            let p = chunk[k];
            return Err(Error::BadCloud {
                path: path.to_path_buf(),
                what: format!(
                    "point {} (0-based, in file order) has a non-finite coordinate (x = {}, \
                     y = {}, z = {}). Fix the file, or read it with non-finite points dropped",
                    first + k as u64,
                    p[0],
                    p[1],
                    p[2]
                ),
            });
        }
        let mut start = 0;
        for (k, p) in chunk.iter().enumerate() {
            if !is_finite_point(p) {
                dropped += 1;
                if k > start {
                    finite.clear();
                    finite.extend_from_slice(&chunk[start..k]);
                    f(first + start as u64, &finite)?;
                }
                start = k + 1;
            }
        }
        if start < chunk.len() {
            f(first + start as u64, &chunk[start..])?;
        }
        Ok(())
    };
    let (records, format, header_bounds) = match format_of(path)? {
        Format::Ply => {
            let (n, d) = ply::stream_positions(path, &mut pass)?;
            (n, d, None)
        }
        Format::Las => {
            let (n, d, b) = las::stream_positions(path, &mut pass)?;
            (n, d, Some(b))
        }
        Format::Pcd | Format::Xyz | Format::E57 => {
            let cloud = load(path)?.cloud;
            for chunk in cloud.positions.chunks(1 << 20) {
                pass(chunk)?;
            }
            (cloud.len() as u64, cloud.source.format, None)
        }
    };
    if dropped > 0 {
        tracing::warn!(
            "{}: dropped {dropped} of {records} points with NaN or infinite coordinates",
            path.display()
        );
    }
    Ok(Streamed {
        records,
        format,
        header_bounds,
    })
}

/// What an input keeps besides its cloud for writing the rectified cloud in its own format.
// One per run, moved and never copied: boxing the LAS header would buy nothing.
#[allow(clippy::large_enum_variant)]
#[derive(Debug)]
pub enum Original {
    /// A LAS/LAZ input: header, EVLRs, CRS, and the raw point records for a LAS/LAZ output.
    Lidar(Lidar),
    /// A PCD input read for a PCD output: header and every slot's record.
    Pcd(PcdFile),
    /// An E57 input read for an E57 output: its scans' metadata and records.
    E57(E57File),
}

impl Original {
    /// The LAS/LAZ input's [`Lidar`], if this is one.
    pub fn lidar(&self) -> Option<&Lidar> {
        match self {
            Original::Lidar(l) => Some(l),
            _ => None,
        }
    }

    /// Keeps the points whose `keep` flag is set (points dropped from the cloud).
    fn retain_mask(&mut self, keep: &[bool]) {
        match self {
            Original::Lidar(l) => l.retain_mask(keep),
            Original::Pcd(p) => p.retain_mask(keep),
            Original::E57(e) => e.retain_mask(keep),
        }
    }
}

/// Reads a cloud for a run whose rectified cloud is written as `output` (resolved). A LAS/LAZ
/// input also gives its [`Lidar`] (header, EVLRs, CRS); for a LAS/LAZ output it holds the raw
/// point records, and the cloud then carries no attribute columns (the records hold them: one
/// copy of the points in memory, not two). A PCD input read for a PCD output gives its
/// [`PcdFile`] the same way, an E57 input read for an E57 output its [`E57File`].
pub fn read_for_output(
    path: &Path,
    opts: &ReadOptions,
    output: CloudFormat,
) -> Result<(Cloud, Option<Original>)> {
    let format = format_of(path)?;
    let wants_pcd = format == Format::Pcd && output == CloudFormat::Pcd;
    let wants_e57 = format == Format::E57 && output == CloudFormat::E57;
    if format != Format::Las && !wants_pcd && !wants_e57 {
        return Ok((read(path, opts)?, None));
    }
    let _span = tracing::debug_span!("read", path = %path.display()).entered();
    let (mut cloud, mut original) = if wants_e57 {
        let (loaded, file) = e57::read(path, true)?;
        let file = file.ok_or_else(|| Error::BadOutput {
            path: path.to_path_buf(),
            what: "the E57 reader kept no records for the E57 output".into(),
        })?;
        (loaded.cloud, Original::E57(file))
    } else if wants_pcd {
        let (loaded, pcd) = pcd::read_file(path, true)?;
        let pcd = pcd.ok_or_else(|| Error::BadOutput {
            path: path.to_path_buf(),
            what: "the PCD reader kept no records for the PCD output".into(),
        })?;
        (loaded.cloud, Original::Pcd(pcd))
    } else {
        let (loaded, lidar) = las::read_lidar(path, output.is_lidar())?;
        (loaded.cloud, Original::Lidar(lidar))
    };
    let keep: Vec<bool> = cloud.positions.iter().map(is_finite_point).collect();
    apply_non_finite(&mut cloud, opts.non_finite)?;
    if cloud.len() != keep.len() {
        original.retain_mask(&keep);
    }
    Ok((cloud, Some(original)))
}

fn is_finite_point(p: &[f64; 3]) -> bool {
    p.iter().all(|c| c.is_finite())
}

fn apply_non_finite(cloud: &mut Cloud, policy: NonFinite) -> Result<()> {
    let bad = cloud
        .positions
        .iter()
        .filter(|p| !is_finite_point(p))
        .count();
    if bad == 0 {
        return Ok(());
    }
    let path = cloud.source.path.clone();
    match policy {
        NonFinite::Reject => {
            let first = cloud
                .positions
                .iter()
                .position(|p| !is_finite_point(p))
                .unwrap_or(0);
            let p = cloud.positions[first];
            Err(Error::BadCloud {
                path,
                what: format!(
                    "point {first} (0-based, in file order) has a non-finite coordinate \
                     (x = {}, y = {}, z = {}); {bad} of {} points are NaN or infinite. \
                     Fix the file, or read it with non-finite points dropped",
                    p[0],
                    p[1],
                    p[2],
                    cloud.len()
                ),
            })
        }
        NonFinite::Drop => {
            let keep: Vec<bool> = cloud.positions.iter().map(is_finite_point).collect();
            let total = cloud.len();
            cloud.retain_mask(&keep);
            tracing::warn!(
                "{}: dropped {bad} of {total} points with NaN or infinite coordinates",
                path.display()
            );
            Ok(())
        }
    }
}

/// Decompresses an LZF buffer to exactly `size` bytes with sharpedge's own decoder (the one
/// PCD `binary_compressed` bodies go through). For the benchmark that measures it against
/// the `lzf` crate (examples/pcd_read.rs); not part of the supported API.
#[doc(hidden)]
pub fn lzf_decompress(input: &[u8], size: usize) -> std::result::Result<Vec<u8>, String> {
    lzf_stream::decompress(input, size).map_err(|e| e.to_string())
}

/// Reads a PLY file's vertices with ply-rs-bw's typed path only, never the hand-written
/// binary decoder that [`read`] uses for binary files. For the benchmark and the tests that
/// check the fast path against the crate; not part of the supported API.
#[doc(hidden)]
pub fn read_ply_via_crate(path: &Path) -> Result<Cloud> {
    Ok(ply::read(path, ply::VertexPath::Crate)?.cloud)
}

/// A property of the points as stored in the file.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct PropertyInfo {
    pub name: String,
    /// The stored type: a PLY type name (`float`, `uchar`, ...), `text` for text
    /// files, `int32 * 0.01 + 0` for scaled LAS coordinates.
    #[serde(rename = "type")]
    pub ty: String,
}

/// A non-point element of a file (PLY `face`, `edge`, ...), which the readers skip.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct ElementInfo {
    pub name: String,
    pub count: usize,
}

/// Axis-aligned bounding box of the finite points.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct BBox {
    pub min: [f64; 3],
    pub max: [f64; 3],
}

impl BBox {
    pub fn size(&self) -> [f64; 3] {
        [
            self.max[0] - self.min[0],
            self.max[1] - self.min[1],
            self.max[2] - self.min[2],
        ]
    }
}

/// One scan of an input that records how it was scanned (E57 point clouds, organised PCD),
/// as `sharpedge info` lists it.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ScanInfo {
    pub name: String,
    /// Points read from this scan (invalid records skipped).
    pub points: usize,
    /// The sensor position: the pose's translation.
    pub position: [f64; 3],
    /// The pose's rotation, a quaternion `[w, x, y, z]`.
    pub rotation: [f64; 4],
    /// `[rows, columns]` of a structured scan; `None` for an unstructured one.
    pub grid: Option<[u32; 2]>,
}

impl ScanInfo {
    /// The scans of a cloud's structure with their point counts (none without a structure).
    fn of(cloud: &Cloud) -> Vec<ScanInfo> {
        let Some(st) = &cloud.structure else {
            return Vec::new();
        };
        let mut counts = vec![0usize; st.scans.len()];
        for &s in &st.scan {
            counts[s as usize] += 1;
        }
        st.scans
            .iter()
            .zip(counts)
            .map(|(s, points)| ScanInfo {
                name: s.name.clone(),
                points,
                position: s.pose.translation,
                rotation: s.pose.rotation,
                grid: s.grid_size,
            })
            .collect()
    }
}

/// What `sharpedge info` prints (also as JSON).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct FileInfo {
    pub path: PathBuf,
    /// Human-readable format, as in `Cloud::source.format`.
    pub format: String,
    /// Number of points stored in the file (including non-finite ones).
    pub points: usize,
    /// Points with a NaN or infinite coordinate (counted, not in the bounding box).
    pub non_finite: usize,
    /// Finite points at exactly the position of an earlier point (`run` analyses each
    /// position once).
    pub duplicates: usize,
    /// x, y, z with their stored types, then every attribute the reader carries.
    pub properties: Vec<PropertyInfo>,
    /// Elements that are not points (faces, edges, ...): skipped by the reader.
    pub other_elements: Vec<ElementInfo>,
    /// Format-specific facts (label, value): a PCD's encoding, organisation (WIDTH x HEIGHT,
    /// NaN slots) and viewpoint.
    pub details: Vec<(String, String)>,
    /// Bounding box of the finite points; `None` when there are none.
    pub bbox: Option<BBox>,
    /// True when the coordinates need double precision (outputs are then written as double).
    pub double_precision: bool,
    /// Mean distance to the nearest neighbour (filled by the neighbours module; None here).
    pub mean_spacing: Option<f64>,
    /// The scans, for inputs that record them (E57, organised PCD); empty otherwise.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub scans: Vec<ScanInfo>,
}

impl std::fmt::Display for FileInfo {
    /// The text `sharpedge info` prints: one `label: value` line per fact.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        writeln!(f, "file:        {}", self.path.display())?;
        writeln!(f, "format:      {}", self.format)?;
        for (label, value) in &self.details {
            writeln!(f, "{:<12} {value}", format!("{label}:"))?;
        }
        write!(f, "points:      {}", self.points)?;
        if self.non_finite > 0 {
            write!(f, " ({} with NaN or infinite coordinates)", self.non_finite)?;
        }
        if self.duplicates > 0 {
            write!(
                f,
                " ({} at the position of an earlier point)",
                self.duplicates
            )?;
        }
        writeln!(f)?;
        let props: Vec<String> = self
            .properties
            .iter()
            .map(|p| format!("{} ({})", p.name, p.ty))
            .collect();
        writeln!(f, "properties:  {}", props.join(", "))?;
        if !self.other_elements.is_empty() {
            let els: Vec<String> = self
                .other_elements
                .iter()
                .map(|e| format!("{} {}", e.name, e.count))
                .collect();
            writeln!(f, "not read:    {}", els.join(", "))?;
        }
        if !self.scans.is_empty() {
            writeln!(f, "scans:       {}", self.scans.len())?;
        }
        for (i, s) in self.scans.iter().enumerate() {
            let [x, y, z] = s.position;
            let [qw, qx, qy, qz] = s.rotation;
            write!(
                f,
                "  scan {i} {:?}: {} points, sensor at ({x}, {y}, {z}), rotation \
                 (w {qw}, x {qx}, y {qy}, z {qz}), ",
                s.name, s.points
            )?;
            match s.grid {
                Some([r, c]) => writeln!(f, "structured {r} rows x {c} columns")?,
                None => writeln!(f, "unstructured")?,
            }
        }
        match &self.bbox {
            Some(b) => {
                let s = b.size();
                writeln!(f, "bbox min:    {} {} {}", b.min[0], b.min[1], b.min[2])?;
                writeln!(f, "bbox max:    {} {} {}", b.max[0], b.max[1], b.max[2])?;
                writeln!(f, "size:        {} {} {}", s[0], s[1], s[2])?;
            }
            None => writeln!(f, "bbox:        none (no finite points)")?,
        }
        writeln!(
            f,
            "precision:   {}",
            if self.double_precision {
                "double (the file is more precise than float at this magnitude)"
            } else {
                "float is enough"
            }
        )?;
        match self.mean_spacing {
            Some(s) => writeln!(f, "spacing:     {s} (mean nearest-neighbour distance)"),
            None => writeln!(f, "spacing:     none (fewer than two distinct points)"),
        }
    }
}

/// Describes a file: format, point count, duplicated points, properties with types, bounding
/// box, mean spacing (estimated on up to 100,000 distinct positions). Reads the whole file
/// (the bounding box and the non-finite count need every point).
pub fn describe(path: &Path) -> Result<FileInfo> {
    let loaded = load(path)?;
    let cloud = &loaded.cloud;
    let mut bbox: Option<BBox> = None;
    let mut non_finite = 0;
    for p in &cloud.positions {
        if !is_finite_point(p) {
            non_finite += 1;
            continue;
        }
        let b = bbox.get_or_insert(BBox { min: *p, max: *p });
        for (k, c) in p.iter().enumerate() {
            b.min[k] = b.min[k].min(*c);
            b.max[k] = b.max[k].max(*c);
        }
    }
    let finite: Vec<[f64; 3]> = cloud
        .positions
        .iter()
        .copied()
        .filter(is_finite_point)
        .collect();
    let distinct = crate::neighbours::Distinct::of(&finite)?;
    Ok(FileInfo {
        path: path.to_path_buf(),
        format: cloud.source.format.clone(),
        points: cloud.len(),
        non_finite,
        properties: loaded.properties,
        other_elements: loaded.other_elements,
        details: loaded.details,
        bbox,
        double_precision: cloud.source.double_precision,
        duplicates: finite.len() - distinct.len(),
        // Over distinct finite positions; a subsample keeps `info` quick on big files.
        mean_spacing: crate::neighbours::mean_spacing_of(&distinct, &finite, 100_000),
        scans: ScanInfo::of(cloud),
    })
}

/// Writes a file atomically: `f` writes into a buffered temporary file created in the
/// destination folder, which is renamed onto `path` only when `f` and the flush succeed. On
/// any failure the temporary file is removed and `path` is left as it was.
///
/// The guarantee is about failures of this process (errors, panics): the data is not
/// fsync'ed, so a power loss right after the rename can still lose it.
///
/// A destination that exists and is no regular file (`/dev/null`, another device, a FIFO) is
/// written in place: renaming onto it would replace the device by a regular file (run as
/// root, `bench --out /dev/null` once did, and every later write to /dev/null appended to
/// that file).
pub fn write_atomic(path: &Path, f: impl FnOnce(&mut dyn Write) -> Result<()>) -> Result<()> {
    write_atomic_file(path, |file| {
        let mut w = std::io::BufWriter::with_capacity(1 << 20, file);
        f(&mut w)?;
        w.flush()
            .map_err(|e| Error::io(path, "cannot write (disk full?)", e))
    })
}

/// `path` opened for writing when it exists and is neither a regular file nor a folder (a
/// device such as `/dev/null`, a FIFO): such a node is written in place, not replaced.
/// `None` for anything else (a missing path, a regular file, a folder: those take the
/// temporary file and the rename, which reports a folder).
fn open_special(path: &Path) -> Result<Option<std::fs::File>> {
    let Ok(meta) = std::fs::metadata(path) else {
        return Ok(None);
    };
    if meta.is_file() || meta.is_dir() {
        return Ok(None);
    }
    std::fs::OpenOptions::new()
        .write(true)
        .open(path)
        .map(Some)
        .map_err(|e| Error::io(path, "cannot open this device or pipe for writing", e))
}

/// A temporary file in the folder of `path`, readable like any output (0644).
fn temp_beside(path: &Path) -> Result<tempfile::NamedTempFile> {
    let dir = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    let mut builder = tempfile::Builder::new();
    builder.prefix(".sharpedge-").suffix(".part");
    // NamedTempFile defaults to mode 0600; outputs are ordinary files that colleagues and
    // viewers must be able to open, so ask for 0644 (the umask still applies).
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        builder.permissions(std::fs::Permissions::from_mode(0o644));
    }
    let tmp = builder.tempfile_in(dir).map_err(|e| {
        Error::io(
            path,
            "cannot create a temporary file in the output folder (does it exist, is it writable?)",
            e,
        )
    })?;
    // Held while the file is written, so that another run cleaning the folder
    // (`output_set::clean_stale`) tells a live writer's file from a killed one's; the kernel
    // releases it when this process ends, however. A file system without locks only means
    // such files are never taken for stale.
    let _ = tmp.as_file().try_lock();
    Ok(tmp)
}

/// Renames a finished temporary file onto `path`.
fn persist(tmp: tempfile::NamedTempFile, path: &Path) -> Result<()> {
    tmp.persist(path).map_err(|e| {
        Error::io(
            path,
            "cannot rename the finished temporary file to this name",
            e.error,
        )
    })?;
    Ok(())
}

/// Like [`write_atomic`], for writers that need a seekable file (the las writer rewrites the
/// header at the end): `f` gets the open temporary file, renamed onto `path` only when `f`
/// succeeds. `f` flushes what it buffers.
pub fn write_atomic_file(path: &Path, f: impl FnOnce(std::fs::File) -> Result<()>) -> Result<()> {
    if let Some(file) = open_special(path)? {
        return f(file);
    }
    let tmp = temp_beside(path)?;
    let file = tmp
        .as_file()
        .try_clone()
        .map_err(|e| Error::io(path, "cannot write", e))?;
    f(file)?;
    persist(tmp, path)
}

/// The distance between `v` and the next f32 towards infinity: the finest step f32 can store
/// at the magnitude of `v` (2^-149 near zero).
pub(crate) fn f32_step(v: f64) -> f64 {
    let a = v.abs() as f32;
    if !a.is_finite() {
        return f64::INFINITY;
    }
    let next = f32::from_bits(a.to_bits() + 1);
    f64::from(next) - f64::from(a)
}

/// Opens a file for reading, with the error naming the file.
pub(crate) fn open(path: &Path) -> Result<std::fs::File> {
    let file = std::fs::File::open(path).map_err(|e| Error::io(path, "cannot open", e))?;
    // Opening a directory succeeds on Unix; say what is wrong before a confusing read error.
    if file.metadata().map(|m| m.is_dir()).unwrap_or(false) {
        return Err(Error::io(
            path,
            "cannot read",
            std::io::Error::other("it is a directory, not a file"),
        ));
    }
    Ok(file)
}

/// A named attribute, for readers.
pub(crate) fn attribute(name: &str, values: crate::Column) -> Attribute {
    Attribute {
        name: name.to_string(),
        values,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[cfg(unix)]
    #[test]
    fn write_atomic_writes_into_a_fifo_and_leaves_it_a_fifo() {
        use std::io::Read;
        use std::os::unix::fs::FileTypeExt;
        let dir = tempfile::tempdir().unwrap();
        let fifo = dir.path().join("out.fifo");
        let made = std::process::Command::new("mkfifo").arg(&fifo).status();
        if !made.is_ok_and(|s| s.success()) {
            eprintln!("skipped: mkfifo is not available");
            return;
        }
        let reader = {
            let fifo = fifo.clone();
            std::thread::spawn(move || {
                let mut got = Vec::new();
                std::fs::File::open(&fifo)
                    .unwrap()
                    .read_to_end(&mut got)
                    .unwrap();
                got
            })
        };
        write_atomic(&fifo, |w| {
            w.write_all(b"through the pipe")
                .map_err(|e| Error::io(&fifo, "write", e))
        })
        .unwrap();
        // Checked before joining: a reader of a replaced FIFO would wait for a writer forever.
        let kind = std::fs::symlink_metadata(&fifo).unwrap().file_type();
        assert!(kind.is_fifo(), "the FIFO was replaced: {kind:?}");
        assert_eq!(reader.join().unwrap(), b"through the pipe");
        // No temporary file was left beside it.
        let names: Vec<_> = std::fs::read_dir(dir.path())
            .unwrap()
            .map(|e| e.unwrap().file_name())
            .collect();
        assert_eq!(names, vec![std::ffi::OsString::from("out.fifo")]);
    }

    #[test]
    fn format_by_extension_ignores_case_and_knows_copc() {
        assert_eq!(format_of(Path::new("a/B.PLY")).ok(), Some(Format::Ply));
        assert_eq!(format_of(Path::new("x.copc.laz")).ok(), Some(Format::Las));
        assert_eq!(format_of(Path::new("x.Las")).ok(), Some(Format::Las));
        assert_eq!(format_of(Path::new("x.pwn")).ok(), Some(Format::Xyz));
        let e = format_of(Path::new("dir/part.stl"))
            .unwrap_err()
            .to_string();
        assert!(
            e.starts_with("dir/part.stl: unknown file type \"stl\""),
            "{e}"
        );
        assert!(e.contains(".ply"), "{e}");
        let e = format_of(Path::new("fandisk.OFF")).unwrap_err().to_string();
        assert!(
            e.ends_with("a triangle mesh is sampled into a scan with `sharpedge synth --mesh FILE --out scan.ply`"),
            "{e}"
        );
        let e = format_of(Path::new("noext")).unwrap_err().to_string();
        assert!(e.contains("unknown file type \"\""), "{e}");
    }

    #[test]
    fn f32_step_matches_the_float_grid() {
        assert_eq!(f32_step(1.0), f64::from(f32::EPSILON));
        // At 512345 f32 keeps 2^19 * 2^-23 = 1/16 m steps: far coarser than a millimetre.
        assert_eq!(f32_step(512345.123), 0.03125);
        assert_eq!(f32_step(-4101234.567), 0.25);
        assert!(f32_step(0.0) > 0.0);
        assert_eq!(f32_step(1e300), f64::INFINITY);
    }

    #[test]
    fn non_finite_reject_names_the_first_bad_point() {
        let mut c = Cloud::from_positions(vec![[0.0; 3], [1.0, f64::NAN, 2.0], [f64::INFINITY; 3]]);
        c.source.path = "scan.ply".into();
        let e = apply_non_finite(&mut c, NonFinite::Reject)
            .unwrap_err()
            .to_string();
        assert!(e.starts_with("scan.ply: point 1 "), "{e}");
        assert!(e.contains("y = NaN"), "{e}");
        assert!(e.contains("2 of 3 points"), "{e}");
    }

    #[test]
    fn non_finite_drop_keeps_attributes_aligned() {
        let mut c = Cloud::from_positions(vec![[0.0; 3], [f64::NAN, 0.0, 0.0], [2.0; 3]]);
        c.attributes
            .push(attribute("id", crate::Column::I32(vec![10, 11, 12])));
        apply_non_finite(&mut c, NonFinite::Drop).unwrap();
        assert_eq!(c.positions, vec![[0.0; 3], [2.0; 3]]);
        assert_eq!(c.attributes[0].values, crate::Column::I32(vec![10, 12]));
    }
}
