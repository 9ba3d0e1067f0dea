//! Publishing a run's output files as one set: a reader of the output folder sees either the
//! complete set of one run or the complete set of another, never a mix, whenever the run is
//! killed and however many runs write into the same folder.
//!
//! Input: the output folder and the names of the files of the set. [`stage`] gives a
//! [`Staging`] folder to write them into; [`Staging::publish`] makes them the folder's outputs.
//! Output: the paths of the published files.
//!
//! On unix the folder looks like this after a run:
//!
//! ```text
//! out/rectified.ply          -> .sharpedge-current/rectified.ply   (one link per name)
//! out/.sharpedge-current     -> .sharpedge-run-Ab12Cd
//! out/.sharpedge-run-Ab12Cd/ rectified.ply features.ply edges.geojson report.json .lock
//! ```
//!
//! A run writes its files into a new run folder and then replaces the `.sharpedge-current`
//! link with one `rename(2)`, which is atomic: every name resolves into one complete run
//! folder at every instant. Renaming the four files one by one, as before, left a run killed
//! between two renames with the rectified cloud of one run beside the report of another.
//! Swapping the output folder itself would need `renameat2(RENAME_EXCHANGE)` and cannot work
//! for `--out .` or a folder that holds the user's other files.
//!
//! Stale run folders (of killed runs) are recognised by their lock: a run holds an exclusive
//! `flock` on its folder's `.lock` from before its first file until it has published, and the
//! kernel releases it when the process dies, SIGKILL included. Every run removes the stale
//! folders it finds, and the run folder it replaced, before and after it publishes.
//!
//! Elsewhere than unix (no symlinks without privileges) the files are renamed one by one, as
//! before, which is atomic per file only.

use std::fs::File;
use std::path::{Path, PathBuf};
use std::time::Duration;

use crate::error::{Error, Result};

/// The prefix of run folders; also of the temporary links a run makes.
const RUN_PREFIX: &str = ".sharpedge-run-";
/// The link naming the published run folder.
const CURRENT: &str = ".sharpedge-current";
/// The lock file in a run folder, held while the run writes.
const LOCK: &str = ".lock";
/// A run folder without its lock file, or a temporary file that is not locked, is left alone
/// this long: its owner may be between creating and locking it.
const GRACE: Duration = Duration::from_secs(60);

/// A run folder being written. Dropped without [`Staging::publish`], it is removed.
pub struct Staging {
    out: PathBuf,
    names: Vec<String>,
    dir: tempfile::TempDir,
    /// Held until published; closing it releases the lock.
    _lock: File,
}

/// Creates a run folder in `out` for the files `names` (after checking that none of them is
/// a folder in the way and removing stale run folders).
pub fn stage(out: &Path, names: &[&str]) -> Result<Staging> {
    for name in names {
        let to = out.join(name);
        if std::fs::symlink_metadata(&to).is_ok_and(|m| m.is_dir()) {
            return Err(Error::io(
                &to,
                "cannot write this output",
                std::io::Error::other(
                    "a folder of that name is in the way; move it or choose another output folder",
                ),
            ));
        }
    }
    clean_stale(out);
    // The owner's pid in the name: a run killed between making its folder and locking it
    // leaves a folder without a lock, stale once that process is gone.
    let prefix = format!("{RUN_PREFIX}{}-", std::process::id());
    let dir = tempfile::Builder::new()
        .prefix(&prefix)
        .tempdir_in(out)
        .map_err(|e| {
            Error::io(
                out,
                "cannot create a temporary folder in the output folder (is it writable?)",
                e,
            )
        })?;
    let lock = lock_new(dir.path()).map_err(|e| {
        Error::io(
            dir.path(),
            "cannot create the lock file of this run's folder",
            e,
        )
    })?;
    // tempdir makes 0700 folders; the outputs are read by colleagues and viewers through
    // the links, as files written straight into `out` would be.
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        std::fs::set_permissions(dir.path(), std::fs::Permissions::from_mode(0o755))
            .map_err(|e| Error::io(dir.path(), "cannot make the run folder readable", e))?;
    }
    Ok(Staging {
        out: out.to_path_buf(),
        names: names.iter().map(|s| s.to_string()).collect(),
        dir,
        _lock: lock,
    })
}

