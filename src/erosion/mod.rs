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
//! One [`Eroder::step`] (all O(cells), deterministic: the receivers, the creep and the strata
//! in bands of rows on every core, the rest on one thread, the same bits on any number):
//! 1. receivers (`flow.rs`): D8 steepest descent, or with [`Eroder::with_seed`] (as the
//!    pipeline runs it) one lower neighbour drawn in proportion to the slopes, anew each
//!    step, so that channels do not lock onto the grid's 8 directions; a guided cell (a branch
//!    the L-system grew, with [`Eroder::with_guide`]: `guide.rs`) drains to the next cell of
//!    its branch whatever the heights; free cells without a
//!    lower neighbour (pits) are detected in the same pass, and only if there are any, their
//!    depressions are filled to the sill (Priority-Flood + epsilon, `fill.rs`);
//! 2. the depth-first stack from the base-level cells and the drainage area along
//!    the reversed stack (`flow.rs`);
//! 3. implicit stream-power incision + uplift in stack order (`stream_power.rs`), then,
//!    when set, the threshold-slope limit (`slope_limit.rs`), the rock's strength weakened
//!    where the step's drainage area gathers (`gathering.rs`);
//! 4. implicit hillslope diffusion (`diffusion.rs`) and optional talus relaxation
//!    (`thermal.rs`): operator splitting, receivers are fixed within a step. The last
//!    step's diffusion covers half the step, the end of Strang's symmetric splitting
//!    (`diffusion::Creep`): a whole step of creep after the last incision rounded its
//!    channels into troughs the D8 paths ran straight along.
//!
//! After the last step the threshold-slope limit (when set) runs once more, after the
//! step's diffusion and talus, repeated while it lowers cells (at most [`FINAL_LIMIT_PAIRS`]
//! pairs of scans), and the routing is redone once more, so the final surface has a
//! strictly descending path from every free cell to base level. That last routing draws
//! with the last step's key, so the drainage area the solver leaves (the stage's layer) is
//! that of one draw of receivers.
//!
//! With [`Eroder::with_slope_limit`] (the pipeline sets it with the talus angle) each step
//! also holds the slopes to the threshold angle after the incision (`slope_limit.rs`), so
//! small maps, where uplift outpaces the talus relaxation, keep slopes rock stands; each
//! cell's angle is the talus angle scaled by the rock's strength ([`SlopeStrength`]), so
//! failed slopes are not planes. The GPU solver runs it in Jacobi passes (see `gpu.rs`).
//! Its last pass comes after the last step's diffusion: a step's creep spreads over
//! `sqrt(kappa dt)` (22 m for the young-mountains preset's 100 kyr steps), which on cells of a
//! few metres smoothed the rock's chutes and ribs into planes (23% harmonic cells on a 2 km
//! map at 512^2, 4-5% with the last pass), where bare rock at the threshold angle has no soil
//! to creep; the surface the run leaves is the rock's, as it failed last.
//!
//! [`Eroder::advance`] runs a step in pieces of about [`CHUNK_CELLS`] cells (bands of rows,
//! runs of the stack in its fixed order, lakes one by one), so a browser job can yield
//! between them; the order of the work, and so every bit of the result, is the same.
//!
//! The scene's section and the terrain types' settings are in `settings.rs`. The stage
//! around the solver (`stage.rs`) pins the sketch's peaks and ridges with the floor and
//! raises their flanks after the last step (`hold.rs`).
//!
//! Base-level cells (`base_level[i] == true`: rivers drawn by the user, a band around
//! them, the border's outlets or the whole border) keep their heights exactly and are the
//! roots of the stack.
//!
//! Memory besides the caller's heights (`f32`), mask (`bool`), uplift (`f32`) and
//! erodibility factors (`f32`, when the rock varies): receiver codes (`u8`), donor bitmasks
//! (`u8`), stack (`u32`), drainage area (`f32`) and, when `diffusivity > 0`, one `f32`
//! scratch field for the implicit diffusion: at most 14 bytes per cell (3.5 four-byte
//! fields). Depression filling, only when
//! pits exist, temporarily allocates two bit sets (2 bits per cell) plus a heap and
//! queues sized by the lakes.

