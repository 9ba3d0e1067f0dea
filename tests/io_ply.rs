//! PLY reading and writing: write -> read round trips for every encoding and precision with
//! attributes of every type, the exact bytes of a written file, `element edge`, georeferenced
//! coordinates, hand-made files in all three encodings with elements before and after the
//! vertices, and the binary fast path against ply-rs-bw's typed path.

use std::path::Path;

use proptest::prelude::*;
use sharpedge::io::{self, PlyEncoding, PlyWriteOptions, Precision, ReadOptions};
use sharpedge::{Attribute, Column};

// ---- helpers --------------------------------------------------------------------------------

#[derive(Clone, Copy, Debug, PartialEq)]
enum Enc {
    Ascii,
    Le,
    Be,
}

impl Enc {
    fn name(self) -> &'static str {
        match self {
            Enc::Ascii => "ascii",
            Enc::Le => "binary_little_endian",
            Enc::Be => "binary_big_endian",
        }
    }
}

/// `ply`, the format line, `rest` (element and property lines), `end_header`.
fn header(enc: Enc, rest: &str) -> String {
    format!("ply\nformat {} 1.0\n{rest}end_header\n", enc.name())
}

/// Builds a PLY body value by value in any encoding.
struct Body {
    enc: Enc,
    bytes: Vec<u8>,
}

impl Body {
    fn new(enc: Enc) -> Self {
        Body {
            enc,
            bytes: Vec::new(),
        }
    }

    fn val(&mut self, ty: &str, v: f64) -> &mut Self {
        macro_rules! bin {
            ($t:ty) => {{
                let x = v as $t;
                match self.enc {
                    Enc::Le => self.bytes.extend_from_slice(&x.to_le_bytes()),
                    Enc::Be => self.bytes.extend_from_slice(&x.to_be_bytes()),
                    Enc::Ascii => self.bytes.extend_from_slice(format!("{x} ").as_bytes()),
                }
            }};
        }
        match ty {
            "char" | "int8" => bin!(i8),
            "uchar" | "uint8" => bin!(u8),
            "short" | "int16" => bin!(i16),
            "ushort" | "uint16" => bin!(u16),
            "int" | "int32" => bin!(i32),
            "uint" | "uint32" => bin!(u32),
            "float" | "float32" => bin!(f32),
            "double" | "float64" => bin!(f64),
            other => panic!("test helper: unknown type {other}"),
        }
        self
    }

    fn list(&mut self, count_ty: &str, ty: &str, vs: &[f64]) -> &mut Self {
        self.val(count_ty, vs.len() as f64);
        for v in vs {
            self.val(ty, *v);
        }
        self
    }

    /// Ends an item (a line in ascii).
    fn end(&mut self) -> &mut Self {
        if self.enc == Enc::Ascii {
            if self.bytes.last() == Some(&b' ') {
                self.bytes.pop();
            }
            self.bytes.push(b'\n');
        }
        self
    }
}

fn write_file(dir: &Path, name: &str, header: &str, body: &[u8]) -> std::path::PathBuf {
    let p = dir.join(name);
    let mut bytes = header.as_bytes().to_vec();
    bytes.extend_from_slice(body);
    std::fs::write(&p, bytes).expect("writing a test file");
    p
}

fn attr(name: &str, values: Column) -> Attribute {
    Attribute {
        name: name.into(),
        values,
    }
}

