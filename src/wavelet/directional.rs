//! The source of new levels of detail interpolated along its valleys and crests, not across
//! them: the synthesis's interpolation corrected where the source has an edge.
//!
//! The levels of detail ([`super::synthesis`], and a world's tiles, `world::window`)
//! interpolate the source linearly along each axis (the lifting's predict: with no detail,
//! the inverse transform is the bilinear interpolation), and add the detail. A valley or a
//! crest one source cell wide that runs diagonally across the grid is then a string of
//! beads: the cell between two of its cells takes the mean of two valley cells and two bank
//! cells, half as deep, so at the output's resolution every small valley running across the
//! axes is a serrated line (on the default scene, 4097^2 from 1025^2: a valley 1-2 m deep
//! was 0.6 m shallower between its source cells than at them).
//!
//! Here the source (a scene's eroded terrain, a DEM, a world's global build) is interpolated
//! once more, level by level, with the edge-directed
//! rule of directional cubic convolution (Zhou, Shen and Zeng 2012, "Image zooming using
//! directional cubic convolution interpolation", IET Image Processing 6(6)): each new cell
//! between four cells takes the mean of the diagonal pair along which the surface bends
//! least (the second differences along each diagonal at the square's four corners: a valley
//! or a crest is straight along itself and bent across), and each new cell between two the
//! mean of the axis pair along which it bends least at its four neighbours; the two pairs
//! weighted by the other's bending to the power [`SHARPNESS`]. The world's cells then take
//! the difference between this and the linear interpolation ([`correct`], and over a whole
//! output in bands of rows, [`correct_field`]): the detail the levels added stays, the
//! interpolation under it follows the edges.
//!
//! Departures from the paper: the direction is chosen by second differences, not first (on
//! a slope both diagonals rise, and first differences saw a direction where there is none:
//! a herringbone on every slope); the interpolation along it is linear (two cells), not
//! cubic (four), so it never overshoots its neighbours (no new pits or peaks); the weights
//! are `1 / (1 + ratio^k)`, free of the paper's `1 +` offset in height units and of its hard
//! switch at a ratio of 1.15, so the result varies smoothly with the heights.
//!
//! Every cell is a function of the source and its position (each level is computed over the
//! rectangle the next needs, with a margin wider than the rule reaches), so a region gives
//! its cells the bits of the whole output: a world's tiles are the same bits whatever the
//! tasks, and an output corrected in bands of rows is the same on any number of threads.

use crate::heightfield::Heightfield;
use crate::jobs::{Cancelled, JobCtx};

/// How sharply the interpolation follows the direction that bends least: the weight of a
/// direction that bends `r` times as much as the other is `1 / (1 + r^SHARPNESS)` (a ratio
/// of 2, 0.06).
pub const SHARPNESS: i32 = 4;

/// Cells of margin each level computes around what the next level (or the window) reads:
/// a cell between two reads its level's cells up to three away, and a level's cells near
/// its rectangle's cut edge (clamped there) are not the whole world's.
const MARGIN: usize = 4;

/// A rectangle of an output's cells: its first column and row, and its size.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Region {
    pub x0: usize,
    pub y0: usize,
    pub width: usize,
    pub height: usize,
}

/// Output rows a band of [`correct_field`] holds at most (about a million cells a band on
/// a 4097^2 output; its margins add a few percent).
const BAND_CELLS: usize = 1 << 20;

/// [`correct`] over the whole of `amplified`, `levels` new levels above `source`
/// (`2^levels (side - 1) + 1` cells a side), in bands of rows: natively each band of a
/// group on a thread, a tick between groups. Every band is a [`Region`], so the bits do not
/// depend on the split. O(output cells); memory a band's levels.
pub async fn correct_field(
    source: &Heightfield,
    levels: u32,
    amplified: &mut Heightfield,
    ctx: &JobCtx,
) -> Result<(), Cancelled> {
    let width = amplified.width().max(1);
    let rows = amplified.height();
    let band = (BAND_CELLS / width).max(1);
    let threads = crate::parallel::threads();
    let group = band * threads;
    let data = amplified.data_mut();
    for start in (0..rows).step_by(group) {
        ctx.tick_of(start, rows, "detail: following the valleys")
            .await?;
        let end = (start + group).min(rows);
        crate::parallel::for_each_band(
            &mut data[start * width..end * width],
            band * width,
            |k, cells| {
                let region = Region {
                    x0: 0,
                    y0: start + k * band,
                    width,
                    height: cells.len() / width,
                };
                correct(source, levels, region, cells);
            },
        );
    }
    Ok(())
}

