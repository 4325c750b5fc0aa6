//! Resampling for export size presets: bilinear, vertex-registered (the four corner cells
//! keep their heights, as a map coordinate maps to `u * (n - 1)`). A cell whose bilinear
//! stencil touches no-data is no-data. O(output cells).

use crate::heightfield::Heightfield;

/// `field` resampled to `width` x `height` cells (each at least 1).
pub fn resample_corners(field: &Heightfield, width: usize, height: usize) -> Heightfield {
    let (w, h) = (field.width(), field.height());
    let axis = |i: usize, n: usize, src: usize| {
        if n <= 1 || src <= 1 {
            return (0, 0, 0.0f32);
        }
        let u = i as f64 * (src - 1) as f64 / (n - 1) as f64;
        let i0 = (u.floor() as usize).min(src - 2);
        (i0, i0 + 1, (u - i0 as f64) as f32)
    };
    let xs: Vec<_> = (0..width.max(1)).map(|x| axis(x, width, w)).collect();
    let d = field.data();
    let mut out = Vec::with_capacity(width.max(1) * height.max(1));
    for y in 0..height.max(1) {
        let (y0, y1, fy) = axis(y, height, h);
        for &(x0, x1, fx) in &xs {
            let tap = |x: usize, y: usize, wgt: f32| {
                if wgt == 0.0 { 0.0 } else { d[y * w + x] * wgt }
            };
            out.push(
                tap(x0, y0, (1.0 - fx) * (1.0 - fy))
                    + tap(x1, y0, fx * (1.0 - fy))
                    + tap(x0, y1, (1.0 - fx) * fy)
                    + tap(x1, y1, fx * fy),
            );
        }
    }
    Heightfield::from_vec(width.max(1), height.max(1), out).expect("non-empty output")
}

/// `field` with its rows in reverse order.
pub fn flipped_y(field: &Heightfield) -> Heightfield {
    let w = field.width();
    let data: Vec<f32> = field.data().chunks(w).rev().flatten().copied().collect();
    Heightfield::from_vec(w, field.height(), data).expect("same size")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn corners_are_kept_and_a_plane_stays_a_plane() {
        let (w, h) = (9, 5);
        let plane: Vec<f32> = (0..w * h)
            .map(|i| (i % w) as f32 * 2.0 + (i / w) as f32)
            .collect();
        let field = Heightfield::from_vec(w, h, plane).unwrap();
        let out = resample_corners(&field, 17, 17);
        assert_eq!(out.get(0, 0), field.get(0, 0));
        assert_eq!(out.get(16, 16), field.get(8, 4));
        for y in 0..17 {
            for x in 0..17 {
                let expect = x as f32 * 0.5 * 2.0 + y as f32 * 0.25;
                assert!((out.get(x, y).unwrap() - expect).abs() < 1e-4);
            }
        }
        assert_eq!(resample_corners(&field, 9, 5), field);
        assert_eq!(flipped_y(&flipped_y(&field)), field);
    }
}
