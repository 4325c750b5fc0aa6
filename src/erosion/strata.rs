//! Layered rock: horizontal beds of hard and soft rock, so that rivers cutting down through
//! them leave cliffs and benches, mesas and buttes, stepped canyon walls.
//!
//! Rock patches ([`super::rock`]) vary the erodibility across the map; strata vary it with
//! depth. A cell's rock is the beds at its height, so the erodibility changes as the land is
//! lowered through the beds: a river cuts slowly through a hard bed, whose edge then
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
//! ones, as for the rock patches. A cell reads the mean hardness of the beds between its
//! lowest and its highest neighbour within two cells ([`Strata::factor_of_cell`]: a cell is
//! an area, and the bed at its centre alone made escarpments one cell high and ragged where
//! beds are thin beside the cells). The same formulas, in `f32`, are in `shaders/erosion.wgsl`
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

    /// The factor on the erodibility of a cell standing at `h` metres whose neighbours within
    /// [`REACH`] cells stand between `lowest` and `highest`: the factor of the mean hardness
    /// of the beds its neighbourhood exposes, from its lowest neighbour to its highest. A cell
    /// is an area, not a point: reading the bed at its centre alone made each cell all hard or
    /// all soft, so that a cell a little higher than its neighbours, in a hard bed, eroded
    /// slower and stayed higher while they, in a soft bed, were cut down: escarpments a cell
    /// high, ragged at the cell's scale, their edges staircases along the grid's rows and
    /// diagonals (the mesas at 50 km, 98 m cells on 120 m beds: a grid-direction index of
    /// 0.32). Read over its neighbourhood, such a cell's rock is a mix, and its neighbours
    /// read nearly the same beds (the index 0.09; over the 8 nearest neighbours 0.10, over
    /// its own face alone, halfway to them, 0.13). Where the neighbourhood spans less than a
    /// bed's edge, as on maps of fine cells on gentle land, the mean is nearly the centre's
    /// hardness. O(1).
    pub fn factor_of_cell(&self, h: f32, lowest: f32, highest: f32) -> f64 {
        let (lo, hi) = (lowest.min(h), highest.max(h));
        (f64::from(self.ln_contrast) * f64::from(0.5 - self.mean_hardness(lo, hi))).exp()
    }

    /// Each cell's [`factor_of_cell`](Self::factor_of_cell) on a `width`-wide grid of
    /// heights `h` (row-major), its neighbours those on the map within [`REACH`] cells, into
    /// `out`. Rows on all threads (each cell reads only `h`: the same values); `along` is
    /// scratch, kept by the caller between steps. O(cells).
    pub fn cell_factors(
        &self,
        h: &[f32],
        width: usize,
        along: &mut Vec<[f32; 2]>,
        out: &mut [f32],
    ) {
        let w = width.max(1);
        let rows = h.len() / w;
        let per = rows.div_ceil(crate::parallel::bands(w, rows)).max(1);
        // The square's least and greatest heights, separably: along each row, then along each
        // column of those (min and max are exact in any order: the whole square's values).
        along.resize(h.len(), [0.0; 2]);
        let along = &mut along[..h.len()];
        crate::parallel::for_each_band(along, per * w, |k, band| {
            for (y, row) in (k * per..).zip(band.chunks_mut(w)) {
                let line = &h[y * w..(y + 1) * w];
                for (x, v) in row.iter_mut().enumerate() {
                    let near = &line[x.saturating_sub(REACH)..(x + REACH + 1).min(w)];
                    *v = near
                        .iter()
                        .fold([f32::INFINITY, f32::NEG_INFINITY], |[lo, hi], z| {
                            [lo.min(*z), hi.max(*z)]
                        });
                }
            }
        });
        crate::parallel::for_each_band(out, per * w, |k, band| {
            for (y, row) in (k * per..).zip(band.chunks_mut(w)) {
                let near = y.saturating_sub(REACH)..(y + REACH + 1).min(rows);
                for (x, v) in row.iter_mut().enumerate() {
                    let [lowest, highest] =
                        near.clone()
                            .fold([f32::INFINITY, f32::NEG_INFINITY], |[lo, hi], ny| {
                                let [a, b] = along[ny * w + x];
                                [lo.min(a), hi.max(b)]
                            });
                    *v = self.factor_of_cell(h[y * w + x], lowest, highest) as f32;
                }
            }
        });
    }

    /// The mean of [`Self::hardness`] over heights `lo` to `hi` metres: the hardness's
    /// integral (in closed form, [`hardness_integral`]) over the span, or the hardness at the
    /// middle of a span under a thousandth of a period (or not a span at all).
    pub fn mean_hardness(&self, lo: f32, hi: f32) -> f32 {
        let (a, b) = (lo / self.period_m, hi / self.period_m);
        let span = b - a;
        if span.is_nan() || span <= MIN_SPAN {
            return self.hardness(0.5 * (lo + hi));
        }
        // Counted from the period that holds `a`, so that f32 keeps its digits.
        let first = a.floor();
        let (a, b) = (a - first, b - first);
        let whole = b.floor();
        let integral = whole * HARD_FRACTION + hardness_integral(b - whole);
        (integral - hardness_integral(a)) / span
    }

    /// How hard the rock at height `h` is: 1 inside a hard bed, 0 inside a soft one.
    pub fn hardness(&self, h: f32) -> f32 {
        let t = h / self.period_m;
        let phase = t - t.floor();
        smoothstep(0.0, EDGE_FRACTION, phase)
            * (1.0 - smoothstep(HARD_FRACTION, HARD_FRACTION + EDGE_FRACTION, phase))
    }
}

