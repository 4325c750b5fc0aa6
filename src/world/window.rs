//! The wavelet levels of detail of [`crate::wavelet::synthesis::amplify`] (seed paper 001,
//! GSA), computed for one window of the output at a time.
//!
//! Every step of the synthesis is local: each output cell's coefficient is a function of its
//! global coordinates (the source sample on the stride-`2^K` vertices, elsewhere a Gaussian
//! keyed on the cell, [`rng::gaussian`], times the band's standard deviation), and each
//! lifting step of the inverse transform reads the two neighbours at the level's stride, with
//! whole-sample symmetry at the map's edges. So a window, grown by a halo the steps cannot
//! cross, gives its cells exactly the bits the whole map would: an update skipped at the
//! halo's cut edge spoils at most `2 s` cells along each axis per level of stride `s`, under
//! `2^(K+1)` in all, and the halo is wider than that. [`synthesize`] is tested against
//! `amplify` bit for bit.
//!
//! Cost: O((window + 2 halo)^2) time and memory, whatever the map's size.

use crate::heightfield::Heightfield;
use crate::wavelet::Band;
use crate::wavelet::directional::Region;
use crate::wavelet::lifting::{self, count_at};
use crate::wavelet::rng;
use crate::wavelet::synthesis::{SigmaTables, output_len};

/// The steps of `lifting::inverse_level` along one axis: (parity of the samples changed,
/// coefficient), undo the update then undo the predict.
const INVERSE: [(usize, f32); 2] = [(0, -0.25), (1, 0.5)];

/// The cells of `window` of `source` amplified by `levels` new levels (global scope: one
/// standard deviation per level and band in `sigma`), the detail keyed on `key`
/// ([`rng::seed_key`]): row-major, `window.width x window.height`, the same bits as the
/// whole map's `amplify` there. `window` must lie inside the output
/// ([`output_len`] of the source's sides).
pub fn synthesize(
    source: &Heightfield,
    sigma: &SigmaTables,
    levels: u32,
    key: u32,
    window: Region,
) -> Vec<f32> {
    let (ow, oh) = (
        output_len(source.width(), levels),
        output_len(source.height(), levels),
    );
    let halo = (2usize << levels) + 2;
    let x = (
        window.x0.saturating_sub(halo),
        (window.x0 + window.width + halo).min(ow),
    );
    let y = (
        window.y0.saturating_sub(halo),
        (window.y0 + window.height + halo).min(oh),
    );
    let mut grid = Grid {
        x0: x.0,
        y0: y.0,
        w: x.1 - x.0,
        h: y.1 - y.0,
        data: Vec::new(),
    };
    grid.data = (y.0..y.1)
        .flat_map(|gy| (x.0..x.1).map(move |gx| (gx, gy)))
        .map(|(gx, gy)| coefficient(source, sigma, levels, key, gx, gy))
        .collect();
    for t in (0..levels).rev() {
        let s = 1usize << t;
        for (parity, c) in INVERSE {
            grid.along_y(oh, s, parity, c);
        }
        for (parity, c) in INVERSE {
            grid.along_x(ow, s, parity, c);
        }
    }
    let mut out = Vec::with_capacity(window.width * window.height);
    for gy in window.y0..window.y0 + window.height {
        let row = (gy - grid.y0) * grid.w;
        let from = row + window.x0 - grid.x0;
        out.extend_from_slice(&grid.data[from..from + window.width]);
    }
    out
}

/// The coefficient `amplify` places at output cell (`x`, `y`) before the inverse transform
/// (its `fill_row` with the global scope and no mask).
fn coefficient(
    source: &Heightfield,
    sigma: &SigmaTables,
    levels: u32,
    key: u32,
    x: usize,
    y: usize,
) -> f32 {
    let top = 1usize << levels;
    let (sw, sh) = (source.width(), source.height());
    let t = ((x | y) | top).trailing_zeros();
    if t >= levels {
        return source.data()[(y >> levels) * sw + (x >> levels)];
    }
    let Some(band) = Band::at((x >> t) & 1 == 1, (y >> t) & 1 == 1) else {
        return 0.0;
    };
    let sx = ((x + top / 2) >> levels).min(sw - 1);
    let sy = ((y + top / 2) >> levels).min(sh - 1);
    sigma.sigma(levels - t, band, sx, sy) * rng::gaussian(key, x as u32, y as u32)
}