/// Creates `dir/.lock` already locked: it is made under another name, locked, then renamed,
/// so no other run can see it unlocked and take the folder for stale.
fn lock_new(dir: &Path) -> std::io::Result<File> {
    let tmp = dir.join(".lock.new");
    let f = File::create(&tmp)?;
    // Without lock support (some network file systems) other runs never take this folder
    // for stale: litter, but never a live run's folder removed.
    let _ = f.try_lock();
    std::fs::rename(&tmp, dir.join(LOCK))?;
    Ok(f)
}

impl Staging {
    /// Where to write the `i`-th file of the set.
    pub fn file(&self, i: usize) -> PathBuf {
        self.run_dir().join(&self.names[i])
    }

    /// The run folder being written.
    pub fn run_dir(&self) -> &Path {
        self.dir.path()
    }

    /// Makes the staged files the output folder's files and returns their paths
    /// (`out/<name>`). Every file must have been written.
    pub fn publish(self) -> Result<Vec<PathBuf>> {
        for i in 0..self.names.len() {
            let f = self.file(i);
            if !f.is_file() {
                return Err(Error::io(
                    self.out.join(&self.names[i]),
                    "cannot publish this output: it was not written",
                    std::io::Error::from(std::io::ErrorKind::NotFound),
                ));
            }
        }
        let placed = self.swap_in()?;
        self.finish();
        Ok(placed)
    }

    /// After the swap: keeps the run folder, releases its lock, then removes stale folders.
    /// The lock goes before the clean-up: of two runs publishing at once, the one that
    /// swapped in first may still hold its lock while the other cleans, and its folder,
    /// replaced, stayed as litter (CI, stop 29). Whichever releases last sees the other's
    /// folder unlocked, and its own if it was replaced.
    fn finish(self) {
        let Staging {
            out, dir, _lock, ..
        } = self;
        let _ = dir.keep();
        drop(_lock);
        clean_stale(&out);
    }

    #[cfg(unix)]
    fn swap_in(&self) -> Result<Vec<PathBuf>> {
        let run_name = file_name(self.run_dir());
        let tmp = |what: &str| self.out.join(format!("{run_name}.{what}"));
        // The names first: each resolves through `.sharpedge-current`, so a new name shows
        // nothing until the swap and an existing one keeps showing the earlier run's file.
        let mut placed = Vec::with_capacity(self.names.len());
        for (i, name) in self.names.iter().enumerate() {
            let to = self.out.join(name);
            let target = Path::new(CURRENT).join(name);
            if !std::fs::read_link(&to).is_ok_and(|t| t == target) {
                replace_with_link(&target, &tmp(&format!("link{i}")), &to)?;
            }
            placed.push(to);
        }
        replace_with_link(
            Path::new(&run_name),
            &tmp("current"),
            &self.out.join(CURRENT),
        )?;
        Ok(placed)
    }

    #[cfg(not(unix))]
    fn swap_in(&self) -> Result<Vec<PathBuf>> {
        let mut placed = Vec::with_capacity(self.names.len());
        for (i, name) in self.names.iter().enumerate() {
            let to = self.out.join(name);
            std::fs::rename(self.file(i), &to)
                .map_err(|e| Error::io(&to, "cannot move the finished output to this name", e))?;
            placed.push(to);
        }
        Ok(placed)
    }
}

