//! The instruction sets of this CPU, for the loops built twice (plain, and for AVX2).

/// Whether the CPU has AVX2 (false off x86-64).
pub(crate) fn avx2() -> bool {
    #[cfg(target_arch = "x86_64")]
    return std::arch::is_x86_feature_detected!("avx2");
    #[cfg(not(target_arch = "x86_64"))]
    false
}

/// Whether the CPU has AVX-512 with byte permutes and byte dot products (F, BW, VL, VBMI and
/// VNNI: Ice Lake, Zen 4 and later; false off x86-64).
pub(crate) fn avx512_vbmi_vnni() -> bool {
    #[cfg(target_arch = "x86_64")]
    return std::arch::is_x86_feature_detected!("avx512f")
        && std::arch::is_x86_feature_detected!("avx512bw")
        && std::arch::is_x86_feature_detected!("avx512vl")
        && std::arch::is_x86_feature_detected!("avx512vbmi")
        && std::arch::is_x86_feature_detected!("avx512vnni");
    #[cfg(not(target_arch = "x86_64"))]
    false
}
