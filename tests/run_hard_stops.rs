//! Issue 12, hard stops. Outputs are never mixed: a run killed (SIGKILL) at any moment while it reads,
//! computes or writes, or a second run writing into the same folder, leaves the output folder
//! with either the complete earlier set or the complete new set, and a later run removes what
//! the killed ones left.

mod run_common;

use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use rand::{RngExt, SeedableRng};
use run_common::*;

const FILES: [&str; 4] = [
    "rectified.ply",
    "features.ply",
    "edges.geojson",
    "report.json",
];

/// One run's outputs as a reader compares them: the bytes of the three clouds and files, and
/// report.json without what differs between two runs of one input (timings, the output folder
/// in the config).
#[derive(PartialEq, Debug)]
struct Set {
    files: Vec<Vec<u8>>,
    report: serde_json::Value,
}

fn read_set(out: &Path) -> Result<Set, String> {
    let mut files = Vec::new();
    for f in &FILES[..3] {
        files.push(std::fs::read(out.join(f)).map_err(|e| format!("{f}: {e}"))?);
    }
    let text = std::fs::read_to_string(out.join("report.json"))
        .map_err(|e| format!("report.json: {e}"))?;
    let mut report: serde_json::Value =
        serde_json::from_str(&text).map_err(|e| format!("report.json: {e}"))?;
    let obj = report.as_object_mut().ok_or("report.json is no object")?;
    obj.remove("timings");
    obj.remove("config");
    Ok(Set { files, report })
}

fn spawn_run(dir: &Path, input: &str, out: &Path) -> Child {
    Command::new(BIN)
        .args(["-q", "run", "pipeline.toml", "--input", input, "--out"])
        .arg(out)
        .current_dir(dir)
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap()
}

/// The run folders in `out` other than those in `known`.
fn new_run_folders(out: &Path, known: &[PathBuf]) -> Vec<PathBuf> {
    std::fs::read_dir(out)
        .map(|rd| {
            rd.filter_map(|e| e.ok())
                .map(|e| e.path())
                .filter(|p| {
                    p.file_name()
                        .and_then(|n| n.to_str())
                        .and_then(|n| n.strip_prefix(".sharpedge-run-"))
                        .is_some_and(|rest| !rest.contains('.'))
                        && !known.contains(p)
                })
                .collect()
        })
        .unwrap_or_default()
}

/// Waits until the run `child` has made its run folder in `out` (one not in `known`), or has
/// ended; returns when that was.
fn wait_for_run_folder(child: &mut Child, out: &Path, known: &[PathBuf]) -> Instant {
    let start = Instant::now();
    while new_run_folders(out, known).is_empty()
        && child.try_wait().unwrap().is_none()
        && start.elapsed() < Duration::from_secs(120)
    {
        std::thread::sleep(Duration::from_micros(100));
    }
    Instant::now()
}

/// Which of `refs` the folder holds; panics on anything else.
fn which(out: &Path, refs: &[Set; 2], what: &str) -> usize {
    let got = read_set(out).unwrap_or_else(|e| panic!("{what}: incomplete output set: {e}"));
    refs.iter()
        .position(|r| *r == got)
        .unwrap_or_else(|| panic!("{what}: the output set mixes two runs or is damaged"))
}

/// `sharpedge synth` of `part` with `points` points at noise 0.15, into DIR/NAME.
fn scan(dir: &Path, name: &str, part: &str, points: &str, seed: &str) {
    synth(
        dir,
        name,
        &[
            "--part", part, "--points", points, "--noise", "0.15", "--seed", seed,
        ],
    );
}

fn inputs(dir: &Path) {
    scan(dir, "a.ply", "box", "300000", "1");
    scan(dir, "b.ply", "lblock", "300000", "2");
    config(dir, "threads = 2\n");
}