/// One attribute of every PLY scalar type, with the extreme values of each.
fn every_type(n: usize) -> Vec<Attribute> {
    let pick = |vals: &[f64], i: usize| vals[i % vals.len()];
    let i8s = [-128.0, 127.0, 0.0, -1.0];
    let u8s = [0.0, 255.0, 17.0];
    let i16s = [-32768.0, 32767.0, -5.0];
    let u16s = [0.0, 65535.0, 1234.0];
    let i32s = [-2147483648.0, 2147483647.0, 7.0];
    let u32s = [0.0, 4294967295.0, 99.0];
    vec![
        attr(
            "scalar_char",
            Column::I8((0..n).map(|i| pick(&i8s, i) as i8).collect()),
        ),
        attr(
            "scalar_uchar",
            Column::U8((0..n).map(|i| pick(&u8s, i) as u8).collect()),
        ),
        attr(
            "scalar_short",
            Column::I16((0..n).map(|i| pick(&i16s, i) as i16).collect()),
        ),
        attr(
            "scalar_ushort",
            Column::U16((0..n).map(|i| pick(&u16s, i) as u16).collect()),
        ),
        attr(
            "scalar_int",
            Column::I32((0..n).map(|i| pick(&i32s, i) as i32).collect()),
        ),
        attr(
            "scalar_uint",
            Column::U32((0..n).map(|i| pick(&u32s, i) as u32).collect()),
        ),
        attr(
            "scalar_float",
            Column::F32(
                (0..n)
                    .map(|i| [0.1f32, -3.4e38, 1.2e-38, -0.0, 16777217.0][i % 5])
                    .collect(),
            ),
        ),
        attr(
            "scalar_double",
            Column::F64(
                (0..n)
                    .map(|i| [0.1, -1e300, 5e-324, 123456789.12345679, 1e-7][i % 5])
                    .collect(),
            ),
        ),
    ]
}

fn positions(n: usize) -> Vec<[f64; 3]> {
    (0..n)
        .map(|i| {
            let t = i as f64;
            [0.1 * t - 3.0, 1.0 / (t + 3.0), -1e-3 * t * t]
        })
        .collect()
}

/// Bit-exact comparison of two columns (NaN-safe, distinguishes -0.0 from 0.0).
fn same_bits(a: &Column, b: &Column) -> bool {
    match (a, b) {
        (Column::F32(x), Column::F32(y)) => {
            x.len() == y.len() && x.iter().zip(y).all(|(p, q)| p.to_bits() == q.to_bits())
        }
        (Column::F64(x), Column::F64(y)) => {
            x.len() == y.len() && x.iter().zip(y).all(|(p, q)| p.to_bits() == q.to_bits())
        }
        _ => a == b,
    }
}

// ---- write -> read ---------------------------------------------------------------------------

#[test]
fn round_trip_every_encoding_and_precision_with_every_type() {
    let dir = tempfile::tempdir().unwrap();
    let n = 23;
    let pos = positions(n);
    let attrs = every_type(n);
    let refs: Vec<&Attribute> = attrs.iter().collect();
    for encoding in [PlyEncoding::BinaryLittleEndian, PlyEncoding::Ascii] {
        for precision in [Precision::F32, Precision::F64] {
            let path = dir
                .path()
                .join(format!("rt_{encoding:?}_{precision:?}.ply"));
            let opts = PlyWriteOptions {
                encoding,
                precision,
            };
            io::write_ply(&path, &pos, &refs, &[], &opts).unwrap();
            let c = io::read(&path, &ReadOptions::default()).unwrap();
            assert_eq!(c.len(), n);
            for (got, want) in c.positions.iter().zip(&pos) {
                for k in 0..3 {
                    let want_k = match precision {
                        Precision::F32 => f64::from(want[k] as f32),
                        Precision::F64 => want[k],
                    };
                    assert_eq!(
                        got[k].to_bits(),
                        want_k.to_bits(),
                        "{encoding:?} {precision:?}"
                    );
                }
            }
            assert_eq!(c.attributes.len(), attrs.len());
            for (got, want) in c.attributes.iter().zip(&attrs) {
                assert_eq!(got.name, want.name);
                assert!(
                    same_bits(&got.values, &want.values),
                    "{encoding:?} {precision:?} {}: {:?} != {:?}",
                    want.name,
                    got.values,
                    want.values
                );
            }
            let enc = match encoding {
                PlyEncoding::Ascii => "ascii",
                PlyEncoding::BinaryLittleEndian => "binary_little_endian",
            };
            assert_eq!(c.source.format, format!("PLY {enc} 1.0"));
            assert_eq!(c.source.double_precision, precision == Precision::F64);
            assert_eq!(c.source.path, path);
        }
    }
}

