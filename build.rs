//! Build script: tells the tests which SIMD paths the build machine's CPU runs, so that a
//! test of a path this CPU lacks is `#[ignore]`d with the reason instead of passing without
//! running (`cfg(femto_host_avx)`: AVX, the eight-wide BVH's lanes; `cfg(femto_host_avx2)`: every feature of `SimdLevel::Avx2`;
//! `cfg(femto_host_avx512)`: those of `SimdLevel::Avx512`). A test binary built here and run
//! on a CPU without the feature fails instead of skipping. The library itself never reads
//! these: it detects the CPU at run time.
//!
//! It also tells the tests which outside inputs this machine lacks, so that `cargo test`'s
//! summary counts a test that needs one as ignored, with the reason, rather than as a pass
//! that checked nothing: `cfg(femto_skip_shared)` (no shared data folder: `$FEMTO_SHARED`,
//! else `../shared`), `cfg(femto_skip_interop)` (no `$FEMTO_INTEROP_PYTHON`),
//! `cfg(femto_skip_browser)` (no `chromium` or `chromedriver` on `PATH`),
//! `cfg(femto_skip_slurm)` (no Slurm daemons and commands or no munge on `PATH`: Debian's
//! `slurm-wlm` and `munge`). Under `CI=true`
//! none is set: there a missing input fails its test.

use std::path::{Path, PathBuf};

fn main() {
    println!("cargo::rerun-if-changed=build.rs");
    outside_inputs();
    println!("cargo::rustc-check-cfg=cfg(femto_host_avx)");
    println!("cargo::rustc-check-cfg=cfg(femto_host_avx2)");
    println!("cargo::rustc-check-cfg=cfg(femto_host_avx512)");
    if std::env::var("CARGO_CFG_TARGET_ARCH").as_deref() != Ok("x86_64") {
        return;
    }
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::is_x86_feature_detected as has;
        if has!("avx") {
            println!("cargo::rustc-cfg=femto_host_avx");
        }
        let avx2 = has!("avx")
            && has!("avx2")
            && has!("bmi1")
            && has!("bmi2")
            && has!("lzcnt")
            && has!("popcnt");
        if avx2 {
            println!("cargo::rustc-cfg=femto_host_avx2");
            if has!("avx512f") && has!("avx512vl") {
                println!("cargo::rustc-cfg=femto_host_avx512");
            }
        }
    }
}

/// Sets the `femto_skip_*` cfgs for the outside inputs that are missing (none under `CI=true`).
fn outside_inputs() {
    for name in [
        "femto_skip_shared",
        "femto_skip_interop",
        "femto_skip_browser",
        "femto_skip_slurm",
    ] {
        println!("cargo::rustc-check-cfg=cfg({name})");
    }
    println!("cargo::rerun-if-env-changed=CI");
    if std::env::var("CI").is_ok_and(|v| v == "true") {
        // Nothing below is read: no rerun when PATH changes (CI's Python step puts the
        // virtual environment first on PATH, and a rerun would compile femto again).
        return;
    }
    for var in ["FEMTO_SHARED", "FEMTO_INTEROP_PYTHON", "PATH"] {
        println!("cargo::rerun-if-env-changed={var}");
    }
    let shared = match std::env::var_os("FEMTO_SHARED") {
        Some(d) => PathBuf::from(d),
        None => {
            Path::new(&std::env::var_os("CARGO_MANIFEST_DIR").unwrap_or_default()).join("../shared")
        }
    };
    // Rerun when the folder appears or goes (a path that does not exist reruns every build).
    println!("cargo::rerun-if-changed={}", shared.display());
    if !shared.is_dir() {
        println!("cargo::rustc-cfg=femto_skip_shared");
    }
    let python = std::env::var_os("FEMTO_INTEROP_PYTHON").map(PathBuf::from);
    if !python.is_some_and(|p| p.is_file()) {
        println!("cargo::rustc-cfg=femto_skip_interop");
    }
    let on_path = |names: &[&str]| {
        std::env::var_os("PATH").is_some_and(|path| {
            std::env::split_paths(&path).any(|dir| names.iter().any(|n| dir.join(n).is_file()))
        })
    };
    if !on_path(&["chromedriver"]) || !on_path(&["chromium", "chromium-browser", "google-chrome"]) {
        println!("cargo::rustc-cfg=femto_skip_browser");
    }
    let slurm = [
        "munged",
        "mungekey",
        "slurmctld",
        "slurmd",
        "sbatch",
        "sinfo",
    ];
    if !slurm.iter().all(|p| on_path(&[p])) {
        println!("cargo::rustc-cfg=femto_skip_slurm");
    }
}
