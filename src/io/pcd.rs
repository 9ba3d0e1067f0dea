//! PCD (PCL's Point Cloud Data): reading versions 0.5–0.7 in `ascii`, `binary` and
//! `binary_compressed` (LZF), and writing a PCD back in the layout it was read with.
//!
//! Input: a `.pcd` file with any FIELDS (types I 1/2/4, U 1/2/4, F 4/8, COUNT ≥ 1, `_`
//! padding), organised (HEIGHT > 1) or not. Output: a [`Loaded`] cloud whose positions are
//! x, y, z as f64 and whose attributes are the other fields with their types (a field of
//! COUNT n gives `name_0` … `name_{n-1}`; a packed `rgb`/`rgba` gives `red`, `green`, `blue`
//! as uchar, and `alpha` for `rgba`; padding is dropped), plus the [`ScanStructure`]: one
//! scan posed by VIEWPOINT and, for an organised frame, each point's `[row, column]`.
//!
//! The slots of an organised frame whose x, y and z are all NaN are the sensor's "no return":
//! they are no points (never in `Cloud::positions`) but keep their place in a PCD written
//! back. Every other non-finite point follows the caller's `input.non_finite` policy.
//!
//! For a PCD output the reader also hands back a [`PcdFile`]: the header and every slot's
//! record as the file stores it, which [`write_pcd`] writes back with the rectified x, y, z of
//! the moved points: unmoved points, NaN slots, padding and every other field stay bit for bit,
//! in the same encoding, organisation and VIEWPOINT.
//!
//! Decoder: own, not pcd-rs. pcd-rs 0.13's `DynReader` builds a `Vec<Field>` of `Vec`s per
//! point: on the 10,000,000-point `x y z rgb` files of scripts/bench_read_pcd.sh (/dev/shm,
//! release) it read `binary` in 10.5 s and `binary_compressed` in 6.9 s; this decoder reads
//! them in 0.14–0.22 s and (on a machine busy with other builds) 1.2–1.4 s, where binary PLY
//! of the same points took 0.15–0.22 s (0.60-0.74 s in the busy run) and PCL 1.13's
//! loadPCDFile 0.36–0.40 s and 0.87–0.89 s (2.8 s busy). A `binary` body is read in chunks of
//! about 1 MB and decoded while hot (no buffer of the whole file). A `binary_compressed`
//! body is read 1 MB at a time and decoded by our own LZF decoder (src/io/lzf_stream.rs;
//! 0.65 s for the 160 MB body where the `lzf` crate takes 0.94 s, `examples/pcd_read lzf`)
//! 256 KB at a time, each piece converted into the cloud's columns while it is in the cache,
//! in a second thread while this one converts when the pool has two (slightly faster than
//! one thread: medians of 5 busy runs 1.08 s against 1.14 s); no buffer of the whole body (peak
//! 263 MB where the whole body made it 413 MB). For a PCD output (the records kept) the body
//! is decompressed whole by the same decoder. Every size in the header is checked against
//! the file's length before anything is allocated, so a lying header gives an error, never
//! an allocation the file cannot back.

use std::fmt::Write as _;
use std::path::Path;

use super::lzf_stream::{self, LzfError};
use super::{Loaded, PropertyInfo};
use crate::cloud::{Attribute, Cloud, Column, Pose, Scan, ScanStructure, Source};
use crate::error::{Error, Result};

/// The type/size pairs PCD defines, for error messages.
const PCD_TYPES: &str = "I 1, I 2, I 4, I 8, U 1, U 2, U 4, U 8, F 4, F 8";

/// LZF's best case: a back reference of 264 bytes costs 3 bytes. A decompressed size beyond
/// this many times the compressed one cannot be real data.
const LZF_MAX_RATIO: u64 = 88;

/// The body encoding of a PCD file (`DATA`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PcdEncoding {
    Ascii,
    Binary,
    BinaryCompressed,
}

impl PcdEncoding {
    fn name(self) -> &'static str {
        match self {
            PcdEncoding::Ascii => "ascii",
            PcdEncoding::Binary => "binary",
            PcdEncoding::BinaryCompressed => "binary_compressed",
        }
    }
}

/// A field's TYPE letter.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Kind {
    I,
    U,
    F,
}

impl Kind {
    fn letter(self) -> char {
        match self {
            Kind::I => 'I',
            Kind::U => 'U',
            Kind::F => 'F',
        }
    }
}

/// One entry of FIELDS with its SIZE, TYPE and COUNT.
#[derive(Debug, Clone, PartialEq, Eq)]
struct Field {
    name: String,
    kind: Kind,
    size: usize,
    count: usize,
}

impl Field {
    fn is_padding(&self) -> bool {
        self.name == "_"
    }

    fn bytes(&self) -> usize {
        self.size * self.count
    }

    /// A packed colour: `rgb` or `rgba` as one 4-byte value (F or U; PCL uses both).
    fn is_packed_colour(&self) -> bool {
        matches!(self.name.as_str(), "rgb" | "rgba")
            && self.size == 4
            && self.count == 1
            && self.kind != Kind::I
    }

    fn type_text(&self) -> String {
        let mut t = format!("{} {}", self.kind.letter(), self.size);
        if self.count > 1 {
            let _ = write!(t, " x {}", self.count);
        }
        if self.is_packed_colour() {
            t.push_str(", packed colour: red, green, blue");
            if self.name == "rgba" {
                t.push_str(", alpha");
            }
        }
        t
    }
}

/// The header of a PCD file.
#[derive(Debug, Clone, PartialEq)]
struct Header {
    version: String,
    fields: Vec<Field>,
    width: usize,
    height: usize,
    /// `tx ty tz qw qx qy qz`.
    viewpoint: [f64; 7],
    points: usize,
    encoding: PcdEncoding,
    /// Byte offset of the body (after the DATA line).
    data_start: usize,
}

impl Header {
    fn point_size(&self) -> usize {
        self.fields.iter().map(Field::bytes).sum()
    }

    /// The bytes of one point without padding: the unit of the compressed layout.
    fn packed_size(&self) -> usize {
        self.fields
            .iter()
            .filter(|f| !f.is_padding())
            .map(Field::bytes)
            .sum()
    }

    fn organised(&self) -> bool {
        self.height > 1
    }

    fn field(&self, name: &str) -> Option<usize> {
        self.fields.iter().position(|f| f.name == name)
    }

    fn pose(&self) -> Pose {
        let v = self.viewpoint;
        Pose {
            rotation: [v[3], v[4], v[5], v[6]],
            translation: [v[0], v[1], v[2]],
        }
    }

    fn organisation_text(&self) -> String {
        if self.organised() {
            format!("organised {} x {}", self.width, self.height)
        } else {
            "unorganised".into()
        }
    }
}

/// Where the values of the body sit in a buffer: one record per point (`binary`, and the
/// records `ascii` is parsed into) or one block per non-padding field (`binary_compressed`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Layout {
    Records,
    Blocks,
}

/// A decoded body: the buffer, where its values start and how they are laid out.
struct Body {
    buf: Vec<u8>,
    start: usize,
    layout: Layout,
}

impl Body {
    /// Byte offset of element 0 of field `f` at point 0, and the step from a point to the
    /// next; `None` for padding in the blocks layout (which does not store it).
    fn place(&self, h: &Header, f: usize) -> Option<(usize, usize)> {
        match self.layout {
            Layout::Records => {
                let off: usize = h.fields[..f].iter().map(Field::bytes).sum();
                Some((self.start + off, h.point_size()))
            }
            Layout::Blocks => {
                if h.fields[f].is_padding() {
                    return None;
                }
                let before: usize = h.fields[..f]
                    .iter()
                    .filter(|g| !g.is_padding())
                    .map(Field::bytes)
                    .sum();
                Some((self.start + before * h.points, h.fields[f].bytes()))
            }
        }
    }

    /// The body as records (`point_size` bytes a point, padding zero), for a writer.
    fn into_records(self, h: &Header) -> Vec<u8> {
        if self.layout == Layout::Records && self.start == 0 {
            return self.buf;
        }
        let ps = h.point_size();
        let mut out = vec![0u8; ps * h.points];
        if self.layout == Layout::Records {
            out.copy_from_slice(&self.buf[self.start..self.start + ps * h.points]);
            return out;
        }
        let mut off = 0;
        for (f, field) in h.fields.iter().enumerate() {
            let w = field.bytes();
            if let Some((base, stride)) = self.place(h, f) {
                for i in 0..h.points {
                    let src = base + i * stride;
                    out[i * ps + off..i * ps + off + w].copy_from_slice(&self.buf[src..src + w]);
                }
            }
            off += w;
        }
        out
    }
}