/// Adds to `heights`, the cells of `window` of an output made by `levels` levels of detail
/// above `world`, the edge-directed interpolation of `world` less its linear interpolation.
pub fn correct(world: &Heightfield, levels: u32, window: Region, heights: &mut [f32]) {
    if levels == 0 || window.width == 0 || window.height == 0 {
        return;
    }
    let directed = interpolate(world, levels, window);
    let s = 1usize << levels;
    let (w, h) = (world.width(), world.height());
    let z = world.data();
    let at = |x: usize, y: usize| f64::from(z[y * w + x]);
    for (row, y) in heights
        .chunks_exact_mut(window.width)
        .zip(window.y0..window.y0 + window.height)
    {
        // The linear interpolation (bilinear at the world's cells) of the global build.
        let y0 = (y / s).min(h - 2);
        let fy = (y - y0 * s) as f64 / s as f64;
        for (cell, x) in row.iter_mut().zip(window.x0..) {
            let x0 = (x / s).min(w - 2);
            let fx = (x - x0 * s) as f64 / s as f64;
            let top = at(x0, y0) + fx * (at(x0 + 1, y0) - at(x0, y0));
            let bottom = at(x0, y0 + 1) + fx * (at(x0 + 1, y0 + 1) - at(x0, y0 + 1));
            let linear = top + fy * (bottom - top);
            *cell += (directed.inside(x as isize, y as isize) - linear) as f32;
        }
    }
}

/// A rectangle of one level's cells: its first column and row, its size, its values; the
/// level's grid is `side` cells each way (reads past it are mirrored, [`Level::at`]).
#[derive(Clone, Debug)]
struct Level {
    x0: usize,
    y0: usize,
    w: usize,
    h: usize,
    side: [usize; 2],
    v: Vec<f64>,
}

impl Level {
    /// The value at (`x`, `y`) of the level's grid, mirrored at the grid's edges (whole
    /// sample: -1 is 1, which keeps a cell's parity, so a read never lands on a cell not yet
    /// computed), then clamped to the rectangle (only its margin reads past it).
    fn at(&self, x: isize, y: isize) -> f64 {
        let clamp = |v: isize, side: usize, lo: usize, len: usize| {
            let last = side as isize - 1;
            let v = if v < 0 {
                -v
            } else if v > last {
                2 * last - v
            } else {
                v
            };
            (v.clamp(0, last) as usize).clamp(lo, lo + len - 1) - lo
        };
        let x = clamp(x, self.side[0], self.x0, self.w);
        let y = clamp(y, self.side[1], self.y0, self.h);
        self.v[y * self.w + x]
    }

    /// A reader of the cells within `r` of (`x`, `y`): [`Level::inside`] where they all lie
    /// in the rectangle, else [`Level::at`] (the same values where both read).
    fn reader(&self, x: isize, y: isize, r: isize) -> impl Fn(isize, isize) -> f64 + '_ {
        let fast = self.holds(x, y, r);
        move |i, j| {
            if fast {
                self.inside(i, j)
            } else {
                self.at(i, j)
            }
        }
    }

    /// A level of the same rectangle with no values.
    fn clone_shape(&self) -> Self {
        Self {
            v: Vec::new(),
            ..*self
        }
    }

    /// Whether every cell within `r` of (`x`, `y`) lies in the rectangle (which lies in the
    /// grid), so [`Level::inside`] reads them as [`Level::at`] does.
    fn holds(&self, x: isize, y: isize, r: isize) -> bool {
        let (x0, y0) = (self.x0 as isize, self.y0 as isize);
        x - r >= x0 && y - r >= y0 && x + r < x0 + self.w as isize && y + r < y0 + self.h as isize
    }

    /// The value at (`x`, `y`), a cell of the rectangle.
    #[inline(always)]
    fn inside(&self, x: isize, y: isize) -> f64 {
        self.v[(y - self.y0 as isize) as usize * self.w + (x - self.x0 as isize) as usize]
    }
}

