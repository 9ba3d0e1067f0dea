//! The rectified cloud as LAS or LAZ with the input's header, records and CRS.
//!
//! Input: the [`Lidar`] the reader kept (header, every EVLR, raw point records), the rectified
//! positions with their moved flags, sharpedge's per-point fields and an optional class code
//! for edge points. Output: a LAS or LAZ file, written atomically, with the input's version,
//! point format, scale and offset, every VLR and EVLR except those that describe a layout
//! that is not written again, and every point record copied byte for byte in input order,
//! except:
//! - a moved point's X, Y, Z, re-quantised with the file's own scale and offset (an unmoved
//!   point keeps its stored integers, so it round-trips bit for bit);
//! - the class of edge points when asked (the legacy formats' flag bits kept);
//! - sharpedge's fields appended to each record as extra bytes, described by the Extra Bytes
//!   VLR (LASF_Spec record 4; LAS 1.4 R15 §2.6) so PDAL, laspy and CloudCompare list them as
//!   dimensions. The input's own extra bytes stay in front, with their descriptors.
//!
//! Dropped VLRs: `laszip encoded` 22204 (the LAZ writer makes a new one for the new record
//! layout; a LAS output has none), the `copc` records (info, extents, the hierarchy EVLR: the
//! output is not a COPC octree) and the input's Extra Bytes VLR (rewritten with ours
//! appended). The las crate writes no waveform packet data inside the file (formats 4, 5, 9,
//! 10 keep their per-point waveform fields, which point into an external .wdp file).

use std::io::Write;
use std::path::Path;

use super::las::Lidar;
use crate::cloud::{Attribute, Column};
use crate::error::{Error, Result};

/// One of sharpedge's per-point fields, written as an extra-bytes dimension.
pub struct ExtraField<'a> {
    /// Name (at most 32 bytes) and values (one per point).
    pub attribute: &'a Attribute,
    /// What the field means (at most 32 bytes), shown by PDAL and CloudCompare.
    pub description: &'a str,
}

/// What the LAS/LAZ output changes besides positions and extra bytes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct LasWriteOptions {
    /// LAZ (true) or LAS.
    pub compressed: bool,
    /// Class code given to the points whose `edge` flag is set; `None` leaves every class.
    pub edge_class: Option<u8>,
}

/// Size of one Extra Bytes descriptor.
const DESCRIPTOR_LEN: usize = 192;
const SPEC: &str = "LASF_Spec";
const EXTRA_BYTES_RECORD: u16 = 4;
/// Points per block handed to the las writer (bounded memory, parallel LAZ chunks).
const BLOCK: usize = 1 << 16;

/// Largest class code a point format stores: 5 bits in formats 0–5, a byte in 6–10.
pub fn max_class(format: u8) -> u8 {
    if format >= 6 { 255 } else { 31 }
}

/// Checks, before any work, that an edge class fits the input's point format.
pub fn check_edge_class(lidar: &Lidar, class: u8) -> Result<()> {
    let format = lidar.point_format();
    if class <= max_class(format) {
        return Ok(());
    }
    Err(Error::Usage {
        option: "output.edge_class".into(),
        message: format!(
            "class {class} does not fit point format {format} of {} (classes 0..={}); \
             choose a code in that range",
            lidar.path.display(),
            max_class(format)
        ),
    })
}

/// The LAS extra-bytes data type of a column (LAS 1.4 R15 Table 24) and its size.
fn data_type(c: &Column) -> (u8, usize) {
    match c {
        Column::U8(_) => (1, 1),
        Column::I8(_) => (2, 1),
        Column::U16(_) => (3, 2),
        Column::I16(_) => (4, 2),
        Column::U32(_) => (5, 4),
        Column::I32(_) => (6, 4),
        Column::F32(_) => (9, 4),
        Column::F64(_) => (10, 8),
    }
}

/// Size in bytes of a described extra-bytes field; `None` for a type the spec does not
/// define.
fn described_size(data_type: u8, options: u8) -> Option<usize> {
    const BASE: [usize; 10] = [1, 1, 2, 2, 4, 4, 8, 8, 4, 8];
    match data_type {
        0 => Some(usize::from(options)),
        1..=10 => Some(BASE[usize::from(data_type - 1)]),
        // Deprecated two- and three-element arrays.
        11..=20 => Some(2 * BASE[usize::from(data_type - 11)]),
        21..=30 => Some(3 * BASE[usize::from(data_type - 21)]),
        _ => None,
    }
}

