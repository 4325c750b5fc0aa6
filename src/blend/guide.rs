//! The guidance of a blend: the reference terrain R taken from a DEM and transformed as the
//! user asks (Algorithm 1, step 2): height scale, quarter-turn rotation, mirror, and a
//! horizontal scale by resampling onto the block's cells.
//!
//! Transforming R's heights and then differencing is the same as transforming its gradient
//! field D: the 5-point divergence is linear in R (so a height scale `s` scales D by `s`),
//! and a rotation or mirror of the grid permutes and flips D's components with it. A
//! horizontal scale resamples R bilinearly at the block's cell centres, which keeps R's
//! heights (not its slopes) as the user sees them on the DEM.

use crate::heightfield::Heightfield;

use super::BlendError;

/// How a reference block is turned before it guides the solve.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Transform {
    /// Clockwise quarter turns, 0..=3.
    pub quarter_turns: u8,
    /// Mirror left-right (applied before the rotation).
    pub mirror: bool,
    /// Multiplies the reference's heights, and so its gradients.
    pub z_scale: f32,
}

impl Default for Transform {
    fn default() -> Self {
        Self {
            quarter_turns: 0,
            mirror: false,
            z_scale: 1.0,
        }
    }
}

impl Transform {
    /// The reference's size after the rotation: quarter turns swap width and height.
    pub fn turned_size(&self, width: usize, height: usize) -> (usize, usize) {
        if self.quarter_turns % 2 == 1 {
            (height, width)
        } else {
            (width, height)
        }
    }

    /// `field` mirrored, turned and scaled in height. O(cells).
    pub fn apply(&self, field: &Heightfield) -> Heightfield {
        let (w, h) = (field.width(), field.height());
        let (tw, th) = self.turned_size(w, h);
        let src = field.data();
        let mut out = Vec::with_capacity(tw * th);
        for ty in 0..th {
            for tx in 0..tw {
                // Undo the clockwise rotation: (tx, ty) in the turned grid comes from (x, y).
                let (x, y) = match self.quarter_turns % 4 {
                    0 => (tx, ty),
                    1 => (ty, h - 1 - tx),
                    2 => (w - 1 - tx, h - 1 - ty),
                    _ => (w - 1 - ty, tx),
                };
                let x = if self.mirror { w - 1 - x } else { x };
                out.push(src[y * w + x] * self.z_scale);
            }
        }
        Heightfield::from_vec(tw, th, out).expect("a turn keeps the cell count")
    }
}

/// The `height` x `width` window of `reference` whose top-left cell is (`row`, `col`),
/// heights multiplied by `z_scale`: the guidance of `strahler blend`.
pub fn window(
    reference: &Heightfield,
    row: usize,
    col: usize,
    height: usize,
    width: usize,
    z_scale: f32,
) -> Result<Heightfield, BlendError> {
    let fits = row
        .checked_add(height)
        .is_some_and(|r| r <= reference.height())
        && col
            .checked_add(width)
            .is_some_and(|c| c <= reference.width());
    if !fits || height == 0 || width == 0 {
        return Err(BlendError::WindowOutside {
            row,
            col,
            height,
            width,
            ref_height: reference.height(),
            ref_width: reference.width(),
        });
    }
    let mut out = Vec::with_capacity(width * height);
    for y in row..row + height {
        let start = y * reference.width() + col;
        out.extend(
            reference.data()[start..start + width]
                .iter()
                .map(|v| v * z_scale),
        );
    }
    Ok(Heightfield::from_vec(width, height, out).expect("non-empty window"))
}

/// `reference` (already transformed) resampled onto `width` x `height` cells covering the same
/// area: bilinear at the cell centres, clamped at the edges. O(width x height).
pub fn resample(reference: &Heightfield, width: usize, height: usize) -> Heightfield {
    let (rw, rh) = (reference.width(), reference.height());
    if (rw, rh) == (width, height) {
        return reference.clone();
    }
    let src = reference.data();
    let axis = |i: usize, n: usize, rn: usize| {
        let u = ((i as f64 + 0.5) * rn as f64 / n as f64 - 0.5).clamp(0.0, (rn - 1) as f64);
        let i0 = u.floor() as usize;
        let i1 = (i0 + 1).min(rn - 1);
        (i0, i1, (u - i0 as f64) as f32)
    };
    let xs: Vec<_> = (0..width).map(|x| axis(x, width, rw)).collect();
    let mut out = Vec::with_capacity(width * height);
    for y in 0..height {
        let (y0, y1, fy) = axis(y, height, rh);
        for &(x0, x1, fx) in &xs {
            let top = src[y0 * rw + x0] * (1.0 - fx) + src[y0 * rw + x1] * fx;
            let bottom = src[y1 * rw + x0] * (1.0 - fx) + src[y1 * rw + x1] * fx;
            out.push(top * (1.0 - fy) + bottom * fy);
        }
    }
    Heightfield::from_vec(width, height, out).expect("non-empty output")
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ramp(w: usize, h: usize) -> Heightfield {
        Heightfield::from_vec(w, h, (0..w * h).map(|i| i as f32).collect()).unwrap()
    }

    #[test]
    fn four_quarter_turns_are_the_identity_and_one_turns_clockwise() {
        let r = ramp(3, 2); // rows: [0 1 2] [3 4 5]
        let t = Transform {
            quarter_turns: 1,
            ..Default::default()
        };
        let once = t.apply(&r);
        assert_eq!((once.width(), once.height()), (2, 3));
        // Clockwise: the west column (3 above... bottom-left first) becomes the top row.
        assert_eq!(once.data(), &[3.0, 0.0, 4.0, 1.0, 5.0, 2.0]);
        let mut back = r.clone();
        for _ in 0..4 {
            back = t.apply(&back);
        }
        assert_eq!(back, r);
        let m = Transform {
            mirror: true,
            ..Default::default()
        }
        .apply(&r);
        assert_eq!(m.data(), &[2.0, 1.0, 0.0, 5.0, 4.0, 3.0]);
    }

    #[test]
    fn resampling_keeps_a_linear_ramp_linear_inside() {
        let r = Heightfield::from_vec(4, 1, vec![0.0, 1.0, 2.0, 3.0]).unwrap();
        let up = resample(&r, 8, 1);
        // Centres of 8 cells map to u = (x + 0.5) / 2 - 0.5.
        for x in 1..7 {
            let u = (x as f32 + 0.5) / 2.0 - 0.5;
            assert!((up.data()[x] - u).abs() < 1e-6);
        }
    }

    #[test]
    fn a_window_outside_the_reference_is_an_error() {
        let r = ramp(4, 4);
        assert!(window(&r, 2, 0, 3, 2, 1.0).is_err());
        assert_eq!(
            window(&r, 1, 1, 2, 2, 2.0).unwrap().data(),
            &[10.0, 12.0, 18.0, 20.0]
        );
    }
}
