//! The rasters the 3D shader reads, prepared once per terrain on the CPU.
//!
//! - heights (`R32Float`, read with `textureLoad`, so no float filtering is needed: WebGL2
//!   and WebGPU both have it),
//! - surface gradients `(dz/dx, dz/dy)` in metres per metre (`Rg16Float`, filterable
//!   everywhere), from which the shader derives per-pixel normals for any exaggeration,
//! - a water mask of the river network (`R8Unorm`).
//!
//! A field larger than the device's texture limit is box-filtered down by an integer factor
//! (the 3D view then shows that resolution; exports are unaffected). O(cells).

use crate::heightfield::Heightfield;
use crate::jobs::{Cancelled, JobCtx};

use super::lod::ChunkTree;

/// The prepared rasters of one terrain.
#[derive(Clone, Debug)]
pub struct TerrainMaps {
    pub width: usize,
    pub height: usize,
    /// Metres per cell (after any reduction).
    pub cell: f32,
    /// Heights in metres, non-finite cells replaced by the lowest height.
    pub heights: Vec<f32>,
    /// `(dz/dx, dz/dy)` per cell as IEEE half floats.
    pub gradients: Vec<[u16; 2]>,
    pub zmin: f32,
    pub zmax: f32,
    pub tree: ChunkTree,
}

impl TerrainMaps {
    /// Prepares `field` (cells of `cell` metres) for a device whose textures are at most
    /// `max_side` texels wide.
    pub fn new(field: &Heightfield, cell: f32, max_side: usize) -> Self {
        let base = Base::of(field, cell, max_side);
        let gradients = gradient_rows(
            &base.heights,
            base.width,
            base.height,
            base.cell,
            0..base.height,
        );
        base.finish(gradients)
    }

    /// [`Self::new`] as a job: yields between bands of rows (the browser keeps painting) and
    /// stops when cancelled.
    pub async fn prepare(
        field: &Heightfield,
        cell: f32,
        max_side: usize,
        job: &JobCtx,
    ) -> Result<Self, Cancelled> {
        let base = Base::of(field, cell, max_side);
        let (w, h) = (base.width, base.height);
        let mut gradients = Vec::with_capacity(w * h);
        for start in (0..h).step_by(256) {
            job.checkpoint(start as f32 / h as f32, "3D view: surface normals")
                .await?;
            let rows = start..(start + 256).min(h);
            gradients.extend(gradient_rows(&base.heights, w, h, base.cell, rows));
        }
        Ok(base.finish(gradients))
    }

    /// Height (metres) at world position `(x, y)` metres, bilinear, clamped to the map.
    pub fn ground(&self, x: f32, y: f32) -> f32 {
        let fx = (x / self.cell).clamp(0.0, (self.width - 1) as f32);
        let fy = (y / self.cell).clamp(0.0, (self.height - 1) as f32);
        let (x0, y0) = (fx.floor() as usize, fy.floor() as usize);
        let (x1, y1) = ((x0 + 1).min(self.width - 1), (y0 + 1).min(self.height - 1));
        let (tx, ty) = (fx - x0 as f32, fy - y0 as f32);
        let at = |x: usize, y: usize| self.heights[y * self.width + x];
        let top = at(x0, y0) * (1.0 - tx) + at(x1, y0) * tx;
        let bottom = at(x0, y1) * (1.0 - tx) + at(x1, y1) * tx;
        top * (1.0 - ty) + bottom * ty
    }

    /// World size of the map (metres).
    pub fn extent(&self) -> (f32, f32) {
        (
            (self.width - 1) as f32 * self.cell,
            (self.height - 1) as f32 * self.cell,
        )
    }
}

/// Heights ready for the textures (reduced, no-data filled), before gradients and the tree.
struct Base {
    width: usize,
    height: usize,
    cell: f32,
    heights: Vec<f32>,
    zmin: f32,
    zmax: f32,
}

impl Base {
    fn of(field: &Heightfield, cell: f32, max_side: usize) -> Self {
        let (w, h) = (field.width(), field.height());
        let (lo, hi) = field.finite_range().unwrap_or((0.0, 0.0));
        let factor = w.max(h).div_ceil(max_side.max(2)).max(1);
        let (heights, width, height) = if factor == 1 {
            let data = field
                .data()
                .iter()
                .map(|&z| if z.is_finite() { z } else { lo })
                .collect();
            (data, w, h)
        } else {
            reduce(field, factor, lo)
        };
        Self {
            width,
            height,
            cell: cell * factor as f32,
            heights,
            zmin: lo,
            zmax: hi.max(lo + 1e-3),
        }
    }

