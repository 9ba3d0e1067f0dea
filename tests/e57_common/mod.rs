//! Helpers shared by the E57 tests: the e57 crate's own view of a file (raw records, the
//! simple reader's points) to check sharpedge against, and the crate's test files in
//! ../shared/data/e57 (None, with a note, when that folder is absent).
#![allow(dead_code)] // each test file uses a different part of this module

use std::path::{Path, PathBuf};

use e57::{CartesianCoordinate, E57Reader, RecordValue};

/// Every scan's metadata and raw records, read with the e57 crate.
pub fn raw(path: &Path) -> Vec<(e57::PointCloud, Vec<Vec<RecordValue>>)> {
    let mut r = E57Reader::from_file(path).unwrap();
    r.pointclouds()
        .into_iter()
        .map(|pc| {
            let v = r.pointcloud_raw(&pc).unwrap().map(|v| v.unwrap()).collect();
            (pc, v)
        })
        .collect()
}

/// The valid points in the common frame as the e57 crate's simple reader gives them.
pub fn crate_points(path: &Path) -> Vec<[f64; 3]> {
    let mut r = E57Reader::from_file(path).unwrap();
    let mut out = Vec::new();
    for pc in r.pointclouds() {
        for p in r.pointcloud_simple(&pc).unwrap() {
            if let CartesianCoordinate::Valid { x, y, z } = p.unwrap().cartesian {
                out.push([x, y, z]);
            }
        }
    }
    out
}

/// A file of ../shared/data/e57; None (the test then passes without checking) when
/// ../shared/data is absent.
pub fn shared(name: &str) -> Option<PathBuf> {
    let d = Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/data");
    if d.is_dir() {
        Some(d.join("e57").join(name))
    } else {
        println!("skipped: ../shared/data absent");
        None
    }
}
