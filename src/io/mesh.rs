//! Triangle meshes (OFF, PLY, OBJ) for the scan simulator.
//!
//! Input: a path whose extension names the format (`.off`, `.ply`, `.obj`, any case).
//! Output: a [`Mesh`] — vertex positions (f64) and triangles (indices into the vertices).
//! Polygons are split into triangle fans `(v0, vi, vi+1)`, which is exact for the convex,
//! planar polygons CAD exporters write; non-convex polygons would need ear clipping.
//!
//! What each reader accepts:
//! - **OFF**: `#` comments and blank lines anywhere; the `OFF` keyword (also `COFF`, `NOFF`,
//!   `CNOFF`, `STOFF`…) alone or followed by the counts on the same line; the edge count (third
//!   number) is read and ignored, as it is optional information; extra columns after x y z
//!   (colours, normals) and after a face's indices (colours) are ignored. The header's counts
//!   are checked against the body in both directions.
//! - **PLY** (via ply-rs-bw's typed `PropertyAccess` path): ascii and binary of either
//!   endianness, elements in any order, `x y z` of any scalar type, a `face` element whose
//!   index list is named `vertex_indices` or `vertex_index` with any count and index type, or
//!   failing that a `tristrips` element (strips separated by -1). Other elements and properties
//!   are skipped.
//! - **OBJ**: `v` (x y z, optional w or colour ignored), `f` with `v`, `v/vt`, `v//vn`, `v/vt/vn`
//!   references, 1-based or negative (relative) indices, polygons; `vt`, `vn`, `usemtl`,
//!   `mtllib`, `o`, `g`, `s`, `l`, `p` and comments are ignored; `\` continues a line.
//!
//! Every malformed input is an [`Error::Malformed`] naming the file, the place (line or element
//! number) and the problem: bad or missing counts, an index out of range, a truncated file, a
//! face with fewer than three vertices, non-finite coordinates, or a mesh without faces.

use std::fs::File;
use std::io::{BufRead, BufReader, Read, Seek};
use std::path::Path;

use ply_rs_bw::parser::{Parser, Reader};
use ply_rs_bw::ply::{ElementDef, PropertyAccess, PropertyAccessResult, PropertyType};

use crate::error::{Error, Result};

/// A triangle mesh: positions and triangles as indices into them.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Mesh {
    pub vertices: Vec<[f64; 3]>,
    pub triangles: Vec<[u32; 3]>,
}

impl Mesh {
    /// Axis-aligned bounding box `(min, max)` of the vertices; `None` when there are none.
    pub fn bbox(&self) -> Option<([f64; 3], [f64; 3])> {
        let first = *self.vertices.first()?;
        let (mut lo, mut hi) = (first, first);
        for v in &self.vertices {
            for k in 0..3 {
                lo[k] = lo[k].min(v[k]);
                hi[k] = hi[k].max(v[k]);
            }
        }
        Some((lo, hi))
    }

