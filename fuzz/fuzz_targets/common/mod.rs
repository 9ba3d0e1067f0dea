//! Shared by the fuzz targets. The library reads files by path (the extension names the
//! format), so each input is written to a file in this process's temporary folder and read
//! back through the public entry point: the path a user's file takes, not a test-only one.
//! `scripts/fuzz.sh` points TMPDIR at a folder it removes afterwards.

use std::path::PathBuf;
use std::sync::OnceLock;

static DIR: OnceLock<tempfile::TempDir> = OnceLock::new();

/// Writes `data` to `name` in the process's temporary folder and returns its path.
pub fn write_input(name: &str, data: &[u8]) -> PathBuf {
    let dir = DIR.get_or_init(|| {
        tempfile::Builder::new()
            .prefix("sharpedge-fuzz-")
            .tempdir()
            .expect("cannot create the fuzz input folder")
    });
    let path = dir.path().join(name);
    std::fs::write(&path, data).expect("cannot write the fuzz input");
    path
}
