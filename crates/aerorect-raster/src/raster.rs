//! Planar rasters of u8, u16 or f32 samples.

use crate::error::RasterError;
pub use crate::sample_kind::SampleKind;
use aerorect_core::ImageSize;
use rayon::prelude::*;

/// A sample type the warp engine can resample.
pub trait Sample: Copy + Default + Send + Sync + PartialEq + std::fmt::Debug + 'static {
    /// The type as a value.
    const KIND: SampleKind;
    /// The type's name in messages and reports.
    const NAME: &'static str = Self::KIND.name();
    /// The alpha value of a valid pixel (255, 65535 or 1.0).
    const OPAQUE: Self;
    fn to_f32(self) -> f32;
    /// From an interpolated value: rounded half up and saturated for integer types.
    fn from_f32(v: f32) -> Self;
    /// `Some` when `v` is exactly representable (used to validate nodata values).
    fn from_f64_exact(v: f64) -> Option<Self>;

    /// The integer weights `bilinear` blends with at fractions `f`, made once per pixel for
    /// all its bands (u8: `bilinear_weights_u8`); types that blend in f32 have none.
    #[doc(hidden)]
    #[inline(always)]
    fn bilinear_weights(_f: (f32, f32)) -> [i32; 4] {
        [0; 4]
    }

    /// The bilinear blend of taps `[p00, p01, p10, p11]` (upper left, upper right, lower left,
    /// lower right) at fractions `(fx, fy)` in [0, 1], `w` being `bilinear_weights((fx, fy))`:
    /// along x, then y, in f32, then `from_f32`.
    #[doc(hidden)]
    #[inline(always)]
    fn bilinear(p: [Self; 4], (fx, fy): (f32, f32), _w: [i32; 4]) -> Self {
        let [p00, p01, p10, p11] = p.map(Self::to_f32);
        let top = p00 + fx * (p01 - p00);
        let bottom = p10 + fx * (p11 - p10);
        Self::from_f32(top + fy * (bottom - top))
    }
}

/// u8's bilinear weights are integers summing to about 2^`U8_WEIGHT_BITS`.
pub(crate) const U8_WEIGHT_BITS: u32 = 22;

/// u8's four bilinear weights at fractions `(fx, fy)` in [0, 1], for taps
/// `[p00, p01, p10, p11]`: each product (1 - fx)(1 - fy), fx (1 - fy), (1 - fx) fy, fx fy in f32,
/// the x factor scaled by 2^22 first (exact), rounded half to even. Each is within 0.75 of
/// 2^22 times the exact product, so a blend is within 255 * 4 * 0.75 / 2^22 < 2e-4 level.
#[inline(always)]
pub(crate) fn bilinear_weights_u8((fx, fy): (f32, f32)) -> [i32; 4] {
    let scale = (1u32 << U8_WEIGHT_BITS) as f32;
    let (bx, by) = (1.0 - fx, 1.0 - fy);
    let (sbx, sfx) = (bx * scale, fx * scale);
    // Half to even by the f32 addition itself: the products are in [0, 2^22], so w + 2^23 lies
    // in [2^23, 2^24), where f32 spacing is 1 and the mantissa bits are the integer w. Integer
    // operations only (no `roundeven` call, no saturating conversion), so loops vectorise.
    let magic = (1u32 << 23) as f32;
    [sbx * by, sfx * by, sbx * fy, sfx * fy]
        .map(|w| ((w + magic).to_bits() - magic.to_bits()) as i32)
}

/// u8's bilinear blend in integers: the taps times the weights (`bilinear_weights_u8`), summed
/// exactly (at most 255 * (2^22 + 3) < 2^31) and rounded half up. Every build computes these
/// integers; the weights are made once per pixel for all its bands.
#[inline(always)]
pub(crate) fn blend_u8(p: [u8; 4], w: [i32; 4]) -> u8 {
    let sum: i32 = p.iter().zip(w).map(|(&p, w)| i32::from(p) * w).sum();
    ((sum + (1 << (U8_WEIGHT_BITS - 1))) >> U8_WEIGHT_BITS) as u8
}

/// u8's bilinear value at fractions `f`: `blend_u8` of `bilinear_weights_u8(f)`.
#[cfg(test)]
pub(crate) fn bilinear_u8(p: [u8; 4], f: (f32, f32)) -> u8 {
    blend_u8(p, bilinear_weights_u8(f))
}

