//! The real files of ../shared/data (see SOURCES.md there): every file of plyfmt/, scan/ and
//! lidar/ read with the point counts SOURCES.md gives, content checks against the numbers it
//! states (class counts, label counts, extents), LAS vs LAZ equality, our LAS columns against
//! the las crate's own per-point decoding, and the binary PLY fast path against ply-rs-bw.
//! Every test prints "skipped: ../shared/data absent" and returns when the folder is missing.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use sharpedge::io::{self, ReadOptions};
use sharpedge::{Cloud, Column};

fn data_dir() -> Option<PathBuf> {
    let d = Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/data");
    if d.is_dir() {
        Some(d)
    } else {
        println!("skipped: ../shared/data absent");
        None
    }
}

fn read(p: &Path) -> Cloud {
    io::read(p, &ReadOptions::default()).unwrap_or_else(|e| panic!("{e}"))
}

/// Point counts from SOURCES.md.
const COUNTS: &[(&str, usize)] = &[
    ("plyfmt/platonic_shelf.ply", 50),
    ("plyfmt/platonic_shelf_big_endian.ply", 50),
    ("plyfmt/platonic_shelf_ascii.ply", 50),
    ("plyfmt/colored_tetra.ply", 4),
    ("plyfmt/sofa.ply", 12103),
    ("plyfmt/elephant_tristrips.ply", 19753),
    ("plyfmt/icosahedron.ply", 12),
    ("plyfmt/greg_turk_example2_ok_ascii.ply", 8),
    ("plyfmt/simple_text.ply", 3),
    ("plyfmt/simple_binary.ply", 3),
    ("plyfmt/text_extradim.ply", 1),
    ("scan/bun000.ply", 40256),
    ("scan/bun_zipper.ply", 35947),
    ("scan/b9_training.ply", 22300),
    ("lidar/autzen_trim.laz", 110000),
    ("lidar/autzen_trim.las", 110000),
    ("lidar/sample_c.las", 14408),
    ("lidar/lone-star.copc.laz", 518862),
    ("lidar/test1_4.las", 1000),
    ("lidar/urban.las", 13511),
    ("cad/fin90_with_PCA_normals.xyz", 757),
    ("cad/cube.pwn", 50000),
];

#[test]
fn every_file_reads_with_the_documented_point_count() {
    let Some(d) = data_dir() else { return };
    for (name, n) in COUNTS {
        let c = read(&d.join(name));
        assert_eq!(c.len(), *n, "{name}");
        assert!(c.is_consistent(), "{name}");
        assert!(
            c.positions.iter().flatten().all(|v| v.is_finite()),
            "{name}"
        );
        let info = io::describe(&d.join(name)).unwrap();
        assert_eq!(info.points, *n, "{name}");
    }
    // No file of these folders is left out of the table.
    for sub in ["plyfmt", "scan", "lidar"] {
        for entry in std::fs::read_dir(d.join(sub)).unwrap() {
            let name = format!("{sub}/{}", entry.unwrap().file_name().to_string_lossy());
            if name == "plyfmt/all_atomic_types_ok_ascii.ply" {
                continue;
            }
            assert!(
                COUNTS.iter().any(|(n, _)| *n == name),
                "{name} has no expected count"
            );
        }
    }
}

#[test]
fn a_file_without_vertex_element_is_a_clear_error() {
    let Some(d) = data_dir() else { return };
    let p = d.join("plyfmt/all_atomic_types_ok_ascii.ply");
    let e = io::read(&p, &ReadOptions::default())
        .unwrap_err()
        .to_string();
    assert_eq!(
        e,
        format!(
            "{}: header: no `vertex` element; elements are: point",
            p.display()
        )
    );
}

fn counts(c: &Cloud, name: &str) -> BTreeMap<i64, usize> {
    let col = &c
        .attribute(name)
        .unwrap_or_else(|| panic!("no {name}"))
        .values;
    let mut m = BTreeMap::new();
    for i in 0..col.len() {
        *m.entry(col.get_f64(i) as i64).or_insert(0) += 1;
    }
    m
}

#[test]
fn lidar_content_matches_sources() {
    let Some(d) = data_dir() else { return };
    let autzen = read(&d.join("lidar/autzen_trim.las"));
    assert_eq!(
        counts(&autzen, "classification"),
        BTreeMap::from([(1, 83893), (2, 26107)])
    );
    let (lo, hi) = autzen.bbox().unwrap();
    let size = [hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]];
    for (s, want) in size.iter().zip([1178.0, 563.0, 114.0]) {
        assert!((s - want).abs() < 1.0, "autzen extent {size:?}");
    }
    assert_eq!(autzen.source.format, "LAS 1.2, point format 3");
    let sample_c = read(&d.join("lidar/sample_c.las"));
    assert_eq!(counts(&sample_c, "classification")[&6], 12525);
    let urban = read(&d.join("lidar/urban.las"));
    assert_eq!(
        counts(&urban, "classification"),
        BTreeMap::from([(1, 29), (2, 2441), (4, 11041)])
    );
    assert!(
        urban
            .positions
            .iter()
            .all(|p| (548800.0..549000.0).contains(&p[0]))
    );
    // Its RGB fields are all 0, and carried as such.
    assert_eq!(counts(&urban, "red"), BTreeMap::from([(0, 13511)]));
    let t14 = read(&d.join("lidar/test1_4.las"));
    assert_eq!(counts(&t14, "classification"), BTreeMap::from([(2, 1000)]));
    assert_eq!(t14.source.format, "LAS 1.4, point format 6");
    let copc = read(&d.join("lidar/lone-star.copc.laz"));
    assert_eq!(
        counts(&copc, "classification"),
        BTreeMap::from([(0, 518862)])
    );
    assert_eq!(copc.source.format, "COPC LAZ 1.4, point format 6");
    assert!(copc.attribute("red").is_none());
    let (lo, hi) = copc.bbox().unwrap();
    for (k, want) in [32.0, 41.0, 16.0].iter().enumerate() {
        assert!((hi[k] - lo[k] - want).abs() < 1.0, "lone-star extent");
    }
}

