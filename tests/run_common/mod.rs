//! Helpers shared by the `run_*` integration tests: run the real `sharpedge` binary in a
//! temporary folder, make inputs with `sharpedge synth` or by hand, and read the outputs back
//! (PLY headers, the `element edge` of features.ply, report.json).
#![allow(dead_code)] // each test file uses a different part of this module

use std::ffi::OsStr;
use std::io::{Read, Seek, SeekFrom};
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

pub const BIN: &str = env!("CARGO_BIN_EXE_sharpedge");

/// What one run of the binary did.
#[derive(Debug)]
pub struct Run {
    pub code: Option<i32>,
    pub stdout: String,
    pub stderr: String,
}

impl Run {
    pub fn ok(&self) -> bool {
        self.code == Some(0)
    }

    /// Panics with both streams unless the run succeeded.
    pub fn assert_ok(&self) -> &Self {
        assert!(self.ok(), "sharpedge failed: {self:#?}");
        self
    }
}

/// Longest a single run may take; every run here takes a second or two. A run that hangs or
/// thrashes is killed, so a regression cannot hold the shared machine.
const TIMEOUT: Duration = Duration::from_secs(300);

/// Runs `sharpedge ARGS` in `cwd`, with no `RUST_LOG` or `NO_COLOR` from the caller's
/// environment (they would change what is printed); killed after `TIMEOUT`.
pub fn sharpedge<S: AsRef<OsStr>>(cwd: &Path, args: &[S]) -> Run {
    // Files, not pipes: nobody has to drain a pipe while we wait.
    let mut stdout = tempfile::tempfile().unwrap();
    let mut stderr = tempfile::tempfile().unwrap();
    let mut child = Command::new(BIN)
        .args(args)
        .current_dir(cwd)
        .env_remove("RUST_LOG")
        .env_remove("NO_COLOR")
        .stdin(Stdio::null())
        .stdout(stdout.try_clone().unwrap())
        .stderr(stderr.try_clone().unwrap())
        .spawn()
        .expect("the sharpedge binary runs");
    let start = Instant::now();
    let status = loop {
        if let Some(s) = child.try_wait().unwrap() {
            break s;
        }
        if start.elapsed() > TIMEOUT {
            let _ = child.kill();
            let _ = child.wait();
            panic!(
                "sharpedge {:?} took more than {TIMEOUT:?}; killed",
                args_text(args)
            );
        }
        std::thread::sleep(Duration::from_millis(20));
    };
    let text = |f: &mut std::fs::File| {
        let mut s = String::new();
        f.seek(SeekFrom::Start(0)).unwrap();
        f.read_to_string(&mut s).unwrap();
        s
    };
    Run {
        code: status.code(),
        stdout: text(&mut stdout),
        stderr: text(&mut stderr),
    }
}

fn args_text<S: AsRef<OsStr>>(args: &[S]) -> Vec<String> {
    args.iter()
        .map(|a| a.as_ref().to_string_lossy().into_owned())
        .collect()
}

/// `sharpedge synth -o DIR/NAME ARGS`, checked to succeed; returns the cloud's path.
pub fn synth(dir: &Path, name: &str, args: &[&str]) -> PathBuf {
    let path = dir.join(name);
    let mut all: Vec<&OsStr> = vec!["-q".as_ref(), "synth".as_ref(), "-o".as_ref()];
    all.push(path.as_os_str());
    all.extend(args.iter().map(|a| OsStr::new(*a)));
    sharpedge(dir, &all).assert_ok();
    assert!(path.is_file(), "synth wrote no {}", path.display());
    path
}

/// The noisy, rounded, rotated box of the brief (50,000 points).
pub const BOX: &[&str] = &[
    "--part", "box", "--points", "50000", "--noise", "0.15", "--round", "1.5", "--rotate",
];

/// The L-block with a concave edge, noisy and rounded.
pub const LBLOCK: &[&str] = &[
    "--part", "lblock", "--points", "50000", "--noise", "0.15", "--round", "1.5", "--rotate",
    "--seed", "3",
];

