//! Each cell's nearest river or valley cell by straight-line (Euclidean) distance: the exact
//! distance transform of Felzenszwalb and Huttenlocher (2012, "Distance transforms of sampled
//! functions", Theory of Computing 8), carrying the nearest channel cell along.
//!
//! A breadth-first walk over the 8-neighbourhood measures the chessboard distance instead:
//! its bands round a river are squares, so the near-river floor and the uplift read from the
//! nearest river's height left rectangular flats and 45-degree creases on low-relief maps.
//!
//! Two passes, O(cells) each: down and up every column, the nearest channel row in that
//! column; then along every row, the lower envelope of the parabolas
//! `(x - q)^2 + g(q)^2` (`g(q)` the column distance at column `q`) gives the exact squared
//! distance and the nearest channel cell. The parabolas' crossings are computed in `f64` from
//! integers below 2^53, so the result is the same bits natively and in wasm; ties go to the
//! first column of the envelope and the upper row.

use crate::heightfield::Heightfield;

/// A column's nearest channel row not yet known (or none in the column).
const NONE: u32 = u32::MAX;

/// What [`Transform`] finds: for each cell, the height of its nearest channel cell and the
/// distance to it in cells. A map without channels has its lowest height at distance 0
/// everywhere.
pub struct NearestChannel {
    pub base: Vec<f32>,
    pub distance: Vec<f32>,
}

/// The transform of an `n` x `n` grid in progress, a band of rows at a time.
pub(super) struct Transform<'a> {
    n: usize,
    heights: &'a [f32],
    /// Each cell's nearest channel row in its own column ([`NONE`]: none).
    column: Vec<u32>,
    phase: Pass,
    out: NearestChannel,
    /// A row's envelope: the columns whose parabolas it is made of, left to right, and
    /// where each starts being the lowest.
    sites: Vec<usize>,
    from: Vec<f64>,
}

#[derive(Clone, Copy)]
enum Pass {
    /// Rows from the top: the nearest channel at or above. The next row to do.
    Down(usize),
    /// Rows from the bottom: the nearest channel at or below, if nearer. Rows left to do.
    Up(usize),
    /// Rows along: the envelope. The next row to do.
    Across(usize),
    Done,
}

impl<'a> Transform<'a> {
    /// Starts on the square `field` with `channel(i)` true on the channel cells.
    pub(super) fn new(field: &'a Heightfield, channel: impl Fn(usize) -> bool) -> Self {
        let (n, heights) = (field.width(), field.data());
        let cells = n * n;
        let column: Vec<u32> = (0..cells)
            .map(|i| if channel(i) { (i / n) as u32 } else { NONE })
            .collect();
        let phase = if column.iter().all(|&r| r == NONE) {
            Pass::Done
        } else {
            Pass::Down(1)
        };
        let out = match phase {
            Pass::Done => {
                let lowest = field.finite_range().map_or(0.0, |(lo, _)| lo);
                NearestChannel {
                    base: vec![lowest; cells],
                    distance: vec![0.0; cells],
                }
            }
            _ => NearestChannel {
                base: vec![f32::NAN; cells],
                distance: vec![f32::INFINITY; cells],
            },
        };
        Self {
            n,
            heights,
            column,
            phase,
            out,
            sites: Vec::with_capacity(n),
            from: Vec::with_capacity(n),
        }
    }

    /// Does about `rows` rows of the passes; returns whether the transform is over.
    pub(super) fn advance(&mut self, rows: usize) -> bool {
        for _ in 0..rows.max(1) {
            if self.step() {
                return true;
            }
        }
        false
    }

    /// One row of the current pass; returns whether the transform is over.
    fn step(&mut self) -> bool {
        let n = self.n;
        self.phase = match self.phase {
            Pass::Down(y) if y < n => {
                let (above, row) = self.column.split_at_mut(y * n);
                for (r, &a) in row[..n].iter_mut().zip(&above[(y - 1) * n..]) {
                    if *r == NONE {
                        *r = a;
                    }
                }
                Pass::Down(y + 1)
            }
            Pass::Down(_) => Pass::Up(n - 1),
            Pass::Up(left) if left > 0 => {
                let y = left - 1;
                let at = y as u32;
                let (row, below) = self.column.split_at_mut((y + 1) * n);
                for (r, &b) in row[y * n..].iter_mut().zip(&below[..n]) {
                    // `b` above this row is this row's own nearest (the downward pass).
                    if b != NONE && b > at && (*r == NONE || b - at < at - *r) {
                        *r = b;
                    }
                }
                Pass::Up(y)
            }
            Pass::Up(_) => Pass::Across(0),
            Pass::Across(y) if y < n => {
                self.row(y);
                Pass::Across(y + 1)
            }
            Pass::Across(_) | Pass::Done => Pass::Done,
        };
        matches!(self.phase, Pass::Done)
    }