#[test]
fn outputs_never_mixed_after_sigkill_at_random_moments() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path();
    inputs(dir);
    let names = ["a.ply", "b.ply"];
    // The two complete sets, and how long a whole run takes here.
    let mut refs = Vec::new();
    let mut longest = Duration::ZERO;
    let mut writing = Duration::MAX;
    for (i, n) in names.iter().enumerate() {
        let out = dir.join(format!("ref{i}"));
        let start = Instant::now();
        let mut child = spawn_run(dir, n, &out);
        let made = wait_for_run_folder(&mut child, &out, &[]);
        let status = child.wait().unwrap();
        longest = longest.max(start.elapsed());
        writing = writing.min(made.elapsed());
        assert!(status.success(), "reference run on {n} failed");
        refs.push(read_set(&out).unwrap());
    }
    println!("a run takes {longest:?}, its write stage {writing:?}");
    let refs: [Set; 2] = refs.try_into().unwrap();
    assert_ne!(refs[0], refs[1]);
    let out = dir.join("out");
    assert!(spawn_run(dir, names[0], &out).wait().unwrap().success());
    let mut held = which(&out, &refs, "the earlier good run");
    assert_eq!(held, 0);
    let mut rng = rand::rngs::SmallRng::seed_from_u64(12);
    let (mut finished, mut in_write, mut killed_writing) = (0, 0, 0);
    for k in 0..50 {
        // The other input each time, so that a mix of the two would show.
        let next = 1 - held;
        let known = new_run_folders(&out, &[]);
        let mut child = spawn_run(dir, names[next], &out);
        let start = Instant::now();
        if k % 2 == 0 {
            // Anywhere in reading and computing (and writing, when the run is quick).
            let at = longest.mul_f64(rng.random_range(0.0..1.0));
            while start.elapsed() < at && child.try_wait().unwrap().is_none() {
                std::thread::sleep(Duration::from_millis(1));
            }
        } else {
            // In the write stage: once the run has made its run folder, within the time the
            // reference runs took from there to their end.
            wait_for_run_folder(&mut child, &out, &known);
            in_write += 1;
            std::thread::sleep(writing.mul_f64(rng.random_range(0.0..1.0)));
        }
        let _ = child.kill();
        let status = child.wait().unwrap();
        if status.success() {
            finished += 1;
        } else if k % 2 == 1 {
            killed_writing += 1;
        }
        let now = which(&out, &refs, &format!("kill {k}"));
        assert!(
            now == held || now == next,
            "kill {k}: the folder holds neither the earlier nor the new set"
        );
        if status.success() {
            assert_eq!(
                now, next,
                "kill {k}: the run finished but its outputs are not there"
            );
        }
        held = now;
    }
    println!(
        "50 kills: {in_write} aimed at the write stage ({killed_writing} of them landed), \
         {finished} runs finished first"
    );
    // How many land depends on the machine's load; enough must, or nothing was tested.
    assert!(
        finished <= 40,
        "{finished} of 50 runs finished before the kill"
    );
    assert!(
        killed_writing >= 5,
        "only {killed_writing} kills landed in the write stage"
    );
    // A run after the kills removes what they left.
    let last = 1 - held;
    assert!(spawn_run(dir, names[last], &out).wait().unwrap().success());
    assert_eq!(which(&out, &refs, "the run after the kills"), last);
    assert_eq!(entries(&out), PLY_OUTPUTS, "litter left by killed runs");
}

#[test]
fn two_runs_into_one_folder_leave_one_complete_set() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path();
    inputs(dir);
    let mut refs = Vec::new();
    for (i, n) in ["a.ply", "b.ply"].iter().enumerate() {
        let out = dir.join(format!("ref{i}"));
        assert!(spawn_run(dir, n, &out).wait().unwrap().success());
        refs.push(read_set(&out).unwrap());
    }
    let refs: [Set; 2] = refs.try_into().unwrap();
    let out = dir.join("out");
    for round in 0..3 {
        let mut a = spawn_run(dir, "a.ply", &out);
        let mut b = spawn_run(dir, "b.ply", &out);
        assert!(a.wait().unwrap().success(), "round {round}: run a failed");
        assert!(b.wait().unwrap().success(), "round {round}: run b failed");
        which(&out, &refs, &format!("round {round}"));
        assert_eq!(entries(&out), PLY_OUTPUTS, "round {round}");
    }
}

/// Waits until the run `child` has read past the start of `input` (its open file's offset in
/// /proc), so that what the test does to the file next happens while it is read.
fn wait_until_reading(child: &mut Child, input: &Path) {
    let fds = PathBuf::from(format!("/proc/{}/fd", child.id()));
    let info = PathBuf::from(format!("/proc/{}/fdinfo", child.id()));
    let input = input.canonicalize().unwrap();
    let start = Instant::now();
    loop {
        assert!(
            child.try_wait().unwrap().is_none(),
            "the run ended before it was caught reading"
        );
        assert!(
            start.elapsed() < Duration::from_secs(60),
            "the run never read its input"
        );
        let reading = std::fs::read_dir(&fds)
            .into_iter()
            .flatten()
            .flatten()
            .any(|fd| {
                std::fs::read_link(fd.path()).is_ok_and(|t| t == input)
                    && std::fs::read_to_string(info.join(fd.file_name())).is_ok_and(|s| {
                        s.lines()
                            .find_map(|l| l.strip_prefix("pos:"))
                            .and_then(|p| p.trim().parse::<u64>().ok())
                            .is_some_and(|pos| pos > 0)
                    })
            });
        if reading {
            return;
        }
        std::thread::sleep(Duration::from_micros(200));
    }
}

fn ascii_input(dir: &Path) -> PathBuf {
    let mut args = vec!["--ascii"];
    args.extend([
        "--part", "box", "--points", "1000000", "--noise", "0.1", "--seed", "4",
    ]);
    synth(dir, "big.ply", &args)
}