/// A descriptor with the name and description set, everything else zero (no scale, offset,
/// no-data, min or max).
fn descriptor(data_type: u8, options: u8, name: &str, description: &str) -> [u8; DESCRIPTOR_LEN] {
    let mut d = [0u8; DESCRIPTOR_LEN];
    d[2] = data_type;
    d[3] = options;
    let n = name.as_bytes();
    d[4..4 + n.len().min(32)].copy_from_slice(&n[..n.len().min(32)]);
    let s = description.as_bytes();
    d[160..160 + s.len().min(32)].copy_from_slice(&s[..s.len().min(32)]);
    d
}

fn descriptor_name(d: &[u8]) -> String {
    let raw = &d[4..36];
    let end = raw.iter().position(|&b| b == 0).unwrap_or(32);
    String::from_utf8_lossy(&raw[..end]).into_owned()
}

fn set_descriptor_name(d: &mut [u8], name: &str) {
    d[4..36].fill(0);
    let n = name.as_bytes();
    d[4..4 + n.len().min(32)].copy_from_slice(&n[..n.len().min(32)]);
}

/// The input's extra-bytes descriptors, made to cover exactly its `existing` extra bytes:
/// undescribed bytes at the end get "undocumented" descriptors (type 0), and a VLR that
/// describes more bytes than the records hold (or an undefined type) is replaced by
/// undocumented descriptors of the whole block, with a warning.
fn input_descriptors(lidar: &Lidar, existing: usize) -> Vec<[u8; DESCRIPTOR_LEN]> {
    let vlr = lidar
        .header
        .vlrs()
        .iter()
        .chain(&lidar.evlrs)
        .find(|v| v.user_id == SPEC && v.record_id == EXTRA_BYTES_RECORD);
    let mut out: Vec<[u8; DESCRIPTOR_LEN]> = Vec::new();
    let mut covered = 0usize;
    if let Some(v) = vlr {
        for c in v.data.chunks_exact(DESCRIPTOR_LEN) {
            let Some(size) = described_size(c[2], c[3]) else {
                covered = usize::MAX;
                break;
            };
            covered = covered.saturating_add(size);
            let mut d = [0u8; DESCRIPTOR_LEN];
            d.copy_from_slice(c);
            out.push(d);
        }
    }
    if covered > existing {
        tracing::warn!(
            "{}: the Extra Bytes VLR describes more than the {existing} extra bytes per point \
             the records hold; they are written back as undocumented bytes",
            lidar.path.display()
        );
        out.clear();
        covered = 0;
    }
    let mut left = existing - covered;
    while left > 0 {
        let n = left.min(255);
        let name = format!("input_extra_bytes_{}", existing - left);
        out.push(descriptor(0, n as u8, &name, "undocumented in the input"));
        left -= n;
    }
    out
}

/// The descriptors of the output: the input's (a name that clashes with one of ours becomes
/// `input_<name>`), then ours.
fn extra_bytes_vlr(lidar: &Lidar, existing: usize, fields: &[ExtraField]) -> las::Vlr {
    let mut descriptors = input_descriptors(lidar, existing);
    let ours: Vec<&str> = fields.iter().map(|f| f.attribute.name.as_str()).collect();
    let mut taken: Vec<String> = descriptors.iter().map(|d| descriptor_name(d)).collect();
    taken.extend(ours.iter().map(|s| s.to_string()));
    for d in &mut descriptors {
        let name = descriptor_name(d);
        if ours.contains(&name.as_str()) {
            let mut renamed = format!("input_{name}");
            while taken.contains(&renamed) {
                renamed = format!("input_{renamed}");
            }
            set_descriptor_name(d, &renamed);
            taken.push(renamed);
        }
    }
    for f in fields {
        let (t, _) = data_type(&f.attribute.values);
        descriptors.push(descriptor(t, 0, &f.attribute.name, f.description));
    }
    las::Vlr {
        user_id: SPEC.into(),
        record_id: EXTRA_BYTES_RECORD,
        description: "Extra Bytes Record".into(),
        data: descriptors.concat(),
    }
}