/// Makes `to` a link to `target` in one rename, through the temporary name `tmp`: `to` shows
/// its old content or the link, never nothing.
#[cfg(unix)]
fn replace_with_link(target: &Path, tmp: &Path, to: &Path) -> Result<()> {
    let err = |e| {
        Error::io(
            to,
            "cannot link this output into the output folder; the earlier output is unchanged",
            e,
        )
    };
    let _ = std::fs::remove_file(tmp);
    std::os::unix::fs::symlink(target, tmp).map_err(err)?;
    std::fs::rename(tmp, to).map_err(|e| {
        let _ = std::fs::remove_file(tmp);
        err(e)
    })
}

fn file_name(p: &Path) -> String {
    p.file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default()
}

/// The run folder `.sharpedge-current` names, if any.
fn current_run(out: &Path) -> Option<String> {
    std::fs::read_link(out.join(CURRENT))
        .ok()
        .map(|t| t.to_string_lossy().into_owned())
}

fn older_than_grace(p: &Path) -> bool {
    std::fs::symlink_metadata(p)
        .and_then(|m| m.modified())
        .ok()
        .and_then(|t| t.elapsed().ok())
        .is_some_and(|age| age > GRACE)
}

/// Whether the process named in the run folder's name (`.sharpedge-run-<pid>-XXXXXX`) has
/// ended; false where that cannot be told (no /proc).
fn owner_gone(dir: &Path) -> bool {
    let name = file_name(dir);
    let Some(pid) = name
        .strip_prefix(RUN_PREFIX)
        .and_then(|rest| rest.split('-').next())
        .and_then(|p| p.parse::<u32>().ok())
    else {
        return false;
    };
    Path::new("/proc/self").exists() && !Path::new("/proc").join(pid.to_string()).exists()
}

/// Whether the run folder `dir` belongs to no live run. On `true` the caller holds its lock
/// (returned) until it has removed the folder.
fn stale_run(out: &Path, dir: &Path) -> Option<Option<File>> {
    let lock = match File::open(dir.join(LOCK)) {
        Ok(f) => match f.try_lock() {
            Ok(()) => Some(f),
            Err(_) => return None,
        },
        // A folder whose run died before locking it, or is creating its lock now.
        Err(_) if owner_gone(dir) || older_than_grace(dir) => None,
        Err(_) => return None,
    };
    // Read after taking the lock: a run swaps its folder in while it holds the lock, so a
    // folder that became current is seen as current here.
    if current_run(out).as_deref() == Some(file_name(dir).as_str()) {
        return None;
    }
    Some(lock)
}

/// Removes what killed or finished runs left in `out`: run folders no live run holds and that
/// are not current, their temporary links, temporary files of [`super::write_atomic`] that no
/// live writer holds, and links of names whose file the current run does not have (a
/// `rectified.laz` after a run that wrote `rectified.ply`). Best effort: what cannot be
/// removed now is removed by a later run.
pub fn clean_stale(out: &Path) {
    let Ok(rd) = std::fs::read_dir(out) else {
        return;
    };
    let entries: Vec<(String, PathBuf)> = rd
        .filter_map(|e| e.ok())
        .map(|e| (e.file_name().to_string_lossy().into_owned(), e.path()))
        .collect();
    let mut removed: Vec<&str> = Vec::new();
    for (name, path) in &entries {
        let is_run_dir = name
            .strip_prefix(RUN_PREFIX)
            .is_some_and(|rest| !rest.contains('.'))
            && std::fs::symlink_metadata(path).is_ok_and(|m| m.is_dir());
        if !is_run_dir {
            continue;
        }
        if let Some(lock) = stale_run(out, path) {
            if std::fs::remove_dir_all(path).is_ok() {
                removed.push(name);
            }
            drop(lock);
        }
    }
    for (name, path) in &entries {
        // `.sharpedge-run-XXXX.link0`, `.current`: temporary links of a run folder.
        if let Some(rest) = name.strip_prefix(RUN_PREFIX)
            && let Some((run, _)) = rest.split_once('.')
        {
            let dir = format!("{RUN_PREFIX}{run}");
            if removed.contains(&dir.as_str()) || !out.join(&dir).exists() {
                let _ = std::fs::remove_file(path);
            }
            continue;
        }
        if name.starts_with(".sharpedge-") && name.ends_with(".part") {
            if older_than_grace(path)
                && let Ok(f) = File::open(path)
                && f.try_lock().is_ok()
            {
                let _ = std::fs::remove_file(path);
            }
            continue;
        }
        // A name linked through `.sharpedge-current` to a file the current run has not.
        if let Ok(t) = std::fs::read_link(path)
            && t.starts_with(CURRENT)
            && !path.exists()
            && out.join(CURRENT).exists()
        {
            let _ = std::fs::remove_file(path);
        }
    }
}

