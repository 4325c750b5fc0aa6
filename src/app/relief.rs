//! Turning heights into a picture: hypsometric tint times hillshade.

use egui::{Color32, ColorImage};

use crate::heightfield::Heightfield;

/// Elevation colour stops from low to high (fraction of the range, sRGB).
const TINT: [(f32, [u8; 3]); 5] = [
    (0.00, [62, 110, 70]),
    (0.25, [120, 150, 86]),
    (0.50, [176, 160, 110]),
    (0.75, [150, 120, 100]),
    (1.00, [242, 240, 236]),
];

/// Shaded relief of `field`: the height range tinted low to high, lit from the north-west at
/// 45 degrees (the cartographic convention). `cell_size` is the horizontal spacing in metres,
/// so slopes are true slopes. Non-finite (no-data) cells are transparent.
/// O(cells).
pub fn shaded_relief(field: &Heightfield, cell_size: f32) -> ColorImage {
    let (w, h) = (field.width(), field.height());
    let (lo, hi) = field.finite_range().unwrap_or((0.0, 1.0));
    let span = (hi - lo).max(1e-6);
    let (sun_x, sun_y, sun_z) = {
        let (az, alt) = (315f32.to_radians(), 45f32.to_radians());
        // x east, y south (rows grow southwards), z up.
        (alt.cos() * az.sin(), -alt.cos() * az.cos(), alt.sin())
    };
    let at = |x: usize, y: usize| field.data()[y * w + x];
    let mut pixels = Vec::with_capacity(w * h);
    for y in 0..h {
        for x in 0..w {
            let z = at(x, y);
            if !z.is_finite() {
                pixels.push(Color32::TRANSPARENT);
                continue;
            }
            let finite_or = |v: f32| if v.is_finite() { v } else { z };
            let (xl, xr) = (x.saturating_sub(1), (x + 1).min(w - 1));
            let (yu, yd) = (y.saturating_sub(1), (y + 1).min(h - 1));
            let dzdx = (finite_or(at(xr, y)) - finite_or(at(xl, y)))
                / (((xr - xl).max(1)) as f32 * cell_size);
            let dzdy = (finite_or(at(x, yd)) - finite_or(at(x, yu)))
                / (((yd - yu).max(1)) as f32 * cell_size);
            // Surface normal (-dz/dx, -dz/dy, 1), normalised.
            let norm = (dzdx * dzdx + dzdy * dzdy + 1.0).sqrt();
            let light = ((-dzdx * sun_x - dzdy * sun_y + sun_z) / norm).clamp(0.0, 1.0);
            let shade = 0.35 + 0.65 * light;
            let [r, g, b] = tint((z - lo) / span);
            let mul = |c: f32| (c * shade).round().clamp(0.0, 255.0) as u8;
            pixels.push(Color32::from_rgb(mul(r), mul(g), mul(b)));
        }
    }
    ColorImage::new([w, h], pixels)
}

fn tint(t: f32) -> [f32; 3] {
    let t = t.clamp(0.0, 1.0);
    for pair in TINT.windows(2) {
        let ((t0, c0), (t1, c1)) = (pair[0], pair[1]);
        if t <= t1 {
            let f = (t - t0) / (t1 - t0);
            return [0, 1, 2].map(|k| c0[k] as f32 + f * (c1[k] as f32 - c0[k] as f32));
        }
    }
    TINT[TINT.len() - 1].1.map(f32::from)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn slopes_facing_the_sun_are_brighter() {
        // A ramp rising to the east faces west, towards the north-western sun; a ramp
        // rising to the west faces away from it.
        let n = 8;
        let east_up: Vec<f32> = (0..n * n).map(|i| (i % n) as f32 * 10.0).collect();
        let west_up: Vec<f32> = (0..n * n).map(|i| (n - i % n) as f32 * 10.0).collect();
        let lum = |data: Vec<f32>| {
            let img = shaded_relief(&Heightfield::from_vec(n, n, data).unwrap(), 10.0);
            let p = img.pixels[4 * n + 4];
            u32::from(p.r()) + u32::from(p.g()) + u32::from(p.b())
        };
        // Facing west (rising east) catches the north-western light; facing east does not.
        assert!(lum(east_up) > lum(west_up));
    }

    #[test]
    fn no_data_is_transparent() {
        let f = Heightfield::from_vec(2, 1, vec![f32::NAN, 1.0]).unwrap();
        assert_eq!(shaded_relief(&f, 1.0).pixels[0], Color32::TRANSPARENT);
    }
}
