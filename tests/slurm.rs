//! The cluster scripts (tools/slurm/, docs/cluster.md) on a real Slurm: a one-node cluster
//! on localhost (munged, slurmctld and slurmd from Debian's `munge` and `slurm-wlm`, with a
//! generated slurm.conf: the machine's CPUs, `proctrack/linuxproc`, `task/none`, no cgroups,
//! every state, spool and log folder in a temporary folder) runs `tools/slurm/submit.sh
//! --wait`: a simulate job array, the merge, the chain job, a render job array and the
//! encode. The merged capture must equal a single-process `femto simulate` file for file
//! and byte for byte, and the encoded MP4 a single-process `femto render`'s; a pipeline
//! whose first task fails must end with a non-zero status and no video. The daemons are
//! stopped when the test ends, pass or fail (a Drop guard).

#[path = "common/cli.rs"]
mod cli;

use cli::{files_under, FemtoCmd};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

/// The capture: small, with every imperfection, so the test adds well under a minute.
const SIM: &str = "--scene cube --size 32x24 --nt 64 --spp 4 --realistic";
/// The video: a dolly of 7 frames of 32x24.
const RENDER: &str = "--dolly 0.5 --size 32x24";
const FRAMES: &str = "7";

/// A program on PATH (or in /usr/sbin, where Debian puts the daemons).
fn program(name: &str) -> PathBuf {
    let path = std::env::var_os("PATH").unwrap_or_default();
    std::env::split_paths(&path)
        .chain([PathBuf::from("/usr/sbin")])
        .map(|d| d.join(name))
        .find(|p| p.is_file())
        .unwrap_or_else(|| panic!("{name} is not installed (apt-get install slurm-wlm munge)"))
}

/// A free TCP port on localhost (bound, read and released).
fn free_port() -> u16 {
    std::net::TcpListener::bind("127.0.0.1:0")
        .and_then(|l| l.local_addr())
        .expect("a free port")
        .port()
}

/// The daemons this test started, stopped (killed and reaped) when it is dropped.
struct Daemons {
    children: Vec<(String, Child)>,
    dir: PathBuf,
}

impl Daemons {
    fn start(&mut self, name: &str, args: &[&str]) {
        let log = std::fs::File::create(self.dir.join(format!("{name}.out"))).unwrap();
        let child = Command::new(program(name))
            .args(args)
            .env("SLURM_CONF", self.dir.join("slurm.conf"))
            .stdin(Stdio::null())
            .stdout(log.try_clone().unwrap())
            .stderr(log)
            .spawn()
            .unwrap_or_else(|e| panic!("{name}: {e}"));
        self.children.push((name.to_string(), child));
    }

    /// The daemons' logs, for a failure message.
    fn logs(&self) -> String {
        let mut text = String::new();
        for name in [
            "munged.out",
            "slurmctld.log",
            "slurmd.log",
            "slurmctld.out",
            "slurmd.out",
        ] {
            let body = std::fs::read_to_string(self.dir.join(name)).unwrap_or_default();
            let tail: Vec<&str> = body.lines().rev().take(15).collect();
            text += &format!("--- {name}\n");
            for l in tail.into_iter().rev() {
                text += l;
                text += "\n";
            }
        }
        text
    }
}

impl Drop for Daemons {
    fn drop(&mut self) {
        // Jobs still queued or running (a failed test) go first, while slurmctld is up.
        if self.children.len() == 3 {
            let _ = Command::new(program("scancel"))
                .args(["--full", "--user"])
                .arg(
                    String::from_utf8_lossy(
                        &Command::new("id")
                            .arg("-un")
                            .output()
                            .map_or(vec![], |o| o.stdout),
                    )
                    .trim(),
                )
                .env("SLURM_CONF", self.dir.join("slurm.conf"))
                .output();
            std::thread::sleep(Duration::from_millis(500));
        }
        // Newest first: slurmd, slurmctld, then munged.
        for (_, child) in self.children.iter_mut().rev() {
            let _ = child.kill();
            let _ = child.wait();
        }
    }
}

