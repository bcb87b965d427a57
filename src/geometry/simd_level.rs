//! The SIMD path femto's dispatches take, chosen at run time: `FEMTO_SIMD` or a library
//! option, so that every path this CPU runs can be forced and compared with the scalar one.
//!
//! femto has two SIMD dispatches: the ray casting of [`crate::geometry::bvh`] (a four-wide
//! tree with plain arrays or SSE2 lanes, an eight-wide tree with AVX lanes, the same compiled
//! a second time for AVX-512) and the transient tracer's row loop ([`crate::tracer`]: a copy
//! compiled for AVX2, BMI1/2, LZCNT and POPCNT, and one with GFNI as well, which the rows
//! take where the CPU has it). A [`SimdLevel`] fixes both:
//!
//! | level    | BVH                                 | tracer rows                 | CPU features |
//! |----------|-------------------------------------|-----------------------------|--------------|
//! | `scalar` | four-wide, plain arrays             | baseline x86-64             | none |
//! | `sse`    | four-wide, SSE2                     | baseline                    | sse2 |
//! | `avx2`   | eight-wide, AVX                     | AVX2 + BMI build (+ GFNI)   | avx avx2 bmi1 bmi2 lzcnt popcnt |
//! | `avx512` | eight-wide, AVX compiled for AVX-512 | AVX2 + BMI build (+ GFNI)  | those and avx512f avx512vl |
//!
//! `scalar` is the code every other architecture runs. `auto` (or no `FEMTO_SIMD`) is what
//! femto does without being asked: each dispatch takes the widest path this CPU runs on its
//! own (on a CPU with AVX but not AVX2: the eight-wide AVX tree with the baseline rows, a
//! pair no named level selects). Asking for a level this CPU lacks is an error
//! ([`SimdError::Unsupported`]) rather than a fallback: a test or a benchmark that forces a
//! path must not silently run another. The `femto` binary checks `FEMTO_SIMD` before it does
//! anything else and exits with code 2 on a bad value; the library's constructors
//! ([`crate::geometry::bvh::Bvh::new`], and the tracer, which follows its BVH) use
//! [`SimdLevel::requested`], which reads it once and falls back to `auto` where it is not
//! valid.
//!
//! Paths that share a tree give the same hits bit for bit (`scalar` and `sse`; `avx2` and
//! `avx512`): every lane computes the scalar watertight test with the same rounding, and the
//! traversal visits the same nodes in the same order. The four- and eight-wide trees return
//! the same distance bit for bit and, on a tie of distance between two triangles, possibly
//! the other triangle. The two row builds compute the same operations in the same order (no
//! fused multiply-add), so tracer output is bit-identical across levels whenever the hits
//! are.

use std::fmt;

/// The environment variable that forces a level: `scalar`, `sse`, `avx2`, `avx512` or `auto`.
pub const ENV_VAR: &str = "FEMTO_SIMD";

/// A SIMD path of every dispatch (see the module doc for what each runs), narrowest first.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum SimdLevel {
    /// Plain arrays, four-wide BVH; baseline tracer rows.
    Scalar,
    /// SSE2 lanes, four-wide BVH; baseline tracer rows.
    Sse,
    /// AVX lanes, eight-wide BVH; tracer rows built for AVX2 and BMI (and GFNI where the CPU
    /// has it).
    Avx2,
    /// The eight-wide BVH compiled for AVX-512 F and VL; tracer rows as for `Avx2`.
    Avx512,
}

/// Errors of a requested SIMD level.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum SimdError {
    /// `FEMTO_SIMD` holds no level name.
    #[error("{ENV_VAR}={value:?}: unknown SIMD path (expected scalar, sse, avx2, avx512 or auto)")]
    Unknown { value: String },
    /// The CPU lacks a feature of the level asked for.
    #[error("SIMD path {level} asked for ({ENV_VAR} or option), but this CPU lacks {missing}")]
    Unsupported { level: SimdLevel, missing: String },
}

impl fmt::Display for SimdLevel {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl SimdLevel {
    /// Every level, narrowest first.
    pub const ALL: [SimdLevel; 4] = [
        SimdLevel::Scalar,
        SimdLevel::Sse,
        SimdLevel::Avx2,
        SimdLevel::Avx512,
    ];

    /// The name `FEMTO_SIMD` takes.
    pub fn name(self) -> &'static str {
        match self {
            SimdLevel::Scalar => "scalar",
            SimdLevel::Sse => "sse",
            SimdLevel::Avx2 => "avx2",
            SimdLevel::Avx512 => "avx512",
        }
    }

    /// Parse a `FEMTO_SIMD` value: `Ok(None)` for `auto` (and for an empty value).
    pub fn parse(value: &str) -> Result<Option<SimdLevel>, SimdError> {
        let v = value.trim();
        if v.is_empty() || v.eq_ignore_ascii_case("auto") {
            return Ok(None);
        }
        SimdLevel::ALL
            .into_iter()
            .find(|l| v.eq_ignore_ascii_case(l.name()))
            .map(Some)
            .ok_or_else(|| SimdError::Unknown {
                value: value.to_string(),
            })
    }

