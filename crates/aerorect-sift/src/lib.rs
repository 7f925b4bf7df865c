//! CPU SIFT: kornia-imgproc 0.2's port of OpenCV's `cv::SIFT` (Apache-2.0, kornia.org), forked
//! so that its x86 paths vectorise. Upstream vectorises its Gaussian blur with NEON intrinsics
//! and leaves every other target a scalar loop whose inner loop runs over the kernel's taps: a
//! serial chain of fused multiply-adds per output, 40 % of a frame's time on x86. The fork
//! swaps the loops there (outputs inner, taps outer), which keeps each output's sequence of
//! operations, and so its bits, and lets the compiler vectorise across outputs; see
//! `scalespace.rs`. The descriptor's patch collection and scatter and the batch exponential,
//! magnitude and angle get AVX2 lanes that repeat the scalar operations (`src/lanes_tests.rs`
//! compares them value by value). Everything else is upstream's code as published, with its
//! tests (which need upstream's reference dumps) left out; `tests/upstream.rs` holds the fork
//! to kornia-imgproc bit for bit. README.md lists the changes.

mod params;
pub(crate) use params::refl101;
pub use params::{SiftConfig, SiftConfigError};

mod pipeline;
pub use pipeline::{
    detect_and_compute as sift_detect_and_compute, FirstOctave, SiftFeatures, SiftKeypoint,
    SiftWorkspace,
};

mod descriptor;
pub use descriptor::DESCR_LEN;

mod scatter;

#[cfg(test)]
mod lanes_tests;

mod hal;

mod detect;

mod orient;

mod scalespace;
