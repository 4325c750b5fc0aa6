//! The stopping rule shared by the CPU and GPU multigrid drivers (see the module docs of
//! `multigrid`): residual below `tolerance`, estimated error below `error_tolerance`, both
//! relative to the fixed heights' range; give up after `max_cycles`, or when two cycles in a
//! row reduce neither the residual nor the correction (the `f32` rounding floor).
//!
//! The rule is evaluated after every cycle, from that cycle's residual and correction. The
//! CPU stops at the first cycle where it fires. The GPU reads these values only every few
//! cycles (one readback per batch, see `crate::diffusion::gpu`), records the batch's cycles
//! in order and stops at the end of the batch in which the rule fired: up to a batch minus
//! one more cycles than the CPU would run, each only reducing the error further. Once the
//! tolerances were met the solve counts as converged, even if a later cycle's residual
//! wanders at the rounding floor.

use super::MultigridParams;

/// Convergence state after each V-cycle.
pub(crate) struct Stopping {
    scale: f32,
    target: f32,
    error_target: f32,
    max_cycles: u32,
    first: f32,
    pub residual: f32,
    last_correction: f32,
    pub estimate: f32,
    pub cycles: u32,
    stalled: u32,
    /// Whether some cycle met both tolerances.
    reached: bool,
}

impl Stopping {
    /// After the full-multigrid start: its `residual` and last coarse `correction`.
    pub fn new(params: &MultigridParams, scale: f32, residual: f32, correction: f32) -> Self {
        Self {
            scale,
            target: params.tolerance * scale,
            error_target: params.error_tolerance * scale,
            max_cycles: params.max_cycles,
            first: residual.max(f32::MIN_POSITIVE),
            residual,
            last_correction: correction,
            estimate: f32::INFINITY,
            cycles: 0,
            stalled: 0,
            reached: false,
        }
    }

    /// Whether another V-cycle should run.
    pub fn keep_going(&self) -> bool {
        !self.converged() && self.cycles < self.max_cycles && self.stalled < 2
    }

    pub fn converged(&self) -> bool {
        self.reached || self.meets_tolerances()
    }

    fn meets_tolerances(&self) -> bool {
        self.residual <= self.target && self.estimate <= self.error_target
    }

    /// Records a finished cycle's residual and largest coarse correction.
    pub fn record(&mut self, residual: f32, correction: f32) {
        self.cycles += 1;
        let progressing = residual < 0.8 * self.residual || correction < 0.8 * self.last_correction;
        self.stalled = if progressing { 0 } else { self.stalled + 1 };
        self.estimate = error_estimate(self.last_correction, correction);
        self.residual = residual;
        self.last_correction = correction;
        self.reached |= self.meets_tolerances();
    }

    /// Progress as the fraction of the residual's way (in orders of magnitude) to the target.
    pub fn progress(&self) -> f32 {
        let total = (self.first / self.target.max(f32::MIN_POSITIVE)).ln();
        if total <= 0.0 {
            return 1.0;
        }
        ((self.first / self.residual.max(f32::MIN_POSITIVE)).ln() / total).clamp(0.0, 0.99)
    }

    /// "cycle N (residual R of the range)" for progress messages.
    pub fn describe(&self) -> String {
        format!(
            "cycle {} (residual {:.1e} of the range)",
            self.cycles + 1,
            self.residual / self.scale
        )
    }

    pub fn relative_residual(&self) -> f32 {
        self.residual / self.scale
    }

    pub fn relative_estimate(&self) -> f32 {
        self.estimate.min(f32::MAX) / self.scale
    }
}

/// Remaining error estimated from the last two coarse-grid corrections: they shrink by the
/// cycle's contraction `rho = correction / previous` (clamped to [0.05, 0.95]), so the
/// error left after the last one is about `rho / (1 - rho)` times it (a geometric tail).
fn error_estimate(previous: f32, correction: f32) -> f32 {
    if !previous.is_finite() {
        return f32::INFINITY;
    }
    let rho = (correction / previous.max(f32::MIN_POSITIVE)).clamp(0.05, 0.95);
    rho / (1.0 - rho) * correction
}
