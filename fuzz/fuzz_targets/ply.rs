//! PLY point clouds through `sharpedge::io::read` (header, elements before `vertex`, the
//! binary and ascii vertex decoders). Passes when the call returns, Ok or Err.
#![no_main]

mod common;

use libfuzzer_sys::fuzz_target;
use sharpedge::io::{NonFinite, ReadOptions, read};

fuzz_target!(|data: &[u8]| {
    let path = common::write_input("input.ply", data);
    let _ = read(&path, &ReadOptions::default());
    let _ = read(
        &path,
        &ReadOptions {
            non_finite: NonFinite::Drop,
        },
    );
});
