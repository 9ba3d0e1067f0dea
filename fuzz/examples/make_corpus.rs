//! Writes the seed corpora of the fuzz targets into `corpus-seed/<target>/` (run by
//! `make_corpus.sh`): small valid files of every flavour each reader takes, made from the
//! repository's samples (their first points) and generated here, so the fuzzer starts from
//! inputs that get past the headers. Every file stays under 64 KB. The `xyz` and `mesh`
//! seeds carry the targets' leading selector byte (see fuzz_targets/xyz.rs and mesh.rs).
//!
//! Usage: `make_corpus REPO_ROOT OUT_DIR`.

use std::path::{Path, PathBuf};

use las::point::Format;
use las::{Builder, Color, Point, Transform, Vector};
use sharpedge::io::{PlyEncoding, PlyWriteOptions, Precision, ReadOptions, read, write_ply};

/// Points taken from each sample: a few KB per seed.
const SAMPLE_POINTS: usize = 60;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let (root, out) = match args.as_slice() {
        [_, root, out] => (PathBuf::from(root), PathBuf::from(out)),
        _ => {
            eprintln!("usage: make_corpus REPO_ROOT OUT_DIR");
            std::process::exit(2);
        }
    };
    for t in ["ply", "las", "xyz", "mesh", "config", "pcd", "e57"] {
        std::fs::create_dir_all(out.join(t)).expect("cannot create the corpus folders");
    }
    ply_seeds(&root, &out.join("ply"));
    las_seeds(&out.join("las"));
    xyz_seeds(&out.join("xyz"));
    mesh_seeds(&out.join("mesh"));
    config_seeds(&root, &out.join("config"));
    pcd_seeds(&out.join("pcd"));
    e57_seeds(&out.join("e57"));
}

/// A PCD header for `fields` (name, TYPE, SIZE, COUNT) and a WIDTH x HEIGHT frame.
fn pcd_header(fields: &[(&str, char, usize, usize)], w: usize, h: usize, data: &str) -> String {
    let list = |f: &dyn Fn(&(&str, char, usize, usize)) -> String| {
        fields.iter().map(f).collect::<Vec<_>>().join(" ")
    };
    format!(
        "# .PCD v0.7 - Point Cloud Data file format\nVERSION 0.7\nFIELDS {}\nSIZE {}\nTYPE {}\n\
         COUNT {}\nWIDTH {w}\nHEIGHT {h}\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS {}\nDATA {data}\n",
        list(&|f| f.0.to_string()),
        list(&|f| f.2.to_string()),
        list(&|f| f.1.to_string()),
        list(&|f| f.3.to_string()),
        w * h
    )
}

/// LZF data of literal runs only (valid LZF, what liblzf stores for data it cannot shrink).
fn lzf_literals(data: &[u8]) -> Vec<u8> {
    let mut out = Vec::new();
    for run in data.chunks(32) {
        out.push((run.len() - 1) as u8);
        out.extend_from_slice(run);
    }
    out
}

