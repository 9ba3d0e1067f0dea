//! Triangle meshes through `sharpedge::io::mesh::read_mesh`. The first byte picks the
//! format: 0 mod 3 OFF, 1 OBJ, 2 PLY. Passes when the call returns, Ok or Err.
#![no_main]

mod common;

use libfuzzer_sys::fuzz_target;
use sharpedge::io::mesh::read_mesh;

fuzz_target!(|data: &[u8]| {
    let Some((&sel, body)) = data.split_first() else {
        return;
    };
    let name = ["input.off", "input.obj", "input.ply"][usize::from(sel % 3)];
    let path = common::write_input(name, body);
    let _ = read_mesh(&path);
});