/// Whether a VLR describes something the output does not have again.
fn dropped(v: &las::Vlr) -> bool {
    las::laz::is_laszip_vlr(v)
        || v.user_id == "copc"
        || (v.user_id == SPEC && v.record_id == EXTRA_BYTES_RECORD)
}

/// The output header: the input's, minus the dropped VLRs, with the Extra Bytes VLR and the
/// longer records.
fn output_header(
    lidar: &Lidar,
    fields: &[ExtraField],
    ours: usize,
    compressed: bool,
) -> Result<las::Header> {
    let input = &lidar.header;
    let existing = usize::from(input.point_format().extra_bytes);
    let mut b = las::Builder::from(input.clone());
    let kept: Vec<String> = input
        .vlrs()
        .iter()
        .chain(&lidar.evlrs)
        .filter(|v| dropped(v))
        .map(|v| format!("{} {}", v.user_id, v.record_id))
        .collect();
    if !kept.is_empty() {
        tracing::debug!("not written again: {}", kept.join(", "));
    }
    b.vlrs.retain(|v| !dropped(v));
    b.evlrs = lidar
        .evlrs
        .iter()
        .filter(|v| !dropped(v))
        .cloned()
        .collect();
    b.vlrs.push(extra_bytes_vlr(lidar, existing, fields));
    let total = existing + ours;
    b.point_format.extra_bytes = u16::try_from(total).map_err(|_| Error::BadOutput {
        path: lidar.path.clone(),
        what: format!("{total} extra bytes per point do not fit a LAS record"),
    })?;
    b.point_format.is_compressed = compressed;
    b.generating_software = format!("sharpedge {}", env!("CARGO_PKG_VERSION"));
    b.into_header().map_err(|e| Error::BadOutput {
        path: lidar.path.clone(),
        what: format!("cannot make the output header from the input's: {e}"),
    })
}

fn las_write_error(path: &Path, e: las::Error) -> Error {
    match e {
        las::Error::Io(io) => Error::io(path, "cannot write", io),
        e => Error::BadOutput {
            path: path.to_path_buf(),
            what: e.to_string(),
        },
    }
}

/// Appends value `i` of a column in little endian.
fn push_value(out: &mut Vec<u8>, c: &Column, i: usize) {
    match c {
        Column::I8(v) => out.extend_from_slice(&v[i].to_le_bytes()),
        Column::U8(v) => out.push(v[i]),
        Column::I16(v) => out.extend_from_slice(&v[i].to_le_bytes()),
        Column::U16(v) => out.extend_from_slice(&v[i].to_le_bytes()),
        Column::I32(v) => out.extend_from_slice(&v[i].to_le_bytes()),
        Column::U32(v) => out.extend_from_slice(&v[i].to_le_bytes()),
        Column::F32(v) => out.extend_from_slice(&v[i].to_le_bytes()),
        Column::F64(v) => out.extend_from_slice(&v[i].to_le_bytes()),
    }
}