fn pcd_seeds(dir: &Path) {
    // An organised 3 x 2 frame, `label x y z rgba`, one NaN slot, in the three encodings.
    let fields = [
        ("label", 'U', 4, 1),
        ("x", 'F', 4, 1),
        ("y", 'F', 4, 1),
        ("z", 'F', 4, 1),
        ("rgba", 'U', 4, 1),
    ];
    let mut records = Vec::new();
    let mut ascii = String::new();
    for i in 0..6u32 {
        let p = if i == 4 {
            [f32::NAN; 3]
        } else {
            [i as f32 * 0.5, 1.0 - i as f32 * 0.25, 2.0]
        };
        let rgba = 0xff00_0000 | i * 0x0010_2030;
        records.extend_from_slice(&(i % 3).to_le_bytes());
        for v in p {
            records.extend_from_slice(&v.to_le_bytes());
        }
        records.extend_from_slice(&rgba.to_le_bytes());
        let t = |v: f32| if v.is_nan() { "nan".to_string() } else { v.to_string() };
        ascii.push_str(&format!("{} {} {} {} {rgba}\n", i % 3, t(p[0]), t(p[1]), t(p[2])));
    }
    let mut b = pcd_header(&fields, 3, 2, "binary").into_bytes();
    b.extend_from_slice(&records);
    write(&dir.join("frame-binary.pcd"), &b);
    let mut a = pcd_header(&fields, 3, 2, "ascii").into_bytes();
    a.extend_from_slice(ascii.as_bytes());
    write(&dir.join("frame-ascii.pcd"), &a);
    let mut blocks = Vec::new();
    for k in 0..5 {
        for i in 0..6 {
            blocks.extend_from_slice(&records[20 * i + 4 * k..20 * i + 4 * k + 4]);
        }
    }
    let packed = lzf_literals(&blocks);
    let mut c = pcd_header(&fields, 3, 2, "binary_compressed").into_bytes();
    c.extend_from_slice(&(packed.len() as u32).to_le_bytes());
    c.extend_from_slice(&(blocks.len() as u32).to_le_bytes());
    c.extend_from_slice(&packed);
    write(&dir.join("frame-compressed.pcd"), &c);
    // Every type, COUNT > 1 and padding, unorganised, ascii; and an old v0.5 header.
    let fields = [
        ("x", 'F', 8, 1),
        ("y", 'F', 8, 1),
        ("z", 'F', 8, 1),
        ("_", 'U', 1, 2),
        ("normal", 'F', 4, 3),
        ("a", 'I', 1, 1),
        ("b", 'I', 2, 1),
        ("c", 'I', 4, 1),
        ("d", 'U', 1, 1),
        ("e", 'U', 2, 1),
        ("rgb", 'F', 4, 1),
    ];
    let mut t = pcd_header(&fields, 2, 1, "ascii");
    t.push_str("1e-3 2.5 -3 0 0 0 0.6 0.8 -5 -300 70000 200 60000 4278190080\n");
    t.push_str("4 5 6 0 0 1 0 0 5 300 -70000 0 0 1.5e-39\n");
    write(&dir.join("types-ascii.pcd"), t.as_bytes());
    write(
        &dir.join("v05.pcd"),
        b"VERSION .5\nFIELDS x y z\nSIZE 4 4 4\nPOINTS 3\nDATA ascii\n1 2 3\n4 5 6\n7 8 9\n",
    );
}

fn write(path: &Path, bytes: &[u8]) {
    std::fs::write(path, bytes).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
}

/// Seeds with the target's selector byte in front.
fn write_selected(dir: &Path, name: &str, selector: u8, body: &[u8]) {
    let mut b = vec![selector];
    b.extend_from_slice(body);
    write(&dir.join(name), &b);
}