fn slurm_conf(dir: &Path) -> String {
    let host = Command::new("hostname").arg("-s").output().unwrap();
    let host = String::from_utf8_lossy(&host.stdout).trim().to_string();
    let user = Command::new("id").arg("-un").output().unwrap();
    let user = String::from_utf8_lossy(&user.stdout).trim().to_string();
    let cpus = std::thread::available_parallelism().map_or(1, |n| n.get());
    let d = dir.display();
    format!(
        "ClusterName=femtotest\n\
         SlurmctldHost={host}\n\
         SlurmctldPort={ctld}\n\
         SlurmdPort={slurmd}\n\
         AuthType=auth/munge\n\
         AuthInfo=socket={d}/munge/munge.sock\n\
         CredType=cred/munge\n\
         SlurmUser={user}\n\
         SlurmdUser={user}\n\
         StateSaveLocation={d}/state\n\
         SlurmdSpoolDir={d}/spool\n\
         SlurmctldPidFile={d}/slurmctld.pid\n\
         SlurmdPidFile={d}/slurmd.pid\n\
         SlurmctldLogFile={d}/slurmctld.log\n\
         SlurmdLogFile={d}/slurmd.log\n\
         ProctrackType=proctrack/linuxproc\n\
         TaskPlugin=task/none\n\
         SwitchType=switch/none\n\
         MpiDefault=none\n\
         SchedulerType=sched/builtin\n\
         SelectType=select/cons_tres\n\
         SelectTypeParameters=CR_CPU\n\
         ReturnToService=2\n\
         JobCompType=jobcomp/none\n\
         AccountingStorageType=accounting_storage/none\n\
         JobAcctGatherType=jobacct_gather/none\n\
         NodeName={host} NodeAddr=127.0.0.1 CPUs={cpus} RealMemory=1000 State=UNKNOWN\n\
         PartitionName=debug Nodes={host} Default=YES MaxTime=INFINITE State=UP\n",
        ctld = free_port(),
        slurmd = free_port(),
    )
}

/// Start munged, slurmctld and slurmd for a one-node cluster in `dir`, and wait until the
/// node is idle.
fn start_cluster(dir: &Path) -> Daemons {
    for sub in ["state", "spool", "munge", "key"] {
        std::fs::create_dir_all(dir.join(sub)).unwrap();
    }
    std::fs::write(dir.join("slurm.conf"), slurm_conf(dir)).unwrap();
    let key = dir.join("key/munge.key");
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        std::fs::set_permissions(dir.join("key"), std::fs::Permissions::from_mode(0o700)).unwrap();
    }
    let made = Command::new(program("mungekey"))
        .args(["-c", "-k"])
        .arg(&key)
        .output()
        .unwrap();
    assert!(made.status.success(), "mungekey: {made:?}");
    let mut daemons = Daemons {
        children: Vec::new(),
        dir: dir.to_path_buf(),
    };
    let at = |p: &str| dir.join(p).display().to_string();
    daemons.start(
        "munged",
        &[
            "-F",
            "-f",
            &format!("--socket={}", at("munge/munge.sock")),
            &format!("--key-file={}", key.display()),
            &format!("--log-file={}", at("munge/munged.log")),
            &format!("--pid-file={}", at("munge/munged.pid")),
            &format!("--seed-file={}", at("munge/munged.seed")),
        ],
    );
    wait_for(&daemons, "the munge socket", || {
        dir.join("munge/munge.sock").exists()
    });
    let conf = at("slurm.conf");
    daemons.start("slurmctld", &["-D", "-i", "-f", &conf]);
    daemons.start("slurmd", &["-D", "-f", &conf]);
    wait_for(&daemons, "an idle node", || {
        Command::new(program("sinfo"))
            .args(["-h", "-o", "%T"])
            .env("SLURM_CONF", &conf)
            .output()
            .is_ok_and(|o| String::from_utf8_lossy(&o.stdout).trim() == "idle")
    });
    daemons
}

fn wait_for(daemons: &Daemons, what: &str, ready: impl Fn() -> bool) {
    let start = Instant::now();
    while !ready() {
        assert!(
            start.elapsed() < Duration::from_secs(60),
            "no {what} after 60 s:\n{}",
            daemons.logs()
        );
        std::thread::sleep(Duration::from_millis(200));
    }
}

