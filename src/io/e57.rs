//! E57 (ASTM E2807), the exchange format of terrestrial and handheld laser scanners, read and
//! written through the `e57` crate; the records of a cartesian scan read for analysis are
//! decoded by our own decoder of the binary sections (src/io/e57_packets.rs: 10,000,000
//! points in 0.49-0.71 s where the crate's record iterator took 3.6-4.0 s on a busy machine),
//! with the crate's values and conversions, so the points are the same to the bit; spherical
//! scans, the records kept for an E57 output and any scan that decoder declines go through
//! the crate.
//!
//! Reading: every point cloud (scan) of the file, in file order, each moved into the file's
//! common frame by its pose (`p = R q + t`, the rotation from the scan's quaternion exactly as
//! the `e57` crate's simple reader computes it). Cartesian or spherical coordinates (spherical
//! converted as the crate does); records whose `cartesianInvalidState` /
//! `sphericalInvalidState` is not 0 (direction only, or no point) are skipped. Intensity and
//! colour become typed columns (`intensity`, `red`, `green`, `blue`, with the column type the
//! stored type needs). The scan structure is kept in [`Cloud::structure`]: one [`Scan`] per
//! point cloud (name, pose, `[rows, columns]` when it has row/column indices) and per point
//! its scan and grid cell.
//!
//! Writing ([`write_e57`], for `output.format = "e57"`): the reader then also keeps an
//! [`E57File`], every record of every scan as stored (typed raw columns) with the scan's
//! metadata. Each scan is written back as one point cloud with its pose, GUID, name, sensor
//! data and prototype (spherical stays spherical, scaled integers stay scaled integers); an
//! unmoved point's record is copied value for value (so it reads back bit-identical), a moved
//! point's coordinates are taken back into its scan's frame and encoded in the record's type.
//! Records that were no point (invalid) are written back unchanged.
//!
//! Hostile files: the header is checked before the crate reads anything (signature, length
//! against the real size, XML inside the file), each scan's claimed record count against the
//! bytes the file has, and every call into the crate runs under `catch_unwind`, so a panic
//! in it on damaged data becomes an error naming the file.

use std::io::{BufReader, Read, Seek};

use std::path::Path;

use e57::{E57Reader, E57Writer, PointCloud, RecordDataType, RecordName, RecordValue};

use super::e57_packets::{self, Batch};
use super::{Loaded, PropertyInfo, attribute};
use crate::cloud::{Cloud, Column, Pose, Scan, ScanStructure, Source};
use crate::error::{Error, Result};
use crate::progress::Progress;

/// The size of the fixed E57 file header.
const HEADER_LEN: u64 = 48;

/// A grid cell for points of an unstructured scan in a file whose other scans are structured
/// (`ScanStructure::grid` has one entry per point or none).
pub const NO_CELL: [u32; 2] = [u32::MAX, u32::MAX];

/// What an E57 input keeps for writing its rectified cloud back as E57.
#[derive(Debug, Clone)]
pub struct E57File {
    guid: String,
    coordinate_metadata: Option<String>,
    extensions: Vec<e57::Extension>,
    scans: Vec<ScanRecords>,
}

/// One scan's metadata and every record as the file stores it.
#[derive(Debug, Clone)]
struct ScanRecords {
    pc: PointCloud,
    rotation: [f64; 9],
    translation: [f64; 3],
    /// One column per prototype record, with every record (valid or not).
    columns: Vec<RawColumn>,
    /// Per record: whether it is a point of the cloud (valid and not dropped).
    taken: Vec<bool>,
}

/// The raw values of one prototype record: integers and scaled integers as the stored integer.
#[derive(Debug, Clone)]
enum RawColumn {
    F32(Vec<f32>),
    F64(Vec<f64>),
    Int(Vec<i64>),
}

impl RawColumn {
    fn new(dt: &RecordDataType) -> Self {
        match dt {
            RecordDataType::Single { .. } => RawColumn::F32(Vec::new()),
            RecordDataType::Double { .. } => RawColumn::F64(Vec::new()),
            RecordDataType::ScaledInteger { .. } | RecordDataType::Integer { .. } => {
                RawColumn::Int(Vec::new())
            }
        }
    }

    fn push(&mut self, v: &RecordValue) -> std::result::Result<(), String> {
        match (self, v) {
            (RawColumn::F32(c), RecordValue::Single(x)) => c.push(*x),
            (RawColumn::F64(c), RecordValue::Double(x)) => c.push(*x),
            (RawColumn::Int(c), RecordValue::Integer(x) | RecordValue::ScaledInteger(x)) => {
                c.push(*x)
            }
            (_, v) => return Err(format!("value {v:?} does not have the record's type")),
        }
        Ok(())
    }

    fn get(&self, i: usize, dt: &RecordDataType) -> RecordValue {
        match (self, dt) {
            (RawColumn::F32(c), _) => RecordValue::Single(c[i]),
            (RawColumn::F64(c), _) => RecordValue::Double(c[i]),
            (RawColumn::Int(c), RecordDataType::ScaledInteger { .. }) => {
                RecordValue::ScaledInteger(c[i])
            }
            (RawColumn::Int(c), _) => RecordValue::Integer(c[i]),
        }
    }
}

impl E57File {
    /// The number of scans (point clouds) of the input.
    pub fn scan_count(&self) -> usize {
        self.scans.len()
    }

    /// Marks the points whose `keep` flag is false (one flag per point of the cloud) as no
    /// longer points: they are written back unchanged.
    pub(crate) fn retain_mask(&mut self, keep: &[bool]) {
        let mut k = keep.iter();
        for s in &mut self.scans {
            for t in s.taken.iter_mut().filter(|t| **t) {
                *t = *k.next().unwrap_or(&true);
            }
        }
    }

    fn points(&self) -> usize {
        self.scans
            .iter()
            .map(|s| s.taken.iter().filter(|&&t| t).count())
            .sum()
    }
}

/// Runs a call into the e57 crate, turning a panic into an error naming the file: the crate
/// decodes bit-packed data whose sizes come from the file.
fn unpanicked<T>(path: &Path, place: &str, f: impl FnOnce() -> Result<T>) -> Result<T> {
    std::panic::catch_unwind(std::panic::AssertUnwindSafe(f)).map_err(|_| {
        Error::malformed(
            path,
            place,
            "the E57 decoder failed on this data (a panic in the e57 crate): the file is damaged",
        )
    })?
}