/// A PCD input kept for writing it back: header and every slot's record (the `binary`
/// layout, padding included), and the slot of each point of the cloud.
#[derive(Debug, Clone, PartialEq)]
pub struct PcdFile {
    header: Header,
    records: Vec<u8>,
    /// Per point of the cloud, its slot (index in the file).
    slots: Vec<u32>,
}

impl PcdFile {
    /// Keeps the slots of the points whose `keep` flag is set (the points the non-finite
    /// policy dropped keep their original values in the output).
    pub fn retain_mask(&mut self, keep: &[bool]) {
        let mut it = keep.iter();
        self.slots.retain(|_| *it.next().unwrap_or(&false));
    }

    /// The encoding the file was read with, and so is written with.
    pub fn encoding(&self) -> PcdEncoding {
        self.header.encoding
    }
}

fn malformed(path: &Path, place: impl Into<String>, what: impl Into<String>) -> Error {
    Error::malformed(path, place, what)
}

/// Parses the header lines up to and including DATA.
fn parse_header(path: &Path, bytes: &[u8]) -> Result<Header> {
    let mut version = None;
    let mut names: Option<Vec<String>> = None;
    let mut sizes: Option<Vec<usize>> = None;
    let mut kinds: Option<Vec<Kind>> = None;
    let mut counts: Option<Vec<usize>> = None;
    let (mut width, mut height, mut points) = (None, None, None);
    let mut viewpoint = [0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0];
    let mut pos = 0usize;
    let mut line_no = 0usize;
    let (encoding, data_start) = loop {
        if pos >= bytes.len() {
            return Err(malformed(
                path,
                "header",
                "the file ends before the DATA line: no PCD header (or a truncated one)",
            ));
        }
        let end = bytes[pos..]
            .iter()
            .position(|&b| b == b'\n')
            .map_or(bytes.len(), |e| pos + e);
        line_no += 1;
        let place = format!("line {line_no}");
        let raw = &bytes[pos..end];
        pos = (end + 1).min(bytes.len());
        let Ok(text) = std::str::from_utf8(raw) else {
            return Err(malformed(
                path,
                place,
                "a header line that is not text: not a PCD file, or its header is damaged",
            ));
        };
        let text = text.trim();
        if text.is_empty() || text.starts_with('#') {
            continue;
        }
        let mut tokens = text.split_ascii_whitespace();
        let key = tokens.next().unwrap_or("");
        let values: Vec<&str> = tokens.collect();
        let one = |what: &str| -> Result<usize> {
            match values.as_slice() {
                [v] => v.parse::<usize>().map_err(|_| {
                    malformed(
                        path,
                        place.clone(),
                        format!("{what} `{v}` is not a whole number ≥ 0"),
                    )
                }),
                _ => Err(malformed(
                    path,
                    place.clone(),
                    format!("{what} takes one number, got `{text}`"),
                )),
            }
        };
        let list = |what: &str| -> Result<Vec<usize>> {
            values
                .iter()
                .map(|v| {
                    v.parse::<usize>().map_err(|_| {
                        malformed(
                            path,
                            place.clone(),
                            format!("{what} value `{v}` is not a whole number"),
                        )
                    })
                })
                .collect()
        };
        match key {
            "VERSION" => {
                let v = values.first().copied().unwrap_or("");
                let v = v.strip_prefix('0').unwrap_or(v);
                if !matches!(v, ".5" | ".6" | ".7") || values.len() != 1 {
                    return Err(malformed(
                        path,
                        place,
                        format!(
                            "unknown PCD version `{}`: sharpedge reads 0.5, 0.6 and 0.7",
                            values.join(" ")
                        ),
                    ));
                }
                version = Some(format!("0{v}"));
            }
            "FIELDS" | "COLUMNS" => {
                if values.is_empty() {
                    return Err(malformed(path, place, "FIELDS names no field"));
                }
                names = Some(values.iter().map(|s| s.to_string()).collect());
            }
            "SIZE" => sizes = Some(list("SIZE")?),
            "COUNT" => counts = Some(list("COUNT")?),
            "TYPE" => {
                let k: Result<Vec<Kind>> = values
                    .iter()
                    .map(|v| match *v {
                        "I" => Ok(Kind::I),
                        "U" => Ok(Kind::U),
                        "F" => Ok(Kind::F),
                        other => Err(malformed(
                            path,
                            place.clone(),
                            format!("unknown TYPE `{other}` (PCD types are I, U and F)"),
                        )),
                    })
                    .collect();
                kinds = Some(k?);
            }
            "WIDTH" => width = Some(one("WIDTH")?),
            "HEIGHT" => height = Some(one("HEIGHT")?),
            "POINTS" => points = Some(one("POINTS")?),
            "VIEWPOINT" => {
                let v: Vec<f64> = values.iter().filter_map(|v| v.parse().ok()).collect();
                if v.len() != 7 || values.len() != 7 || v.iter().any(|x| !x.is_finite()) {
                    return Err(malformed(
                        path,
                        place,
                        format!(
                            "VIEWPOINT takes 7 finite numbers (tx ty tz qw qx qy qz), got `{}`",
                            values.join(" ")
                        ),
                    ));
                }
                viewpoint.copy_from_slice(&v);
            }
            "DATA" => {
                let e = match values.as_slice() {
                    ["ascii"] => PcdEncoding::Ascii,
                    ["binary"] => PcdEncoding::Binary,
                    ["binary_compressed"] => PcdEncoding::BinaryCompressed,
                    _ => {
                        return Err(malformed(
                            path,
                            place,
                            format!(
                                "unknown DATA `{}`: PCD data is ascii, binary or \
                                 binary_compressed",
                                values.join(" ")
                            ),
                        ));
                    }
                };
                break (e, pos);
            }
            _ => {
                return Err(malformed(
                    path,
                    place,
                    format!(
                        "`{}` is no PCD header line (VERSION, FIELDS, SIZE, TYPE, COUNT, \
                         WIDTH, HEIGHT, VIEWPOINT, POINTS, DATA)",
                        text.chars().take(60).collect::<String>()
                    ),
                ));
            }
        }
    };
    let Some(names) = names else {
        return Err(malformed(path, "header", "no FIELDS line"));
    };
    let n = names.len();
    let per_field = |what: &str, len: Option<usize>| -> Result<()> {
        match len {
            Some(l) if l != n => Err(malformed(
                path,
                "header",
                format!("{what} has {l} values but FIELDS names {n} fields"),
            )),
            _ => Ok(()),
        }
    };
    per_field("SIZE", sizes.as_ref().map(Vec::len))?;
    per_field("TYPE", kinds.as_ref().map(Vec::len))?;
    per_field("COUNT", counts.as_ref().map(Vec::len))?;
    let Some(sizes) = sizes else {
        return Err(malformed(path, "header", "no SIZE line"));
    };
    // PCD 0.5 files may lack TYPE and COUNT: PCL reads them as float and 1.
    let kinds = kinds.unwrap_or_else(|| vec![Kind::F; n]);
    let counts = counts.unwrap_or_else(|| vec![1; n]);
    let mut fields = Vec::with_capacity(n);
    for (((name, size), kind), count) in names.into_iter().zip(sizes).zip(kinds).zip(counts) {
        let ok = matches!(
            (kind, size),
            (Kind::I | Kind::U, 1 | 2 | 4 | 8) | (Kind::F, 4 | 8)
        );
        if !ok {
            return Err(malformed(
                path,
                "header",
                format!(
                    "field `{name}` has TYPE {} SIZE {size}, which is no PCD type \
                     (sharpedge reads {PCD_TYPES})",
                    kind.letter()
                ),
            ));
        }
        if count == 0 || count > 1 << 16 {
            return Err(malformed(
                path,
                "header",
                format!("field `{name}` has COUNT {count} (expected 1 to 65536)"),
            ));
        }
        if name != "_" && fields.iter().any(|f: &Field| f.name == name) {
            return Err(malformed(
                path,
                "header",
                format!("field `{name}` is named twice in FIELDS"),
            ));
        }
        fields.push(Field {
            name,
            kind,
            size,
            count,
        });
    }
    for axis in ["x", "y", "z"] {
        match fields.iter().find(|f| f.name == axis) {
            None => {
                let have: Vec<&str> = fields.iter().map(|f| f.name.as_str()).collect();
                return Err(malformed(
                    path,
                    "header",
                    format!(
                        "no `{axis}` field (FIELDS {}): sharpedge needs x, y and z",
                        have.join(" ")
                    ),
                ));
            }
            Some(f) if f.kind != Kind::F || f.count != 1 => {
                return Err(malformed(
                    path,
                    "header",
                    format!(
                        "field `{axis}` is {}: coordinates must be F 4 or F 8 with COUNT 1",
                        f.type_text()
                    ),
                ));
            }
            Some(_) => {}
        }
    }
    // PCL's rules for old files: no WIDTH/HEIGHT means unorganised, no POINTS means
    // WIDTH x HEIGHT.
    let height = height.unwrap_or(1);
    let width = match (width, points) {
        (Some(w), _) => w,
        (None, Some(p)) if height == 1 => p,
        (None, _) => return Err(malformed(path, "header", "no WIDTH line")),
    };
    let slots = width.checked_mul(height);
    let points = points.or(slots).unwrap_or(usize::MAX);
    if slots != Some(points) {
        return Err(malformed(
            path,
            "header",
            format!(
                "POINTS {points} is not WIDTH {width} x HEIGHT {height}: the header \
                 contradicts itself"
            ),
        ));
    }
    if points > u32::MAX as usize {
        return Err(malformed(
            path,
            "header",
            format!("POINTS {points}: more than the 4,294,967,295 points sharpedge reads"),
        ));
    }
    Ok(Header {
        version: version.unwrap_or_else(|| "0.7".into()),
        fields,
        width,
        height,
        viewpoint,
        points,
        encoding,
        data_start,
    })
}

