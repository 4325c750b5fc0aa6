//! Energy-reduction masks (seed paper 001, Sec. 4.2): grey images over the map where 0 keeps
//! all the synthetic detail and 1 removes it (roads, rivers, lakes).
//!
//! A mask has its own resolution. Its samples are vertex-registered like a terrain: sample
//! (i, j) of a `w x h` mask sits at map point `(i / (w - 1), j / (h - 1))`, so a mask of the
//! terrain's size lines up with the terrain's cells, and it is sampled bilinearly at any other
//! resolution. Masks are painted with a round brush, derived from the river network, and
//! read from / written to greyscale PNG (white = 1).

use glam::DVec2;
use thiserror::Error;

use crate::dem::ReadLimits;
use crate::river::RiverNetwork;

/// Why a mask could not be made or read.
#[derive(Debug, Error, PartialEq)]
pub enum MaskError {
    #[error("a mask needs at least 1x1 samples and at most {limit} in all, got {width}x{height}")]
    Size {
        width: usize,
        height: usize,
        limit: u64,
    },
    #[error("not a readable PNG mask: {0}")]
    Png(String),
    #[error("could not write the mask PNG: {0}")]
    Write(String),
}

/// A grey energy-reduction mask with values in [0, 1].
#[derive(Clone, Debug, PartialEq)]
pub struct Mask {
    width: usize,
    height: usize,
    values: Vec<f32>,
}

/// A round brush (the app's mask tool).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Brush {
    /// Radius in mask samples.
    pub radius: f32,
    /// Fraction of the radius painted at full strength; the rest fades out smoothly.
    pub hardness: f32,
    /// Grey value painted, 0..1 (1 = remove all synthetic detail).
    pub value: f32,
    /// Paint 0 instead of `value`.
    pub eraser: bool,
}

impl Default for Brush {
    fn default() -> Self {
        Self {
            radius: 8.0,
            hardness: 0.5,
            value: 1.0,
            eraser: false,
        }
    }
}

impl Mask {
    /// An all-zero mask (keep all detail everywhere).
    pub fn new(width: usize, height: usize) -> Result<Self, MaskError> {
        ReadLimits::default()
            .check(width as u64, height as u64)
            .map_err(|_| MaskError::Size {
                width,
                height,
                limit: ReadLimits::default().max_cells,
            })?;
        Ok(Self {
            width,
            height,
            values: vec![0.0; width * height],
        })
    }

    /// Wraps row-major values, clamping them to [0, 1] (NaN becomes 0).
    pub fn from_values(width: usize, height: usize, values: Vec<f32>) -> Result<Self, MaskError> {
        let mut mask = Self::new(width, height)?;
        if values.len() != width * height {
            return Err(MaskError::Size {
                width,
                height,
                limit: ReadLimits::default().max_cells,
            });
        }
        for (m, v) in mask.values.iter_mut().zip(values) {
            *m = if v.is_nan() { 0.0 } else { v.clamp(0.0, 1.0) };
        }
        Ok(mask)
    }

    pub fn width(&self) -> usize {
        self.width
    }

    pub fn height(&self) -> usize {
        self.height
    }

    pub fn values(&self) -> &[f32] {
        &self.values
    }

    /// Whether every sample is 0 (the mask changes nothing).
    pub fn is_clear(&self) -> bool {
        self.values.iter().all(|&v| v == 0.0)
    }

    /// Bilinear value at map point (u, v) in [0, 1]^2 (clamped outside).
    pub fn sample(&self, u: f64, v: f64) -> f32 {
        let fx = (u.clamp(0.0, 1.0) * (self.width - 1) as f64).max(0.0);
        let fy = (v.clamp(0.0, 1.0) * (self.height - 1) as f64).max(0.0);
        let (x0, y0) = (fx.floor() as usize, fy.floor() as usize);
        let (x1, y1) = ((x0 + 1).min(self.width - 1), (y0 + 1).min(self.height - 1));
        let (tx, ty) = ((fx - x0 as f64) as f32, (fy - y0 as f64) as f32);
        let at = |x: usize, y: usize| self.values[y * self.width + x];
        let top = at(x0, y0) + (at(x1, y0) - at(x0, y0)) * tx;
        let bottom = at(x0, y1) + (at(x1, y1) - at(x0, y1)) * tx;
        top + (bottom - top) * ty
    }

    /// The cells `w` x `h` from `(x0, y0)` of the mask resampled to an `n` x `n` grid: the
    /// values [`Self::resampled`]`(n, n)` gives those cells, bit for bit, sampled over the
    /// window alone (a tile of a world, `crate::world::refine`). O(w x h).
    pub fn window(&self, n: usize, [x0, y0]: [usize; 2], [w, h]: [usize; 2]) -> Vec<f32> {
        if n == self.width && n == self.height {
            return (y0..y0 + h)
                .flat_map(|y| self.values[y * n + x0..y * n + x0 + w].iter().copied())
                .collect();
        }
        let step = if n > 1 { 1.0 / (n - 1) as f64 } else { 0.0 };
        (y0..y0 + h)
            .flat_map(|y| (x0..x0 + w).map(move |x| self.sample(x as f64 * step, y as f64 * step)))
            .collect()
    }

