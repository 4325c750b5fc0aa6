//! Depression filling of a world in tiles, exact: the tiled Priority-Flood of Barnes (2016,
//! "Parallel priority-flood depression filling for trillion cell digital elevation models",
//! Computers & Geosciences 96), which gives every cell the level the one-piece
//! Priority-Flood (Barnes, Lehman and Mulla 2014) gives it, with memory bounded by a tile.
//!
//! Three steps, each a stage of tasks ([`super::plan::Task`]):
//! 1. **Each tile alone** ([`flood_tile`]): a Priority-Flood seeded with the tile's
//!    perimeter. Cells on the world's edge are the ocean (label [`OCEAN`]); every other
//!    perimeter cell, when the flood pops it unlabelled, starts a watershed of its own label,
//!    and each cell the flood reaches takes the label of the cell it came from and is raised
//!    to its level (`max`, no epsilon). Where two labels touch, the lowest level at which
//!    water crosses between them is an edge of the tile's spill graph. The tile keeps that
//!    graph and its perimeter ([`TileGraph`], a few kB), not its cells.
//! 2. **The whole world's graph** ([`solve`]): the tiles' graphs, joined by an edge between
//!    every two 8-neighbour cells on either side of a tile boundary (at the higher of their
//!    heights), flooded from the ocean in order of level (a minimax Dijkstra): each label's
//!    spill level is the lowest level at which its water reaches the ocean.
//! 3. **Each tile again** ([`fill_tile`]): the same local flood (the same bits), then every
//!    cell raised to its label's spill level.
//!
//! Why it is exact: every path from a cell to the world's edge leaves its tile through the
//! perimeter, so the one-piece level is at least the tile-local one, and the rest of the way
//! is what the graph measures (Barnes 2016, section 3). A plain fill leaves lakes flat, as
//! GIS tools' "fill sinks" does; the pipeline's own epsilon fill (each cell a representable
//! step above the one that reached it) depends on the order of the whole map's flood and
//! has no exact tiled form, so the world is filled flat.

use std::collections::BinaryHeap;

use serde::{Deserialize, Serialize};

use crate::radix_heap::{RadixHeap, ordered_key};

/// The label of the world's edge: water that reaches it leaves the world.
pub const OCEAN: u32 = 1;
/// No label yet.
const NONE: u32 = 0;

/// A tile's cells after its own flood: raised to their local level, and labelled.
#[derive(Clone, Debug, PartialEq)]
pub struct TileFlood {
    pub filled: Vec<f32>,
    pub labels: Vec<u32>,
    pub graph: TileGraph,
}

/// What step 2 needs of a tile: its watersheds, the spill levels between them, and its
/// perimeter. Heights as `f32` bits (exact through JSON).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct TileGraph {
    pub width: usize,
    pub height: usize,
    /// Labels used: `OCEAN` and `2..labels`.
    pub labels: u32,
    /// `(a, b, level bits)` with `a < b`, the lowest level between labels `a` and `b`.
    pub edges: Vec<(u32, u32, u32)>,
    /// The perimeter's cells in clockwise order from the top-left corner
    /// ([`perimeter_cells`]): `(height bits, label)`.
    pub perimeter: Vec<(u32, u32)>,
}

/// Step 1: floods a `w x h` tile from its perimeter; `on_world_edge(x, y)` says which of its
/// cells lie on the world's edge (the ocean). O(cells log range) with a radix heap.
pub fn flood_tile(
    heights: &[f32],
    w: usize,
    h: usize,
    on_world_edge: impl Fn(usize, usize) -> bool,
) -> TileFlood {
    let mut z = heights.to_vec();
    let mut labels = vec![NONE; w * h];
    let mut closed = vec![false; w * h];
    let mut heap = RadixHeap::new();
    let perimeter = perimeter_cells(w, h);
    for &i in &perimeter {
        closed[i] = true;
        if on_world_edge(i % w, i / w) {
            labels[i] = OCEAN;
        }
        heap.push(ordered_key(z[i]), i as u32);
    }
    let mut next = OCEAN + 1;
    let mut spills = std::collections::HashMap::<(u32, u32), f32>::new();
    while let Some((_, i)) = heap.pop() {
        let i = i as usize;
        if labels[i] == NONE {
            labels[i] = next;
            next += 1;
        }
        let (x, y) = (i % w, i / w);
        for (nx, ny) in neighbours(x, y, w, h) {
            let j = ny * w + nx;
            if labels[j] != NONE {
                if labels[j] != labels[i] {
                    let key = ordered_pair(labels[i], labels[j]);
                    let level = z[i].max(z[j]);
                    let spill = spills.entry(key).or_insert(level);
                    *spill = spill.min(level);
                }
                continue;
            }
            if closed[j] {
                // An unpopped perimeter seed: the edge is recorded when it pops.
                continue;
            }
            closed[j] = true;
            labels[j] = labels[i];
            z[j] = z[j].max(z[i]);
            heap.push(ordered_key(z[j]), j as u32);
        }
    }
    let mut edges: Vec<(u32, u32, u32)> = spills
        .into_iter()
        .map(|((a, b), level)| (a, b, level.to_bits()))
        .collect();
    edges.sort_unstable();
    let graph = TileGraph {
        width: w,
        height: h,
        labels: next,
        edges,
        perimeter: perimeter
            .iter()
            .map(|&i| (z[i].to_bits(), labels[i]))
            .collect(),
    };
    TileFlood {
        filled: z,
        labels,
        graph,
    }
}

