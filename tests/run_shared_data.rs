//! `sharpedge info` and `sharpedge run` through the real binary on every file of
//! ../shared/data (see SOURCES.md there): each either succeeds with the point count SOURCES.md
//! gives, or fails with exit code 1 and one error naming the file and the problem (a 3-point
//! file, a file with no vertex element, a mesh), leaving no output folder behind. The LAS and
//! LAZ copies of autzen give identical outputs (LAS in, LAS out; LAZ in, LAZ out). A file added to those folders without an
//! entry here fails the test. Skipped (with a message) when ../shared/data is absent.

mod run_common;

use std::path::{Path, PathBuf};

use run_common::*;

/// What each file must give: `Ok(points)` or `Err(part of the message)`.
const EXPECTED: &[(&str, Result<usize, &str>)] = &[
    ("cad/anchor_dense.off", Err(MESH)),
    ("cad/box.obj", Err(MESH)),
    ("cad/cube.pwn", Ok(50000)),
    ("cad/fandisk.off", Err(MESH)),
    ("cad/fin90_with_PCA_normals.xyz", Ok(757)),
    ("cad/joint.off", Err(MESH)),
    ("cad/pinion.off", Err(MESH)),
    ("lidar/autzen_trim.las", Ok(110000)),
    ("lidar/autzen_trim.laz", Ok(110000)),
    ("lidar/lone-star.copc.laz", Ok(518862)),
    ("lidar/sample_c.las", Ok(14408)),
    ("lidar/test1_4.las", Ok(1000)),
    ("lidar/urban.las", Ok(13511)),
    (
        "plyfmt/all_atomic_types_ok_ascii.ply",
        Err("header: no `vertex` element; elements are: point"),
    ),
    (
        "plyfmt/colored_tetra.ply",
        Err("the cloud has only 4 point(s)"),
    ),
    ("plyfmt/elephant_tristrips.ply", Ok(19753)),
    (
        "plyfmt/greg_turk_example2_ok_ascii.ply",
        Err("the cloud has only 8 point(s)"),
    ),
    ("plyfmt/icosahedron.ply", Ok(12)),
    ("plyfmt/platonic_shelf.ply", Ok(50)),
    ("plyfmt/platonic_shelf_ascii.ply", Ok(50)),
    ("plyfmt/platonic_shelf_big_endian.ply", Ok(50)),
    (
        "plyfmt/simple_binary.ply",
        Err("the cloud has only 3 point(s)"),
    ),
    (
        "plyfmt/simple_text.ply",
        Err("the cloud has only 3 point(s)"),
    ),
    ("plyfmt/sofa.ply", Ok(12103)),
    (
        "plyfmt/text_extradim.ply",
        Err("the cloud has only 1 point(s)"),
    ),
    ("scan/b9_training.ply", Ok(22300)),
    ("scan/bun000.ply", Ok(40256)),
    ("scan/bun_zipper.ply", Ok(35947)),
];

const MESH: &str = "a triangle mesh is sampled into a scan with `sharpedge synth --mesh FILE";

/// Files whose point count `info` gives although `run` refuses them (too few points).
fn info_points(name: &str) -> Option<usize> {
    match EXPECTED.iter().find(|(n, _)| *n == name)?.1 {
        Ok(n) => Some(n),
        Err(e) => e
            .strip_prefix("the cloud has only ")
            .and_then(|r| r.strip_suffix(" point(s)"))
            .map(|n| n.parse().unwrap()),
    }
}

fn data_dir() -> Option<PathBuf> {
    let d = Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/data");
    if d.is_dir() {
        Some(d)
    } else {
        println!("skipped: ../shared/data absent");
        None
    }
}

#[test]
fn the_table_names_every_file() {
    let Some(d) = data_dir() else { return };
    let mut found = Vec::new();
    for sub in ["cad", "lidar", "plyfmt", "scan"] {
        for e in std::fs::read_dir(d.join(sub)).unwrap() {
            found.push(format!(
                "{sub}/{}",
                e.unwrap().file_name().to_string_lossy()
            ));
        }
    }
    found.sort();
    let listed: Vec<String> = EXPECTED.iter().map(|(n, _)| n.to_string()).collect();
    assert_eq!(found, listed);
}

