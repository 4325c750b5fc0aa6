//! The threshold-slope limit of the eroded surface: no free cell stands higher above any
//! cell within two cells than the talus slope allows, `h_i <= h_j + tan(talus) * |x_i - x_j|`.
//!
//! Hillslopes of rapidly uplifting ranges stand at a threshold angle, steeper ground failing
//! by landslides whose debris the rivers carry away (Burbank et al. 1996, "Bedrock incision,
//! rock uplift and threshold hillslopes in the northwestern Himalayas", Nature 379;
//! Montgomery and Brandon 2002, "Topographic controls on erosion rates in tectonically active
//! mountain ranges", EPSL 201). The thermal relaxation of each step (`thermal.rs`) moves
//! material downhill but, at two passes a step, cannot hold the angle where uplift outpaces it
//! (slopes of 50-75 degrees on 2-10 km maps); this limit lowers what stands above it, leaving
//! the largest surface below the eroded one whose slopes all stay within the angle, and the
//! step's hillslope diffusion then rounds the crests it leaves.
//!
//! The largest such surface is the min-plus convolution `h'_i = min_j (h_j + c_ij)` with the
//! slope cone `c_ij = tan(talus) * d_ij`, computed as a chamfer distance transform: raster
//! scans forward and backward, each cell taking the minimum over the half of a 5 x 5 mask
//! already scanned (the 8 neighbours and the 8 knight's moves, exact distances 1, sqrt 2 and
//! sqrt 5; Borgefors 1986, "Distance transformations in digital images", CVGIP 34). The 5 x
//! 5 mask's cones are 16-sided (within 2.7% of round) where the 8 neighbours alone give
//! octagons, whose facets would face the grid's 8 directions. Base-level cells (the rivers
//! and their banks) keep their heights and act only as sources. The solver runs one scan
//! pair a time step, after the incision ([`super::Eroder::with_slope_limit`]): exact where
//! no base-level cell bends the paths, and the next step's pair goes on from there.
//!
//! **Rock strength varies.** One angle everywhere makes every failed slope a plane (the
//! min-plus convolution with one cone), so the finer the grid, the more of a steep map is
//! planar facets: the default scene had 3.7% harmonic cells at 1024^2, 9% at 2048^2 and 26% at
//! 4096^2, where real mountains have a few percent at any resolution. The angle rock stands at
//! depends on its strength, which fractures, joints and weathering vary over metres to
//! hundreds of metres (Schmidt and Montgomery 1995, "Limits to relief", Science 270; Selby
//! 1980, "A rock mass strength classification for geomorphic purposes", Z. Geomorph. 24). So
//! each cell's allowed rise is `tan(talus)` times its strength factor ([`Strength`]), a seeded
//! fBm in metres between `1 - SPREAD` and 1: the talus angle is the strongest rock's, weaker
//! zones fail lower, and a failed slope is the weighted distance from base level, a cut
//! carried upslope behind each weak zone as a chute, sound rock standing between them as a
//! rib. With factors the surface is still the largest one whose slopes stay within each
//! cell's own angle.
//!
//! **Soft rock stands gentler.** The same weakness sets how fast rock erodes and the angle it
//! fails at: shales and marls are cut fast and stand at gentle slopes, granite and limestone
//! resist and stand steep (Selby 1980; Schmidt and Montgomery 1995). So the rock field of
//! the erodibility ([`super::Rock`], patches of harder and softer rock kilometres across)
//! scales the factors too ([`Strength::with_rock`]): units of soft rock, with smooth contacts
//! to the hard, fail at [`SOFT_ROCK_STRENGTH`] of the hard rock's slope. One steepness
//! everywhere (the slopes of the default scene at 10 km within 5 degrees of their median for
//! half the map, where the SRTM window spreads them over 14) becomes gentle country on soft
//! rock beside steep massifs on hard rock. The talus angle stays the strongest rock's.
//!
//! Pits are rare: a lowered cell ends at `h_j + c_ij` above some cell `j` within two cells,
//! which is lower, and a cell not lowered keeps its lower neighbour, which only went down;
//! only where `j` is a knight's move away behind two higher base-level cells can a lowered
//! cell be left without a lower neighbour, and the next routing fills it.

use std::cmp::Reverse;
use std::collections::BinaryHeap;
use std::ops::Range;

use crate::noise::{FbmGrid, Perlin};