#[test]
#[cfg_attr(
    femto_skip_slurm,
    ignore = "needs Slurm and munge on PATH (apt-get install slurm-wlm munge)"
)]
fn slurm_job_arrays_merge_and_encode_as_one_process_would() {
    let tmp = tempfile::tempdir().unwrap();
    let cluster = tmp.path().join("cluster");
    let daemons = start_cluster(&cluster);
    let work = tmp.path().join("work");
    let femto = env!("CARGO_BIN_EXE_femto");
    let repo = Path::new(env!("CARGO_MANIFEST_DIR"));
    let started = Instant::now();
    let run = Command::new(repo.join("tools/slurm/submit.sh"))
        .args([
            "--work",
            work.to_str().unwrap(),
            "--bands",
            "3",
            "--parts",
            "2",
        ])
        .args(["--sim", SIM, "--render", RENDER, "--frames", FRAMES])
        .args(["--femto", femto, "--wait"])
        .env("SLURM_CONF", cluster.join("slurm.conf"))
        .output()
        .unwrap();
    let seconds = started.elapsed().as_secs_f64();
    let logs = files_under(&work.join("logs"))
        .into_iter()
        .map(|(k, v)| format!("--- {}\n{}", k.display(), String::from_utf8_lossy(&v)))
        .collect::<String>();
    assert!(
        run.status.success(),
        "submit.sh: {:?}\n{}{}\njob logs:\n{logs}\ndaemons:\n{}",
        run.status,
        String::from_utf8_lossy(&run.stdout),
        String::from_utf8_lossy(&run.stderr),
        daemons.logs()
    );
    println!("{}", String::from_utf8_lossy(&run.stdout));
    println!("submit.sh --wait: {seconds:.1} s");

    // A failing task (simulate refuses --spp 0) fails the pipeline: Slurm cancels the jobs
    // after it and submit.sh --wait says so with a non-zero status.
    let failed_work = tmp.path().join("failed");
    let failed = Command::new(repo.join("tools/slurm/submit.sh"))
        .args([
            "--work",
            failed_work.to_str().unwrap(),
            "--bands",
            "2",
            "--parts",
            "2",
        ])
        .args([
            "--sim",
            "--scene cube --size 32x24 --spp 0",
            "--render",
            RENDER,
        ])
        .args(["--frames", FRAMES, "--femto", femto, "--wait"])
        .env("SLURM_CONF", cluster.join("slurm.conf"))
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&failed.stderr);
    assert_eq!(failed.status.code(), Some(1), "a failed task: {stderr}");
    assert!(stderr.contains("a job failed or was cancelled"), "{stderr}");
    assert!(!failed_work.join("video.mp4").exists());
    drop(daemons);

    // The same capture in one process, from a folder of its own with the same --out, so
    // that it records the same command line.
    let single = tmp.path().join("single");
    std::fs::create_dir(&single).unwrap();
    let mut sim: Vec<&str> = vec!["simulate"];
    sim.extend(SIM.split(' '));
    sim.extend(["--out", "capture"]);
    FemtoCmd::new().args(&sim).current_dir(&single).ok();
    let whole = files_under(&single.join("capture"));
    let merged = files_under(&work.join("capture"));
    assert_eq!(
        merged.keys().collect::<Vec<_>>(),
        whole.keys().collect::<Vec<_>>()
    );
    for (name, bytes) in &whole {
        assert!(merged[name] == *bytes, "capture/{} differs", name.display());
    }
    // The video in one process, from the cluster's world-time cube.
    let mut render: Vec<&str> = vec![
        "render",
        "--cube",
        "world.h5",
        "--calibration",
        "cube.calibration.toml",
        "--mesh",
        "capture/scene.glb",
    ];
    render.extend(RENDER.split(' '));
    render.extend(["--frame-count", FRAMES, "--out", "single.mp4"]);
    FemtoCmd::new().args(&render).current_dir(&work).ok();
    let video = std::fs::read(work.join("video.mp4")).unwrap();
    assert!(!video.is_empty());
    assert!(
        video == std::fs::read(work.join("single.mp4")).unwrap(),
        "video.mp4 (encoded from the render job array's parts) differs from single.mp4"
    );
}