/// An error of the e57 crate as ours. Its messages say what is wrong ("Failed to read E57:
/// ... CRC ..."); the chain of sources is folded in because `main` prints one line.
fn e57_error(path: &Path, place: &str, e: e57::Error) -> Error {
    let mut what = e.to_string();
    let mut src = std::error::Error::source(&e);
    while let Some(s) = src {
        let s_text = s.to_string();
        if !what.contains(&s_text) {
            what = format!("{what}: {s_text}");
        }
        src = s.source();
    }
    // The crate reports a page whose CRC fails while reading a section as that section
    // "appears to be truncated"; say what the user must know first.
    if what.contains("invalid checksum") {
        what = format!(
            "a page of the file fails its CRC checksum, the file is damaged ({})",
            what.replace("File appears to be truncated: ", "")
        );
    }
    Error::malformed(path, place, what)
}

/// Checks the fixed header before the crate reads the file, so that a file that is no E57, a
/// truncated one or one whose XML lies outside it get a message saying so.
fn check_header(path: &Path, file: &mut std::fs::File, len: u64) -> Result<()> {
    let mut h = [0u8; HEADER_LEN as usize];
    if len < HEADER_LEN {
        return Err(Error::malformed(
            path,
            "header",
            format!("not an E57 file: {len} bytes, shorter than the 48-byte E57 header"),
        ));
    }
    file.read_exact(&mut h)
        .map_err(|e| Error::io(path, "cannot read", e))?;
    if &h[0..8] != b"ASTM-E57" {
        return Err(Error::malformed(
            path,
            "header",
            format!(
                "not an E57 file: it starts with {:?}, not \"ASTM-E57\"",
                String::from_utf8_lossy(&h[0..8])
            ),
        ));
    }
    let u64_at = |o: usize| {
        let mut b = [0u8; 8];
        b.copy_from_slice(&h[o..o + 8]);
        u64::from_le_bytes(b)
    };
    let (declared, xml_offset, xml_len) = (u64_at(16), u64_at(24), u64_at(32));
    if declared != len {
        return Err(Error::malformed(
            path,
            "header",
            if declared > len {
                format!(
                    "the header says the file has {declared} bytes but it has {len}: \
                     the file is truncated"
                )
            } else {
                format!(
                    "the header says the file has {declared} bytes but it has {len}: \
                     data was appended or the header is damaged"
                )
            },
        ));
    }
    // The XML's logical length is at most its physical extent (CRC pages add 4 bytes in 1024).
    if xml_offset >= len || xml_len > len - xml_offset {
        return Err(Error::malformed(
            path,
            "header",
            format!(
                "the XML section ({xml_len} bytes at byte {xml_offset}) lies outside the \
                 {len}-byte file"
            ),
        ));
    }
    file.rewind()
        .map_err(|e| Error::io(path, "cannot read", e))?;
    Ok(())
}

/// A buffered file reader whose seeks stay inside the buffer when they can. The e57 crate
/// seeks to every 1024-byte page before reading it, and `BufReader::seek` always drops its
/// buffer: through a plain `BufReader` of 64 KB each page cost a 64 KB read (a third of the
/// reading time of a 10M-point file went into the kernel copying those).
struct PageReader {
    inner: BufReader<std::fs::File>,
    pos: u64,
}

impl PageReader {
    fn new(file: std::fs::File) -> Self {
        PageReader {
            inner: BufReader::with_capacity(1 << 16, file),
            pos: 0,
        }
    }
}

impl Read for PageReader {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        let n = self.inner.read(buf)?;
        self.pos += n as u64;
        Ok(n)
    }
}

impl Seek for PageReader {
    fn seek(&mut self, to: std::io::SeekFrom) -> std::io::Result<u64> {
        let target = match to {
            std::io::SeekFrom::Start(p) => i128::from(p),
            std::io::SeekFrom::Current(d) => i128::from(self.pos) + i128::from(d),
            std::io::SeekFrom::End(_) => {
                self.pos = self.inner.seek(to)?;
                return Ok(self.pos);
            }
        };
        let delta = i64::try_from(target - i128::from(self.pos)).map_err(|_| {
            std::io::Error::new(std::io::ErrorKind::InvalidInput, "seek out of range")
        })?;
        if target < 0 {
            return Err(std::io::Error::new(
                std::io::ErrorKind::InvalidInput,
                "seek before the start of the file",
            ));
        }
        // Keeps the buffer when the target is inside it.
        self.inner.seek_relative(delta)?;
        self.pos = target as u64;
        Ok(self.pos)
    }
}

/// Bits one record of this prototype takes in the file (as the crate packs them).
fn record_bits(proto: &[e57::Record]) -> u64 {
    let int_bits = |min: i64, max: i64| {
        let range = i128::from(max) - i128::from(min);
        if range > 0 {
            u64::from(range.ilog2()) + 1
        } else {
            0
        }
    };
    proto
        .iter()
        .map(|r| match r.data_type {
            RecordDataType::Single { .. } => 32,
            RecordDataType::Double { .. } => 64,
            RecordDataType::ScaledInteger { min, max, .. }
            | RecordDataType::Integer { min, max } => int_bits(min, max),
        })
        .sum()
}

/// A value of a record as f64 (scaled integers scaled), as the crate's `to_f64` does.
#[inline]
fn value_f64(v: &RecordValue, dt: &RecordDataType) -> f64 {
    match (v, dt) {
        (RecordValue::Single(s), _) => f64::from(*s),
        (RecordValue::Double(d), _) => *d,
        (RecordValue::ScaledInteger(i), RecordDataType::ScaledInteger { scale, offset, .. }) => {
            *i as f64 * scale + offset
        }
        (RecordValue::ScaledInteger(i) | RecordValue::Integer(i), _) => *i as f64,
    }
}

/// A state or index value as an integer (a float one truncated, as the crate's `to_i64`).
#[inline]
fn value_i64(v: &RecordValue, dt: &RecordDataType) -> i64 {
    match v {
        RecordValue::Integer(i) => *i,
        _ => value_f64(v, dt) as i64,
    }
}