/// Decodes the body into a buffer the fields can be read from.
fn read_body(path: &Path, h: &Header, bytes: Vec<u8>) -> Result<Body> {
    let available = bytes.len() - h.data_start;
    match h.encoding {
        PcdEncoding::Binary => {
            let need = (h.point_size() as u128) * (h.points as u128);
            if need > available as u128 {
                return Err(malformed(
                    path,
                    format!("byte {}", h.data_start),
                    format!(
                        "the file is truncated: the header declares {} points of {} bytes \
                         ({need} bytes), the file holds {available} bytes after the header",
                        h.points,
                        h.point_size()
                    ),
                ));
            }
            Ok(Body {
                start: h.data_start,
                buf: bytes,
                layout: Layout::Records,
            })
        }
        PcdEncoding::BinaryCompressed => read_compressed(path, h, &bytes),
        PcdEncoding::Ascii => read_ascii(path, h, &bytes),
    }
}

/// Checks the compressed and uncompressed sizes of a `binary_compressed` body (`sizes`: the
/// 8 bytes after the header, `None` when the file ends before them; `available`: the bytes
/// of the file after them) against the header and the file, before anything is allocated.
fn compressed_sizes(
    path: &Path,
    h: &Header,
    sizes: Option<&[u8]>,
    available: u64,
) -> Result<(usize, usize)> {
    let place = format!("byte {}", h.data_start);
    let Some(&[c0, c1, c2, c3, u0, u1, u2, u3]) = sizes else {
        return Err(malformed(
            path,
            place,
            "the file is truncated: it ends before the compressed and uncompressed sizes \
             of binary_compressed data",
        ));
    };
    let compressed = u32::from_le_bytes([c0, c1, c2, c3]) as usize;
    let uncompressed = u32::from_le_bytes([u0, u1, u2, u3]) as usize;
    if compressed as u64 > available {
        return Err(malformed(
            path,
            place,
            format!(
                "the compressed size {compressed} runs past the end of the file ({available} \
                 bytes follow the sizes): the file is truncated or the size is wrong"
            ),
        ));
    }
    let expected = (h.packed_size() as u128) * (h.points as u128);
    if uncompressed as u128 != expected {
        return Err(malformed(
            path,
            place,
            format!(
                "the uncompressed size {uncompressed} does not match the header's {} points \
                 of {} bytes ({expected} bytes)",
                h.points,
                h.packed_size()
            ),
        ));
    }
    if uncompressed as u64 > (compressed as u64).saturating_mul(LZF_MAX_RATIO) {
        return Err(malformed(
            path,
            place,
            format!(
                "{compressed} compressed bytes cannot hold {uncompressed} bytes of LZF data \
                 (at most {LZF_MAX_RATIO}x): the sizes are wrong"
            ),
        ));
    }
    Ok((compressed, uncompressed))
}

/// The error of a damaged LZF body whose sizes start at `at`.
fn lzf_damaged(path: &Path, at: usize, e: &LzfError) -> Error {
    malformed(
        path,
        format!("byte {}", at as u64 + 8 + e.at),
        format!("the LZF data is damaged: {}", e.what),
    )
}

fn read_compressed(path: &Path, h: &Header, bytes: &[u8]) -> Result<Body> {
    let at = h.data_start;
    let available = bytes.len().saturating_sub(at + 8) as u64;
    let (compressed, uncompressed) = compressed_sizes(path, h, bytes.get(at..at + 8), available)?;
    if uncompressed == 0 {
        return Ok(Body {
            buf: Vec::new(),
            start: 0,
            layout: Layout::Blocks,
        });
    }
    let data = &bytes[at + 8..at + 8 + compressed];
    let buf = lzf_stream::decompress(data, uncompressed).map_err(|e| lzf_damaged(path, at, &e))?;
    Ok(Body {
        buf,
        start: 0,
        layout: Layout::Blocks,
    })
}

/// Whether a float field's ascii value is the packed colour's bits as an integer, as PCL
/// writes `rgb` (a float whose bit patterns include NaNs).
fn is_colour_integer(field: &Field, tok: &str) -> bool {
    field.kind == Kind::F && field.is_packed_colour() && tok.bytes().all(|b| b.is_ascii_digit())
}

fn read_ascii(path: &Path, h: &Header, bytes: &[u8]) -> Result<Body> {
    let values: usize = h.fields.iter().map(|f| f.count).sum();
    let body = &bytes[h.data_start..];
    // Every value takes at least two bytes (a digit and a separator): check that before
    // allocating the records.
    if (h.points as u128) * (values as u128) * 2 > body.len() as u128 + 1 {
        return Err(malformed(
            path,
            format!("byte {}", h.data_start),
            format!(
                "the file is truncated: the header declares {} points of {values} values, \
                 more than its {} bytes after the header can hold",
                h.points,
                body.len()
            ),
        ));
    }
    let ps = h.point_size();
    let mut buf = vec![0u8; ps * h.points];
    let header_lines = bytes[..h.data_start]
        .iter()
        .filter(|&&b| b == b'\n')
        .count();
    let mut lines = body.split(|&b| b == b'\n').enumerate();
    for i in 0..h.points {
        let (line_idx, text) = loop {
            match lines.next() {
                None => {
                    return Err(malformed(
                        path,
                        format!("point {i}"),
                        format!(
                            "the file is truncated: it ends after {i} of the {} points the \
                             header declares",
                            h.points
                        ),
                    ));
                }
                Some((k, l)) if !l.iter().all(u8::is_ascii_whitespace) => break (k, l),
                Some(_) => {}
            }
        };
        let place = || format!("line {} (point {i})", header_lines + line_idx + 1);
        // A bad value on a last line without its newline is the file cut off, not bad data.
        let end = text.as_ptr() as usize - body.as_ptr() as usize + text.len();
        let cut = end >= body.len() && !body.ends_with(b"\n");
        let malformed = |place: String, what: String| {
            if cut {
                malformed(
                    path,
                    place,
                    format!(
                        "the file is truncated: it ends inside this point's line, but the \
                         header declares {} points",
                        h.points
                    ),
                )
            } else {
                malformed(path, place, what)
            }
        };
        let Ok(text) = std::str::from_utf8(text) else {
            return Err(malformed(place(), "a line that is not text".into()));
        };
        let mut tokens = text.split_ascii_whitespace();
        let rec = &mut buf[i * ps..(i + 1) * ps];
        let mut off = 0;
        for field in &h.fields {
            for _ in 0..field.count {
                let Some(tok) = tokens.next() else {
                    return Err(malformed(
                        place(),
                        format!(
                            "the line ends before field `{}`: a point has {values} values",
                            field.name
                        ),
                    ));
                };
                let out = &mut rec[off..off + field.size];
                off += field.size;
                if field.is_padding() {
                    continue;
                }
                let bad = || {
                    malformed(
                        place(),
                        format!(
                            "cannot read `{tok}` as field `{}` ({})",
                            field.name,
                            field.type_text()
                        ),
                    )
                };
                macro_rules! put {
                    ($t:ty) => {{
                        let v: $t = tok.parse().map_err(|_| bad())?;
                        out.copy_from_slice(&v.to_le_bytes());
                    }};
                }
                match (field.kind, field.size) {
                    (Kind::I, 1) => put!(i8),
                    (Kind::I, 2) => put!(i16),
                    (Kind::I, 4) => put!(i32),
                    (Kind::U, 1) => put!(u8),
                    (Kind::U, 2) => put!(u16),
                    (Kind::U, 4) => put!(u32),
                    (Kind::I, 8) => put!(i64),
                    (Kind::U, 8) => put!(u64),
                    (Kind::F, 4) if is_colour_integer(field, tok) => put!(u32),
                    (Kind::F, 4) => put!(f32),
                    _ => put!(f64),
                }
            }
        }
        if let Some(tok) = tokens.next() {
            return Err(malformed(
                place(),
                format!("`{tok}` after the {values} values the header declares for a point"),
            ));
        }
    }
    let extra = lines
        .filter(|(_, l)| !l.iter().all(u8::is_ascii_whitespace))
        .count();
    if extra > 0 {
        tracing::warn!(
            "{}: {extra} lines after the {} points the header declares are ignored",
            path.display(),
            h.points
        );
    }
    Ok(Body {
        buf,
        start: 0,
        layout: Layout::Records,
    })
}

