//! Terrain heights: a DEM in its own CRS, and a height grid resampled from it onto the world
//! CRS for the ground-to-image map (sampled bilinearly between cell centres).

use crate::{Crs, GeoError};

/// The largest |height| a DEM may hold, metres (heights beyond it are a nodata value nobody
/// declared, such as 1e30 or -3.4e38).
pub const MAX_DEM_HEIGHT_M: f64 = 1e5;

/// A north-up raster of heights in any CRS; NaN is no data. `top_left` is the outer corner of
/// cell (0, 0), so the centre of cell (c, r) is (x0 + (c + 0.5) sx, y0 - (r + 0.5) sy).
/// `aerorect_io::read_dem` reads one from a GeoTIFF (`name` is then the file's path).
#[derive(Debug, Clone)]
pub struct Dem {
    pub name: String,
    pub values: Vec<f32>,
    pub width: usize,
    pub height: usize,
    pub top_left: [f64; 2],
    pub cell_size: [f64; 2],
    pub crs: Crs,
}

/// Bilinear interpolation between cell centres of a row-major grid; `None` outside the centres'
/// hull or where a tap is NaN.
#[inline]
fn bilinear(values: &[f32], width: usize, height: usize, col: f64, row: f64) -> Option<f64> {
    if !(col >= 0.0 && row >= 0.0 && col <= (width - 1) as f64 && row <= (height - 1) as f64) {
        return None;
    }
    let (c0, c1, fx) = nodes_around(col, width);
    let (r0, r1, fy) = nodes_around(row, height);
    let at = |c: usize, r: usize| values[r * width + c] as f64;
    let top = lerp(at(c0, r0), at(c1, r0), fx);
    let bottom = lerp(at(c0, r1), at(c1, r1), fx);
    let h = lerp(top, bottom, fy);
    h.is_finite().then_some(h)
}

/// The nodes before and after position `v` (in 0..=n - 1) on an axis of `n` nodes, and `v`'s
/// fraction of the way from the first.
fn nodes_around(v: f64, n: usize) -> (usize, usize, f64) {
    let i0 = (v.floor() as usize).min(n.saturating_sub(2));
    (i0, (i0 + 1).min(n - 1), v - i0 as f64)
}

/// `a` to `b` by `t`, as `a (1 - t) + b t`.
fn lerp(a: f64, b: f64, t: f64) -> f64 {
    a * (1.0 - t) + b * t
}

impl Dem {
    /// Checks the shape and that some height is valid.
    pub fn validate(&self) -> Result<(), GeoError> {
        let bad = |m: String| Err(GeoError::Dem(format!("{}: {m}", self.name)));
        if self.width < 2 || self.height < 2 || self.values.len() != self.width * self.height {
            return bad(format!(
                "{} x {} is too small for interpolation",
                self.width, self.height
            ));
        }
        if !(self.cell_size[0] > 0.0 && self.cell_size[1] > 0.0) {
            return bad(format!("cell size {:?} is not positive", self.cell_size));
        }
        if !self.values.iter().any(|v| v.is_finite()) {
            return bad("has no valid height (all nodata)".into());
        }
        if let Some(h) = self
            .values
            .iter()
            .find(|v| v.is_finite() && v.abs() > MAX_DEM_HEIGHT_M as f32)
        {
            return bad(format!(
                "a height of {h:e} m is outside the sane range |h| <= {MAX_DEM_HEIGHT_M} m \
                 (an undeclared nodata value? give the file a GDAL_NODATA tag)"
            ));
        }
        Ok(())
    }

    /// The height at (x, y) of the DEM's CRS, bilinear between cell centres.
    pub fn height_at(&self, x: f64, y: f64) -> Option<f64> {
        let col = (x - self.top_left[0]) / self.cell_size[0] - 0.5;
        let row = (self.top_left[1] - y) / self.cell_size[1] - 0.5;
        bilinear(&self.values, self.width, self.height, col, row)
    }

    /// The height at (x, y) of the `world` CRS: projected into the DEM's CRS when it differs.
    pub fn height_in(&self, world: &Crs, x: f64, y: f64) -> Option<f64> {
        if world.same_definition(&self.crs) {
            return self.height_at(x, y);
        }
        let p = world.transform(&self.crs, x, y).ok()?;
        self.height_at(p[0], p[1])
    }

    /// Whether `world` is the DEM's CRS (the same text, or the same PROJ parameters: an EPSG
    /// code and the WKT of its `.prj`), so a world position is a DEM position. Callers that look
    /// up many heights decide it once: [`Self::height_in`] compares the texts only, and the
    /// identity transform it otherwise runs per lookup cost a 1,000-frame flight whose DEM and
    /// poses name UTM 33N differently a projection round trip per tie and per grid node.
    pub fn shares_crs(&self, world: &Crs) -> bool {
        world.same_definition(&self.crs) || world.same_as(&self.crs)
    }