#[test]
fn input_truncated_while_read_fails_and_keeps_the_earlier_output() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path();
    inputs(dir);
    let big = ascii_input(dir);
    let out = dir.join("out");
    assert!(spawn_run(dir, "a.ply", &out).wait().unwrap().success());
    let earlier = read_set(&out).unwrap();
    let mut child = Command::new(BIN)
        .args([
            "-q",
            "run",
            "pipeline.toml",
            "--input",
            "big.ply",
            "--out",
            "out",
        ])
        .current_dir(dir)
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    wait_until_reading(&mut child, &big);
    let half = std::fs::metadata(&big).unwrap().len() / 2;
    std::fs::OpenOptions::new()
        .write(true)
        .open(&big)
        .unwrap()
        .set_len(half)
        .unwrap();
    let run = child.wait_with_output().unwrap();
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert_eq!(run.status.code(), Some(1), "{stderr}");
    assert!(
        stderr.starts_with("error: big.ply: line ")
            && stderr.contains("the file ends")
            && stderr.contains("the file is truncated"),
        "{stderr}"
    );
    assert_eq!(
        read_set(&out).unwrap(),
        earlier,
        "the earlier output changed"
    );
    assert_eq!(entries(&out), PLY_OUTPUTS);
}

#[test]
fn input_deleted_while_read_is_read_whole() {
    // On unix a deleted file stays readable through the open handle: the run reads all of it
    // and its outputs are those of the file as it was.
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path();
    config(dir, "threads = 2\n");
    let big = ascii_input(dir);
    std::fs::copy(&big, dir.join("copy.ply")).unwrap();
    assert!(
        spawn_run(dir, "copy.ply", &dir.join("ref"))
            .wait()
            .unwrap()
            .success()
    );
    let out = dir.join("out");
    let mut child = spawn_run(dir, "big.ply", &out);
    wait_until_reading(&mut child, &big);
    std::fs::remove_file(&big).unwrap();
    assert!(child.wait().unwrap().success());
    let (got, want) = (read_set(&out).unwrap(), read_set(&dir.join("ref")).unwrap());
    assert!(
        got.files == want.files,
        "the outputs differ from the whole file's"
    );
}

/// A small tmpfs mounted for one test, unmounted when dropped.
struct Tmpfs(PathBuf);

impl Tmpfs {
    /// `None` (with a message) where this process may not mount, e.g. not as root.
    fn mount(at: &Path, bytes: u64) -> Option<Tmpfs> {
        std::fs::create_dir_all(at).unwrap();
        let r = Command::new("mount")
            .args(["-t", "tmpfs", "-o", &format!("size={bytes}"), "tmpfs"])
            .arg(at)
            .output();
        match r {
            Ok(o) if o.status.success() => Some(Tmpfs(at.to_path_buf())),
            Ok(o) => {
                println!(
                    "skipped: cannot mount a small tmpfs here (needs root): {}",
                    String::from_utf8_lossy(&o.stderr).trim()
                );
                None
            }
            Err(e) => {
                println!("skipped: cannot run mount: {e}");
                None
            }
        }
    }
}

impl Drop for Tmpfs {
    fn drop(&mut self) {
        let _ = Command::new("umount").arg("-l").arg(&self.0).status();
    }
}

#[test]
fn disk_full_during_write_fails_and_keeps_the_earlier_output() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path();
    config(dir, "threads = 2\n");
    scan(dir, "small.ply", "box", "30000", "1");
    scan(dir, "large.ply", "box", "200000", "1");
    // Room for the small run's outputs (about 1 MB) twice, not for the large one's (6 MB).
    let Some(disk) = Tmpfs::mount(&dir.join("disk"), 3 << 20) else {
        return;
    };
    let out = disk.0.join("out");
    assert!(spawn_run(dir, "small.ply", &out).wait().unwrap().success());
    let earlier = read_set(&out).unwrap();
    let run = sharpedge(
        dir,
        &[
            "run",
            "pipeline.toml",
            "-q",
            "--input",
            "large.ply",
            "--out",
        ]
        .map(std::ffi::OsStr::new)
        .into_iter()
        .chain([out.as_os_str()])
        .collect::<Vec<_>>(),
    );
    assert_eq!(run.code, Some(1), "{run:#?}");
    assert!(
        run.stderr.starts_with(&format!(
            "error: {}: cannot write (disk full?)",
            out.join("rectified.ply").display()
        )) && run.stderr.contains("No space left on device"),
        "{}",
        run.stderr
    );
    assert_eq!(
        read_set(&out).unwrap(),
        earlier,
        "the earlier output changed"
    );
    assert_eq!(
        entries(&out),
        PLY_OUTPUTS,
        "the failed run left files behind"
    );
    // The space is free again: the small run still fits.
    assert!(spawn_run(dir, "small.ply", &out).wait().unwrap().success());
}
