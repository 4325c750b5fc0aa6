//! Geomorphons: landform classes from line-of-sight ternary patterns.
//!
//! Jasiewicz, J. and Stepinski, T. F. (2013). Geomorphons - a pattern recognition approach to
//! classification and mapping of landforms. Geomorphology 182, 147-156.
//! doi:10.1016/j.geomorph.2012.11.005
//!
//! For every cell and each of the 8 principal directions the heights up to `L` cells away are
//! seen from the cell. With `phi` the largest elevation angle (zenith angle `90° - phi`) and
//! `psi` the smallest elevation angle (nadir angle `90° + psi`) along that line, the direction
//! is coded
//!
//! * `+` when `nadir - zenith = phi + psi > t` (the horizon rises: neighbours higher),
//! * `-` when `phi + psi < -t` (neighbours lower),
//! * `0` otherwise,
//!
//! with `t` the flatness threshold. The landform depends only on the number of `-` and `+`
//! (the paper's Fig. 4 lookup table, reproduced in [`FORM_TABLE`]). Lines are cut at the map
//! border; a cell is only classified when its 3x3 window and every sample on its 8 lines are
//! finite.

use super::grid::{DIRS8, Grid};

/// Names of the 10 geomorphon classes, in the order of `Realism::geomorphons`.
pub const GEOMORPHON_NAMES: [&str; 10] = [
    "flat",
    "peak",
    "ridge",
    "shoulder",
    "spur",
    "slope",
    "hollow",
    "footslope",
    "valley",
    "pit",
];

pub(super) const FL: u8 = 0;
pub(super) const PK: u8 = 1;
pub(super) const RI: u8 = 2;
pub(super) const SH: u8 = 3;
pub(super) const SP: u8 = 4;
pub(super) const SL: u8 = 5;
pub(super) const HL: u8 = 6;
pub(super) const FS: u8 = 7;
pub(super) const VL: u8 = 8;
pub(super) const PT: u8 = 9;
/// Impossible combination (more than 8 directions); never produced.
pub(super) const XX: u8 = u8::MAX;

/// Landform by `[number of '-'][number of '+']`: Jasiewicz and Stepinski (2013), Fig. 4
/// (the same table as GRASS GIS `r.geomorphon`).
#[rustfmt::skip]
pub(super) const FORM_TABLE: [[u8; 9]; 9] = [
    //        + 0   1   2   3   4   5   6   7   8
    /* - 0 */ [FL, FL, FL, FS, FS, VL, VL, VL, PT],
    /* - 1 */ [FL, FL, FS, FS, FS, VL, VL, VL, XX],
    /* - 2 */ [FL, SH, SL, SL, HL, HL, VL, XX, XX],
    /* - 3 */ [SH, SH, SL, SL, SL, HL, XX, XX, XX],
    /* - 4 */ [SH, SH, SP, SL, SL, XX, XX, XX, XX],
    /* - 5 */ [RI, RI, SP, SP, XX, XX, XX, XX, XX],
    /* - 6 */ [RI, RI, RI, XX, XX, XX, XX, XX, XX],
    /* - 7 */ [RI, RI, XX, XX, XX, XX, XX, XX, XX],
    /* - 8 */ [PK, XX, XX, XX, XX, XX, XX, XX, XX],
];

/// Ternary code of one direction from `up = tan(phi)` (largest elevation angle) and
/// `down = tan(psi)` (smallest), for the threshold with `sin t`, `cos t` (`0 <= t < 90°`).
///
/// Equivalent to comparing `atan(up) + atan(down)` with `±t`, without the two `atan`s:
/// with `S = atan(up) + atan(down)` in `(-180°, 180°)`, `sign(sin S) = sign(up + down)` and
/// `sin(S ∓ t) ∝ (up + down) cos t ∓ (1 - up·down) sin t`.
#[inline]
pub(super) fn ternary(up: f64, down: f64, sin_t: f64, cos_t: f64) -> i8 {
    let sum = up + down;
    let cos_part = 1.0 - up * down;
    if sum > 0.0 && sum * cos_t - cos_part * sin_t > 0.0 {
        1
    } else if sum < 0.0 && sum * cos_t + cos_part * sin_t < 0.0 {
        -1
    } else {
        0
    }
}

/// The landform index for `minus` / `plus` counts (`XX` if impossible).
pub(super) fn form(minus: usize, plus: usize) -> u8 {
    FORM_TABLE
        .get(minus)
        .and_then(|row| row.get(plus))
        .copied()
        .unwrap_or(XX)
}

/// Per-row scratch buffers (one value per column).
struct RowScratch {
    up: Vec<f64>,
    down: Vec<f64>,
    bad: Vec<bool>,
    plus: Vec<u8>,
    minus: Vec<u8>,
}

impl RowScratch {
    fn new(w: usize) -> Self {
        RowScratch {
            up: vec![0.0; w],
            down: vec![0.0; w],
            bad: vec![false; w],
            plus: vec![0; w],
            minus: vec![0; w],
        }
    }
}

/// Geomorphon class of every cell (`None` = not classified), row-major. Used by tests and
/// by [`class_fractions`]. Rows are independent, so they run in bands on every thread
/// natively (the same classes whatever the split). O(cells x radius).
pub(super) fn classify(
    g: &Grid,
    interior: &[bool],
    radius: usize,
    flat_deg: f64,
) -> Vec<Option<u8>> {
    let mut out = vec![None; g.w * g.h];
    let (w, h) = (g.w, g.h);
    if w < 3 || h < 3 {
        return out;
    }
    let view = View::new(g, radius, flat_deg);
    let rows_per_band = h.div_ceil(crate::parallel::bands(w, h)).max(1);
    crate::parallel::for_each_band(&mut out, rows_per_band * w, |k, band| {
        let mut s = RowScratch::new(w);
        for (dr, row) in band.chunks_mut(w).enumerate() {
            let r = k * rows_per_band + dr;
            if r > 0 && r + 1 < h {
                classify_row(g, interior, &view, r, &mut s, row);
            }
        }
    });
    out
}

