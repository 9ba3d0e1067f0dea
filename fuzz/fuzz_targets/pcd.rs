//! PCD point clouds through `sharpedge::io::read` (header, the chunked binary reader, LZF
//! and the ascii decoder) and through `read_for_output` for a PCD output (the whole-file
//! path that keeps the records), whose result is written back with `write_pcd`. Passes when
//! every call returns, Ok or Err.
#![no_main]

mod common;

use libfuzzer_sys::fuzz_target;
use sharpedge::io::{CloudFormat, NonFinite, Original, ReadOptions, read, read_for_output, write_pcd};

fuzz_target!(|data: &[u8]| {
    let path = common::write_input("input.pcd", data);
    let _ = read(&path, &ReadOptions::default());
    let drop = ReadOptions {
        non_finite: NonFinite::Drop,
    };
    if let Ok((cloud, Some(Original::Pcd(pcd)))) = read_for_output(&path, &drop, CloudFormat::Pcd) {
        let moved = vec![true; cloud.len()];
        let out = common::write_input("output.pcd", b"");
        let _ = write_pcd(&out, &pcd, &cloud.positions, &moved);
    }
});
