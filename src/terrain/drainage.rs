//! Does the terrain drain along its rivers? D8 steepest descent on the final heights.

use serde::Serialize;

use crate::heightfield::Heightfield;
use crate::skeleton::CellKind;

/// Drainage measures of a terrain (`strahler generate --report`, tests).
#[derive(Clone, Debug, Default, Serialize)]
pub struct Drainage {
    pub river_cells: usize,
    /// River cells whose steepest descent leads to a river cell or off the map.
    pub river_cells_draining: usize,
    pub river_fraction: f64,
    /// Cells whose descent path reaches the map border (an outlet).
    pub cells_to_outlet: usize,
    pub outlet_fraction: f64,
    /// Interior cells with no lower neighbour (pits).
    pub pit_cells: usize,
    pub pit_fraction: f64,
}

const NEIGHBOURS: [(i64, i64, f32); 8] = [
    (-1, 0, 1.0),
    (1, 0, 1.0),
    (0, -1, 1.0),
    (0, 1, 1.0),
    (-1, -1, std::f32::consts::SQRT_2),
    (1, -1, std::f32::consts::SQRT_2),
    (-1, 1, std::f32::consts::SQRT_2),
    (1, 1, std::f32::consts::SQRT_2),
];

/// D8 receivers: the neighbour of steepest descent, `None` for a cell with no lower
/// neighbour. Border cells drain off the map when nothing inside is lower.
fn receivers(field: &Heightfield) -> Vec<Option<u32>> {
    let (w, h) = (field.width() as i64, field.height() as i64);
    let z = field.data();
    (0..w * h)
        .map(|i| {
            let (x, y) = (i % w, i / w);
            let mut best = None;
            let mut steepest = 0.0f32;
            for (dx, dy, dist) in NEIGHBOURS {
                let (nx, ny) = (x + dx, y + dy);
                if nx < 0 || ny < 0 || nx >= w || ny >= h {
                    continue;
                }
                let j = ny * w + nx;
                let slope = (z[i as usize] - z[j as usize]) / dist;
                if slope > steepest {
                    steepest = slope;
                    best = Some(j as u32);
                }
            }
            best
        })
        .collect()
}

/// Whether any interior cell has no strictly lower neighbour (a pit or a flat). O(cells).
/// A harmonic fill obeys the maximum principle, so pits can only sit on fixed cells; most
/// terrains have none and skip the flooding below.
pub fn has_pits(field: &Heightfield) -> bool {
    let (w, h) = (field.width() as i64, field.height() as i64);
    let z = field.data();
    (1..h - 1).any(|y| {
        (1..w - 1).any(|x| {
            let c = z[(y * w + x) as usize];
            !NEIGHBOURS
                .iter()
                .any(|(dx, dy, _)| z[((y + dy) * w + x + dx) as usize] < c)
        })
    })
}

/// What [`fill_depressions`] changed.
#[derive(Clone, Copy, Debug, Default, Serialize)]
pub struct Conditioning {
    /// Cells raised out of a depression.
    pub raised_cells: usize,
    /// Largest raise in metres.
    pub max_raise: f32,
}

/// Priority-Flood with epsilon (Barnes, Lehman and Mulla 2014): floods the terrain inward
/// from the map border in order of height; a cell reached from a higher one is raised just
/// above it (the next representable `f32`), so every cell then has a strictly descending
/// path to the border and no pit remains. Only depressions are touched (rivers, which
/// already descend to their estuaries, are not). O(cells log range) with a radix heap.
pub fn fill_depressions(field: &mut Heightfield) -> Conditioning {
    use super::radix_heap::{RadixHeap, ordered_key};

    let (w, h) = (field.width() as i64, field.height() as i64);
    let z = field.data_mut();
    let mut closed = vec![false; z.len()];
    // Heights pop in non-decreasing order (a raised cell sits just above the level that
    // reached it), so a monotone radix heap replaces the binary heap of the paper.
    let mut heap = RadixHeap::new();
    for i in 0..(w * h) {
        let (x, y) = (i % w, i / w);
        if x == 0 || y == 0 || x == w - 1 || y == h - 1 {
            closed[i as usize] = true;
            heap.push(ordered_key(z[i as usize]), i as u32);
        }
    }
    let mut result = Conditioning::default();
    while let Some((_, i)) = heap.pop() {
        let level = z[i as usize];
        let (x, y) = (i64::from(i) % w, i64::from(i) / w);
        for (dx, dy, _) in NEIGHBOURS {
            let (nx, ny) = (x + dx, y + dy);
            if nx < 0 || ny < 0 || nx >= w || ny >= h {
                continue;
            }
            let j = (ny * w + nx) as usize;
            if closed[j] {
                continue;
            }
            closed[j] = true;
            if z[j] <= level {
                let raised = level.next_up();
                result.raised_cells += 1;
                result.max_raise = result.max_raise.max(raised - z[j]);
                z[j] = raised;
            }
            heap.push(ordered_key(z[j]), j as u32);
        }
    }
    result
}