    fn finish(self, gradients: Vec<[u16; 2]>) -> TerrainMaps {
        let field = Heightfield::from_vec(self.width, self.height, self.heights)
            .expect("a prepared field is valid");
        let tree = ChunkTree::new(&field);
        TerrainMaps {
            width: self.width,
            height: self.height,
            cell: self.cell,
            heights: field.into_vec(),
            gradients,
            zmin: self.zmin,
            zmax: self.zmax,
            tree,
        }
    }
}

/// Box filter by `factor` (finite cells only).
fn reduce(field: &Heightfield, factor: usize, fill: f32) -> (Vec<f32>, usize, usize) {
    let (w, h) = (field.width(), field.height());
    let (rw, rh) = (w.div_ceil(factor), h.div_ceil(factor));
    let mut out = vec![fill; rw * rh];
    for (j, row) in out.chunks_mut(rw).enumerate() {
        for (i, v) in row.iter_mut().enumerate() {
            let (mut sum, mut n) = (0.0f64, 0u32);
            for y in j * factor..((j + 1) * factor).min(h) {
                for x in i * factor..((i + 1) * factor).min(w) {
                    let z = field.data()[y * w + x];
                    if z.is_finite() {
                        sum += f64::from(z);
                        n += 1;
                    }
                }
            }
            if n > 0 {
                *v = (sum / f64::from(n)) as f32;
            }
        }
    }
    (out, rw, rh)
}

/// Central differences (one-sided at the border), metres per metre, of `rows`.
fn gradient_rows(
    heights: &[f32],
    w: usize,
    h: usize,
    cell: f32,
    rows: std::ops::Range<usize>,
) -> Vec<[u16; 2]> {
    let at = |x: usize, y: usize| heights[y * w + x];
    let mut out = Vec::with_capacity(w * rows.len());
    for y in rows {
        for x in 0..w {
            let (xa, xb) = (x.saturating_sub(1), (x + 1).min(w - 1));
            let (ya, yb) = (y.saturating_sub(1), (y + 1).min(h - 1));
            let dx = (at(xb, y) - at(xa, y)) / (((xb - xa).max(1)) as f32 * cell);
            let dy = (at(x, yb) - at(x, ya)) / (((yb - ya).max(1)) as f32 * cell);
            out.push([f16_bits(dx), f16_bits(dy)]);
        }
    }
    out
}

/// Width in metres of a river of Strahler order `order`: 2.5 m for a first-order creek,
/// doubling with each order (Horton's laws give drainage areas about four times larger per
/// order, and hydraulic geometry (Leopold and Maddock 1953) widths growing as the square root
/// of discharge, so about twice as wide per order): 40 m at order 5, 160 m at order 7.
pub fn river_width_m(order: u8) -> f32 {
    2.5 * 2f32.powi(i32::from(order.max(1)) - 1)
}

/// The river network as a water mask: 255 on the cells a river covers at its width
/// ([`river_width_m`]) on cells `cell_m` metres wide; a river narrower than half a cell stays
/// dry (so only real rivers look like water, whatever the map's scale). `order` is the
/// skeleton's per-cell order, `size` x `size`.
pub fn water_mask(order: &[u8], size: usize, cell_m: f32) -> Vec<u8> {
    let mut out = vec![0u8; size * size];
    if order.len() < size * size || cell_m.is_nan() || cell_m <= 0.0 {
        return out;
    }
    for y in 0..size {
        for x in 0..size {
            let o = order[y * size + x];
            if o == 0 {
                continue;
            }
            let width = river_width_m(o);
            if width < 0.5 * cell_m {
                continue;
            }
            let r = ((width / cell_m - 1.0) / 2.0).ceil().max(0.0) as usize;
            for yy in y.saturating_sub(r)..=(y + r).min(size - 1) {
                for xx in x.saturating_sub(r)..=(x + r).min(size - 1) {
                    out[yy * size + xx] = 255;
                }
            }
        }
    }
    out
}

/// Nearest-sample reduction of a square mask to at most `max_side` texels per side.
pub fn reduce_mask(mask: &[u8], side: usize, max_side: usize) -> (Vec<u8>, usize) {
    if side <= max_side {
        return (mask[..side * side].to_vec(), side);
    }
    let factor = side.div_ceil(max_side);
    let out_side = side.div_ceil(factor);
    let out = (0..out_side * out_side)
        .map(|k| {
            let (x, y) = ((k % out_side) * factor, (k / out_side) * factor);
            // Keep thin rivers: any water cell in the block counts.
            let mut v = 0;
            for yy in y..(y + factor).min(side) {
                for xx in x..(x + factor).min(side) {
                    v = v.max(mask[yy * side + xx]);
                }
            }
            v
        })
        .collect();
    (out, out_side)
}