impl Sample for u8 {
    const KIND: SampleKind = SampleKind::U8;
    const OPAQUE: Self = u8::MAX;
    #[inline(always)]
    fn to_f32(self) -> f32 {
        self as f32
    }
    /// `(v + 0.5) as u8`, which saturates (negative -> 0, > 255 -> 255, NaN -> 0), written as
    /// a clamp and an exact conversion: loops over it vectorise (the saturating `as` stayed
    /// scalar, three times slower in the mosaic's division of its tiles).
    #[inline(always)]
    #[allow(clippy::manual_clamp)] // `clamp` would keep a NaN, which `max` makes 0
    fn from_f32(v: f32) -> Self {
        let x = (v + 0.5).max(0.0).min(255.0);
        // SAFETY: x is a number in [0, 255].
        unsafe { x.to_int_unchecked::<u8>() }
    }
    fn from_f64_exact(v: f64) -> Option<Self> {
        (v.fract() == 0.0 && (0.0..=255.0).contains(&v)).then_some(v as u8)
    }
    #[inline(always)]
    fn bilinear_weights(f: (f32, f32)) -> [i32; 4] {
        bilinear_weights_u8(f)
    }
    #[inline(always)]
    fn bilinear(p: [Self; 4], _f: (f32, f32), w: [i32; 4]) -> Self {
        blend_u8(p, w)
    }
}

impl Sample for u16 {
    const KIND: SampleKind = SampleKind::U16;
    const OPAQUE: Self = u16::MAX;
    #[inline(always)]
    fn to_f32(self) -> f32 {
        self as f32
    }
    /// `(v + 0.5) as u16` (saturating), as u8's: a clamp and an exact conversion.
    #[inline(always)]
    #[allow(clippy::manual_clamp)] // `clamp` would keep a NaN, which `max` makes 0
    fn from_f32(v: f32) -> Self {
        let x = (v + 0.5).max(0.0).min(65535.0);
        // SAFETY: x is a number in [0, 65535].
        unsafe { x.to_int_unchecked::<u16>() }
    }
    fn from_f64_exact(v: f64) -> Option<Self> {
        (v.fract() == 0.0 && (0.0..=65535.0).contains(&v)).then_some(v as u16)
    }
}

impl Sample for f32 {
    const KIND: SampleKind = SampleKind::F32;
    const OPAQUE: Self = 1.0;
    #[inline(always)]
    fn to_f32(self) -> f32 {
        self
    }
    #[inline(always)]
    fn from_f32(v: f32) -> Self {
        v
    }
    fn from_f64_exact(v: f64) -> Option<Self> {
        let f = v as f32;
        (f as f64 == v || v.is_nan()).then_some(f)
    }
}

/// A planar raster: `bands` planes of `width x height` samples, row-major.
#[derive(Debug, Clone, PartialEq)]
pub struct Raster<T> {
    size: ImageSize,
    planes: Vec<Vec<T>>,
}

impl<T: Sample> Raster<T> {
    /// A raster filled with `value`; refuses sizes whose allocation would fail.
    pub fn filled(size: ImageSize, bands: usize, value: T) -> Result<Self, RasterError> {
        let n = checked_len::<T>(size, bands)?;
        let mut planes = Vec::with_capacity(bands);
        for _ in 0..bands {
            let mut p = Vec::new();
            p.try_reserve_exact(n)
                .map_err(|_| too_large::<T>(size, bands))?;
            p.resize(n, value);
            planes.push(p);
        }
        Ok(Self { size, planes })
    }

    /// A raster of default (zero) samples.
    pub fn new(size: ImageSize, bands: usize) -> Result<Self, RasterError> {
        Self::filled(size, bands, T::default())
    }

    /// Wraps planes; each must hold width x height samples.
    pub fn from_planes(size: ImageSize, planes: Vec<Vec<T>>) -> Result<Self, RasterError> {
        let n = checked_len::<T>(size, planes.len())?;
        if let Some(p) = planes.iter().find(|p| p.len() != n) {
            return Err(length_mismatch(p.len(), n, size, planes.len()));
        }
        Ok(Self { size, planes })
    }

    /// From pixel-interleaved samples (RGBRGB...).
    pub fn from_interleaved(
        size: ImageSize,
        bands: usize,
        data: &[T],
    ) -> Result<Self, RasterError> {
        let n = checked_len::<T>(size, bands)?;
        if data.len() != n * bands {
            return Err(length_mismatch(data.len(), n * bands, size, bands));
        }
        let planes = (0..bands)
            .into_par_iter()
            .map(|b| band_of_interleaved(data, bands, b))
            .collect();
        Ok(Self { size, planes })
    }

