//! The sample types a raster holds, as a value: what an [`crate::AnyRaster`] holds and what
//! each [`crate::Sample`] type is, for code that decides by the type without holding pixels
//! (a mosaic's format, a tile cache's key) and for messages.

/// One of the three sample types: 8- and 16-bit unsigned integers, 32-bit floats.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum SampleKind {
    U8,
    U16,
    F32,
}

impl SampleKind {
    /// "u8", "u16" or "f32", as messages and reports name it.
    pub const fn name(self) -> &'static str {
        match self {
            SampleKind::U8 => "u8",
            SampleKind::U16 => "u16",
            SampleKind::F32 => "f32",
        }
    }

    /// Bytes of one sample.
    pub const fn bytes(self) -> usize {
        match self {
            SampleKind::U8 => 1,
            SampleKind::U16 => 2,
            SampleKind::F32 => 4,
        }
    }

    /// Whether samples are integers: resampled values are rounded and saturated to them.
    pub const fn is_integer(self) -> bool {
        !matches!(self, SampleKind::F32)
    }
}

impl std::fmt::Display for SampleKind {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

#[cfg(test)]
mod tests {
    use crate::{AnyRaster, Raster, Sample};
    use aerorect_core::ImageSize;

    /// Each kind's size is its type's and its name the Rust type's (the reports' convention),
    /// the rasters of each type say their kind, and only the float type resamples without
    /// rounding (`from_f32` keeps 0.4).
    #[test]
    fn each_kind_is_its_sample_types() {
        fn check<T: Sample>(any: fn(Raster<T>) -> AnyRaster, name: &str) {
            let kind = T::KIND;
            assert_eq!(kind.bytes(), std::mem::size_of::<T>(), "{kind}");
            assert_eq!((kind.name(), T::NAME), (name, name));
            assert_eq!(kind.to_string(), name);
            let raster = any(Raster::<T>::new(ImageSize::new(2, 1), 3).unwrap());
            assert_eq!(raster.sample_kind(), kind);
            assert_eq!(raster.sample_bytes(), std::mem::size_of::<T>());
            let rounds = T::from_f32(0.4).to_f32() != 0.4;
            assert_eq!(kind.is_integer(), rounds, "{kind}");
        }
        check::<u8>(AnyRaster::U8, "u8");
        check::<u16>(AnyRaster::U16, "u16");
        check::<f32>(AnyRaster::F32, "f32");
    }
}
