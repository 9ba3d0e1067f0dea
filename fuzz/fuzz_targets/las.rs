//! LAS and LAZ (the same reader: the las crate tells them apart by the header) through
//! `sharpedge::io::read` (attribute columns) and `read_for_output` with a LAS output (raw
//! records kept, every EVLR read, non-finite points dropped). Passes when the calls return.
#![no_main]

mod common;

use libfuzzer_sys::fuzz_target;
use sharpedge::io::{CloudFormat, NonFinite, ReadOptions, read, read_for_output};

fuzz_target!(
    init: {
        // libfuzzer-sys's panic hook aborts at once, even on a panic that the library catches:
        // sharpedge turns a panic inside laz (which indexes its tables with decoded symbols,
        // src/io/las.rs) into an error. Back to the default hook; a panic that escapes the
        // call still aborts (libfuzzer-sys catches it around each input) and is reported.
        drop(std::panic::take_hook());
    },
    |data: &[u8]| {
    let path = common::write_input("input.las", data);
    if read(&path, &ReadOptions::default()).is_err() {
        // The same header and chunk checks run first on both paths; skip the second read.
        return;
    }
    let _ = read_for_output(
        &path,
        &ReadOptions {
            non_finite: NonFinite::Drop,
        },
        CloudFormat::Las,
    );
    }
);