fn ply_seeds(root: &Path, dir: &Path) {
    for sample in ["box", "lblock"] {
        let src = root.join("samples").join(format!("{sample}.ply"));
        let mut cloud = read(&src, &ReadOptions::default()).expect("cannot read a sample");
        let keep: Vec<bool> = (0..cloud.len()).map(|i| i < SAMPLE_POINTS).collect();
        cloud.retain_mask(&keep);
        let positions = &cloud.positions;
        let attrs = &cloud.attributes;
        let refs: Vec<&sharpedge::Attribute> = attrs.iter().collect();
        for (enc, precision, tag) in [
            (PlyEncoding::BinaryLittleEndian, Precision::F32, "bin-float"),
            (
                PlyEncoding::BinaryLittleEndian,
                Precision::F64,
                "bin-double",
            ),
            (PlyEncoding::Ascii, Precision::F32, "ascii"),
        ] {
            let opts = PlyWriteOptions {
                encoding: enc,
                precision,
            };
            let path = dir.join(format!("{sample}-{tag}.ply"));
            let edges: &[[u32; 2]] = if tag == "ascii" {
                &[[0, 1], [1, 2]]
            } else {
                &[]
            };
            write_ply(&path, positions, &refs, edges, &opts).expect("cannot write a seed");
        }
    }
    // Hand-written flavours: big endian, an element before `vertex` with a list, integer
    // coordinates, NaN in ascii.
    let mut be = b"ply\nformat binary_big_endian 1.0\nelement face 1\n\
        property list uchar int vertex_indices\nelement vertex 3\nproperty float x\n\
        property float y\nproperty float z\nproperty uchar red\nend_header\n"
        .to_vec();
    be.extend_from_slice(&[3, 0, 0, 0, 0, 0, 0, 0, 1, 0, 0, 0, 2]);
    for v in [[0.0f32, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.5]] {
        for c in v {
            be.extend_from_slice(&c.to_be_bytes());
        }
        be.push(200);
    }
    write(&dir.join("face-first-be.ply"), &be);
    write(
        &dir.join("int-ascii.ply"),
        b"ply\nformat ascii 1.0\ncomment ints\nelement range_grid 2\n\
          property list uchar int vertex_indices\nelement vertex 3\nproperty int x\n\
          property short y\nproperty uint z\nproperty double quality\nend_header\n\
          1 0\n0\n1 2 3 0.5\n-4 5 6 nan\n7 -8 9 inf\n",
    );
}

fn las_header(format: u8, version: (u8, u8), offset: f64) -> las::Header {
    let mut b = Builder::from(version);
    b.point_format = Format::new(format).expect("point format");
    b.point_format.is_compressed = false;
    let t = Transform {
        scale: 0.001,
        offset,
    };
    b.transforms = Vector { x: t, y: t, z: t };
    b.into_header().expect("header")
}

fn las_points(format: u8) -> Vec<Point> {
    let f = Format::new(format).expect("point format");
    (0..40)
        .map(|i| {
            let t = f64::from(i);
            Point {
                x: 1000.0 + (t * 0.7).sin(),
                y: 2000.0 + t * 0.01,
                z: 10.0 + (t * 0.3).cos(),
                intensity: i as u16 * 7,
                return_number: 1,
                number_of_returns: 1,
                gps_time: f.has_gps_time.then_some(t * 0.5),
                color: f.has_color.then_some(Color::new(i as u16, 3, 65535)),
                nir: f.has_nir.then_some(17),
                ..Default::default()
            }
        })
        .collect()
}

fn las_seeds(dir: &Path) {
    for (format, version) in [
        (0, (1, 2)),
        (1, (1, 2)),
        (2, (1, 3)),
        (3, (1, 2)),
        (6, (1, 4)),
        (7, (1, 4)),
        (8, (1, 4)),
    ] {
        for compressed in [false, true] {
            let mut header = las_header(format, version, 1000.0);
            let ext = if compressed { "laz" } else { "las" };
            if compressed {
                let mut b = Builder::new(header.into_raw().expect("raw header")).expect("builder");
                b.point_format.is_compressed = true;
                header = b.into_header().expect("header");
            }
            let path = dir.join(format!("format{format}-{}.{}.{ext}", version.0, version.1));
            let mut w = las::Writer::from_path(&path, header).expect("LAS writer");
            for p in las_points(format) {
                w.write_point(p).expect("write point");
            }
            w.close().expect("close");
        }
    }
}

fn xyz_seeds(dir: &Path) {
    // Selector 0: .xyz, 1: .pts.
    write_selected(dir, "plain.xyz", 0, b"0 0 0\n1 0 0\n0 1 0\n0 0 1.5\n");
    write_selected(
        dir,
        "normals.xyz",
        0,
        b"# comment\n0,0,0,0,0,1\n1,0,0,0,0,1\n0.5;1;0;0;0;1\n",
    );
    write_selected(
        dir,
        "named.xyz",
        0,
        b"//X,Y,Z,R,G,B,Scalar field\n512345.123 4101234.567 12.5 255 0 0 0.25\n\
          512345.124 4101234.568 12.6 0 255 0 nan\n",
    );
    write_selected(
        dir,
        "header.xyz",
        0,
        b"x y z intensity\n1e-3 2E3 -4.5 7\ninf 0 0 1\n",
    );
    write_selected(
        dir,
        "leica.pts",
        1,
        b"3\n0 0 0 -1204 10 20 30\n1 0 0 -1000 11 21 31\n0 1 0 200 12 22 32\n2\n5 5 5 1 2 3 4\n6 6 6 1 2 3 4\n",
    );
}