#[test]
fn binary_file_is_byte_exact() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("exact.ply");
    let pos = [[1.0, -2.0, 0.5], [3.25, 4.0, -8.0]];
    let red = attr("red", Column::U8(vec![255, 7]));
    let sharp = attr("scalar_sharpness", Column::F32(vec![0.5, -1.0]));
    let opts = PlyWriteOptions {
        encoding: PlyEncoding::BinaryLittleEndian,
        precision: Precision::F64,
    };
    io::write_ply(&path, &pos, &[&red, &sharp], &[[0, 1]], &opts).unwrap();
    let bytes = std::fs::read(&path).unwrap();
    let mut want = format!(
        "ply\n\
         format binary_little_endian 1.0\n\
         comment written by sharpedge {}\n\
         element vertex 2\n\
         property double x\n\
         property double y\n\
         property double z\n\
         property uchar red\n\
         property float scalar_sharpness\n\
         element edge 1\n\
         property int vertex1\n\
         property int vertex2\n\
         end_header\n",
        env!("CARGO_PKG_VERSION")
    )
    .into_bytes();
    for (p, (r, s)) in pos.iter().zip([(255u8, 0.5f32), (7, -1.0)]) {
        for c in p {
            want.extend_from_slice(&c.to_le_bytes());
        }
        want.push(r);
        want.extend_from_slice(&s.to_le_bytes());
    }
    want.extend_from_slice(&0i32.to_le_bytes());
    want.extend_from_slice(&1i32.to_le_bytes());
    assert_eq!(bytes, want);
}

#[test]
fn ascii_file_is_readable_text() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("a.ply");
    let q = attr("quality", Column::F32(vec![0.25, 1e-7]));
    let id = attr("scalar_edge_id", Column::I32(vec![-1, 3]));
    let opts = PlyWriteOptions {
        encoding: PlyEncoding::Ascii,
        precision: Precision::F32,
    };
    io::write_ply(
        &path,
        &[[0.1, 2.0, -3.5], [1e20, 0.0, 7.0]],
        &[&q, &id],
        &[[1, 0]],
        &opts,
    )
    .unwrap();
    let text = std::fs::read_to_string(&path).unwrap();
    let body = text.split("end_header\n").nth(1).unwrap();
    assert_eq!(body, "0.1 2 -3.5 0.25 -1\n1e20 0 7 1e-7 3\n1 0\n");
}

/// Reads the edge element back with ply-rs-bw's generic parser (fine for a few edges).
fn edges_via_crate(path: &Path) -> Vec<[i32; 2]> {
    use ply_rs_bw::parser::Parser;
    use ply_rs_bw::ply::{DefaultElement, Property};
    let mut f = std::fs::File::open(path).unwrap();
    let ply = Parser::<DefaultElement>::new().read_ply(&mut f).unwrap();
    let def = &ply.header.elements["edge"];
    let names: Vec<&String> = def.properties.keys().collect();
    assert_eq!(names, ["vertex1", "vertex2"]);
    ply.payload["edge"]
        .iter()
        .map(|e| match (&e["vertex1"], &e["vertex2"]) {
            (Property::Int(a), Property::Int(b)) => [*a, *b],
            other => panic!("edge properties must be int, got {other:?}"),
        })
        .collect()
}

