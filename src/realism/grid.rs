//! The internal raster shared by every metric: heights as `f64`, non-finite input mapped to NaN.

use crate::jobs::{Cancelled, JobCtx, finish_inline};

/// A row-major height raster (row 0 first), `f64` heights, NaN = no data.
pub(super) struct Grid {
    /// Heights, `w * h` values, NaN where the input was not finite.
    pub(super) z: Vec<f64>,
    /// Number of columns.
    pub(super) w: usize,
    /// Number of rows.
    pub(super) h: usize,
    /// Cell size along a row (x, east-west), metres, > 0.
    pub(super) cx: f64,
    /// Cell size along a column (y, north-south), metres, > 0.
    pub(super) cy: f64,
    /// Interior cells where water leaves the map besides its border and its voids (a
    /// designed terrain's river mouths), ascending; empty for a DEM.
    pub(super) sinks: Vec<u32>,
}

/// The 8 neighbour offsets `(d_row, d_col)`, clockwise from north.
pub(super) const DIRS8: [(isize, isize); 8] = [
    (-1, 0),
    (-1, 1),
    (0, 1),
    (1, 1),
    (1, 0),
    (1, -1),
    (0, -1),
    (-1, -1),
];

impl Grid {
    /// Builds a grid, or `None` when the shape does not match `heights` or a cell size is
    /// zero / not finite. Negative cell sizes (north-up geotransforms) are taken by magnitude.
    pub(super) fn new(heights: &[f32], w: usize, h: usize, cx: f64, cy: f64) -> Option<Self> {
        finish_inline(|ctx| async move { Self::new_in(heights, w, h, cx, cy, &ctx).await })
    }

    /// [`Self::new`] in a job: a tick every [`crate::jobs::CELLS_PER_TICK`] cells.
    pub(super) async fn new_in(
        heights: &[f32],
        w: usize,
        h: usize,
        cx: f64,
        cy: f64,
        ctx: &JobCtx,
    ) -> Result<Option<Self>, Cancelled> {
        let Some(n) = w.checked_mul(h) else {
            return Ok(None);
        };
        let (cx, cy) = (cx.abs(), cy.abs());
        let size_ok = |s: f64| s.is_finite() && s > 0.0;
        if n == 0 || heights.len() != n || !size_ok(cx) || !size_ok(cy) {
            return Ok(None);
        }
        let z = ctx
            .map_cells(n, "reading the heights", |i| {
                let v = heights[i];
                if v.is_finite() {
                    f64::from(v)
                } else {
                    f64::NAN
                }
            })
            .await?;
        Ok(Some(Self {
            z,
            w,
            h,
            cx,
            cy,
            sinks: Vec::new(),
        }))
    }

    /// The grid with water leaving it at `sinks` too (cell indices, any order).
    pub(super) fn with_sinks(mut self, sinks: &[u32]) -> Self {
        self.sinks = sinks
            .iter()
            .copied()
            .filter(|&i| (i as usize) < self.z.len())
            .collect();
        self.sinks.sort_unstable();
        self.sinks.dedup();
        self
    }

    /// Horizontal distance (m) of one step in direction `(dr, dc)`.
    pub(super) fn step_length(&self, dr: isize, dc: isize) -> f64 {
        (dr as f64 * self.cy).hypot(dc as f64 * self.cx)
    }

    /// The neighbour of cell `i = r * w + c` in direction `(dr, dc)`, if inside the raster.
    pub(super) fn neighbour(&self, r: usize, c: usize, dr: isize, dc: isize) -> Option<usize> {
        let rr = r.checked_add_signed(dr).filter(|&v| v < self.h)?;
        let cc = c.checked_add_signed(dc).filter(|&v| v < self.w)?;
        Some(rr * self.w + cc)
    }

    /// `true` for cells whose whole 3x3 window is finite; border cells are never interior.
    pub(super) fn interior_mask(&self) -> Vec<bool> {
        let (w, h) = (self.w, self.h);
        let mut mask = vec![false; w * h];
        if w < 3 || h < 3 {
            return mask;
        }
        // Rows of "3 finite cells centred here", then three such rows stacked.
        let mut row3 = vec![false; w * h];
        for r in 0..h {
            let row = &self.z[r * w..(r + 1) * w];
            for c in 1..w - 1 {
                row3[r * w + c] = row[c - 1..=c + 1].iter().all(|v| v.is_finite());
            }
        }
        for r in 1..h - 1 {
            for c in 1..w - 1 {
                let i = r * w + c;
                mask[i] = row3[i - w] && row3[i] && row3[i + w];
            }
        }
        mask
    }

    /// `(min, max)` of the finite heights, or `None` when there are none.
    pub(super) fn finite_range(&self) -> Option<(f64, f64)> {
        self.z
            .iter()
            .filter(|v| v.is_finite())
            .fold(None, |acc, &v| match acc {
                None => Some((v, v)),
                Some((lo, hi)) => Some((lo.min(v), hi.max(v))),
            })
    }
}