/// What a run on a PLY (or XYZ) input writes, sorted: the link naming the published run
/// folder, that folder (as [`entries`] lists it), and the four outputs linked into it.
pub const PLY_OUTPUTS: [&str; 6] = [
    ".sharpedge-current",
    ".sharpedge-run-*",
    "edges.geojson",
    "features.ply",
    "rectified.ply",
    "report.json",
];

/// Writes `text` to DIR/pipeline.toml and returns its path.
pub fn config(dir: &Path, text: &str) -> PathBuf {
    let p = dir.join("pipeline.toml");
    std::fs::write(&p, text).unwrap();
    p
}

/// Names of the entries of a folder (hidden ones too), sorted; empty when it does not exist.
/// A run folder `.sharpedge-run-XXXXXX` is listed as `.sharpedge-run-*`.
pub fn entries(dir: &Path) -> Vec<String> {
    let Ok(rd) = std::fs::read_dir(dir) else {
        return Vec::new();
    };
    let mut v: Vec<String> = rd
        .map(|e| {
            let name = e.unwrap().file_name().to_string_lossy().into_owned();
            match name.strip_prefix(".sharpedge-run-") {
                Some(rest) if !rest.contains('.') => ".sharpedge-run-*".to_string(),
                _ => name,
            }
        })
        .collect();
    v.sort();
    v
}

/// A failed run as the issue demands: exit code 1 (not clap's 2, not a panic's 101), an
/// `error:` line on stderr containing every one of `parts`, no panic text, nothing on stdout
/// and nothing in the output folder.
pub fn assert_failed_cleanly(run: &Run, parts: &[&str], out_dir: &Path) {
    assert_eq!(run.code, Some(1), "exit code: {run:#?}");
    assert!(!run.stderr.contains("panicked"), "panic: {}", run.stderr);
    assert!(
        !run.stderr.contains("RUST_BACKTRACE"),
        "panic: {}",
        run.stderr
    );
    assert!(
        run.stderr.starts_with("error: "),
        "stderr should be the error: {}",
        run.stderr
    );
    for p in parts {
        assert!(
            run.stderr.contains(p),
            "stderr `{}` should contain `{p}`",
            run.stderr.trim_end()
        );
    }
    assert_eq!(run.stdout, "", "nothing on stdout");
    assert_eq!(
        entries(out_dir),
        Vec::<String>::new(),
        "files left behind in {}",
        out_dir.display()
    );
}

/// Writes a binary little-endian PLY with double x, y, z (so NaN and infinity can be stored,
/// which sharpedge's own writer refuses to do).
pub fn write_raw_ply(path: &Path, points: &[[f64; 3]]) {
    let mut bytes = format!(
        "ply\nformat binary_little_endian 1.0\nelement vertex {}\nproperty double x\nproperty double y\nproperty double z\nend_header\n",
        points.len()
    )
    .into_bytes();
    for p in points {
        for c in p {
            bytes.extend_from_slice(&c.to_le_bytes());
        }
    }
    std::fs::write(path, bytes).unwrap();
}

/// Writes an ascii PLY with float x, y, z and the given header/body text verbatim.
pub fn write_text(path: &Path, text: &str) {
    std::fs::write(path, text).unwrap();
}

/// A jittered, perfectly flat square grid in the plane z = 0.25 (side `n` points, pitch 0.5).
pub fn flat_plane(n: usize) -> Vec<[f64; 3]> {
    let mut v = Vec::with_capacity(n * n);
    for i in 0..n {
        for j in 0..n {
            // A deterministic jitter (no RNG needed): irrational multiples folded into ±0.05.
            let jx = ((i * 7919 + j * 104_729) as f64 * 0.618_033_988_7).fract() - 0.5;
            let jy = ((i * 15_485_863 + j * 32_452_843) as f64 * 0.414_213_562_3).fract() - 0.5;
            v.push([i as f64 * 0.5 + 0.1 * jx, j as f64 * 0.5 + 0.1 * jy, 0.25]);
        }
    }
    v
}

