//! Harmonic fraction: how much of the terrain satisfies Laplace's equation.
//!
//! A cell is *harmonic* when the 5-point Laplacian deviation is at most 0.1 % of the height
//! change across one cell:
//!
//! ```text
//! |h_c - m| <= 0.001 * |grad h| * cell
//! m      = (wx (h_e + h_w) + wy (h_n + h_s)) / (2 wx + 2 wy),  wx = 1/cell_x^2, wy = 1/cell_y^2
//! grad h = ((h_e - h_w) / (2 cell_x), (h_s - h_n) / (2 cell_y))   (central differences, m/m)
//! cell   = (cell_x + cell_y) / 2
//! ```
//!
//! `m` is the mean of the 4 neighbours on square cells; on rectangular cells it is the
//! weighted mean that makes `h_c - m` proportional to the anisotropic 5-point Laplacian, so
//! that harmonic functions (planes, `x^2 - y^2`) stay harmonic on any grid. Where the
//! gradient is exactly 0 the inequality only holds for a deviation of exactly 0.
//! Real DEMs are rarely harmonic (a few per cent of cells); diffusion / Laplace fills
//! (Poisson blending, "membrane" interpolation of voids) are harmonic almost everywhere,
//! so a high fraction flags smooth, unnatural terrain.

use super::grid::Grid;

/// Relative tolerance of the harmonic test (0.1 % of the local height change per cell).
pub(super) const HARMONIC_TOLERANCE: f64 = 0.001;

/// Is the interior cell `i` harmonic (see the module documentation)?
pub(super) fn is_harmonic(g: &Grid, i: usize) -> bool {
    let w = g.w;
    let (hc, hn, hs, hw, he) = (g.z[i], g.z[i - w], g.z[i + w], g.z[i - 1], g.z[i + 1]);
    let wx = 1.0 / (g.cx * g.cx);
    let wy = 1.0 / (g.cy * g.cy);
    let mean = (wx * (he + hw) + wy * (hn + hs)) / (2.0 * (wx + wy));
    let deviation = (hc - mean).abs();
    let gx = (he - hw) / (2.0 * g.cx);
    let gy = (hs - hn) / (2.0 * g.cy);
    let cell = 0.5 * (g.cx + g.cy);
    deviation <= HARMONIC_TOLERANCE * gx.hypot(gy) * cell
}

/// Fraction of interior cells that are harmonic; 0 when there are none.
pub(super) fn harmonic_fraction(g: &Grid, interior: &[bool]) -> f64 {
    let mut total = 0usize;
    let mut harmonic = 0usize;
    for (i, _) in interior.iter().enumerate().filter(|(_, m)| **m) {
        total += 1;
        harmonic += usize::from(is_harmonic(g, i));
    }
    if total == 0 {
        0.0
    } else {
        harmonic as f64 / total as f64
    }
}
