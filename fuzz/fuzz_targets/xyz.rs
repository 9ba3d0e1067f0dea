//! XYZ text through `sharpedge::io::read`. The first byte picks the extension: odd `.pts`
//! (Leica point-count lines), even `.xyz`. Passes when the call returns, Ok or Err.
#![no_main]

mod common;

use libfuzzer_sys::fuzz_target;
use sharpedge::io::{ReadOptions, read};

fuzz_target!(|data: &[u8]| {
    let Some((&sel, body)) = data.split_first() else {
        return;
    };
    let name = if sel & 1 == 1 {
        "input.pts"
    } else {
        "input.xyz"
    };
    let path = common::write_input(name, body);
    let _ = read(&path, &ReadOptions::default());
});