/// One vertex property as declared in a PLY header.
#[derive(Debug, Clone, PartialEq)]
pub struct Prop {
    pub ty: String,
    pub name: String,
}

/// One element of a PLY header with its scalar properties.
#[derive(Debug, Clone, PartialEq)]
pub struct Element {
    pub name: String,
    pub count: usize,
    pub props: Vec<Prop>,
}

/// The parsed header of a PLY file and the byte offset where the body starts.
#[derive(Debug)]
pub struct Header {
    pub format: String,
    pub elements: Vec<Element>,
    pub body: usize,
}

impl Header {
    pub fn element(&self, name: &str) -> &Element {
        self.elements
            .iter()
            .find(|e| e.name == name)
            .unwrap_or_else(|| panic!("no element {name} in {self:?}"))
    }
}

impl Element {
    /// The type of a property, if present.
    pub fn ty(&self, name: &str) -> Option<&str> {
        self.props
            .iter()
            .find(|p| p.name == name)
            .map(|p| p.ty.as_str())
    }
}

pub fn parse_header(bytes: &[u8]) -> Header {
    let end = bytes
        .windows(11)
        .position(|w| w == b"end_header\n")
        .expect("a PLY header");
    let text = std::str::from_utf8(&bytes[..end]).unwrap();
    let mut lines = text.lines();
    assert_eq!(lines.next(), Some("ply"));
    let mut format = String::new();
    let mut elements: Vec<Element> = Vec::new();
    for l in lines {
        let w: Vec<&str> = l.split_whitespace().collect();
        match w.as_slice() {
            ["format", f, "1.0"] => format = f.to_string(),
            ["element", name, count] => elements.push(Element {
                name: name.to_string(),
                count: count.parse().unwrap(),
                props: Vec::new(),
            }),
            ["property", "list", ..] => panic!("list property in {l}"),
            ["property", ty, name] => elements.last_mut().unwrap().props.push(Prop {
                ty: ty.to_string(),
                name: name.to_string(),
            }),
            ["comment", ..] | ["obj_info", ..] => {}
            _ => panic!("unexpected header line {l}"),
        }
    }
    Header {
        format,
        elements,
        body: end + 11,
    }
}

pub fn type_size(ty: &str) -> usize {
    match ty {
        "char" | "uchar" | "int8" | "uint8" => 1,
        "short" | "ushort" | "int16" | "uint16" => 2,
        "int" | "uint" | "float" | "int32" | "uint32" | "float32" => 4,
        "double" | "float64" => 8,
        _ => panic!("unknown type {ty}"),
    }
}

/// Bytes per item of a binary element of scalar properties.
pub fn stride_of(e: &Element) -> usize {
    e.props.iter().map(|p| type_size(&p.ty)).sum()
}

/// The `element edge` of a binary little-endian features.ply: the vertex count and the
/// (vertex1, vertex2) pairs, read from the bytes (sharpedge's reader skips non-vertex
/// elements).
pub fn read_edges(path: &Path) -> (usize, Vec<[i32; 2]>) {
    let bytes = std::fs::read(path).unwrap();
    let h = parse_header(&bytes);
    assert_eq!(h.format, "binary_little_endian", "{}", path.display());
    let names: Vec<&str> = h.elements.iter().map(|e| e.name.as_str()).collect();
    let v = h.element("vertex");
    if names == ["vertex"] {
        // The writer leaves out an empty `element edge`.
        assert_eq!(
            bytes.len(),
            h.body + v.count * stride_of(v),
            "{}",
            path.display()
        );
        return (v.count, Vec::new());
    }
    assert_eq!(names, ["vertex", "edge"], "{}", path.display());
    let e = h.element("edge");
    assert_eq!(
        e.props,
        vec![
            Prop {
                ty: "int".into(),
                name: "vertex1".into()
            },
            Prop {
                ty: "int".into(),
                name: "vertex2".into()
            }
        ],
        "edge properties of {}",
        path.display()
    );
    let start = h.body + v.count * stride_of(v);
    assert_eq!(
        bytes.len(),
        start + 8 * e.count,
        "{}: file size must match the header",
        path.display()
    );
    let i32_at = |o: usize| i32::from_le_bytes(bytes[o..o + 4].try_into().unwrap());
    let pairs = (0..e.count)
        .map(|k| [i32_at(start + 8 * k), i32_at(start + 8 * k + 4)])
        .collect();
    (v.count, pairs)
}

