//! PLY: reading the `vertex` element of any PLY file, writing point clouds (and edge graphs).
//!
//! Reading parses the header with ply-rs-bw, consumes the elements before `vertex` (faces,
//! range grids, custom elements, with list properties) through the crate's typed path into a
//! zero-sized element type that ignores them, and never reads the elements after `vertex`.
//! The vertices themselves are decoded
//! * in binary files by a hand-written column decoder ([`read_binary_vertices`]): the crate's
//!   typed path measured ~6–7x a plain read of the bytes on a 5M-point file, over the
//!   required 6x, the decoder ~1.8x (benches/read.rs);
//! * in ascii files by a hand-written line decoder ([`read_ascii_vertices`]), whose float
//!   syntax takes `nan` and `inf` (invalid points as PCL writes them), which the crate's
//!   grammar refuses. The crate's typed path (`PropertyAccess` on [`VertexRec`], read in
//!   chunks of [`CHUNK`]) is kept as the reference both decoders are tested against.
//!
//! x, y, z become f64 positions; every other vertex property becomes an [`Attribute`] with
//! its own type and name. The crate's generic per-vertex property maps are never used (one
//! hash map per vertex made a 5M-point read ~25x slower).
//!
//! Writing is done by hand (the layout is trivial and the crate's writer would need a
//! `PropertyAccess` getter call per value): a header listing `x y z` in the requested precision
//! and every attribute with its type, an optional `element edge` (`int vertex1, int vertex2`),
//! and a body in binary little endian or ascii, through [`super::write_atomic`].

use std::collections::HashMap;
use std::fmt::Write as _;
use std::io::{BufRead, BufReader, ErrorKind, Read, Seek, SeekFrom, Write};
use std::path::Path;

use ply_rs_bw::parser::{ParseError, Parser, Reader};
use ply_rs_bw::ply::{
    ElementDef, Encoding, PropertyAccess, PropertyAccessResult, PropertyType, ScalarType,
};

use super::{ElementInfo, Loaded, PropertyInfo};
use crate::cloud::{Attribute, Cloud, Column, Source};
use crate::error::{Error, Result};
use crate::progress::Progress;

/// Vertices per chunk: bounds the crate's intermediate `Vec<VertexRec>` (~8 MB) and sets the
/// progress-bar granularity.
const CHUNK: usize = 1 << 16;

/// Attribute values kept inline per vertex; more spill into a heap vector (slower, rare).
const INLINE: usize = 8;

/// The scalar type names PLY allows, for error messages.
const PLY_TYPES: &str = "char uchar short ushort int uint float double \
                         (or int8 uint8 int16 uint16 int32 uint32 float32 float64)";

fn is_ply_type(t: &str) -> bool {
    matches!(
        t,
        "char"
            | "uchar"
            | "short"
            | "ushort"
            | "int"
            | "uint"
            | "float"
            | "double"
            | "int8"
            | "uint8"
            | "int16"
            | "uint16"
            | "int32"
            | "uint32"
            | "float32"
            | "float64"
    )
}

fn scalar_name(t: &ScalarType) -> &'static str {
    match t {
        ScalarType::Char => "char",
        ScalarType::UChar => "uchar",
        ScalarType::Short => "short",
        ScalarType::UShort => "ushort",
        ScalarType::Int => "int",
        ScalarType::UInt => "uint",
        ScalarType::Float => "float",
        ScalarType::Double => "double",
    }
}

fn type_name(t: &PropertyType) -> String {
    match t {
        PropertyType::Scalar(s) => scalar_name(s).to_string(),
        PropertyType::List(i, s) => format!("list {} {}", scalar_name(i), scalar_name(s)),
    }
}

fn empty_column(t: &ScalarType, capacity: usize) -> Column {
    match t {
        ScalarType::Char => Column::I8(Vec::with_capacity(capacity)),
        ScalarType::UChar => Column::U8(Vec::with_capacity(capacity)),
        ScalarType::Short => Column::I16(Vec::with_capacity(capacity)),
        ScalarType::UShort => Column::U16(Vec::with_capacity(capacity)),
        ScalarType::Int => Column::I32(Vec::with_capacity(capacity)),
        ScalarType::UInt => Column::U32(Vec::with_capacity(capacity)),
        ScalarType::Float => Column::F32(Vec::with_capacity(capacity)),
        ScalarType::Double => Column::F64(Vec::with_capacity(capacity)),
    }
}

/// One vertex as the typed parser fills it. Every PLY scalar (up to u32/i32 and f32/f64) is
/// exactly representable as f64, so attribute values are held as f64 and cast back to their
/// column's type without loss.
struct VertexRec {
    xyz: [f64; 3],
    n: usize,
    inline: [f64; INLINE],
    more: Vec<f64>,
}

impl VertexRec {
    #[inline]
    fn put(&mut self, name: &str, v: f64) -> PropertyAccessResult {
        match name.as_bytes() {
            b"x" => self.xyz[0] = v,
            b"y" => self.xyz[1] = v,
            b"z" => self.xyz[2] = v,
            // Properties arrive in header order, so the k-th other property is attribute k.
            _ => {
                if self.n < INLINE {
                    self.inline[self.n] = v;
                } else {
                    self.more.push(v);
                }
                self.n += 1;
            }
        }
        PropertyAccessResult::Set
    }

    #[inline]
    fn extra(&self, i: usize) -> f64 {
        if i < INLINE {
            self.inline[i]
        } else {
            self.more[i - INLINE]
        }
    }
}

impl PropertyAccess for VertexRec {
    fn new() -> Self {
        VertexRec {
            xyz: [0.0; 3],
            n: 0,
            inline: [0.0; INLINE],
            more: Vec::new(),
        }
    }
    fn set_char(&mut self, name: &str, v: i8) -> PropertyAccessResult {
        self.put(name, f64::from(v))
    }
    fn set_uchar(&mut self, name: &str, v: u8) -> PropertyAccessResult {
        self.put(name, f64::from(v))
    }
    fn set_short(&mut self, name: &str, v: i16) -> PropertyAccessResult {
        self.put(name, f64::from(v))
    }
    fn set_ushort(&mut self, name: &str, v: u16) -> PropertyAccessResult {
        self.put(name, f64::from(v))
    }
    fn set_int(&mut self, name: &str, v: i32) -> PropertyAccessResult {
        self.put(name, f64::from(v))
    }
    fn set_uint(&mut self, name: &str, v: u32) -> PropertyAccessResult {
        self.put(name, f64::from(v))
    }
    fn set_float(&mut self, name: &str, v: f32) -> PropertyAccessResult {
        self.put(name, f64::from(v))
    }
    fn set_double(&mut self, name: &str, v: f64) -> PropertyAccessResult {
        self.put(name, v)
    }
    // List properties in the vertex element are rejected from the header before any body is
    // read; the default list hooks (ignore) are never reached.
}

