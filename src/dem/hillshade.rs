//! Grey hillshades for comparing terrains by eye (`strahler hillshade`): the classic
//! cartographic shading (light from the north-west, 45 degrees above the horizon, Horn's
//! 3x3 gradient as GDAL's `gdaldem hillshade` computes it), resampled to a panel size so
//! terrains of different resolutions sit side by side at the same scale of the picture.

use crate::heightfield::Heightfield;

/// Hillshade of `field` (cells `cell_x` by `cell_y` metres) as 8-bit grey, 1 (dark) to 255;
/// 0 marks no-data. `z_factor` exaggerates heights. O(cells).
pub fn hillshade(field: &Heightfield, cell_x: f64, cell_y: f64, z_factor: f64) -> Vec<u8> {
    let sun = Sun::new(cell_x, cell_y, z_factor);
    let (w, h) = (field.width(), field.height());
    let mut out = vec![0u8; w * h];
    for y in 0..h {
        for x in 0..w {
            if let Some(shade) = sun.shade(field, x, y) {
                out[y * w + x] = (1.0 + 254.0 * shade).round() as u8;
            }
        }
    }
    out
}

/// The light of the classic hillshade on one grid: from the north-west (azimuth 315), 45
/// degrees above the horizon, on cells `cell_x` by `cell_y` metres with heights times
/// `z_factor`. The app's map tints heights and multiplies by the same light.
#[derive(Clone, Copy, Debug)]
pub struct Sun {
    cell_x: f64,
    cell_y: f64,
    z_factor: f64,
}

impl Sun {
    pub fn new(cell_x: f64, cell_y: f64, z_factor: f64) -> Self {
        Self {
            cell_x,
            cell_y,
            z_factor,
        }
    }

    /// The light on cell (`x`, `y`), 0 (turned away) to 1 (facing the sun); `None` on
    /// no-data. Horn's (1981) weighted differences over the 3x3 window, as GDAL's `gdaldem
    /// hillshade`; neighbours past the edge or without data count as the cell itself.
    pub fn shade(&self, field: &Heightfield, x: usize, y: usize) -> Option<f64> {
        let (w, h) = (field.width(), field.height());
        let z = field.data();
        let at = |x: usize, y: usize| f64::from(z[y.min(h - 1) * w + x.min(w - 1)]);
        let c = at(x, y);
        if !c.is_finite() {
            return None;
        }
        let g = |x, y| {
            let v = at(x, y);
            if v.is_finite() { v } else { c }
        };
        let (xl, xr) = (x.saturating_sub(1), x + 1);
        let (yu, yd) = (y.saturating_sub(1), y + 1);
        let dzdx = ((g(xr, yu) + 2.0 * g(xr, y) + g(xr, yd))
            - (g(xl, yu) + 2.0 * g(xl, y) + g(xl, yd)))
            / (8.0 * self.cell_x)
            * self.z_factor;
        let dzdy = ((g(xl, yd) + 2.0 * g(x, yd) + g(xr, yd))
            - (g(xl, yu) + 2.0 * g(x, yu) + g(xr, yu)))
            / (8.0 * self.cell_y)
            * self.z_factor;
        // Light from azimuth 315 (north-west), as a mathematical angle: 360 - 315 + 90 = 135.
        let (light, altitude) = (135f64.to_radians(), 45f64.to_radians());
        let slope = dzdx.hypot(dzdy).atan();
        // Aspect as GDAL takes it (rows grow southwards).
        let aspect = dzdy.atan2(-dzdx);
        let shade =
            altitude.sin() * slope.cos() + altitude.cos() * slope.sin() * (light - aspect).cos();
        Some(shade.clamp(0.0, 1.0))
    }
}

/// `pixels` (`w` x `h`) resampled to `side` x `side` by the nearest sample (a picture, not
/// data).
pub fn resample_nearest(pixels: &[u8], w: usize, h: usize, side: usize) -> Vec<u8> {
    let mut out = vec![0u8; side * side];
    for y in 0..side {
        let sy = (y * h / side).min(h - 1);
        for x in 0..side {
            out[y * side + x] = pixels[sy * w + (x * w / side).min(w - 1)];
        }
    }
    out
}