/// Which slots become points: all, or those listed.
enum Slots<'a> {
    All(usize),
    Listed(&'a [u32]),
}

/// Gathers one `N`-byte value per point from `base + slot * stride`.
fn gather<const N: usize, T>(
    buf: &[u8],
    base: usize,
    stride: usize,
    slots: &Slots,
    decode: impl Fn([u8; N]) -> T,
) -> Vec<T> {
    let at = |s: usize| {
        let o = base + s * stride;
        let mut b = [0u8; N];
        b.copy_from_slice(&buf[o..o + N]);
        decode(b)
    };
    match slots {
        Slots::All(n) => (0..*n).map(at).collect(),
        Slots::Listed(l) => l.iter().map(|&s| at(s as usize)).collect(),
    }
}

/// The column of element `k` of field `f`.
fn column(h: &Header, body: &Body, f: usize, k: usize, slots: &Slots) -> Option<Column> {
    let field = &h.fields[f];
    let (base, stride) = body.place(h, f)?;
    let base = base + k * field.size;
    let b = &body.buf;
    Some(match (field.kind, field.size) {
        (Kind::I, 1) => Column::I8(gather(b, base, stride, slots, i8::from_le_bytes)),
        (Kind::I, 2) => Column::I16(gather(b, base, stride, slots, i16::from_le_bytes)),
        (Kind::I, 4) => Column::I32(gather(b, base, stride, slots, i32::from_le_bytes)),
        (Kind::U, 1) => Column::U8(gather(b, base, stride, slots, u8::from_le_bytes)),
        (Kind::U, 2) => Column::U16(gather(b, base, stride, slots, u16::from_le_bytes)),
        (Kind::U, 4) => Column::U32(gather(b, base, stride, slots, u32::from_le_bytes)),
        // 64-bit integers as f64 (the cloud has no 64-bit integer column): exact up to 2^53;
        // a PCD output writes the stored bytes back, whatever their size.
        (Kind::I, 8) => Column::F64(gather(b, base, stride, slots, |a| {
            i64::from_le_bytes(a) as f64
        })),
        (Kind::U, 8) => Column::F64(gather(b, base, stride, slots, |a| {
            u64::from_le_bytes(a) as f64
        })),
        (Kind::F, 4) => Column::F32(gather(b, base, stride, slots, f32::from_le_bytes)),
        _ => Column::F64(gather(b, base, stride, slots, f64::from_le_bytes)),
    })
}

/// Which part of a field an attribute column holds.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Part {
    /// Element `k` of the field (of its COUNT).
    Element(usize),
    /// Byte `b` of a packed colour (little-endian 0xAARRGGBB: blue is byte 0).
    ColourByte(usize),
}

/// One attribute column of the cloud: its field, the part of it and its name.
struct AttrSpec {
    field: usize,
    part: Part,
    name: String,
}

/// The attribute columns of every field but x, y, z and padding, in field order: a packed
/// colour gives red, green, blue (and alpha), a field of COUNT n gives name_0 … name_n-1.
fn attribute_specs(path: &Path, h: &Header) -> Result<Vec<AttrSpec>> {
    let mut out: Vec<AttrSpec> = Vec::new();
    for (f, field) in h.fields.iter().enumerate() {
        if field.is_padding() || matches!(field.name.as_str(), "x" | "y" | "z") {
            continue;
        }
        if field.is_packed_colour() {
            let names: &[(&str, usize)] = if field.name == "rgba" {
                &[("red", 2), ("green", 1), ("blue", 0), ("alpha", 3)]
            } else {
                &[("red", 2), ("green", 1), ("blue", 0)]
            };
            for &(name, byte) in names {
                out.push(AttrSpec {
                    field: f,
                    part: Part::ColourByte(byte),
                    name: name.into(),
                });
            }
            continue;
        }
        for k in 0..field.count {
            let name = if field.count == 1 {
                field.name.clone()
            } else {
                format!("{}_{k}", field.name)
            };
            out.push(AttrSpec {
                field: f,
                part: Part::Element(k),
                name,
            });
        }
    }
    for (i, a) in out.iter().enumerate() {
        if out[..i].iter().any(|b| b.name == a.name) {
            return Err(malformed(
                path,
                "header",
                format!(
                    "two fields give the attribute `{}` (a packed rgb/rgba gives red, green, \
                     blue and alpha; field `name` of COUNT n gives name_0 … name_n-1)",
                    a.name
                ),
            ));
        }
    }
    Ok(out)
}

/// The attributes of every field but x, y, z and padding, in field order.
fn attributes(path: &Path, h: &Header, body: &Body, slots: &Slots) -> Result<Vec<Attribute>> {
    let mut out = Vec::new();
    for spec in attribute_specs(path, h)? {
        let values = match spec.part {
            Part::ColourByte(byte) => body.place(h, spec.field).map(|(base, stride)| {
                Column::U8(gather(
                    &body.buf,
                    base + byte,
                    stride,
                    slots,
                    |b: [u8; 1]| b[0],
                ))
            }),
            Part::Element(k) => column(h, body, spec.field, k, slots),
        };
        if let Some(values) = values {
            out.push(Attribute {
                name: spec.name,
                values,
            });
        }
    }
    Ok(out)
}

/// Appends x, y, z of the `count` slots of `body` (the file's slots from `first` on) that are
/// points; for an organised frame the slots whose three coordinates are NaN are skipped and
/// the kept slots listed (as indices into `body`).
fn positions(h: &Header, body: &Body, count: usize, pos: &mut Vec<[f64; 3]>) -> Option<Vec<u32>> {
    let axes = ["x", "y", "z"].map(|a| {
        let f = h.field(a).unwrap_or(0);
        let (base, stride) = body.place(h, f).unwrap_or((0, 0));
        (base, stride, h.fields[f].size)
    });
    let buf = &body.buf;
    let read = |(base, stride, size): (usize, usize, usize), i: usize| -> f64 {
        let o = base + i * stride;
        if size == 4 {
            let mut b = [0u8; 4];
            b.copy_from_slice(&buf[o..o + 4]);
            f64::from(f32::from_le_bytes(b))
        } else {
            let mut b = [0u8; 8];
            b.copy_from_slice(&buf[o..o + 8]);
            f64::from_le_bytes(b)
        }
    };
    let point = |i: usize| [read(axes[0], i), read(axes[1], i), read(axes[2], i)];
    if !h.organised() {
        pos.extend((0..count).map(point));
        return None;
    }
    let mut slots = Vec::new();
    for i in 0..count {
        let p = point(i);
        if p.iter().all(|c| c.is_nan()) {
            continue;
        }
        pos.push(p);
        slots.push(i as u32);
    }
    Some(slots)
}