/// report.json parsed.
pub fn report(out_dir: &Path) -> serde_json::Value {
    let text = std::fs::read_to_string(out_dir.join("report.json")).unwrap();
    serde_json::from_str(&text).unwrap()
}

/// A report without what may differ between runs that must otherwise agree: the stage
/// timings and the echoed thread count.
pub fn without_timings(mut r: serde_json::Value) -> serde_json::Value {
    let o = r.as_object_mut().unwrap();
    assert!(o.remove("timings").is_some(), "report has timings");
    let cfg = o["config"].as_object_mut().unwrap();
    assert!(cfg.remove("threads").is_some(), "config echoes threads");
    r
}

/// Reads a cloud with sharpedge's reader.
pub fn read_cloud(path: &Path) -> sharpedge::Cloud {
    sharpedge::io::read(path, &sharpedge::io::ReadOptions::default())
        .unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

/// A per-point column of a cloud as f64 values.
pub fn column(cloud: &sharpedge::Cloud, name: &str) -> Vec<f64> {
    let a = cloud
        .attribute(name)
        .unwrap_or_else(|| panic!("no attribute {name}"));
    (0..a.values.len()).map(|i| a.values.get_f64(i)).collect()
}

/// A temporary folder holding a minimal pipeline.toml; runs happen inside it with `--out out`.
#[allow(clippy::new_without_default)]
pub struct Case {
    pub dir: tempfile::TempDir,
}

impl Case {
    pub fn new() -> Case {
        let dir = tempfile::tempdir().unwrap();
        config(dir.path(), "[input]\npath = \"scan.ply\"\n");
        Case { dir }
    }

    pub fn path(&self) -> &Path {
        self.dir.path()
    }

    pub fn out(&self) -> PathBuf {
        self.path().join("out")
    }

    /// `sharpedge run pipeline.toml --input INPUT --out out`, plus `extra`.
    pub fn run(&self, input: &str, extra: &[&str]) -> Run {
        let mut args = vec!["run", "pipeline.toml", "--input", input, "--out", "out"];
        args.extend_from_slice(extra);
        sharpedge(self.path(), &args)
    }

    pub fn write(&self, name: &str, text: &str) {
        write_text(&self.path().join(name), text);
    }
}

pub const XYZ_HEADER: &str = "ply\nformat ascii 1.0\nelement vertex {n}\nproperty float x\nproperty float y\nproperty float z\nend_header\n";

/// An ascii PLY with float x, y, z.
pub fn ascii_ply(points: &[[f64; 3]]) -> String {
    let mut s = XYZ_HEADER.replace("{n}", &points.len().to_string());
    for p in points {
        s.push_str(&format!("{} {} {}\n", p[0], p[1], p[2]));
    }
    s
}

/// Runs with the given pipeline.toml (a valid input is present) and checks the failure: the
/// first stderr line starts with `error: ` + `expected`; the default output folder is not
/// created.
pub fn bad_config(text: &str, expected: &str) -> String {
    let c = Case::new();
    synth(c.path(), "scan.ply", BOX);
    config(c.path(), text);
    let r = sharpedge(c.path(), &["run", "pipeline.toml"]);
    assert_failed_cleanly(&r, &[expected], &c.out());
    assert!(
        r.stderr.starts_with(&format!("error: {expected}")),
        "{}",
        r.stderr
    );
    assert!(!c.out().exists(), "no output folder for a bad config");
    r.stderr
}

/// A folder with the synth box as scan.ply and a pipeline.toml reading it.
pub fn job() -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    synth(dir.path(), "scan.ply", BOX);
    config(dir.path(), "[input]\npath = \"scan.ply\"\n");
    dir
}