/// An element we only need to get past. Zero-sized: a `Vec<Skip>` of any length allocates
/// nothing, and every value is ignored by the trait's default setters.
struct Skip;

impl PropertyAccess for Skip {
    fn new() -> Self {
        Skip
    }
}

/// Appends a chunk of parsed vertices to the position and attribute columns.
fn append_chunk(recs: &[VertexRec], positions: &mut Vec<[f64; 3]>, columns: &mut [Column]) {
    positions.extend(recs.iter().map(|r| r.xyz));
    for (i, col) in columns.iter_mut().enumerate() {
        // The casts are exact: each value was widened from this very type.
        match col {
            Column::I8(v) => v.extend(recs.iter().map(|r| r.extra(i) as i8)),
            Column::U8(v) => v.extend(recs.iter().map(|r| r.extra(i) as u8)),
            Column::I16(v) => v.extend(recs.iter().map(|r| r.extra(i) as i16)),
            Column::U16(v) => v.extend(recs.iter().map(|r| r.extra(i) as u16)),
            Column::I32(v) => v.extend(recs.iter().map(|r| r.extra(i) as i32)),
            Column::U32(v) => v.extend(recs.iter().map(|r| r.extra(i) as u32)),
            Column::F32(v) => v.extend(recs.iter().map(|r| r.extra(i) as f32)),
            Column::F64(v) => v.extend(recs.iter().map(|r| r.extra(i))),
        }
    }
}

/// The crate's error text without its `Line N: ` prefix, on one line.
fn crate_message(e: &ParseError) -> String {
    let s = e.to_string();
    let s = match (e.line(), s.split_once(": ")) {
        (Some(_), Some((head, rest))) if head.starts_with("Line ") => rest.to_string(),
        _ => s,
    };
    s.replace("\n\t", "; ").replace('\n', "; ")
}

fn is_io_failure(kind: ErrorKind) -> bool {
    !matches!(
        kind,
        ErrorKind::InvalidInput | ErrorKind::InvalidData | ErrorKind::UnexpectedEof
    )
}

/// Line `line` (1-based) of the file's header, for quoting in errors.
fn header_line_text(path: &Path, line: usize) -> Option<String> {
    let mut head = Vec::new();
    std::fs::File::open(path)
        .ok()?
        .take(1 << 20)
        .read_to_end(&mut head)
        .ok()?;
    let text = String::from_utf8_lossy(&head);
    let l = text.split('\n').nth(line.checked_sub(1)?)?;
    let l = l.trim_end_matches('\r');
    Some(l.chars().take(120).collect())
}

/// Why a header line did not parse, in the user's terms.
fn explain_header_line(text: &str) -> String {
    let t: Vec<&str> = text.split_whitespace().collect();
    match t.first().copied() {
        Some("property") => {
            let types: &[&str] = if t.get(1) == Some(&"list") {
                &t[2.min(t.len())..4.min(t.len())]
            } else {
                &t[1.min(t.len())..2.min(t.len())]
            };
            if let Some(bad) = types.iter().find(|ty| !is_ply_type(ty)) {
                format!("unknown PLY type `{bad}` in `{text}`; the PLY types are {PLY_TYPES}")
            } else {
                format!(
                    "cannot parse `{text}`: expected `property TYPE NAME` or \
                     `property list COUNT_TYPE TYPE NAME` (names start with a letter or `_`)"
                )
            }
        }
        Some("element") => format!("cannot parse `{text}`: expected `element NAME COUNT`"),
        Some("format") => format!(
            "cannot parse `{text}`: expected `format ascii 1.0`, \
             `format binary_little_endian 1.0` or `format binary_big_endian 1.0`"
        ),
        _ => format!(
            "cannot parse `{text}`: header lines start with format, element, property, \
             comment, obj_info or end_header"
        ),
    }
}

fn header_error(path: &Path, e: &ParseError) -> Error {
    if is_io_failure(e.kind()) {
        return Error::io(
            path,
            "cannot read",
            std::io::Error::new(e.kind(), e.to_string()),
        );
    }
    let msg = crate_message(e);
    match e.line() {
        Some(1) if msg.contains("magic number") => Error::malformed(
            path,
            "line 1",
            "not a PLY file: the first line must be `ply` (is the extension right?)",
        ),
        None if msg.contains("magic number") => {
            Error::malformed(path, "line 1", "not a PLY file: the file is empty")
        }
        Some(line) if e.kind() == ErrorKind::UnexpectedEof => Error::malformed(
            path,
            format!("header line {line}"),
            "the file ends inside the header (no `end_header` line): truncated file?",
        ),
        Some(line) => {
            let what = match header_line_text(path, line) {
                Some(text) if msg.starts_with("Couldn't parse line") => explain_header_line(&text),
                Some(text) => format!("{msg} (line: `{text}`)"),
                None => msg,
            };
            Error::malformed(path, format!("header line {line}"), what)
        }
        None => Error::malformed(path, "header", msg),
    }
}

/// Error while reading the items of `element`; `start_line` is the parser's line counter
/// when the element began (for ascii the file line of its first item; for binary the
/// counter advances by one per item too, so the difference is the item index either way).
fn body_error(
    path: &Path,
    e: &ParseError,
    element: &str,
    count: usize,
    start_line: usize,
    encoding: Encoding,
) -> Error {
    if is_io_failure(e.kind()) {
        return Error::io(
            path,
            "cannot read",
            std::io::Error::new(e.kind(), e.to_string()),
        );
    }
    let index = e.line().map(|l| l.saturating_sub(start_line));
    let item = match index {
        Some(i) => format!("{element} {i} of {count}"),
        None => format!("element `{element}` ({count} items)"),
    };
    let place = match (encoding, e.line()) {
        (Encoding::Ascii, Some(line)) => format!("line {line} ({item})"),
        _ => item,
    };
    let what = if e.kind() == ErrorKind::UnexpectedEof {
        format!(
            "the file ends here, but the header declares {count} `{element}` items: the file \
             is truncated or its header promises more than the body holds"
        )
    } else {
        format!("cannot read the values: {}", crate_message(e))
    };
    Error::malformed(path, place, what)
}

/// How the vertex element is decoded.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum VertexPath {
    /// The hand-written decoders: [`read_binary_vertices`], [`read_ascii_vertices`].
    Fast,
    /// Always the crate's typed path (kept as the reference the fast path is tested against).
    Crate,
}

