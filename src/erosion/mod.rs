//! Fluvial erosion by the stream-power law with uplift, hillslope diffusion and
//! optional thermal erosion:
//!
//! ```text
//! dh/dt = U(x) - K A^m S^n + kappa * lap(h)
//! ```
//!
//! solved with the implicit O(n) scheme of Braun & Willett (2013), "A very efficient
//! O(n), implicit and parallel method to solve the stream power equation governing
//! fluvial incision and landscape evolution", Geomorphology 180–181, 170–179.
//!
//! One [`Eroder::step`] (all O(cells), single-threaded, deterministic):
//! 1. D8 steepest-descent receivers (`flow.rs`); free cells without a lower
//!    neighbour (pits) are detected in the same pass, and only if there are any, their
//!    depressions are filled to the sill (Priority-Flood + epsilon, `fill.rs`);
//! 2. the depth-first stack from the base-level cells and the drainage area along
//!    the reversed stack (`flow.rs`);
//! 3. implicit stream-power incision + uplift in stack order (`stream_power.rs`);
//! 4. implicit hillslope diffusion (`diffusion.rs`) and optional talus relaxation
//!    (`thermal.rs`): operator splitting, receivers are fixed within a step.
//!
//! After the last step the routing is redone once more, so the final surface has a
//! strictly descending path from every free cell to base level.
//!
//! Base-level cells (`base_level[i] == true`: rivers drawn by the user, a band around
//! them, the map border) keep their heights exactly and are the roots of the stack.
//!
//! Memory besides the caller's heights (`f32`), mask (`bool`) and uplift (`f32`):
//! receiver codes (`u8`), donor bitmasks (`u8`), stack (`u32`), drainage area (`f32`)
//! and, when `diffusivity > 0`, one `f32` scratch field for the implicit diffusion:
//! at most 14 bytes per cell (3.5 four-byte fields). Depression filling, only when
//! pits exist, temporarily allocates two bit sets (2 bits per cell) plus a heap and
//! queues sized by the lakes.

mod diffusion;
mod error;
mod fill;
mod flow;
pub mod gpu;
mod grid;
mod layers;
mod params;
mod stage;
mod stream_power;
mod thermal;

#[cfg(test)]
mod tests;

pub use self::error::ErosionError;
pub use self::layers::{depth_grey, drainage_grey, layer_pngs};
pub use self::params::{ErosionParams, PRESETS, preset};
pub use self::stage::{
    Eroded, ErosionReport, ErosionSettings, MAX_SOLVER_SIDE, Prepared, StageError, base_level,
    erode_terrain, nearest_channel, roughen, uplift_from_design,
};

use self::flow::Network;
use self::grid::Grid;

/// The phases of one time step, in order.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Phase {
    Route,
    Area,
    Incise,
    Hillslope,
    Talus,
}

/// Time-stepping landscape-evolution solver; see the module docs.
pub struct Eroder {
    grid: Grid,
    heights: Vec<f32>,
    base: Vec<bool>,
    uplift: Vec<f32>,
    params: ErosionParams,
    dt: f64,
    steps_done: u32,
    /// Receivers, donors and stack (see [`flow`]).
    net: Network,
    area: Vec<f32>,
    /// Right-hand side for the implicit diffusion (empty when `diffusivity == 0`).
    scratch: Vec<f32>,
    /// Heights no cell may be lowered below (see [`Eroder::with_floor`]); empty = none.
    floor: Vec<f32>,
    /// The next phase of the current step ([`Eroder::advance`]).
    phase: Phase,
}

/// Flow routing of a surface, as computed by [`receivers_and_area`].
#[derive(Clone, Debug)]
pub struct Routing {
    /// The input heights with depressions filled (Priority-Flood + epsilon).
    pub heights: Vec<f32>,
    /// D8 steepest-descent receiver of each cell (itself for base-level cells).
    pub receivers: Vec<u32>,
    /// Braun–Willett stack: every receiver precedes its donors.
    pub stack: Vec<u32>,
    /// Drainage area in m^2 (each cell contributes `cell_m^2`).
    pub area: Vec<f32>,
}

/// Routes flow over `heights` (after filling depressions) and returns receivers, stack
/// and drainage area. Inputs are validated as in [`Eroder::new`].
pub fn receivers_and_area(
    heights: &[f32],
    width: usize,
    height: usize,
    cell_m: f64,
    base_level: &[bool],
) -> Result<Routing, ErosionError> {
    let grid = check_grid(width, height, cell_m)?;
    check_len("heights", heights.len(), grid.len())?;
    check_len("base_level", base_level.len(), grid.len())?;
    check_finite("heights", heights)?;
    if !base_level.contains(&true) {
        return Err(ErosionError::NoBaseLevel);
    }
    let mut heights = heights.to_vec();
    let mut net = Network::new(grid);
    net.route(grid, &mut heights, base_level);
    let mut area = vec![0.0; grid.len()];
    net.area(grid, &mut area);
    Ok(Routing {
        heights,
        receivers: net.receiver_indices(),
        stack: net.stack,
        area,
    })
}