/// The rotation matrix of an E57 pose, laid out and computed exactly as the e57 crate's
/// simple reader does (so a point here equals the crate's to the bit).
fn rotation_of(pc: &PointCloud) -> ([f64; 9], [f64; 3], Pose) {
    let t = pc.transform.clone().unwrap_or_default();
    let q = &t.rotation;
    let m = [
        q.w * q.w + q.x * q.x - q.y * q.y - q.z * q.z,
        2.0 * (q.x * q.y + q.w * q.z),
        2.0 * (q.x * q.z - q.w * q.y),
        2.0 * (q.x * q.y - q.w * q.z),
        q.w * q.w + q.y * q.y - q.x * q.x - q.z * q.z,
        2.0 * (q.y * q.z + q.w * q.x),
        2.0 * (q.x * q.z + q.w * q.y),
        2.0 * (q.y * q.z - q.w * q.x),
        q.w * q.w + q.z * q.z - q.x * q.x - q.y * q.y,
    ];
    let tr = [t.translation.x, t.translation.y, t.translation.z];
    let pose = Pose {
        rotation: [q.w, q.x, q.y, q.z],
        translation: tr,
    };
    (m, tr, pose)
}

#[inline]
fn to_cloud(m: &[f64; 9], t: &[f64; 3], q: [f64; 3]) -> [f64; 3] {
    let [x, y, z] = q;
    [
        m[0] * x + m[3] * y + m[6] * z + t[0],
        m[1] * x + m[4] * y + m[7] * z + t[1],
        m[2] * x + m[5] * y + m[8] * z + t[2],
    ]
}

/// The inverse of [`to_cloud`]: a point of the cloud in the scan's own frame. `None` when the
/// pose's rotation is singular (a zero quaternion).
fn to_scan(m: &[f64; 9], t: &[f64; 3], p: [f64; 3]) -> Option<[f64; 3]> {
    // `to_cloud` applies the matrix whose columns are m[0..3], m[3..6], m[6..9].
    let a = nalgebra::Matrix3::new(m[0], m[3], m[6], m[1], m[4], m[7], m[2], m[5], m[8]);
    let inv = a.try_inverse()?;
    let v = inv * nalgebra::Vector3::new(p[0] - t[0], p[1] - t[1], p[2] - t[2]);
    Some([v[0], v[1], v[2]])
}

/// Where each record a reader needs sits in the prototype.
#[derive(Default)]
struct Slots {
    cartesian: Option<[usize; 3]>,
    cartesian_invalid: Option<usize>,
    spherical: Option<[usize; 3]>,
    spherical_invalid: Option<usize>,
    intensity: Option<usize>,
    color: Option<[usize; 3]>,
    grid: Option<[usize; 2]>,
}

impl Slots {
    fn of(proto: &[e57::Record]) -> Self {
        let at = |n: RecordName| proto.iter().position(|r| r.name == n);
        let three = |a, b, c| match (at(a), at(b), at(c)) {
            (Some(a), Some(b), Some(c)) => Some([a, b, c]),
            _ => None,
        };
        Slots {
            cartesian: three(
                RecordName::CartesianX,
                RecordName::CartesianY,
                RecordName::CartesianZ,
            ),
            cartesian_invalid: at(RecordName::CartesianInvalidState),
            spherical: three(
                RecordName::SphericalRange,
                RecordName::SphericalAzimuth,
                RecordName::SphericalElevation,
            ),
            spherical_invalid: at(RecordName::SphericalInvalidState),
            intensity: at(RecordName::Intensity),
            color: three(
                RecordName::ColorRed,
                RecordName::ColorGreen,
                RecordName::ColorBlue,
            ),
            grid: match (at(RecordName::RowIndex), at(RecordName::ColumnIndex)) {
                (Some(r), Some(c)) => Some([r, c]),
                _ => None,
            },
        }
    }
}

/// The column type that holds every value of a record's type.
fn column_kind(dt: &RecordDataType) -> Column {
    match *dt {
        RecordDataType::Single { .. } => Column::F32(Vec::new()),
        RecordDataType::Integer { min, max } if min >= 0 && max <= 255 => Column::U8(Vec::new()),
        RecordDataType::Integer { min, max } if min >= 0 && max <= 65_535 => {
            Column::U16(Vec::new())
        }
        RecordDataType::Integer { min, max }
            if min >= i64::from(i32::MIN) && max <= i64::from(i32::MAX) =>
        {
            Column::I32(Vec::new())
        }
        RecordDataType::Integer { min, max } if min >= 0 && max <= i64::from(u32::MAX) => {
            Column::U32(Vec::new())
        }
        _ => Column::F64(Vec::new()),
    }
}

/// Appends a value to a column made by [`column_kind`] for a compatible type (the value fits:
/// the crate checks integers against the record's range). A scan without the record gets 0.
#[inline]
fn push_value(col: &mut Column, v: Option<(&RecordValue, &RecordDataType)>) {
    let i = || v.map_or(0, |(v, dt)| value_i64(v, dt));
    let f = || v.map_or(0.0, |(v, dt)| value_f64(v, dt));
    match col {
        Column::U8(c) => c.push(i() as u8),
        Column::U16(c) => c.push(i() as u16),
        Column::I32(c) => c.push(i() as i32),
        Column::U32(c) => c.push(i() as u32),
        Column::F32(c) => c.push(f() as f32),
        Column::F64(c) => c.push(f()),
        Column::I8(c) => c.push(i() as i8),
        Column::I16(c) => c.push(i() as i16),
    }
}

/// Reserves room for `n` values, so that a big scan's columns do not grow by copying.
fn reserve(col: &mut Column, n: usize) {
    match col {
        Column::U8(c) => c.reserve(n),
        Column::U16(c) => c.reserve(n),
        Column::I32(c) => c.reserve(n),
        Column::U32(c) => c.reserve(n),
        Column::F32(c) => c.reserve(n),
        Column::F64(c) => c.reserve(n),
        Column::I8(c) => c.reserve(n),
        Column::I16(c) => c.reserve(n),
    }
}

/// The column type for a property over all scans: one type when they agree, f64 otherwise.
fn common_kind(pcs: &[PointCloud], slot: impl Fn(&Slots) -> Option<usize>) -> Option<Column> {
    let mut kind: Option<Column> = None;
    for pc in pcs {
        if let Some(i) = slot(&Slots::of(&pc.prototype)) {
            let k = column_kind(&pc.prototype[i].data_type);
            kind = Some(match kind {
                Some(prev) if std::mem::discriminant(&prev) != std::mem::discriminant(&k) => {
                    Column::F64(Vec::new())
                }
                Some(prev) => prev,
                None => k,
            });
        }
    }
    kind
}

fn type_text(dt: &RecordDataType) -> String {
    match dt {
        RecordDataType::Single { .. } => "float".into(),
        RecordDataType::Double { .. } => "double".into(),
        RecordDataType::ScaledInteger {
            min,
            max,
            scale,
            offset,
        } => format!("int[{min}, {max}] * {scale} + {offset}"),
        RecordDataType::Integer { min, max } => format!("int[{min}, {max}]"),
    }
}

