//! Files for inspection in MeshLab and CloudCompare, as the pipeline will write them: a
//! rectified-like cloud (`scalar_*` fields for CloudCompare, `quality` and uchar
//! `red/green/blue` for MeshLab) in binary float, binary double with a georeferenced offset,
//! and ascii; and a features-like file with an `element edge`. The test checks that each reads
//! back with its fields. With `SHARPEDGE_VIEWER_SAMPLES=DIR` it also leaves the files in DIR
//! for `scripts/check_viewers.sh DIR/*.ply`, which opens them with the real programs.

use std::path::{Path, PathBuf};

use sharpedge::io::{self, PlyEncoding, PlyWriteOptions, Precision, ReadOptions};
use sharpedge::{Attribute, Column};

fn attr(name: &str, values: Column) -> Attribute {
    Attribute {
        name: name.into(),
        values,
    }
}

/// Two faces of a block meeting at a sharp edge along y, sampled on a grid: points near the
/// edge get edge id 0, a high sharpness and red; the rest edge id -1 and grey.
fn rectified_like(offset: [f64; 3]) -> (Vec<[f64; 3]>, Vec<Attribute>) {
    let mut pos = Vec::new();
    let (mut id, mut sharp, mut moved, mut disp, mut quality) =
        (Vec::new(), Vec::new(), Vec::new(), Vec::new(), Vec::new());
    let (mut r, mut g, mut b) = (Vec::new(), Vec::new(), Vec::new());
    for face in 0..2 {
        for i in 0..40 {
            for j in 0..50 {
                let u = f64::from(i) * 0.25; // distance from the edge, mm
                let y = f64::from(j) * 0.25;
                let p = if face == 0 { [u, y, 0.0] } else { [0.0, y, u] };
                let s = (-u / 1.5).exp() as f32;
                pos.push([p[0] + offset[0], p[1] + offset[1], p[2] + offset[2]]);
                let near = u < 1.0;
                id.push(if near { 0 } else { -1 });
                sharp.push(s);
                moved.push(u8::from(near && i > 0));
                disp.push(if near { 0.05 * (1.0 - u) as f32 } else { 0.0 });
                quality.push(s);
                let c = (255.0 * s) as u8;
                r.push(if near { 255 } else { 128 + c / 2 });
                g.push(if near { 0 } else { 128 });
                b.push(if near { 0 } else { 128 });
            }
        }
    }
    let attrs = vec![
        attr("scalar_edge_id", Column::I32(id)),
        attr("scalar_sharpness", Column::F32(sharp)),
        attr("scalar_moved", Column::U8(moved)),
        attr("scalar_displacement", Column::F32(disp)),
        attr("quality", Column::F32(quality)),
        attr("red", Column::U8(r)),
        attr("green", Column::U8(g)),
        attr("blue", Column::U8(b)),
    ];
    (pos, attrs)
}

/// A box's 8 corners and 12 edges, like features.ply: corners red, kind 1 = corner.
fn features_like() -> (Vec<[f64; 3]>, Vec<Attribute>, Vec<[u32; 2]>) {
    let mut pos = Vec::new();
    for k in 0..8u32 {
        pos.push([
            f64::from(k & 1) * 10.0,
            f64::from((k >> 1) & 1) * 6.0,
            f64::from((k >> 2) & 1) * 4.0,
        ]);
    }
    let mut edges = Vec::new();
    for a in 0..8u32 {
        for bit in [1, 2, 4] {
            let b = a | bit;
            if b != a {
                edges.push([a, b]);
            }
        }
    }
    let attrs = vec![
        attr("scalar_kind", Column::U8(vec![1; 8])),
        attr(
            "scalar_error",
            Column::F32((0..8).map(|i| i as f32 * 0.01).collect()),
        ),
        attr("red", Column::U8(vec![255; 8])),
        attr("green", Column::U8(vec![0; 8])),
        attr("blue", Column::U8(vec![0; 8])),
    ];
    (pos, attrs, edges)
}

fn write_samples(dir: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    let cases = [
        (
            "rectified_float.ply",
            [0.0; 3],
            PlyEncoding::BinaryLittleEndian,
            Precision::F32,
        ),
        (
            "rectified_georef_double.ply",
            [512345.123, 4101234.567, 80.0],
            PlyEncoding::BinaryLittleEndian,
            Precision::F64,
        ),
        (
            "rectified_ascii.ply",
            [0.0; 3],
            PlyEncoding::Ascii,
            Precision::F32,
        ),
    ];
    for (name, offset, encoding, precision) in cases {
        let (pos, attrs) = rectified_like(offset);
        let refs: Vec<&Attribute> = attrs.iter().collect();
        let p = dir.join(name);
        io::write_ply(
            &p,
            &pos,
            &refs,
            &[],
            &PlyWriteOptions {
                encoding,
                precision,
            },
        )
        .unwrap();
        out.push(p);
    }
    let (pos, attrs, edges) = features_like();
    let refs: Vec<&Attribute> = attrs.iter().collect();
    let p = dir.join("features_edges.ply");
    io::write_ply(&p, &pos, &refs, &edges, &PlyWriteOptions::default()).unwrap();
    out.push(p);
    out
}

#[test]
fn viewer_sample_files_read_back_with_their_fields() {
    let tmp = tempfile::tempdir().unwrap();
    let keep = std::env::var_os("SHARPEDGE_VIEWER_SAMPLES").map(PathBuf::from);
    let dir = match &keep {
        Some(d) => {
            std::fs::create_dir_all(d).unwrap();
            d.clone()
        }
        None => tmp.path().to_path_buf(),
    };
    for p in write_samples(&dir) {
        let c = io::read(&p, &ReadOptions::default()).unwrap();
        let names: Vec<&str> = c.attributes.iter().map(|a| a.name.as_str()).collect();
        if p.ends_with("features_edges.ply") {
            assert_eq!(c.len(), 8);
            assert_eq!(
                names,
                ["scalar_kind", "scalar_error", "red", "green", "blue"]
            );
            let info = io::describe(&p).unwrap();
            assert_eq!(info.other_elements[0].count, 12);
        } else {
            assert_eq!(c.len(), 4000);
            assert_eq!(
                names,
                [
                    "scalar_edge_id",
                    "scalar_sharpness",
                    "scalar_moved",
                    "scalar_displacement",
                    "quality",
                    "red",
                    "green",
                    "blue"
                ]
            );
            for colour in ["red", "green", "blue"] {
                assert!(matches!(c.attribute(colour).unwrap().values, Column::U8(_)));
            }
        }
        if keep.is_some() {
            println!("wrote {}", p.display());
        }
    }
}