/// Step 3: the tile's cells raised to their watersheds' spill levels (`levels[label]`, from
/// [`solve`]).
pub fn fill_tile(flood: TileFlood, levels: &[f32]) -> Vec<f32> {
    let TileFlood {
        mut filled, labels, ..
    } = flood;
    for (z, label) in filled.iter_mut().zip(labels) {
        if let Some(level) = levels.get(label as usize) {
            *z = z.max(*level);
        }
    }
    filled
}

/// The tiles of a world, `per x per` of them in rows, each of `tile` cells a side but the
/// last row and column (the world is `size` cells a side).
#[derive(Clone, Copy, Debug)]
pub struct Layout {
    pub size: usize,
    pub tile: usize,
}

impl Layout {
    fn per(&self) -> usize {
        self.size.div_ceil(self.tile)
    }

    /// Tile `k`'s corner and size.
    fn tile_rect(&self, k: usize) -> (usize, usize, usize, usize) {
        let per = self.per();
        let (x0, y0) = ((k % per) * self.tile, (k / per) * self.tile);
        (
            x0,
            y0,
            self.tile.min(self.size - x0),
            self.tile.min(self.size - y0),
        )
    }
}

/// Step 2: each tile's spill levels, indexed by its labels (`levels[k][label]`; the ocean's
/// is minus infinity), from every tile's graph (`graphs[k]`, in tile order).
pub fn solve(layout: Layout, graphs: &[TileGraph]) -> Vec<Vec<f32>> {
    // Global label ids: the ocean is 0, then each tile's own labels (2..) in tile order.
    let mut base = Vec::with_capacity(graphs.len());
    let mut count = 1usize;
    for g in graphs {
        base.push(count);
        count += g.labels.saturating_sub(OCEAN + 1) as usize;
    }
    let id = |k: usize, label: u32| -> usize {
        if label == OCEAN {
            0
        } else {
            base[k] + (label - OCEAN - 1) as usize
        }
    };
    let mut adjacent: Vec<Vec<(usize, f32)>> = vec![Vec::new(); count];
    let mut link = |a: usize, b: usize, level: f32| {
        if a != b {
            adjacent[a].push((b, level));
            adjacent[b].push((a, level));
        }
    };
    for (k, g) in graphs.iter().enumerate() {
        for &(a, b, level) in &g.edges {
            link(id(k, a), id(k, b), f32::from_bits(level));
        }
    }
    // Across tile boundaries: each perimeter cell with its 8-neighbours in the tile to its
    // right, below, below-right and below-left (each pair once).
    let per = layout.per();
    let at = |x: usize, y: usize| -> (usize, f32, u32) {
        let k = (y / layout.tile) * per + x / layout.tile;
        let (x0, y0, w, h) = layout.tile_rect(k);
        let index = perimeter_index(x - x0, y - y0, w, h);
        let (bits, label) = graphs[k].perimeter[index];
        (k, f32::from_bits(bits), label)
    };
    for (k, g) in graphs.iter().enumerate() {
        let (x0, y0, w, h) = layout.tile_rect(k);
        for i in perimeter_cells(g.width, g.height) {
            let (x, y) = (x0 + i % w, y0 + i / w);
            let (_, z, label) = at(x, y);
            for (nx, ny) in neighbours(x, y, layout.size, layout.size) {
                let other = (ny / layout.tile) * per + nx / layout.tile;
                if other <= k {
                    continue;
                }
                let (_, nz, nlabel) = at(nx, ny);
                link(id(k, label), id(other, nlabel), z.max(nz));
            }
        }
        debug_assert_eq!((g.width, g.height), (w, h));
    }
    // Flood the graph from the ocean, lowest level first.
    let mut level = vec![f32::INFINITY; count];
    level[0] = f32::NEG_INFINITY;
    let mut heap = BinaryHeap::new();
    heap.push(std::cmp::Reverse((ordered_key(f32::NEG_INFINITY), 0usize)));
    let mut done = vec![false; count];
    while let Some(std::cmp::Reverse((_, u))) = heap.pop() {
        if std::mem::replace(&mut done[u], true) {
            continue;
        }
        for &(v, spill) in &adjacent[u] {
            let reach = level[u].max(spill);
            if reach < level[v] {
                level[v] = reach;
                heap.push(std::cmp::Reverse((ordered_key(reach), v)));
            }
        }
    }
    graphs
        .iter()
        .enumerate()
        .map(|(k, g)| {
            (0..g.labels)
                .map(|label| match label {
                    NONE => f32::NEG_INFINITY,
                    _ => level[id(k, label)],
                })
                .collect()
        })
        .collect()
}

