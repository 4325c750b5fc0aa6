//! Grey hillshades for comparing terrains by eye (`strahler hillshade`): the classic
//! cartographic shading (light from the north-west, 45 degrees above the horizon, Horn's
//! 3x3 gradient as GDAL's `gdaldem hillshade` computes it), resampled to a panel size so
//! terrains of different resolutions sit side by side at the same scale of the picture.

use crate::heightfield::Heightfield;

/// Hillshade of `field` (cells `cell_x` by `cell_y` metres) as 8-bit grey, 1 (dark) to 255;
/// 0 marks no-data. `z_factor` exaggerates heights. O(cells).
pub fn hillshade(field: &Heightfield, cell_x: f64, cell_y: f64, z_factor: f64) -> Vec<u8> {
    let (w, h) = (field.width(), field.height());
    let z = field.data();
    let at = |x: usize, y: usize| f64::from(z[y.min(h - 1) * w + x.min(w - 1)]);
    // Light from azimuth 315 (north-west), as a mathematical angle: 360 - 315 + 90 = 135.
    let (light, altitude) = (135f64.to_radians(), 45f64.to_radians());
    let mut out = vec![0u8; w * h];
    for y in 0..h {
        for x in 0..w {
            let (xl, xr) = (x.saturating_sub(1), x + 1);
            let (yu, yd) = (y.saturating_sub(1), y + 1);
            let c = at(x, y);
            if !c.is_finite() {
                continue;
            }
            let g = |x, y| {
                let v = at(x, y);
                if v.is_finite() { v } else { c }
            };
            // Horn (1981): weighted differences over the 3x3 window.
            let dzdx = ((g(xr, yu) + 2.0 * g(xr, y) + g(xr, yd))
                - (g(xl, yu) + 2.0 * g(xl, y) + g(xl, yd)))
                / (8.0 * cell_x)
                * z_factor;
            let dzdy = ((g(xl, yd) + 2.0 * g(x, yd) + g(xr, yd))
                - (g(xl, yu) + 2.0 * g(x, yu) + g(xr, yu)))
                / (8.0 * cell_y)
                * z_factor;
            let slope = dzdx.hypot(dzdy).atan();
            // Aspect as GDAL takes it (rows grow southwards).
            let aspect = dzdy.atan2(-dzdx);
            let shade = altitude.sin() * slope.cos()
                + altitude.cos() * slope.sin() * (light - aspect).cos();
            out[y * w + x] = (1.0 + 254.0 * shade.clamp(0.0, 1.0)).round() as u8;
        }
    }
    out
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