/// Measures drainage. O(cells): each cell's outlet is resolved once along its descent path.
pub fn measure(field: &Heightfield, kinds: &[CellKind]) -> Drainage {
    let (w, h) = (field.width(), field.height());
    let n = w * h;
    let recv = receivers(field);
    let border = |i: usize| {
        let (x, y) = (i % w, i / w);
        x == 0 || y == 0 || x + 1 == w || y + 1 == h
    };
    // 0 = unknown, 1 = reaches an outlet, 2 = ends in a pit.
    let mut fate = vec![0u8; n];
    let mut path = Vec::new();
    for start in 0..n {
        let mut i = start;
        while fate[i] == 0 {
            path.push(i);
            match recv[i] {
                Some(j) => i = j as usize,
                None => {
                    fate[i] = if border(i) { 1 } else { 2 };
                    break;
                }
            }
            if path.len() > n {
                break; // cannot happen with strict descent; guards against NaN heights
            }
        }
        let result = if fate[i] == 0 { 2 } else { fate[i] };
        for &p in &path {
            fate[p] = result;
        }
        path.clear();
    }
    let mut d = Drainage::default();
    for i in 0..n {
        if fate[i] == 1 {
            d.cells_to_outlet += 1;
        }
        if recv[i].is_none() && !border(i) {
            d.pit_cells += 1;
        }
        if kinds[i] == CellKind::River {
            d.river_cells += 1;
            let ok = match recv[i] {
                Some(j) => kinds[j as usize] == CellKind::River,
                None => border(i),
            };
            if ok {
                d.river_cells_draining += 1;
            }
        }
    }
    d.river_fraction = d.river_cells_draining as f64 / d.river_cells.max(1) as f64;
    d.outlet_fraction = d.cells_to_outlet as f64 / n as f64;
    d.pit_fraction = d.pit_cells as f64 / n as f64;
    d
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_tilted_plane_drains_and_a_bowl_has_one_pit() {
        let n = 9;
        let plane: Vec<f32> = (0..n * n).map(|i| (i % n) as f32).collect();
        let kinds = vec![CellKind::Free; n * n];
        let d = measure(&Heightfield::from_vec(n, n, plane).unwrap(), &kinds);
        assert_eq!(d.outlet_fraction, 1.0);
        assert_eq!(d.pit_cells, 0);
        let bowl: Vec<f32> = (0..n * n)
            .map(|i| {
                let (x, y) = ((i % n) as f32 - 4.0, (i / n) as f32 - 4.0);
                x * x + y * y
            })
            .collect();
        let mut bowl = Heightfield::from_vec(n, n, bowl).unwrap();
        let d = measure(&bowl, &kinds);
        assert!(has_pits(&bowl));
        assert_eq!(d.pit_cells, 1);
        assert_eq!(d.cells_to_outlet, 0);
        // Flooding the bowl leaves no pit and every cell draining out.
        let c = fill_depressions(&mut bowl);
        assert!(c.raised_cells > 0);
        let d = measure(&bowl, &kinds);
        assert_eq!((d.pit_cells, d.outlet_fraction), (0, 1.0));
        assert!(!has_pits(&bowl));
    }
}