/// The edge-directed interpolation of `world` over `levels` levels, on the rectangle of the
/// last level that covers `window`.
fn interpolate(world: &Heightfield, levels: u32, window: Region) -> Level {
    // The rectangle each level needs, from the last down to the global build.
    let mut sides = vec![[world.width(), world.height()]];
    for _ in 0..levels {
        let [w, h] = sides[sides.len() - 1];
        sides.push([2 * w - 1, 2 * h - 1]);
    }
    // Each level is computed over what the next reads, and MARGIN cells more each way: its
    // cells between two read the level's own cells up to three away.
    let grow = |[x0, y0, x1, y1]: [usize; 4], by: usize, [w, h]: [usize; 2]| {
        [
            x0.saturating_sub(by),
            y0.saturating_sub(by),
            (x1 + by).min(w),
            (y1 + by).min(h),
        ]
    };
    let mut needed = [
        window.x0,
        window.y0,
        window.x0 + window.width,
        window.y0 + window.height,
    ];
    let mut rects = Vec::new();
    for l in (1..=levels as usize).rev() {
        let computed = grow(needed, MARGIN, sides[l]);
        rects.push(computed);
        // The centres read the coarse cells one before and two after their square.
        let [x0, y0, x1, y1] = computed;
        needed = grow([x0 / 2, y0 / 2, x1 / 2 + 1, y1 / 2 + 1], 2, sides[l - 1]);
    }
    rects.push(needed);
    rects.reverse();
    let [x0, y0, x1, y1] = rects[0];
    let z = world.data();
    let mut level = Level {
        x0,
        y0,
        w: x1 - x0,
        h: y1 - y0,
        side: sides[0],
        v: (y0..y1)
            .flat_map(|y| (x0..x1).map(move |x| f64::from(z[y * world.width() + x])))
            .collect(),
    };
    for l in 1..=levels as usize {
        level = refine(&level, rects[l], sides[l]);
    }
    level
}

/// One level finer than `coarse`: rectangle `[x0, y0, x1, y1)` of a grid `side` cells a
/// side. The cells on the coarse grid keep their values; the cells between four take the
/// diagonal pair's mean ([`centre`]); the cells between two, the axis pair's ([`edge`]).
fn refine(coarse: &Level, rect: [usize; 4], side: [usize; 2]) -> Level {
    let [x0, y0, x1, y1] = rect;
    let mut fine = Level {
        x0,
        y0,
        w: x1 - x0,
        h: y1 - y0,
        side,
        v: vec![0.0; (x1 - x0) * (y1 - y0)],
    };
    // First the coarse cells and the centres, each centre reading the bends of its corners.
    let every = |_: usize, _: usize| true;
    let down = bends(coarse, (1, 1), every);
    let up = bends(coarse, (1, -1), every);
    for y in y0..y1 {
        for x in x0..x1 {
            let (cx, cy) = ((x / 2) as isize, (y / 2) as isize);
            let value = match (x % 2 == 1, y % 2 == 1) {
                (false, false) => coarse.at(cx, cy),
                (true, true) => centre(coarse, (&down, &up), cx, cy),
                _ => continue,
            };
            fine.v[(y - y0) * fine.w + (x - x0)] = value;
        }
    }
    // Then the cells between two, reading the bends of the cells around them along each
    // axis (cells two apart: coarse cells and centres).
    let known = |x: usize, y: usize| x % 2 == y % 2;
    let along_x = bends(&fine, (2, 0), known);
    let along_y = bends(&fine, (0, 2), known);
    for y in y0..y1 {
        for x in x0..x1 {
            let (odd_x, odd_y) = (x % 2 == 1, y % 2 == 1);
            if odd_x == odd_y {
                continue;
            }
            let (fx, fy) = (x as isize, y as isize);
            let value = if odd_x && (y == 0 || y + 1 == side[1]) {
                // On the grid's edge only the pair along it is the world's.
                0.5 * (fine.at(fx - 1, fy) + fine.at(fx + 1, fy))
            } else if odd_y && (x == 0 || x + 1 == side[0]) {
                0.5 * (fine.at(fx, fy - 1) + fine.at(fx, fy + 1))
            } else {
                edge(&fine, (&along_x, &along_y), fx, fy)
            };
            fine.v[(y - y0) * fine.w + (x - x0)] = value;
        }
    }
    fine
}

/// The second differences `|v(p - d) - 2 v(p) + v(p + d)|` of `level` along `d` at each of
/// its cells where `at_cell` (0 elsewhere), as a level of the same rectangle.
fn bends(level: &Level, (dx, dy): (isize, isize), at_cell: impl Fn(usize, usize) -> bool) -> Level {
    let reach = dx.abs().max(dy.abs());
    let mut v = vec![0.0; level.w * level.h];
    for y in level.y0..level.y0 + level.h {
        for x in level.x0..level.x0 + level.w {
            if !at_cell(x, y) {
                continue;
            }
            let (fx, fy) = (x as isize, y as isize);
            let read = level.reader(fx, fy, reach);
            v[(y - level.y0) * level.w + (x - level.x0)] =
                (read(fx - dx, fy - dy) - 2.0 * read(fx, fy) + read(fx + dx, fy + dy)).abs();
        }
    }
    Level {
        v,
        ..level.clone_shape()
    }
}