/// Writes the rectified cloud as LAS (or LAZ) in the input's layout; see the module comment.
/// `positions` and `moved` and every field have one entry per record of `lidar`; `edge`
/// marks the points that get `opts.edge_class`.
pub fn write_las(
    path: &Path,
    lidar: &Lidar,
    positions: &[[f64; 3]],
    moved: &[bool],
    edge: &[bool],
    fields: &[ExtraField],
    opts: &LasWriteOptions,
) -> Result<()> {
    let bad = |what: String| Error::BadOutput {
        path: path.to_path_buf(),
        what,
    };
    let len = lidar.record_len;
    let n = lidar.records.len().checked_div(len).unwrap_or(0);
    if !lidar.has_records() {
        return Err(bad(
            "the input's point records were not kept by the reader".into()
        ));
    }
    if positions.len() != n || moved.len() != n || edge.len() != n {
        return Err(bad(format!(
            "{} positions, {} moved flags and {} edge flags for {n} records",
            positions.len(),
            moved.len(),
            edge.len()
        )));
    }
    for f in fields {
        let name = &f.attribute.name;
        if f.attribute.values.len() != n {
            return Err(bad(format!(
                "field {name} has {} values for {n} points",
                f.attribute.values.len()
            )));
        }
        if name.is_empty() || name.len() > 32 || f.description.len() > 32 {
            return Err(bad(format!(
                "extra-bytes name {name:?} and description {:?} must hold 1..=32 and \
                 0..=32 bytes",
                f.description
            )));
        }
    }
    if let Some(c) = opts.edge_class {
        check_edge_class(lidar, c)?;
    }
    let ours: usize = fields
        .iter()
        .map(|f| data_type(&f.attribute.values).1)
        .sum();
    let header = output_header(lidar, fields, ours, opts.compressed)?;
    let transforms = *header.transforms();
    let format = *header.point_format();
    // Moved points on the file's grid, checked before the writer exists (a las writer that
    // is dropped unfinished panics).
    let mut requantised: Vec<(usize, [i32; 3])> = Vec::new();
    for (i, p) in positions.iter().enumerate() {
        if !moved[i] {
            continue;
        }
        let t = [transforms.x, transforms.y, transforms.z];
        let mut q = [0i32; 3];
        for k in 0..3 {
            q[k] = t[k].inverse(p[k]).map_err(|_| {
                bad(format!(
                    "moved point {i} ({}, {}, {}) is outside what the file's scale and offset \
                     can store",
                    p[0], p[1], p[2]
                ))
            })?;
        }
        requantised.push((i, q));
    }
    let legacy = !format.is_extended;
    let class_at = if legacy { 15 } else { 16 };
    super::write_atomic_file(path, |file| {
        let sink = std::io::BufWriter::with_capacity(1 << 20, file);
        let mut writer = las::Writer::new(sink, header).map_err(|e| las_write_error(path, e))?;
        let result = (|| -> Result<()> {
            let out_len = len + ours;
            let mut next_moved = requantised.iter().peekable();
            let mut start = 0;
            while start < n {
                let end = (start + BLOCK).min(n);
                let mut bytes: Vec<u8> = Vec::with_capacity((end - start) * out_len);
                for (i, &is_edge) in edge.iter().enumerate().take(end).skip(start) {
                    let at = bytes.len();
                    bytes.extend_from_slice(&lidar.records[i * len..(i + 1) * len]);
                    if let Some(&&(_, q)) = next_moved.peek().filter(|(j, _)| *j == i) {
                        for (k, v) in q.iter().enumerate() {
                            bytes[at + 4 * k..at + 4 * k + 4].copy_from_slice(&v.to_le_bytes());
                        }
                        next_moved.next();
                    }
                    if let (Some(c), true) = (opts.edge_class, is_edge) {
                        let b = &mut bytes[at + class_at];
                        *b = if legacy { (*b & 0xE0) | c } else { c };
                    }
                    for f in fields {
                        push_value(&mut bytes, &f.attribute.values, i);
                    }
                }
                let pd = las::PointDataBuilder::new()
                    .with_format(format)
                    .with_transforms(transforms)
                    .build_from_bytes(bytes)
                    .map_err(|e| las_write_error(path, e))?;
                writer
                    .write_points(&pd)
                    .map_err(|e| las_write_error(path, e))?;
                start = end;
            }
            writer.close().map_err(|e| las_write_error(path, e))
        })();
        match result {
            Ok(()) => {
                let mut sink = writer.into_inner().map_err(|e| las_write_error(path, e))?;
                sink.flush()
                    .map_err(|e| Error::io(path, "cannot write (disk full?)", e))
            }
            Err(e) => {
                // An unfinished las writer panics when dropped; the temporary file is removed
                // by the caller, so only this small buffer leaks, once, on a failed run.
                std::mem::forget(writer);
                Err(e)
            }
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sizes_of_described_types() {
        assert_eq!(described_size(0, 7), Some(7));
        assert_eq!(described_size(1, 0), Some(1));
        assert_eq!(described_size(6, 0), Some(4));
        assert_eq!(described_size(10, 0), Some(8));
        assert_eq!(described_size(19, 0), Some(8)); // two floats
        assert_eq!(described_size(20, 0), Some(16)); // two doubles
        assert_eq!(described_size(30, 0), Some(24));
        assert_eq!(described_size(31, 0), None);
    }

    #[test]
    fn descriptor_layout() {
        let d = descriptor(6, 0, "edge_id", "edge id, -1 = none");
        assert_eq!(d[2], 6);
        assert_eq!(&d[4..11], b"edge_id");
        assert_eq!(d[11], 0);
        assert_eq!(&d[160..178], b"edge id, -1 = none");
        assert_eq!(descriptor_name(&d), "edge_id");
        assert_eq!(max_class(3), 31);
        assert_eq!(max_class(6), 255);
    }
}