/// Reads the vertices of a PLY file (see the module comment).
pub(crate) fn read(path: &Path, path_choice: VertexPath) -> Result<Loaded> {
    let file = super::open(path)?;
    let file_len = file.metadata().map(|m| m.len()).unwrap_or(0);
    let mut reader = Reader::new(BufReader::with_capacity(1 << 17, file));
    let header = Parser::<Skip>::new()
        .read_header(&mut reader)
        .map_err(|e| header_error(path, &e))?;
    check_unique_names(path, reader.get_mut())?;

    let Some(vertex_def) = header.elements.get("vertex").cloned() else {
        let names: Vec<&str> = header.elements.keys().map(|k| k.as_str()).collect();
        let list = if names.is_empty() {
            "none".to_string()
        } else {
            names.join(", ")
        };
        return Err(Error::malformed(
            path,
            "header",
            format!("no `vertex` element; elements are: {list}"),
        ));
    };
    let (coord_types, extras) = vertex_layout(path, &vertex_def)?;

    let mut properties = Vec::new();
    for (name, t) in ["x", "y", "z"].iter().zip(&coord_types) {
        properties.push(PropertyInfo {
            name: name.to_string(),
            ty: scalar_name(t).to_string(),
        });
    }
    for (name, t) in &extras {
        properties.push(PropertyInfo {
            name: name.clone(),
            ty: scalar_name(t).to_string(),
        });
    }
    let other_elements = header
        .elements
        .values()
        .filter(|e| e.name != "vertex")
        .map(|e| ElementInfo {
            name: e.name.clone(),
            count: e.count,
        })
        .collect();

    // Consume the elements that precede `vertex`; those after it are never read.
    for def in header.elements.values() {
        if def.name == "vertex" {
            break;
        }
        skip_element(&mut reader, path, def, &header, file_len)?;
    }

    let n = vertex_def.count;
    if header.encoding != Encoding::Ascii {
        // An ascii body is read line by line, each line consuming the file, and says which
        // line is missing when it ends early.
        check_element_fits(&mut reader, path, &vertex_def, header.encoding, file_len)?;
    }
    // Never trust the header's count for allocation: a lying header could ask for terabytes.
    // Each vertex takes at least one byte per property in any encoding.
    let min_bytes = vertex_def.properties.len().max(1) as u64;
    let capacity = (n as u64).min(file_len / min_bytes) as usize;
    let mut positions = Vec::with_capacity(capacity);
    let mut columns: Vec<Column> = extras
        .iter()
        .map(|(_, t)| empty_column(t, capacity))
        .collect();

    let progress = if n as u64 >= super::PROGRESS_MIN_POINTS {
        Progress::start("read", n as u64, "points")
    } else {
        Progress::hidden()
    };
    if path_choice == VertexPath::Fast && header.encoding == Encoding::Ascii {
        let first_line = reader.line();
        read_ascii_vertices(
            reader.get_mut(),
            path,
            &vertex_def,
            first_line,
            &mut positions,
            &mut columns,
            &progress,
        )?;
    } else if path_choice == VertexPath::Fast {
        let big_endian = header.encoding == Encoding::BinaryBigEndian;
        read_binary_vertices(
            reader.get_mut(),
            path,
            &vertex_def,
            big_endian,
            &mut positions,
            &mut columns,
            &progress,
        )?;
    } else {
        let parser = Parser::<VertexRec>::new();
        let start = reader.line();
        let mut chunk_def = vertex_def.clone();
        let mut done = 0;
        while done < n {
            chunk_def.count = CHUNK.min(n - done);
            let recs = parser
                .read_payload_for_element(&mut reader, &chunk_def, &header)
                .map_err(|e| body_error(path, &e, "vertex", n, start, header.encoding))?;
            append_chunk(&recs, &mut positions, &mut columns);
            done += chunk_def.count;
            progress.inc(chunk_def.count as u64);
        }
    }

    let double_precision = coord_types.iter().enumerate().any(|(k, t)| match t {
        ScalarType::Double => true,
        // 32-bit integers beyond 2^24 do not fit f32's mantissa.
        ScalarType::Int | ScalarType::UInt => positions.iter().any(|p| p[k].abs() > 16777216.0),
        _ => false,
    });
    let attributes = extras
        .into_iter()
        .zip(columns)
        .map(|((name, _), values)| Attribute { name, values })
        .collect();
    Ok(Loaded {
        cloud: Cloud {
            positions,
            attributes,
            source: Source {
                path: path.to_path_buf(),
                format: format!("PLY {} {}", header.encoding, header.version),
                double_precision,
            },
            structure: None,
        },
        properties,
        other_elements,
        details: Vec::new(),
    })
}

/// Points per chunk of [`stream_positions`]: 1M points (24 MB of positions plus the record
/// bytes), few calls, and a chunk far smaller than any tile worth streaming for.
const STREAM_CHUNK: usize = 1 << 20;

/// Streams the vertex positions of a PLY file (binary or ascii) in chunks of at most
/// [`STREAM_CHUNK`] points, in file order, to `f`, without holding the cloud: the tiles of a
/// cloud larger than memory are cut from it this way (`tiles`). The vertex properties other
/// than x, y, z are decoded and dropped chunk by chunk. Returns the vertex count and the
/// format's description (as `Source::format`).
pub(crate) fn stream_positions(
    path: &Path,
    f: &mut (dyn FnMut(&[[f64; 3]]) -> Result<()> + Send),
) -> Result<(u64, String)> {
    let file = super::open(path)?;
    let file_len = file.metadata().map(|m| m.len()).unwrap_or(0);
    let mut reader = Reader::new(BufReader::with_capacity(1 << 17, file));
    let header = Parser::<Skip>::new()
        .read_header(&mut reader)
        .map_err(|e| header_error(path, &e))?;
    check_unique_names(path, reader.get_mut())?;
    let Some(vertex_def) = header.elements.get("vertex").cloned() else {
        return Err(Error::malformed(path, "header", "no `vertex` element"));
    };
    let (_, extras) = vertex_layout(path, &vertex_def)?;
    for def in header.elements.values() {
        if def.name == "vertex" {
            break;
        }
        skip_element(&mut reader, path, def, &header, file_len)?;
    }
    let n = vertex_def.count;
    if header.encoding != Encoding::Ascii {
        check_element_fits(&mut reader, path, &vertex_def, header.encoding, file_len)?;
    }
    let progress = if n as u64 >= super::PROGRESS_MIN_POINTS {
        Progress::start("read", n as u64, "points")
    } else {
        Progress::hidden()
    };
    let first_line = reader.line();
    let mut positions = Vec::with_capacity(STREAM_CHUNK.min(n));
    let mut chunk_def = vertex_def.clone();
    let mut done = 0;
    while done < n {
        chunk_def.count = STREAM_CHUNK.min(n - done);
        positions.clear();
        let mut columns: Vec<Column> = extras.iter().map(|(_, t)| empty_column(t, 0)).collect();
        if header.encoding == Encoding::Ascii {
            read_ascii_vertices(
                reader.get_mut(),
                path,
                &chunk_def,
                first_line + done,
                &mut positions,
                &mut columns,
                &progress,
            )?;
        } else {
            let big_endian = header.encoding == Encoding::BinaryBigEndian;
            read_binary_vertices(
                reader.get_mut(),
                path,
                &chunk_def,
                big_endian,
                &mut positions,
                &mut columns,
                &progress,
            )?;
        }
        f(&positions)?;
        done += chunk_def.count;
    }
    Ok((
        n as u64,
        format!("PLY {} {}", header.encoding, header.version),
    ))
}