    /// The CPU features the level needs (names as `is_x86_feature_detected!` spells them).
    pub fn features(self) -> &'static [&'static str] {
        const AVX2: &[&str] = &["avx", "avx2", "bmi1", "bmi2", "lzcnt", "popcnt"];
        const AVX512: &[&str] = &[
            "avx", "avx2", "bmi1", "bmi2", "lzcnt", "popcnt", "avx512f", "avx512vl",
        ];
        match self {
            SimdLevel::Scalar => &[],
            SimdLevel::Sse => &["sse2"],
            SimdLevel::Avx2 => AVX2,
            SimdLevel::Avx512 => AVX512,
        }
    }

    /// The features of [`SimdLevel::features`] this CPU lacks (all of them off x86_64,
    /// `scalar` excepted).
    pub fn missing_features(self) -> Vec<&'static str> {
        self.features()
            .iter()
            .copied()
            .filter(|f| !cpu_has(f))
            .collect()
    }

    /// Whether this CPU runs every path of the level.
    pub fn is_supported(self) -> bool {
        self.missing_features().is_empty()
    }

    /// `Ok(self)` where the CPU runs the level, else [`SimdError::Unsupported`].
    pub fn check(self) -> Result<SimdLevel, SimdError> {
        let missing = self.missing_features();
        if missing.is_empty() {
            Ok(self)
        } else {
            Err(SimdError::Unsupported {
                level: self,
                missing: missing.join(", "),
            })
        }
    }

    /// The level `FEMTO_SIMD` asks for, checked against this CPU: `Ok(None)` when it is unset
    /// or `auto`.
    pub fn from_env() -> Result<Option<SimdLevel>, SimdError> {
        match std::env::var(ENV_VAR) {
            Ok(v) => SimdLevel::parse(&v)?.map(SimdLevel::check).transpose(),
            Err(std::env::VarError::NotPresent) => Ok(None),
            Err(std::env::VarError::NotUnicode(v)) => Err(SimdError::Unknown {
                value: v.to_string_lossy().into_owned(),
            }),
        }
    }

    /// The level the library's constructors use: [`SimdLevel::from_env`] read once per
    /// process, `None` (`auto`) where it is unset or not valid (the binary refuses those).
    pub fn requested() -> Option<SimdLevel> {
        static REQUESTED: std::sync::OnceLock<Option<SimdLevel>> = std::sync::OnceLock::new();
        *REQUESTED.get_or_init(|| SimdLevel::from_env().ok().flatten())
    }
}

/// Whether this CPU has `feature` (a name of [`SimdLevel::features`]).
fn cpu_has(feature: &str) -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        match feature {
            "sse2" => is_x86_feature_detected!("sse2"),
            "avx" => is_x86_feature_detected!("avx"),
            "avx2" => is_x86_feature_detected!("avx2"),
            "bmi1" => is_x86_feature_detected!("bmi1"),
            "bmi2" => is_x86_feature_detected!("bmi2"),
            "lzcnt" => is_x86_feature_detected!("lzcnt"),
            "popcnt" => is_x86_feature_detected!("popcnt"),
            "gfni" => is_x86_feature_detected!("gfni"),
            "avx512f" => is_x86_feature_detected!("avx512f"),
            "avx512vl" => is_x86_feature_detected!("avx512vl"),
            _ => false,
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        let _ = feature;
        false
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_parse_back_and_bad_names_are_refused() {
        for l in SimdLevel::ALL {
            assert_eq!(SimdLevel::parse(l.name()), Ok(Some(l)));
            assert_eq!(SimdLevel::parse(&l.name().to_uppercase()), Ok(Some(l)));
        }
        assert_eq!(SimdLevel::parse("auto"), Ok(None));
        assert_eq!(SimdLevel::parse(""), Ok(None));
        for bad in ["avx", "neon", "sse2", "avx-512"] {
            let e = SimdLevel::parse(bad).unwrap_err();
            assert!(e.to_string().contains("FEMTO_SIMD"), "{e}");
        }
    }

    #[test]
    fn scalar_runs_everywhere_and_levels_are_nested() {
        assert!(SimdLevel::Scalar.is_supported());
        assert_eq!(SimdLevel::Scalar.check(), Ok(SimdLevel::Scalar));
        // A wider level needs every feature of the narrower ones (but the scalar one).
        for w in SimdLevel::ALL.windows(2).skip(1) {
            for f in w[0].features() {
                assert!(w[1].features().contains(f) || *f == "sse2", "{f}");
            }
        }
    }

    #[cfg(target_arch = "x86_64")]
    #[test]
    fn support_is_what_the_cpu_reports() {
        use std::arch::is_x86_feature_detected as has;
        assert!(SimdLevel::Sse.is_supported());
        let avx2 = has!("avx")
            && has!("avx2")
            && has!("bmi1")
            && has!("bmi2")
            && has!("lzcnt")
            && has!("popcnt");
        assert_eq!(SimdLevel::Avx2.is_supported(), avx2);
        let avx512 = avx2 && has!("avx512f") && has!("avx512vl");
        assert_eq!(SimdLevel::Avx512.is_supported(), avx512);
        for l in SimdLevel::ALL {
            if let Err(SimdError::Unsupported { missing, .. }) = l.check() {
                assert!(!missing.is_empty());
            }
        }
    }
}
