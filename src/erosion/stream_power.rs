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
//! The erodibility may vary from cell to cell (`K_i`, rock of varying hardness: `rock.rs`)
//! and with the beds its neighbourhood exposes at the start of the step (layered rock:
//! `strata.rs`).
//!
//! When `h_i + dt U_i <= h_r'` (a receiver uplifted faster than its donor) there is no
//! downhill slope: the node only gets its uplift and becomes a pit for the next step.

use super::flow::{NONE, Network};
use super::grid::{D8_DIST, Grid};
use crate::parallel::{self, Cells, SharedField};

/// The incision law of one solver with its constants: the time step, `K`, `m`, `n`, and
/// the factors that do not change between steps.
pub(super) struct Incision {
    dt: f64,
    m: f64,
    n: f64,
    /// `F = coef[code] * A^m`: `K dt / L^n` of the D8 step `code`.
    coef: [f64; 8],
    /// `A^m` for drainage areas of 0 to [`POW_TABLE_CELLS`] cells.
    pow_table: Vec<f64>,
    inv_cell2: f64,
}

/// `A^m` is tabulated for drainage areas below this many cells (most cells), as
/// `powf` would otherwise dominate the cost of the update.
const POW_TABLE_CELLS: usize = 4096;
const NEWTON_MAX_ITERS: usize = 40;
const NEWTON_REL_TOL: f64 = 1e-10;

impl Incision {
    /// The law `dh/dt = U - K A^m S^n` stepped by `dt` years on `grid`.
    pub(super) fn new(grid: Grid, dt: f64, k: f64, m: f64, n: f64) -> Self {
        let kdt = k * dt;
        let cell2 = grid.cell * grid.cell;
        Incision {
            dt,
            m,
            n,
            coef: D8_DIST.map(|d| kdt / (d * grid.cell).powf(n)),
            pow_table: (0..POW_TABLE_CELLS)
                .map(|c| (c as f64 * cell2).powf(m))
                .collect(),
            inv_cell2: 1.0 / cell2,
        }
    }

    /// Updates `h` (uplift included; an empty `uplift` is none) at the cells of `run`, a run
    /// of `net`'s stack. Runs must come in stack order, as each cell needs its receiver's new
    /// height; the run's independent parts ([`Network::independent_runs`]) go to the
    /// threads, the same bits. O(cells of the run).
    pub(super) fn apply(
        &self,
        net: &Network,
        run: std::ops::Range<usize>,
        fields: &Fields<'_>,
        h: &mut [f32],
    ) {
        let runs = net.independent_runs(run);
        if let [run] = &runs[..] {
            for &i in &net.stack[run.clone()] {
                self.update(net, i as usize, fields, h);
            }
            return;
        }
        let shared = SharedField::new(h);
        parallel::for_each_item(runs, |part| {
            let mut cells = &shared;
            for &i in &net.stack[part] {
                self.update(net, i as usize, fields, &mut cells);
            }
        });
    }

    /// The new height of cell `i`, whose receiver has its own already.
    #[inline]
    fn update<C: Cells + ?Sized>(&self, net: &Network, i: usize, fields: &Fields<'_>, h: &mut C) {
        let Fields {
            area,
            uplift,
            erodibility,
            beds,
        } = *fields;
        let code = usize::from(net.dir[i]);
        if code == usize::from(NONE) {
            return; // base level (routing leaves no pits)
        }
        // An empty uplift is none: `+ dt * 0` keeps the bits zeros would give.
        let u = uplift.get(i).copied().unwrap_or(0.0);
        let hi = h.get(i) as f64 + self.dt * u as f64;
        let a = area[i] as f64;
        let cells = (a * self.inv_cell2 + 0.5) as usize;
        let a_m = if cells < POW_TABLE_CELLS {
            self.pow_table[cells]
        } else {
            a.powf(self.m)
        };
        // An empty field is uniform rock: no factor, the bits of before.
        let mut f = match erodibility.get(i) {
            Some(k) => self.coef[code] * a_m * f64::from(*k),
            None => self.coef[code] * a_m,
        };
        // The beds its neighbourhood exposes at the start of the step (f32, as the GPU's).
        if let Some(b) = beds.get(i) {
            f *= f64::from(*b);
        }
        let damp = 1.0 / (1.0 + f);
        // Everything above is independent of the receiver's new height, which
        // was computed just before: keep the dependent chain short.
        let hr = h.get(i.wrapping_add_signed(net.off[code])) as f64;
        let new = if hi <= hr || f == 0.0 {
            hi // no downhill slope (or no erosion): uplift only
        } else if self.n == 1.0 {
            // (h_i + dt U + F h_r') / (1 + F), rearranged.
            hr + (hi - hr) * damp
        } else {
            hr + newton(hi - hr, f, self.n)
        };
        h.set(i, new as f32);
    }
}

/// The per-cell fields the incision reads: drainage area (m^2), uplift (m/yr; empty: none),
/// the erodibility's factor (empty: 1) and the factor of the beds each cell's neighbourhood
/// exposes at the start of the step ([`super::Strata::cell_factors`]; empty: no beds).
#[derive(Clone, Copy)]
pub(super) struct Fields<'a> {
    pub(super) area: &'a [f32],
    pub(super) uplift: &'a [f32],
    pub(super) erodibility: &'a [f32],
    pub(super) beds: &'a [f32],
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