    /// Total area of the triangles.
    pub fn area(&self) -> f64 {
        self.triangles
            .iter()
            .map(|t| {
                let [a, b, c] = t.map(|i| self.vertices[i as usize]);
                let u = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
                let v = [c[0] - a[0], c[1] - a[1], c[2] - a[2]];
                let n = [
                    u[1] * v[2] - u[2] * v[1],
                    u[2] * v[0] - u[0] * v[2],
                    u[0] * v[1] - u[1] * v[0],
                ];
                0.5 * (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt()
            })
            .sum()
    }
}

/// Reads a triangle mesh from an OFF, PLY or OBJ file (chosen by the extension).
pub fn read_mesh(path: &Path) -> Result<Mesh> {
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(|e| e.to_ascii_lowercase())
        .unwrap_or_default();
    let mesh = match ext.as_str() {
        "off" => read_off(path, open(path)?)?,
        "obj" => read_obj(path, open(path)?)?,
        "ply" => read_ply(path, open(path)?)?,
        _ => {
            return Err(Error::UnknownFormat {
                path: path.to_path_buf(),
                ext,
                allowed: "a triangle mesh must be .off, .ply or .obj",
            });
        }
    };
    if mesh.triangles.is_empty() {
        return Err(Error::malformed(
            path,
            "file",
            "the mesh has no faces; give a surface mesh, not a point cloud",
        ));
    }
    Ok(mesh)
}

fn open(path: &Path) -> Result<BufReader<File>> {
    File::open(path)
        .map(BufReader::new)
        .map_err(|e| Error::io(path, "cannot open", e))
}

/// Appends the fan triangulation of `poly` (already validated indices) to `out`.
fn push_fan(out: &mut Vec<[u32; 3]>, poly: &[u32]) {
    for i in 1..poly.len().saturating_sub(1) {
        out.push([poly[0], poly[i], poly[i + 1]]);
    }
}

fn parse_f64(tok: &str) -> Option<f64> {
    tok.parse::<f64>().ok().filter(|v| v.is_finite())
}

/// Checks the vertex count fits the u32 indices of [`Mesh`].
fn check_vertex_count(path: &Path, place: &str, n: usize) -> Result<()> {
    if n > u32::MAX as usize {
        return Err(Error::malformed(
            path,
            place,
            format!("{n} vertices is more than the 2^32 a mesh index can address"),
        ));
    }
    Ok(())
}

// ---------------------------------------------------------------------------------------------
// OFF

/// The non-blank, comment-stripped lines of a text file with their 1-based numbers.
struct Lines<R: BufRead> {
    inner: R,
    line_no: usize,
    buf: String,
}

impl<R: BufRead> Lines<R> {
    fn new(inner: R) -> Self {
        Lines {
            inner,
            line_no: 0,
            buf: String::new(),
        }
    }

