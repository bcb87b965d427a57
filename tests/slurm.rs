//! The cluster scripts (tools/slurm/, docs/cluster.md) on a real Slurm: the one-node cluster
//! on localhost that docs/cluster.md's "Try it on one machine" starts, with the same script
//! (`tools/slurm/one-node.sh start`: munged, slurmctld and slurmd from Debian's `munge` and
//! `slurm-wlm`, configured from `tools/slurm/one-node.conf`: the machine's CPUs,
//! `proctrack/linuxproc`, `task/none`, no cgroups, every state, spool and log folder in a
//! temporary folder; here on free ports), runs `tools/slurm/submit.sh --wait`: a simulate
//! job array, the merge, the chain job, a render job array and the encode. The merged
//! capture must equal a single-process `femto simulate` file for file and byte for byte, and
//! the encoded MP4 a single-process `femto render`'s; a pipeline whose first task fails must
//! end with a non-zero status, no video and no video line. The daemons are stopped when the
//! test ends, pass or fail (a Drop guard running `one-node.sh stop`).

#[path = "common/cli.rs"]
mod cli;

use cli::{files_under, FemtoCmd};
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;

/// The capture: small, with every imperfection, so the test adds well under a minute.
const SIM: &str = "--scene cube --size 32x24 --nt 64 --spp 4 --realistic";
/// The video: a dolly of 7 frames of 32x24.
const RENDER: &str = "--dolly 0.5 --size 32x24";
const FRAMES: &str = "7";

fn repo() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

/// A free TCP port on localhost (bound, read and released).
fn free_port() -> u16 {
    std::net::TcpListener::bind("127.0.0.1:0")
        .and_then(|l| l.local_addr())
        .expect("a free port")
        .port()
}

/// The one-node Slurm of `tools/slurm/one-node.sh` in `dir`, stopped by the same script
/// when dropped.
struct Cluster {
    dir: PathBuf,
}

impl Cluster {
    fn start(dir: &Path) -> Cluster {
        let out = Command::new(repo().join("tools/slurm/one-node.sh"))
            .arg("start")
            .arg(dir)
            .env("SLURMCTLD_PORT", free_port().to_string())
            .env("SLURMD_PORT", free_port().to_string())
            .output()
            .expect("tools/slurm/one-node.sh");
        let cluster = Cluster {
            dir: dir.to_path_buf(),
        };
        assert!(
            out.status.success(),
            "one-node.sh start: {:?}\n{}{}",
            out.status,
            String::from_utf8_lossy(&out.stdout),
            String::from_utf8_lossy(&out.stderr)
        );
        cluster
    }

    fn conf(&self) -> PathBuf {
        self.dir.join("slurm.conf")
    }

    /// The daemons' logs, for a failure message.
    fn logs(&self) -> String {
        let mut text = String::new();
        for name in ["munge/munged.log", "slurmctld.log", "slurmd.log"] {
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

impl Drop for Cluster {
    fn drop(&mut self) {
        let _ = Command::new(repo().join("tools/slurm/one-node.sh"))
            .arg("stop")
            .arg(&self.dir)
            .output();
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
    let daemons = Cluster::start(&cluster);
    let work = tmp.path().join("work");
    let femto = env!("CARGO_BIN_EXE_femto");
    let repo = repo();
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
        .env("SLURM_CONF", daemons.conf())
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
        .env("SLURM_CONF", daemons.conf())
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&failed.stderr);
    assert_eq!(failed.status.code(), Some(1), "a failed task: {stderr}");
    assert!(stderr.contains("a job failed or was cancelled"), "{stderr}");
    assert!(!failed_work.join("video.mp4").exists());
    let stdout = String::from_utf8_lossy(&failed.stdout);
    assert!(
        !stdout.contains("video:"),
        "a failed run names no video: {stdout}"
    );

    // submit.sh's own default --sim (no --size in it) is submitted as it is: its rows come
    // from the default's explicit size. Submitted only, then cancelled.
    let default_work = tmp.path().join("default");
    let submitted = Command::new(repo.join("tools/slurm/submit.sh"))
        .args(["--work", default_work.to_str().unwrap(), "--femto", femto])
        .env("SLURM_CONF", daemons.conf())
        .output()
        .unwrap();
    assert!(
        submitted.status.success(),
        "submit.sh with its default --sim: {}",
        String::from_utf8_lossy(&submitted.stderr)
    );
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
