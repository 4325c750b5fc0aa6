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
    /// sin(altitude), and cos(altitude) times the cosine and sine of the light's direction.
    up: f64,
    east: f64,
    north: f64,
}

impl Sun {
    pub fn new(cell_x: f64, cell_y: f64, z_factor: f64) -> Self {
        // Light from azimuth 315 (north-west), as a mathematical angle: 360 - 315 + 90 = 135.
        let (light, altitude) = (135f64.to_radians(), 45f64.to_radians());
        Self {
            cell_x,
            cell_y,
            z_factor,
            up: altitude.sin(),
            east: altitude.cos() * light.cos(),
            north: altitude.cos() * light.sin(),
        }
    }

    /// The light on cell (`x`, `y`), 0 (turned away) to 1 (facing the sun); `None` on
    /// no-data. Horn's (1981) weighted differences over the 3x3 window, as GDAL's `gdaldem
    /// hillshade`; neighbours past the edge or without data count as the cell itself.
    ///
    /// GDAL writes `sin(alt) cos(slope) + cos(alt) sin(slope) cos(light - aspect)` with
    /// `slope = atan(|grad|)` and `aspect = atan2(dz/dy, -dz/dx)`; expanded, that is
    /// `(sin(alt) + cos(alt) (sin(light) dz/dy - cos(light) dz/dx)) / sqrt(1 + |grad|^2)`,
    /// the form used here (no trigonometry per cell).
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
        let shade = (self.up + self.north * dzdy - self.east * dzdx)
            / (1.0 + dzdx * dzdx + dzdy * dzdy).sqrt();
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

#[cfg(test)]
mod tests {
    use super::*;

    /// The trigonometry-free light equals GDAL's slope-and-aspect formula on planes of every
    /// slope and direction (and a flat plane gets sin(45 degrees)).
    #[test]
    fn the_light_is_gdals_formula() {
        let sun = Sun::new(10.0, 10.0, 1.0);
        for (gx, gy) in [
            (0.0, 0.0),
            (0.3, -0.2),
            (-1.5, 0.7),
            (2.0, 2.0),
            (-0.05, -3.0),
        ] {
            // A plane rising gx east and gy south per metre.
            let data = (0..9)
                .map(|i| (gx * (i % 3) as f64 * 10.0 + gy * (i / 3) as f64 * 10.0) as f32)
                .collect();
            let field = Heightfield::from_vec(3, 3, data).unwrap();
            let (light, altitude) = (135f64.to_radians(), 45f64.to_radians());
            let slope = f64::hypot(gx, gy).atan();
            let aspect = f64::atan2(gy, -gx);
            let gdal = (altitude.sin() * slope.cos()
                + altitude.cos() * slope.sin() * (light - aspect).cos())
            .clamp(0.0, 1.0);
            let ours = sun.shade(&field, 1, 1).unwrap();
            assert!((ours - gdal).abs() < 1e-6, "({gx}, {gy}): {ours} vs {gdal}");
        }
    }
}
