//! Build script: tells the tests which SIMD paths the build machine's CPU runs, so that a
//! test of a path this CPU lacks is `#[ignore]`d with the reason instead of passing without
//! running (`cfg(femto_host_avx)`: AVX, the eight-wide BVH's lanes; `cfg(femto_host_avx2)`: every feature of `SimdLevel::Avx2`;
//! `cfg(femto_host_avx512)`: those of `SimdLevel::Avx512`). A test binary built here and run
//! on a CPU without the feature fails instead of skipping. The library itself never reads
//! these: it detects the CPU at run time.

fn main() {
    println!("cargo::rerun-if-changed=build.rs");
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
            && has!("popcnt")
            && has!("gfni");
        if avx2 {
            println!("cargo::rustc-cfg=femto_host_avx2");
            if has!("avx512f") && has!("avx512vl") {
                println!("cargo::rustc-cfg=femto_host_avx512");
            }
        }
    }
}