    /// [`Self::height_in`] for many lookups in `world`: whether it is the DEM's CRS
    /// ([`Self::shares_crs`]) is decided here, once.
    pub fn heights_in<D>(
        dem: D,
        world: &Crs,
    ) -> impl Fn(f64, f64) -> Option<f64> + Send + Sync + use<D>
    where
        D: std::ops::Deref<Target = Dem> + Send + Sync,
    {
        let (direct, world) = (dem.shares_crs(world), world.clone());
        move |x, y| match direct {
            true => dem.height_at(x, y),
            false => dem.height_in(&world, x, y),
        }
    }

    /// Lowest and highest valid (finite) heights. Taken in `f32`, branch-free, which
    /// vectorises (a flight plans each frame over the DEM, and this scan was 1.5 % of the
    /// 1,000-frame flight's CPU); widening to `f64` is exact and keeps the order.
    pub fn range(&self) -> Option<(f64, f64)> {
        let (lo, hi) =
            self.values
                .iter()
                .fold((f32::INFINITY, f32::NEG_INFINITY), |(lo, hi), &h| {
                    let valid = h.is_finite();
                    let low = if valid { h } else { f32::INFINITY };
                    let high = if valid { h } else { f32::NEG_INFINITY };
                    (lo.min(low), hi.max(high))
                });
        (lo <= hi).then_some((f64::from(lo), f64::from(hi)))
    }
}

/// Heights at the nodes of a north-up world grid (no holes: they were filled when sampled).
#[derive(Debug, Clone)]
pub struct HeightGrid {
    /// World position of node (0, 0), the top-left one.
    pub origin: [f64; 2],
    pub spacing: f64,
    pub width: usize,
    pub height: usize,
    pub values: Vec<f32>,
}

/// What sampling a DEM onto a world grid found.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sampling {
    pub nodes: usize,
    /// Nodes outside the DEM or on nodata, given the fill height.
    pub filled: usize,
}

impl HeightGrid {
    /// Samples `dem` at the nodes of a grid over `bounds` = [xmin, ymin, xmax, ymax] of the
    /// `world` CRS every `spacing` metres. Nodes without a height get `fill`.
    pub fn from_dem(
        dem: &Dem,
        world: &Crs,
        bounds: [f64; 4],
        spacing: f64,
        fill: f64,
    ) -> Result<(Self, Sampling), GeoError> {
        let width = ((bounds[2] - bounds[0]) / spacing).ceil() as usize + 2;
        let height = ((bounds[3] - bounds[1]) / spacing).ceil() as usize + 2;
        if width.saturating_mul(height) > 50_000_000 {
            return Err(GeoError::Dem(format!(
                "{}: a {width} x {height} height grid is too large",
                dem.name
            )));
        }
        let origin = [bounds[0] - spacing / 2.0, bounds[3] + spacing / 2.0];
        let mut values = Vec::with_capacity(width * height);
        let mut filled = 0;
        let height_at = Dem::heights_in(dem, world);
        for r in 0..height {
            for c in 0..width {
                let (x, y) = (
                    origin[0] + c as f64 * spacing,
                    origin[1] - r as f64 * spacing,
                );
                let h = height_at(x, y);
                filled += h.is_none() as usize;
                values.push(h.unwrap_or(fill) as f32);
            }
        }
        let grid = Self {
            origin,
            spacing,
            width,
            height,
            values,
        };
        Ok((
            grid,
            Sampling {
                nodes: width * height,
                filled,
            },
        ))
    }

    /// The height at world (x, y), bilinear; positions outside take the nearest edge.
    #[inline]
    pub fn height_at(&self, x: f64, y: f64) -> f64 {
        let col = ((x - self.origin[0]) / self.spacing).clamp(0.0, (self.width - 1) as f64);
        let row = ((self.origin[1] - y) / self.spacing).clamp(0.0, (self.height - 1) as f64);
        bilinear(&self.values, self.width, self.height, col, row).unwrap_or(f64::NAN)
    }

    /// Each x of `xs` replaced by [`Self::height_at`] (x, `y`), bit for bit: the row's part
    /// of the lookup (a division, the clamp, the two rows of nodes) taken once for the row.
    pub fn heights_along(&self, y: f64, xs: &mut [f64]) {
        let (w, h) = (self.width, self.height);
        let row = ((self.origin[1] - y) / self.spacing).clamp(0.0, (h - 1) as f64);
        if !(row >= 0.0 && row <= (h - 1) as f64) {
            return xs.fill(f64::NAN);
        }
        let (r0, r1, fy) = nodes_around(row, h);
        let (top, bottom) = (&self.values[r0 * w..][..w], &self.values[r1 * w..][..w]);
        #[cfg(target_arch = "x86_64")]
        let xs = match std::arch::is_x86_feature_detected!("avx2") {
            true => {
                let nodes = crate::terrain_avx2::RowNodes {
                    top,
                    bottom,
                    fy,
                    x0: self.origin[0],
                    spacing: self.spacing,
                };
                // SAFETY: the CPU has AVX2.
                let done = unsafe { crate::terrain_avx2::heights(&nodes, xs) };
                &mut xs[done..]
            }
            false => xs,
        };
        for x in xs {
            let col = ((*x - self.origin[0]) / self.spacing).clamp(0.0, (w - 1) as f64);
            if !(col >= 0.0 && col <= (w - 1) as f64) {
                *x = f64::NAN;
                continue;
            }
            let (c0, c1, fx) = nodes_around(col, w);
            let t = lerp(top[c0] as f64, top[c1] as f64, fx);
            let b = lerp(bottom[c0] as f64, bottom[c1] as f64, fx);
            let v = lerp(t, b, fy);
            *x = if v.is_finite() { v } else { f64::NAN };
        }
    }
}