#[test]
fn edge_element_round_trip() {
    let dir = tempfile::tempdir().unwrap();
    let pos = positions(5);
    let edges = [[0u32, 1], [1, 2], [2, 3], [3, 4], [4, 0]];
    let id = attr("scalar_edge_id", Column::I32(vec![0, 0, 1, 1, 2]));
    for encoding in [PlyEncoding::BinaryLittleEndian, PlyEncoding::Ascii] {
        let path = dir.path().join(format!("edges_{encoding:?}.ply"));
        let opts = PlyWriteOptions {
            encoding,
            precision: Precision::F64,
        };
        io::write_ply(&path, &pos, &[&id], &edges, &opts).unwrap();
        let got = edges_via_crate(&path);
        let want: Vec<[i32; 2]> = edges.iter().map(|e| [e[0] as i32, e[1] as i32]).collect();
        assert_eq!(got, want, "{encoding:?}");
        // Our reader reads the vertices and reports the edges as an element it skipped.
        let c = io::read(&path, &ReadOptions::default()).unwrap();
        assert_eq!(c.positions, pos);
        let info = io::describe(&path).unwrap();
        assert_eq!(info.other_elements.len(), 1);
        assert_eq!(info.other_elements[0].name, "edge");
        assert_eq!(info.other_elements[0].count, 5);
    }
}

#[test]
fn georeferenced_coordinates_survive_double() {
    let dir = tempfile::tempdir().unwrap();
    let pos: Vec<[f64; 3]> = (0..100)
        .map(|i| {
            let t = f64::from(i);
            [
                512345.123 + 0.001 * t,
                4101234.567 - 0.003 * t,
                80.25 + 1e-4 * t,
            ]
        })
        .collect();
    for encoding in [PlyEncoding::BinaryLittleEndian, PlyEncoding::Ascii] {
        let path = dir.path().join(format!("geo_{encoding:?}.ply"));
        let opts = PlyWriteOptions {
            encoding,
            precision: Precision::F64,
        };
        io::write_ply(&path, &pos, &[], &[], &opts).unwrap();
        let c = io::read(&path, &ReadOptions::default()).unwrap();
        for (a, b) in c.positions.iter().zip(&pos) {
            for k in 0..3 {
                assert!((a[k] - b[k]).abs() <= 1e-6, "{encoding:?}: {a:?} vs {b:?}");
            }
        }
        assert!(c.source.double_precision);
        assert_eq!(Precision::for_source(&c.source), Precision::F64);
    }
    // Float coordinates cannot hold them: the reason outputs follow the input's precision.
    let path = dir.path().join("geo_f32.ply");
    io::write_ply(&path, &pos, &[], &[], &PlyWriteOptions::default()).unwrap();
    let c = io::read(&path, &ReadOptions::default()).unwrap();
    let worst = c
        .positions
        .iter()
        .zip(&pos)
        .map(|(a, b)| (a[1] - b[1]).abs())
        .fold(0.0, f64::max);
    assert!(
        worst > 1e-2,
        "f32 error at 4e6 should be centimetres, got {worst}"
    );
    assert!(!c.source.double_precision);
}

#[test]
fn empty_cloud_is_read_and_written() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("empty.ply");
    let a = attr("quality", Column::F32(vec![]));
    io::write_ply(&path, &[], &[&a], &[], &PlyWriteOptions::default()).unwrap();
    let c = io::read(&path, &ReadOptions::default()).unwrap();
    assert!(c.is_empty());
    assert_eq!(c.attributes.len(), 1);
    assert!(c.is_consistent());
    assert_eq!(io::describe(&path).unwrap().bbox, None);
}