/// Checks the header for names ply-rs-bw would merge without a word: it keeps elements and
/// their properties in maps keyed by name, so a second `x` (or a second `vertex` element)
/// replaces the first and the body would be decoded with a record layout that is not the
/// file's. Reads the header again (the crate has just parsed it, so it ends) through the
/// reader's own handle, then goes back to where the reader was: a file deleted or replaced
/// meanwhile is still the one read. A hash map per element keeps this linear in the header's
/// length, however many properties it names.
pub(crate) fn check_unique_names<R: BufRead + Seek>(path: &Path, r: &mut R) -> Result<()> {
    let io = |e| Error::io(path, "cannot read", e);
    let back = r.stream_position().map_err(io)?;
    r.seek(SeekFrom::Start(0)).map_err(io)?;
    let checked = unique_names(path, r);
    r.seek(SeekFrom::Start(back)).map_err(io)?;
    checked
}

fn unique_names(path: &Path, r: &mut impl BufRead) -> Result<()> {
    let mut elements: HashMap<String, usize> = HashMap::new();
    let mut properties: HashMap<String, usize> = HashMap::new();
    let mut element = String::new();
    let mut buf = Vec::new();
    let mut line = 0usize;
    loop {
        buf.clear();
        let got = r
            .read_until(b'\n', &mut buf)
            .map_err(|e| Error::io(path, "cannot read", e))?;
        if got == 0 {
            return Ok(());
        }
        line += 1;
        let text = String::from_utf8_lossy(&buf);
        let words: Vec<&str> = text.split_whitespace().collect();
        match words.as_slice() {
            ["end_header", ..] => return Ok(()),
            ["element", name, ..] => {
                if let Some(first) = elements.insert(name.to_string(), line) {
                    return Err(Error::malformed(
                        path,
                        format!("header line {line}"),
                        format!(
                            "element `{name}` is declared twice (header lines {first} and \
                             {line}): which one is meant is ambiguous; rename or remove one"
                        ),
                    ));
                }
                element = name.to_string();
                properties.clear();
            }
            ["property", .., name] => {
                if let Some(first) = properties.insert(name.to_string(), line) {
                    return Err(Error::malformed(
                        path,
                        format!("header line {line}"),
                        format!(
                            "element `{element}` has two properties named `{name}` (header \
                             lines {first} and {line}): which one is meant is ambiguous; \
                             rename or remove one"
                        ),
                    ));
                }
            }
            _ => {}
        }
    }
}

/// The fewest bytes one item of `def` takes in a binary body (a list at least its count)
/// and whether every item takes exactly that (scalar properties only).
fn min_binary_size(def: &ElementDef) -> (u64, bool) {
    let mut size = 0u64;
    let mut fixed = true;
    for p in def.properties.values() {
        size += match &p.data_type {
            PropertyType::Scalar(t) => scalar_size(t) as u64,
            PropertyType::List(count, _) => {
                fixed = false;
                scalar_size(count) as u64
            }
        };
    }
    (size, fixed)
}

/// Checks, before anything is read or allocated for it, that the `def.count` items the
/// header declares can fit in the bytes left after the reader's position: in a binary body
/// count x the smallest item size, in an ascii body one line (at least one byte) an item.
/// A header count is never trusted: 2^64 - 1 items of a zero-size element would otherwise be
/// skipped one by one for ever, and a huge count of small items read until the file ends.
pub(crate) fn check_element_fits<R: BufRead + Seek>(
    reader: &mut Reader<R>,
    path: &Path,
    def: &ElementDef,
    encoding: Encoding,
    file_len: u64,
) -> Result<()> {
    let pos = reader
        .get_mut()
        .stream_position()
        .map_err(|e| Error::io(path, "cannot read", e))?;
    let remaining = file_len.saturating_sub(pos);
    let count = def.count as u64;
    let (min, unit) = if encoding == Encoding::Ascii {
        (1, "one line each".to_string())
    } else {
        let (min, fixed) = min_binary_size(def);
        let unit = if fixed {
            format!("{min} bytes each")
        } else {
            format!("at least {min} bytes each")
        };
        (min, unit)
    };
    if min == 0 || count.checked_mul(min).is_some_and(|b| b <= remaining) {
        return Ok(());
    }
    let name = &def.name;
    Err(Error::malformed(
        path,
        format!("{name} {} of {count}", remaining / min),
        format!(
            "the file ends here, but the header declares {count} `{name}` items ({unit}) and \
             only {remaining} bytes follow byte {pos}: the file is truncated or its header \
             promises more than the body holds"
        ),
    ))
}

/// Gets past an element that is not read, after checking its count against the bytes left:
/// a binary element of scalars is one seek (none for an element without properties, whatever
/// its count), anything else goes through the crate's parser into [`Skip`].
pub(crate) fn skip_element<R: BufRead + Seek>(
    reader: &mut Reader<R>,
    path: &Path,
    def: &ElementDef,
    header: &ply_rs_bw::ply::Header,
    file_len: u64,
) -> Result<()> {
    check_element_fits(reader, path, def, header.encoding, file_len)?;
    let (size, fixed) = min_binary_size(def);
    if header.encoding != Encoding::Ascii && fixed {
        // Fits in the file (checked), so in an i64.
        let bytes = def.count as u64 * size;
        reader
            .get_mut()
            .seek(SeekFrom::Current(bytes as i64))
            .map_err(|e| Error::io(path, "cannot read", e))?;
        return Ok(());
    }
    let start = reader.line();
    Parser::<Skip>::new()
        .read_payload_for_element(reader, def, header)
        .map_err(|e| body_error(path, &e, &def.name, def.count, start, header.encoding))?;
    Ok(())
}