    /// Pixel-interleaved samples (RGBRGB...), blocks of pixels in parallel.
    pub fn to_interleaved(&self) -> Vec<T> {
        let bands = self.bands();
        let mut out = vec![T::default(); self.size.pixels() * bands];
        if bands == 0 {
            return out;
        }
        out.par_chunks_mut(INTERLEAVE_BLOCK_PX * bands)
            .enumerate()
            .for_each(|(i, block)| {
                let start = i * INTERLEAVE_BLOCK_PX;
                for (b, p) in self.planes.iter().enumerate() {
                    let src = &p[start..start + block.len() / bands];
                    put_band_interleaved(block, bands, b, src);
                }
            });
        out
    }

    pub fn size(&self) -> ImageSize {
        self.size
    }

    pub fn width(&self) -> usize {
        self.size.width
    }

    pub fn height(&self) -> usize {
        self.size.height
    }

    pub fn bands(&self) -> usize {
        self.planes.len()
    }

    /// Band `b` as a row-major slice. Panics if `b` is out of range.
    pub fn plane(&self, b: usize) -> &[T] {
        &self.planes[b]
    }

    pub fn plane_mut(&mut self, b: usize) -> &mut [T] {
        &mut self.planes[b]
    }

    pub fn planes(&self) -> &[Vec<T>] {
        &self.planes
    }

    pub(crate) fn planes_mut(&mut self) -> &mut [Vec<T>] {
        &mut self.planes
    }

    /// Sample of band `b` at column `x`, row `y`, if inside.
    pub fn get(&self, b: usize, x: usize, y: usize) -> Option<T> {
        (x < self.size.width && y < self.size.height)
            .then(|| self.planes.get(b).map(|p| p[y * self.size.width + x]))
            .flatten()
    }

    /// Applies `f` to every sample, producing a raster of another type.
    pub fn map_samples<U: Sample>(&self, f: impl Fn(T) -> U) -> Raster<U> {
        Raster {
            size: self.size,
            planes: self
                .planes
                .iter()
                .map(|p| p.iter().map(|&v| f(v)).collect())
                .collect(),
        }
    }
}

fn checked_len<T>(size: ImageSize, bands: usize) -> Result<usize, RasterError> {
    if size.width == 0 || size.height == 0 || bands == 0 {
        return Err(RasterError::Empty);
    }
    let bytes =
        size.width as u128 * size.height as u128 * bands as u128 * std::mem::size_of::<T>() as u128;
    if bytes > isize::MAX as u128 / 2 {
        return Err(too_large::<T>(size, bands));
    }
    Ok(size.width * size.height)
}

fn too_large<T>(size: ImageSize, bands: usize) -> RasterError {
    let bytes =
        size.width as u128 * size.height as u128 * bands as u128 * std::mem::size_of::<T>() as u128;
    RasterError::TooLarge {
        width: size.width,
        height: size.height,
        bands,
        sample: std::any::type_name::<T>(),
        bytes,
    }
}

fn length_mismatch(got: usize, want: usize, size: ImageSize, bands: usize) -> RasterError {
    RasterError::LengthMismatch {
        got,
        want,
        width: size.width,
        height: size.height,
        bands,
    }
}

/// A raster of any supported sample type, as read from or written to files.
#[derive(Debug, Clone, PartialEq)]
pub enum AnyRaster {
    U8(Raster<u8>),
    U16(Raster<u16>),
    F32(Raster<f32>),
}

impl AnyRaster {
    pub fn size(&self) -> ImageSize {
        match self {
            AnyRaster::U8(r) => r.size(),
            AnyRaster::U16(r) => r.size(),
            AnyRaster::F32(r) => r.size(),
        }
    }

    pub fn bands(&self) -> usize {
        match self {
            AnyRaster::U8(r) => r.bands(),
            AnyRaster::U16(r) => r.bands(),
            AnyRaster::F32(r) => r.bands(),
        }
    }

    /// The sample type held.
    pub fn sample_kind(&self) -> SampleKind {
        match self {
            AnyRaster::U8(_) => u8::KIND,
            AnyRaster::U16(_) => u16::KIND,
            AnyRaster::F32(_) => f32::KIND,
        }
    }