#[test]
fn writer_rejects_inconsistent_data_without_leaving_a_file() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("bad.ply");
    let pos = positions(3);
    let short = attr("quality", Column::F32(vec![1.0]));
    let spaced = attr("my value", Column::F32(vec![1.0; 3]));
    let dup = attr("x", Column::F32(vec![1.0; 3]));
    let nan_attr = attr("quality", Column::F64(vec![0.0, f64::NAN, 1.0]));
    let ascii = PlyWriteOptions {
        encoding: PlyEncoding::Ascii,
        precision: Precision::F32,
    };
    let d = PlyWriteOptions::default();
    let cases: Vec<(Result<(), sharpedge::Error>, &str)> = vec![
        (
            io::write_ply(&path, &pos, &[&short], &[], &d),
            "attribute `quality` has 1 values for 3 vertices",
        ),
        (
            io::write_ply(&path, &pos, &[&spaced], &[], &d),
            "attribute name `my value` is not a PLY property name",
        ),
        (
            io::write_ply(&path, &pos, &[&dup], &[], &d),
            "two vertex properties are named `x`",
        ),
        (
            io::write_ply(&path, &pos, &[], &[[0, 3]], &d),
            "edge 0 (0, 3) points past the last vertex (3 vertices)",
        ),
        (
            io::write_ply(&path, &[[0.0, f64::NAN, 0.0]], &[], &[], &d),
            "vertex 0 has a non-finite position (0, NaN, 0)",
        ),
        (
            io::write_ply(&path, &[[1e39, 0.0, 0.0]], &[], &[], &d),
            "does not fit a float; write double coordinates",
        ),
        (
            io::write_ply(&path, &pos, &[&nan_attr], &[], &ascii),
            "attribute `quality` is NaN at vertex 1",
        ),
    ];
    for (r, want) in cases {
        let e = r.unwrap_err().to_string();
        assert!(
            e.starts_with(&format!("{}: cannot write: ", path.display())),
            "{e}"
        );
        assert!(e.contains(want), "{e}\nshould contain: {want}");
    }
    // NaN attributes are fine in binary (the value round-trips).
    io::write_ply(&path, &pos, &[&nan_attr], &[], &d).unwrap();
    let c = io::read(&path, &ReadOptions::default()).unwrap();
    assert!(c.attributes[0].values.get_f64(1).is_nan());
    std::fs::remove_file(&path).unwrap();
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
}

#[test]
fn write_atomic_replaces_only_on_success() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("report.json");
    io::write_atomic(&path, |w| {
        w.write_all(b"{\"v\": 1}")
            .map_err(|e| sharpedge::Error::io("x", "w", e))
    })
    .unwrap();
    assert_eq!(std::fs::read(&path).unwrap(), b"{\"v\": 1}");
    let r = io::write_atomic(&path, |w| {
        w.write_all(b"{\"v\": 2, half").unwrap();
        Err(sharpedge::Error::Usage {
            option: "test".into(),
            message: "fails midway".into(),
        })
    });
    assert!(r.is_err());
    // The old content is intact and no temporary file is left over.
    assert_eq!(std::fs::read(&path).unwrap(), b"{\"v\": 1}");
    let names: Vec<_> = std::fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    assert_eq!(names, ["report.json"]);
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        let mode = std::fs::metadata(&path).unwrap().permissions().mode();
        assert_eq!(
            mode & 0o044,
            0o044,
            "outputs must be readable by others: {mode:o}"
        );
    }
}

// ---- hand-made files ------------------------------------------------------------------------

/// A file with a face element before the vertices and a custom element with lists after
/// them, comments and obj_info; vertex properties of mixed types.
fn mixed_file(dir: &Path, enc: Enc) -> std::path::PathBuf {
    let h = header(
        enc,
        "comment made by a test\n\
         obj_info scanner: none\n\
         element face 2\n\
         property list uchar int vertex_indices\n\
         property uchar flags\n\
         element vertex 3\n\
         property short label\n\
         property float z\n\
         property double x\n\
         property int8 tag\n\
         property float y\n\
         property uint32 big\n\
         element range_grid 2\n\
         property list uint8 int32 vertex_indices\n",
    );
    let mut b = Body::new(enc);
    b.list("uchar", "int", &[0.0, 1.0, 2.0])
        .val("uchar", 9.0)
        .end();
    b.list("uchar", "int", &[2.0, 1.0, 0.0, 1.0])
        .val("uchar", 8.0)
        .end();
    for (i, p) in [[1.5, -2.0, 0.25], [512345.125, 7.0, -1.0], [0.0, 0.0, 0.0]]
        .iter()
        .enumerate()
    {
        b.val("short", -(i as f64))
            .val("float", p[2])
            .val("double", p[0])
            .val("int8", i as f64 - 1.0)
            .val("float", p[1])
            .val("uint32", 4294967295.0 - i as f64)
            .end();
    }
    b.list("uint8", "int32", &[]).end();
    b.list("uint8", "int32", &[5.0]).end();
    write_file(dir, &format!("mixed_{enc:?}.ply"), &h, &b.bytes)
}