#[test]
fn info_on_every_file() {
    let Some(d) = data_dir() else { return };
    let tmp = tempfile::tempdir().unwrap();
    for (name, expected) in EXPECTED {
        let path = d.join(name);
        let r = sharpedge(
            tmp.path(),
            &["info".as_ref(), path.as_os_str(), "--json".as_ref()],
        );
        match info_points(name) {
            Some(n) => {
                assert!(r.ok(), "{name}: {r:#?}");
                let v: serde_json::Value = serde_json::from_str(&r.stdout).unwrap();
                assert_eq!(v["points"], n, "{name}");
            }
            None => {
                let Err(part) = expected else { unreachable!() };
                assert_eq!(r.code, Some(1), "{name}: {r:#?}");
                assert!(
                    r.stderr
                        .starts_with(&format!("error: {}: ", path.display())),
                    "{name}: {}",
                    r.stderr
                );
                assert!(r.stderr.contains(part), "{name}: {}", r.stderr);
            }
        }
    }
}

#[test]
fn run_on_every_file_succeeds_or_fails_cleanly() {
    let Some(d) = data_dir() else { return };
    let tmp = tempfile::tempdir().unwrap();
    let w = tmp.path();
    std::fs::copy(
        Path::new(env!("CARGO_MANIFEST_DIR")).join("pipeline.toml"),
        w.join("pipeline.toml"),
    )
    .unwrap();
    for (name, expected) in EXPECTED {
        let path = d.join(name);
        let out = w.join("r").join(name.replace('/', "_"));
        let r = sharpedge(
            w,
            &[
                "-q".as_ref(),
                "run".as_ref(),
                "pipeline.toml".as_ref(),
                "--input".as_ref(),
                path.as_os_str(),
                "--out".as_ref(),
                out.as_os_str(),
            ],
        );
        match expected {
            Ok(n) => {
                assert!(r.ok(), "{name}: {r:#?}");
                // LAS and LAZ (COPC too) come back in their own format, the rest as PLY.
                let ext = ["las", "laz"]
                    .into_iter()
                    .find(|e| name.ends_with(&format!(".{e}")))
                    .unwrap_or("ply");
                let rectified = format!("rectified.{ext}");
                assert_eq!(
                    entries(&out),
                    [
                        ".sharpedge-current",
                        ".sharpedge-run-*",
                        "edges.geojson",
                        "features.ply",
                        rectified.as_str(),
                        "report.json"
                    ],
                    "{name}"
                );
                assert_eq!(report(&out)["counts"]["points"], *n, "{name}");
                let count = if ext == "ply" {
                    let bytes = std::fs::read(out.join(&rectified)).unwrap();
                    parse_header(&bytes).element("vertex").count
                } else {
                    las::Reader::from_path(out.join(&rectified))
                        .unwrap()
                        .header()
                        .number_of_points() as usize
                };
                assert_eq!(count, *n, "{name}");
            }
            Err(part) => {
                assert_failed_cleanly(&r, &[&format!("{}: ", path.display()), part], &out);
                assert!(!out.exists(), "{name}: the output folder was left behind");
            }
        }
    }
    // The LAS and LAZ copies of autzen hold the same points: the same outputs, the rectified
    // clouds with the same records once decompressed.
    for f in ["features.ply", "edges.geojson"] {
        let las = std::fs::read(w.join("r/lidar_autzen_trim.las").join(f)).unwrap();
        let laz = std::fs::read(w.join("r/lidar_autzen_trim.laz").join(f)).unwrap();
        assert!(las == laz, "{f} differs between the LAS and the LAZ input");
    }
    let records = |p: PathBuf| {
        let mut r = las::Reader::from_path(p).unwrap();
        r.read_all().unwrap().raw_bytes().to_vec()
    };
    assert!(
        records(w.join("r/lidar_autzen_trim.las/rectified.las"))
            == records(w.join("r/lidar_autzen_trim.laz/rectified.laz")),
        "the rectified LAS and LAZ hold different records"
    );
    // The failed runs made no folder; `r` holds the successful ones only.
    let ok = EXPECTED.iter().filter(|(_, e)| e.is_ok()).count();
    assert_eq!(entries(&w.join("r")).len(), ok);
}

#[test]
fn a_failed_run_leaves_an_existing_output_folder_alone() {
    // The run removes only folders it made itself.
    let c = Case::new();
    c.write(
        "three.ply",
        &ascii_ply(&[[0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]),
    );
    std::fs::create_dir(c.out()).unwrap();
    let r = c.run("three.ply", &[]);
    assert_failed_cleanly(&r, &["three.ply: the cloud has only 3 point(s)"], &c.out());
    assert!(c.out().is_dir(), "the user's folder is kept");
    // A nested --out whose parents did not exist goes with them.
    let r = sharpedge(
        c.path(),
        &[
            "run",
            "pipeline.toml",
            "--input",
            "three.ply",
            "--out",
            "new/deep/out",
        ],
    );
    assert_failed_cleanly(&r, &["three.ply"], &c.path().join("new/deep/out"));
    assert!(!c.path().join("new").exists(), "made folders removed");
}
