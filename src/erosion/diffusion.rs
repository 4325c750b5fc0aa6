//! Linear hillslope diffusion `dh/dt = kappa * lap(h)`, backward Euler.
//!
//! Choice: implicit (backward Euler) on the 5-point Laplacian,
//! `(1 + r k_i) h_i' - r * sum_nb h_nb' = h_i` with `r = kappa dt / cell^2` and `k_i` the
//! number of in-grid 4-neighbours (zero flux across the map edge), solved with
//! red-black Gauss–Seidel sweeps started from `h`.
//!
//! Why: every Gauss–Seidel update `h_i' = (h_i + r sum h_nb') / (1 + r k_i)` is a convex
//! combination of values, so each sweep obeys a discrete maximum principle and the
//! result is stable and free of overshoot for *any* `dt`. Explicit sub-stepping would
//! need `dt / (cell^2 / 4 kappa)` passes, unbounded for long steps on fine grids.
//! One red-black sweep carries information about two cells, and the step's diffusion
//! length is `sqrt(kappa dt) = sqrt(r)` cells, so we run `ceil(sqrt(r))` sweeps,
//! clamped to `MIN_SWEEPS..=MAX_SWEEPS`: O(cells) per step. Only the shortest wavelengths
//! (a few cells), which Gauss–Seidel smooths fastest, converge; longer ones are smoothed less
//! than by the exact backward-Euler solution, which stays stable but is not the asked
//! creep, and the shortfall grows with the grid. Measured on a sine of a 390 m wavelength
//! (a hillslope's scale) on a 10 km map, the share of the exact step's smoothing these
//! sweeps do: `kappa` 0.05 m^2/yr (old-hills, coastal-plain), 45% / 28% / 16% at 256^2 /
//! 512^2 / 1024^2 (r 3.3 / 13 / 52); `kappa` 0.005 (young-mountains), 50% / 25% at 512^2 /
//! 1024^2. So the creep a preset asks for is weaker on finer grids: the coastal plain's
//! median slope was 1.5 / 2.4 / 3.9 degrees at 256^2 / 512^2 / 1024^2; with `2 r` sweeps
//! (up to 64) 1.2 / 1.7 / 2.4, its heights averaged down correlating 0.945 between 512^2
//! and 1024^2 (0.89). The presets were tuned with these sweeps. An exact solve of the step
//! (multigrid V-cycles, on both backends) is issue 32's, not done yet.
//! Base-level cells are fixed (Dirichlet).

use super::grid::{D4, Grid};

/// Bounds on the red-black Gauss–Seidel sweeps per time step.
const MIN_SWEEPS: usize = 2;
const MAX_SWEEPS: usize = 8;

/// One backward-Euler diffusion step with ratio `r = kappa dt / cell^2`, run as
/// [`Self::sweeps`] sweeps of two colours each ([`Self::rows`]).
pub(super) struct Diffusion {
    r: f32,
    sweeps: usize,
}

impl Diffusion {
    pub(super) fn new(r: f64) -> Self {
        let r = r as f32;
        Diffusion {
            r,
            sweeps: (r.sqrt().ceil() as usize).clamp(MIN_SWEEPS, MAX_SWEEPS),
        }
    }

    /// Red-black Gauss–Seidel sweeps of the step.
    pub(super) fn sweeps(&self) -> usize {
        self.sweeps
    }

    /// Updates the cells of colour `colour` (0: `x + y` even) in `rows`; `rhs` holds the
    /// heights before the step (copied before the first sweep). A colour's cells only read
    /// the other colour, so any split into rows gives the same bits. O(cells of the rows).
    pub(super) fn rows(
        &self,
        grid: Grid,
        h: &mut [f32],
        base: &[bool],
        rhs: &[f32],
        colour: usize,
        rows: std::ops::Range<usize>,
    ) {
        let r = self.r;
        let w = grid.width;
        // Diagonal weights for 4, 3 and 2 neighbours (interior, edge, corner).
        let inv = |k: usize| 1.0 / (1.0 + r * k as f32);
        let inv4 = inv(4);
        for y in rows {
            let interior_row = y > 0 && y + 1 < grid.height;
            let mut x = (y + colour) % 2;
            while x < w {
                let i = y * w + x;
                if !base[i] {
                    h[i] = if interior_row && x > 0 && x + 1 < w {
                        (rhs[i] + r * (h[i - w] + h[i - 1] + h[i + 1] + h[i + w])) * inv4
                    } else {
                        let (mut sum, mut k) = (0.0, 0);
                        for &o in &D4 {
                            if let Some(j) = grid.offset(x, y, o) {
                                sum += h[j];
                                k += 1;
                            }
                        }
                        (rhs[i] + r * sum) * inv(k)
                    };
                }
                x += 2;
            }
        }
    }
}