impl Eroder {
    /// Builds a solver.
    ///
    /// * `heights`: row-major `width * height` elevations in metres.
    /// * `cell_m`: cell size in metres (square cells).
    /// * `base_level`: cells with fixed height where water leaves the map (rivers,
    ///   their banks, the border); at least one must be `true`.
    /// * `uplift`: rock uplift rate `U` in m/yr per cell (1 m/kyr = 0.001); ignored on
    ///   base-level cells. Negative values (subsidence) are allowed.
    pub fn new(
        heights: Vec<f32>,
        width: usize,
        height: usize,
        cell_m: f64,
        base_level: Vec<bool>,
        uplift: Vec<f32>,
        params: ErosionParams,
    ) -> Result<Self, ErosionError> {
        let grid = check_grid(width, height, cell_m)?;
        let n = grid.len();
        check_len("heights", heights.len(), n)?;
        check_len("base_level", base_level.len(), n)?;
        check_len("uplift", uplift.len(), n)?;
        check_finite("heights", &heights)?;
        check_finite("uplift", &uplift)?;
        params
            .validate()
            .map_err(|(field, problem)| ErosionError::InvalidParam { field, problem })?;
        if !base_level.contains(&true) {
            return Err(ErosionError::NoBaseLevel);
        }
        let scratch = if params.diffusivity > 0.0 {
            vec![0.0; n]
        } else {
            Vec::new()
        };
        Ok(Eroder {
            grid,
            heights,
            base: base_level,
            uplift,
            params,
            dt: params.years / f64::from(params.steps),
            steps_done: 0,
            net: Network::new(grid),
            area: vec![0.0; n],
            scratch,
            floor: Vec::new(),
            phase: Phase::Route,
        })
    }

    /// Sets heights below which no cell is lowered (applied after every step). The pipeline
    /// passes the height of each cell's nearest river, so erosion never digs the land
    /// beside a river below it and leaves the river hanging on a levee.
    pub fn with_floor(mut self, floor: Vec<f32>) -> Result<Self, ErosionError> {
        check_len("floor", floor.len(), self.grid.len())?;
        check_finite("floor", &floor)?;
        self.floor = floor;
        Ok(self)
    }

    /// Performs one time step if any remain and returns whether steps remain
    /// afterwards (`false` once all are done; further calls do nothing). Each step is
    /// O(cells), so a UI can yield between steps.
    pub fn step(&mut self) -> bool {
        while !self.advance() {}
        self.steps_done < self.params.steps
    }

    /// Runs the next phase of the current step (routing, drainage area, incision, hillslope
    /// diffusion, talus and the floor): each is O(cells), so a browser job can yield between
    /// phases and never hold the page for a whole step. Returns true when the step ended
    /// (or when no step remains); the same bits as [`Eroder::step`].
    pub fn advance(&mut self) -> bool {
        if self.steps_done >= self.params.steps {
            return true;
        }
        let g = self.grid;
        let p = self.params;
        match self.phase {
            Phase::Route => {
                self.net.route(g, &mut self.heights, &self.base);
                self.phase = Phase::Area;
            }
            Phase::Area => {
                self.net.area(g, &mut self.area);
                self.phase = Phase::Incise;
            }
            Phase::Incise => {
                stream_power::Incision {
                    grid: g,
                    uplift: &self.uplift,
                    dir: &self.net.dir,
                    off: self.net.off,
                    stack: &self.net.stack,
                    area: &self.area,
                    dt: self.dt,
                    k: p.erodibility,
                    m: p.m,
                    n: p.n,
                }
                .apply(&mut self.heights);
                self.phase = Phase::Hillslope;
            }
            Phase::Hillslope => {
                if p.diffusivity > 0.0 {
                    let r = p.diffusivity * self.dt / (g.cell * g.cell);
                    diffusion::diffuse(g, &mut self.heights, &self.base, r, &mut self.scratch);
                }
                self.phase = Phase::Talus;
            }
            Phase::Talus => {
                if let Some(talus) = p.talus_deg {
                    thermal::relax(g, &mut self.heights, &self.base, talus);
                }
                for (h, f) in self.heights.iter_mut().zip(&self.floor) {
                    *h = h.max(*f);
                }
                self.steps_done += 1;
                self.phase = Phase::Route;
                if self.steps_done >= p.steps {
                    // Leave a pit-free surface and the matching drainage area.
                    self.net.route(g, &mut self.heights, &self.base);
                    self.net.area(g, &mut self.area);
                }
                return true;
            }
        }
        false
    }

    /// Number of completed steps.
    pub fn steps_done(&self) -> u32 {
        self.steps_done
    }

    /// Current heights (row-major, metres). Between steps they may still contain
    /// pits created by diffusion or thermal erosion; after the last step they do not.
    pub fn heights(&self) -> &[f32] {
        &self.heights
    }

    /// Consumes the solver and returns the heights.
    pub fn into_heights(self) -> Vec<f32> {
        self.heights
    }

    /// Drainage area (m^2) of the last step (all zero before the first), e.g. for a
    /// "log drainage area" map layer.
    pub fn drainage_area(&self) -> &[f32] {
        &self.area
    }
}

fn check_grid(width: usize, height: usize, cell_m: f64) -> Result<Grid, ErosionError> {
    let n = width.saturating_mul(height);
    if n == 0 || n >= u32::MAX as usize {
        return Err(ErosionError::BadDimensions { width, height });
    }
    if !(cell_m.is_finite() && cell_m > 0.0) {
        return Err(ErosionError::BadCellSize(cell_m));
    }
    Ok(Grid {
        width,
        height,
        cell: cell_m,
    })
}

fn check_len(what: &'static str, got: usize, expected: usize) -> Result<(), ErosionError> {
    if got == expected {
        Ok(())
    } else {
        Err(ErosionError::SizeMismatch {
            what,
            expected,
            got,
        })
    }
}

fn check_finite(what: &'static str, v: &[f32]) -> Result<(), ErosionError> {
    match v.iter().position(|x| !x.is_finite()) {
        Some(index) => Err(ErosionError::NonFinite { what, index }),
        None => Ok(()),
    }
}