/// The row-major indices of a `w x h` tile's perimeter, clockwise from the top-left corner:
/// the top row, the right column, the bottom row backwards, the left column upwards (each
/// cell once).
pub fn perimeter_cells(w: usize, h: usize) -> Vec<usize> {
    if w == 0 || h == 0 {
        return Vec::new();
    }
    if h == 1 {
        return (0..w).collect();
    }
    if w == 1 {
        return (0..h).map(|y| y * w).collect();
    }
    let mut cells = Vec::with_capacity(2 * (w + h) - 4);
    cells.extend(0..w);
    cells.extend((1..h).map(|y| y * w + w - 1));
    cells.extend((0..w - 1).rev().map(|x| (h - 1) * w + x));
    cells.extend((1..h - 1).rev().map(|y| y * w));
    cells
}

/// Where cell (`x`, `y`) of a `w x h` tile's perimeter lies in [`perimeter_cells`].
fn perimeter_index(x: usize, y: usize, w: usize, h: usize) -> usize {
    if h == 1 {
        return x;
    }
    if w == 1 {
        return y;
    }
    if y == 0 {
        x
    } else if x == w - 1 {
        w - 1 + y
    } else if y == h - 1 {
        w + h - 2 + (w - 1 - x)
    } else {
        2 * w + h - 3 + (h - 1 - y)
    }
}

/// The 8-neighbours of (`x`, `y`) inside a `w x h` grid.
fn neighbours(x: usize, y: usize, w: usize, h: usize) -> impl Iterator<Item = (usize, usize)> {
    (-1i64..=1)
        .flat_map(|dy| (-1i64..=1).map(move |dx| (dx, dy)))
        .filter(|&d| d != (0, 0))
        .filter_map(move |(dx, dy)| {
            let (nx, ny) = (x as i64 + dx, y as i64 + dy);
            (nx >= 0 && ny >= 0 && (nx as usize) < w && (ny as usize) < h)
                .then_some((nx as usize, ny as usize))
        })
}