/// The default spread of the strength factors (the scene's `erosion.strength_spread`): they
/// span `(1 - spread, 1]` times the talus slope's tangent; at 0.5 and a talus of 35 degrees
/// the weakest rock fails at 19 degrees, as weak, weathered rock masses stand at 20-30
/// degrees where strong ones stand at 35 and steeper (Selby 1980). It was 0.3 (weakest 26
/// degrees, factors' standard deviation 0.075): every failed face stood within a few
/// degrees of the talus angle, a median slope of 28 degrees on the default design at 10 km
/// (the SRTM window 18) with planar facets between the valleys; 0.5 measured on it at 512^2
/// (2 / 10 / 50 km): median slope 29 / 28 / 22 -> 25 / 24 / 19 degrees, spectral bump 0.46 /
/// 1.35 / 1.09 -> 0.39 / 1.02 / 0.97, direction index 0.033 / 0.007 / 0.022 -> 0.009 / 0.014
/// / 0.011, straight channel runs at 2 km 35.6% -> 30.2%, harmonic cells at 10 km 1.3% ->
/// 0.8%, relief at 10 km 1016 -> 912 m (the window 942 m).
pub const SPREAD: f64 = 0.5;
/// Wavelength of the strength field's largest octave, metres: buttresses and gullies of a
/// rock face (its finer octaves go down to two cells of the grid).
pub const STRENGTH_SCALE_M: f64 = 320.0;
/// Amplitude ratio between the strength field's octaves: 1, the finest scales vary as much
/// as the largest, as joints and fractures do from metres to hundreds of metres (at 0.75 a
/// 2 km map's failed faces kept 7% harmonic cells, at 1 about 4%).
const STRENGTH_ROUGHNESS: f64 = 1.0;
/// The most octaves (down to 320 m / 2^7 = 2.5 m).
const MAX_OCTAVES: u32 = 8;
/// Gain on the fBm (its octaves' sum normalised by their amplitudes has a standard deviation
/// of about 0.1): the factors' standard deviation is then about `SPREAD / 4`.
const GAIN: f64 = 2.5;

/// How strong the softest rock of a map's rock field is by default (the scene's
/// `erosion.soft_rock_strength`): its threshold slope is this share of the hardest rock's.
/// Weak rock masses (marls, shales, weathered schists) stand at a third to a half of the
/// slope strong ones hold (Selby 1980; Schmidt and Montgomery 1995). Measured on the default
/// scene at 1024^2 against 1 (rock of one strength): at 10 km the slopes' quartiles at 40 m
/// (the SRTM window's cells) went from 20.6 / 23.6 / 25.9 to 11.3 / 16.6 / 22.7 degrees (the
/// window's 11.0 / 17.9 / 25.1), the spectral bump from 1.43 to 0.88 (the window's 1.04),
/// the hypsometric integral from 0.37 to 0.35; at 2 km the integral from 0.44 to 0.31 and
/// the high ground on the frame from 70% to 53% (real 2-50 km windows about 45-80%).
pub const SOFT_ROCK_STRENGTH: f64 = 0.4;

/// Where along the rock field's range (0 hardest, 1 softest) rock passes from hard to soft:
/// a smoothstep from `UNIT_EDGE` to `1 - UNIT_EDGE`, so a map is units of hard and of soft
/// rock with contacts between them, as bedrock is mapped, not an even gradient. With the
/// field's values taken as they are, most rock was of middling strength and the slopes stood
/// in one narrow band: on the default scene at 10 km their quartiles at 40 m were 14.1 /
/// 17.2 / 20.2 degrees, with the units 11.3 / 16.6 / 22.7 (the SRTM window's 11.0 / 17.9 /
/// 25.1).
const UNIT_EDGE: f64 = 0.35;

