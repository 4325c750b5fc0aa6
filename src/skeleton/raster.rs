//! Drawing rivers and ridges into the skeleton in bands of rows (seed paper 000, eq. 5).
//!
//! Every cell's result is independent of the order segments are drawn in (a ridge cell keeps
//! the highest ridge through it, a river cell the lowest river, rivers win over ridges, and
//! eq. 5's noise depends on the cell only), so bands of rows can be drawn on their own: each
//! band draws the segments that reach its rows, clipped to them, then adds the ridge noise of
//! its cells. Bands run on all threads natively and one at a time on the web, with the job's
//! ticks between them.

use super::noise::FbmGrid;
use super::{CellKind, bresenham};

/// A straight segment in grid cells with eq. 5's linear heights: `h = start + t * rise`, `t`
/// the distance from `a` over the segment's length.
#[derive(Clone, Copy, Debug)]
pub(super) struct Line {
    pub a: (i64, i64),
    pub b: (i64, i64),
    pub start: f64,
    pub rise: f64,
    /// Strahler order of a river link (0 for ridges).
    pub order: u8,
}

impl Line {
    /// Eq. 5's linear part at cell `(x, y)` of this segment.
    fn height(&self, x: i64, y: i64, length: f64) -> f64 {
        let d = (((x - self.a.0).pow(2) + (y - self.a.1).pow(2)) as f64).sqrt();
        self.start + (d / length).min(1.0) * self.rise
    }

    fn length(&self) -> f64 {
        let (dx, dy) = (self.b.0 - self.a.0, self.b.1 - self.a.1);
        ((dx * dx + dy * dy) as f64).sqrt().max(1.0)
    }

    /// The rows the segment covers.
    fn rows(&self) -> (i64, i64) {
        (self.a.1.min(self.b.1), self.a.1.max(self.b.1))
    }
}

/// For every band of `band_rows` rows, the indices of the `lines` that reach it, in order.
/// O(lines x bands each spans).
pub(super) fn by_band(lines: &[Line], n: usize, band_rows: usize) -> Vec<Vec<u32>> {
    let bands = n.div_ceil(band_rows);
    let mut lists = vec![Vec::new(); bands];
    let last = n as i64 - 1;
    for (k, line) in lines.iter().enumerate() {
        let (top, bottom) = line.rows();
        if bottom < 0 || top > last {
            continue;
        }
        let (top, bottom) = (top.max(0) as usize, bottom.min(last) as usize);
        for list in &mut lists[top / band_rows..=bottom / band_rows] {
            list.push(k as u32);
        }
    }
    lists
}

/// The rows `first_row ..` of the skeleton's layers, `n` cells wide.
pub(super) struct Band<'s> {
    pub n: usize,
    pub first_row: usize,
    pub heights: &'s mut [f32],
    pub kinds: &'s mut [CellKind],
    pub river_order: &'s mut [u8],
}

impl Band<'_> {
    /// The band's index of cell `(x, y)`, if it is one of its cells.
    fn index(&self, x: i64, y: i64) -> Option<usize> {
        let rows = self.kinds.len() / self.n;
        let y = y - self.first_row as i64;
        (x >= 0 && y >= 0 && (x as usize) < self.n && (y as usize) < rows)
            .then(|| y as usize * self.n + x as usize)
    }

    /// A ridge segment: the highest ridge wins a cell, rivers keep theirs.
    pub fn ridge(&mut self, line: &Line) {
        let length = line.length();
        bresenham(line.a, line.b, |x, y| {
            let Some(i) = self.index(x, y) else { return };
            if self.kinds[i] == CellKind::River {
                return;
            }
            let h = line.height(x, y, length) as f32;
            if self.kinds[i] == CellKind::Free || h > self.heights[i] {
                self.heights[i] = h;
            }
            self.kinds[i] = CellKind::Ridge;
        });
    }

    /// A river link, 4-connected (a diagonal Bresenham step gets its corner cell too, so water
    /// cannot leak between two diagonal river cells): the lowest river wins a cell.
    pub fn river(&mut self, line: &Line) {
        let length = line.length();
        let mut put = |x: i64, y: i64| {
            let Some(i) = self.index(x, y) else { return };
            let h = line.height(x, y, length) as f32;
            if self.kinds[i] != CellKind::River || h < self.heights[i] {
                self.heights[i] = h;
            }
            self.kinds[i] = CellKind::River;
            self.river_order[i] = self.river_order[i].max(line.order);
        };
        let mut previous: Option<(i64, i64)> = None;
        bresenham(line.a, line.b, |x, y| {
            if let Some((px, py)) = previous
                && px != x
                && py != y
            {
                put(x, py);
            }
            put(x, y);
            previous = Some((x, y));
        });
    }

    /// Eq. 5's `F(P)` (fractal Perlin noise, `amplitude` metres) on every ridge cell, once per
    /// cell after all segments' linear heights (the highest segment's).
    pub fn ridge_noise(&mut self, amplitude: f64, fbm: &FbmGrid<'_>) {
        if amplitude == 0.0 {
            return;
        }
        let n = self.n;
        for (j, (h, k)) in self.heights.iter_mut().zip(self.kinds.iter()).enumerate() {
            if *k == CellKind::Ridge {
                let f = amplitude * fbm.at(j % n, self.first_row + j / n);
                *h = (f64::from(*h) + f) as f32;
            }
        }
    }
}
