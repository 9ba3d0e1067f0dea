//! Issue 14: a plan runs through a real batch engine. Starts a single-node Slurm cluster on
//! this machine (Debian's slurm-wlm and munge: munged, slurmctld and slurmd on free ports,
//! every file in a temporary folder), submits the plan's generated `sbatch.sh` with `sbatch
//! --wait`, merges and compares with the untiled run; also runs the same plan with `xargs
//! -P 2`. Without Slurm (or not as root: the daemons run as root here) the Slurm part says
//! why and skips, unless SHARPEDGE_REQUIRE_SLURM=1 (CI installs Slurm and sets it).

mod tiles_common;

use std::net::TcpListener;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use tiles_common::*;

/// Where Debian installs the daemons (not on a user's PATH).
fn find(program: &str) -> Option<PathBuf> {
    let path = std::env::var_os("PATH").unwrap_or_default();
    std::env::split_paths(&path)
        .chain(["/usr/sbin", "/usr/bin", "/sbin"].map(PathBuf::from))
        .map(|d| d.join(program))
        .find(|p| p.is_file())
}

/// Kills the daemons it started (by their own process ids) when dropped.
struct Daemons(Vec<Child>);

impl Drop for Daemons {
    fn drop(&mut self) {
        for c in &mut self.0 {
            let _ = c.kill();
            let _ = c.wait();
        }
    }
}

fn free_port() -> u16 {
    TcpListener::bind("127.0.0.1:0")
        .and_then(|l| l.local_addr())
        .map(|a| a.port())
        .expect("a free port")
}

fn skip_or_fail(why: &str) {
    if std::env::var_os("SHARPEDGE_REQUIRE_SLURM").is_some_and(|v| v == "1") {
        panic!("SHARPEDGE_REQUIRE_SLURM=1 but {why}");
    }
    // Straight to the process's stderr, not through eprintln!: the test harness keeps what a
    // passing test prints with eprintln! to itself, and a skipped Slurm run must show in a
    // plain `cargo test`.
    use std::io::Write;
    let _ = writeln!(
        std::io::stderr(),
        "tiles_slurm: SKIPPED the Slurm part (the xargs part ran): {why} (apt-get install \
         slurm-wlm munge, and run as root; SHARPEDGE_REQUIRE_SLURM=1 makes this a failure)"
    );
}

/// The last lines of the test cluster's logs, for a failure message (the folder is removed
/// when the test unwinds).
fn log_tails(dir: &Path) -> String {
    let mut out = String::new();
    for name in ["munged.log", "slurmctld.log", "slurmd.log"] {
        let text = std::fs::read_to_string(dir.join(name)).unwrap_or_default();
        let lines: Vec<&str> = text.lines().collect();
        out += &format!("\n--- {name} (last lines)\n");
        out += &lines[lines.len().saturating_sub(15)..].join("\n");
    }
    out
}

/// Starts munged, slurmctld and slurmd for one node named after this host; returns the
/// daemons and the slurm.conf to point SLURM_CONF at.
fn start_cluster(dir: &Path, bins: &[PathBuf; 3]) -> (Daemons, PathBuf) {
    let [munged, slurmctld, slurmd] = bins;
    let host = String::from_utf8(Command::new("hostname").arg("-s").output().unwrap().stdout)
        .unwrap()
        .trim()
        .to_string();
    for sub in ["state", "spool"] {
        std::fs::create_dir_all(dir.join(sub)).unwrap();
    }
    // Our own munge key: any 1024 bytes, readable by root only.
    let key = dir.join("munge.key");
    let bytes: Vec<u8> = (0..1024u32)
        .map(|i| (i.wrapping_mul(2654435761) >> 13) as u8)
        .collect();
    std::fs::write(&key, bytes).unwrap();
    use std::os::unix::fs::PermissionsExt;
    std::fs::set_permissions(&key, std::fs::Permissions::from_mode(0o600)).unwrap();
    let socket = dir.join("munge.sock");
    let d = dir.display();
    let conf = format!(
        "ClusterName=sharpedgetest\nSlurmctldHost={host}(127.0.0.1)\nSlurmUser=root\n\
         SlurmdUser=root\nSlurmctldPort={}\nSlurmdPort={}\nAuthType=auth/munge\n\
         AuthInfo=socket={}\nCredType=cred/munge\nStateSaveLocation={d}/state\n\
         SlurmdSpoolDir={d}/spool\nSlurmctldPidFile={d}/slurmctld.pid\n\
         SlurmdPidFile={d}/slurmd.pid\nProctrackType=proctrack/linuxproc\nTaskPlugin=task/none\n\
         ReturnToService=2\nSchedulerType=sched/builtin\nSelectType=select/cons_tres\n\
         SelectTypeParameters=CR_Core\nMpiDefault=none\nJobCompType=jobcomp/none\n\
         AccountingStorageType=accounting_storage/none\nSlurmctldLogFile={d}/slurmctld.log\n\
         SlurmdLogFile={d}/slurmd.log\nNodeName={host} NodeAddr=127.0.0.1 CPUs=2 State=UNKNOWN\n\
         PartitionName=test Nodes={host} Default=YES MaxTime=INFINITE State=UP\n",
        free_port(),
        free_port(),
        socket.display()
    );
    let conf_path = dir.join("slurm.conf");
    std::fs::write(&conf_path, conf).unwrap();
    let spawn = |cmd: &mut Command| {
        cmd.stdout(Stdio::null())
            .stderr(Stdio::null())
            .env("SLURM_CONF", &conf_path)
            .spawn()
            .expect("start a Slurm daemon")
    };
    let mut daemons = Daemons(Vec::new());
    daemons.0.push(spawn(
        Command::new(munged)
            .arg("--foreground")
            .arg("--force")
            .arg(format!("--socket={}", socket.display()))
            .arg(format!("--key-file={}", key.display()))
            .arg(format!("--pid-file={d}/munged.pid"))
            .arg(format!("--log-file={d}/munged.log"))
            .arg(format!("--seed-file={d}/munged.seed")),
    ));
    let wait_for = |what: &str, ready: &dyn Fn() -> bool| {
        let start = Instant::now();
        while !ready() {
            assert!(
                start.elapsed() < Duration::from_secs(60),
                "{what} did not come up within 60 s:{}",
                log_tails(dir)
            );
            std::thread::sleep(Duration::from_millis(200));
        }
    };
    wait_for("munged", &|| socket.exists());
    daemons.0.push(spawn(
        Command::new(slurmctld).arg("-D").arg("-f").arg(&conf_path),
    ));
    daemons.0.push(spawn(
        Command::new(slurmd)
            .arg("-D")
            .arg("-f")
            .arg(&conf_path)
            .arg("-N")
            .arg(&host),
    ));
    wait_for("the node", &|| {
        Command::new("sinfo")
            .args(["-h", "-o", "%T"])
            .env("SLURM_CONF", &conf_path)
            .output()
            .is_ok_and(|o| String::from_utf8_lossy(&o.stdout).trim() == "idle")
    });
    (daemons, conf_path)
}

