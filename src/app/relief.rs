//! Turning heights into a picture: hypsometric tint times hillshade.

use std::ops::Range;

use egui::{Color32, ColorImage};

use crate::dem::hillshade::Sun;
use crate::heightfield::Heightfield;
use crate::jobs::{Cancelled, JobCtx};

/// Elevation colour stops from low to high (fraction of the range, sRGB).
const TINT: [(f32, [u8; 3]); 5] = [
    (0.00, [62, 110, 70]),
    (0.25, [120, 150, 86]),
    (0.50, [176, 160, 110]),
    (0.75, [150, 120, 100]),
    (1.00, [242, 240, 236]),
];

/// Shaded relief of `field`: the height range tinted low to high, times the light of
/// [`crate::dem::hillshade`] (from the north-west at 45 degrees, the cartographic convention). `cell_size` is the horizontal spacing in metres,
/// so slopes are true slopes. Non-finite (no-data) cells are transparent.
/// O(cells).
pub fn shaded_relief(field: &Heightfield, cell_size: f32) -> ColorImage {
    let mut pixels = Vec::with_capacity(field.width() * field.height());
    let shading = Shading::of(field, cell_size);
    shading.rows(field, 0..field.height(), &mut pixels);
    ColorImage::new([field.width(), field.height()], pixels)
}

/// [`shaded_relief`] in bands of rows (about 2^16 cells each) with [`JobCtx::tick`] between
/// them, so a job on the browser's main thread lets it paint: the same picture.
pub async fn shaded_relief_stepped(
    field: &Heightfield,
    cell_size: f32,
    ctx: &JobCtx,
) -> Result<ColorImage, Cancelled> {
    let (w, h) = (field.width(), field.height());
    let mut pixels = Vec::with_capacity(w * h);
    let shading = Shading::of(field, cell_size);
    let rows = ((1usize << 16) / w.max(1)).max(1);
    for start in (0..h).step_by(rows) {
        shading.rows(field, start..(start + rows).min(h), &mut pixels);
        ctx.tick(0.5, "drawing the map").await?;
    }
    Ok(ColorImage::new([w, h], pixels))
}

/// What every pixel of one relief shares: the height range and the sun.
struct Shading {
    lo: f32,
    span: f32,
    sun: Sun,
}

impl Shading {
    fn of(field: &Heightfield, cell_size: f32) -> Self {
        let (lo, hi) = field.finite_range().unwrap_or((0.0, 1.0));
        let cell = f64::from(cell_size);
        Self {
            lo,
            span: (hi - lo).max(1e-6),
            sun: Sun::new(cell, cell, 1.0),
        }
    }

    /// Appends the pixels of `rows` to `pixels`.
    fn rows(&self, field: &Heightfield, rows: Range<usize>, pixels: &mut Vec<Color32>) {
        let w = field.width();
        for y in rows {
            for x in 0..w {
                let Some(light) = self.sun.shade(field, x, y) else {
                    pixels.push(Color32::TRANSPARENT);
                    continue;
                };
                let shade = 0.35 + 0.65 * light as f32;
                let z = field.data()[y * w + x];
                let [r, g, b] = tint((z - self.lo) / self.span);
                let mul = |c: f32| (c * shade).round().clamp(0.0, 255.0) as u8;
                pixels.push(Color32::from_rgb(mul(r), mul(g), mul(b)));
            }
        }
    }
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

    #[test]
    fn the_stepped_relief_is_the_same_picture() {
        let (w, h) = (300, 517);
        let data: Vec<f32> = (0..w * h)
            .map(|i| ((i % w) as f32 * 0.05).sin() * 40.0 + (i / w) as f32 * 0.3)
            .collect();
        let field = Heightfield::from_vec(w, h, data).unwrap();
        let stepped =
            pollster::block_on(shaded_relief_stepped(&field, 5.0, &JobCtx::detached())).unwrap();
        assert_eq!(stepped, shaded_relief(&field, 5.0));
    }
}