fn record_name(r: &e57::Record) -> String {
    match &r.name {
        RecordName::Unknown { namespace, name } => format!("{namespace}:{name}"),
        n => {
            // The E57 tag names (`cartesianX`, ...), which the crate keeps private.
            let debug = format!("{n:?}");
            let mut c = debug.chars();
            c.next()
                .map(|f| f.to_ascii_lowercase().to_string() + c.as_str())
                .unwrap_or_default()
        }
    }
}

/// The values of record `rec` of a batch as f64, as [`value_f64`] gives them (scaled
/// integers scaled; a record of 0 bits is its `min`).
fn batch_f64(b: &Batch, rec: usize, dt: &RecordDataType, out: &mut Vec<f64>) {
    out.clear();
    let raw = b.values[rec];
    let int = |i: usize, min: i64| raw.map_or(min, |v| (i128::from(min) + i128::from(v[i])) as i64);
    match *dt {
        RecordDataType::Single { .. } => out.extend(
            raw.unwrap_or(&[])
                .iter()
                .map(|&v| f64::from(f32::from_bits(v as u32))),
        ),
        RecordDataType::Double { .. } => {
            out.extend(raw.unwrap_or(&[]).iter().map(|&v| f64::from_bits(v)))
        }
        RecordDataType::ScaledInteger {
            min, scale, offset, ..
        } => out.extend((0..b.len).map(|i| int(i, min) as f64 * scale + offset)),
        RecordDataType::Integer { min, .. } => out.extend((0..b.len).map(|i| int(i, min) as f64)),
    }
    // Floats never have 0 bits; keep the batch's length whatever the prototype says.
    out.resize(b.len, 0.0);
}

/// The values of record `rec` of a batch as integers, as [`value_i64`] gives them.
fn batch_i64(b: &Batch, rec: usize, dt: &RecordDataType, out: &mut Vec<i64>, f: &mut Vec<f64>) {
    out.clear();
    if let RecordDataType::Integer { min, .. } = *dt {
        let raw = b.values[rec];
        out.extend(
            (0..b.len).map(|i| raw.map_or(min, |v| (i128::from(min) + i128::from(v[i])) as i64)),
        );
    } else {
        batch_f64(b, rec, dt, f);
        out.extend(f.iter().map(|&v| v as i64));
    }
}

/// Appends the values of the `valid` records of a batch to a column as [`push_value`] does
/// (0 when the scan has no such record).
fn push_batch(
    col: &mut Column,
    b: &Batch,
    rec: Option<(usize, &RecordDataType)>,
    valid: &[u32],
    ints: &mut Vec<i64>,
    floats: &mut Vec<f64>,
) {
    let float_col = matches!(col, Column::F32(_) | Column::F64(_));
    match rec {
        Some((r, dt)) if float_col => batch_f64(b, r, dt, floats),
        Some((r, dt)) => batch_i64(b, r, dt, ints, floats),
        None => {
            floats.clear();
            floats.resize(b.len, 0.0);
            ints.clear();
            ints.resize(b.len, 0);
        }
    }
    let (iv, fv) = (&*ints, &*floats);
    let at = valid.iter().map(|&i| i as usize);
    match col {
        Column::U8(c) => c.extend(at.map(|i| iv[i] as u8)),
        Column::U16(c) => c.extend(at.map(|i| iv[i] as u16)),
        Column::I32(c) => c.extend(at.map(|i| iv[i] as i32)),
        Column::U32(c) => c.extend(at.map(|i| iv[i] as u32)),
        Column::I8(c) => c.extend(at.map(|i| iv[i] as i8)),
        Column::I16(c) => c.extend(at.map(|i| iv[i] as i16)),
        Column::F32(c) => c.extend(at.map(|i| fv[i] as f32)),
        Column::F64(c) => c.extend(at.map(|i| fv[i])),
    }
}

fn truncate(col: &mut Column, n: usize) {
    match col {
        Column::U8(c) => c.truncate(n),
        Column::U16(c) => c.truncate(n),
        Column::I32(c) => c.truncate(n),
        Column::U32(c) => c.truncate(n),
        Column::F32(c) => c.truncate(n),
        Column::F64(c) => c.truncate(n),
        Column::I8(c) => c.truncate(n),
        Column::I16(c) => c.truncate(n),
    }
}

/// The columns a scan's points are appended to.
struct Sinks<'a> {
    positions: &'a mut Vec<[f64; 3]>,
    scan_of: &'a mut Vec<u32>,
    /// `Some` when some scan of the file has row/column indices.
    grid: Option<&'a mut Vec<[u32; 2]>>,
    intensity: Option<&'a mut Column>,
    color: Option<&'a mut [Column; 3]>,
}