    /// Next line with content: `(line number, text without comment)`, or `None` at the end.
    fn next(&mut self, path: &Path) -> Result<Option<(usize, &str)>> {
        // Find the line first and borrow the buffer only once it stops changing.
        let (start, end) = loop {
            self.buf.clear();
            let n = self
                .inner
                .read_line(&mut self.buf)
                .map_err(|e| Error::io(path, "cannot read", e))?;
            if n == 0 {
                return Ok(None);
            }
            self.line_no += 1;
            let cut = self.buf.find('#').unwrap_or(self.buf.len());
            let text = &self.buf[..cut];
            let trimmed = text.trim();
            if !trimmed.is_empty() {
                let start = text.len() - text.trim_start().len();
                break (start, start + trimmed.len());
            }
        };
        Ok(Some((self.line_no, &self.buf[start..end])))
    }
}

fn read_off<R: BufRead>(path: &Path, reader: R) -> Result<Mesh> {
    let mut lines = Lines::new(reader);
    let Some((line, text)) = lines.next(path)? else {
        return Err(Error::malformed(
            path,
            "line 1",
            "empty file; expected an OFF header",
        ));
    };
    let mut toks = text.split_whitespace();
    let keyword = toks.next().unwrap_or_default();
    if !keyword.ends_with("OFF") || keyword.starts_with('4') || keyword.starts_with('n') {
        return Err(Error::malformed(
            path,
            format!("line {line}"),
            format!("expected the keyword OFF (or COFF, NOFF, CNOFF, STOFF), found {keyword:?}"),
        ));
    }
    let rest: Vec<String> = toks.map(str::to_owned).collect();
    if rest.first().map(String::as_str) == Some("BINARY") {
        return Err(Error::malformed(
            path,
            format!("line {line}"),
            "binary OFF is not supported; convert the file to ascii OFF, PLY or OBJ",
        ));
    }
    // The counts follow on the keyword line or on the next line with content.
    let (count_line, counts) = if rest.is_empty() {
        match lines.next(path)? {
            Some((l, t)) => (l, t.split_whitespace().map(str::to_owned).collect()),
            None => {
                return Err(Error::malformed(
                    path,
                    format!("line {}", line + 1),
                    "file ends before the counts line `vertices faces edges`",
                ));
            }
        }
    } else {
        (line, rest)
    };
    let parse_count = |i: usize, what: &str| -> Result<usize> {
        let tok = counts.get(i).ok_or_else(|| {
            Error::malformed(
                path,
                format!("line {count_line}"),
                format!("missing the {what} count; the counts line is `vertices faces edges`"),
            )
        })?;
        tok.parse::<usize>().map_err(|_| {
            Error::malformed(
                path,
                format!("line {count_line}"),
                format!("bad {what} count {tok:?}: expected a non-negative integer"),
            )
        })
    };
    let nv = parse_count(0, "vertex")?;
    let nf = parse_count(1, "face")?;
    // The edge count is optional in practice (some writers omit it) and is never needed.
    if let Some(tok) = counts.get(2) {
        tok.parse::<usize>().map_err(|_| {
            Error::malformed(
                path,
                format!("line {count_line}"),
                format!("bad edge count {tok:?}: expected a non-negative integer"),
            )
        })?;
    }
    check_vertex_count(path, &format!("line {count_line}"), nv)?;

    let mut vertices = Vec::with_capacity(nv.min(1 << 24));
    for i in 0..nv {
        let Some((l, t)) = lines.next(path)? else {
            return Err(Error::malformed(
                path,
                format!("line {}", lines.line_no + 1),
                format!(
                    "truncated: the header promises {nv} vertices and {nf} faces, the file ends after {i} vertices"
                ),
            ));
        };
        let mut it = t.split_whitespace();
        let mut p = [0.0; 3];
        for (k, c) in p.iter_mut().enumerate() {
            let tok = it.next().ok_or_else(|| {
                Error::malformed(
                    path,
                    format!("line {l}"),
                    format!("vertex {i} has {k} coordinates; expected x y z"),
                )
            })?;
            *c = parse_f64(tok).ok_or_else(|| {
                Error::malformed(
                    path,
                    format!("line {l}"),
                    format!("vertex {i}: bad coordinate {tok:?} (expected a finite number)"),
                )
            })?;
        }
        vertices.push(p);
    }

    let mut triangles = Vec::with_capacity(nf.min(1 << 24));
    let mut poly: Vec<u32> = Vec::new();
    for f in 0..nf {
        let Some((l, t)) = lines.next(path)? else {
            return Err(Error::malformed(
                path,
                format!("line {}", lines.line_no + 1),
                format!("truncated: the header promises {nf} faces, the file ends after {f}"),
            ));
        };
        let mut it = t.split_whitespace();
        let tok = it.next().unwrap_or_default();
        let n: usize = tok.parse().map_err(|_| {
            Error::malformed(
                path,
                format!("line {l}"),
                format!("face {f}: bad vertex count {tok:?}"),
            )
        })?;
        if n < 3 {
            return Err(Error::malformed(
                path,
                format!("line {l}"),
                format!("face {f} has {n} vertices; a face needs at least 3"),
            ));
        }
        poly.clear();
        for k in 0..n {
            let tok = it.next().ok_or_else(|| {
                Error::malformed(
                    path,
                    format!("line {l}"),
                    format!("face {f} announces {n} vertices but lists {k}"),
                )
            })?;
            let idx: i64 = tok.parse().map_err(|_| {
                Error::malformed(
                    path,
                    format!("line {l}"),
                    format!("face {f}: bad vertex index {tok:?}"),
                )
            })?;
            if idx < 0 || idx as usize >= nv {
                return Err(Error::malformed(
                    path,
                    format!("line {l}"),
                    format!(
                        "face {f}: vertex index {idx} out of range (the file has {nv} vertices, indices 0..{})",
                        nv.saturating_sub(1)
                    ),
                ));
            }
            poly.push(idx as u32);
        }
        push_fan(&mut triangles, &poly);
    }
    if let Some((l, _)) = lines.next(path)? {
        return Err(Error::malformed(
            path,
            format!("line {l}"),
            format!(
                "data after the last face: the header says {nv} vertices and {nf} faces; fix the counts"
            ),
        ));
    }
    Ok(Mesh {
        vertices,
        triangles,
    })
}

// ---------------------------------------------------------------------------------------------
// OBJ

fn read_obj<R: BufRead>(path: &Path, mut reader: R) -> Result<Mesh> {
    let mut vertices: Vec<[f64; 3]> = Vec::new();
    let mut triangles = Vec::new();
    let mut poly: Vec<u32> = Vec::new();
    let mut buf = String::new();
    let mut joined = String::new();
    let mut line_no = 0usize;
    let mut face_no = 0usize;
    loop {
        // Gather one logical line (a trailing backslash continues it).
        joined.clear();
        let start_line = line_no + 1;
        let mut eof = false;
        loop {
            buf.clear();
            let n = reader
                .read_line(&mut buf)
                .map_err(|e| Error::io(path, "cannot read", e))?;
            if n == 0 {
                eof = true;
                break;
            }
            line_no += 1;
            let t = buf.trim_end_matches(['\n', '\r']);
            if let Some(s) = t.strip_suffix('\\') {
                joined.push_str(s);
                joined.push(' ');
            } else {
                joined.push_str(t);
                break;
            }
        }
        if eof && joined.is_empty() {
            break;
        }
        let text = match joined.find('#') {
            Some(i) => &joined[..i],
            None => &joined[..],
        };
        let mut it = text.split_whitespace();
        let Some(key) = it.next() else { continue };
        match key {
            "v" => {
                let mut p = [0.0; 3];
                for (k, c) in p.iter_mut().enumerate() {
                    let tok = it.next().ok_or_else(|| {
                        Error::malformed(
                            path,
                            format!("line {start_line}"),
                            format!("vertex with {k} coordinates; expected `v x y z`"),
                        )
                    })?;
                    *c = parse_f64(tok).ok_or_else(|| {
                        Error::malformed(
                            path,
                            format!("line {start_line}"),
                            format!("bad vertex coordinate {tok:?} (expected a finite number)"),
                        )
                    })?;
                }
                vertices.push(p);
                check_vertex_count(path, &format!("line {start_line}"), vertices.len())?;
            }
            "f" => {
                poly.clear();
                let nv = vertices.len();
                for tok in it {
                    let vref = tok.split('/').next().unwrap_or_default();
                    let idx: i64 = vref.parse().map_err(|_| {
                        Error::malformed(
                            path,
                            format!("line {start_line}"),
                            format!("face {face_no}: bad vertex reference {tok:?}"),
                        )
                    })?;
                    // OBJ indices are 1-based; negative ones count back from the last vertex.
                    let abs = if idx > 0 {
                        idx - 1
                    } else if idx < 0 {
                        nv as i64 + idx
                    } else {
                        -1
                    };
                    if abs < 0 || abs as usize >= nv {
                        return Err(Error::malformed(
                            path,
                            format!("line {start_line}"),
                            format!(
                                "face {face_no}: vertex index {idx} out of range ({nv} vertices defined so far; indices are 1..={nv} or -1..=-{nv})"
                            ),
                        ));
                    }
                    poly.push(abs as u32);
                }
                if poly.len() < 3 {
                    return Err(Error::malformed(
                        path,
                        format!("line {start_line}"),
                        format!(
                            "face {face_no} has {} vertices; a face needs at least 3",
                            poly.len()
                        ),
                    ));
                }
                push_fan(&mut triangles, &poly);
                face_no += 1;
            }
            _ => {} // vt, vn, vp, usemtl, mtllib, o, g, s, l, p, ...: not geometry we sample
        }
        if eof {
            break;
        }
    }
    Ok(Mesh {
        vertices,
        triangles,
    })
}

// ---------------------------------------------------------------------------------------------
// PLY

/// One `vertex` element: only x, y, z are kept.
#[derive(Default)]
struct PlyVertex {
    p: [f64; 3],
    set: u8,
}

impl PlyVertex {
    fn put(&mut self, name: &str, v: f64) -> PropertyAccessResult {
        let k = match name {
            "x" => 0,
            "y" => 1,
            "z" => 2,
            _ => return PropertyAccessResult::Ignored,
        };
        self.p[k] = v;
        self.set |= 1 << k;
        PropertyAccessResult::Set
    }
}

impl PropertyAccess for PlyVertex {
    fn new() -> Self {
        Self::default()
    }
    fn set_char(&mut self, n: &str, v: i8) -> PropertyAccessResult {
        self.put(n, v.into())
    }
    fn set_uchar(&mut self, n: &str, v: u8) -> PropertyAccessResult {
        self.put(n, v.into())
    }
    fn set_short(&mut self, n: &str, v: i16) -> PropertyAccessResult {
        self.put(n, v.into())
    }
    fn set_ushort(&mut self, n: &str, v: u16) -> PropertyAccessResult {
        self.put(n, v.into())
    }
    fn set_int(&mut self, n: &str, v: i32) -> PropertyAccessResult {
        self.put(n, v.into())
    }
    fn set_uint(&mut self, n: &str, v: u32) -> PropertyAccessResult {
        self.put(n, v.into())
    }
    fn set_float(&mut self, n: &str, v: f32) -> PropertyAccessResult {
        self.put(n, v.into())
    }
    fn set_double(&mut self, n: &str, v: f64) -> PropertyAccessResult {
        self.put(n, v)
    }
}

/// One `face` or `tristrips` element: only the index list (named by `INDEX_NAMES`) is kept.
#[derive(Default)]
struct PlyIndices {
    idx: Vec<i64>,
}

const INDEX_NAMES: [&str; 2] = ["vertex_indices", "vertex_index"];

impl PlyIndices {
    fn put<T: Into<i64>>(&mut self, name: &str, v: Vec<T>) -> PropertyAccessResult {
        if INDEX_NAMES.contains(&name) {
            self.idx = v.into_iter().map(Into::into).collect();
            PropertyAccessResult::Set
        } else {
            PropertyAccessResult::Ignored
        }
    }
}

impl PropertyAccess for PlyIndices {
    fn new() -> Self {
        Self::default()
    }
    fn set_list_char(&mut self, n: &str, v: Vec<i8>) -> PropertyAccessResult {
        self.put(n, v)
    }
    fn set_list_uchar(&mut self, n: &str, v: Vec<u8>) -> PropertyAccessResult {
        self.put(n, v)
    }
    fn set_list_short(&mut self, n: &str, v: Vec<i16>) -> PropertyAccessResult {
        self.put(n, v)
    }
    fn set_list_ushort(&mut self, n: &str, v: Vec<u16>) -> PropertyAccessResult {
        self.put(n, v)
    }
    fn set_list_int(&mut self, n: &str, v: Vec<i32>) -> PropertyAccessResult {
        self.put(n, v)
    }
    fn set_list_uint(&mut self, n: &str, v: Vec<u32>) -> PropertyAccessResult {
        self.put(n, v)
    }
}

/// An element we do not need: every property is read (the parser must consume it) and dropped.
struct Skip;

impl PropertyAccess for Skip {
    fn new() -> Self {
        Skip
    }
}

/// Turns a ply-rs-bw error into ours, keeping its line number as the place.
/// In binary bodies ply-rs-bw counts elements, not lines, so only the element is named.
fn ply_error(path: &Path, element: &str, binary: bool, e: ply_rs_bw::parser::ParseError) -> Error {
    let msg = e.to_string();
    let msg = match (e.line(), binary) {
        (Some(l), true) => msg
            .strip_prefix(&format!("Line {l}: "))
            .unwrap_or(&msg)
            .to_owned(),
        _ => msg,
    };
    let line = if binary { None } else { e.line() };
    let (place, what) = match line {
        Some(l) => {
            let prefix = format!("Line {l}: ");
            let what = msg.strip_prefix(&prefix).unwrap_or(&msg).to_owned();
            (format!("line {l} (element {element})"), what)
        }
        None => (format!("element {element}"), msg),
    };
    Error::malformed(
        path,
        place,
        what.replace(".\n\t", "; ").replace("\n\t", "; "),
    )
}

/// The index list property of an element, if it has one named as PLY writers do.
fn index_list<'a>(path: &Path, def: &'a ElementDef) -> Result<Option<&'a str>> {
    for name in INDEX_NAMES {
        if let Some(p) = def.properties.get(name) {
            return match &p.data_type {
                PropertyType::List(_, t)
                    if !matches!(
                        t,
                        ply_rs_bw::ply::ScalarType::Float | ply_rs_bw::ply::ScalarType::Double
                    ) =>
                {
                    Ok(Some(name))
                }
                other => Err(Error::malformed(
                    path,
                    "header",
                    format!(
                        "element {}: property {name} must be a list of integers, found {other:?}",
                        def.name
                    ),
                )),
            };
        }
    }
    Ok(None)
}