    /// The mask resampled (bilinearly, vertex-registered) to `width x height`.
    pub fn resampled(&self, width: usize, height: usize) -> Vec<f32> {
        if width == self.width && height == self.height {
            return self.values.clone();
        }
        let step = |n: usize| if n > 1 { 1.0 / (n - 1) as f64 } else { 0.0 };
        let (du, dv) = (step(width), step(height));
        let mut out = Vec::with_capacity(width * height);
        for y in 0..height {
            for x in 0..width {
                out.push(self.sample(x as f64 * du, y as f64 * dv));
            }
        }
        out
    }

    /// Map point to fractional sample coordinates.
    fn to_samples(&self, p: DVec2) -> DVec2 {
        DVec2::new(
            p.x * (self.width - 1) as f64,
            p.y * (self.height - 1) as f64,
        )
    }

    /// Paints a stroke segment from `a` to `b` (map units) with `brush`, stamping every quarter
    /// radius. Cost O(length / radius * radius^2).
    pub fn paint_segment(&mut self, a: DVec2, b: DVec2, brush: &Brush) {
        let (pa, pb) = (self.to_samples(a), self.to_samples(b));
        let radius = f64::from(brush.radius.clamp(0.5, 4096.0));
        let stamps = ((pa.distance(pb) / (radius * 0.25)).ceil() as usize).clamp(1, 100_000);
        for k in 0..=stamps {
            let c = pa.lerp(pb, k as f64 / stamps as f64);
            self.stamp(c, radius, brush);
        }
    }

    /// One round stamp centred at sample coordinates `c`: full strength within `hardness *
    /// radius`, a smoothstep fade to 0 at `radius`; the painted value replaces the old one in
    /// proportion to the strength (painting never overshoots the target).
    fn stamp(&mut self, c: DVec2, radius: f64, brush: &Brush) {
        let target = if brush.eraser {
            0.0
        } else {
            brush.value.clamp(0.0, 1.0)
        };
        let inner = radius * f64::from(brush.hardness.clamp(0.0, 1.0));
        let x0 = (c.x - radius).floor().max(0.0) as usize;
        let y0 = (c.y - radius).floor().max(0.0) as usize;
        let x1 = ((c.x + radius).ceil().max(0.0) as usize).min(self.width - 1);
        let y1 = ((c.y + radius).ceil().max(0.0) as usize).min(self.height - 1);
        for y in y0..=y1 {
            for x in x0..=x1 {
                let d = DVec2::new(x as f64, y as f64).distance(c);
                let strength = falloff(d, inner, radius) as f32;
                if strength > 0.0 {
                    let v = &mut self.values[y * self.width + x];
                    let blended = *v + (target - *v) * strength;
                    // Repeated stamps of one stroke must not wash a harder value out.
                    *v = if brush.eraser {
                        blended.min(*v)
                    } else if target >= *v {
                        blended.max(*v)
                    } else {
                        blended.min(*v)
                    };
                }
            }
        }
    }

    /// A starting mask from river networks: every link is painted with a width growing with
    /// its Strahler order (`base_radius` samples for order 1, +50% per order), so the new
    /// detail levels keep river beds smooth (Fig. 13 of seed 001).
    pub fn from_rivers(
        width: usize,
        height: usize,
        rivers: &[(&RiverNetwork, &[u32])],
        base_radius: f32,
    ) -> Result<Self, MaskError> {
        let mut mask = Self::new(width, height)?;
        for (net, orders) in rivers {
            for (down, up) in net.link_pairs() {
                let order = orders.get(up).copied().unwrap_or(1).max(1);
                let brush = Brush {
                    radius: base_radius * (1.0 + 0.5 * (order - 1) as f32),
                    hardness: 0.6,
                    value: 1.0,
                    eraser: false,
                };
                mask.paint_segment(net.nodes[down], net.nodes[up], &brush);
            }
        }
        Ok(mask)
    }