/// Reads scan `s` (cartesian, not spherical) with [`e57_packets::decode_scan`], appending
/// its valid points to `out` exactly as the crate path does (the same values, conversions
/// and pose): the row and column extent when it has them. `None` when the decoder declines
/// the scan; the columns are then as they were and the caller reads it with the crate.
#[allow(clippy::too_many_arguments)]
fn read_scan_fast(
    path: &Path,
    file: &mut std::fs::File,
    len: u64,
    pc: &PointCloud,
    s: usize,
    slots: &Slots,
    m: &[f64; 9],
    t: &[f64; 3],
    out: &mut Sinks,
    progress: &Progress,
) -> Result<Option<[u32; 2]>> {
    let Some([x, y, z]) = slots.cartesian else {
        return Ok(None);
    };
    if slots.spherical.is_some() {
        return Ok(None);
    }
    let proto = &pc.prototype;
    let dt = |r: usize| &proto[r].data_type;
    let start = out.positions.len();
    let start_grid = out.grid.as_ref().map_or(0, |g| g.len());
    let mut max_cell = [0u32; 2];
    let mut first = 0u64;
    let (mut xs, mut ys, mut zs) = (Vec::new(), Vec::new(), Vec::new());
    let (mut ints, mut floats, mut ints2) = (Vec::new(), Vec::new(), Vec::new());
    let mut valid: Vec<u32> = Vec::new();
    let mut convert = |b: &Batch| -> Result<()> {
        batch_f64(b, x, dt(x), &mut xs);
        batch_f64(b, y, dt(y), &mut ys);
        batch_f64(b, z, dt(z), &mut zs);
        valid.clear();
        match slots.cartesian_invalid {
            Some(r) => {
                batch_i64(b, r, dt(r), &mut ints, &mut floats);
                valid.extend((0..b.len as u32).filter(|&i| ints[i as usize] == 0));
            }
            None => valid.extend(0..b.len as u32),
        }
        out.positions.extend(valid.iter().map(|&i| {
            let i = i as usize;
            to_cloud(m, t, [xs[i], ys[i], zs[i]])
        }));
        out.scan_of
            .extend(std::iter::repeat_n(s as u32, valid.len()));
        if let Some(c) = out.intensity.as_deref_mut() {
            let rec = slots.intensity.map(|r| (r, dt(r)));
            push_batch(c, b, rec, &valid, &mut ints, &mut floats);
        }
        if let Some(cs) = out.color.as_deref_mut() {
            for (k, c) in cs.iter_mut().enumerate() {
                let rec = slots.color.map(|rs| (rs[k], dt(rs[k])));
                push_batch(c, b, rec, &valid, &mut ints, &mut floats);
            }
        }
        if let Some(g) = out.grid.as_deref_mut() {
            match slots.grid {
                Some([ri, ci]) => {
                    batch_i64(b, ri, dt(ri), &mut ints, &mut floats);
                    batch_i64(b, ci, dt(ci), &mut ints2, &mut floats);
                    for &i in &valid {
                        let i = i as usize;
                        let cell = |v: i64, what: &str| {
                            u32::try_from(v)
                                .ok()
                                .filter(|&v| v < u32::MAX)
                                .ok_or_else(|| {
                                    Error::malformed(
                                        path,
                                        format!("scan {s}, record {}", first + i as u64),
                                        format!("{what} index {v} is negative or too large"),
                                    )
                                })
                        };
                        let c = [cell(ints[i], "row")?, cell(ints2[i], "column")?];
                        max_cell = [max_cell[0].max(c[0]), max_cell[1].max(c[1])];
                        g.push(c);
                    }
                }
                None => g.extend(std::iter::repeat_n(NO_CELL, valid.len())),
            }
        }
        progress.inc(valid.len() as u64);
        first += b.len as u64;
        Ok(())
    };
    // One thread: a second one unpacking packets while this one converts was slower on a
    // busy 2-core machine (0.81-1.02 s against 0.49-0.71 s for 10,000,000 points, five
    // alternating runs), as was a converting thread beside the crate's decoding before.
    let decoded = e57_packets::decode_scan(file, len, pc, &mut convert)?;
    if decoded.is_none() {
        out.positions.truncate(start);
        out.scan_of.truncate(start);
        if let Some(g) = out.grid.as_deref_mut() {
            g.truncate(start_grid);
        }
        for c in out
            .intensity
            .iter_mut()
            .map(|c| &mut **c)
            .chain(out.color.iter_mut().flat_map(|c| c.iter_mut()))
        {
            truncate(c, start);
        }
        return Ok(None);
    }
    Ok(Some(max_cell))
}

/// Reads an E57 file: the cloud (see the module comment) and, when `keep_records`, the
/// [`E57File`] a writer needs.
pub(crate) fn read(path: &Path, keep_records: bool) -> Result<(Loaded, Option<E57File>)> {
    unpanicked(path, "file", || read_inner(path, keep_records))
}