    /// "u8", "u16" or "f32".
    pub fn sample_name(&self) -> &'static str {
        self.sample_kind().name()
    }

    /// Bytes of one sample: 1, 2 or 4.
    pub fn sample_bytes(&self) -> usize {
        self.sample_kind().bytes()
    }

    /// Band `b` as f32 values (for metrics).
    pub fn plane_f32(&self, b: usize) -> Vec<f32> {
        match self {
            AnyRaster::U8(r) => r.plane(b).iter().map(|&v| v.to_f32()).collect(),
            AnyRaster::U16(r) => r.plane(b).iter().map(|&v| v.to_f32()).collect(),
            AnyRaster::F32(r) => r.plane(b).to_vec(),
        }
    }
}

/// Pixels per parallel block of [`Raster::to_interleaved`].
const INTERLEAVE_BLOCK_PX: usize = 1 << 16;

/// Band `b` of pixel-interleaved `data` of `bands` samples a pixel (1-4 bands unrolled).
fn band_of_interleaved<T: Copy>(data: &[T], bands: usize, b: usize) -> Vec<T> {
    fn take<T: Copy, const N: usize>(data: &[T], b: usize) -> Vec<T> {
        data.as_chunks::<N>().0.iter().map(|p| p[b]).collect()
    }
    match bands {
        1 => data.to_vec(),
        2 => take::<T, 2>(data, b),
        3 => take::<T, 3>(data, b),
        4 => take::<T, 4>(data, b),
        _ => data.chunks_exact(bands).map(|p| p[b]).collect(),
    }
}