    /// Reads a greyscale (or colour, converted to luminance) PNG of 8 or 16 bits; white = 1.
    /// The size is checked against `limits` from the header, before any allocation.
    pub fn from_png(bytes: &[u8], limits: ReadLimits) -> Result<Self, MaskError> {
        let mut decoder = png::Decoder::new(std::io::Cursor::new(bytes));
        decoder.set_transformations(png::Transformations::EXPAND);
        let mut reader = decoder
            .read_info()
            .map_err(|e| MaskError::Png(e.to_string()))?;
        let (width, height) = {
            let info = reader.info();
            (info.width as usize, info.height as usize)
        };
        limits
            .check(width as u64, height as u64)
            .map_err(|_| MaskError::Size {
                width,
                height,
                limit: limits.max_cells,
            })?;
        let size = reader
            .output_buffer_size()
            .ok_or_else(|| MaskError::Png("the image is too large to decode".into()))?;
        let mut buf = vec![0u8; size];
        let frame = reader
            .next_frame(&mut buf)
            .map_err(|e| MaskError::Png(e.to_string()))?;
        let channels = frame.color_type.samples();
        let wide = frame.bit_depth == png::BitDepth::Sixteen;
        let bytes_per = if wide { 2 } else { 1 };
        let max = if wide { 65535.0 } else { 255.0 };
        let sample = |k: usize| -> f32 {
            if wide {
                f32::from(u16::from_be_bytes([buf[2 * k], buf[2 * k + 1]])) / max
            } else {
                f32::from(buf[k]) / max
            }
        };
        let row_len = frame.line_size;
        let mut values = Vec::with_capacity(width * height);
        for y in 0..height {
            for x in 0..width {
                let first = (y * row_len) / bytes_per + x * channels;
                let v = match channels {
                    1 | 2 => sample(first),
                    _ => {
                        0.2126 * sample(first)
                            + 0.7152 * sample(first + 1)
                            + 0.0722 * sample(first + 2)
                    }
                };
                values.push(v);
            }
        }
        Self::from_values(width, height, values)
    }

    /// The mask as an 8-bit greyscale PNG (white = 1).
    pub fn to_png(&self) -> Result<Vec<u8>, MaskError> {
        let grey: Vec<u8> = self
            .values
            .iter()
            .map(|v| (v * 255.0).round() as u8)
            .collect();
        crate::dem::png16::write_grey8(self.width, self.height, &grey)
            .map_err(|e| MaskError::Write(e.to_string()))
    }
}

/// Brush strength at distance `d`: 1 inside `inner`, smoothstep to 0 at `outer`.
fn falloff(d: f64, inner: f64, outer: f64) -> f64 {
    if d <= inner {
        1.0
    } else if d >= outer {
        0.0
    } else {
        let t = (outer - d) / (outer - inner).max(1e-9);
        t * t * (3.0 - 2.0 * t)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_hard_brush_paints_its_disc_and_nothing_else() {
        let mut mask = Mask::new(65, 65).unwrap();
        let brush = Brush {
            radius: 6.0,
            hardness: 1.0,
            value: 1.0,
            eraser: false,
        };
        let centre = DVec2::splat(0.5);
        mask.paint_segment(centre, centre, &brush);
        assert_eq!(mask.values()[32 * 65 + 32], 1.0);
        assert_eq!(mask.values()[32 * 65 + 37], 1.0);
        assert_eq!(mask.values()[32 * 65 + 40], 0.0);
        let erase = Brush {
            eraser: true,
            ..brush
        };
        mask.paint_segment(centre, centre, &erase);
        assert!(mask.is_clear());
    }

    #[test]
    fn png_round_trip_keeps_8_bit_values() {
        let values: Vec<f32> = (0..40).map(|k| (k * 6) as f32 / 255.0).collect();
        let mask = Mask::from_values(8, 5, values).unwrap();
        let back = Mask::from_png(&mask.to_png().unwrap(), ReadLimits::default()).unwrap();
        assert_eq!(back.width(), 8);
        for (a, b) in mask.values().iter().zip(back.values()) {
            assert!((a - b).abs() < 1e-6);
        }
    }

    #[test]
    fn corrupt_and_oversized_pngs_are_errors() {
        assert!(matches!(
            Mask::from_png(b"not a png", ReadLimits::default()),
            Err(MaskError::Png(_))
        ));
        let mask = Mask::new(64, 64).unwrap();
        let small = ReadLimits { max_cells: 100 };
        assert!(matches!(
            Mask::from_png(&mask.to_png().unwrap(), small),
            Err(MaskError::Size { .. })
        ));
    }

    #[test]
    fn resampling_is_vertex_registered() {
        let mask = Mask::from_values(2, 1, vec![0.0, 1.0]).unwrap();
        let wide = mask.resampled(5, 1);
        assert_eq!(wide, vec![0.0, 0.25, 0.5, 0.75, 1.0]);
    }

    /// A window of the resampled mask is those cells of the whole resampling, bit for bit,
    /// whether the grid is the mask's own size or another.
    #[test]
    fn a_window_is_the_resampled_masks_cells_there() {
        let values = (0..35).map(|i| ((i * 7) % 11) as f32 / 10.0).collect();
        let mask = Mask::from_values(7, 5, values).unwrap();
        let square = Mask::from_values(6, 6, (0..36).map(|i| i as f32 / 35.0).collect()).unwrap();
        for (mask, n) in [(&mask, 23), (&mask, 3), (&square, 6)] {
            let whole = mask.resampled(n, n);
            let (at, size) = ([1, 2], [n - 2, n - 3]);
            let window = mask.window(n, at, size);
            assert_eq!(window.len(), size[0] * size[1]);
            for (i, v) in window.iter().enumerate() {
                let (x, y) = (at[0] + i % size[0], at[1] + i / size[0]);
                assert_eq!(v.to_bits(), whole[y * n + x].to_bits(), "({x}, {y}) of {n}");
            }
        }
    }
}