/// A window of the output grid being transformed, in global coordinates.
struct Grid {
    x0: usize,
    y0: usize,
    w: usize,
    h: usize,
    data: Vec<f32>,
}

impl Grid {
    /// One lifting step along x on every row of the stride-`s` sub-grid in the window (`ow`
    /// the map's width); a target whose neighbour lies outside the window is left alone.
    fn along_x(&mut self, ow: usize, s: usize, parity: usize, c: f32) {
        let n = count_at(ow, s);
        let first = self.x0.div_ceil(s);
        let last = (self.x0 + self.w - 1) / s;
        for gy in (self.y0.div_ceil(s) * s..self.y0 + self.h).step_by(s) {
            let row = &mut self.data[(gy - self.y0) * self.w..(gy - self.y0 + 1) * self.w];
            for i in (first..=last).filter(|i| i % 2 == parity) {
                let (l, r) = lifting::neighbours(i, n);
                if l < first || r < first || l > last || r > last {
                    continue;
                }
                let at = |k: usize| k * s - self.x0;
                let sum = row[at(l)] + row[at(r)];
                row[at(i)] += c * sum;
            }
        }
    }

    /// One lifting step along y on every column of the stride-`s` sub-grid in the window
    /// (`oh` the map's height); a target row whose neighbour lies outside is left alone.
    fn along_y(&mut self, oh: usize, s: usize, parity: usize, c: f32) {
        let n = count_at(oh, s);
        let first = self.y0.div_ceil(s);
        let last = (self.y0 + self.h - 1) / s;
        let columns: Vec<usize> = (self.x0.div_ceil(s) * s..self.x0 + self.w)
            .step_by(s)
            .map(|gx| gx - self.x0)
            .collect();
        for k in (first..=last).filter(|k| k % 2 == parity) {
            let (l, r) = lifting::neighbours(k, n);
            if l < first || r < first || l > last || r > last {
                continue;
            }
            let row = |k: usize| (k * s - self.y0) * self.w;
            let (target, above, below) = (row(k), row(l), row(r));
            for &x in &columns {
                let sum = self.data[above + x] + self.data[below + x];
                self.data[target + x] += c * sum;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::jobs::JobCtx;
    use crate::wavelet::synthesis::{AmplifyParams, amplify, prepare};

    /// Windows anywhere (corners, edges, the middle, the whole map) get the bits the whole
    /// map's `amplify` gives there, for one to three new levels.
    #[test]
    fn a_window_has_the_bits_of_the_whole_map() {
        let source = crate::wavelet::fbm::diamond_square(33, 33, 0.7, 5).unwrap();
        for levels in 1..=3 {
            let params = AmplifyParams {
                levels,
                seed: 9,
                ..AmplifyParams::default()
            };
            let whole = pollster::block_on(amplify(&source, &params, None, &JobCtx::detached()))
                .expect("amplified")
                .field;
            let (_, sigma) = prepare(&source, &params).expect("analysed");
            let key = rng::seed_key(params.seed);
            let n = whole.width();
            let windows = [
                Region {
                    x0: 0,
                    y0: 0,
                    width: n,
                    height: n,
                },
                Region {
                    x0: 0,
                    y0: 0,
                    width: 17,
                    height: 9,
                },
                Region {
                    x0: n / 3,
                    y0: n / 5,
                    width: n / 3,
                    height: n / 2,
                },
                Region {
                    x0: n - 29,
                    y0: n - 13,
                    width: 29,
                    height: 13,
                },
                Region {
                    x0: n / 2 - 1,
                    y0: 1,
                    width: 1,
                    height: 1,
                },
            ];
            for window in windows {
                let got = synthesize(&source, &sigma, levels, key, window);
                for (k, v) in got.iter().enumerate() {
                    let (x, y) = (window.x0 + k % window.width, window.y0 + k / window.width);
                    let want = whole.data()[y * n + x];
                    assert_eq!(
                        v.to_bits(),
                        want.to_bits(),
                        "{levels} levels, {window:?}, ({x}, {y})"
                    );
                }
            }
        }
    }
}