#[test]
fn a_plan_runs_as_a_slurm_job_array_and_with_xargs() {
    let tmp = tempfile::tempdir().unwrap();
    let d = tmp.path();
    let cfg = config(d, 5.0);
    let cfg = cfg.to_str().unwrap();
    ok(
        d,
        &[
            "-q", "synth", "--part", "box", "--points", "200000", "--out", "box.ply",
        ],
    );
    ok(
        d,
        &["-q", "run", cfg, "--input", "box.ply", "--out", "whole"],
    );
    let (we, wc) = features(&d.join("whole"));
    ok(
        d,
        &[
            "-q", "plan", cfg, "--input", "box.ply", "--out", "plan", "--grid", "2,2,1",
        ],
    );
    let script = std::fs::read_to_string(d.join("plan/sbatch.sh")).unwrap();
    assert!(script.contains("#SBATCH --array=0-3\n"), "{script}");

    // Any parallel runner: xargs -P 2, as the plan's summary says.
    let status = Command::new("sh")
        .current_dir(d)
        .arg("-c")
        .arg(format!(
            "seq 0 3 | xargs -P 2 -I{{}} '{BIN}' -q run plan/pipeline.toml --plan plan --tile {{}}"
        ))
        .status()
        .unwrap();
    assert!(status.success());
    ok(d, &["-q", "merge", "plan", "--out", "merged-xargs"]);
    let (me, mc) = features(&d.join("merged-xargs"));
    assert_eq!((me.len(), mc.len()), (we.len(), wc.len()));
    assert!(worst_match(&we, &me) <= 1e-4 && worst_match(&wc, &mc) <= 1e-4);

    // Slurm.
    let bins = ["munged", "slurmctld", "slurmd"].map(find);
    if bins.iter().any(Option::is_none) || find("sbatch").is_none() {
        return skip_or_fail("Slurm is not installed (munged, slurmctld, slurmd, sbatch)");
    }
    // SAFETY-free check of the user: `id -u`.
    let uid = Command::new("id").arg("-u").output().unwrap().stdout;
    if String::from_utf8_lossy(&uid).trim() != "0" {
        return skip_or_fail("the test cluster's daemons run as root and this is not root");
    }
    let bins = bins.map(Option::unwrap);
    let cluster = tempfile::tempdir().unwrap();
    let (_daemons, conf) = start_cluster(cluster.path(), &bins);
    ok(
        d,
        &[
            "-q", "plan", cfg, "--input", "box.ply", "--out", "splan", "--grid", "2,2,1",
        ],
    );
    let out = Command::new("sbatch")
        .current_dir(d)
        .env("SLURM_CONF", &conf)
        .args(["--wait", "splan/sbatch.sh"])
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "sbatch --wait failed: {}{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr),
        log_tails(cluster.path())
    );
    for t in 0..4 {
        assert!(
            d.join(format!("splan/logs/tile-{t}.log")).exists(),
            "no log of task {t}"
        );
    }
    ok(d, &["-q", "merge", "splan", "--out", "merged-slurm"]);
    let (se, sc) = features(&d.join("merged-slurm"));
    assert_eq!((se.len(), sc.len()), (we.len(), wc.len()));
    // The same tiles as with xargs: the same result, bit for bit.
    assert_eq!(
        std::fs::read(d.join("merged-slurm/features.ply")).unwrap(),
        std::fs::read(d.join("merged-xargs/features.ply")).unwrap()
    );
}