#[test]
fn elements_before_and_after_vertices_are_skipped_in_every_encoding() {
    let dir = tempfile::tempdir().unwrap();
    for enc in [Enc::Ascii, Enc::Le, Enc::Be] {
        let path = mixed_file(dir.path(), enc);
        let c = io::read(&path, &ReadOptions::default()).unwrap();
        assert_eq!(
            c.positions,
            vec![[1.5, -2.0, 0.25], [512345.125, 7.0, -1.0], [0.0, 0.0, 0.0]],
            "{enc:?}"
        );
        let names: Vec<&str> = c.attributes.iter().map(|a| a.name.as_str()).collect();
        assert_eq!(names, ["label", "tag", "big"]);
        assert_eq!(c.attributes[0].values, Column::I16(vec![0, -1, -2]));
        assert_eq!(c.attributes[1].values, Column::I8(vec![-1, 0, 1]));
        assert_eq!(
            c.attributes[2].values,
            Column::U32(vec![4294967295, 4294967294, 4294967293])
        );
        assert_eq!(c.source.format, format!("PLY {} 1.0", enc.name()));
        // x is double: the file is more precise than float.
        assert!(c.source.double_precision);
        // The crate's typed path gives the very same cloud.
        assert_eq!(io::read_ply_via_crate(&path).unwrap(), c, "{enc:?}");
        let info = io::describe(&path).unwrap();
        let types: Vec<String> = info
            .properties
            .iter()
            .map(|p| format!("{} {}", p.ty, p.name))
            .collect();
        assert_eq!(
            types,
            [
                "double x",
                "float y",
                "float z",
                "short label",
                "char tag",
                "uint big"
            ]
        );
        let other: Vec<(String, usize)> = info
            .other_elements
            .iter()
            .map(|e| (e.name.clone(), e.count))
            .collect();
        assert_eq!(
            other,
            [("face".to_string(), 2), ("range_grid".to_string(), 2)]
        );
    }
}

#[test]
fn header_with_trailing_spaces_comments_and_sized_type_names() {
    let dir = tempfile::tempdir().unwrap();
    let text = "ply \nformat ascii 1.0 \ncomment a b c\nobj_info x y\n\
                element vertex 2\nproperty float32 x\nproperty float64 y\n\
                property int16 z \nproperty uint16 w\nproperty uint8 red\nend_header\n\
                1.5 2.25 -3 65535 255\n-0.5 1e-3 7 0 0\n";
    let path = dir.path().join("spaces.ply");
    std::fs::write(&path, text).unwrap();
    let c = io::read(&path, &ReadOptions::default()).unwrap();
    assert_eq!(c.positions, vec![[1.5, 2.25, -3.0], [-0.5, 1e-3, 7.0]]);
    assert_eq!(c.attributes[0].values, Column::U16(vec![65535, 0]));
    assert_eq!(c.attributes[1].values, Column::U8(vec![255, 0]));
}

#[test]
fn integer_coordinates_beyond_float_mantissa_need_double() {
    let dir = tempfile::tempdir().unwrap();
    for (v, double) in [(16777216.0, false), (16777217.0, true)] {
        let h = header(
            Enc::Le,
            "element vertex 1\nproperty int x\nproperty int y\nproperty int z\n",
        );
        let mut b = Body::new(Enc::Le);
        b.val("int", v).val("int", 0.0).val("int", -5.0);
        let path = write_file(dir.path(), "ints.ply", &h, &b.bytes);
        let c = io::read(&path, &ReadOptions::default()).unwrap();
        assert_eq!(c.positions, vec![[v, 0.0, -5.0]]);
        assert_eq!(c.source.double_precision, double, "{v}");
    }
}