/// How soft rock of erodibility factor `k` is in a field of `ln_contrast` (factors between
/// `exp(-ln_contrast / 2)` and `exp(ln_contrast / 2)`): 0 for hard rock, 1 for soft, a
/// smooth contact between ([`UNIT_EDGE`]).
fn softness(k: f32, ln_contrast: f64) -> f64 {
    let along = (f64::from(k).ln() / ln_contrast + 0.5).clamp(0.0, 1.0);
    let t = ((along - UNIT_EDGE) / (1.0 - 2.0 * UNIT_EDGE)).clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

/// The farthest a move of [`FORWARD`] reaches along either axis, in cells.
const REACH: isize = 2;

/// The mask's offsets `(dx, dy)` in the forward scan's half (rows above, and the cells left
/// of the current one); the backward half is their negation.
const FORWARD: [(isize, isize); 8] = [
    (-1, -2),
    (1, -2),
    (-2, -1),
    (-1, -1),
    (0, -1),
    (1, -1),
    (2, -1),
    (-1, 0),
];

/// The index in [`FORWARD`] of the move along the scanned row, to the cell scanned just
/// before (the others reach into rows scanned before the current one).
const ALONG: usize = 7;

/// The rock's strength on an `n` x `n` map of `cell_m` cells: each cell's factor on the
/// talus slope's tangent, in `(1 - spread, 1]`, sampled row by row ([`Strength::rows`]).
/// Positions are in metres, so the same scene has the same rock at any resolution (a finer
/// grid adds octaves, down to two of its cells).
pub struct Strength {
    perlin: Perlin,
    n: usize,
    /// fBm cycles of the largest octave across the map.
    cycles: f64,
    octaves: u32,
    spread: f64,
    /// The rock's units ([`super::Rock`], its erodibility factors), their ln contrast and
    /// the softest rock's strength ([`Strength::with_rock`]); `None`: rock of one strength.
    rock: Option<(super::Rock, f64, f64)>,
}

impl Strength {
    /// `spread` in `[0, 1)`: 0 is rock of one strength everywhere.
    pub fn new(n: usize, cell_m: f64, seed: u64, spread: f64) -> Self {
        let finest = STRENGTH_SCALE_M / (2.0 * cell_m.max(1e-9));
        let octaves = (finest.max(1.0).log2().floor() as u32 + 1).min(MAX_OCTAVES);
        Self {
            perlin: Perlin::new(crate::terrain::stage_seed(seed, "rock strength")),
            n,
            cycles: n as f64 * cell_m / STRENGTH_SCALE_M,
            octaves,
            spread,
            rock: None,
        }
    }

    /// The factors with the rock's units in them: `rock` gives each cell's erodibility
    /// factor, between `1 / sqrt(contrast)` (hardest) and `sqrt(contrast)` (softest), and
    /// soft rock's factors are `soft_strength` times hard rock's ([`softness`]). Rock that
    /// erodes faster fails at lower angles too. Nothing changes where `contrast` is 1 or
    /// `soft_strength` 1.
    pub fn with_rock(mut self, rock: super::Rock, contrast: f64, soft_strength: f64) -> Self {
        if contrast > 1.0 && soft_strength < 1.0 {
            self.rock = Some((rock, contrast.ln(), soft_strength));
        }
        self
    }

    /// Fills `out` (whole rows) with the factors of the rows from `first_row` on; the same
    /// values however the rows are split. O(cells of the rows x octaves).
    pub fn rows(&self, first_row: usize, out: &mut [f32]) {
        self.window([0, first_row], self.n, out);
    }

    /// Fills `out` (rows of `width` cells) with the factors of the window of the map whose
    /// first cell is (`x0`, `y0`): the same values as [`rows`](Self::rows) there (a world's
    /// tile sampling the rock of the whole world, `crate::world::refine`). The window must
    /// lie inside the map. O(cells of the window x octaves + n x octaves).
    pub fn window(&self, at: [usize; 2], width: usize, out: &mut [f32]) {
        self.spread_window(at, width, out);
        if let Some((rock, ln_contrast, soft_strength)) = &self.rock {
            let mut k = vec![0.0f32; out.len()];
            rock.window(at, width, &mut k);
            soften(out, &k, *ln_contrast, *soft_strength);
        }
    }

    /// [`rows`](Self::rows) given the rock's erodibility factors of those rows (`rock`, the
    /// [`super::Rock`]'s as [`with_rock`](Self::with_rock) was given, unpainted), where the
    /// caller made them already: the same values, without sampling the rock again.
    pub fn rows_on_rock(&self, first_row: usize, out: &mut [f32], rock: &[f32]) {
        match &self.rock {
            Some((_, ln_contrast, soft_strength)) if rock.len() == out.len() => {
                self.spread_window([0, first_row], self.n, out);
                soften(out, rock, *ln_contrast, *soft_strength);
            }
            _ => self.rows(first_row, out),
        }
    }

    /// The factors of the strength's spread alone (a window as in [`window`](Self::window)).
    fn spread_window(&self, [x0, y0]: [usize; 2], width: usize, out: &mut [f32]) {
        let n = self.n.max(1);
        let fbm = FbmGrid::new(
            &self.perlin,
            n,
            self.cycles,
            self.octaves,
            STRENGTH_ROUGHNESS,
        );
        for (k, v) in out.iter_mut().enumerate() {
            let (x, y) = (x0 + k % width.max(1), y0 + k / width.max(1));
            // `u` in [0, 1] about 1/2 (GAIN widens the octaves' normalised sum).
            let u = (0.5 + GAIN * fbm.at(x, y)).clamp(0.0, 1.0);
            *v = (1.0 - self.spread * u) as f32;
        }
    }
}

/// Weakens the factors `out` by the rock's units of erodibility factors `k` (see
/// [`Strength::with_rock`]).
fn soften(out: &mut [f32], k: &[f32], ln_contrast: f64, soft_strength: f64) {
    for (v, k) in out.iter_mut().zip(k) {
        *v *= (1.0 - (1.0 - soft_strength) * softness(*k, ln_contrast)) as f32;
    }
}

/// The 5 x 5 mask on a `width` x `height` grid: offsets and the rise allowed over each, and
/// each cell's strength factor on the rise (empty: 1 everywhere).
pub(super) struct Mask {
    width: usize,
    height: usize,
    cell: f32,
    steps: [(isize, isize, f32); 8],
    /// The rock's own factors ([`Mask::with_strength`]; empty: 1 everywhere).
    rock: Vec<f32>,
    /// The rock's factors weakened where water gathers
    /// ([`Mask::weaken_where_water_gathers`]); empty until then: the limit applies `rock`.
    weakened: Vec<f32>,
}

impl Mask {
    /// The mask of slopes up to `talus_deg` on a `width` x `height` grid of `cell_m` cells.
    pub(super) fn new(width: usize, height: usize, cell_m: f64, talus_deg: f64) -> Self {
        let rise = (talus_deg.to_radians().tan() * cell_m) as f32;
        Self {
            width,
            height,
            cell: cell_m as f32,
            steps: FORWARD.map(|(dx, dy)| {
                let d = ((dx * dx + dy * dy) as f32).sqrt();
                (dx, dy, rise * d)
            }),
            rock: Vec::new(),
            weakened: Vec::new(),
        }
    }

    /// The mask with each cell's strength factor ([`Strength`]) on the rise it allows above
    /// its neighbours; empty: 1 everywhere.
    pub(super) fn with_strength(mut self, strength: Vec<f32>) -> Self {
        self.rock = strength;
        self
    }

    /// The factors the limit applies: the rock's, weakened where water gathers once
    /// [`Mask::weaken_where_water_gathers`] has run; empty: 1 everywhere.
    fn strength(&self) -> &[f32] {
        if self.weakened.is_empty() {
            &self.rock
        } else {
            &self.weakened
        }
    }

    /// Sets the factors the limit applies to the rock's times the weakening where water
    /// gathers, from each cell's drainage area `area` (m^2) ([`super::gathering`]); an
    /// `area` of another size than the map leaves the rock's factors. O(cells).
    pub(super) fn weaken_where_water_gathers(&mut self, area: &[f32]) {
        if area.len() == self.width * self.height {
            super::gathering::weaken(&self.rock, area, self.cell, &mut self.weakened);
        }
    }

    /// One band of a scan: rows `rows` of the forward scan (top down, left to right), or of
    /// the backward scan (row `height - 1 - y` for `y` in `rows`, right to left). Returns
    /// whether a cell was lowered. O(cells of the rows).
    ///
    /// In a row with cells two from every edge, each such cell's cap over the rows scanned
    /// before is computed for the whole row first ([`Self::caps_from_rows_before`]), and the
    /// move along the row is then the recurrence `h_x = min(before_x, h_(x - 1) + rise_x)`
    /// (`x - 1` the cell scanned just before), one tight loop ([`Self::along_row`]); the
    /// cells within two of the row's ends take every move one by one. Each cell ends at the
    /// same value as when every move is taken in turn.
    pub(super) fn scan(
        &self,
        h: &mut [f32],
        base: &[bool],
        rows: Range<usize>,
        forward: bool,
    ) -> bool {
        let (w, rows_total) = (self.width as isize, self.height as isize);
        let sign = if forward { 1 } else { -1 };
        let mut before = vec![0.0f32; self.width];
        let mut rise = vec![0.0f32; self.width];
        let mut changed = false;
        for yy in rows {
            let y = if forward { yy } else { self.height - 1 - yy } as isize;
            let at = |xx: isize| if forward { xx } else { w - 1 - xx };
            // Rows with cells two from every edge (none on a map under five cells wide).
            let inner_row = y >= REACH && y < rows_total - REACH && w > 2 * REACH;
            if !inner_row {
                for xx in 0..w {
                    changed |= self.lower(h, base, at(xx), y, sign);
                }
                continue;
            }
            self.caps_from_rows_before(h, y as usize, sign, &mut before);
            self.rises_along(y as usize, &mut rise);
            for xx in 0..REACH {
                changed |= self.lower(h, base, at(xx), y, sign);
            }
            changed |= self.along_row(h, base, y as usize, forward, (&before, &rise));
            for xx in w - REACH..w {
                changed |= self.lower(h, base, at(xx), y, sign);
            }
        }
        changed
    }

    /// Lowers cell `(x, y)` of a scan (`sign` 1 forward, -1 backward) to its cap, the lowest
    /// `h_j + rise_ij s_i` over the mask's moves into the cells scanned before it, looked at
    /// one by one (the cells near the map's edges); returns whether it was lowered.
    fn lower(&self, h: &mut [f32], base: &[bool], x: isize, y: isize, sign: isize) -> bool {
        let (w, rows_total) = (self.width as isize, self.height as isize);
        let i = (y * w + x) as usize;
        if base[i] {
            return false;
        }
        let strength = self.strength().get(i).copied().unwrap_or(1.0);
        let mut cap = h[i];
        for &(dx, dy, rise) in &self.steps {
            let (nx, ny) = (x + sign * dx, y + sign * dy);
            if nx >= 0 && ny >= 0 && nx < w && ny < rows_total {
                cap = cap.min(h[(ny * w + nx) as usize] + rise * strength);
            }
        }
        if cap < h[i] {
            h[i] = cap;
            true
        } else {
            false
        }
    }

    /// The rise allowed along the row over one cell, `rise s_x`, for the cells of row `y` at
    /// least [`REACH`] from its ends, into `out` (indexed by column).
    fn rises_along(&self, y: usize, out: &mut [f32]) {
        let w = self.width;
        let inner = REACH as usize..w - REACH as usize;
        let along_rise = self.steps[ALONG].2;
        let out = &mut out[inner.clone()];
        match self.strength().get(y * w + inner.start..y * w + inner.end) {
            Some(strength) => {
                for (r, s) in out.iter_mut().zip(strength) {
                    *r = along_rise * s;
                }
            }
            None => out.fill(along_rise),
        }
    }

    /// The move along row `y` for its cells at least [`REACH`] from its ends, in scan order:
    /// each free cell becomes `min(before_x, h_prev + rise_x)`, `h_prev` the cell scanned
    /// just before, as it now stands (`before_x` is at most `h_x`, so the cell never rises);
    /// base-level cells keep their heights. Returns whether a cell was lowered.
    fn along_row(
        &self,
        h: &mut [f32],
        base: &[bool],
        y: usize,
        forward: bool,
        (before, rise): (&[f32], &[f32]),
    ) -> bool {
        let w = self.width;
        let (first, end) = (REACH as usize, w - REACH as usize);
        // The cell scanned just before the run: its last end cell, already done.
        let mut prev = if forward {
            h[y * w + first - 1]
        } else {
            h[y * w + end]
        };
        let row = &mut h[y * w..(y + 1) * w];
        let fixed = &base[y * w..(y + 1) * w];
        let mut lowered = false;
        // Plain comparisons, not `f32::min`: the heights are never NaN (the erosion refuses
        // them), and `min`'s NaN handling doubled this loop's chain of dependent instructions.
        let mut step = |x: usize, prev: f32| {
            let over = prev + rise[x];
            let cap = if over < before[x] { over } else { before[x] };
            let v = if fixed[x] { row[x] } else { cap };
            lowered |= v < row[x];
            row[x] = v;
            v
        };
        if forward {
            for x in first..end {
                prev = step(x, prev);
            }
        } else {
            for x in (first..end).rev() {
                prev = step(x, prev);
            }
        }
        lowered
    }

    /// Each cell of row `y` at least [`REACH`] from its ends: `min(h_i, h_j + rise_ij s_i)`
    /// over the mask's moves into the rows the scan (`sign` 1 forward, -1 backward) passed
    /// before, into `out` (indexed by column). The row's own updates do not change those
    /// rows, so this runs a pass per move along the row, which the compiler vectorises; the
    /// minimum is exact in any order, so the scan's bits are those of one cell at a time.
    fn caps_from_rows_before(&self, h: &[f32], y: usize, sign: isize, out: &mut [f32]) {
        let w = self.width;
        let inner = REACH as usize..w - REACH as usize;
        let row = y * w;
        let out = &mut out[inner.clone()];
        out.copy_from_slice(&h[row + inner.start..row + inner.end]);
        for (k, &(dx, dy, rise)) in self.steps.iter().enumerate() {
            if k == ALONG {
                continue;
            }
            let from = (row + inner.start).wrapping_add_signed(sign * (dy * w as isize + dx));
            let src = &h[from..from + out.len()];
            match self.strength().get(row + inner.start..row + inner.end) {
                // Comparisons, not `f32::min` (see `along_row`): one vector minimum each.
                Some(strength) => {
                    for ((cap, z), s) in out.iter_mut().zip(src).zip(strength) {
                        let c = z + rise * s;
                        *cap = if c < *cap { c } else { *cap };
                    }
                }
                None => {
                    for (cap, z) in out.iter_mut().zip(src) {
                        let c = z + rise;
                        *cap = if c < *cap { c } else { *cap };
                    }
                }
            }
        }
    }

    /// The limit carried out from `seeds` alone: every cell standing above a lowered cell
    /// more than the mask allows is lowered to the cap, and its own neighbours are looked at
    /// in turn, lowest first (Dijkstra's order on the mask's 16 moves, each cell's cap the
    /// lowest `h_j + rise_ij * strength_i` of its neighbours). The surface elsewhere is left
    /// as it stands: where only the seeds were lowered (a floor cut into a surface within the
    /// limit), it is the scans' surface, found in O(lowered cells log cells) where the scans
    /// need passes over the whole map until nothing changes. `base` cells keep their heights.
    /// Returns how many times a cell was lowered.
    pub(super) fn relax_from(
        &self,
        h: &mut [f32],
        base: &[bool],
        seeds: impl Iterator<Item = usize>,
    ) -> usize {
        let (w, rows) = (self.width as isize, self.height as isize);
        let mut heap: BinaryHeap<Reverse<(Height, u32)>> =
            seeds.map(|i| Reverse((Height(h[i]), i as u32))).collect();
        let mut lowered = 0;
        while let Some(Reverse((Height(z), j))) = heap.pop() {
            let j = j as usize;
            if z != h[j] {
                continue;
            }
            let (x, y) = ((j % self.width) as isize, (j / self.width) as isize);
            for sign in [1, -1] {
                for &(dx, dy, rise) in &self.steps {
                    let (nx, ny) = (x + sign * dx, y + sign * dy);
                    if nx < 0 || ny < 0 || nx >= w || ny >= rows {
                        continue;
                    }
                    let i = (ny * w + nx) as usize;
                    if base[i] {
                        continue;
                    }
                    let cap = z + rise * self.strength().get(i).copied().unwrap_or(1.0);
                    if cap < h[i] {
                        h[i] = cap;
                        lowered += 1;
                        heap.push(Reverse((Height(cap), i as u32)));
                    }
                }
            }
        }
        lowered
    }
}

/// A height ordered by `f32::total_cmp`, for the heap of [`Mask::relax_from`].
#[derive(Clone, Copy, PartialEq)]
struct Height(f32);

impl Eq for Height {}

impl PartialOrd for Height {
    fn partial_cmp(&self, other: &Self) -> Option<std::cmp::Ordering> {
        Some(self.cmp(other))
    }
}

impl Ord for Height {
    fn cmp(&self, other: &Self) -> std::cmp::Ordering {
        self.0.total_cmp(&other.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Scans on 10 m cells until nothing changes; returns how many cells were lowered.
    fn limited(h: &mut [f32], n: usize, base: &[bool], talus: f64) -> usize {
        limited_in(h, n, base, Mask::new(n, n, 10.0, talus))
    }

    /// [`limited`] with a given mask.
    fn limited_in(h: &mut [f32], n: usize, base: &[bool], mask: Mask) -> usize {
        let before = h.to_vec();
        for _ in 0..8 {
            let forward = mask.scan(h, base, 0..n, true);
            let backward = mask.scan(h, base, 0..n, false);
            if !(forward || backward) {
                break;
            }
        }
        h.iter().zip(&before).filter(|(a, b)| a != b).count()
    }

    /// The scan one cell at a time, in scan order, over every move of the mask: what
    /// [`Mask::scan`] computes with its rows-before part taken a row at a time.
    fn cell_by_cell(mask: &Mask, h: &mut [f32], base: &[bool], forward: bool) {
        let (w, rows) = (mask.width as isize, mask.height as isize);
        let sign = if forward { 1 } else { -1 };
        for yy in 0..rows {
            let y = if forward { yy } else { rows - 1 - yy };
            for xx in 0..w {
                let x = if forward { xx } else { w - 1 - xx };
                let i = (y * w + x) as usize;
                if base[i] {
                    continue;
                }
                let strength = mask.strength().get(i).copied().unwrap_or(1.0);
                for &(dx, dy, rise) in &mask.steps {
                    let (nx, ny) = (x + sign * dx, y + sign * dy);
                    if nx >= 0 && ny >= 0 && nx < w && ny < rows {
                        h[i] = h[i].min(h[(ny * w + nx) as usize] + rise * strength);
                    }
                }
            }
        }
    }

    /// The scans give the bits of the cell-by-cell definition, forward and backward, with
    /// and without the rock's strength, on a rough field with a river; and on a map three
    /// cells wide, which has no cell two from every edge.
    #[test]
    fn the_scans_are_the_cell_by_cell_limit() {
        scans_match_cell_by_cell(37, 29);
        scans_match_cell_by_cell(3, 9);
    }

    fn scans_match_cell_by_cell(w: usize, rows: usize) {
        let mut state = 0x2545_f491_u32;
        let rough: Vec<f32> = (0..w * rows)
            .map(|i| {
                state ^= state << 13;
                state ^= state >> 17;
                state ^= state << 5;
                (i % w) as f32 * 3.0 + (state % 4000) as f32 * 0.01
            })
            .collect();
        // Base level on the west edge and scattered inside, where the scans pass over it.
        let base: Vec<bool> = (0..w * rows).map(|i| i % w == 0 || i % 11 == 5).collect();
        // The strength of a square map as wide as the longer side, cut to this one.
        let side = w.max(rows);
        let mut square = vec![0.0f32; side * side];
        Strength::new(side, 10.0, 3, SPREAD).rows(0, &mut square);
        let strength: Vec<f32> = (0..w * rows)
            .map(|i| square[i / w * side + i % w])
            .collect();
        for varied in [false, true] {
            let mask = Mask::new(w, rows, 10.0, 30.0);
            let mask = if varied {
                mask.with_strength(strength.clone())
            } else {
                mask
            };
            for forward in [true, false] {
                let (mut fast, mut slow) = (rough.clone(), rough.clone());
                let lowered = mask.scan(&mut fast, &base, 0..rows, forward);
                cell_by_cell(&mask, &mut slow, &base, forward);
                assert!(lowered, "the field is steeper than the mask");
                let bits = |h: &[f32]| h.iter().map(|z| z.to_bits()).collect::<Vec<_>>();
                assert_eq!(
                    bits(&fast),
                    bits(&slow),
                    "strength {varied}, forward {forward}"
                );
            }
        }
    }

    /// A spike on a plain becomes a 16-sided cone of the talus slope: every cell at most
    /// `tan(talus) * distance` above the plain, lowered only, the plain and the base kept,
    /// no pit; a second run changes nothing.
    #[test]
    fn a_spike_becomes_a_round_cone_of_the_talus_slope() {
        let n = 41;
        let mut h = vec![0.0f32; n * n];
        let base: Vec<bool> = (0..n * n).map(|i| i % n == 0).collect();
        let c = 20 * n + 20;
        h[c] = 1000.0;
        h[20 * n + 30] = 3.0;
        let before = h.clone();
        let count = limited(&mut h, n, &base, 30.0);
        assert_eq!(count, 1, "only the spike stands above the limit");
        let tan = 30f64.to_radians().tan() * 10.0;
        // The spike is one cell: its neighbours at 0 hold it to tan * 10 m.
        assert!((f64::from(h[c]) - tan).abs() < 1e-3, "{}", h[c]);
        assert!(h.iter().zip(&before).all(|(a, b)| a <= b));
        // A raised table: the limit cuts its edges into a cone about the plain.
        let mut table = vec![500.0f32; n * n];
        for (i, b) in base.iter().enumerate() {
            if *b {
                table[i] = 0.0;
            }
        }
        limited(&mut table, n, &base, 30.0);
        for y in 0..n {
            for x in 1..n {
                let limit = tan * x as f64; // the nearest base cell is (0, y)
                let got = f64::from(table[y * n + x]);
                assert!(got <= limit * 1.001 + 1e-3, "({x}, {y}): {got} > {limit}");
                assert!(got >= limit * 0.97 - 1e-3, "({x}, {y}): {got} < {limit}");
            }
        }
        let again = table.clone();
        assert_eq!(limited(&mut table, n, &base, 30.0), 0);
        assert_eq!(table, again);
    }

    /// A trench cut into a rough surface within the limit: carried out from the trench alone,
    /// the limit gives the scans' surface to the bit, lowers land only, and a second run
    /// lowers nothing. Both with varied strength.
    #[test]
    fn the_limit_from_a_cut_is_the_scans_limit() {
        let n = 48;
        let strength: Vec<f32> = (0..n * n)
            .map(|i| 0.7 + 0.3 * ((i * 7919 % 101) as f32 / 100.0))
            .collect();
        let mask = || Mask::new(n, n, 10.0, 35.0).with_strength(strength.clone());
        let mut rough: Vec<f32> = (0..n * n)
            .map(|i| 300.0 + ((i * 2654435761usize) % 1000) as f32 / 5.0)
            .collect();
        let no_base = vec![false; n * n];
        limited_in(&mut rough, n, &no_base, mask());
        let mut base = vec![false; n * n];
        for x in 4..40 {
            let i = 20 * n + x;
            rough[i] = 0.0;
            base[i] = true;
        }
        let mut scanned = rough.clone();
        limited_in(&mut scanned, n, &base, mask());
        let mut carried = rough.clone();
        let seeds = (0..n * n).filter(|&i| base[i]);
        assert!(mask().relax_from(&mut carried, &base, seeds) > 0);
        assert_eq!(carried, scanned);
        assert!(carried.iter().zip(&rough).all(|(a, b)| a <= b));
        let seeds = (0..n * n).filter(|&i| base[i]);
        assert_eq!(mask().relax_from(&mut carried, &base, seeds), 0);
    }

    /// Around a single low cell the cone is round: the height at every distance varies with
    /// the direction by under 3% (an octagon of the 8 neighbours alone: 8%).
    #[test]
    fn cones_are_nearly_round() {
        let n = 81;
        let mut h = vec![1.0e4f32; n * n];
        let mut base = vec![false; n * n];
        let c = 40 * n + 40;
        h[c] = 0.0;
        base[c] = true;
        limited(&mut h, n, &base, 45.0);
        for y in 0..n {
            for x in 0..n {
                let r = ((x as f64 - 40.0).hypot(y as f64 - 40.0)) * 10.0;
                if (100.0..=390.0).contains(&r) {
                    let ratio = f64::from(h[y * n + x]) / r;
                    assert!((1.0 - 1e-3..1.03).contains(&ratio), "({x}, {y}): {ratio}");
                }
            }
        }
    }

    /// The rock field's units: where the field's rock is hardest the factors are the
    /// spread's alone, where softest `soft` times them, in between no lower and no higher,
    /// and most of the map lies in one unit or the other (not at middling strength); the same
    /// however the rows are split, or given the rock's factors made before; uniform rock, or
    /// soft rock as strong as hard, changes nothing.
    #[test]
    fn soft_rock_units_fail_lower_than_hard_ones() {
        let (n, cell, seed, contrast, soft) = (200, 50.0, 9, 10.0, 0.4);
        let rock = || super::super::Rock::new(n, cell, contrast, 2500.0, seed);
        let factors = |strength: Strength, first: usize, rows: usize| {
            let mut out = vec![0.0f32; n * rows];
            strength.rows(first, &mut out);
            out
        };
        let plain = factors(Strength::new(n, cell, seed, SPREAD), 0, n);
        let units = factors(
            Strength::new(n, cell, seed, SPREAD).with_rock(rock(), contrast, soft),
            0,
            n,
        );
        let mut k = vec![0.0f32; n * n];
        rock().rows(0, &mut k);
        let (lo, hi) = (contrast.sqrt().recip() as f32, contrast.sqrt() as f32);
        let (mut hard, mut softest) = (0, 0);
        for ((p, u), k) in plain.iter().zip(&units).zip(&k) {
            let share = u / p;
            assert!(
                share >= soft as f32 - 1e-6 && share <= 1.0 + 1e-6,
                "{share}"
            );
            if *k <= lo * 1.01 {
                assert!(
                    (share - 1.0).abs() < 1e-6,
                    "the hardest rock keeps its angle"
                );
            }
            if *k >= hi * 0.99 {
                assert!(
                    (share - soft as f32).abs() < 1e-6,
                    "the softest rock fails lowest"
                );
            }
            hard += usize::from(share > 0.95);
            softest += usize::from(share < soft as f32 + 0.05);
        }
        assert!(
            hard > n * n / 5 && softest > n * n / 5,
            "units of both: {hard} hard, {softest} soft of {}",
            n * n
        );
        let lower = factors(
            Strength::new(n, cell, seed, SPREAD).with_rock(rock(), contrast, soft),
            n / 2,
            n / 2,
        );
        assert_eq!(&units[n * n / 2..], &lower[..]);
        // Given the rock's factors already made, the same values.
        let mut k = vec![0.0f32; n * n / 2];
        rock().rows(n / 2, &mut k);
        let mut given = vec![0.0f32; n * n / 2];
        Strength::new(n, cell, seed, SPREAD)
            .with_rock(rock(), contrast, soft)
            .rows_on_rock(n / 2, &mut given, &k);
        assert_eq!(given, lower);
        for same in [
            Strength::new(n, cell, seed, SPREAD).with_rock(rock(), 1.0, soft),
            Strength::new(n, cell, seed, SPREAD).with_rock(rock(), contrast, 1.0),
        ] {
            assert_eq!(factors(same, 0, n), plain);
        }
    }

    /// The rock's strength: factors within `(1 - SPREAD, 1]`, spread over most of the range
    /// (standard deviation within a factor of 2 of `SPREAD / 4`), varying from cell to cell;
    /// the same field however the rows are split; another seed, another field.
    #[test]
    fn strength_spans_its_range_and_varies_at_every_scale() {
        let n = 256;
        let field = |seed| {
            let mut out = vec![0.0f32; n * n];
            Strength::new(n, 2.5, seed, SPREAD).rows(0, &mut out);
            out
        };
        let f = field(3);
        assert!(f.iter().all(|v| (1.0 - SPREAD as f32..=1.0).contains(v)));
        let mean = f.iter().map(|v| f64::from(*v)).sum::<f64>() / f.len() as f64;
        let sd = (f
            .iter()
            .map(|v| (f64::from(*v) - mean).powi(2))
            .sum::<f64>()
            / f.len() as f64)
            .sqrt();
        assert!((SPREAD / 8.0..SPREAD / 2.0).contains(&sd), "sd {sd}");
        // Neighbouring cells differ: the finest octave is two cells long.
        let steps = (1..n).filter(|x| f[x - 1] != f[*x]).count();
        assert!(steps > n * 9 / 10, "{steps}");
        let mut half = vec![0.0f32; n * n / 2];
        Strength::new(n, 2.5, 3, SPREAD).rows(n / 2, &mut half);
        assert_eq!(&f[n * n / 2..], &half[..]);
        assert_ne!(f, field(4));
        // The scene's spread sets the range: none is one angle, a wider one reaches lower.
        let mut one = vec![0.0f32; n * n];
        Strength::new(n, 2.5, 3, 0.0).rows(0, &mut one);
        assert!(one.iter().all(|v| *v == 1.0));
        let mut wide = vec![0.0f32; n * n];
        Strength::new(n, 2.5, 3, 0.6).rows(0, &mut wide);
        let lowest = |f: &[f32]| f.iter().copied().fold(1.0f32, f32::min);
        assert!(wide.iter().all(|v| (0.4..=1.0).contains(v)));
        assert!(
            lowest(&wide) < lowest(&f) - 0.05,
            "{} vs {}",
            lowest(&wide),
            lowest(&f)
        );
    }

    /// With the rock's strength a failed slope is no plane: a table cut back from a river
    /// along its west edge stands at most at the talus slope, at least at the weakest rock's,
    /// and its cells are not harmonic (under 5%, where one angle leaves almost all of them
    /// on a plane); no cell is raised.
    #[test]
    fn strength_breaks_the_planes_of_failed_slopes() {
        let n = 96;
        let base: Vec<bool> = (0..n * n).map(|i| i % n == 0).collect();
        let table: Vec<f32> = base.iter().map(|b| if *b { 0.0 } else { 2000.0 }).collect();
        let harmonic = |h: &[f32]| {
            let mut count = 0;
            for y in 1..n - 1 {
                for x in 2..n - 1 {
                    let i = y * n + x;
                    let mean = (h[i - 1] + h[i + 1] + h[i - n] + h[i + n]) / 4.0;
                    let grad = (h[i + 1] - h[i - 1]).hypot(h[i + n] - h[i - n]) / 2.0;
                    count += usize::from((h[i] - mean).abs() <= 1e-3 * grad);
                }
            }
            count as f64 / ((n - 2) * (n - 3)) as f64
        };
        let mut plain = table.clone();
        limited(&mut plain, n, &base, 35.0);
        let mut strength = vec![0.0f32; n * n];
        Strength::new(n, 10.0, 5, SPREAD).rows(0, &mut strength);
        let mut varied = table.clone();
        limited_in(
            &mut varied,
            n,
            &base,
            Mask::new(n, n, 10.0, 35.0).with_strength(strength),
        );
        assert!(harmonic(&plain) > 0.9, "one angle: {}", harmonic(&plain));
        assert!(harmonic(&varied) < 0.05, "strength: {}", harmonic(&varied));
        let tan = 35f64.to_radians().tan() * 10.0;
        for y in 0..n {
            for x in 1..n {
                let got = f64::from(varied[y * n + x]);
                let (top, bottom) = (tan * x as f64, (1.0 - SPREAD) * tan * x as f64);
                assert!(got <= top * 1.001 + 1e-3, "({x}, {y}): {got} > {top}");
                assert!(got >= bottom * 0.97 - 1e-3, "({x}, {y}): {got} < {bottom}");
            }
        }
        assert!(varied.iter().zip(&table).all(|(a, b)| a <= b));
    }
}
