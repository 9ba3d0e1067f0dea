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
//! them in 0.14–0.22 s and 0.56–0.71 s (binary PLY of the same points 0.15–0.22 s, PCL 1.13's
//! loadPCDFile 0.36–0.40 s and 0.87–0.89 s). A `binary` body is read in chunks of about 1 MB
//! and decoded while hot (no buffer of the whole file); a `binary_compressed` body is
//! decompressed whole by the `lzf` crate (0.26 s of the 0.56 s: a decoder of our own copying
//! runs with `extend_from_within` took 0.30 s, so the crate stays), then its field blocks are
//! decoded. Every size in the header is checked against the file's length before anything is
//! allocated, so a lying header gives an error, never an allocation the file cannot back.

use std::fmt::Write as _;
use std::path::Path;

use super::{Loaded, PropertyInfo, attribute};
use crate::cloud::{Attribute, Cloud, Column, Pose, Scan, ScanStructure, Source};
use crate::error::{Error, Result};

/// The type/size pairs PCD defines, for error messages.
const PCD_TYPES: &str = "I 1, I 2, I 4, U 1, U 2, U 4, F 4, F 8";

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
            (Kind::I | Kind::U, 1 | 2 | 4) | (Kind::F, 4 | 8)
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

fn read_compressed(path: &Path, h: &Header, bytes: &[u8]) -> Result<Body> {
    let at = h.data_start;
    let place = format!("byte {at}");
    let Some(sizes) = bytes.get(at..at + 8) else {
        return Err(malformed(
            path,
            place,
            "the file is truncated: it ends before the compressed and uncompressed sizes \
             of binary_compressed data",
        ));
    };
    let compressed = u32::from_le_bytes([sizes[0], sizes[1], sizes[2], sizes[3]]) as usize;
    let uncompressed = u32::from_le_bytes([sizes[4], sizes[5], sizes[6], sizes[7]]) as usize;
    let available = bytes.len() - at - 8;
    if compressed > available {
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
    if uncompressed == 0 {
        return Ok(Body {
            buf: Vec::new(),
            start: 0,
            layout: Layout::Blocks,
        });
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
    let data = &bytes[at + 8..at + 8 + compressed];
    let buf = lzf::decompress(data, uncompressed).map_err(|e| {
        malformed(
            path,
            format!("byte {}", at + 8),
            format!("the LZF data is damaged ({e})"),
        )
    })?;
    if buf.len() != uncompressed {
        return Err(malformed(
            path,
            format!("byte {}", at + 8),
            format!(
                "the LZF data decompresses to {} bytes, the header says {uncompressed}: the \
                 data is damaged or the sizes are wrong",
                buf.len()
            ),
        ));
    }
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
        (Kind::F, 4) => Column::F32(gather(b, base, stride, slots, f32::from_le_bytes)),
        _ => Column::F64(gather(b, base, stride, slots, f64::from_le_bytes)),
    })
}

/// The attributes of every field but x, y, z and padding, in field order.
fn attributes(path: &Path, h: &Header, body: &Body, slots: &Slots) -> Result<Vec<Attribute>> {
    let mut out: Vec<Attribute> = Vec::new();
    for (f, field) in h.fields.iter().enumerate() {
        if field.is_padding() || matches!(field.name.as_str(), "x" | "y" | "z") {
            continue;
        }
        if field.is_packed_colour() {
            // Little-endian 0xAARRGGBB: blue is the first byte.
            let Some((base, stride)) = body.place(h, f) else {
                continue;
            };
            let names: &[(&str, usize)] = if field.name == "rgba" {
                &[("red", 2), ("green", 1), ("blue", 0), ("alpha", 3)]
            } else {
                &[("red", 2), ("green", 1), ("blue", 0)]
            };
            for &(name, byte) in names {
                let v = gather(&body.buf, base + byte, stride, slots, |b: [u8; 1]| b[0]);
                out.push(attribute(name, Column::U8(v)));
            }
            continue;
        }
        for k in 0..field.count {
            let name = if field.count == 1 {
                field.name.clone()
            } else {
                format!("{}_{k}", field.name)
            };
            if let Some(values) = column(h, body, f, k, slots) {
                out.push(Attribute { name, values });
            }
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

/// Reads a `binary` file's body chunk by chunk: no buffer of the whole file, and the
/// records are decoded while they are hot in the cache. `None` when the header does not fit
/// in the first [`HEAD_BYTES`] (the caller then reads the whole file).
fn read_binary_chunked(path: &Path) -> Result<Option<(Header, Decoded)>> {
    use std::io::{Read, Seek, SeekFrom};
    let mut file = super::open(path)?;
    let file_len = file.metadata().map(|m| m.len()).unwrap_or(0);
    let mut head = Vec::new();
    (&mut file)
        .take(HEAD_BYTES)
        .read_to_end(&mut head)
        .map_err(|e| Error::io(path, "cannot read", e))?;
    let header = match parse_header(path, &head) {
        Ok(h) if h.encoding == PcdEncoding::Binary => h,
        Ok(_) => return Ok(None),
        Err(_) if (head.len() as u64) < file_len => return Ok(None),
        Err(e) => return Err(e),
    };
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

/// Reads a PCD file; with `keep`, also the [`PcdFile`] for writing it back (the cloud then
/// carries no attribute columns: the records hold them, one copy of the points, not two).
pub(crate) fn read_file(path: &Path, keep: bool) -> Result<(Loaded, Option<PcdFile>)> {
    let chunked = if keep {
        None
    } else {
        read_binary_chunked(path)?
    };
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