#[cfg(test)]
#[cfg(unix)]
mod tests {
    use super::*;

    fn names(dir: &Path) -> Vec<String> {
        let mut v: Vec<String> = std::fs::read_dir(dir)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        v.sort();
        v
    }

    fn publish(out: &Path, files: &[(&str, &str)]) -> Vec<PathBuf> {
        let names: Vec<&str> = files.iter().map(|f| f.0).collect();
        let s = stage(out, &names).unwrap();
        for (i, (_, text)) in files.iter().enumerate() {
            std::fs::write(s.file(i), text).unwrap();
        }
        s.publish().unwrap()
    }

    fn runs(out: &Path) -> Vec<String> {
        names(out)
            .into_iter()
            .filter(|n| n.starts_with(RUN_PREFIX))
            .collect()
    }

    #[test]
    fn a_second_run_replaces_the_whole_set_and_its_folder() {
        let d = tempfile::tempdir().unwrap();
        let placed = publish(d.path(), &[("a.txt", "1a"), ("b.txt", "1b")]);
        assert_eq!(placed, [d.path().join("a.txt"), d.path().join("b.txt")]);
        let first = runs(d.path());
        assert_eq!(first.len(), 1);
        publish(d.path(), &[("a.txt", "2a"), ("b.txt", "2b")]);
        assert_eq!(
            std::fs::read_to_string(d.path().join("a.txt")).unwrap(),
            "2a"
        );
        assert_eq!(
            std::fs::read_to_string(d.path().join("b.txt")).unwrap(),
            "2b"
        );
        let second = runs(d.path());
        assert_eq!(second.len(), 1, "{second:?}");
        assert_ne!(first, second);
        assert_eq!(
            names(d.path()),
            [CURRENT, second[0].as_str(), "a.txt", "b.txt"]
        );
    }

    #[test]
    fn an_unpublished_run_changes_nothing_and_leaves_nothing() {
        let d = tempfile::tempdir().unwrap();
        publish(d.path(), &[("a.txt", "1a")]);
        let before = names(d.path());
        let s = stage(d.path(), &["a.txt"]).unwrap();
        std::fs::write(s.file(0), "2a").unwrap();
        drop(s);
        assert_eq!(names(d.path()), before);
        assert_eq!(
            std::fs::read_to_string(d.path().join("a.txt")).unwrap(),
            "1a"
        );
    }

    #[test]
    fn a_missing_file_is_not_published() {
        let d = tempfile::tempdir().unwrap();
        let s = stage(d.path(), &["a.txt", "b.txt"]).unwrap();
        std::fs::write(s.file(0), "a").unwrap();
        let e = s.publish().unwrap_err().to_string();
        assert!(e.contains("b.txt: cannot publish this output"), "{e}");
        assert!(names(d.path()).is_empty(), "{:?}", names(d.path()));
    }

