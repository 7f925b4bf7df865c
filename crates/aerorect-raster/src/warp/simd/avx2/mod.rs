//! The AVX2 build of the kernels, eight (or four) destination pixels per step: one file per
//! kernel (`nearest`, `bilinear`, `bicubic`) and per sample type (`u8`, `u16`, `f32`), the row
//! loop (`row`), and the pieces they share (`lanes`, `*_lanes`, `positions`, `sample`). The
//! AVX-512 steps are the sibling module `avx512`. See `warp/SIMD.md`.

pub(crate) mod bicubic;
pub(crate) mod bicubic_lanes;
pub(crate) mod bilinear;
pub(crate) mod bilinear_lanes;
pub(crate) mod cubic_positions;
pub(crate) mod f32;
pub(crate) mod lanes;
pub(crate) mod nearest;
pub(crate) mod nearest_lanes;
pub(crate) mod positions;
pub(crate) mod row;
pub(crate) mod sample;
pub(crate) mod scratch;
pub(crate) mod tail;
pub(crate) mod u16;
pub(crate) mod u8;
