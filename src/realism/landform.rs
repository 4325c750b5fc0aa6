//! The measures that tell a synthetic terrain from real land at a glance
//! (`shared/docs/realism.md`, issue 32): the grid's 8-fold direction signature, flats and
//! hypsometry. All over the interior cells (3x3 window finite), central differences at the
//! true cell size.
//!
//! * **Grid-direction index** `sum(g cos(8a)) / sum(g)`, with `g = |grad h|` and `a` the
//!   aspect `atan2(dh/dy, dh/dx)`: the slope-weighted mean of `cos(8a)`, which is 1 where
//!   every slope faces one of the 8 grid directions, -1 where every slope faces half-way
//!   between two, and about 0 on real land whatever its trend (0.005-0.09 on SRTM, Copernicus
//!   and USGS DEMs). D8 flow routing leaves 0.2-0.3.
//! * **Flat fraction**: share of cells whose slope is under [`FLAT_DEG`] (mountain DEMs about
//!   1%; a terrain with wide flat floors, 5-10%).
//! * **Hypsometric integral** `(mean - min) / (max - min)` over the finite cells (Strahler
//!   1952, "Hypsometric (area-altitude) analysis of erosional topography"; real DEMs
//!   0.15-0.36): low when the high ground is a few spots (map corners), high on plateaus.
//! * **High ground on the frame**: the share of the highest [`TOP_SHARE`] of the finite
//!   cells lying within [`FRAME_BAND`] of the map's width (or height) of its edge. 36% where
//!   the high ground is spread evenly; 45-55% in 10-50 km windows of real mountains (the SRTM
//!   tile N44E005, 60 windows each), more in small windows lying on one slope (about 80% at
//!   2 km); near 100% where the map's frame is a divide all round and the corners stand
//!   highest (a closed catchment).

use super::grid::Grid;

/// Slope (degrees) under which a cell counts as flat.
pub const FLAT_DEG: f64 = 0.5;

/// The share of the highest cells whose place [`frame_share`] measures.
pub const TOP_SHARE: f64 = 0.05;
/// How far from the edge, as a share of the map's side, a cell counts as on the frame.
pub const FRAME_BAND: f64 = 0.1;

/// The landform measures of one raster.
pub(super) struct Landform {
    pub(super) grid_direction_index: f64,
    pub(super) flat_fraction: f64,
    pub(super) hypsometric_integral: f64,
    pub(super) frame_share: f64,
}

/// Measures `g` over its `interior` cells (all zero where nothing can be measured).
pub(super) fn landform(g: &Grid, interior: &[bool]) -> Landform {
    let w = g.w;
    let (mut weighted, mut total, mut flats, mut cells) = (0.0, 0.0, 0usize, 0usize);
    let flat_tan = FLAT_DEG.to_radians().tan();
    for (i, _) in interior.iter().enumerate().filter(|(_, m)| **m) {
        let dx = (g.z[i + 1] - g.z[i - 1]) / (2.0 * g.cx);
        let dy = (g.z[i + w] - g.z[i - w]) / (2.0 * g.cy);
        let grad = dx.hypot(dy);
        cells += 1;
        if grad < flat_tan {
            flats += 1;
        }
        if grad > 0.0 {
            weighted += grad * cos8(dx, dy, grad);
            total += grad;
        }
    }
    Landform {
        grid_direction_index: if total > 0.0 { weighted / total } else { 0.0 },
        flat_fraction: if cells > 0 {
            flats as f64 / cells as f64
        } else {
            0.0
        },
        hypsometric_integral: hypsometric_integral(g),
        frame_share: frame_share(g),
    }
}

/// The share of the highest [`TOP_SHARE`] of `g`'s finite cells (those at or above that
/// quantile) that lie within [`FRAME_BAND`] of the side of the edge; 0 for an empty raster.
/// O(cells).
fn frame_share(g: &Grid) -> f64 {
    let mut finite: Vec<f64> = g.z.iter().copied().filter(|v| v.is_finite()).collect();
    if finite.is_empty() {
        return 0.0;
    }
    let k = ((1.0 - TOP_SHARE) * (finite.len() - 1) as f64).round() as usize;
    let (_, threshold, _) = finite.select_nth_unstable_by(k, f64::total_cmp);
    let threshold = *threshold;
    let near = |i: usize, n: usize| {
        let from_edge = i.min(n - 1 - i) as f64;
        from_edge < FRAME_BAND * n as f64
    };
    let (mut top, mut framed) = (0usize, 0usize);
    for (i, z) in g.z.iter().enumerate() {
        if *z >= threshold {
            top += 1;
            if near(i % g.w, g.w) || near(i / g.w, g.h) {
                framed += 1;
            }
        }
    }
    framed as f64 / top as f64
}