fn scalar_size(t: &ScalarType) -> usize {
    match t {
        ScalarType::Char | ScalarType::UChar => 1,
        ScalarType::Short | ScalarType::UShort => 2,
        ScalarType::Int | ScalarType::UInt | ScalarType::Float => 4,
        ScalarType::Double => 8,
    }
}

/// Reads until `buf` is full or the file ends; returns the bytes read.
fn read_full(r: &mut impl Read, buf: &mut [u8]) -> std::io::Result<usize> {
    let mut got = 0;
    while got < buf.len() {
        match r.read(&mut buf[got..]) {
            Ok(0) => break,
            Ok(k) => got += k,
            Err(e) if e.kind() == ErrorKind::Interrupted => {}
            Err(e) => return Err(e),
        }
    }
    Ok(got)
}

/// The values of the field at byte `off` of each `stride`-byte record, as `$t`.
macro_rules! field_values {
    ($buf:expr, $stride:expr, $off:expr, $be:expr, $t:ty) => {{
        const S: usize = std::mem::size_of::<$t>();
        let (off, be) = ($off, $be);
        $buf.chunks_exact($stride).map(move |rec| {
            let mut a = [0u8; S];
            a.copy_from_slice(&rec[off..off + S]);
            if be {
                <$t>::from_be_bytes(a)
            } else {
                <$t>::from_le_bytes(a)
            }
        })
    }};
}

/// The binary fast path: decodes the vertex element column by column from raw record bytes.
///
/// Why it exists: the benchmark (benches/read.rs) measured the crate's typed path at ~7x a
/// plain `std::fs::read` of a 5M-point float xyz + uchar rgb file (0.40 s vs 0.055 s), over
/// the required 6x; its cost is one `read_exact` and one by-name setter call per value. Here
/// a chunk of records is read with one call and each field is swept with one type dispatch
/// per chunk. Vertex properties are all scalars (lists are rejected from the header), so the
/// record size is fixed. The tests compare it with the crate's path on every sample file.
fn read_binary_vertices(
    r: &mut impl Read,
    path: &Path,
    def: &ElementDef,
    big_endian: bool,
    positions: &mut Vec<[f64; 3]>,
    columns: &mut [Column],
    progress: &Progress,
) -> Result<()> {
    let mut fields = Vec::new();
    let mut stride = 0;
    for f in vertex_fields(path, def)? {
        let size = scalar_size(&f.ty);
        fields.push((f.role, f.ty, stride));
        stride += size;
    }
    let n = def.count;
    let mut buf = Vec::new();
    let mut done = 0;
    while done < n {
        let m = CHUNK.min(n - done);
        buf.resize(m * stride, 0u8);
        let got = read_full(r, &mut buf).map_err(|e| Error::io(path, "cannot read", e))?;
        if got < buf.len() {
            return Err(Error::malformed(
                path,
                format!("vertex {} of {n}", done + got / stride.max(1)),
                format!(
                    "the file ends here, but the header declares {n} `vertex` items: the file \
                     is truncated or its header promises more than the body holds"
                ),
            ));
        }
        let base = positions.len();
        positions.resize(base + m, [0.0; 3]);
        let chunk_pos = &mut positions[base..];
        for (role, t, off) in &fields {
            match role {
                Role::Coord(k) => {
                    let k = *k;
                    macro_rules! coord {
                        ($t:ty) => {
                            for (p, v) in chunk_pos
                                .iter_mut()
                                .zip(field_values!(buf, stride, *off, big_endian, $t))
                            {
                                p[k] = f64::from(v);
                            }
                        };
                    }
                    match t {
                        ScalarType::Char => coord!(i8),
                        ScalarType::UChar => coord!(u8),
                        ScalarType::Short => coord!(i16),
                        ScalarType::UShort => coord!(u16),
                        ScalarType::Int => coord!(i32),
                        ScalarType::UInt => coord!(u32),
                        ScalarType::Float => coord!(f32),
                        ScalarType::Double => coord!(f64),
                    }
                }
                Role::Extra(i) => {
                    // Columns were created from the same header, in the same order and types.
                    match &mut columns[*i] {
                        Column::I8(v) => v.extend(field_values!(buf, stride, *off, big_endian, i8)),
                        Column::U8(v) => v.extend(field_values!(buf, stride, *off, big_endian, u8)),
                        Column::I16(v) => {
                            v.extend(field_values!(buf, stride, *off, big_endian, i16))
                        }
                        Column::U16(v) => {
                            v.extend(field_values!(buf, stride, *off, big_endian, u16))
                        }
                        Column::I32(v) => {
                            v.extend(field_values!(buf, stride, *off, big_endian, i32))
                        }
                        Column::U32(v) => {
                            v.extend(field_values!(buf, stride, *off, big_endian, u32))
                        }
                        Column::F32(v) => {
                            v.extend(field_values!(buf, stride, *off, big_endian, f32))
                        }
                        Column::F64(v) => {
                            v.extend(field_values!(buf, stride, *off, big_endian, f64))
                        }
                    }
                }
            }
        }
        done += m;
        progress.inc(m as u64);
    }
    Ok(())
}

/// Where a vertex property's values go: a coordinate (0, 1, 2 for x, y, z) or an extra
/// attribute column (in header order).
enum Role {
    Coord(usize),
    Extra(usize),
}

/// One property of the vertex element, as both decoders read it.
struct Field<'a> {
    name: &'a str,
    ty: ScalarType,
    role: Role,
}

/// The vertex element's properties in header order with their roles; list properties are an
/// error (`vertex_layout` rejects them before any body is read).
fn vertex_fields<'a>(path: &Path, def: &'a ElementDef) -> Result<Vec<Field<'a>>> {
    let mut extra = 0;
    def.properties
        .iter()
        .map(|(name, p)| {
            let PropertyType::Scalar(t) = &p.data_type else {
                return Err(Error::malformed(
                    path,
                    "header, element vertex",
                    format!("vertex property `{name}` is a list"),
                ));
            };
            let role = match name.as_str() {
                "x" => Role::Coord(0),
                "y" => Role::Coord(1),
                "z" => Role::Coord(2),
                _ => {
                    extra += 1;
                    Role::Extra(extra - 1)
                }
            };
            Ok(Field {
                name: name.as_str(),
                ty: t.clone(),
                role,
            })
        })
        .collect()
}

