//! The AVX-512 (F, BW, VL, VBMI, VNNI) steps over blocks whose pixels are all inside, sixteen
//! pixels per 512-bit vector, each the arithmetic of its AVX2 counterpart in the same order: one
//! file per kernel (`nearest`, `bilinear`, `bicubic`) and the pieces they share (`offsets`,
//! `rows`, `lanes`). The AVX2 kernels call them where the CPU has these extensions. See
//! `warp/SIMD.md`.

pub(crate) mod bicubic;
pub(crate) mod bilinear;
pub(crate) mod lanes;
pub(crate) mod nearest;
pub(crate) mod offsets;
pub(crate) mod rows;
#[cfg(test)]
mod tests;
