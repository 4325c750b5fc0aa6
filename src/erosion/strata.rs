//! Layered rock: horizontal beds of hard and soft rock, so that rivers cutting down through
//! them leave cliffs and benches, mesas and buttes, stepped canyon walls.
//!
//! Rock patches ([`super::rock`]) vary the erodibility across the map; strata vary it with
//! depth. A cell's rock is the bed at its current height, so the erodibility changes as the
//! land is lowered through the beds: a river cuts slowly through a hard bed, whose edge then
//! stands as a cliff (the stream-power law's steady slope `S = (U / K A^m)^(1/n)` is steep
//! where `K` is small), and quickly through the soft bed below, which forms a gentle bench.
//! This is the model of Forte, Yanites and Whipple 2016 ("Complexities of landscape evolution
//! during incision through layered stratigraphy with contrasts in rock strength", Earth
//! Surface Processes and Landforms 41) and Perne, Covington, Thaler and Myre 2017 ("Steady
//! state, erosional continuity, and the topography of landscapes developed in layered
//! rocks", Earth Surface Dynamics 5): `K(z)` a periodic function of elevation in the
//! stream-power law.
//!
//! Beds are flat and repeat every `period` metres: the lower [`HARD_FRACTION`] of each period
//! is the hard bed. Its edges ramp over [`EDGE_FRACTION`] of the period (a smoothstep), so
//! that `K` is continuous in the height and the CPU and GPU solvers, whose heights differ in
//! the last bits, read nearly the same rock. The factor on `K` is `contrast^(1/2 - hard)`,
//! `hard` in `[0, 1]`: `1/sqrt(contrast)` in the hard beds, `sqrt(contrast)` in the soft
//! ones, as for the rock patches. The same formula, in `f32`, is in `shaders/erosion.wgsl`
//! (`strata_factor`).

/// The hard bed's share of each period of the beds (the rest is soft rock).
pub const HARD_FRACTION: f32 = 0.35;
/// The share of a period over which the rock changes from one bed to the next.
pub const EDGE_FRACTION: f32 = 0.15;

/// Flat beds of hard and soft rock repeating with height (see the module's comment).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Strata {
    /// Thickness of one hard bed and the soft bed above it, metres (> 0).
    pub period_m: f32,
    /// The natural logarithm of how many times faster the soft beds erode than the hard.
    pub ln_contrast: f32,
}

impl Strata {
    /// Beds of `period_m` metres whose soft rock erodes `contrast` times faster than the
    /// hard; `None` (no beds) where `period_m` is 0 or `contrast` is 1.
    pub fn new(period_m: f64, contrast: f64) -> Option<Self> {
        (period_m > 0.0 && contrast != 1.0).then(|| Self {
            period_m: period_m as f32,
            ln_contrast: contrast.ln() as f32,
        })
    }

    /// The factor on the erodibility of rock at height `h` metres. O(1). The hardness is
    /// `f32` arithmetic, exact alike everywhere; the exponential is taken in `f64`, whose
    /// `exp` gives the same bits natively and in wasm here, where `f32::exp` did not (the
    /// page's terrain of a layered scene differed from the native one).
    pub fn factor(&self, h: f32) -> f64 {
        (f64::from(self.ln_contrast) * f64::from(0.5 - self.hardness(h))).exp()
    }

    /// How hard the rock at height `h` is: 1 inside a hard bed, 0 inside a soft one.
    pub fn hardness(&self, h: f32) -> f32 {
        let t = h / self.period_m;
        let phase = t - t.floor();
        smoothstep(0.0, EDGE_FRACTION, phase)
            * (1.0 - smoothstep(HARD_FRACTION, HARD_FRACTION + EDGE_FRACTION, phase))
    }
}

/// WGSL's `smoothstep`: 0 below `a`, 1 above `b`, a cubic between.
fn smoothstep(a: f32, b: f32, x: f32) -> f32 {
    let t = ((x - a) / (b - a)).clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Hard beds take the lower share of each period, soft the rest; the factors span the
    /// contrast and change continuously; no beds where the contrast is 1 or the period 0.
    #[test]
    fn beds_alternate_with_height() {
        assert_eq!(Strata::new(0.0, 10.0), None);
        assert_eq!(Strata::new(100.0, 1.0), None);
        let s = Strata::new(100.0, 16.0).expect("beds");
        // Inside a hard bed (20 m into the period) and a soft one (70 m), at any depth.
        for base in [-300.0, 0.0, 100.0, 1200.0] {
            assert!((s.factor(base + 20.0) - 0.25).abs() < 1e-5);
            assert!((s.factor(base + 70.0) - 4.0).abs() < 1e-4);
        }
        let hard = (0..1000)
            .filter(|k| s.hardness(*k as f32 / 10.0) > 0.5)
            .count();
        assert!((330..=370).contains(&hard), "hard share {hard} of 1000");
        // Continuous: a centimetre never changes the factor by more than a few per cent.
        for k in 0..20_000 {
            let h = k as f32 * 0.01;
            let (a, b) = (s.factor(h), s.factor(h + 0.01));
            assert!((a / b).ln().abs() < 0.05, "{h}: {a} {b}");
        }
    }
}