/// The weight of direction `a` against `b` given how much the surface bends along each: one
/// where it bends far less along `a`, a half where alike (or not at all).
fn weight(a: f64, b: f64) -> f64 {
    if a + b <= 0.0 {
        return 0.5;
    }
    let (a, b) = (a.powi(SHARPNESS), b.powi(SHARPNESS));
    if a + b <= 0.0 || !(a + b).is_finite() {
        return if a < b {
            1.0
        } else if a > b {
            0.0
        } else {
            0.5
        };
    }
    b / (a + b)
}

/// The centre of coarse square (`x`, `y`)-(`x + 1`, `y + 1`): the mean of the diagonal pair
/// along which the surface bends least, its second differences along each diagonal
/// (`down`, `up`) at the square's four corners (a valley or a crest is straight along itself
/// and bent across).
fn centre(c: &Level, (down, up): (&Level, &Level), x: isize, y: isize) -> f64 {
    let corners = [(x, y), (x + 1, y), (x, y + 1), (x + 1, y + 1)];
    let sum = |b: &Level| {
        let b = b.reader(x, y, 1);
        corners.iter().map(|&(i, j)| b(i, j)).sum::<f64>()
    };
    let c = c.reader(x, y, 1);
    let along_down = 0.5 * (c(x, y) + c(x + 1, y + 1));
    let along_up = 0.5 * (c(x + 1, y) + c(x, y + 1));
    let w = weight(sum(down), sum(up));
    w * along_down + (1.0 - w) * along_up
}