fn read_inner(path: &Path, keep_records: bool) -> Result<(Loaded, Option<E57File>)> {
    let mut file = super::open(path)?;
    let len = file
        .metadata()
        .map_err(|e| Error::io(path, "cannot read", e))?
        .len();
    check_header(path, &mut file, len)?;
    // A handle of its own (its own offset) for the scans read by our own decoder
    // (src/io/e57_packets.rs).
    let mut fast_file = super::open(path)?;
    let mut reader =
        E57Reader::new(PageReader::new(file)).map_err(|e| e57_error(path, "header and XML", e))?;
    let pcs = reader.pointclouds();
    let total_records: u64 = pcs.iter().map(|pc| pc.records).sum();
    // A record of b bits needs b bits of data, and all scans share the file; a record of 0
    // bits (constants only) counts as 1. So a lying count cannot make us reserve what the
    // file cannot back: at most 8 records per byte, for such degenerate prototypes only.
    let mut claimed_bits = 0u64;
    for (s, pc) in pcs.iter().enumerate() {
        let bits = record_bits(&pc.prototype).max(1);
        claimed_bits = claimed_bits.saturating_add(pc.records.saturating_mul(bits));
        if claimed_bits > len.saturating_mul(8) {
            return Err(Error::malformed(
                path,
                format!("scan {s}"),
                format!(
                    "the scan claims {} records of {bits} bits, which with the scans before \
                     it is more than the {len}-byte file can hold",
                    pc.records
                ),
            ));
        }
    }
    let n_cap = usize::try_from(total_records).unwrap_or(usize::MAX);

    let intensity_kind = common_kind(&pcs, |s| s.intensity);
    let color_kind = pcs
        .iter()
        .any(|pc| Slots::of(&pc.prototype).color.is_some())
        .then(|| {
            let k = |c: usize| common_kind(&pcs, move |s| s.color.map(|x| x[c]));
            [k(0), k(1), k(2)]
        });
    let mut intensity = intensity_kind;
    let mut color = color_kind.map(|c| c.map(|k| k.unwrap_or(Column::F64(Vec::new()))));
    for c in intensity.iter_mut().chain(color.iter_mut().flatten()) {
        reserve(c, n_cap);
    }
    let any_grid = pcs.iter().any(|pc| Slots::of(&pc.prototype).grid.is_some());

    let mut positions: Vec<[f64; 3]> = Vec::with_capacity(n_cap);
    let mut scan_of: Vec<u32> = Vec::with_capacity(n_cap);
    let mut grid: Vec<[u32; 2]> = if any_grid {
        Vec::with_capacity(n_cap)
    } else {
        Vec::new()
    };
    let mut scans = Vec::with_capacity(pcs.len());
    let mut kept = Vec::new();
    let progress = if total_records >= super::PROGRESS_MIN_POINTS {
        Progress::start("read", total_records, "points")
    } else {
        Progress::hidden()
    };
    for (s, pc) in pcs.iter().enumerate() {
        let place = format!("scan {s}");
        let slots = Slots::of(&pc.prototype);
        if slots.cartesian.is_none() && slots.spherical.is_none() {
            return Err(Error::malformed(
                path,
                place,
                "the scan has neither cartesian nor spherical coordinates",
            ));
        }
        let (m, t, pose) = rotation_of(pc);
        let proto = &pc.prototype;
        let mut records = keep_records.then(|| {
            let columns: Vec<RawColumn> =
                proto.iter().map(|r| RawColumn::new(&r.data_type)).collect();
            (columns, Vec::new())
        });
        let mut max_cell = [0u32; 2];
        let fast = if keep_records {
            None
        } else {
            let mut sinks = Sinks {
                positions: &mut positions,
                scan_of: &mut scan_of,
                grid: any_grid.then_some(&mut grid),
                intensity: intensity.as_mut(),
                color: color.as_mut(),
            };
            read_scan_fast(
                path,
                &mut fast_file,
                len,
                pc,
                s,
                &slots,
                &m,
                &t,
                &mut sinks,
                &progress,
            )?
        };
        if let Some(cells) = fast {
            max_cell = cells;
        } else {
            let iter = reader
                .pointcloud_raw(pc)
                .map_err(|e| e57_error(path, &place, e))?;
            for (r, values) in iter.enumerate() {
                let values =
                    values.map_err(|e| e57_error(path, &format!("{place}, record {r}"), e))?;
                let state = |slot: Option<usize>| {
                    slot.map_or(0, |i| value_i64(&values[i], &proto[i].data_type))
                };
                let f = |i: usize| value_f64(&values[i], &proto[i].data_type);
                let q = match (slots.cartesian, slots.spherical) {
                    (Some([x, y, z]), _) if state(slots.cartesian_invalid) == 0 => {
                        Some([f(x), f(y), f(z)])
                    }
                    (_, Some([ra, az, el])) if state(slots.spherical_invalid) == 0 => {
                        let (range, azimuth, elevation) = (f(ra), f(az), f(el));
                        let cos_ele = elevation.cos();
                        Some([
                            range * cos_ele * azimuth.cos(),
                            range * cos_ele * azimuth.sin(),
                            range * elevation.sin(),
                        ])
                    }
                    _ => None,
                };
                if let Some((columns, taken)) = &mut records {
                    for (c, v) in columns.iter_mut().zip(&values) {
                        c.push(v).map_err(|w| {
                            Error::malformed(path, format!("{place}, record {r}"), w)
                        })?;
                    }
                    taken.push(q.is_some());
                }
                let Some(q) = q else { continue };
                positions.push(to_cloud(&m, &t, q));
                scan_of.push(s as u32);
                if let Some(c) = &mut intensity {
                    push_value(
                        c,
                        slots.intensity.map(|i| (&values[i], &proto[i].data_type)),
                    );
                }
                if let Some(cs) = &mut color {
                    for (k, c) in cs.iter_mut().enumerate() {
                        push_value(
                            c,
                            slots.color.map(|x| (&values[x[k]], &proto[x[k]].data_type)),
                        );
                    }
                }
                if any_grid {
                    let cell = match slots.grid {
                        Some([ri, ci]) => {
                            let cell = |i: usize, what: &str| {
                                let v = value_i64(&values[i], &proto[i].data_type);
                                u32::try_from(v)
                                    .ok()
                                    .filter(|&v| v < u32::MAX)
                                    .ok_or_else(|| {
                                        Error::malformed(
                                            path,
                                            format!("{place}, record {r}"),
                                            format!("{what} index {v} is negative or too large"),
                                        )
                                    })
                            };
                            let c = [cell(ri, "row")?, cell(ci, "column")?];
                            max_cell = [max_cell[0].max(c[0]), max_cell[1].max(c[1])];
                            c
                        }
                        None => NO_CELL,
                    };
                    grid.push(cell);
                }
                if positions.len().is_multiple_of(65_536) {
                    progress.inc(65_536);
                }
            }
        }
        let name = pc
            .name
            .clone()
            .or_else(|| pc.guid.clone())
            .unwrap_or_else(|| format!("scan {s}"));
        let rows_cols = slots
            .grid
            .map(|_| [max_cell[0].saturating_add(1), max_cell[1].saturating_add(1)]);
        scans.push(Scan {
            name,
            pose,
            grid_size: rows_cols,
        });
        if let Some((columns, taken)) = records {
            if taken.len() as u64 != pc.records {
                return Err(Error::malformed(
                    path,
                    place,
                    format!("{} of {} records could be read", taken.len(), pc.records),
                ));
            }
            kept.push(ScanRecords {
                pc: pc.clone(),
                rotation: m,
                translation: t,
                columns,
                taken,
            });
        }
    }
    drop(progress);

    let mut attributes = Vec::new();
    if let Some(c) = intensity {
        attributes.push(attribute("intensity", c));
    }
    if let Some([r, g, b]) = color {
        attributes.push(attribute("red", r));
        attributes.push(attribute("green", g));
        attributes.push(attribute("blue", b));
    }
    let mut properties: Vec<PropertyInfo> = Vec::new();
    for pc in &pcs {
        for r in &pc.prototype {
            let name = record_name(r);
            if !properties.iter().any(|p| p.name == name) {
                properties.push(PropertyInfo {
                    name,
                    ty: type_text(&r.data_type),
                });
            }
        }
    }
    let double_precision = pcs.iter().any(|pc| {
        pc.prototype.iter().any(|r| {
            matches!(
                r.name,
                RecordName::CartesianX
                    | RecordName::CartesianY
                    | RecordName::CartesianZ
                    | RecordName::SphericalRange
            ) && !matches!(r.data_type, RecordDataType::Single { .. })
        })
    }) || scans.iter().any(|s| s.pose != Pose::default());
    let n_points = positions.len();
    let skipped = total_records.saturating_sub(n_points as u64);
    let format = format!(
        "E57 1.0, {} scan{}, {total_records} records ({skipped} invalid skipped)",
        scans.len(),
        if scans.len() == 1 { "" } else { "s" },
    );
    let file = keep_records.then(|| E57File {
        guid: reader.guid().to_string(),
        coordinate_metadata: reader.coordinate_metadata().map(str::to_string),
        extensions: reader.extensions(),
        scans: kept,
    });
    let loaded = Loaded {
        cloud: Cloud {
            positions,
            attributes,
            source: Source {
                path: path.to_path_buf(),
                format,
                double_precision,
            },
            structure: Some(ScanStructure {
                scans,
                scan: scan_of,
                grid,
            }),
        },
        properties,
        other_elements: Vec::new(),
        // The scans are described from the cloud's structure (`FileInfo::scans`).
        details: Vec::new(),
    };
    Ok((loaded, file))
}