mod coarse;
mod diffusion;
mod error;
mod fill;
pub mod floodplain;
mod floor_along;
mod flow;
mod gathering;
pub mod gpu;
mod grid;
mod guide;
mod hold;
mod layers;
mod nearest;
mod network_floors;
pub mod offload;
mod outlets;
mod painted;
mod params;
mod ranges;
mod rock;
mod settings;
mod slope_limit;
mod stack;
mod stage;
mod strata;
mod stream_power;
mod thermal;

#[cfg(test)]
mod tests;

pub use self::coarse::MAX_SOLVER_SIDE;
pub use self::error::ErosionError;
pub use self::guide::{grown_kinds, shaped_kinds};
pub use self::hold::Held;
pub use self::layers::{depth_grey, drainage_grey, layer_pngs};
pub use self::nearest::NearestChannel;
pub use self::painted::{HARD_ROCK, Painted, UPLIFT_GAIN};
pub use self::params::{ErosionParams, PRESETS, describe, preset, river_slope};
pub use self::ranges::{DEFAULT_SCALE_M as DEFAULT_UPLIFT_SCALE_M, Ranges};
pub use self::rock::{Rock, erodibility_factors};
pub use self::settings::{Border, ErosionSettings, Relief};
pub use self::slope_limit::Strength as SlopeStrength;
pub use self::stage::{
    Anchors, Eroded, ErosionReport, Prepared, StageError, base_level, erode_field,
    erode_field_within, erode_terrain, nearest_channel, rock_in_window, roughen,
    strength_in_window, uplift_from_design, uplift_map,
};
pub use self::strata::Strata;

use self::flow::Network;
use self::grid::Grid;

/// Cells of work per [`Eroder::advance`] (a few milliseconds natively): a band of rows of a
/// sweep, a run of the stack, or lakes that saw about this many cells.
pub const CHUNK_CELLS: usize = 1 << 16;

/// Most pairs of scans of the threshold-slope limit's last pass, after the last step: it is
/// repeated while it lowers cells, as one pair is exact only where no base-level cell bends
/// the paths (with the creep solved to 5%, a face of a block cut back from a river stood
/// 42 degrees steep after one pair, on a 35 degree limit). Measured on a 2 km map at 512^2,
/// each pair lowers about half as much as the one before (40k, 17k, 7.5k, 3.8k, 2k metres
/// summed over the cells): 4 pairs take the bulk at the cost of 3 more pairs of scans of
/// the map, where settling every cell took more than 16. With them the default design's
/// 2 km map (test `one_design_reads_as_land_at_every_map_width`) stands at most 36.1 degrees
/// steep by Horn's stencil on its 35 degree limit (39.8 before the creep was solved).
pub(super) const FINAL_LIMIT_PAIRS: u32 = 4;

/// Where the current time step stands: its phase, in order, and how far the phase went.
enum Phase {
    /// Receivers, lakes and the stack (see [`flow::Route`]).
    Route(flow::Route),
    /// Drainage area: the stack's cells below `left` are still to be added, from the end.
    Area { left: usize },
    /// Incision of the stack's cells from `next` on.
    Incise { next: usize },
    /// Hillslope diffusion: the next half sweep.
    Hillslope { half: usize },
    /// Talus relaxation: the pass and the next row of its scan.
    Talus { pass: usize, row: usize },
    /// The threshold-slope limit ([`Eroder::with_slope_limit`]): the scan (forward, then
    /// backward), the next row of it, and whether the pair of scans lowered a cell.
    Limit {
        forward: bool,
        row: usize,
        lowered: bool,
    },
    /// The floor, from cell `next` on.
    Floor { next: usize },
}