/// How far (cells, along each axis) the neighbourhood a cell reads its beds over reaches.
pub const REACH: usize = 2;

/// Spans of heights under this share of a period take the hardness at their middle.
const MIN_SPAN: f32 = 1.0e-3;

/// The integral of the hardness over the phases 0 to `p` of one period (`p` in `[0, 1]`; the
/// whole period's is [`HARD_FRACTION`]): the rising edge, the hard bed, the falling edge.
/// The smoothstep's integral from 0 to `s` is `s^3 - s^4 / 2`, times the edge's width.
fn hardness_integral(p: f32) -> f32 {
    let (e, h) = (EDGE_FRACTION, HARD_FRACTION);
    let ramp = |s: f32| {
        let s = s.clamp(0.0, 1.0);
        e * s * s * s * (1.0 - 0.5 * s)
    };
    let falling = (p - h).clamp(0.0, e);
    ramp(p / e) + (p.min(h) - e).max(0.0) + falling - ramp(falling / e)
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

    /// The factors read the least and greatest heights of each cell's whole square of
    /// neighbours (within REACH, clipped at the map's edges), as one cell at a time would.
    #[test]
    fn each_cell_reads_its_whole_square() {
        let s = Strata::new(120.0, 20.0).expect("beds");
        let (w, rows) = (13, 9);
        let h: Vec<f32> = (0..w * rows)
            .map(|i| ((i * 7919) % 241) as f32 * 1.3 - 40.0)
            .collect();
        let mut out = vec![0.0; w * rows];
        s.cell_factors(&h, w, &mut Vec::new(), &mut out);
        for y in 0..rows {
            for x in 0..w {
                let (mut lo, mut hi) = (f32::INFINITY, f32::NEG_INFINITY);
                for ny in y.saturating_sub(REACH)..(y + REACH + 1).min(rows) {
                    for nx in x.saturating_sub(REACH)..(x + REACH + 1).min(w) {
                        lo = lo.min(h[ny * w + nx]);
                        hi = hi.max(h[ny * w + nx]);
                    }
                }
                let want = s.factor_of_cell(h[y * w + x], lo, hi) as f32;
                assert_eq!(out[y * w + x].to_bits(), want.to_bits(), "({x}, {y})");
            }
        }
    }

    /// The mean hardness over a span of heights is the mean of the hardness sampled finely
    /// over it; a whole number of periods gives the hard beds' share; a span too short to
    /// measure gives the hardness at its middle; a cell whose neighbourhood spans beds reads
    /// a mix where its centre reads one bed.
    #[test]
    fn a_cell_reads_the_beds_its_neighbourhood_exposes() {
        let s = Strata::new(120.0, 20.0).expect("beds");
        let sampled = |lo: f32, hi: f32| {
            let k = 20_000;
            (0..k)
                .map(|j| s.hardness(lo + (hi - lo) * (j as f32 + 0.5) / k as f32))
                .sum::<f32>()
                / k as f32
        };
        for (lo, hi) in [
            (0.0, 10.0),
            (5.0, 50.0),
            (30.0, 70.0),
            (-75.0, 47.0),
            (1190.0, 1433.0),
            (2511.5, 2512.5),
        ] {
            let (got, want) = (s.mean_hardness(lo, hi), sampled(lo, hi));
            assert!((got - want).abs() < 2e-3, "{lo}..{hi}: {got} vs {want}");
        }
        for periods in 1..4 {
            let m = s.mean_hardness(37.0, 37.0 + 120.0 * periods as f32);
            assert!((m - HARD_FRACTION).abs() < 1e-4, "{periods}: {m}");
        }
        assert_eq!(s.mean_hardness(30.0, 30.05), s.hardness(30.025));
        assert_eq!(s.factor_of_cell(30.0, 30.0, 30.0), s.factor(30.0));
        // In a hard bed a point is all hard; a cell whose lowest neighbour stands 100 m below
        // reads the soft bed under it too, and a cell in a soft bed whose neighbours rise
        // into the hard bed above reads some of it.
        assert!(s.hardness(25.0) > 0.99);
        let mixed = s.mean_hardness(-75.0, 25.0);
        assert!((0.2..0.8).contains(&mixed), "{mixed}");
        assert!(s.factor_of_cell(25.0, -75.0, 25.0) > 2.0 * s.factor(25.0));
        assert!(s.hardness(110.0) < 0.01);
        assert!(s.factor_of_cell(110.0, 110.0, 150.0) < 0.5 * s.factor(110.0));
    }
}
