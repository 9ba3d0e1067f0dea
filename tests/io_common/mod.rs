//! Helpers shared by the bad-input tests of the readers (io_bad_input.rs, io_hostile.rs).

use std::path::{Path, PathBuf};

use sharpedge::io::{self, ReadOptions};
use sharpedge::{Cloud, Error};

pub fn read(path: &Path) -> Result<Cloud, Error> {
    io::read(path, &ReadOptions::default())
}

/// The message of an error that must occur, checked to start with the file's path.
pub fn message<T: std::fmt::Debug>(r: Result<T, Error>, path: &Path) -> String {
    let e = r.expect_err("bad input must be an error").to_string();
    assert!(
        e.starts_with(&format!("{}: ", path.display())),
        "the message must start with the file: {e}"
    );
    e
}

pub fn assert_contains(e: &str, parts: &[&str]) {
    for p in parts {
        assert!(e.contains(p), "message `{e}` should contain `{p}`");
    }
}

pub fn write(dir: &Path, name: &str, content: &[u8]) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, content).unwrap();
    p
}