fn read_ply<R: Read + Seek>(path: &Path, source: R) -> Result<Mesh> {
    let file_len = std::fs::metadata(path).map(|m| m.len()).unwrap_or(0);
    let mut reader = Reader::new(BufReader::new(source));
    let header = Parser::<Skip>::new()
        .read_header(&mut reader)
        .map_err(|e| ply_error(path, "header", false, e))?;
    super::ply::check_unique_names(path, reader.get_mut())?;
    let binary = header.encoding != ply_rs_bw::ply::Encoding::Ascii;

    let Some(vdef) = header.elements.get("vertex") else {
        return Err(Error::malformed(
            path,
            "header",
            "no `vertex` element; a mesh needs vertices with x, y, z",
        ));
    };
    for c in ["x", "y", "z"] {
        match vdef.properties.get(c).map(|p| &p.data_type) {
            Some(PropertyType::Scalar(_)) => {}
            Some(PropertyType::List(..)) => {
                return Err(Error::malformed(
                    path,
                    "header",
                    format!("vertex property {c} is a list; it must be a scalar"),
                ));
            }
            None => {
                return Err(Error::malformed(
                    path,
                    "header",
                    format!("the vertex element has no property {c}"),
                ));
            }
        }
    }
    // Faces come from `face`; `tristrips` only when there is no usable face element.
    let face_list = match header.elements.get("face") {
        Some(def) => index_list(path, def)?,
        None => None,
    };
    let strip_list = match header.elements.get("tristrips") {
        Some(def) if face_list.is_none() => index_list(path, def)?,
        _ => None,
    };
    if face_list.is_none() && strip_list.is_none() {
        return Err(Error::malformed(
            path,
            "header",
            "no faces: the file has no `face` element with a `vertex_indices` (or `vertex_index`) list and no `tristrips`; give a surface mesh, not a point cloud",
        ));
    }
    check_vertex_count(path, "header", vdef.count)?;

    let mut vertices: Vec<[f64; 3]> = Vec::new();
    let mut faces: Vec<PlyIndices> = Vec::new();
    let mut strips: Vec<PlyIndices> = Vec::new();
    for (name, def) in &header.elements {
        // No count is trusted before it is checked against the bytes left.
        super::ply::check_element_fits(&mut reader, path, def, header.encoding, file_len)?;
        match name.as_str() {
            "vertex" => {
                let vs = Parser::<PlyVertex>::new()
                    .read_payload_for_element(&mut reader, def, &header)
                    .map_err(|e| ply_error(path, name, binary, e))?;
                vertices.reserve_exact(vs.len());
                for (i, v) in vs.iter().enumerate() {
                    if v.set != 0b111 || !v.p.iter().all(|c| c.is_finite()) {
                        return Err(Error::malformed(
                            path,
                            format!("element vertex {i} of {}", def.count),
                            format!("coordinates {:?} are not finite", v.p),
                        ));
                    }
                    vertices.push(v.p);
                }
            }
            "face" if face_list.is_some() => {
                faces = Parser::<PlyIndices>::new()
                    .read_payload_for_element(&mut reader, def, &header)
                    .map_err(|e| ply_error(path, name, binary, e))?;
            }
            "tristrips" if strip_list.is_some() => {
                strips = Parser::<PlyIndices>::new()
                    .read_payload_for_element(&mut reader, def, &header)
                    .map_err(|e| ply_error(path, name, binary, e))?;
            }
            _ => super::ply::skip_element(&mut reader, path, def, &header, file_len)?,
        }
    }

    let nv = vertices.len();
    let check = |what: &str, i: usize, idx: i64| -> Result<u32> {
        if idx < 0 || idx as usize >= nv {
            return Err(Error::malformed(
                path,
                format!("element {what} {i}"),
                format!(
                    "vertex index {idx} out of range (the file has {nv} vertices, indices 0..{})",
                    nv.saturating_sub(1)
                ),
            ));
        }
        Ok(idx as u32)
    };
    let mut triangles = Vec::new();
    let mut poly: Vec<u32> = Vec::new();
    for (i, f) in faces.iter().enumerate() {
        if f.idx.len() < 3 {
            return Err(Error::malformed(
                path,
                format!("element face {i}"),
                format!("face has {} vertices; a face needs at least 3", f.idx.len()),
            ));
        }
        poly.clear();
        for &idx in &f.idx {
            poly.push(check("face", i, idx)?);
        }
        push_fan(&mut triangles, &poly);
    }
    // Triangle strips: -1 ends a strip; every other triangle is flipped to keep the winding.
    for (i, s) in strips.iter().enumerate() {
        for run in s.idx.split(|&v| v < 0) {
            for k in 2..run.len() {
                let (a, b, c) = (run[k - 2], run[k - 1], run[k]);
                if a == b || b == c || a == c {
                    continue; // degenerate joins between strips
                }
                let t = if k % 2 == 0 { [a, b, c] } else { [b, a, c] };
                triangles.push([
                    check("tristrips", i, t[0])?,
                    check("tristrips", i, t[1])?,
                    check("tristrips", i, t[2])?,
                ]);
            }
        }
    }
    Ok(Mesh {
        vertices,
        triangles,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::io::Cursor;

    fn off(text: &str) -> Result<Mesh> {
        read_off(Path::new("t.off"), Cursor::new(text.as_bytes()))
    }
    fn obj(text: &str) -> Result<Mesh> {
        read_obj(Path::new("t.obj"), Cursor::new(text.as_bytes()))
    }

    #[test]
    fn off_counts_on_keyword_line_and_comments() {
        let m =
            off("OFF 4 2 0 # a square\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n# faces\n4 0 1 2 3\n3 0 1 2\n")
                .unwrap();
        assert_eq!(m.vertices.len(), 4);
        assert_eq!(m.triangles, vec![[0, 1, 2], [0, 2, 3], [0, 1, 2]]);
        assert!((m.area() - 1.5).abs() < 1e-12);
    }

    #[test]
    fn off_extra_data_is_an_error() {
        let e = off("OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n3 0 1 2\n").unwrap_err();
        assert_eq!(
            e.to_string(),
            "t.off: line 7: data after the last face: the header says 3 vertices and 1 faces; fix the counts"
        );
    }

    #[test]
    fn obj_negative_and_slashed_indices() {
        let m = obj("v 0 0 0\nv 1 0 0\nv 1 1 0\nvt 0 0\nf -3/1 -2//1 -1/1/1\n").unwrap();
        assert_eq!(m.triangles, vec![[0, 1, 2]]);
    }

    #[test]
    fn obj_line_continuation() {
        let m = obj("v 0 0 0\nv 1 0 0\nv 1 1 0\nf 1 2 \\\n 3\n").unwrap();
        assert_eq!(m.triangles, vec![[0, 1, 2]]);
    }

    #[test]
    fn obj_zero_index_rejected() {
        let e = obj("v 0 0 0\nv 1 0 0\nv 1 1 0\nf 0 1 2\n").unwrap_err();
        assert!(
            e.to_string()
                .contains("line 4: face 0: vertex index 0 out of range"),
            "{e}"
        );
    }
}