/// A cell between two coarse cells (along x or y), its other two neighbours centres: the
/// mean of the pair along which the surface bends least, its second differences along each
/// axis (`along_x`, `along_y`) at the four neighbours.
fn edge(f: &Level, (along_x, along_y): (&Level, &Level), x: isize, y: isize) -> f64 {
    let around = [(x - 1, y), (x + 1, y), (x, y - 1), (x, y + 1)];
    let sum = |b: &Level| {
        let b = b.reader(x, y, 1);
        around.iter().map(|&(i, j)| b(i, j)).sum::<f64>()
    };
    let f = f.reader(x, y, 1);
    let along_h = 0.5 * (f(x - 1, y) + f(x + 1, y));
    let along_v = 0.5 * (f(x, y - 1) + f(x, y + 1));
    let w = weight(sum(along_x), sum(along_y));
    w * along_h + (1.0 - w) * along_v
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `world` at (`x`, `y`) global cells, bilinear: the levels' interpolation without detail.
    fn bilinear(world: &Heightfield, x: f64, y: f64) -> f64 {
        let (w, h) = (world.width(), world.height());
        let (x0, y0) = ((x as usize).min(w - 2), (y as usize).min(h - 2));
        let (fx, fy) = (x - x0 as f64, y - y0 as f64);
        let z = world.data();
        let at = |x: usize, y: usize| f64::from(z[y * w + x]);
        let top = at(x0, y0) + fx * (at(x0 + 1, y0) - at(x0, y0));
        let bottom = at(x0, y0 + 1) + fx * (at(x0 + 1, y0 + 1) - at(x0, y0 + 1));
        top + fy * (bottom - top)
    }

    fn field(n: usize, f: impl Fn(f64, f64) -> f64) -> Heightfield {
        let data = (0..n * n)
            .map(|i| f((i % n) as f64, (i / n) as f64) as f32)
            .collect();
        Heightfield::from_vec(n, n, data).unwrap()
    }

    /// The whole world `levels` levels above `world` with no detail: the linear
    /// interpolation, corrected or not.
    fn whole(world: &Heightfield, levels: u32, corrected: bool) -> (Vec<f32>, usize) {
        let side = ((world.width() - 1) << levels) + 1;
        let s = f64::from(1u32 << levels);
        let mut cells: Vec<f32> = (0..side * side)
            .map(|i| bilinear(world, (i % side) as f64 / s, (i / side) as f64 / s) as f32)
            .collect();
        if corrected {
            let window = Region {
                x0: 0,
                y0: 0,
                width: side,
                height: side,
            };
            correct(world, levels, window, &mut cells);
        }
        (cells, side)
    }

    /// How much higher than its cells a valley one global cell wide is between them, on
    /// average along its course: the cell halfway between two of its global cells, less
    /// their mean (`course(t)`: global cell `t` of the valley).
    fn beads(cells: &[f32], side: usize, course: impl Fn(usize) -> [usize; 2]) -> f64 {
        let at = |[x, y]: [usize; 2]| f64::from(cells[y * side + x]);
        let (mut sum, mut count) = (0.0, 0);
        for t in 2..18 {
            let (a, b) = (course(t), course(t + 1));
            let node = |[x, y]: [usize; 2]| [4 * x, 4 * y];
            let middle = [2 * (a[0] + b[0]), 2 * (a[1] + b[1])];
            sum += at(middle) - 0.5 * (at(node(a)) + at(node(b)));
            count += 1;
        }
        sum / f64::from(count)
    }

    /// Global cell `t` of a valley's course.
    type Course = fn(usize) -> [usize; 2];

    /// A valley (and a crest) one global cell wide along either diagonal, cut into a tilted
    /// plane: linear interpolation leaves it half as deep halfway between its global cells (a
    /// string of beads); the edge-directed one keeps its depth there.
    #[test]
    fn a_diagonal_valley_or_crest_is_not_beaded() {
        let n = 21;
        for depth in [4.0, -4.0] {
            let down = field(n, |x, y| 0.3 * x + 0.2 * y - depth * f64::from(x == y));
            let up = field(n, |x, y| {
                0.3 * x - 0.2 * y - depth * f64::from(x + y == 20.0)
            });
            let courses: [(&Heightfield, Course); 2] =
                [(&down, |t| [t, t]), (&up, |t| [t, 20 - t])];
            for (world, course) in courses {
                let (linear, side) = whole(world, 2, false);
                let (directed, _) = whole(world, 2, true);
                let before = beads(&linear, side, course) / depth;
                let after = beads(&directed, side, course) / depth;
                assert!((before - 0.5).abs() < 0.05, "linear: {before}");
                assert!(after.abs() < 0.05, "edge-directed: {after} of the depth");
            }
        }
    }

    /// A plane is its own interpolation: the correction is nothing.
    #[test]
    fn a_plane_is_left_as_it_is() {
        let world = field(17, |x, y| 5.0 + 0.3 * x - 0.7 * y);
        let (linear, _) = whole(&world, 3, false);
        let (directed, _) = whole(&world, 3, true);
        for (a, b) in linear.iter().zip(&directed) {
            assert!((a - b).abs() < 1e-4, "{a} against {b}");
        }
    }

    /// A rough surface: each window's correction is the bits of the whole world's there
    /// (windows at the world's edges and corners, across the middle, one cell), and no cell
    /// leaves the range of the global cells within two of it (the means never overshoot).
    #[test]
    fn a_window_is_the_bits_of_the_whole_and_never_overshoots() {
        let n = 33;
        let world = field(n, |x, y| {
            let noise = f64::from(crate::wavelet::rng::gaussian(7, x as u32, y as u32));
            (0.4 * x).sin() * 20.0 + (0.23 * y + 0.1 * x).cos() * 15.0 + 6.0 * noise
        });
        for levels in [1, 2, 3] {
            let side = ((n - 1) << levels) + 1;
            let mut all = vec![0.0f32; side * side];
            let everything = Region {
                x0: 0,
                y0: 0,
                width: side,
                height: side,
            };
            correct(&world, levels, everything, &mut all);
            let windows = [
                (0, 0, 10, 10),
                (side - 13, side - 7, 13, 7),
                (side / 3, 0, 21, side),
                (side / 2, side / 2 - 5, 1, 1),
                (5, side / 2, side - 5, 9),
            ];
            for (x0, y0, width, height) in windows {
                let window = Region {
                    x0,
                    y0,
                    width,
                    height,
                };
                let mut cells = vec![0.0f32; width * height];
                correct(&world, levels, window, &mut cells);
                for (i, v) in cells.iter().enumerate() {
                    let (x, y) = (x0 + i % width, y0 + i / width);
                    assert_eq!(
                        v.to_bits(),
                        all[y * side + x].to_bits(),
                        "levels {levels}, window {window:?}, cell ({x}, {y})"
                    );
                }
            }
            let (directed, _) = whole(&world, levels, true);
            let s = 1usize << levels;
            let z = world.data();
            for (i, v) in directed.iter().enumerate() {
                let (gx, gy) = ((i % side) / s, (i / side) / s);
                let near = (gy.saturating_sub(2)..(gy + 3).min(n))
                    .flat_map(|y| (gx.saturating_sub(2)..(gx + 3).min(n)).map(move |x| (x, y)))
                    .map(|(x, y)| z[y * n + x]);
                let (lo, hi) = near.fold((f32::INFINITY, f32::NEG_INFINITY), |(lo, hi), v| {
                    (lo.min(v), hi.max(v))
                });
                assert!(*v >= lo - 1e-3 && *v <= hi + 1e-3, "{v} outside {lo}..{hi}");
            }
        }
    }
}