    #[test]
    fn stale_folders_go_and_live_ones_stay() {
        let d = tempfile::tempdir().unwrap();
        // A killed run: its folder's lock is free.
        let dead = d.path().join(format!("{RUN_PREFIX}dead01"));
        std::fs::create_dir(&dead).unwrap();
        std::fs::write(dead.join(LOCK), "").unwrap();
        std::fs::write(dead.join("a.txt"), "half").unwrap();
        std::fs::write(d.path().join(format!("{RUN_PREFIX}dead01.link0")), "").unwrap();
        // A live run in another process: its lock is held (flock locks are per open file,
        // so a second open in this process stands for the other process).
        let live = stage(d.path(), &["a.txt"]).unwrap();
        publish(d.path(), &[("a.txt", "new")]);
        assert!(!dead.exists());
        assert!(!d.path().join(format!("{RUN_PREFIX}dead01.link0")).exists());
        assert!(live.run_dir().is_dir());
        assert_eq!(runs(d.path()).len(), 2);
        drop(live);
        assert_eq!(runs(d.path()).len(), 1);
        assert_eq!(
            std::fs::read_to_string(d.path().join("a.txt")).unwrap(),
            "new"
        );
    }

    #[test]
    fn two_runs_publishing_at_once_leave_one_run_folder() {
        // Regression (CI of stop 29, `two_runs_into_one_folder_leave_one_complete_set`):
        // run a swaps in, run b swaps in and cleans while a still holds its lock, then a
        // ends. a's replaced folder was left behind.
        let d = tempfile::tempdir().unwrap();
        let staged = |text: &str| {
            let s = stage(d.path(), &["a.txt"]).unwrap();
            std::fs::write(s.file(0), text).unwrap();
            s
        };
        let a = staged("a");
        let b = staged("b");
        a.swap_in().unwrap();
        b.publish().unwrap();
        assert_eq!(runs(d.path()).len(), 2, "a still holds its lock");
        a.finish();
        assert_eq!(runs(d.path()).len(), 1, "{:?}", names(d.path()));
        assert_eq!(
            std::fs::read_to_string(d.path().join("a.txt")).unwrap(),
            "b"
        );
    }

    #[test]
    fn a_folder_killed_before_its_lock_goes_once_its_process_has() {
        let d = tempfile::tempdir().unwrap();
        // No lock file: killed between making the folder and locking it. A pid above the
        // kernel's limit (4,194,304) is no live process; this process's own pid is.
        let dead = d.path().join(format!("{RUN_PREFIX}4194400-abc123"));
        let alive = d
            .path()
            .join(format!("{RUN_PREFIX}{}-def456", std::process::id()));
        std::fs::create_dir(&dead).unwrap();
        std::fs::create_dir(&alive).unwrap();
        publish(d.path(), &[("a.txt", "new")]);
        assert!(!dead.exists());
        assert!(
            alive.exists(),
            "a young folder of a live process was removed"
        );
    }

    #[test]
    fn a_name_the_new_set_has_not_is_unlinked() {
        let d = tempfile::tempdir().unwrap();
        publish(d.path(), &[("rectified.laz", "l"), ("report.json", "1")]);
        publish(d.path(), &[("rectified.ply", "p"), ("report.json", "2")]);
        let visible: Vec<String> = names(d.path())
            .into_iter()
            .filter(|n| !n.starts_with('.'))
            .collect();
        assert_eq!(visible, ["rectified.ply", "report.json"]);
    }

    #[test]
    fn an_older_plain_file_is_replaced_by_the_link() {
        let d = tempfile::tempdir().unwrap();
        std::fs::write(d.path().join("a.txt"), "old version").unwrap();
        publish(d.path(), &[("a.txt", "new")]);
        assert_eq!(
            std::fs::read_to_string(d.path().join("a.txt")).unwrap(),
            "new"
        );
        assert!(
            std::fs::symlink_metadata(d.path().join("a.txt"))
                .unwrap()
                .is_symlink()
        );
    }

    #[test]
    fn a_folder_in_the_way_is_refused_before_anything_is_written() {
        let d = tempfile::tempdir().unwrap();
        std::fs::create_dir(d.path().join("b.txt")).unwrap();
        let e = stage(d.path(), &["a.txt", "b.txt"])
            .err()
            .unwrap()
            .to_string();
        assert!(e.contains("b.txt: cannot write this output"), "{e}");
        assert_eq!(names(d.path()), ["b.txt"]);
    }
}