fn mesh_seeds(dir: &Path) {
    // Selector 0: .off, 1: .obj, 2: .ply.
    let tet = "0 0 0\n1 0 0\n0 1 0\n0 0 1\n";
    write_selected(
        dir,
        "tet.off",
        0,
        format!("OFF\n# tetrahedron\n4 4 6\n{tet}3 0 2 1\n3 0 1 3\n3 0 3 2\n3 1 2 3\n").as_bytes(),
    );
    write_selected(
        dir,
        "quad.off",
        0,
        b"COFF 4 1 0\n0 0 0 255 0 0 255\n1 0 0 0 255 0 255\n1 1 0 0 0 255 255\n0 1 0 9 9 9 255\n4 0 1 2 3 1 2 3\n",
    );
    write_selected(
        dir,
        "tet.obj",
        1,
        b"# tet\nmtllib a.mtl\no tet\nv 0 0 0\nv 1 0 0\nv 0 1 0 1\nv 0 0 1\nvt 0 0\nvn 0 0 1\n\
          f 1 3 2\nf 1/1 2/1 4/1\nf -4//1 -1//1 -2//1\nf 2/1/1 3/1/1 \\\n 4/1/1\nl 1 2\n",
    );
    write_selected(
        dir,
        "tet-ascii.ply",
        2,
        format!(
            "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\n\
             property float z\nelement face 4\nproperty list uchar int vertex_indices\n\
             end_header\n{tet}3 0 2 1\n3 0 1 3\n3 0 3 2\n3 1 2 3\n"
        )
        .as_bytes(),
    );
    let mut bin = b"ply\nformat binary_little_endian 1.0\nelement vertex 4\nproperty double x\n\
        property double y\nproperty double z\nelement tristrips 1\n\
        property list int int vertex_indices\nend_header\n"
        .to_vec();
    for v in [
        [0.0f64, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        [0.0, 0.0, 1.0],
    ] {
        for c in v {
            bin.extend_from_slice(&c.to_le_bytes());
        }
    }
    bin.extend_from_slice(&6i32.to_le_bytes());
    for i in [0i32, 1, 2, 3, -1, 0] {
        bin.extend_from_slice(&i.to_le_bytes());
    }
    write_selected(dir, "strips-bin.ply", 2, &bin);
}

fn config_seeds(root: &Path, dir: &Path) {
    let reference = std::fs::read(root.join("pipeline.toml")).expect("cannot read pipeline.toml");
    write(&dir.join("pipeline.toml"), &reference);
    write(
        &dir.join("short.toml"),
        b"seed = 7\nthreads = 2\n[input]\npath = \"scan.laz\"\nnon_finite = \"drop\"\n\
          [output]\nformat = \"laz\"\nclassify_edges = true\nedge_class = 20\n\
          [features]\nradius = 0.5\nnoise = \"auto\"\n[fit.pso]\nw = 0.5\n\
          [fit]\nrectify_with = \"exact\"\n",
    );
    write(
        &dir.join("inline.toml"),
        b"input = { path = \"a.ply\", sensors = [[0.0, 0.0, 5.0], [1, 2, 3]] }\n\
          output.dir = \"res\"\nfit.pso.iterations_2d = 30\nedges.band = 2.5\n",
    );
}

/// E57 seeds written with the e57 crate (each a few pages): double cartesian with intensity
/// and colour; spherical with invalid records and row/column indices; two scans of scaled
/// integers with poses.
fn e57_seeds(dir: &Path) {
    use e57::{E57Writer, Record, RecordDataType, RecordName, RecordValue};
    let xyz = |i: usize| {
        let t = i as f64 * 0.37;
        [t.cos() * 2.0, t.sin() * 2.0, i as f64 * 0.05]
    };
    let ok = |r: e57::Result<()>| r.expect("e57 writer");

    let mut w = E57Writer::from_file(dir.join("cartesian_rgb.e57"), "seed-1").expect("e57");
    let mut pc = w
        .add_pointcloud(
            "seed-1-scan",
            vec![
                Record::CARTESIAN_X_F64,
                Record::CARTESIAN_Y_F64,
                Record::CARTESIAN_Z_F64,
                Record::INTENSITY_U16,
                Record::COLOR_RED_U8,
                Record::COLOR_GREEN_U8,
                Record::COLOR_BLUE_U8,
            ],
        )
        .expect("e57");
    for i in 0..30 {
        let p = xyz(i);
        let c = |k: usize| RecordValue::Integer(((i * 40 + k * 80) % 256) as i64);
        ok(pc.add_point(vec![
            RecordValue::Double(p[0]),
            RecordValue::Double(p[1]),
            RecordValue::Double(p[2]),
            RecordValue::Integer(i as i64 * 1000),
            c(0),
            c(1),
            c(2),
        ]));
    }
    ok(pc.finalize());
    ok(w.finalize());

    let mut w = E57Writer::from_file(dir.join("spherical_grid.e57"), "seed-2").expect("e57");
    let index = |name| Record {
        name,
        data_type: RecordDataType::Integer { min: 0, max: 7 },
    };
    let mut pc = w
        .add_pointcloud(
            "seed-2-scan",
            vec![
                Record::SPHERICAL_RANGE_F32,
                Record::SPHERICAL_AZIMUTH_F32,
                Record::SPHERICAL_ELEVATION_F32,
                Record::SPHERICAL_INVALID_STATE,
                index(RecordName::RowIndex),
                index(RecordName::ColumnIndex),
            ],
        )
        .expect("e57");
    for i in 0..32 {
        ok(pc.add_point(vec![
            RecordValue::Single(1.0 + i as f32 * 0.1),
            RecordValue::Single(i as f32 * 0.2),
            RecordValue::Single(0.5 - i as f32 * 0.03),
            RecordValue::Integer(if i % 5 == 0 { 2 } else { 0 }),
            RecordValue::Integer((i / 8) as i64),
            RecordValue::Integer((i % 8) as i64),
        ]));
    }
    ok(pc.finalize());
    ok(w.finalize());

    let mut w = E57Writer::from_file(dir.join("two_scans_scaled.e57"), "seed-3").expect("e57");
    let coord = |name| Record {
        name,
        data_type: RecordDataType::ScaledInteger {
            min: -100_000,
            max: 100_000,
            scale: 0.001,
            offset: 0.0,
        },
    };
    for s in 0..2 {
        let mut pc = w
            .add_pointcloud(
                &format!("seed-3-scan-{s}"),
                vec![
                    coord(RecordName::CartesianX),
                    coord(RecordName::CartesianY),
                    coord(RecordName::CartesianZ),
                ],
            )
            .expect("e57");
        let mut t = e57::Transform::default();
        t.rotation.w = 0.8;
        t.rotation.z = 0.6 * (s as f64 * 2.0 - 1.0);
        t.translation.x = 10.0 * s as f64;
        pc.set_transform(Some(t));
        pc.set_name(Some(format!("scan {s}")));
        for i in 0..25 {
            let p = xyz(i + s * 25);
            ok(pc.add_point(
                p.iter()
                    .map(|v| RecordValue::ScaledInteger((v * 1000.0).round() as i64))
                    .collect(),
            ));
        }
        ok(pc.finalize());
    }
    ok(w.finalize());
}