/// Decodes the ascii `vertex` element line by line: one vertex a line, its values separated
/// by whitespace, each parsed as its property's type. Floats take every spelling Rust's
/// parser does, `nan`, `-nan`, `inf` and `infinity` included (the crate's grammar refused
/// them, so a scan with invalid points stored as NaN, as PCL writes them, could not be read
/// and dropped), integers must fit their type. `first_line` is the file line of vertex 0.
fn read_ascii_vertices(
    r: &mut impl std::io::BufRead,
    path: &Path,
    def: &ElementDef,
    first_line: usize,
    positions: &mut Vec<[f64; 3]>,
    columns: &mut [Column],
    progress: &Progress,
) -> Result<()> {
    let fields = vertex_fields(path, def)?;
    let n = def.count;
    let mut line = String::new();
    for i in 0..n {
        line.clear();
        let got = r
            .read_line(&mut line)
            .map_err(|e| Error::io(path, "cannot read", e))?;
        let place = || format!("line {} (vertex {i} of {n})", first_line + i);
        // A bad value on a last line without its newline is the file cut off, not bad data.
        let cut = !line.ends_with('\n');
        let malformed = |what: String| {
            if cut {
                Error::malformed(
                    path,
                    place(),
                    format!(
                        "the file ends inside this vertex's line, but the header declares {n} \
                         `vertex` items: the file is truncated"
                    ),
                )
            } else {
                Error::malformed(path, place(), what)
            }
        };
        if got == 0 {
            return Err(Error::malformed(
                path,
                place(),
                format!(
                    "the file ends here, but the header declares {n} `vertex` items: the file \
                     is truncated or its header promises more than the body holds"
                ),
            ));
        }
        let mut tokens = line.split_ascii_whitespace();
        let mut p = [0.0f64; 3];
        for Field { name, ty: t, role } in &fields {
            let Some(tok) = tokens.next() else {
                return Err(malformed(format!(
                    "the line ends before property `{name}`: the header declares {} values a \
                     vertex",
                    fields.len()
                )));
            };
            let bad = || {
                malformed(format!(
                    "cannot read `{tok}` as the {} property `{name}`",
                    scalar_name(t)
                ))
            };
            macro_rules! int {
                ($ty:ty) => {{
                    let v: $ty = tok.parse().map_err(|_| bad())?;
                    v
                }};
            }
            match role {
                Role::Coord(k) => {
                    p[*k] = match t {
                        ScalarType::Float => f64::from(tok.parse::<f32>().map_err(|_| bad())?),
                        ScalarType::Double => tok.parse::<f64>().map_err(|_| bad())?,
                        ScalarType::Char => f64::from(int!(i8)),
                        ScalarType::UChar => f64::from(int!(u8)),
                        ScalarType::Short => f64::from(int!(i16)),
                        ScalarType::UShort => f64::from(int!(u16)),
                        ScalarType::Int => f64::from(int!(i32)),
                        ScalarType::UInt => f64::from(int!(u32)),
                    }
                }
                Role::Extra(col) => match &mut columns[*col] {
                    Column::I8(v) => v.push(int!(i8)),
                    Column::U8(v) => v.push(int!(u8)),
                    Column::I16(v) => v.push(int!(i16)),
                    Column::U16(v) => v.push(int!(u16)),
                    Column::I32(v) => v.push(int!(i32)),
                    Column::U32(v) => v.push(int!(u32)),
                    Column::F32(v) => v.push(tok.parse::<f32>().map_err(|_| bad())?),
                    Column::F64(v) => v.push(tok.parse::<f64>().map_err(|_| bad())?),
                },
            }
        }
        if let Some(tok) = tokens.next() {
            return Err(Error::malformed(
                path,
                place(),
                format!(
                    "`{tok}` after the {} values the header declares for a vertex",
                    fields.len()
                ),
            ));
        }
        positions.push(p);
        if (i + 1) % CHUNK == 0 {
            progress.inc(CHUNK as u64);
        }
    }
    progress.inc((n % CHUNK) as u64);
    Ok(())
}

/// Checks the vertex element: scalar properties only, x, y and z present. Returns the types
/// of x, y, z and the other properties in header order.
#[allow(clippy::type_complexity)]
fn vertex_layout(
    path: &Path,
    def: &ElementDef,
) -> Result<([ScalarType; 3], Vec<(String, ScalarType)>)> {
    let mut coords: [Option<ScalarType>; 3] = [None, None, None];
    let mut extras = Vec::new();
    for (name, p) in &def.properties {
        let t = match &p.data_type {
            PropertyType::Scalar(t) => t.clone(),
            PropertyType::List(..) => {
                return Err(Error::malformed(
                    path,
                    "header, element vertex",
                    format!(
                        "vertex property `{name}` is a list ({}); sharpedge reads only scalar \
                         vertex properties (x, y, z and per-point values). Remove it or move it \
                         to another element",
                        type_name(&p.data_type)
                    ),
                ));
            }
        };
        match name.as_str() {
            "x" => coords[0] = Some(t),
            "y" => coords[1] = Some(t),
            "z" => coords[2] = Some(t),
            _ => extras.push((name.clone(), t)),
        }
    }
    match coords {
        [Some(x), Some(y), Some(z)] => Ok(([x, y, z], extras)),
        _ => {
            let missing: Vec<&str> = ["x", "y", "z"]
                .iter()
                .zip(&coords)
                .filter(|(_, c)| c.is_none())
                .map(|(n, _)| *n)
                .collect();
            let have: Vec<&str> = def.properties.keys().map(|k| k.as_str()).collect();
            Err(Error::malformed(
                path,
                "header, element vertex",
                format!(
                    "vertex property {} missing; the vertex properties are: {}",
                    missing
                        .iter()
                        .map(|m| format!("`{m}`"))
                        .collect::<Vec<_>>()
                        .join(", "),
                    if have.is_empty() {
                        "none".to_string()
                    } else {
                        have.join(", ")
                    }
                ),
            ))
        }
    }
}

// ---------------------------------------------------------------------------------------------
// Writing
// ---------------------------------------------------------------------------------------------

/// Body encoding of a written PLY file.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum PlyEncoding {
    /// Compact and fast; what MeshLab, CloudCompare and Open3D write themselves.
    #[default]
    BinaryLittleEndian,
    /// Human-readable; every value round-trips exactly (shortest representation).
    Ascii,
}

/// Type of the written coordinates.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Precision {
    /// 4-byte float: ample for parts in local coordinates, too coarse for georeferenced ones
    /// (f32 steps are 1/16 at 500 000).
    #[default]
    F32,
    /// 8-byte double.
    F64,
}

impl Precision {
    /// The precision a cloud's source needs: F64 when the file it came from stored
    /// coordinates more precisely than f32 holds at their magnitude.
    pub fn for_source(source: &Source) -> Precision {
        if source.double_precision {
            Precision::F64
        } else {
            Precision::F32
        }
    }
}

/// Options of [`write_ply`]. The default is binary little endian with float coordinates.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct PlyWriteOptions {
    pub encoding: PlyEncoding,
    pub precision: Precision,
}