/// Appends `from` to `into` (columns of one field read chunk by chunk: same type).
fn append(into: &mut Column, from: Column) {
    match (into, from) {
        (Column::I8(a), Column::I8(b)) => a.extend(b),
        (Column::U8(a), Column::U8(b)) => a.extend(b),
        (Column::I16(a), Column::I16(b)) => a.extend(b),
        (Column::U16(a), Column::U16(b)) => a.extend(b),
        (Column::I32(a), Column::I32(b)) => a.extend(b),
        (Column::U32(a), Column::U32(b)) => a.extend(b),
        (Column::F32(a), Column::F32(b)) => a.extend(b),
        (Column::F64(a), Column::F64(b)) => a.extend(b),
        _ => {}
    }
}

/// The points of a file, decoded in one piece or chunk by chunk.
#[derive(Default)]
struct Decoded {
    positions: Vec<[f64; 3]>,
    attributes: Vec<Attribute>,
    /// The file slot of each point, for an organised frame.
    slots: Option<Vec<u32>>,
}

impl Decoded {
    /// Decodes the `count` slots of `body`, which are the file's slots from `first` on.
    fn add(
        &mut self,
        path: &Path,
        h: &Header,
        body: &Body,
        first: usize,
        count: usize,
        with_attributes: bool,
    ) -> Result<()> {
        let listed = positions(h, body, count, &mut self.positions);
        if with_attributes {
            let slots = match &listed {
                Some(l) => Slots::Listed(l),
                None => Slots::All(count),
            };
            let attrs = attributes(path, h, body, &slots)?;
            if self.attributes.is_empty() {
                self.attributes = attrs;
            } else {
                for (into, from) in self.attributes.iter_mut().zip(attrs) {
                    append(&mut into.values, from.values);
                }
            }
        }
        if let Some(l) = listed {
            self.slots
                .get_or_insert_with(Vec::new)
                .extend(l.iter().map(|&s| s + first as u32));
        }
        Ok(())
    }
}

/// Slots decoded at a time from a `binary` file read in chunks (about 1 MB of records).
const CHUNK_BYTES: usize = 1 << 20;

/// Bytes read first for the header; a longer header makes the reader read the whole file.
const HEAD_BYTES: u64 = 1 << 16;

/// Reads a `binary` or `binary_compressed` file's body in pieces, without a buffer of the
/// whole file: `binary` records chunk by chunk, decoded while they are hot in the cache;
/// `binary_compressed` through [`read_compressed_streamed`]. `None` when the header does not
/// fit in the first [`HEAD_BYTES`] or the body is ascii (the caller then reads the whole
/// file).
fn read_streamed(path: &Path) -> Result<Option<(Header, Decoded)>> {
    use std::io::{Read, Seek, SeekFrom};
    let mut file = super::open(path)?;
    let file_len = file.metadata().map(|m| m.len()).unwrap_or(0);
    let mut head = Vec::new();
    (&mut file)
        .take(HEAD_BYTES)
        .read_to_end(&mut head)
        .map_err(|e| Error::io(path, "cannot read", e))?;
    let header = match parse_header(path, &head) {
        Ok(h) if h.encoding != PcdEncoding::Ascii => h,
        Ok(_) => return Ok(None),
        Err(_) if (head.len() as u64) < file_len => return Ok(None),
        Err(e) => return Err(e),
    };
    if header.encoding == PcdEncoding::BinaryCompressed {
        let decoded = read_compressed_streamed(path, file, file_len, &header)?;
        return Ok(Some((header, decoded)));
    }
    let ps = header.point_size();
    let available = file_len.saturating_sub(header.data_start as u64);
    let need = (ps as u128) * (header.points as u128);
    if need > available as u128 {
        return Err(malformed(
            path,
            format!("byte {}", header.data_start),
            format!(
                "the file is truncated: the header declares {} points of {ps} bytes ({need} \
                 bytes), the file holds {available} bytes after the header",
                header.points
            ),
        ));
    }
    file.seek(SeekFrom::Start(header.data_start as u64))
        .map_err(|e| Error::io(path, "cannot read", e))?;
    // Never more slots than the file has: a header of huge fields and POINTS 0 must not
    // allocate a chunk.
    let per_chunk = (CHUNK_BYTES / ps).max(1).min(header.points);
    let mut out = Decoded {
        positions: Vec::with_capacity(header.points),
        ..Default::default()
    };
    let mut body = Body {
        buf: vec![0u8; per_chunk * ps],
        start: 0,
        layout: Layout::Records,
    };
    let mut first = 0;
    while first < header.points {
        let count = per_chunk.min(header.points - first);
        file.read_exact(&mut body.buf[..count * ps])
            .map_err(|e| Error::io(path, "cannot read", e))?;
        out.add(path, &header, &body, first, count, true)?;
        first += count;
    }
    Ok(Some((header, out)))
}

/// Output bytes of a `binary_compressed` body decoded at a time, after the window of earlier
/// output that LZF back references reach: small enough to stay in the cache from decoding
/// to converting.
const LZF_CHUNK: usize = 256 << 10;

/// Input bytes of a `binary_compressed` body read from the file at a time.
const LZF_READ: usize = 1 << 20;

/// Chunks a decoding thread may hand on before it waits for the converting one.
const LZF_QUEUE: usize = 4;

/// Where the values of one field's block (the `binary_compressed` layout) go.
enum Target {
    /// Coordinate `a` of the positions.
    Axis(usize),
    /// Bytes of a packed colour: (attribute, byte) pairs.
    Colour(Vec<(usize, usize)>),
    /// Element `k` to attribute `first + k`.
    Elements(usize),
}

/// One non-padding field's block of a `binary_compressed` body: its byte range in the
/// decompressed body, its value size and COUNT, and where its values go.
struct Block {
    start: u64,
    end: u64,
    kind: Kind,
    size: usize,
    count: usize,
    target: Target,
}

/// The cloud's columns for every slot of the file, filled block by block as the body
/// decodes: [`SlotSink::feed`] takes the decompressed bytes in order, in pieces of any size.
struct SlotSink {
    blocks: Vec<Block>,
    /// The block being filled.
    block: usize,
    /// Offset in the decompressed body of the next value to convert.
    at: u64,
    /// The first bytes of a value split between two pieces.
    carry: [u8; 8],
    carried: usize,
    positions: Vec<[f64; 3]>,
    attributes: Vec<Attribute>,
}

/// Writes the little-endian values of `bytes` to `col` from index `i0` on.
fn fill(col: &mut Column, i0: usize, bytes: &[u8]) {
    macro_rules! fill {
        ($v:expr, $t:ty) => {{
            const N: usize = std::mem::size_of::<$t>();
            for (d, ch) in $v[i0..].iter_mut().zip(bytes.chunks_exact(N)) {
                let mut a = [0u8; N];
                a.copy_from_slice(ch);
                *d = <$t>::from_le_bytes(a);
            }
        }};
    }
    match col {
        Column::I8(v) => fill!(v, i8),
        Column::U8(v) => fill!(v, u8),
        Column::I16(v) => fill!(v, i16),
        Column::U16(v) => fill!(v, u16),
        Column::I32(v) => fill!(v, i32),
        Column::U32(v) => fill!(v, u32),
        Column::F32(v) => fill!(v, f32),
        Column::F64(v) => fill!(v, f64),
    }
}