#[test]
fn autzen_las_and_laz_give_identical_points() {
    let Some(d) = data_dir() else { return };
    let las = read(&d.join("lidar/autzen_trim.las"));
    let laz = read(&d.join("lidar/autzen_trim.laz"));
    assert_eq!(las.positions, laz.positions);
    assert_eq!(las.attributes, laz.attributes);
    assert_eq!(laz.source.format, "LAZ 1.2, point format 3");
}

#[test]
fn las_columns_match_the_las_crate_point_decoding() {
    let Some(d) = data_dir() else { return };
    for name in ["lidar/autzen_trim.las", "lidar/test1_4.las"] {
        let p = d.join(name);
        let ours = read(&p);
        let mut reader = las::Reader::from_path(&p).unwrap();
        let all = reader.read_all().unwrap();
        let col = |n: &str| &ours.attribute(n).unwrap().values;
        for (i, pt) in all.points().enumerate() {
            let pt = pt.unwrap();
            assert_eq!(ours.positions[i], [pt.x, pt.y, pt.z], "{name} point {i}");
            assert_eq!(col("intensity").get_f64(i), f64::from(pt.intensity));
            assert_eq!(col("return_number").get_f64(i), f64::from(pt.return_number));
            assert_eq!(
                col("classification").get_f64(i),
                f64::from(u8::from(pt.classification))
            );
            assert_eq!(
                col("point_source_id").get_f64(i),
                f64::from(pt.point_source_id)
            );
            assert_eq!(Some(col("gps_time").get_f64(i)), pt.gps_time);
            if let Some(c) = pt.color {
                assert_eq!(col("red").get_f64(i), f64::from(c.red));
                assert_eq!(col("blue").get_f64(i), f64::from(c.blue));
            }
        }
    }
}

#[test]
fn ply_content_matches_sources() {
    let Some(d) = data_dir() else { return };
    let b9 = read(&d.join("scan/b9_training.ply"));
    assert_eq!(
        counts(&b9, "label"),
        BTreeMap::from([(-1, 19853), (0, 1567), (1, 314), (2, 566)])
    );
    assert!(b9.source.double_precision);
    assert!(
        b9.positions
            .iter()
            .all(|p| (596640.0..596750.0).contains(&p[0])
                && (243610.0..243740.0).contains(&p[1])
                && (73.0..98.0).contains(&p[2]))
    );
    let bunny = read(&d.join("scan/bun_zipper.ply"));
    let names: Vec<&str> = bunny.attributes.iter().map(|a| a.name.as_str()).collect();
    assert_eq!(names, ["confidence", "intensity"]);
    assert!(matches!(bunny.attributes[0].values, Column::F32(_)));
    let extra = read(&d.join("plyfmt/text_extradim.ply"));
    assert!(matches!(
        extra.attribute("blue").unwrap().values,
        Column::I8(_)
    ));
    assert!(matches!(
        extra.attribute("omg").unwrap().values,
        Column::I32(_)
    ));
    let tetra = read(&d.join("plyfmt/colored_tetra.ply"));
    assert_eq!(tetra.attribute("id").unwrap().values.len(), 4);
    let cube = read(&d.join("plyfmt/greg_turk_example2_ok_ascii.ply"));
    let (lo, hi) = cube.bbox().unwrap();
    assert_eq!((lo, hi), ([0.0; 3], [1.0; 3]));
    let simple = read(&d.join("plyfmt/simple_text.ply"));
    assert_eq!(simple.positions.len(), 3);
    // The same geometry stored three ways (face element first or last, three encodings).
    let le = read(&d.join("plyfmt/platonic_shelf.ply"));
    let be = read(&d.join("plyfmt/platonic_shelf_big_endian.ply"));
    let ascii = read(&d.join("plyfmt/platonic_shelf_ascii.ply"));
    assert_eq!(le.positions, be.positions);
    for (a, b) in le.positions.iter().zip(&ascii.positions) {
        for k in 0..3 {
            assert!(
                (a[k] - b[k]).abs() <= 1e-12 * a[k].abs().max(1.0),
                "{a:?} {b:?}"
            );
        }
    }
}

#[test]
fn fast_paths_match_the_crate_on_every_ply() {
    let Some(d) = data_dir() else { return };
    for (name, _) in COUNTS.iter().filter(|(n, _)| n.ends_with(".ply")) {
        let p = d.join(name);
        let fast = read(&p);
        let via_crate = io::read_ply_via_crate(&p).unwrap();
        assert_eq!(fast, via_crate, "{name}");
    }
}
