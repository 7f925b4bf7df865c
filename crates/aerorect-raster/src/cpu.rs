//! The instruction sets of this CPU, for the loops built twice (plain, and for AVX2).

/// Whether the CPU has AVX2 (false off x86-64).
pub(crate) fn avx2() -> bool {
    #[cfg(target_arch = "x86_64")]
    return std::arch::is_x86_feature_detected!("avx2");
    #[cfg(not(target_arch = "x86_64"))]
    false
}