impl SlotSink {
    /// Zeroed columns for the header's slots (pages the system maps when they are written).
    fn new(path: &Path, h: &Header) -> Result<SlotSink> {
        let n = h.points;
        let specs = attribute_specs(path, h)?;
        let mut attributes = Vec::with_capacity(specs.len());
        for spec in &specs {
            let field = &h.fields[spec.field];
            let values = match (spec.part, field.kind, field.size) {
                (Part::ColourByte(_), _, _) | (_, Kind::U, 1) => Column::U8(vec![0; n]),
                (_, Kind::I, 1) => Column::I8(vec![0; n]),
                (_, Kind::I, 2) => Column::I16(vec![0; n]),
                (_, Kind::U, 2) => Column::U16(vec![0; n]),
                (_, Kind::I, 4) => Column::I32(vec![0; n]),
                (_, Kind::U, 4) => Column::U32(vec![0; n]),
                (_, Kind::F, 4) => Column::F32(vec![0.0; n]),
                _ => Column::F64(vec![0.0; n]),
            };
            attributes.push(Attribute {
                name: spec.name.clone(),
                values,
            });
        }
        let mut blocks = Vec::new();
        let mut start = 0u64;
        for (f, field) in h.fields.iter().enumerate() {
            if field.is_padding() {
                continue;
            }
            let target = match field.name.as_str() {
                "x" => Target::Axis(0),
                "y" => Target::Axis(1),
                "z" => Target::Axis(2),
                _ if field.is_packed_colour() => Target::Colour(
                    specs
                        .iter()
                        .enumerate()
                        .filter(|(_, s)| s.field == f)
                        .filter_map(|(i, s)| match s.part {
                            Part::ColourByte(b) => Some((i, b)),
                            Part::Element(_) => None,
                        })
                        .collect(),
                ),
                _ => Target::Elements(specs.iter().position(|s| s.field == f).unwrap_or(0)),
            };
            let end = start + (field.bytes() as u64) * (n as u64);
            blocks.push(Block {
                start,
                end,
                kind: field.kind,
                size: field.size,
                count: field.count,
                target,
            });
            start = end;
        }
        Ok(SlotSink {
            blocks,
            block: 0,
            at: 0,
            carry: [0; 8],
            carried: 0,
            positions: vec![[0.0; 3]; n],
            attributes,
        })
    }

    /// Converts the next decompressed bytes of the body.
    fn feed(&mut self, mut bytes: &[u8]) {
        while !bytes.is_empty() && self.block < self.blocks.len() {
            let b = &self.blocks[self.block];
            let size = b.size;
            let first = ((self.at - b.start) / size as u64) as usize;
            let whole = if self.carried > 0 {
                let take = (size - self.carried).min(bytes.len());
                self.carry[self.carried..self.carried + take].copy_from_slice(&bytes[..take]);
                self.carried += take;
                bytes = &bytes[take..];
                if self.carried < size {
                    return;
                }
                self.carried = 0;
                let value = self.carry;
                Self::put(
                    b,
                    &mut self.positions,
                    &mut self.attributes,
                    first,
                    &value[..size],
                );
                size
            } else {
                let left = usize::try_from(b.end - self.at).unwrap_or(usize::MAX);
                let take = bytes.len().min(left);
                let whole = take / size * size;
                if whole == 0 {
                    // Less than a value left in this piece: keep it for the next one.
                    self.carry[..take].copy_from_slice(&bytes[..take]);
                    self.carried = take;
                    return;
                }
                let (now, rest) = bytes.split_at(whole);
                Self::put(b, &mut self.positions, &mut self.attributes, first, now);
                bytes = rest;
                whole
            };
            self.at += whole as u64;
            if self.at == b.end {
                self.block += 1;
            }
        }
    }

    /// Converts whole values of block `b`, the first being value `first` of the block.
    fn put(
        b: &Block,
        positions: &mut [[f64; 3]],
        attributes: &mut [Attribute],
        first: usize,
        bytes: &[u8],
    ) {
        match &b.target {
            Target::Axis(a) => {
                let a = *a;
                let dst = &mut positions[first..];
                if b.size == 4 {
                    for (p, ch) in dst.iter_mut().zip(bytes.chunks_exact(4)) {
                        p[a] = f64::from(f32::from_le_bytes([ch[0], ch[1], ch[2], ch[3]]));
                    }
                } else {
                    for (p, ch) in dst.iter_mut().zip(bytes.chunks_exact(8)) {
                        let mut v = [0u8; 8];
                        v.copy_from_slice(ch);
                        p[a] = f64::from_le_bytes(v);
                    }
                }
            }
            Target::Colour(parts) => {
                for &(attr, byte) in parts {
                    if let Column::U8(v) = &mut attributes[attr].values {
                        for (d, ch) in v[first..].iter_mut().zip(bytes.chunks_exact(4)) {
                            *d = ch[byte];
                        }
                    }
                }
            }
            Target::Elements(attr) if b.size == 8 && b.kind != Kind::F => {
                // A 64-bit integer, as f64 (see `column`).
                for (t, ch) in bytes.chunks_exact(8).enumerate() {
                    let v = first + t;
                    let mut a = [0u8; 8];
                    a.copy_from_slice(ch);
                    let x = if b.kind == Kind::I {
                        i64::from_le_bytes(a) as f64
                    } else {
                        u64::from_le_bytes(a) as f64
                    };
                    if let Column::F64(c) = &mut attributes[attr + v % b.count].values {
                        c[v / b.count] = x;
                    }
                }
            }
            Target::Elements(attr) if b.count == 1 => {
                fill(&mut attributes[*attr].values, first, bytes)
            }
            Target::Elements(attr) => {
                for (t, ch) in bytes.chunks_exact(b.size).enumerate() {
                    let v = first + t;
                    fill(&mut attributes[attr + v % b.count].values, v / b.count, ch);
                }
            }
        }
    }

    /// The points: every slot of an unorganised file; the slots of an organised one whose
    /// x, y and z are not all NaN, listed.
    fn finish(self, h: &Header) -> Decoded {
        let SlotSink {
            mut positions,
            mut attributes,
            ..
        } = self;
        if !h.organised() {
            return Decoded {
                positions,
                attributes,
                slots: None,
            };
        }
        let keep: Vec<bool> = positions
            .iter()
            .map(|p| !p.iter().all(|c| c.is_nan()))
            .collect();
        let slots = (0..h.points as u32).filter(|&s| keep[s as usize]).collect();
        if !keep.iter().all(|&k| k) {
            let mut it = keep.iter();
            positions.retain(|_| *it.next().unwrap_or(&false));
            for a in &mut attributes {
                a.values.retain_mask(&keep);
            }
        }
        Decoded {
            positions,
            attributes,
            slots: Some(slots),
        }
    }
}

/// A piece of decompressed output handed from the decoder to the converter: the buffer and
/// the range of it that is new output (the bytes before are the window of earlier output).
type Piece = (Vec<u8>, usize, usize);

/// Decodes the `compressed` bytes of LZF from `file` (positioned at them) in pieces,
/// handing each [`LZF_CHUNK`] of output to `hand_on`, which gives back a buffer to reuse
/// (`None`: stop). Errors name the file offset of a bad token (`body` is the offset of the
/// sizes before the data).
fn decode_lzf_body(
    path: &Path,
    file: &mut std::fs::File,
    body: usize,
    compressed: usize,
    uncompressed: usize,
    hand_on: &mut dyn FnMut(Piece) -> Option<Vec<u8>>,
) -> Result<()> {
    use lzf_stream::{Cursor, MAX_TOKEN_IN, SLACK, WINDOW};
    use std::io::Read;
    let buf_len = WINDOW + LZF_CHUNK + SLACK;
    let stop = WINDOW + LZF_CHUNK;
    let mut out = vec![0u8; buf_len];
    let mut spare: Option<Vec<u8>> = None;
    let mut input = vec![0u8; LZF_READ.min(compressed).max(MAX_TOKEN_IN + 2)];
    let mut filled = 0;
    let mut unread = compressed;
    let mut c = Cursor {
        input: 0,
        output: 0,
        room: uncompressed,
        consumed_before: 0,
    };
    let mut begin = 0;
    loop {
        if filled - c.input < MAX_TOKEN_IN + 2 && unread > 0 {
            input.copy_within(c.input..filled, 0);
            filled -= c.input;
            c.consumed_before += c.input as u64;
            c.input = 0;
            let n = (input.len() - filled).min(unread);
            file.read_exact(&mut input[filled..filled + n])
                .map_err(|e| Error::io(path, "cannot read", e))?;
            filled += n;
            unread -= n;
        }
        let last = unread == 0;
        lzf_stream::decode(&input[..filled], last, &mut out, stop, &mut c)
            .map_err(|e| lzf_damaged(path, body, &e))?;
        if last && c.input == filled {
            let end = c.output;
            hand_on((out, begin, end));
            break;
        }
        if c.output >= stop {
            let mut next = spare.take().unwrap_or_else(|| vec![0u8; buf_len]);
            next[..WINDOW].copy_from_slice(&out[c.output - WINDOW..c.output]);
            let end = c.output;
            match hand_on((std::mem::replace(&mut out, next), begin, end)) {
                Some(b) if b.len() == buf_len => spare = Some(b),
                Some(_) => {}
                None => return Ok(()),
            }
            c.output = WINDOW;
            begin = WINDOW;
        }
    }
    if c.room > 0 {
        return Err(malformed(
            path,
            format!("byte {}", body + 8 + compressed),
            format!(
                "the LZF data ends after {} of the {uncompressed} bytes the sizes declare: \
                 the data is truncated or the sizes are wrong",
                uncompressed - c.room
            ),
        ));
    }
    Ok(())
}

