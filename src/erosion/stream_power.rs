//! Implicit stream-power incision with uplift (Braun & Willett 2013).
//!
//! Their governing equation, the detachment-limited law `dh/dt = U - K A^m S^n`, is
//! discretised implicitly along the receiver of each node, with the slope taken
//! *at the new time* (their implicit finite-difference equation):
//!
//! ```text
//! (h_i' - h_i) / dt = U_i - K A_i^m ((h_i' - h_r') / L_ir)^n
//! ```
//!
//! Because the stack lists every receiver `r` before its donors, `h_r'` is already
//! known when node `i` is updated, so the whole grid is solved in one O(cells) pass.
//! * `n = 1`: their closed-form solution `h_i' = (h_i + dt U_i + F h_r') / (1 + F)`,
//!   `F = K dt A_i^m / L_ir`.
//! * `n != 1`: their Newton–Raphson iteration on the same equation. We iterate on
//!   `x = h_i' - h_r'` (as fastscapelib does): `g(x) = x - c + F x^n = 0` with
//!   `c = h_i + dt U_i - h_r'`, `F = K dt A^m / L^n`; the root lies in `(0, c]`, and a
//!   step leaving that bracket is replaced by bisection, so it converges for any `n`.
//!
//! When `h_i + dt U_i <= h_r'` (a receiver uplifted faster than its donor) there is no
//! downhill slope: the node only gets its uplift and becomes a pit for the next step.

use super::flow::NONE;
use super::grid::{D8_DIST, Grid};

/// Inputs of one incision update.
pub(super) struct Incision<'a> {
    pub(super) grid: Grid,
    pub(super) uplift: &'a [f32],
    /// Receiver codes and their index offsets (see [`flow`](super::flow)).
    pub(super) dir: &'a [u8],
    pub(super) off: [isize; 9],
    pub(super) stack: &'a [u32],
    pub(super) area: &'a [f32],
    pub(super) dt: f64,
    /// `K`, `m`, `n`.
    pub(super) k: f64,
    pub(super) m: f64,
    pub(super) n: f64,
}

/// `A^m` is tabulated for drainage areas below this many cells (most cells), as
/// `powf` would otherwise dominate the cost of the update.
const POW_TABLE_CELLS: usize = 4096;
const NEWTON_MAX_ITERS: usize = 40;
const NEWTON_REL_TOL: f64 = 1e-10;

impl Incision<'_> {
    /// Updates `h` in stack order (uplift included).
    pub(super) fn apply(&self, h: &mut [f32]) {
        let kdt = self.k * self.dt;
        // `F = coef[code] * A^m`, with `L^n` of the D8 step `code` folded in.
        let coef = D8_DIST.map(|d| kdt / (d * self.grid.cell).powf(self.n));
        let cell2 = self.grid.cell * self.grid.cell;
        let inv_cell2 = 1.0 / cell2;
        let pow_table: Vec<f64> = (0..POW_TABLE_CELLS)
            .map(|c| (c as f64 * cell2).powf(self.m))
            .collect();
        let linear = self.n == 1.0;
        for &i in self.stack {
            let i = i as usize;
            let code = usize::from(self.dir[i]);
            if code == usize::from(NONE) {
                continue; // base level (routing leaves no pits)
            }
            let hi = h[i] as f64 + self.dt * self.uplift[i] as f64;
            let a = self.area[i] as f64;
            let cells = (a * inv_cell2 + 0.5) as usize;
            let a_m = if cells < POW_TABLE_CELLS {
                pow_table[cells]
            } else {
                a.powf(self.m)
            };
            let f = coef[code] * a_m;
            let damp = 1.0 / (1.0 + f);
            // Everything above is independent of the receiver's new height, which
            // was computed just before: keep the dependent chain short.
            let hr = h[i.wrapping_add_signed(self.off[code])] as f64;
            let new = if hi <= hr || f == 0.0 {
                hi // no downhill slope (or no erosion): uplift only
            } else if linear {
                // (h_i + dt U + F h_r') / (1 + F), rearranged.
                hr + (hi - hr) * damp
            } else {
                hr + newton(hi - hr, f, self.n)
            };
            h[i] = new as f32;
        }
    }
}

/// Solves `x - c + f x^n = 0` for `x` in `(0, c]` (`c > 0`, `f > 0`).
fn newton(c: f64, f: f64, n: f64) -> f64 {
    let (mut lo, mut hi) = (0.0, c);
    let mut x = c;
    for _ in 0..NEWTON_MAX_ITERS {
        let xn1 = x.powf(n - 1.0);
        let g = x - c + f * xn1 * x;
        if g > 0.0 {
            hi = x;
        } else {
            lo = x;
        }
        let dg = 1.0 + n * f * xn1;
        let mut next = x - g / dg;
        if !(next > lo && next < hi) {
            next = 0.5 * (lo + hi);
        }
        let done = (next - x).abs() <= NEWTON_REL_TOL * c;
        x = next;
        if done {
            break;
        }
    }
    x
}