/// IEEE 754 half-precision bits of `v` (round to nearest; overflow to infinity, tiny
/// values to zero): the `Rg16Float` texture format.
pub fn f16_bits(v: f32) -> u16 {
    let bits = v.to_bits();
    let sign = ((bits >> 16) & 0x8000) as u16;
    if v.is_nan() {
        return sign | 0x7e00;
    }
    let exp = ((bits >> 23) & 0xff) as i32 - 127 + 15;
    let mantissa = bits & 0x007f_ffff;
    if exp >= 31 {
        return sign | 0x7c00;
    }
    if exp <= 0 {
        if exp < -10 {
            return sign;
        }
        // Subnormal half.
        let m = (mantissa | 0x0080_0000) >> (1 - exp);
        let rounded = (m + 0x1000) >> 13;
        return sign | rounded as u16;
    }
    let rounded = ((exp as u32) << 10 | (mantissa >> 13)) + ((mantissa >> 12) & 1);
    if rounded >= 0x7c00 {
        return sign | 0x7c00;
    }
    sign | rounded as u16
}

#[cfg(test)]
mod tests {
    use super::*;

    fn from_f16(h: u16) -> f32 {
        let sign = if h & 0x8000 != 0 { -1.0 } else { 1.0 };
        let exp = i32::from((h >> 10) & 0x1f);
        let m = f32::from(h & 0x3ff);
        sign * match exp {
            0 => m * 2f32.powi(-24),
            31 => f32::INFINITY,
            e => (1.0 + m / 1024.0) * 2f32.powi(e - 15),
        }
    }

    #[test]
    fn half_floats_round_trip_within_their_precision() {
        for v in [0.0f32, 1.0, -2.5, 0.1234, 1e-3, -7.75e-5, 300.0, 65000.0] {
            let back = from_f16(f16_bits(v));
            assert!((back - v).abs() <= v.abs() * 1e-3 + 1e-7, "{v} -> {back}");
        }
        assert_eq!(from_f16(f16_bits(1e6)), f32::INFINITY);
        let nan = f16_bits(f32::NAN);
        assert!(nan & 0x7c00 == 0x7c00 && nan & 0x3ff != 0);
    }

    #[test]
    fn a_plane_has_its_slope_everywhere_and_ground_interpolates() {
        let (w, h) = (40, 30);
        let data = (0..w * h)
            .map(|i| 0.5 * (i % w) as f32 - 0.25 * (i / w) as f32)
            .collect();
        let field = Heightfield::from_vec(w, h, data).unwrap();
        let maps = TerrainMaps::new(&field, 2.0, 4096);
        for g in &maps.gradients {
            assert!((from_f16(g[0]) - 0.25).abs() < 1e-3);
            assert!((from_f16(g[1]) + 0.125).abs() < 1e-3);
        }
        assert!((maps.ground(3.0, 5.0) - (0.5 * 1.5 - 0.25 * 2.5)).abs() < 1e-4);
    }

    #[test]
    fn large_fields_are_reduced_to_the_texture_limit() {
        let field = Heightfield::filled(1000, 500, 7.0).unwrap();
        let maps = TerrainMaps::new(&field, 1.0, 256);
        assert!(maps.width <= 256 && maps.height <= 256);
        assert_eq!(maps.cell, 4.0);
        assert!(maps.heights.iter().all(|&z| z == 7.0));
    }

    #[test]
    fn no_data_cells_never_reach_the_mesh() {
        let mut field = Heightfield::filled(64, 64, 3.0).unwrap();
        field.data_mut()[100] = f32::NAN;
        let maps = TerrainMaps::new(&field, 1.0, 4096);
        assert!(maps.heights.iter().all(|z| z.is_finite()));
    }

    #[test]
    fn water_follows_the_river_width_in_metres() {
        let n = 21;
        let mut order = vec![0u8; n * n];
        for y in 0..n {
            order[y * n + 5] = 1; // a creek: 2.5 m
            order[y * n + 14] = 5; // a river: 40 m
        }
        let wet_columns = |cell: f32| {
            let mask = water_mask(&order, n, cell);
            (0..n)
                .filter(|&x| mask[10 * n + x] == 255)
                .collect::<Vec<_>>()
        };
        // 10 m cells: the creek stays dry, the river is five cells wide (one centre cell
        // and two on each side: ceil((40 / 10 - 1) / 2) = 2).
        assert_eq!(wet_columns(10.0), vec![12, 13, 14, 15, 16]);
        // 4 m cells: the creek is water too.
        assert!(wet_columns(4.0).contains(&5));
        // 100 m cells: even the river is narrower than half a cell.
        assert!(wet_columns(100.0).is_empty());
        assert_eq!(river_width_m(7), 160.0);
    }
}
