//! Drawing rivers and ridges into the skeleton in bands of rows (seed paper 000, eq. 5).
//!
//! Every cell's result is independent of the order segments are drawn in (a ridge cell keeps
//! the highest ridge through it, noise included, a river cell the lowest river, rivers win
//! over ridges, and eq. 5's noise depends on the cell and the segment only), so bands of rows
//! can be drawn on their own: each band draws the segments that reach its rows, clipped to
//! them. Bands run on all threads natively and one at a time on the web, with the job's ticks
//! between them.

use super::{CellKind, bresenham};
use crate::noise::FbmGrid;

/// A straight segment in grid cells with eq. 5's linear heights: `h = start + t * rise`, `t`
/// the distance from `a` over the segment's length.
#[derive(Clone, Copy, Debug)]
pub(super) struct Line {
    pub a: (i64, i64),
    pub b: (i64, i64),
    pub start: f64,
    pub rise: f64,
    /// A ridge's height above its rivers (eq. 4's `alpha * d`) at `a` and at `b`, interpolated
    /// like the height (zero for rivers).
    pub relief: [f64; 2],
    /// Strahler order of a river link (0 for ridges).
    pub order: u8,
}

impl Line {
    /// How far cell `(x, y)` is along the segment, in [0, 1].
    fn t(&self, x: i64, y: i64, length: f64) -> f64 {
        let d = (((x - self.a.0).pow(2) + (y - self.a.1).pow(2)) as f64).sqrt();
        (d / length).min(1.0)
    }

    /// Eq. 5's linear part at `t` along the segment.
    fn height(&self, t: f64) -> f64 {
        self.start + t * self.rise
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

/// Eq. 5's `F(P)` on ridges: fBm of `amplitude` metres. Where it would lower a ridge, its
/// amplitude is limited to half the ridge's relief there (eq. 4's `alpha * d`, interpolated
/// along the segment), so a ridge sinks at most halfway to the river nodes it separates; above
/// the linear part it keeps its full amplitude. Without the limit, the closely packed rivers
/// of a dense network (a few metres of relief between them) get ridge cells below the river
/// and drain sideways into them. The two lobes meet at `F = 0`, so the noise stays continuous.
#[derive(Clone, Copy)]
pub(super) struct RidgeNoise<'f> {
    pub amplitude: f64,
    pub fbm: &'f FbmGrid<'f>,
}

impl RidgeNoise<'_> {
    /// `F(P)` at cell `(x, y)` (inside the map) of a ridge `relief` metres above its rivers.
    fn at(&self, x: i64, y: i64, relief: f64) -> f64 {
        if self.amplitude == 0.0 {
            return 0.0;
        }
        bounded_noise(self.amplitude, self.fbm.at(x as usize, y as usize), relief)
    }
}

/// Eq. 5's noise term `amplitude * f` (`f` the fBm's value) on a ridge `relief` metres above
/// its rivers, lowering it by at most half that relief (see [`RidgeNoise`]). Sketched ridges
/// take their noise through the same bound.
pub(super) fn bounded_noise(amplitude: f64, f: f64, relief: f64) -> f64 {
    if f >= 0.0 {
        amplitude * f
    } else {
        amplitude.min(0.5 * relief.max(0.0)) * f
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

    /// A ridge segment with eq. 5's heights, noise included: the highest ridge wins a cell,
    /// rivers keep theirs.
    pub fn ridge(&mut self, line: &Line, noise: &RidgeNoise<'_>) {
        let length = line.length();
        let [relief_a, relief_b] = line.relief;
        bresenham(line.a, line.b, |x, y| {
            let Some(i) = self.index(x, y) else { return };
            if self.kinds[i] == CellKind::River {
                return;
            }
            let t = line.t(x, y, length);
            let relief = relief_a + t * (relief_b - relief_a);
            let h = (line.height(t) + noise.at(x, y, relief)) as f32;
            if self.kinds[i] == CellKind::Free || h > self.heights[i] {
                self.heights[i] = h;
            }
            self.kinds[i] = CellKind::Ridge;
        });
    }

    /// A river link, 4-connected ([`river_cells`]): the lowest river wins a cell.
    pub fn river(&mut self, line: &Line) {
        let length = line.length();
        river_cells(line, |x, y| {
            let Some(i) = self.index(x, y) else { return };
            let h = line.height(line.t(x, y, length)) as f32;
            if self.kinds[i] != CellKind::River || h < self.heights[i] {
                self.heights[i] = h;
            }
            self.kinds[i] = CellKind::River;
            self.river_order[i] = self.river_order[i].max(line.order);
        });
    }
}

/// The cells of a river link, 4-connected: Bresenham's line, where a diagonal step also
/// visits its corner cell first, so that water cannot leak between two diagonal river cells.
pub(super) fn river_cells(line: &Line, mut visit: impl FnMut(i64, i64)) {
    let mut previous: Option<(i64, i64)> = None;
    bresenham(line.a, line.b, |x, y| {
        if let Some((px, py)) = previous
            && px != x
            && py != y
        {
            visit(x, py);
        }
        visit(x, y);
        previous = Some((x, y));
    });
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::noise::Perlin;

    /// Eq. 5's noise on a low ridge (2 to 4 m above its rivers) with 25 m of amplitude: it may
    /// lower the ridge by half its relief at most, and keeps its full amplitude upwards.
    #[test]
    fn ridge_noise_lowers_a_ridge_by_at_most_half_its_relief() {
        let n = 256;
        let perlin = Perlin::new(3);
        let fbm = FbmGrid::new(&perlin, n, 8.0, 5, 0.5);
        let noise = RidgeNoise {
            amplitude: 25.0,
            fbm: &fbm,
        };
        let (mut heights, mut kinds, mut order) = (
            vec![0.0; n * n],
            vec![CellKind::Free; n * n],
            vec![0; n * n],
        );
        let mut band = Band {
            n,
            first_row: 0,
            heights: &mut heights,
            kinds: &mut kinds,
            river_order: &mut order,
        };
        let y = 100;
        let line = Line {
            a: (0, y),
            b: (n as i64 - 1, y),
            start: 50.0,
            rise: 10.0,
            relief: [2.0, 4.0],
            order: 0,
        };
        band.ridge(&line, &noise);
        let (mut lowered, mut raised_beyond) = (0, 0);
        for x in 0..n {
            let i = y as usize * n + x;
            assert_eq!(kinds[i], CellKind::Ridge);
            let t = x as f64 / (n - 1) as f64;
            let (linear, relief) = (50.0 + 10.0 * t, 2.0 + 2.0 * t);
            let h = f64::from(heights[i]);
            assert!(h >= linear - 0.5 * relief - 1e-4, "x {x}: {h} vs {linear}");
            lowered += usize::from(h < linear - 0.1);
            raised_beyond += usize::from(h > linear + relief);
        }
        assert!(
            lowered > 20 && raised_beyond > 20,
            "{lowered} {raised_beyond}"
        );
    }
}
