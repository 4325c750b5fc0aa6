//! Valleys that drain: each valley line continued from its mouth down the DEM's own descent.
//!
//! Choice (a departure from seed paper 003): the paper's valley lines end where profile
//! recognition stops seeing a trough, usually inside the map, and feed a learned generator
//! that needs no drainage. Our scene rebuilds the terrain by diffusion between the lines, and
//! a line ending inside the map is then the lowest point of a closed basin, which the
//! pipeline's depression filling turns into a flat lake (12-27% of the cells of the SRTM test
//! crop were flat). Real valleys do not end: they run on, down to a larger valley or the
//! sea. So each valley, longest first, is continued from its mouth along the D8 descent of the
//! depression-filled DEM (`realism::descent`: Priority-Flood+epsilon, Barnes et al. 2014;
//! D8, O'Callaghan and Mark 1984) until it joins a valley already drained or leaves the map.
//! The continuation's heights are the filled surface's, never above the height before them,
//! so every valley descends from its head to its outlet.

use super::{FeatureLine, Features, MAX_POINTS_PER_LINE};

/// Continues every valley of `f` (longest first) from its mouth down the descent of `z`
/// (`w` x `h`, voids refused before), one point every `spacing` cells, and marks the cells
/// crossed in `f.valley_cells`. Lines stay within [`MAX_POINTS_PER_LINE`] points. O(cells).
pub(super) fn drain_valleys(f: &mut Features, z: &[f32], w: usize, h: usize, spacing: usize) {
    let Some((to, filled)) = crate::realism::descent(z, w, h, 1.0, 1.0) else {
        return;
    };
    let (sx, sy) = ((w - 1) as f64, (h - 1) as f64);
    let cell_of = |p: [f64; 2]| {
        let (x, y) = ((p[0] * sx).round() as i64, (p[1] * sy).round() as i64);
        (x.clamp(0, w as i64 - 1), y.clamp(0, h as i64 - 1))
    };
    // Which valley (index + 1) each cell lies on; 0 for none.
    let mut owner = vec![0u32; w * h];
    for (k, line) in f.valleys.iter().enumerate() {
        for s in line.points.windows(2) {
            crate::skeleton::bresenham(cell_of(s[0]), cell_of(s[1]), |x, y| {
                owner[y as usize * w + x as usize] = k as u32 + 1;
            });
        }
    }
    for (k, line) in f.valleys.iter_mut().enumerate() {
        let own = k as u32 + 1;
        let Some(&mouth) = line.points.first() else {
            continue;
        };
        let (mx, my) = cell_of(mouth);
        let path = descent_path(&to, &owner, my as usize * w + mx as usize, own);
        if path.is_empty() {
            continue;
        }
        for &c in &path {
            owner[c] = own;
            f.valley_cells[c] = true;
        }
        prepend(line, &path, &filled, w, spacing.max(1), (sx, sy));
    }
}

/// The cells below `start` down the descent `to`, up to and including the first that leaves
/// the map (no receiver) or lies on a valley other than `own`.
fn descent_path(to: &[u32], owner: &[u32], start: usize, own: u32) -> Vec<usize> {
    let mut path = Vec::new();
    if owner[start] != own && owner[start] != 0 {
        return path; // the mouth already sits on another valley
    }
    let mut at = start;
    // The filled surface falls strictly along `to`, so the walk ends; the bound guards it.
    while path.len() < to.len() {
        let next = to[at];
        if next == u32::MAX {
            break;
        }
        at = next as usize;
        path.push(at);
        if owner[at] != 0 && owner[at] != own {
            break;
        }
    }
    path
}

/// Puts `path` (cells going down from the line's mouth) before the line's points, one point
/// every `spacing` cells and the last, in map units, with the filled heights kept at or below
/// the height before them; then thins the line to [`MAX_POINTS_PER_LINE`] points.
fn prepend(
    line: &mut FeatureLine,
    path: &[usize],
    filled: &[f64],
    w: usize,
    spacing: usize,
    (sx, sy): (f64, f64),
) {
    let mut level = line.heights.first().copied().unwrap_or(f64::INFINITY);
    let mut below: Vec<([f64; 2], f64)> = Vec::new();
    for (i, &c) in path.iter().enumerate() {
        level = level.min(filled[c]);
        if (i + 1) % spacing == 0 || i + 1 == path.len() {
            let p = [(c % w) as f64 / sx, (c / w) as f64 / sy];
            below.push((p, level));
        }
    }
    below.reverse();
    let mut points: Vec<[f64; 2]> = below.iter().map(|b| b.0).collect();
    let mut heights: Vec<f64> = below.iter().map(|b| b.1).collect();
    points.append(&mut line.points);
    heights.append(&mut line.heights);
    let n = points.len();
    if n > MAX_POINTS_PER_LINE {
        let step = n.div_ceil(MAX_POINTS_PER_LINE - 1);
        let keep = |i: usize| i.is_multiple_of(step) || i + 1 == n;
        points = (0..n).filter(|&i| keep(i)).map(|i| points[i]).collect();
        heights = (0..n).filter(|&i| keep(i)).map(|i| heights[i]).collect();
    }
    line.points = points;
    line.heights = heights;
}

#[cfg(test)]
mod tests {
    use super::super::{FeatureParams, extract};

    /// A valley cut into a slope that tilts to the south, ending (as profile recognition
    /// sees it) well inside the map: below its mouth the land keeps falling to the south edge.
    fn tilted_valley(n: usize) -> Vec<f32> {
        (0..n * n)
            .map(|i| {
                let (x, y) = ((i % n) as f32, (i / n) as f32);
                let across = (x - n as f32 / 2.0).abs();
                // The trough fades out in the southern half: a plain slope below it.
                let depth = 60.0 * ((0.6 * n as f32 - y) / (0.2 * n as f32)).clamp(0.0, 1.0);
                1000.0 - 4.0 * y + across * 3.0 - depth * (-across * across / 40.0).exp()
            })
            .collect()
    }

    #[test]
    fn every_valley_descends_to_the_border_or_another_valley() {
        let n = 96;
        let z = tilted_valley(n);
        let f = extract(&z, n, n, &FeatureParams::default()).unwrap();
        assert!(!f.valleys.is_empty());
        let cell = |p: [f64; 2]| {
            let (x, y) = (
                (p[0] * (n - 1) as f64).round(),
                (p[1] * (n - 1) as f64).round(),
            );
            (x as usize, y as usize)
        };
        for line in &f.valleys {
            let (x, y) = cell(line.points[0]);
            let on_border = x == 0 || y == 0 || x == n - 1 || y == n - 1;
            let joins = f
                .valleys
                .iter()
                .filter(|l| !std::ptr::eq(*l, line))
                .any(|other| {
                    other.points.iter().any(|p| {
                        let (ox, oy) = cell(*p);
                        ox.abs_diff(x) <= 5 && oy.abs_diff(y) <= 5
                    })
                });
            assert!(
                on_border || joins,
                "a valley ends inside the map at {x}, {y}"
            );
            let lowest = line.heights.iter().copied().fold(f64::INFINITY, f64::min);
            assert!(
                line.heights[0] <= lowest + 1e-6,
                "the outlet is not the valley's lowest point: {:?}",
                line.heights
            );
        }
        // The main valley now reaches the south edge, below where its trough faded out.
        let longest = &f.valleys[0];
        assert!(
            cell(longest.points[0]).1 == n - 1,
            "{:?}",
            longest.points[0]
        );
    }
}