/// `src` into band `b` of pixel-interleaved `out` of `bands` samples a pixel.
fn put_band_interleaved<T: Copy>(out: &mut [T], bands: usize, b: usize, src: &[T]) {
    fn put<T: Copy, const N: usize>(out: &mut [T], b: usize, src: &[T]) {
        for (p, &v) in out.as_chunks_mut::<N>().0.iter_mut().zip(src) {
            p[b] = v;
        }
    }
    match bands {
        1 => out.copy_from_slice(src),
        2 => put::<T, 2>(out, b, src),
        3 => put::<T, 3>(out, b, src),
        4 => put::<T, 4>(out, b, src),
        _ => {
            for (p, &v) in out.chunks_exact_mut(bands).zip(src) {
                p[b] = v;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// u8's and u16's `from_f32` are the saturating `(v + 0.5) as` casts, for every kind of
    /// f32: the range's ends and just past them, halves, negatives, -0, infinities, NaN, and
    /// a sweep at a tenth of a level.
    #[test]
    fn integer_from_f32_is_the_saturating_cast() {
        let odd = [
            f32::NAN,
            -f32::NAN,
            f32::INFINITY,
            f32::NEG_INFINITY,
            -0.0,
            -0.5,
            -0.49,
            -1e-30,
            254.49,
            254.5,
            255.0,
            255.49,
            255.5,
            65534.49,
            65534.5,
            65535.49,
            65535.5,
            1e10,
            f32::MAX,
            f32::MIN,
        ];
        let sweep = (-100..700_000).map(|i| i as f32 * 0.1);
        for v in odd.into_iter().chain(sweep) {
            assert_eq!(u8::from_f32(v), (v + 0.5) as u8, "{v}");
            assert_eq!(u16::from_f32(v), (v + 0.5) as u16, "{v}");
        }
    }

    /// The exact bilinear value, in f64.
    fn bilinear_f64(p: [u8; 4], (fx, fy): (f32, f32)) -> f64 {
        let [p00, p01, p10, p11] = p.map(f64::from);
        let (fx, fy) = (f64::from(fx), f64::from(fy));
        (1.0 - fy) * ((1.0 - fx) * p00 + fx * p01) + fy * ((1.0 - fx) * p10 + fx * p11)
    }

    #[test]
    fn u8_bilinear_rounds_the_exact_blend() {
        use rand::{Rng, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(13);
        let mut near_half = 0;
        for i in 0..200_000 {
            let p: [u8; 4] = if i % 2 == 0 {
                rng.random()
            } else {
                // Steps of the full range: the largest weight errors.
                [0, 255, 255, 0].map(|v| if rng.random_bool(0.5) { v } else { 255 - v })
            };
            let f: (f32, f32) = (rng.random_range(0.0..=1.0), rng.random_range(0.0..=1.0));
            let w = bilinear_weights_u8(f);
            let total: i32 = w.iter().sum();
            assert!(
                (total - (1 << U8_WEIGHT_BITS)).abs() <= 2,
                "{f:?}: weights sum to {total}"
            );
            let exact = bilinear_f64(p, f);
            let sum: i64 = p
                .iter()
                .zip(w)
                .map(|(&p, w)| i64::from(p) * i64::from(w))
                .sum();
            let ours = sum as f64 / f64::from(1u32 << U8_WEIGHT_BITS);
            assert!(
                (ours - exact).abs() < 2e-4,
                "{p:?} {f:?}: {ours} vs {exact}"
            );
            let got = f64::from(bilinear_u8(p, f));
            if ((exact + 0.5).fract() - 0.5).abs() < 0.5 - 2e-4 {
                assert_eq!(got, (exact + 0.5).floor(), "{p:?} {f:?}: exact {exact}");
            } else {
                near_half += 1;
                assert!(
                    (got - exact).abs() <= 0.5 + 2e-4,
                    "{p:?} {f:?}: exact {exact}"
                );
            }
        }
        assert!(
            near_half < 2_000,
            "{near_half} values within 2e-4 of a half"
        );
    }

    #[test]
    fn u8_bilinear_is_exact_at_the_taps_and_halves() {
        let p = [10, 200, 33, 255];
        for (f, want) in [
            ((0.0, 0.0), 10),
            ((1.0, 0.0), 200),
            ((0.0, 1.0), 33),
            ((1.0, 1.0), 255),
        ] {
            assert_eq!(bilinear_u8(p, f), want, "{f:?}");
        }
        // Means of 1.5 and 2.5 round half up, as `from_f32` does.
        assert_eq!(bilinear_u8([1, 2, 1, 2], (0.5, 0.5)), 2);
        assert_eq!(bilinear_u8([2, 3, 2, 3], (0.5, 0.5)), 3);
        assert_eq!(bilinear_u8([0, 1, 0, 0], (0.5, 0.5)), 0);
        assert_eq!(bilinear_u8([255; 4], (0.3, 0.7)), 255);
    }

    #[test]
    fn interleaved_round_trip() {
        let size = ImageSize::new(3, 2);
        let data: Vec<u8> = (0..18).collect();
        let r = Raster::from_interleaved(size, 3, &data).expect("fits");
        assert_eq!(r.plane(1), &[1, 4, 7, 10, 13, 16]);
        assert_eq!(r.get(2, 2, 1), Some(17));
        assert_eq!(r.to_interleaved(), data);
    }

    #[test]
    fn interleaving_matches_the_per_sample_formula_for_any_band_count() {
        // more pixels than one parallel block, and a partial last block
        let size = ImageSize::new(517, 300);
        for bands in 1..=6 {
            let data: Vec<u16> = (0..size.pixels() * bands)
                .map(|i| (i * 7919 % 65521) as u16)
                .collect();
            let r = Raster::from_interleaved(size, bands, &data).expect("fits");
            for b in 0..bands {
                for (i, &v) in r.plane(b).iter().enumerate() {
                    assert_eq!(v, data[i * bands + b], "band {b} of {bands}, pixel {i}");
                }
            }
            assert_eq!(r.to_interleaved(), data, "{bands} bands");
        }
    }

    #[test]
    fn rounding_is_half_up_and_saturating() {
        assert_eq!(u8::from_f32(1.49), 1);
        assert_eq!(u8::from_f32(1.5), 2);
        assert_eq!(u8::from_f32(-7.0), 0);
        assert_eq!(u8::from_f32(300.0), 255);
        assert_eq!(u16::from_f32(65535.6), 65535);
        assert_eq!(u8::from_f64_exact(256.0), None);
        assert_eq!(u8::from_f64_exact(1.5), None);
        assert_eq!(f32::from_f64_exact(0.1), None);
        assert_eq!(f32::from_f64_exact(-9999.0), Some(-9999.0));
    }

    #[test]
    fn huge_sizes_are_refused_not_aborted() {
        let e = Raster::<u8>::new(ImageSize::new(usize::MAX / 4, 8), 1).unwrap_err();
        assert!(matches!(e, RasterError::TooLarge { .. }));
        assert_eq!(
            Raster::<u8>::new(ImageSize::new(0, 8), 1).unwrap_err(),
            RasterError::Empty
        );
    }
}