    /// The lower envelope of row `y`'s parabolas, and each cell's nearest channel from it.
    fn row(&mut self, y: usize) {
        let n = self.n;
        let near = &self.column[y * n..(y + 1) * n];
        // f(q): the squared distance to column q's nearest channel; columns without one
        // have no parabola.
        let f = |q: usize| {
            let r = near[q] as i64;
            ((r - y as i64) * (r - y as i64)) as f64
        };
        let (sites, from) = (&mut self.sites, &mut self.from);
        sites.clear();
        from.clear();
        for q in (0..n).filter(|&q| near[q] != NONE) {
            let mut start = f64::NEG_INFINITY;
            while let Some(&v) = sites.last() {
                let (qf, vf) = (q as f64, v as f64);
                start = ((f(q) + qf * qf) - (f(v) + vf * vf)) / (2.0 * (qf - vf));
                if start <= from[from.len() - 1] {
                    sites.pop();
                    from.pop();
                    start = f64::NEG_INFINITY;
                } else {
                    break;
                }
            }
            sites.push(q);
            from.push(start);
        }
        let mut k = 0;
        for x in 0..n {
            while k + 1 < sites.len() && from[k + 1] < x as f64 {
                k += 1;
            }
            let q = sites[k];
            let dx = x as f64 - q as f64;
            let site = near[q] as usize * n + q;
            let i = y * n + x;
            self.out.base[i] = self.heights[site];
            self.out.distance[i] = (dx * dx + f(q)).sqrt() as f32;
        }
    }

    /// The result (complete once [`Self::advance`] returned true).
    pub(super) fn finish(self) -> NearestChannel {
        self.out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn transform(heights: &[f32], n: usize, channel: &[bool]) -> NearestChannel {
        let field = Heightfield::from_vec(n, n, heights.to_vec()).unwrap();
        let mut t = Transform::new(&field, |i| channel[i]);
        // A few rows at a time, as the stage runs it between its ticks.
        while !t.advance(3) {}
        t.finish()
    }

    /// Exact against a brute-force search on scattered channel cells: the distance, and the
    /// base is the height of a channel cell at that distance.
    #[test]
    fn matches_the_brute_force_nearest_channel() {
        let n = 37;
        let mut state = 12345u64;
        let mut next = || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (state >> 33) as usize
        };
        for trial in 0..6 {
            let heights: Vec<f32> = (0..n * n).map(|i| (i * 7 % 101) as f32).collect();
            let mut channel = vec![false; n * n];
            for _ in 0..=trial * 4 {
                channel[next() % (n * n)] = true;
            }
            let near = transform(&heights, n, &channel);
            for i in 0..n * n {
                let (x, y) = ((i % n) as f64, (i / n) as f64);
                let d =
                    |j: usize| ((x - (j % n) as f64).powi(2) + (y - (j / n) as f64).powi(2)).sqrt();
                let best = (0..n * n)
                    .filter(|&j| channel[j])
                    .map(d)
                    .fold(f64::INFINITY, f64::min);
                assert_eq!(near.distance[i], best as f32, "cell {i}, trial {trial}");
                assert!(
                    (0..n * n).any(|j| channel[j] && d(j) == best && heights[j] == near.base[i]),
                    "cell {i}: base {} is no nearest channel's height",
                    near.base[i]
                );
            }
        }
    }

    /// The cells within 8 of a lone channel cell make a disc (the breadth-first walk made
    /// a 17 x 17 square of them).
    #[test]
    fn the_band_round_a_point_is_a_disc() {
        let n = 41;
        let heights = vec![0.0; n * n];
        let mut channel = vec![false; n * n];
        channel[20 * n + 20] = true;
        let near = transform(&heights, n, &channel);
        let within = near.distance.iter().filter(|d| **d <= 8.0).count();
        // pi 8^2 = 201 lattice points, give or take the rim.
        assert_eq!(within, 197);
        assert_eq!(near.distance[(20 + 6) * n + 20 + 6], 72f32.sqrt());
    }

    #[test]
    fn no_channel_means_the_lowest_height_everywhere() {
        let heights = vec![3.0, 1.0, f32::NAN, 2.0];
        let near = transform(&heights, 2, &[false; 4]);
        assert_eq!(near.base, vec![1.0; 4]);
        assert_eq!(near.distance, vec![0.0; 4]);
    }
}