/// Reads a `binary_compressed` body from `file` (its header read): the LZF data in pieces
/// of [`LZF_READ`] bytes, decoded [`LZF_CHUNK`] bytes at a time and each piece converted
/// into the cloud's columns while it is in the cache, with no buffer of the whole body.
/// With two or more threads (the caller's rayon pool) a second thread decodes while this
/// one converts.
fn read_compressed_streamed(
    path: &Path,
    mut file: std::fs::File,
    file_len: u64,
    h: &Header,
) -> Result<Decoded> {
    use std::io::{Read, Seek, SeekFrom};
    let at = h.data_start;
    let after = file_len.saturating_sub(at as u64);
    let mut sizes = [0u8; 8];
    let got = if after >= 8 {
        file.seek(SeekFrom::Start(at as u64))
            .and_then(|_| file.read_exact(&mut sizes))
            .map_err(|e| Error::io(path, "cannot read", e))?;
        Some(&sizes[..])
    } else {
        None
    };
    let (compressed, uncompressed) = compressed_sizes(path, h, got, after.saturating_sub(8))?;
    let mut sink = SlotSink::new(path, h)?;
    if uncompressed == 0 {
        return Ok(sink.finish(h));
    }
    if rayon::current_num_threads() < 2 {
        decode_lzf_body(
            path,
            &mut file,
            at,
            compressed,
            uncompressed,
            &mut |(buf, a, b)| {
                sink.feed(&buf[a..b]);
                Some(buf)
            },
        )?;
        return Ok(sink.finish(h));
    }
    use std::sync::mpsc::{channel, sync_channel};
    let (full_tx, full_rx) = sync_channel::<Piece>(LZF_QUEUE);
    let (free_tx, free_rx) = channel::<Vec<u8>>();
    let decoded = std::thread::scope(|s| {
        let decoder = s.spawn(move || {
            decode_lzf_body(
                path,
                &mut file,
                at,
                compressed,
                uncompressed,
                &mut |piece| {
                    full_tx.send(piece).ok()?;
                    // A converted buffer if one is back, else a new one (at most LZF_QUEUE
                    // wait in the channel, so few are ever made).
                    Some(free_rx.try_recv().unwrap_or_default())
                },
            )
        });
        for (buf, a, b) in full_rx.iter() {
            sink.feed(&buf[a..b]);
            let _ = free_tx.send(buf);
        }
        decoder.join()
    });
    match decoded {
        Ok(result) => result?,
        Err(panic) => std::panic::resume_unwind(panic),
    }
    Ok(sink.finish(h))
}

/// Reads a PCD file; with `keep`, also the [`PcdFile`] for writing it back (the cloud then
/// carries no attribute columns: the records hold them, one copy of the points, not two).
pub(crate) fn read_file(path: &Path, keep: bool) -> Result<(Loaded, Option<PcdFile>)> {
    let chunked = if keep { None } else { read_streamed(path)? };
    let (header, decoded, body) = match chunked {
        Some((h, d)) => (h, d, None),
        None => {
            let bytes = std::fs::read(path).map_err(|e| Error::io(path, "cannot read", e))?;
            let header = parse_header(path, &bytes)?;
            let body = read_body(path, &header, bytes)?;
            let mut d = Decoded {
                positions: Vec::with_capacity(header.points),
                ..Default::default()
            };
            d.add(path, &header, &body, 0, header.points, !keep)?;
            (header, d, Some(body))
        }
    };
    let Decoded {
        positions,
        attributes,
        slots: listed,
    } = decoded;
    let n = positions.len();
    let nan_slots = header.points - n;
    if header.organised() {
        tracing::debug!(
            "{}: {nan_slots} of the {} slots of the organised {} x {} frame are NaN (no \
             return): skipped, kept in a PCD output",
            path.display(),
            header.points,
            header.width,
            header.height
        );
    }
    let width = header.width as u32;
    let grid = match &listed {
        Some(l) => l.iter().map(|&s| [s / width, s % width]).collect(),
        None => Vec::new(),
    };
    let structure = ScanStructure {
        scans: vec![Scan {
            name: path
                .file_name()
                .map(|n| n.to_string_lossy().into_owned())
                .unwrap_or_default(),
            pose: header.pose(),
            grid_size: header.organised().then_some([header.height as u32, width]),
        }],
        scan: vec![0; n],
        grid,
    };
    let mut properties = Vec::with_capacity(header.fields.len());
    for f in &header.fields {
        properties.push(PropertyInfo {
            name: f.name.clone(),
            ty: f.type_text(),
        });
    }
    let v = header.viewpoint;
    let details = vec![
        ("encoding".to_string(), header.encoding.name().to_string()),
        (
            "organisation".to_string(),
            if header.organised() {
                format!(
                    "organised {} x {} (WIDTH x HEIGHT), {nan_slots} of {} slots NaN (no \
                     return, not points)",
                    header.width, header.height, header.points
                )
            } else {
                "unorganised".to_string()
            },
        ),
        (
            "viewpoint".to_string(),
            format!(
                "origin {} {} {}, orientation (w x y z) {} {} {} {}",
                v[0], v[1], v[2], v[3], v[4], v[5], v[6]
            ),
        ),
    ];
    let x = h_field(&header, "x");
    let cloud = Cloud {
        positions,
        attributes,
        source: Source {
            path: path.to_path_buf(),
            format: format!(
                "PCD {} {}, {}",
                header.version,
                header.encoding.name(),
                header.organisation_text()
            ),
            double_precision: x.is_some_and(|f| f.size == 8),
        },
        structure: Some(structure),
    };
    let original = match (keep, body) {
        (true, Some(body)) => {
            let slots = listed.unwrap_or_else(|| (0..header.points as u32).collect());
            let records = body.into_records(&header);
            Some(PcdFile {
                header,
                records,
                slots,
            })
        }
        _ => None,
    };
    Ok((
        Loaded {
            cloud,
            properties,
            other_elements: Vec::new(),
            details,
        },
        original,
    ))
}

fn h_field<'a>(h: &'a Header, name: &str) -> Option<&'a Field> {
    h.field(name).map(|f| &h.fields[f])
}

/// Reads a PCD file for analysis.
pub(crate) fn read(path: &Path) -> Result<Loaded> {
    Ok(read_file(path, false)?.0)
}

/// Writes `pcd` back to `path` with the moved points' x, y, z replaced by `rectified`
/// (one position per point of the cloud, in its order): same header, fields, organisation,
/// encoding and VIEWPOINT; every other byte as read.
pub fn write_pcd(path: &Path, pcd: &PcdFile, rectified: &[[f64; 3]], moved: &[bool]) -> Result<()> {
    let h = &pcd.header;
    if rectified.len() != pcd.slots.len() || moved.len() != pcd.slots.len() {
        return Err(Error::BadOutput {
            path: path.to_path_buf(),
            what: format!(
                "{} rectified positions and {} moved flags for a PCD of {} points",
                rectified.len(),
                moved.len(),
                pcd.slots.len()
            ),
        });
    }
    let ps = h.point_size();
    let mut records = pcd.records.clone();
    let axes = ["x", "y", "z"].map(|a| {
        let f = h.field(a).unwrap_or(0);
        let off: usize = h.fields[..f].iter().map(Field::bytes).sum();
        (off, h.fields[f].size)
    });
    for ((p, &m), &slot) in rectified.iter().zip(moved).zip(&pcd.slots) {
        if !m {
            continue;
        }
        let rec = slot as usize * ps;
        for (k, &(off, size)) in axes.iter().enumerate() {
            let o = rec + off;
            if size == 4 {
                records[o..o + 4].copy_from_slice(&(p[k] as f32).to_le_bytes());
            } else {
                records[o..o + 8].copy_from_slice(&p[k].to_le_bytes());
            }
        }
    }
    let header = header_text(h);
    super::write_atomic(path, |w| {
        let io = |e| Error::io(path, "cannot write (disk full?)", e);
        w.write_all(header.as_bytes()).map_err(io)?;
        match h.encoding {
            PcdEncoding::Binary => w.write_all(&records).map_err(io),
            PcdEncoding::BinaryCompressed => {
                let blocks = to_blocks(h, &records);
                let packed = if blocks.is_empty() {
                    Vec::new()
                } else {
                    lzf::compress(&blocks).unwrap_or_else(|_| lzf_literals(&blocks))
                };
                let sizes = [packed.len() as u32, blocks.len() as u32];
                for s in sizes {
                    w.write_all(&s.to_le_bytes()).map_err(io)?;
                }
                w.write_all(&packed).map_err(io)
            }
            PcdEncoding::Ascii => write_ascii(w, h, &records).map_err(io),
        }
    })
}

