//! The engine's vector arithmetic: the number types vectorised code is written over once
//! ([`Real`], [`Lanes`]: one `f64`, four portable lanes, AVX2's register), the only code that
//! names an intrinsic, and which vector instructions the fast paths may use, the one place
//! every dispatch asks. The environment variable [`PORTABLE`] set to anything but `0` or empty forces the
//! portable code everywhere; the fast paths give the same bits as it (each is tested against
//! it), and CI runs the whole suite under the switch with the same pinned hashes.

use std::sync::OnceLock;

#[cfg(target_arch = "x86_64")]
mod avx2;
mod chacha;
mod lanes;
#[cfg(target_arch = "x86_64")]
mod ziggurat;

#[cfg(target_arch = "x86_64")]
pub use avx2::{Avx2, F64x4};
pub use chacha::chacha_state;
#[cfg(target_arch = "x86_64")]
pub use chacha::{chacha_blocks_8, chacha_blocks_16};
pub use lanes::{F64x4Portable, Lanes, Lanes4, Quad, Real, Scalar};
#[cfg(target_arch = "x86_64")]
pub use ziggurat::{ziggurat_candidates_4, ziggurat_candidates_8};

/// The environment variable that forces the portable code.
pub const PORTABLE: &str = "CHASSIS_MC_PORTABLE";

/// Whether [`PORTABLE`] forces the portable code (read once per process).
pub fn portable_forced() -> bool {
    static FORCED: OnceLock<bool> = OnceLock::new();
    *FORCED.get_or_init(|| std::env::var_os(PORTABLE).is_some_and(|v| !v.is_empty() && v != "0"))
}

/// Whether the AVX2 paths may run: the CPU has AVX2 and the portable code is not forced.
#[cfg(target_arch = "x86_64")]
pub fn avx2() -> bool {
    !portable_forced() && std::arch::is_x86_feature_detected!("avx2")
}

/// Whether the AVX-512F paths may run (as [`avx2`]).
#[cfg(target_arch = "x86_64")]
pub fn avx512f() -> bool {
    !portable_forced() && std::arch::is_x86_feature_detected!("avx512f")
}

/// Whether the AVX-512F with VL paths may run (as [`avx2`]).
#[cfg(target_arch = "x86_64")]
pub fn avx512vl() -> bool {
    avx512f() && std::arch::is_x86_feature_detected!("avx512vl")
}