/// The ground under the frame.
#[derive(Debug, Clone)]
pub enum Terrain {
    /// Level ground at this height (world frame).
    Flat(f64),
    Grid(HeightGrid),
}

impl Terrain {
    #[inline]
    pub fn height_at(&self, x: f64, y: f64) -> f64 {
        match self {
            Terrain::Flat(z) => *z,
            Terrain::Grid(g) => g.height_at(x, y),
        }
    }

    /// Each x of `xs` replaced by [`Self::height_at`] (x, `y`).
    pub fn heights_along(&self, y: f64, xs: &mut [f64]) {
        match self {
            Terrain::Flat(z) => xs.fill(*z),
            Terrain::Grid(g) => g.heights_along(y, xs),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A row's heights are `height_at`'s bit for bit (the AVX2 loop's and the scalar tail's):
    /// inside, on and beyond the edges (the nearest edge), across a node with no height
    /// (NaN), for x not a number or infinite, and for a grid one node wide.
    #[test]
    fn heights_along_a_row_are_height_at_bit_for_bit() {
        let (width, height) = (7, 5);
        let mut values: Vec<f32> = (0..width * height)
            .map(|i| 100.0 + ((i * 37) % 23) as f32 * 0.73)
            .collect();
        values[2 * width + 3] = f32::NAN;
        let grids = [
            HeightGrid {
                origin: [500.0, 2000.0],
                spacing: 2.5,
                width,
                height,
                values,
            },
            HeightGrid {
                origin: [500.0, 2000.0],
                spacing: 2.5,
                width: 1,
                height: 2,
                values: vec![10.0, 20.0],
            },
        ];
        // 43: ten runs of four (the AVX2 loop's) and a tail of three; x off the grid's
        // ends, exactly on its first and last nodes, not a number and infinite. Spaced 0.61
        // apart, four x's mostly straddle a node (gathered); 0.1 apart, 25 share each cell
        // (the nodes broadcast), across the first node and off the grid's start.
        let mut coarse: Vec<f64> = (0..43).map(|i| 493.0 + i as f64 * 0.61).collect();
        let odd = [
            (3, f64::NAN),
            (8, 500.0),
            (17, 515.0),
            (22, f64::INFINITY),
            (41, f64::NEG_INFINITY),
        ];
        for (k, x) in odd {
            coarse[k] = x;
        }
        let mut fine: Vec<f64> = (0..43).map(|i| 498.0 + i as f64 * 0.1).collect();
        fine[13] = f64::NAN;
        let mut checked = 0;
        for g in &grids {
            for y in [2003.0, 2000.0, 1996.3, 1994.9, 1990.0, 1980.0, f64::NAN] {
                for xs0 in [&coarse, &fine] {
                    let mut xs = xs0.clone();
                    g.heights_along(y, &mut xs);
                    for (x, got) in xs0.iter().zip(&xs) {
                        assert_eq!(got.to_bits(), g.height_at(*x, y).to_bits(), "({x}, {y})");
                        checked += got.is_finite() as usize;
                    }
                }
            }
        }
        assert!(checked > 400, "{checked}");
    }

    /// The range is the lowest and highest finite height (a slow scan in f64), none where
    /// there is none: NaN, both infinities and the extreme finite values among them.
    #[test]
    fn range_is_the_finite_heights_lowest_and_highest() {
        let dem = |values: Vec<f32>| Dem {
            name: "t".into(),
            width: values.len(),
            height: 1,
            values,
            top_left: [0.0, 0.0],
            cell_size: [1.0, -1.0],
            crs: Crs::from_epsg(32635).expect("UTM 35N"),
        };
        let slow = |v: &[f32]| {
            let finite: Vec<f64> = v
                .iter()
                .filter(|h| h.is_finite())
                .map(|&h| h as f64)
                .collect();
            let lo = finite.iter().copied().reduce(f64::min)?;
            Some((lo, finite.iter().copied().reduce(f64::max)?))
        };
        let mut wave: Vec<f32> = (0..1003)
            .map(|i| ((i * 7919) % 1000) as f32 * 0.37 - 50.0)
            .collect();
        wave[17] = f32::NAN;
        wave[400] = f32::INFINITY;
        wave[999] = f32::NEG_INFINITY;
        let cases = [
            wave,
            vec![f32::NAN, f32::INFINITY, f32::NEG_INFINITY],
            vec![],
            vec![f32::MAX, f32::NAN, -f32::MAX, 0.0],
            vec![-0.0, f32::MIN_POSITIVE, f32::NAN],
            vec![123.5],
        ];
        for v in cases {
            assert_eq!(dem(v.clone()).range(), slow(&v), "{v:?}");
        }
    }
}