/// `cos(8a)` of the aspect `a = atan2(dy, dx)` of a gradient of length `grad > 0`, without the
/// angle: `cos(8a) = T8(cos a)`, here as `cos(2b)` applied three times from `cos a`.
fn cos8(dx: f64, dy: f64, grad: f64) -> f64 {
    let (c, s) = (dx / grad, dy / grad);
    let c2 = c * c - s * s; // cos 2a
    let c4 = 2.0 * c2 * c2 - 1.0; // cos 4a
    2.0 * c4 * c4 - 1.0 // cos 8a
}

/// `(mean - min) / (max - min)` of the finite heights; 0 for a flat or empty raster.
fn hypsometric_integral(g: &Grid) -> f64 {
    let Some((lo, hi)) = g.finite_range() else {
        return 0.0;
    };
    if hi <= lo {
        return 0.0;
    }
    let (sum, count) =
        g.z.iter()
            .filter(|v| v.is_finite())
            .fold((0.0, 0usize), |(s, n), v| (s + v, n + 1));
    (sum / count as f64 - lo) / (hi - lo)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn grid(n: usize, f: impl Fn(f64, f64) -> f64) -> Grid {
        let z: Vec<f32> = (0..n * n)
            .map(|i| f((i % n) as f64, (i / n) as f64) as f32)
            .collect();
        Grid::new(&z, n, n, 10.0, 10.0).expect("a grid")
    }

    #[test]
    fn cos8_matches_the_angle() {
        for k in 0..64 {
            let a = k as f64 * 0.1;
            let (dx, dy) = (3.0 * a.cos(), 3.0 * a.sin());
            assert!((cos8(dx, dy, 3.0) - (8.0 * a).cos()).abs() < 1e-9, "{a}");
        }
    }

    /// A plane facing a grid direction scores 1, one facing half-way between two -1, a cone
    /// (every aspect equally; flat outside its round base, whose square's corners would favour
    /// the diagonals) about 0.
    #[test]
    fn direction_index_of_planes_and_a_cone() {
        let measure = |g: &Grid| landform(g, &g.interior_mask()).grid_direction_index;
        assert!((measure(&grid(32, |x, _| 2.0 * x)) - 1.0).abs() < 1e-9);
        assert!((measure(&grid(32, |x, y| x + y)) - 1.0).abs() < 1e-9);
        let t = (22.5f64).to_radians();
        let off = grid(32, |x, y| 5.0 * (x * t.cos() + y * t.sin()));
        assert!((measure(&off) + 1.0).abs() < 1e-6);
        let cone = grid(201, |x, y| -(x - 100.0).hypot(y - 100.0).min(95.0));
        assert!(measure(&cone).abs() < 0.01, "{}", measure(&cone));
    }

    #[test]
    fn flats_and_hypsometry() {
        let tilted = grid(40, |x, _| x); // 0.1 m/m: 5.7 degrees
        let f = landform(&tilted, &tilted.interior_mask());
        assert_eq!(f.flat_fraction, 0.0);
        assert!((f.hypsometric_integral - 0.5).abs() < 1e-9);
        let floor = grid(40, |x, _| if x < 30.0 { 0.0 } else { 10.0 * (x - 30.0) });
        let f = landform(&floor, &floor.interior_mask());
        assert!((0.7..0.8).contains(&f.flat_fraction), "{}", f.flat_fraction);
        assert!(f.hypsometric_integral < 0.15);
    }

    /// A dome's top stands in the middle, off the frame; a bowl's rim is all frame; a plane
    /// rising east has its top on the east edge.
    #[test]
    fn high_ground_on_the_frame() {
        let share = |g: &Grid| landform(g, &g.interior_mask()).frame_share;
        let dome = grid(50, |x, y| -(x - 24.5).hypot(y - 24.5));
        assert_eq!(share(&dome), 0.0);
        let bowl = grid(50, |x, y| (x - 24.5).hypot(y - 24.5));
        assert!(share(&bowl) > 0.95, "{}", share(&bowl));
        let plane = grid(50, |x, _| x);
        assert_eq!(share(&plane), 1.0);
        // A ridge along the middle rows meets the frame only where it crosses it.
        let ridge = grid(50, |_, y| -(y - 24.5).abs());
        assert!(share(&ridge) < 0.25, "{}", share(&ridge));
    }
}