#[test]
fn vertex_properties_past_the_inline_slots_are_kept() {
    // 12 extra properties: more than the typed path keeps inline per vertex.
    let dir = tempfile::tempdir().unwrap();
    let mut props =
        String::from("element vertex 2\nproperty float x\nproperty float y\nproperty float z\n");
    for i in 0..12 {
        props.push_str(&format!("property int p{i}\n"));
    }
    for enc in [Enc::Ascii, Enc::Le] {
        let mut b = Body::new(enc);
        for v in 0..2 {
            b.val("float", 1.0).val("float", 2.0).val("float", 3.0);
            for i in 0..12 {
                b.val("int", f64::from(100 * v + i));
            }
            b.end();
        }
        let path = write_file(dir.path(), "many.ply", &header(enc, &props), &b.bytes);
        for c in [
            io::read(&path, &ReadOptions::default()).unwrap(),
            io::read_ply_via_crate(&path).unwrap(),
        ] {
            assert_eq!(c.attributes.len(), 12);
            for (i, a) in c.attributes.iter().enumerate() {
                assert_eq!(a.name, format!("p{i}"));
                assert_eq!(
                    a.values,
                    Column::I32(vec![i as i32, 100 + i as i32]),
                    "{enc:?}"
                );
            }
        }
    }
}

// ---- properties -----------------------------------------------------------------------------

fn column_strategy(n: usize) -> impl Strategy<Value = Column> {
    prop_oneof![
        proptest::collection::vec(any::<i8>(), n).prop_map(Column::I8),
        proptest::collection::vec(any::<u8>(), n).prop_map(Column::U8),
        proptest::collection::vec(any::<i16>(), n).prop_map(Column::I16),
        proptest::collection::vec(any::<u16>(), n).prop_map(Column::U16),
        proptest::collection::vec(any::<i32>(), n).prop_map(Column::I32),
        proptest::collection::vec(any::<u32>(), n).prop_map(Column::U32),
        proptest::collection::vec(proptest::num::f32::NORMAL | proptest::num::f32::ZERO, n)
            .prop_map(Column::F32),
        proptest::collection::vec(proptest::num::f64::NORMAL | proptest::num::f64::ZERO, n)
            .prop_map(Column::F64),
    ]
}

fn cloud_strategy() -> impl Strategy<Value = (Vec<[f64; 3]>, Vec<Column>)> {
    (0usize..40).prop_flat_map(|n| {
        (
            proptest::collection::vec(proptest::array::uniform3(-1e7f64..1e7f64), n),
            proptest::collection::vec(column_strategy(n), 0..5),
        )
    })
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(48))]

    /// Whatever the values and types, double coordinates and every attribute read back
    /// bit for bit, in both encodings.
    #[test]
    fn any_cloud_round_trips((pos, cols) in cloud_strategy(), ascii in any::<bool>()) {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("p.ply");
        let attrs: Vec<Attribute> = cols
            .into_iter()
            .enumerate()
            .map(|(i, c)| attr(&format!("a{i}"), c))
            .collect();
        let refs: Vec<&Attribute> = attrs.iter().collect();
        let opts = PlyWriteOptions {
            encoding: if ascii { PlyEncoding::Ascii } else { PlyEncoding::BinaryLittleEndian },
            precision: Precision::F64,
        };
        io::write_ply(&path, &pos, &refs, &[], &opts).unwrap();
        let c = io::read(&path, &ReadOptions::default()).unwrap();
        prop_assert_eq!(&c.positions, &pos);
        prop_assert_eq!(c.attributes.len(), attrs.len());
        for (g, w) in c.attributes.iter().zip(&attrs) {
            prop_assert!(same_bits(&g.values, &w.values), "{:?} vs {:?}", g.values, w.values);
        }
    }
}