/// [`classify`] row after row on one thread: the reference the bands are tested against.
#[cfg(test)]
pub(super) fn classify_serially(
    g: &Grid,
    interior: &[bool],
    radius: usize,
    flat_deg: f64,
) -> Vec<Option<u8>> {
    let (w, h) = (g.w, g.h);
    let mut out = vec![None; w * h];
    let view = View::new(g, radius, flat_deg);
    let mut s = RowScratch::new(w);
    for (r, row) in out.chunks_mut(w).enumerate().take(h - 1).skip(1) {
        classify_row(g, interior, &view, r, &mut s, row);
    }
    out
}

/// What every row's classification shares: the line length, the flatness threshold's sine
/// and cosine, and which rows hold NaN samples.
struct View {
    radius: usize,
    sin_cos: (f64, f64),
    row_has_nan: Vec<bool>,
}

impl View {
    fn new(g: &Grid, radius: usize, flat_deg: f64) -> Self {
        View {
            radius: radius.clamp(1, g.w.max(g.h)),
            sin_cos: flat_deg.to_radians().sin_cos(),
            row_has_nan: g
                .z
                .chunks_exact(g.w)
                .map(|row| row.iter().any(|v| v.is_nan()))
                .collect(),
        }
    }
}

/// The classes of row `r` (interior columns) into `out`, one row of the output.
fn classify_row(
    g: &Grid,
    interior: &[bool],
    view: &View,
    r: usize,
    s: &mut RowScratch,
    out: &mut [Option<u8>],
) {
    let w = g.w;
    let (sin_t, cos_t) = view.sin_cos;
    s.plus.fill(0);
    s.minus.fill(0);
    s.bad.fill(false);
    for &(dr, dc) in &DIRS8 {
        scan_direction(g, &view.row_has_nan, r, (dr, dc), view.radius, s);
        for c in 1..w - 1 {
            match ternary(s.up[c], s.down[c], sin_t, cos_t) {
                1 => s.plus[c] += 1,
                -1 => s.minus[c] += 1,
                _ => {}
            }
        }
    }
    for c in 1..w - 1 {
        if interior[r * w + c] && !s.bad[c] {
            let f = form(usize::from(s.minus[c]), usize::from(s.plus[c]));
            out[c] = (f != XX).then_some(f);
        }
    }
}

/// For row `r` and direction `(dr, dc)`: the max / min tangent of the elevation angle along
/// the line (up to `radius` steps, cut at the border) into `s.up` / `s.down`, and NaN samples
/// into `s.bad` (checked only on rows flagged in `row_has_nan`). Columns `1..w-1` only; row-wise so the inner loop runs over contiguous slices.
fn scan_direction(
    g: &Grid,
    row_has_nan: &[bool],
    r: usize,
    (dr, dc): (isize, isize),
    radius: usize,
    s: &mut RowScratch,
) {
    let w = g.w;
    s.up.fill(f64::NEG_INFINITY);
    s.down.fill(f64::INFINITY);
    let step = g.step_length(dr, dc);
    let center = &g.z[r * w..(r + 1) * w];
    for j in 1..=radius {
        let Some(rr) = r.checked_add_signed(dr * j as isize).filter(|&v| v < g.h) else {
            break;
        };
        // Columns c in [1, w-2] whose sample c + off lies in [0, w-1].
        let off = dc * j as isize;
        let c_lo = 1.max(-off) as usize;
        let c_hi = (w as isize - 2).min(w as isize - 1 - off);
        if c_hi < c_lo as isize {
            break;
        }
        let n = c_hi as usize - c_lo + 1;
        let src_start = (c_lo as isize + off) as usize;
        let src = &g.z[rr * w + src_start..rr * w + src_start + n];
        let ctr = &center[c_lo..c_lo + n];
        let up = &mut s.up[c_lo..c_lo + n];
        let down = &mut s.down[c_lo..c_lo + n];
        let bad = &mut s.bad[c_lo..c_lo + n];
        let inv = 1.0 / (j as f64 * step);
        if row_has_nan[rr] {
            for k in 0..n {
                bad[k] |= src[k].is_nan();
            }
        }
        // NaN differences fail both comparisons and leave `up` / `down` alone (a NaN centre
        // is never an interior cell; a NaN sample has just been flagged in `bad`).
        for k in 0..n {
            let t = (src[k] - ctr[k]) * inv;
            up[k] = if t > up[k] { t } else { up[k] };
            down[k] = if t < down[k] { t } else { down[k] };
        }
    }
}

/// Fractions of the 10 classes among the classified cells (all 0 when none is classified).
pub(super) fn class_fractions(
    g: &Grid,
    interior: &[bool],
    radius: usize,
    flat_deg: f64,
) -> [f64; 10] {
    let mut counts = [0usize; 10];
    for f in classify(g, interior, radius, flat_deg)
        .into_iter()
        .flatten()
    {
        if let Some(slot) = counts.get_mut(usize::from(f)) {
            *slot += 1;
        }
    }
    let total: usize = counts.iter().sum();
    let mut out = [0.0; 10];
    if total > 0 {
        for (o, &c) in out.iter_mut().zip(&counts) {
            *o = c as f64 / total as f64;
        }
    }
    out
}
