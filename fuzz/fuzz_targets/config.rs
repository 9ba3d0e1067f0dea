//! pipeline.toml through `sharpedge::config::load` (read, TOML parse into the raw structs,
//! validate into settings). Passes when the call returns, Ok or Err.
#![no_main]

mod common;

use libfuzzer_sys::fuzz_target;
use sharpedge::config::load;

fuzz_target!(|data: &[u8]| {
    let path = common::write_input("pipeline.toml", data);
    let _ = load(&path);
});