/// The records as one block per non-padding field (the binary_compressed layout).
fn to_blocks(h: &Header, records: &[u8]) -> Vec<u8> {
    let ps = h.point_size();
    let mut out = Vec::with_capacity(h.packed_size() * h.points);
    let mut off = 0;
    for f in &h.fields {
        let w = f.bytes();
        if !f.is_padding() {
            for i in 0..h.points {
                out.extend_from_slice(&records[i * ps + off..i * ps + off + w]);
            }
        }
        off += w;
    }
    out
}

/// LZF data of literal runs only (up to 32 bytes a run after a length byte): what LZF stores
/// when it finds nothing to reference, for data the compressor cannot shrink.
fn lzf_literals(data: &[u8]) -> Vec<u8> {
    let mut out = Vec::with_capacity(data.len() + data.len() / 32 + 1);
    for run in data.chunks(32) {
        out.push((run.len() - 1) as u8);
        out.extend_from_slice(run);
    }
    out
}

fn header_text(h: &Header) -> String {
    let join = |f: &dyn Fn(&Field) -> String| -> String {
        h.fields.iter().map(f).collect::<Vec<_>>().join(" ")
    };
    let viewpoint: Vec<String> = h.viewpoint.iter().map(f64::to_string).collect();
    format!(
        "# .PCD v0.7 - Point Cloud Data file format\nVERSION 0.7\nFIELDS {}\nSIZE {}\nTYPE \
         {}\nCOUNT {}\nWIDTH {}\nHEIGHT {}\nVIEWPOINT {}\nPOINTS {}\nDATA {}\n",
        join(&|f| f.name.clone()),
        join(&|f| f.size.to_string()),
        join(&|f| f.kind.letter().to_string()),
        join(&|f| f.count.to_string()),
        h.width,
        h.height,
        viewpoint.join(" "),
        h.points,
        h.encoding.name()
    )
}

/// One line per slot; floats in their shortest form that reads back to the same bits (NaN
/// as `nan`, as PCL writes it), a packed float colour as its bits' integer (as PCL writes
/// `rgb`: many colours are NaN bit patterns).
fn write_ascii(w: &mut dyn std::io::Write, h: &Header, records: &[u8]) -> std::io::Result<()> {
    let ps = h.point_size();
    let mut s = String::with_capacity(1 << 16);
    for i in 0..h.points {
        let rec = &records[i * ps..(i + 1) * ps];
        let mut off = 0;
        let mut first = true;
        for f in &h.fields {
            for _ in 0..f.count {
                let b = &rec[off..off + f.size];
                off += f.size;
                if !first {
                    s.push(' ');
                }
                first = false;
                push_ascii(&mut s, f, b);
            }
        }
        s.push('\n');
        if s.len() > (1 << 16) - 1024 {
            w.write_all(s.as_bytes())?;
            s.clear();
        }
    }
    w.write_all(s.as_bytes())
}

fn push_ascii(s: &mut String, f: &Field, b: &[u8]) {
    let mut a4 = [0u8; 4];
    let mut a8 = [0u8; 8];
    let mut a2 = [0u8; 2];
    let _ = match (f.kind, f.size) {
        (Kind::I, 1) => write!(s, "{}", b[0] as i8),
        (Kind::U, 1) => write!(s, "{}", b[0]),
        (Kind::I, 2) | (Kind::U, 2) => {
            a2.copy_from_slice(b);
            if f.kind == Kind::I {
                write!(s, "{}", i16::from_le_bytes(a2))
            } else {
                write!(s, "{}", u16::from_le_bytes(a2))
            }
        }
        (Kind::I, 4) => {
            a4.copy_from_slice(b);
            write!(s, "{}", i32::from_le_bytes(a4))
        }
        (Kind::U, 4) => {
            a4.copy_from_slice(b);
            write!(s, "{}", u32::from_le_bytes(a4))
        }
        (Kind::I, 8) => {
            a8.copy_from_slice(b);
            write!(s, "{}", i64::from_le_bytes(a8))
        }
        (Kind::U, 8) => {
            a8.copy_from_slice(b);
            write!(s, "{}", u64::from_le_bytes(a8))
        }
        (Kind::F, 4) => {
            a4.copy_from_slice(b);
            if f.is_packed_colour() {
                write!(s, "{}", u32::from_le_bytes(a4))
            } else {
                push_float(s, f64::from(f32::from_le_bytes(a4)), f32::from_le_bytes(a4));
                Ok(())
            }
        }
        _ => {
            a8.copy_from_slice(b);
            push_float(s, f64::from_le_bytes(a8), f64::from_le_bytes(a8));
            Ok(())
        }
    };
}

/// A float in the shortest decimal that parses back to the same value (`{:?}` of Rust
/// floats, with an exponent where that is shorter), `nan` and `inf` as PCL writes them.
fn push_float(s: &mut String, v: f64, shortest: impl std::fmt::Display + std::fmt::LowerExp) {
    if v.is_nan() {
        s.push_str("nan");
    } else if v.is_infinite() {
        s.push_str(if v > 0.0 { "inf" } else { "-inf" });
    } else if v != 0.0 && !(1e-5..1e16).contains(&v.abs()) {
        let _ = write!(s, "{shortest:e}");
    } else {
        let _ = write!(s, "{shortest}");
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn header(text: &str) -> Result<Header> {
        parse_header(Path::new("t.pcd"), text.as_bytes())
    }

    const XYZ: &str = "FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\n";

    #[test]
    fn header_defaults_follow_pcl() {
        let h = header("VERSION .5\nFIELDS x y z\nSIZE 4 4 4\nPOINTS 3\nDATA ascii\n").unwrap();
        assert_eq!((h.width, h.height, h.points), (3, 1, 3));
        assert_eq!(h.version, "0.5");
        assert!(h.fields.iter().all(|f| f.kind == Kind::F && f.count == 1));
        assert_eq!(h.viewpoint, [0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0]);
    }

    #[test]
    fn header_errors_name_what_is_wrong() {
        let e = |t: &str| header(t).unwrap_err().to_string();
        assert!(
            e(&format!("{XYZ}WIDTH 4\nHEIGHT 2\nPOINTS 7\nDATA binary\n"))
                .contains("POINTS 7 is not WIDTH 4 x HEIGHT 2"),
        );
        assert!(
            e("FIELDS x y z\nSIZE 4 4 2\nTYPE F F F\nWIDTH 1\nDATA binary\n")
                .contains("field `z` has TYPE F SIZE 2, which is no PCD type")
        );
        assert!(
            e("FIELDS x y\nSIZE 4 4\nTYPE F F\nWIDTH 1\nDATA binary\n")
                .contains("no `z` field (FIELDS x y)")
        );
        assert!(
            e(&format!("{XYZ}WIDTH 1\nBOGUS 3\n"))
                .contains("t.pcd: line 6: `BOGUS 3` is no PCD header line")
        );
        assert!(e(&format!("{XYZ}WIDTH 1\nDATA zip\n")).contains("unknown DATA `zip`"));
        assert!(e(&format!("{XYZ}WIDTH 1\n")).contains("ends before the DATA line"));
    }

    #[test]
    fn lzf_literal_runs_decompress() {
        let data: Vec<u8> = (0..100u8).collect();
        let packed = lzf_literals(&data);
        assert_eq!(lzf::decompress(&packed, 100).unwrap(), data);
    }

    #[test]
    fn ascii_floats_read_back_bit_for_bit() {
        let f = Field {
            name: "v".into(),
            kind: Kind::F,
            size: 4,
            count: 1,
        };
        for v in [0.1f32, -1.5e-7, 3.4e38, 1e-45, 123456.79] {
            let mut s = String::new();
            push_ascii(&mut s, &f, &v.to_le_bytes());
            assert_eq!(s.parse::<f32>().unwrap().to_bits(), v.to_bits(), "{s}");
        }
    }
}
