//! The AVX2 bilinear kernel: one block, eight pixels per step (sixteen with AVX-512 where the
//! block is all inside).

use super::lanes::{Consts, store_flags};
use super::positions::{Positions, inside_run};
use super::sample::SimdSample;
use crate::warp::portable::Bilinear;
use crate::warp::simd::avx512::bilinear::bilinear_inside16;
use crate::warp::types::SourceGeometry;

/// Bilinear for one block: `pos` the source positions, `planes` the source bands, `outs` the
/// destination bands (as long as `pos`); `valid` receives the inside flags.
///
/// # Safety
/// AVX2; the source at least 2 x 2 (`g.width, g.height >= 2`), every plane `g.width * g.height`.
#[target_feature(enable = "avx2")]
pub(crate) unsafe fn bilinear_block<T: SimdSample, P: Positions>(
    g: &SourceGeometry,
    pos: &P,
    planes: &[&[T]],
    outs: &mut [&mut [T]],
    valid: &mut [bool],
    nodata: T,
) {
    let n = pos.len().min(valid.len());
    let k = Consts::new(g);
    let mut i = 0;
    if let Some(whole) = inside_run(&k, pos, n) {
        valid[..whole].fill(true);
        if let (true, Some(buffered)) = (g.avx512, pos.buffered()) {
            // SAFETY: `g.avx512`: the CPU has AVX-512 F, BW, VL, VBMI, VNNI; as this function's
            // contract; every pixel of the whole steps is inside.
            i = unsafe { bilinear_inside16(&k, buffered, planes, outs, whole, nodata) };
        }
        while i < whole {
            // SAFETY: i + 8 <= whole <= n; every pixel of the whole steps is inside.
            let t = unsafe { pos.bilinear_inside8(&k, i, T::WINDOWS) };
            for (plane, out) in planes.iter().zip(outs.iter_mut()) {
                // SAFETY: as this function's contract; i + 8 <= n = every output's length.
                unsafe { T::bilinear8(&k, &t, plane, out, i, nodata) };
            }
            i += 8;
        }
    }
    while i + 8 <= n {
        // SAFETY: i + 8 <= n.
        let t = unsafe { pos.bilinear8(&k, i, T::WINDOWS) };
        if t.mask == 0 {
            // All eight outside (common around an ortho's footprint): no loads.
            for out in outs.iter_mut() {
                out[i..i + 8].fill(nodata);
            }
        } else {
            for (plane, out) in planes.iter().zip(outs.iter_mut()) {
                // SAFETY: as this function's contract; i + 8 <= n = every output's length.
                unsafe { T::bilinear8(&k, &t, plane, out, i, nodata) };
            }
        }
        store_flags(valid, i, t.mask);
        i += 8;
    }
    pos.tail(i)
        .run::<Bilinear, T>(g, planes, outs, valid, nodata);
}