fn is_ply_name(name: &str) -> bool {
    // The name grammar of ply-rs-bw, so everything written here reads back.
    let mut chars = name.chars();
    match chars.next() {
        Some(c) if c.is_ascii_alphabetic() || c == '_' => {}
        _ => return false,
    }
    chars.all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-')
}

fn check_write_input(
    path: &Path,
    positions: &[[f64; 3]],
    attributes: &[&Attribute],
    edges: &[[u32; 2]],
    opts: &PlyWriteOptions,
) -> Result<()> {
    let bad = |what: String| Error::BadOutput {
        path: path.to_path_buf(),
        what,
    };
    let n = positions.len();
    for (i, p) in positions.iter().enumerate() {
        if !p.iter().all(|c| c.is_finite()) {
            return Err(bad(format!(
                "vertex {i} has a non-finite position ({}, {}, {})",
                p[0], p[1], p[2]
            )));
        }
        if opts.precision == Precision::F32 && p.iter().any(|c| c.abs() > f64::from(f32::MAX)) {
            return Err(bad(format!(
                "vertex {i} ({}, {}, {}) does not fit a float; write double coordinates",
                p[0], p[1], p[2]
            )));
        }
    }
    let mut names: Vec<&str> = vec!["x", "y", "z"];
    for a in attributes {
        if !is_ply_name(&a.name) {
            return Err(bad(format!(
                "attribute name `{}` is not a PLY property name (letters, digits, `_`, `-`; \
                 starting with a letter or `_`)",
                a.name
            )));
        }
        if names.contains(&a.name.as_str()) {
            return Err(bad(format!("two vertex properties are named `{}`", a.name)));
        }
        names.push(&a.name);
        if a.values.len() != n {
            return Err(bad(format!(
                "attribute `{}` has {} values for {n} vertices",
                a.name,
                a.values.len()
            )));
        }
        if opts.encoding == PlyEncoding::Ascii {
            let first_bad = match &a.values {
                Column::F32(v) => v.iter().position(|x| !x.is_finite()),
                Column::F64(v) => v.iter().position(|x| !x.is_finite()),
                _ => None,
            };
            if let Some(i) = first_bad {
                return Err(bad(format!(
                    "attribute `{}` is {} at vertex {i}; ascii PLY readers disagree on how \
                     NaN and infinity are spelled, write binary instead",
                    a.name,
                    a.values.get_f64(i)
                )));
            }
        }
    }
    if !edges.is_empty() && n > i32::MAX as usize + 1 {
        return Err(bad(format!(
            "{n} vertices: edge indices do not fit the `int` type of `element edge`"
        )));
    }
    if let Some((i, e)) = edges
        .iter()
        .enumerate()
        .find(|(_, e)| e[0] as usize >= n || e[1] as usize >= n)
    {
        return Err(bad(format!(
            "edge {i} ({}, {}) points past the last vertex ({} vertices)",
            e[0], e[1], n
        )));
    }
    Ok(())
}

/// The header text of a written file, byte for byte.
pub(crate) fn header_text(
    n: usize,
    attributes: &[&Attribute],
    n_edges: usize,
    opts: &PlyWriteOptions,
) -> String {
    let mut h = String::new();
    let encoding = match opts.encoding {
        PlyEncoding::BinaryLittleEndian => "binary_little_endian",
        PlyEncoding::Ascii => "ascii",
    };
    let coord = match opts.precision {
        Precision::F32 => "float",
        Precision::F64 => "double",
    };
    // Writing to a String cannot fail.
    let _ = writeln!(h, "ply\nformat {encoding} 1.0");
    let _ = writeln!(
        h,
        "comment written by sharpedge {}",
        env!("CARGO_PKG_VERSION")
    );
    let _ = writeln!(h, "element vertex {n}");
    for c in ["x", "y", "z"] {
        let _ = writeln!(h, "property {coord} {c}");
    }
    for a in attributes {
        let _ = writeln!(h, "property {} {}", a.values.ply_type(), a.name);
    }
    if n_edges > 0 {
        let _ = writeln!(
            h,
            "element edge {n_edges}\nproperty int vertex1\nproperty int vertex2"
        );
    }
    h.push_str("end_header\n");
    h
}

/// Writes `element vertex` (x, y, z in `precision`, then every attribute with its own type and
/// name, in order) and, when `edges` is not empty, `element edge` with `int vertex1, int
/// vertex2`. Atomic: writes a temporary file in the destination folder and renames it when
/// complete, so a failure leaves nothing behind.
pub fn write_ply(
    path: &Path,
    positions: &[[f64; 3]],
    attributes: &[&Attribute],
    edges: &[[u32; 2]],
    opts: &PlyWriteOptions,
) -> Result<()> {
    let _span = tracing::debug_span!("write_ply", path = %path.display()).entered();
    check_write_input(path, positions, attributes, edges, opts)?;
    let header = header_text(positions.len(), attributes, edges.len(), opts);
    let n = positions.len() as u64;
    let progress = if n >= super::PROGRESS_MIN_POINTS {
        Progress::start("write", n, "points")
    } else {
        Progress::hidden()
    };
    super::write_atomic(path, |w| {
        let io = |e| Error::io(path, "cannot write (disk full?)", e);
        w.write_all(header.as_bytes()).map_err(io)?;
        match opts.encoding {
            PlyEncoding::BinaryLittleEndian => {
                write_binary_body(w, positions, attributes, edges, opts.precision, &progress)
            }
            PlyEncoding::Ascii => {
                write_ascii_body(w, positions, attributes, edges, opts.precision, &progress)
            }
        }
        .map_err(io)
    })
}

fn write_binary_body(
    w: &mut dyn Write,
    positions: &[[f64; 3]],
    attributes: &[&Attribute],
    edges: &[[u32; 2]],
    precision: Precision,
    progress: &Progress,
) -> std::io::Result<()> {
    let coord_size = match precision {
        Precision::F32 => 4,
        Precision::F64 => 8,
    };
    let sizes: Vec<usize> = attributes.iter().map(|a| column_size(&a.values)).collect();
    let stride = 3 * coord_size + sizes.iter().sum::<usize>();
    let mut buf = Vec::new();
    let mut start = 0;
    // Column by column into a strided buffer: one type dispatch per column and chunk, not per
    // value.
    while start < positions.len() {
        let m = CHUNK.min(positions.len() - start);
        buf.clear();
        buf.resize(m * stride, 0u8);
        for (j, p) in positions[start..start + m].iter().enumerate() {
            let rec = &mut buf[j * stride..j * stride + 3 * coord_size];
            match precision {
                Precision::F32 => {
                    for k in 0..3 {
                        rec[4 * k..4 * k + 4].copy_from_slice(&(p[k] as f32).to_le_bytes());
                    }
                }
                Precision::F64 => {
                    for k in 0..3 {
                        rec[8 * k..8 * k + 8].copy_from_slice(&p[k].to_le_bytes());
                    }
                }
            }
        }
        let mut offset = 3 * coord_size;
        for (a, size) in attributes.iter().zip(&sizes) {
            put_column(&mut buf, stride, offset, &a.values, start, m);
            offset += size;
        }
        w.write_all(&buf)?;
        progress.inc(m as u64);
        start += m;
    }
    buf.clear();
    for e in edges {
        // Indices were checked to fit i32.
        buf.extend_from_slice(&(e[0] as i32).to_le_bytes());
        buf.extend_from_slice(&(e[1] as i32).to_le_bytes());
    }
    w.write_all(&buf)
}