/// The scored cases `cases` (names such as "r003,r080") of `sharpedge bench --random 100
/// --seed SEED`, run in a temporary folder: the bench's JSON `cases` array, checked to hold
/// those cases in that order.
pub fn bench_random_cases(seed: u64, cases: &str) -> Vec<serde_json::Value> {
    let dir = tempfile::tempdir().unwrap();
    let seed = seed.to_string();
    sharpedge(
        dir.path(),
        &[
            "bench", "--random", "100", "--seed", &seed, "--cases", cases, "--out", "b.json", "-q",
        ],
    )
    .assert_ok();
    let text = std::fs::read_to_string(dir.path().join("b.json")).unwrap();
    let j: serde_json::Value = serde_json::from_str(&text).unwrap();
    let got = j["cases"].as_array().unwrap().clone();
    let names: Vec<&str> = got.iter().map(|c| c["name"].as_str().unwrap()).collect();
    assert_eq!(names, cases.split(',').collect::<Vec<_>>());
    got
}

/// [`bench_random_cases`] for draws pinned by their point counts: `(name, points)` each,
/// failing with "the draw changed" when a case's drawn cloud is not the one a test was
/// written against.
pub fn bench_random_draws(seed: u64, draws: &[(&str, u64)]) -> Vec<serde_json::Value> {
    let names: Vec<&str> = draws.iter().map(|d| d.0).collect();
    let cases = bench_random_cases(seed, &names.join(","));
    for (c, (name, points)) in cases.iter().zip(draws) {
        assert_eq!(
            c["points"].as_u64(),
            Some(*points),
            "{name}: the draw changed"
        );
    }
    cases
}

/// [`bench_random_draws`] for one draw: its scored case.
pub fn bench_random_draw(seed: u64, name: &str, points: u64) -> serde_json::Value {
    bench_random_draws(seed, &[(name, points)]).remove(0)
}

/// Checks a scored case's rectification: at most `max_away` points away from every edge
/// moved (`away_before` before the change under test), and rectified / raw distance at most
/// `max_ratio` (`ratio_before` before).
pub fn assert_rectified(
    case: &serde_json::Value,
    (max_away, away_before): (u64, u64),
    (max_ratio, ratio_before): (f64, f64),
) {
    let name = &case["name"];
    let away = case["rectify"]["away_moved"].as_u64().unwrap();
    assert!(
        away <= max_away,
        "{name}: {away} points away from edges moved ({away_before} before)"
    );
    let ratio = case["rectify"]["ratio"].as_f64().unwrap();
    assert!(
        ratio <= max_ratio,
        "{name}: rectified / raw {ratio:.3} ({ratio_before} before)"
    );
}

/// Checks a scored case's corners: recall at least `min_recall` (`recall_before` before the
/// change under test) and precision at least `min_precision`; the messages list the missed
/// and the spurious corners.
pub fn assert_corners(
    case: &serde_json::Value,
    (min_recall, recall_before): (f64, f64),
    min_precision: f64,
) {
    let name = &case["name"];
    let c = &case["corners"];
    let recall = c["recall"].as_f64().unwrap();
    assert!(
        recall >= min_recall,
        "{name}: corner recall {recall:.3} ({recall_before} before), missed {}",
        c["missed"]
    );
    let precision = c["precision"].as_f64().unwrap();
    assert!(
        precision >= min_precision,
        "{name}: corner precision {precision:.3}, spurious {}",
        c["spurious"]
    );
}

/// Checks a scored case's edges: recall (share of the true length found) at least
/// `min_recall` (`recall_before` before the change under test).
pub fn assert_edge_recall(case: &serde_json::Value, (min_recall, recall_before): (f64, f64)) {
    let recall = case["edges"]["recall"].as_f64().unwrap();
    assert!(
        recall >= min_recall,
        "{}: edge recall {recall:.3} ({recall_before} before)",
        case["name"]
    );
}

/// Checks that a scored case passes every check of the bench.
pub fn assert_passes(case: &serde_json::Value) {
    assert_eq!(
        case["pass"].as_bool(),
        Some(true),
        "{}: {}",
        case["name"],
        case["checks"]
    );
}
