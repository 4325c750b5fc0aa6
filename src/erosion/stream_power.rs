//! Implicit stream-power incision with uplift (Braun & Willett 2013, section 3).
//!
//! The detachment-limited law `dh/dt = U - K A^m S^n` (their eq. 1 without diffusion)
//! is discretised implicitly along the receiver of each node, with the slope taken
//! *at the new time* (their implicit finite-difference form):
//!
//! ```text
//! (h_i' - h_i) / dt = U_i - K A_i^m ((h_i' - h_r') / L_ir)^n
//! ```
//!
//! Because the stack lists every receiver `r` before its donors, `h_r'` is already
//! known when node `i` is updated, so the whole grid is solved in one O(cells) pass.
//! * `n = 1`: the closed form `h_i' = (h_i + dt U_i + F h_r') / (1 + F)`,
//!   `F = K dt A_i^m / L_ir`.
//! * `n != 1`: Newton–Raphson on the same equation, as in the paper. We iterate on
//!   `x = h_i' - h_r'` (as fastscapelib does): `g(x) = x - c + F x^n = 0` with
//!   `c = h_i + dt U_i - h_r'`, `F = K dt A^m / L^n`; the root lies in `(0, c]`, and a
//!   step leaving that bracket is replaced by bisection, so it converges for any `n`.
//!
//! When `h_i + dt U_i <= h_r'` (a receiver uplifted faster than its donor) there is no
//! downhill slope: the node only gets its uplift and becomes a pit for the next step.

use super::grid::Grid;

/// Inputs of one incision update.
pub(super) struct Incision<'a> {
    pub(super) grid: Grid,
    pub(super) base: &'a [bool],
    pub(super) uplift: &'a [f32],
    pub(super) rec: &'a [u32],
    pub(super) stack: &'a [u32],
    pub(super) area: &'a [f32],
    pub(super) dt: f64,
    /// `K`, `m`, `n`.
    pub(super) k: f64,
    pub(super) m: f64,
    pub(super) n: f64,
}

const NEWTON_MAX_ITERS: usize = 40;
const NEWTON_REL_TOL: f64 = 1e-10;

impl Incision<'_> {
    /// Updates `h` in stack order (uplift included).
    pub(super) fn apply(&self, h: &mut [f32]) {
        let kdt = self.k * self.dt;
        let sqrt_m = self.m == 0.5;
        let linear = self.n == 1.0;
        for &i in self.stack {
            let i = i as usize;
            if self.base[i] {
                continue;
            }
            let r = self.rec[i] as usize;
            let hr = h[r] as f64;
            let hi = h[i] as f64 + self.dt * self.uplift[i] as f64;
            if hi <= hr || kdt == 0.0 {
                h[i] = hi as f32;
                continue;
            }
            let a = self.area[i] as f64;
            let a_m = if sqrt_m { a.sqrt() } else { a.powf(self.m) };
            let len = self.grid.distance(i, r);
            let new = if linear {
                let f = kdt * a_m / len;
                (hi + f * hr) / (1.0 + f)
            } else {
                let f = kdt * a_m / len.powf(self.n);
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