/// Time-stepping landscape-evolution solver; see the module docs.
pub struct Eroder {
    grid: Grid,
    heights: Vec<f32>,
    base: Vec<bool>,
    uplift: Vec<f32>,
    params: ErosionParams,
    steps_done: u32,
    /// Receivers, donors and stack (see [`flow`]).
    net: Network,
    area: Vec<f32>,
    /// Right-hand side for the implicit diffusion (empty when `diffusivity == 0`).
    scratch: Vec<f32>,
    /// Heights no cell may be lowered below (see [`Eroder::with_floor`]); empty = none.
    floor: Vec<f32>,
    incision: stream_power::Incision,
    /// Each step's hillslope diffusion ([`diffusion::Creep`]).
    creep: diffusion::Creep,
    talus: Option<thermal::Talus>,
    /// The next piece of the current step ([`Eroder::advance`]).
    phase: Phase,
    /// Whether the current step routes the final surface (the last step, after its floor).
    finishing: bool,
    /// Whether the limit's last pass, after the last step, has begun
    /// ([`Eroder::with_slope_limit`]).
    final_limit: bool,
    /// Pairs of scans of the last pass repeated so far (at most [`FINAL_LIMIT_PAIRS`]).
    final_limit_pairs: u32,
    /// Cells of work per [`Eroder::advance`] ([`CHUNK_CELLS`]).
    chunk: usize,
    /// The seed of the random receivers ([`Eroder::with_seed`]); `None`: steepest descent.
    seed: Option<u64>,
    /// Where the grid's cells key their draws ([`Eroder::with_seed_in`]; its own cells).
    frame: flow::Frame,
    /// The threshold-slope limit after each step's incision ([`Eroder::with_slope_limit`]).
    limit: Option<slope_limit::Mask>,
    /// The cells the limit keeps ([`Eroder::with_base_failing`]); empty: the base level.
    limit_held: Vec<bool>,
    /// Each cell's factor on the erodibility ([`Eroder::with_erodibility`]); empty: 1.
    erodibility: Vec<f32>,
    /// Beds of hard and soft rock ([`Eroder::with_strata`]); `None`: no beds.
    strata: Option<Strata>,
    /// The factor of the beds each cell's neighbourhood exposes at the start of the step's
    /// incision; empty without beds.
    beds: Vec<f32>,
    /// Scratch of [`Self::read_the_beds`], kept between steps: the heights the beds are read
    /// at, and each cell's least and greatest along its row ([`Strata::cell_factors`]).
    bed_scratch: (Vec<f32>, Vec<[f32; 2]>),
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
    ///   base-level cells. Negative values (subsidence) are allowed. Empty: no uplift
    ///   anywhere (the same heights as zeros, without a field of them).
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
        if !uplift.is_empty() {
            check_len("uplift", uplift.len(), n)?;
        }
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
        let dt = params.years / f64::from(params.steps);
        Ok(Eroder {
            grid,
            heights,
            base: base_level,
            uplift,
            params,
            steps_done: 0,
            net: Network::new(grid),
            area: vec![0.0; n],
            scratch,
            floor: Vec::new(),
            incision: stream_power::Incision::new(grid, dt, params.erodibility, params.m, params.n),
            creep: diffusion::Creep::new(
                params.diffusivity * dt / (grid.cell * grid.cell),
                params.steps,
            ),
            talus: params.talus_deg.map(|deg| thermal::Talus::new(grid, deg)),
            phase: Phase::Route(flow::Route::new(None)),
            finishing: false,
            final_limit: false,
            final_limit_pairs: 0,
            chunk: CHUNK_CELLS,
            seed: None,
            frame: flow::Frame::own(width),
            limit: None,
            limit_held: Vec::new(),
            erodibility: Vec::new(),
            strata: None,
            beds: Vec::new(),
            bed_scratch: (Vec::new(), Vec::new()),
        })
    }

    /// Multiplies the erodibility `K` of each cell by `factors` (rock of varying hardness,
    /// `rock.rs`); empty: uniform rock. Factors must be finite and above 0.
    pub fn with_erodibility(mut self, factors: Vec<f32>) -> Result<Self, ErosionError> {
        check_factors("erodibility", &factors, self.grid.len())?;
        self.erodibility = factors;
        Ok(self)
    }

    /// Varies the erodibility `K` with height: beds of hard and soft rock (`strata.rs`);
    /// `None`: no beds.
    pub fn with_strata(mut self, strata: Option<Strata>) -> Self {
        self.strata = strata;
        self
    }

    /// With beds, each cell's factor of the beds its neighbourhood exposes, from the heights the
    /// incision starts from (uplifted off base level, as the incision reads them; the GPU's
    /// `lift`). O(cells).
    fn read_the_beds(&mut self) {
        let Some(strata) = self.strata else {
            return;
        };
        let dt = self.params.years / f64::from(self.params.steps.max(1));
        let (start, along) = &mut self.bed_scratch;
        start.clear();
        start.extend((0..self.grid.len()).map(|i| {
            let h = self.heights[i];
            match self.uplift.get(i) {
                Some(u) if !self.base[i] => (f64::from(h) + dt * f64::from(*u)) as f32,
                _ => h,
            }
        }));
        self.beds.resize(self.grid.len(), 1.0);
        strata.cell_factors(start, self.grid.width, along, &mut self.beds);
    }

    /// Holds the slopes of the surface to `talus_deg` after each step's incision, before the
    /// hillslope diffusion (`slope_limit.rs`: what stands above the threshold slope fails, as
    /// landslides do, and the diffusion rounds the crests the limit leaves): one forward and
    /// one backward scan a step, exact where no base-level cell bends the paths, and the
    /// next step's scans go on from there; after the last step, one pair more, after its
    /// diffusion and talus, so the surface keeps the texture the rock's strength gives it.
    /// `strength` is each cell's factor on the talus slope's tangent, in (0, 1] (rock that
    /// fails lower, [`SlopeStrength`]); empty: the talus angle everywhere.
    pub fn with_slope_limit(
        mut self,
        talus_deg: f64,
        strength: Vec<f32>,
    ) -> Result<Self, ErosionError> {
        check_factors("slope strength", &strength, self.grid.len())?;
        let g = self.grid;
        let mask = slope_limit::Mask::new(g.width, g.height, g.cell, talus_deg);
        self.limit = Some(mask.with_strength(strength));
        Ok(self)
    }

    /// Lets the threshold-slope limit ([`Eroder::with_slope_limit`]) lower the base-level
    /// cells marked in `failing` (one flag a cell) as it lowers the land: they stay base level
    /// for the water, which leaves there, but fail like the land beside them. A window of a
    /// larger map holds its edge for the water; where that edge is the map's own border, no
    /// other window refines the land beyond it, and held it stood as a wall above faces the
    /// limit lowered (`crate::world::refine`). Empty: the limit keeps every base-level cell.
    pub fn with_base_failing(mut self, failing: Vec<bool>) -> Result<Self, ErosionError> {
        if failing.is_empty() {
            return Ok(self);
        }
        check_len("failing base level", failing.len(), self.grid.len())?;
        self.limit_held = self
            .base
            .iter()
            .zip(&failing)
            .map(|(b, f)| *b && !f)
            .collect();
        Ok(self)
    }

    /// Draws each cell's receiver at random among its lower neighbours, in proportion to
    /// their slopes, anew every step, from `seed` (see `flow.rs`): isotropic channels, the
    /// same bits for the same seed. Without it receivers are the steepest descent (D8).
    pub fn with_seed(mut self, seed: u64) -> Self {
        self.seed = Some(seed);
        self.net.pick = self.pick();
        self
    }

    /// [`Eroder::with_seed`] for a window of a larger grid, `world_width` cells wide, whose
    /// first cell is (`x0`, `y0`) there: each cell draws what the larger grid's cell draws,
    /// so overlapping windows draw alike where they overlap (a world built in tiles,
    /// `crate::world::refine`). The window must lie inside that width.
    pub fn with_seed_in(
        mut self,
        seed: u64,
        [x0, y0]: [usize; 2],
        world_width: usize,
    ) -> Result<Self, ErosionError> {
        if x0 + self.grid.width > world_width {
            return Err(ErosionError::InvalidParam {
                field: "frame",
                problem: format!(
                    "a window {} cells wide from column {x0} is not inside {world_width}",
                    self.grid.width
                ),
            });
        }
        self.frame = flow::Frame {
            x0,
            y0,
            stride: world_width,
        };
        Ok(self.with_seed(seed))
    }

    /// How the current step's routing picks receivers.
    fn pick(&self) -> flow::Pick {
        match self.seed {
            Some(seed) => flow::Pick::Random(flow::step_key(seed, self.steps_done), self.frame),
            None => flow::Pick::Steepest,
        }
    }

    /// Guides the receivers of some cells (`guide`: a D8 code per cell, 8 = none; empty:
    /// none): each such cell drains that way whatever the heights, as the branches the
    /// L-system grew drain down their course while the law sets their heights
    /// (`guide.rs`). A guided cell's receiver must lie inside the grid and the guided cells
    /// must not form a cycle (the stack would miss them): [`Prepared`] guides each one to a
    /// lower cell of the design.
    pub fn with_guide(mut self, guide: Vec<u8>) -> Result<Self, ErosionError> {
        if !guide.is_empty() {
            check_len("guide", guide.len(), self.grid.len())?;
        }
        self.net.guide = guide;
        Ok(self)
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
    /// O(cells).
    pub fn step(&mut self) -> bool {
        while !self.advance() {}
        self.steps_done < self.params.steps
    }

    /// Runs the next piece of the current step, about [`CHUNK_CELLS`] cells of work a
    /// thread: a band of rows of the receivers (one a thread) or of a talus pass; a run of
    /// the stack for its walk, or for the drainage area or the incision (one a thread the
    /// trees go to, split between them: [`flow::Network::independent_runs`]); lakes that
    /// saw about that many cells; or a run of the
    /// floor. The diffusion goes by passes over the whole map, each of up to
    /// [`diffusion::BLOCK`] half sweeps in one pass over its memory (`Diffusion::block`).
    /// So a browser job can yield between pieces and never
    /// hold the page for a whole phase. Returns true when the step ended (or when no step
    /// remains); the same bits as [`Eroder::step`], however the work is split, as every
    /// piece runs in the same order. O(chunk) per call, besides a copy or fill of a field
    /// where a phase starts, a single lake larger than the chunk, and the diffusion's
    /// passes, O(cells).
    pub fn advance(&mut self) -> bool {
        if self.steps_done >= self.params.steps {
            return true;
        }
        if self.advance_phase() {
            self.next_phase()
        } else {
            false
        }
    }

    /// Does a chunk of the current phase; returns whether the phase is complete.
    fn advance_phase(&mut self) -> bool {
        let g = self.grid;
        let chunk = self.chunk;
        let rows = flow::rows_per(chunk, g.width);
        match &mut self.phase {
            Phase::Route(route) => {
                self.net
                    .continue_route(g, &mut self.heights, &self.base, route, chunk)
            }
            Phase::Area { left } => {
                let run = left.saturating_sub(chunk.saturating_mul(stack::tree_threads()))..*left;
                *left = run.start;
                self.net.accumulate_area(&mut self.area, run);
                *left == 0
            }
            Phase::Incise { next } => {
                let run = *next
                    ..next
                        .saturating_add(chunk.saturating_mul(stack::tree_threads()))
                        .min(self.net.stack.len());
                *next = run.end;
                let fields = stream_power::Fields {
                    area: &self.area,
                    uplift: &self.uplift,
                    erodibility: &self.erodibility,
                    beds: &self.beds,
                };
                self.incision
                    .apply(&self.net, run, &fields, &mut self.heights);
                *next == self.net.stack.len()
            }
            Phase::Hillslope { half } => {
                // A pass over the map of up to BLOCK half sweeps, split among the threads
                // (`Diffusion::block`).
                let creep = self.creep.of_step(self.steps_done);
                let end = half.saturating_add(diffusion::BLOCK).min(creep.halves());
                let halves = *half..end;
                creep.block(
                    g,
                    &mut self.heights,
                    &self.base,
                    &self.scratch,
                    halves.clone(),
                );
                *half = halves.end;
                *half == creep.halves()
            }
            Phase::Limit {
                forward,
                row,
                lowered,
            } => {
                let band = *row..row.saturating_add(rows).min(g.height);
                if let Some(mask) = &self.limit {
                    let held = if self.limit_held.is_empty() {
                        &self.base
                    } else {
                        &self.limit_held
                    };
                    *lowered |= mask.scan(&mut self.heights, held, band.clone(), *forward);
                }
                *row = band.end;
                if *row == g.height && *forward {
                    (*forward, *row) = (false, 0);
                } else if *row == g.height
                    && self.final_limit
                    && *lowered
                    && self.final_limit_pairs < FINAL_LIMIT_PAIRS
                {
                    // The last pass is repeated while it lowers cells (at most
                    // FINAL_LIMIT_PAIRS pairs): one pair is exact only where no base-level
                    // cell bends the paths.
                    self.final_limit_pairs += 1;
                    (*forward, *row, *lowered) = (true, 0, false);
                }
                *row == g.height
            }
            Phase::Talus { pass, row } => {
                let band = *row..row.saturating_add(rows).min(g.height);
                if let Some(talus) = &self.talus {
                    talus.rows(g, &mut self.heights, &self.base, *pass, band.clone());
                }
                *row = band.end;
                if *row == g.height {
                    *row = 0;
                    *pass += 1;
                }
                *pass == thermal::THERMAL_PASSES
            }
            Phase::Floor { next } => {
                let run = *next..next.saturating_add(chunk).min(self.floor.len());
                *next = run.end;
                for (h, f) in self.heights[run.clone()].iter_mut().zip(&self.floor[run]) {
                    *h = h.max(*f);
                }
                *next == self.floor.len()
            }
        }
    }

    /// Moves on from the completed phase; returns whether the step ended. The phases of a
    /// step: route, area, incision, the threshold-slope limit (when set), hillslope
    /// diffusion (when `diffusivity > 0`), talus (when on) and the floor (when set); the last
    /// step then runs the limit once more (when set) and routes once more, so the surface is
    /// left pit-free with the matching drainage area.
    fn next_phase(&mut self) -> bool {
        let p = self.params;
        self.phase = match self.phase {
            Phase::Route(_) => {
                flow::start_area(self.grid, &mut self.area);
                Phase::Area {
                    left: self.net.stack.len(),
                }
            }
            Phase::Area { .. } if self.finishing => return self.end_step(),
            Phase::Limit { .. } if self.final_limit => {
                self.finishing = true;
                Phase::Route(flow::Route::new(None))
            }
            Phase::Area { .. } => {
                self.read_the_beds();
                Phase::Incise { next: 0 }
            }
            Phase::Incise { .. } if self.limit.is_some() => {
                if let Some(mask) = &mut self.limit {
                    // The step's drainage area weakens the rock where water gathers.
                    mask.weaken_where_water_gathers(&self.area);
                }
                Phase::Limit {
                    forward: true,
                    row: 0,
                    lowered: false,
                }
            }
            Phase::Incise { .. } | Phase::Limit { .. } if p.diffusivity > 0.0 => {
                self.scratch.copy_from_slice(&self.heights);
                Phase::Hillslope { half: 0 }
            }
            Phase::Incise { .. } | Phase::Limit { .. } | Phase::Hillslope { .. }
                if self.talus.is_some() =>
            {
                Phase::Talus { pass: 0, row: 0 }
            }
            Phase::Incise { .. }
            | Phase::Limit { .. }
            | Phase::Hillslope { .. }
            | Phase::Talus { .. }
                if !self.floor.is_empty() =>
            {
                Phase::Floor { next: 0 }
            }
            Phase::Incise { .. }
            | Phase::Limit { .. }
            | Phase::Hillslope { .. }
            | Phase::Talus { .. }
            | Phase::Floor { .. } => {
                if self.steps_done + 1 < p.steps {
                    return self.end_step();
                }
                if self.limit.is_some() && !self.final_limit {
                    // The limit once more: the surface the rock's strength leaves.
                    self.final_limit = true;
                    Phase::Limit {
                        forward: true,
                        row: 0,
                        lowered: false,
                    }
                } else {
                    // Leave a pit-free surface and the matching drainage area.
                    self.finishing = true;
                    Phase::Route(flow::Route::new(None))
                }
            }
        };
        false
    }

    /// Counts the step done and starts the next one's routing; returns true.
    fn end_step(&mut self) -> bool {
        self.steps_done += 1;
        self.finishing = false;
        self.net.pick = self.pick();
        self.phase = Phase::Route(flow::Route::new(None));
        true
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

/// Checks per-cell factors (`what`: erodibility, slope strength): none (uniform rock), or
/// one per cell, finite and above 0.
fn check_factors(what: &'static str, factors: &[f32], cells: usize) -> Result<(), ErosionError> {
    if factors.is_empty() {
        return Ok(());
    }
    check_len(what, factors.len(), cells)?;
    check_finite(what, factors)?;
    match factors.iter().position(|k| *k <= 0.0) {
        Some(index) => Err(ErosionError::NotPositive { what, index }),
        None => Ok(()),
    }
}

fn check_finite(what: &'static str, v: &[f32]) -> Result<(), ErosionError> {
    match v.iter().position(|x| !x.is_finite()) {
        Some(index) => Err(ErosionError::NonFinite { what, index }),
        None => Ok(()),
    }
}