fn ordered_pair(a: u32, b: u32) -> (u32, u32) {
    (a.min(b), a.max(b))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A rough terrain full of pits: a tilted, wavy surface with noise.
    fn rough(n: usize, seed: u64) -> Vec<f32> {
        let mut state = seed | 1;
        (0..n * n)
            .map(|i| {
                state ^= state << 13;
                state ^= state >> 7;
                state ^= state << 17;
                let (x, y) = ((i % n) as f32, (i / n) as f32);
                let noise = (state % 1000) as f32 / 40.0;
                0.3 * x + 10.0 * (y * 0.21).sin() * (x * 0.17).cos() + noise
            })
            .collect()
    }

    /// The one-piece Priority-Flood: the whole world as one tile.
    fn one_piece(heights: &[f32], n: usize) -> Vec<f32> {
        let flood = flood_tile(heights, n, n, |_, _| true);
        fill_tile(flood, &[])
    }

    /// Steps 1 to 3 over tiles of `tile` cells.
    fn tiled(heights: &[f32], n: usize, tile: usize) -> Vec<f32> {
        let layout = Layout { size: n, tile };
        let per = layout.per();
        let cut = |k: usize| {
            let (x0, y0, w, h) = layout.tile_rect(k);
            let cells: Vec<f32> = (y0..y0 + h)
                .flat_map(|y| heights[y * n + x0..y * n + x0 + w].to_vec())
                .collect();
            let edge = move |x: usize, y: usize| {
                x0 + x == 0 || y0 + y == 0 || x0 + x == n - 1 || y0 + y == n - 1
            };
            (flood_tile(&cells, w, h, edge), (x0, y0, w, h))
        };
        let graphs: Vec<TileGraph> = (0..per * per).map(|k| cut(k).0.graph).collect();
        // Through JSON, as the tasks hand them on.
        let graphs: Vec<TileGraph> =
            serde_json::from_str(&serde_json::to_string(&graphs).unwrap()).unwrap();
        let levels = solve(layout, &graphs);
        let mut out = vec![0.0; n * n];
        for (k, tile_levels) in levels.iter().enumerate() {
            let (flood, (x0, y0, w, h)) = cut(k);
            let filled = fill_tile(flood, tile_levels);
            for y in 0..h {
                out[(y0 + y) * n + x0..(y0 + y) * n + x0 + w]
                    .copy_from_slice(&filled[y * w..(y + 1) * w]);
            }
        }
        out
    }

    #[test]
    fn a_world_filled_in_tiles_has_the_bits_of_the_one_piece_fill() {
        for (n, tile, seed) in [
            (64, 16, 1),
            (100, 32, 7),
            (97, 16, 3),
            (128, 64, 11),
            (50, 48, 5),
        ] {
            let heights = rough(n, seed);
            let whole = one_piece(&heights, n);
            let raised = whole.iter().zip(&heights).filter(|(a, b)| a > b).count();
            assert!(raised > n * n / 20, "{n}: only {raised} cells in pits");
            let parts = tiled(&heights, n, tile);
            let same = whole
                .iter()
                .zip(&parts)
                .all(|(a, b)| a.to_bits() == b.to_bits());
            assert!(same, "{n}^2 in tiles of {tile}: the fills differ");
        }
    }

    #[test]
    fn the_one_piece_fill_leaves_no_pit_and_never_lowers() {
        let n = 80;
        let heights = rough(n, 9);
        let filled = one_piece(&heights, n);
        assert!(filled.iter().zip(&heights).all(|(a, b)| a >= b));
        // Every interior cell has a neighbour no higher (flat lakes drain across their flat).
        for y in 1..n - 1 {
            for x in 1..n - 1 {
                let z = filled[y * n + x];
                let lowest = neighbours(x, y, n, n)
                    .map(|(a, b)| filled[b * n + a])
                    .fold(f32::INFINITY, f32::min);
                assert!(lowest <= z, "({x}, {y}) is a pit");
            }
        }
    }

    #[test]
    fn a_lake_across_four_tiles_fills_to_its_rim() {
        // A bowl centred on a tile corner, its rim at 10 with a notch at 6 on one side.
        let n = 32;
        let mut heights = vec![10.0f32; n * n];
        for y in 1..n - 1 {
            for x in 1..n - 1 {
                let d = ((x as f32 - 16.0).powi(2) + (y as f32 - 16.0).powi(2)).sqrt();
                if d < 10.0 {
                    heights[y * n + x] = d * 0.2;
                }
            }
        }
        for x in 16..n {
            heights[16 * n + x] = heights[16 * n + x].min(6.0);
        }
        heights[16 * n + n - 1] = 6.0;
        let parts = tiled(&heights, n, 16);
        assert_eq!(parts[16 * n + 16], 6.0);
        assert_eq!(parts, one_piece(&heights, n));
    }

    #[test]
    fn the_perimeter_is_walked_once_in_order() {
        for (w, h) in [(1, 1), (5, 1), (1, 4), (2, 2), (7, 5), (16, 16)] {
            let cells = perimeter_cells(w, h);
            let mut seen = cells.clone();
            seen.sort_unstable();
            seen.dedup();
            assert_eq!(seen.len(), cells.len(), "{w}x{h}");
            for (k, &i) in cells.iter().enumerate() {
                assert_eq!(perimeter_index(i % w, i / w, w, h), k, "{w}x{h} cell {i}");
            }
        }
    }
}