/// Encodes a coordinate in a record's type (scaled integers rounded to the nearest step).
fn encode(dt: &RecordDataType, v: f64) -> Option<RecordValue> {
    let int = |x: f64| (x.is_finite() && x.abs() < 9.0e18).then(|| x.round() as i64);
    match dt {
        RecordDataType::Single { .. } => Some(RecordValue::Single(v as f32)),
        RecordDataType::Double { .. } => Some(RecordValue::Double(v)),
        RecordDataType::ScaledInteger { scale, offset, .. } => {
            int((v - offset) / scale).map(RecordValue::ScaledInteger)
        }
        RecordDataType::Integer { .. } => int(v).map(RecordValue::Integer),
    }
}

/// Widens a record type's declared range so that `v` (a moved point's new value) fits: the
/// sharpened corner of a part lies outside the rounded scan's bounds. Stored integers decode
/// the same whatever the range.
fn widen(dt: &mut RecordDataType, v: &RecordValue) {
    match (dt, v) {
        (
            RecordDataType::ScaledInteger { min, max, .. } | RecordDataType::Integer { min, max },
            RecordValue::ScaledInteger(i) | RecordValue::Integer(i),
        ) => {
            *min = (*min).min(*i);
            *max = (*max).max(*i);
        }
        (RecordDataType::Single { min, max }, RecordValue::Single(x)) => {
            *min = min.map(|m| m.min(*x));
            *max = max.map(|m| m.max(*x));
        }
        (RecordDataType::Double { min, max }, RecordValue::Double(x)) => {
            *min = min.map(|m| m.min(*x));
            *max = max.map(|m| m.max(*x));
        }
        _ => {}
    }
}

/// Gives the state and flag records the ranges the e57 writer insists on (invalid states
/// [0, 2], `is*Invalid` flags [0, 1]) when the file declares a narrower one: libE57Format
/// writes `cartesianInvalidState` as [0, 1] when no record is invalid. The values stay the
/// same; only the declared range (and so the bits per value) changes.
fn flag_ranges(proto: &mut [e57::Record]) {
    for r in proto {
        let want = match r.name {
            RecordName::CartesianInvalidState | RecordName::SphericalInvalidState => 2,
            RecordName::IsColorInvalid
            | RecordName::IsIntensityInvalid
            | RecordName::IsTimeStampInvalid => 1,
            _ => continue,
        };
        if let RecordDataType::Integer { min, max } = &mut r.data_type
            && *min >= 0
            && *max <= want
        {
            (*min, *max) = (0, want);
        }
    }
}

/// The new stored values of a moved point, `q` in its scan's frame: the cartesian and
/// spherical coordinates the prototype has. The azimuth is taken in the turn of the old one
/// (a file may store azimuths in [0, 2π) or (-π, π]).
fn moved_values(
    proto: &[e57::Record],
    slots: &Slots,
    old: &dyn Fn(usize) -> f64,
    q: [f64; 3],
) -> Option<Vec<(usize, RecordValue)>> {
    let mut out = Vec::with_capacity(6);
    if let Some(ix) = slots.cartesian {
        for (k, i) in ix.into_iter().enumerate() {
            out.push((i, encode(&proto[i].data_type, q[k])?));
        }
    }
    if let Some([ra, az, el]) = slots.spherical {
        let range = (q[0] * q[0] + q[1] * q[1] + q[2] * q[2]).sqrt();
        let mut azimuth = q[1].atan2(q[0]);
        let turn = std::f64::consts::TAU;
        azimuth += ((old(az) - azimuth) / turn).round() * turn;
        let elevation = if range > 0.0 {
            (q[2] / range).clamp(-1.0, 1.0).asin()
        } else {
            0.0
        };
        out.push((ra, encode(&proto[ra].data_type, range)?));
        out.push((az, encode(&proto[az].data_type, azimuth)?));
        out.push((el, encode(&proto[el].data_type, elevation)?));
    }
    Some(out)
}

/// How one scan is written: its prototype (ranges widened for moved points) and, per moved
/// record in order, the new values of its coordinate fields by prototype index.
struct Plan {
    proto: Vec<e57::Record>,
    changes: Vec<(usize, Vec<(usize, RecordValue)>)>,
}

/// Writes the rectified cloud as E57: one point cloud per scan of the input with its pose and
/// metadata, every record in the input's order and types; `rectified` and `moved` have one
/// entry per point of the cloud read (the scans' valid records, in order).
pub fn write_e57(
    path: &Path,
    file: &E57File,
    rectified: &[[f64; 3]],
    moved: &[bool],
) -> Result<()> {
    let n = file.points();
    if rectified.len() != n || moved.len() != n {
        return Err(Error::BadOutput {
            path: path.to_path_buf(),
            what: format!(
                "{} rectified positions and {} moved flags for the input's {n} points",
                rectified.len(),
                moved.len()
            ),
        });
    }
    // The new values of moved points, per scan, and the prototypes widened to hold them.
    let mut k = 0usize;
    let mut plans = Vec::with_capacity(file.scans.len());
    for (s, scan) in file.scans.iter().enumerate() {
        let mut proto = scan.pc.prototype.clone();
        flag_ranges(&mut proto);
        let slots = Slots::of(&proto);
        let mut changes: Vec<(usize, Vec<(usize, RecordValue)>)> = Vec::new();
        for (r, _) in scan.taken.iter().enumerate().filter(|(_, t)| **t) {
            if moved[k] {
                let bad = |what: String| Error::BadOutput {
                    path: path.to_path_buf(),
                    what: format!("scan {s}, record {r}: {what}"),
                };
                let q = to_scan(&scan.rotation, &scan.translation, rectified[k])
                    .ok_or_else(|| bad("the scan's pose rotation is singular".into()))?;
                let stored = &scan.pc.prototype;
                let old = |i: usize| {
                    value_f64(
                        &scan.columns[i].get(r, &stored[i].data_type),
                        &stored[i].data_type,
                    )
                };
                let vals = moved_values(&scan.pc.prototype, &slots, &old, q).ok_or_else(|| {
                    bad(format!(
                        "the moved point {:?} cannot be stored in the record types",
                        rectified[k]
                    ))
                })?;
                for (i, v) in &vals {
                    widen(&mut proto[*i].data_type, v);
                }
                changes.push((r, vals));
            }
            k += 1;
        }
        plans.push(Plan { proto, changes });
    }
    super::write_atomic_file(path, |f| {
        unpanicked(path, "writing", || write_scans(path, f, file, plans))
    })
}