fn column_size(c: &Column) -> usize {
    match c {
        Column::I8(_) | Column::U8(_) => 1,
        Column::I16(_) | Column::U16(_) => 2,
        Column::I32(_) | Column::U32(_) | Column::F32(_) => 4,
        Column::F64(_) => 8,
    }
}

/// Writes values `start..start + m` of `col` little endian at `offset` of every record.
fn put_column(buf: &mut [u8], stride: usize, offset: usize, col: &Column, start: usize, m: usize) {
    macro_rules! put {
        ($v:expr) => {{
            for (j, x) in $v[start..start + m].iter().enumerate() {
                let b = x.to_le_bytes();
                let o = j * stride + offset;
                buf[o..o + b.len()].copy_from_slice(&b);
            }
        }};
    }
    match col {
        Column::I8(v) => put!(v),
        Column::U8(v) => put!(v),
        Column::I16(v) => put!(v),
        Column::U16(v) => put!(v),
        Column::I32(v) => put!(v),
        Column::U32(v) => put!(v),
        Column::F32(v) => put!(v),
        Column::F64(v) => put!(v),
    }
}

/// Appends a float in the shortest text that reads back to the same value; exponent form
/// only for very large or small magnitudes (Display would spell out hundreds of zeros).
fn push_float(
    s: &mut String,
    v: f64,
    display: impl std::fmt::Display,
    exp: impl std::fmt::LowerExp,
) {
    let a = v.abs();
    if a != 0.0 && !(1e-5..1e16).contains(&a) {
        let _ = write!(s, "{exp:e}");
    } else {
        let _ = write!(s, "{display}");
    }
}

fn push_value(s: &mut String, col: &Column, i: usize) {
    let _ = match col {
        Column::I8(v) => write!(s, "{}", v[i]),
        Column::U8(v) => write!(s, "{}", v[i]),
        Column::I16(v) => write!(s, "{}", v[i]),
        Column::U16(v) => write!(s, "{}", v[i]),
        Column::I32(v) => write!(s, "{}", v[i]),
        Column::U32(v) => write!(s, "{}", v[i]),
        Column::F32(v) => {
            push_float(s, f64::from(v[i]), v[i], v[i]);
            Ok(())
        }
        Column::F64(v) => {
            push_float(s, v[i], v[i], v[i]);
            Ok(())
        }
    };
}

fn write_ascii_body(
    w: &mut dyn Write,
    positions: &[[f64; 3]],
    attributes: &[&Attribute],
    edges: &[[u32; 2]],
    precision: Precision,
    progress: &Progress,
) -> std::io::Result<()> {
    let mut s = String::with_capacity(1 << 16);
    for (i, p) in positions.iter().enumerate() {
        for (k, c) in p.iter().enumerate() {
            if k > 0 {
                s.push(' ');
            }
            match precision {
                Precision::F32 => {
                    let f = *c as f32;
                    push_float(&mut s, f64::from(f), f, f);
                }
                Precision::F64 => push_float(&mut s, *c, *c, *c),
            }
        }
        for a in attributes {
            s.push(' ');
            push_value(&mut s, &a.values, i);
        }
        s.push('\n');
        if s.len() > (1 << 16) - 512 {
            w.write_all(s.as_bytes())?;
            s.clear();
        }
        if (i + 1) % CHUNK == 0 {
            progress.inc(CHUNK as u64);
        }
    }
    for e in edges {
        let _ = writeln!(s, "{} {}", e[0], e[1]);
        if s.len() > (1 << 16) - 64 {
            w.write_all(s.as_bytes())?;
            s.clear();
        }
    }
    w.write_all(s.as_bytes())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn header_line_explanations_name_the_bad_type() {
        let e = explain_header_line("property int64 x");
        assert!(e.starts_with("unknown PLY type `int64`"), "{e}");
        let e = explain_header_line("property list uchar int128 vertex_indices");
        assert!(e.starts_with("unknown PLY type `int128`"), "{e}");
        let e = explain_header_line("property float 9x");
        assert!(e.contains("expected `property TYPE NAME`"), "{e}");
        let e = explain_header_line("elemnt vertex 3");
        assert!(e.contains("header lines start with"), "{e}");
    }

    #[test]
    fn ply_names_follow_the_parser_grammar() {
        assert!(is_ply_name("scalar_edge_id"));
        assert!(is_ply_name("_a-1"));
        assert!(!is_ply_name("1a"));
        assert!(!is_ply_name("a b"));
        assert!(!is_ply_name(""));
    }

    #[test]
    fn ascii_floats_are_shortest_round_trip() {
        let mut s = String::new();
        for v in [
            0.1f64,
            512345.123,
            -4101234.567,
            1e-7,
            1.5e20,
            0.0,
            -0.0,
            123.0,
        ] {
            s.clear();
            push_float(&mut s, v, v, v);
            assert_eq!(
                s.parse::<f64>().unwrap().to_bits(),
                v.to_bits(),
                "{v} -> {s}"
            );
        }
        s.clear();
        push_float(&mut s, 1e-7, 1e-7, 1e-7);
        assert_eq!(s, "1e-7");
        let f = 0.1f32;
        s.clear();
        push_float(&mut s, f64::from(f), f, f);
        assert_eq!(s, "0.1");
    }

    #[test]
    fn vertex_rec_spills_past_the_inline_slots() {
        let mut r = VertexRec::new();
        for i in 0..(INLINE + 3) {
            r.put(&format!("p{i}"), i as f64);
        }
        r.put("y", 7.0);
        assert_eq!(r.xyz, [0.0, 7.0, 0.0]);
        assert_eq!(r.n, INLINE + 3);
        for i in 0..(INLINE + 3) {
            assert_eq!(r.extra(i), i as f64);
        }
    }
}
