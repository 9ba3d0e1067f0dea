//! The one error type of the library.
//!
//! Every variant carries what a user needs to fix the problem: the file, the place in it
//! (line, byte offset, element, key) and the bad value. `main` wraps it in `anyhow` and prints
//! the chain once. A failed fit of one edge or corner is *not* an `Error` of the run: the
//! pipeline counts and reports it; the geometry functions return these variants so the caller
//! can decide.
//!
//! Variants are grouped by the part of the library that raises them; add new ones to the group
//! they belong to.

use std::path::PathBuf;

/// Result with the library's error.
pub type Result<T, E = Error> = std::result::Result<T, E>;

#[derive(Debug, thiserror::Error)]
pub enum Error {
    // ---- files and formats (io/) ----
    /// The OS refused an operation on a file (missing, unreadable, unwritable). The OS's reason
    /// is the error's `source()`, not repeated in its own message (`main` prints the chain
    /// with `{:#}`, which would show it twice).
    #[error("{}: {action}", path.display())]
    Io {
        path: PathBuf,
        /// What we were doing, e.g. "cannot open", "cannot create temporary file in".
        action: &'static str,
        #[source]
        source: std::io::Error,
    },
    /// The file's extension names no format sharpedge reads or writes.
    #[error("{}: unknown file type {ext:?}: {allowed}", path.display())]
    UnknownFormat {
        path: PathBuf,
        ext: String,
        /// The extensions that are accepted, for the message.
        allowed: &'static str,
    },
    /// The file is not what its format says: bad header, truncated body, wrong types.
    /// `place` says where: "line 7", "byte 1024", "vertex 12 of 100", "header".
    #[error("{}: {place}: {what}", path.display())]
    Malformed {
        path: PathBuf,
        place: String,
        what: String,
    },
    /// The cloud cannot be processed: empty, one point, all points identical, NaN coordinates.
    #[error("{}: {what}", path.display())]
    BadCloud { path: PathBuf, what: String },
    /// Data handed to a writer cannot be stored as asked: columns of the wrong length, a
    /// property name the format cannot hold, an edge pointing past the last vertex, a NaN
    /// position. A bug of the caller, reported instead of writing a file viewers misread.
    #[error("{}: cannot write: {what}", path.display())]
    BadOutput { path: PathBuf, what: String },

    // ---- configuration (config.rs, cli.rs) ----
    /// A bad key or value in a pipeline file. `line` is 1-based; 0 when unknown.
    #[error("{}:{line}: {key}: {message}", path.display())]
    Config {
        path: PathBuf,
        line: usize,
        key: String,
        message: String,
    },
    /// A bad command-line value that clap could not catch (e.g. a combination of options).
    #[error("{option}: {message}")]
    Usage { option: String, message: String },

    // ---- geometry and fitting (fit/, pipeline stages) ----
    /// Fewer points than a fit needs.
    #[error("{what}: needs at least {needed} points, got {got}")]
    TooFewPoints {
        what: &'static str,
        needed: usize,
        got: usize,
    },
    /// The input has no unique answer: collinear points for a plane, parallel lines for a
    /// corner, all points identical for a line, a NaN in the input.
    #[error("{what}: degenerate input: {why}")]
    Degenerate { what: &'static str, why: String },
    /// A fit whose lines are all (nearly) parallel, so they meet nowhere: for a 2D profile, a
    /// surface that does not turn rather than a failed fit. Printed like `Degenerate`.
    #[error("{what}: degenerate input: {why}")]
    Parallel {
        what: &'static str,
        why: &'static str,
    },
    /// One side of a corner fit has too few points (given, or left after line propagation).
    /// `side` is 1-based, in the caller's order.
    #[error("{fit}: side {side} has {got} usable points, needs at least {needed}: {hint}")]
    SideTooSmall {
        fit: &'static str,
        side: usize,
        needed: usize,
        got: usize,
        /// What the caller can do about it.
        hint: &'static str,
    },
    /// A fitting parameter is out of range (e.g. from the `[fit]` table of pipeline.toml).
    #[error("fit parameter {name} = {value}: expected {expected}")]
    InvalidParameter {
        name: &'static str,
        value: String,
        expected: &'static str,
    },

    // ---- tiles (tiles/) ----
    /// A plan folder or one of its files cannot be used: not a plan, another pipeline file
    /// than the plan's, a tile id out of range, a halo narrower than a tile's scale needs.
    #[error("{}: {what}", path.display())]
    Plan { path: PathBuf, what: String },
    /// `merge` on a plan whose tiles are not all done: the tiles never run (or killed) and
    /// the failed ones with their errors.
    #[error(
        "{}: {} of {total} tiles are not done ({}); run them with `sharpedge run CONFIG --plan \
         DIR --tile I`, or merge what exists with --partial",
        path.display(),
        missing.len() + failed.len(),
        incomplete_list(missing, failed)
    )]
    Incomplete {
        path: PathBuf,
        total: usize,
        missing: Vec<usize>,
        failed: Vec<(usize, String)>,
    },

    // ---- scan simulator (synth/) ----
    /// A simulator parameter outside its allowed range (`name` is the field of `SynthParams`
    /// and the CLI option without `--`, with `_` for `-`).
    #[error("synth parameter {name} = {value}: {allowed}")]
    SynthParam {
        name: &'static str,
        value: String,
        allowed: String,
    },
}

/// The tiles `Error::Incomplete` names: missing ones as a list, failed ones with their error.
fn incomplete_list(missing: &[usize], failed: &[(usize, String)]) -> String {
    let mut parts = Vec::new();
    if !missing.is_empty() {
        let ids: Vec<String> = missing.iter().map(|i| i.to_string()).collect();
        parts.push(format!("missing: tile {}", ids.join(", ")));
    }
    for (i, e) in failed {
        parts.push(format!("tile {i} failed: {e}"));
    }
    parts.join("; ")
}

impl Error {
    /// Shorthand for [`Error::Io`].
    pub fn io(path: impl Into<PathBuf>, action: &'static str, source: std::io::Error) -> Self {
        Error::Io {
            path: path.into(),
            action,
            source,
        }
    }

    /// Shorthand for [`Error::Malformed`].
    pub fn malformed(
        path: impl Into<PathBuf>,
        place: impl Into<String>,
        what: impl Into<String>,
    ) -> Self {
        Error::Malformed {
            path: path.into(),
            place: place.into(),
            what: what.into(),
        }
    }
}