fn write_scans(path: &Path, f: std::fs::File, file: &E57File, plans: Vec<Plan>) -> Result<()> {
    let err = |place: &str, e: e57::Error| Error::BadOutput {
        path: path.to_path_buf(),
        what: format!("{place}: {e}"),
    };
    let guid = format!("{}-sharpedge", file.guid);
    let mut w = E57Writer::new(f, &guid).map_err(|e| err("header", e))?;
    w.set_coordinate_metadata(file.coordinate_metadata.clone());
    for x in &file.extensions {
        w.register_extension(x.clone())
            .map_err(|e| err("extension", e))?;
    }
    for (s, (scan, Plan { proto, changes })) in file.scans.iter().zip(plans).enumerate() {
        let place = format!("scan {s}");
        let pc = &scan.pc;
        let scan_guid = pc
            .guid
            .clone()
            .unwrap_or_else(|| format!("{guid}-scan-{s}"));
        let mut pw = w
            .add_pointcloud(&scan_guid, proto.clone())
            .map_err(|e| err(&place, e))?;
        pw.set_name(pc.name.clone());
        pw.set_description(pc.description.clone());
        pw.set_original_guids(pc.original_guids.clone());
        pw.set_transform(pc.transform.clone());
        pw.set_acquisition_start(pc.acquisition_start.clone());
        pw.set_acquisition_end(pc.acquisition_end.clone());
        pw.set_sensor_vendor(pc.sensor_vendor.clone());
        pw.set_sensor_model(pc.sensor_model.clone());
        pw.set_sensor_serial(pc.sensor_serial.clone());
        pw.set_sensor_hw_version(pc.sensor_hw_version.clone());
        pw.set_sensor_sw_version(pc.sensor_sw_version.clone());
        pw.set_sensor_fw_version(pc.sensor_fw_version.clone());
        pw.set_temperature(pc.temperature);
        pw.set_humidity(pc.humidity);
        pw.set_atmospheric_pressure(pc.atmospheric_pressure);
        if pc.intensity_limits.is_some() {
            pw.set_intensity_limits(pc.intensity_limits.clone());
        }
        if pc.color_limits.is_some() {
            pw.set_color_limits(pc.color_limits.clone());
        }
        let mut next = changes.into_iter().peekable();
        for r in 0..scan.taken.len() {
            let mut values: Vec<RecordValue> = scan
                .columns
                .iter()
                .zip(&proto)
                .map(|(c, p)| c.get(r, &p.data_type))
                .collect();
            if next.peek().is_some_and(|(cr, _)| *cr == r)
                && let Some((_, vals)) = next.next()
            {
                for (i, v) in vals {
                    values[i] = v;
                }
            }
            pw.add_point(values)
                .map_err(|e| err(&format!("{place}, record {r}"), e))?;
        }
        pw.finalize().map_err(|e| err(&place, e))?;
    }
    w.finalize().map_err(|e| err("XML", e))?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pc_with(q: [f64; 4], t: [f64; 3]) -> PointCloud {
        let mut tr = e57::Transform::default();
        (tr.rotation.w, tr.rotation.x, tr.rotation.y, tr.rotation.z) = (q[0], q[1], q[2], q[3]);
        (tr.translation.x, tr.translation.y, tr.translation.z) = (t[0], t[1], t[2]);
        // PointCloud has no public constructor: take one from a file written in memory.
        let mut buf = std::io::Cursor::new(Vec::new());
        {
            let mut w = E57Writer::new(&mut buf, "g").unwrap();
            let mut p = w
                .add_pointcloud(
                    "s",
                    vec![
                        e57::Record::CARTESIAN_X_F64,
                        e57::Record::CARTESIAN_Y_F64,
                        e57::Record::CARTESIAN_Z_F64,
                    ],
                )
                .unwrap();
            p.finalize().unwrap();
            w.finalize().unwrap();
        }
        buf.set_position(0);
        let mut pc = E57Reader::new(buf).unwrap().pointclouds().remove(0);
        pc.transform = Some(tr);
        pc
    }

    #[test]
    fn to_scan_inverts_the_pose() {
        let n = (0.9f64 * 0.9 + 0.1 * 0.1 + 0.2 * 0.2 + 0.3 * 0.3).sqrt();
        let pc = pc_with([0.9 / n, 0.1 / n, -0.2 / n, 0.3 / n], [5.0, -2.0, 1.0]);
        let (m, t, pose) = rotation_of(&pc);
        assert_eq!(pose.translation, [5.0, -2.0, 1.0]);
        let q = [1.5, -0.25, 3.0];
        let back = to_scan(&m, &t, to_cloud(&m, &t, q)).unwrap();
        for k in 0..3 {
            assert!((back[k] - q[k]).abs() < 1e-12, "{back:?}");
        }
        // A zero quaternion has no inverse: reported, not a NaN point.
        let pc0 = pc_with([0.0; 4], [0.0; 3]);
        let (m0, t0, _) = rotation_of(&pc0);
        assert_eq!(to_scan(&m0, &t0, [1.0, 2.0, 3.0]), None);
    }

    #[test]
    fn encode_rounds_to_the_scaled_integer_step_and_widen_covers_it() {
        let mut dt = RecordDataType::ScaledInteger {
            min: -100,
            max: 100,
            scale: 0.01,
            offset: 1.0,
        };
        let v = encode(&dt, 2.5).unwrap();
        assert_eq!(v, RecordValue::ScaledInteger(150));
        widen(&mut dt, &v);
        assert!(matches!(
            dt,
            RecordDataType::ScaledInteger {
                min: -100,
                max: 150,
                ..
            }
        ));
        assert_eq!(encode(&dt, f64::NAN), None);
        assert_eq!(
            encode(&RecordDataType::F32, 0.1),
            Some(RecordValue::Single(0.1))
        );
    }

    #[test]
    fn flag_ranges_widen_only_narrower_flags() {
        let rec = |name, min, max| e57::Record {
            name,
            data_type: RecordDataType::Integer { min, max },
        };
        let mut p = vec![
            rec(RecordName::CartesianInvalidState, 0, 1),
            rec(RecordName::IsColorInvalid, 0, 0),
            rec(RecordName::RowIndex, 0, 1),
        ];
        flag_ranges(&mut p);
        let ranges: Vec<String> = p.iter().map(|r| format!("{:?}", r.data_type)).collect();
        assert_eq!(
            ranges,
            [
                "Integer { min: 0, max: 2 }",
                "Integer { min: 0, max: 1 }",
                "Integer { min: 0, max: 1 }"
            ]
        );
    }
}
