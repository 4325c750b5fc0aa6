//! The three grid operators of the multigrid solver, on one level each (CPU).
//!
//! The discrete operator is eq. 7 with zero flux at the border:
//! `(A u)_i = n_i u_i - sum_{j in N(i)} u_j`, where `N(i)` are the in-grid 4-neighbours and
//! `n_i = |N(i)|`. The solver finds `u` with `(A u)_i = b_i` on free cells and `u` given on
//! fixed cells. Neighbours are always visited left, right, up, down, as in the WGSL kernels.

use crate::diffusion::FixedMask;

use crate::parallel;

/// Copies of the rows just above and below a band (absent at the grid's border).
type Halo = (Option<Vec<f32>>, Option<Vec<f32>>);

/// One red-black Gauss-Seidel sweep: first the cells with even `x + y`, then the odd ones;
/// each free cell solves its own row of `A u = b`: `u_i = (b_i + sum u_j) / n_i`.
/// Within a colour the updates are independent, so the GPU gives the same result, and so do
/// any number of threads: natively, large levels are split into row bands relaxed in
/// parallel, each band reading copies of the two rows bordering it (the other colour, which
/// no thread writes during this half-sweep). O(cells).
pub fn relax_red_black(u: &mut [f32], b: Option<&[f32]>, fixed: &FixedMask, w: usize, h: usize) {
    let bands = parallel::bands(w, h);
    for colour in 0..2 {
        if bands <= 1 {
            relax_band(u, 0, None, None, b, fixed, (w, h), colour);
            continue;
        }
        let rows_per_band = h.div_ceil(bands);
        // Halo rows: the row above and below each band, copied before anything changes.
        let halos: Vec<Halo> = (0..h)
            .step_by(rows_per_band)
            .map(|y0| {
                let y1 = (y0 + rows_per_band).min(h);
                let above = (y0 > 0).then(|| u[(y0 - 1) * w..y0 * w].to_vec());
                let below = (y1 < h).then(|| u[y1 * w..(y1 + 1) * w].to_vec());
                (above, below)
            })
            .collect();
        parallel::for_each_band(u, rows_per_band * w, |k, band| {
            let (above, below) = &halos[k];
            relax_band(
                band,
                k * rows_per_band,
                above.as_deref(),
                below.as_deref(),
                b,
                fixed,
                (w, h),
                colour,
            );
        });
    }
}

/// One colour of a red-black half-sweep over `band`, the rows `y0..` of a `w` x `h` grid.
/// `above` / `below` are the rows just outside the band (absent at the grid's border).
#[allow(clippy::too_many_arguments)]
fn relax_band(
    band: &mut [f32],
    y0: usize,
    above: Option<&[f32]>,
    below: Option<&[f32]>,
    b: Option<&[f32]>,
    fixed: &FixedMask,
    (w, h): (usize, usize),
    colour: usize,
) {
    let rows = band.len() / w;
    for local in 0..rows {
        let y = y0 + local;
        let (before, rest) = band.split_at_mut(local * w);
        let (row, after) = rest.split_at_mut(w);
        let up = if local > 0 {
            Some(&before[(local - 1) * w..])
        } else {
            above
        };
        let down = if local + 1 < rows {
            Some(&after[..w])
        } else {
            below
        };
        let rhs = b.map(|b| &b[y * w..(y + 1) * w]);
        relax_row(row, up, down, rhs, fixed, y * w, (y + colour) & 1);
        debug_assert!(y < h);
    }
}

/// One colour of one row: the cells `first, first + 2, ...`. `up` / `down` are the rows
/// above and below (absent at the top and bottom border of the grid).
#[inline(always)]
fn relax_row(
    row: &mut [f32],
    up: Option<&[f32]>,
    down: Option<&[f32]>,
    rhs: Option<&[f32]>,
    fixed: &FixedMask,
    base: usize,
    first: usize,
) {
    let w = row.len();
    match (up, down) {
        (Some(up), Some(down)) if w >= 3 => {
            if first == 0 {
                relax_cell(row, Some(up), Some(down), rhs, fixed, base, 0);
            }
            relax_interior(row, up, down, rhs, fixed, base, first);
            if (w - 1) % 2 == first {
                relax_cell(row, Some(up), Some(down), rhs, fixed, base, w - 1);
            }
        }
        _ => {
            let mut x = first;
            while x < w {
                relax_cell(row, up, down, rhs, fixed, base, x);
                x += 2;
            }
        }
    }
}

/// The interior cells `1..w-1` of one colour of a row with both neighbour rows, in chunks of
/// 64: the neighbour mean of every cell of the chunk is computed at once (no stride, no
/// branch: the loop vectorises), then stored on the colour's free cells only, found from the
/// fixed bits of the chunk. The other colour's values, which these means read, do not change
/// during the half-sweep, so this is exactly the cell-by-cell update (same sums, same order).
#[inline(always)]
fn relax_interior(
    row: &mut [f32],
    up: &[f32],
    down: &[f32],
    rhs: Option<&[f32]>,
    fixed: &FixedMask,
    base: usize,
    first: usize,
) {
    const CHUNK: usize = 64;
    let w = row.len();
    let mut mean = [0.0f32; CHUNK];
    let mut x0 = 1;
    while x0 + 1 < w {
        let n = (w - 1 - x0).min(CHUNK);
        let (left, centre) = (&row[x0 - 1..x0 - 1 + n], &row[x0 + 1..x0 + 1 + n]);
        let (up, down) = (&up[x0..x0 + n], &down[x0..x0 + n]);
        match rhs {
            Some(r) => {
                let r = &r[x0..x0 + n];
                for k in 0..n {
                    // Same sum order as `relax_cell` (left, right, up, down), n = 4.
                    mean[k] = (r[k] + (((left[k] + centre[k]) + up[k]) + down[k])) * 0.25;
                }
            }
            None => {
                for k in 0..n {
                    mean[k] = (0.0 + (((left[k] + centre[k]) + up[k]) + down[k])) * 0.25;
                }
            }
        }
        // Store on the cells of this colour (k even when x0 has the colour's parity); the
        // fixed ones are put back.
        let start = usize::from(!(x0 + first).is_multiple_of(2));
        keeping_fixed(&mut row[x0..x0 + n], fixed, base + x0, |cells| {
            for k in (start..cells.len()).step_by(2) {
                cells[k] = mean[k];
            }
        });
        x0 += n;
    }
}

/// One cell with whatever neighbours it has (the general case at the grid's border).
#[inline(always)]
fn relax_cell(
    row: &mut [f32],
    up: Option<&[f32]>,
    down: Option<&[f32]>,
    rhs: Option<&[f32]>,
    fixed: &FixedMask,
    base: usize,
    x: usize,
) {
    if fixed.is_fixed_index(base + x) {
        return;
    }
    let w = row.len();
    let mut sum = 0.0f32;
    let mut count = 0.0f32;
    if x > 0 {
        sum += row[x - 1];
        count += 1.0;
    }
    if x + 1 < w {
        sum += row[x + 1];
        count += 1.0;
    }
    if let Some(up) = up {
        sum += up[x];
        count += 1.0;
    }
    if let Some(down) = down {
        sum += down[x];
        count += 1.0;
    }
    if count > 0.0 {
        row[x] = (rhs.map_or(0.0, |r| r[x]) + sum) / count;
    }
}

/// Residual `r_i = b_i - (A u)_i` of a free cell (0 for fixed cells).
#[inline(always)]
fn residual_at(
    u: &[f32],
    b: Option<&[f32]>,
    fixed: &FixedMask,
    w: usize,
    h: usize,
    x: usize,
    y: usize,
) -> f32 {
    let i = y * w + x;
    if fixed.is_fixed_index(i) {
        return 0.0;
    }
    b.map_or(0.0, |b| b[i]) + differences(u, w, h, x, y)
}

/// `sum_j (u_j - u_i)` over the in-grid neighbours (left, right, up, down), i.e. `-(A u)_i`.
///
/// Formed from differences rather than as `n u_i - sum u_j`: neighbouring heights are close,
/// so each difference is exact in floating point (Sterbenz), and the residual keeps full
/// relative precision even when it is a millionth of the heights. This is what lets the
/// `f32` solver (and the WGSL twin) converge to the solution's own rounding.
#[inline(always)]
fn differences(u: &[f32], w: usize, h: usize, x: usize, y: usize) -> f32 {
    let i = y * w + x;
    let c = u[i];
    let mut sum = 0.0f32;
    if x > 0 {
        sum += u[i - 1] - c;
    }
    if x + 1 < w {
        sum += u[i + 1] - c;
    }
    if y > 0 {
        sum += u[i - w] - c;
    }
    if y + 1 < h {
        sum += u[i + w] - c;
    }
    sum
}

/// The residuals of row `y` into `out` (`w` values; 0 on fixed cells), the same values as
/// [`residual_at`]. Interior rows are computed for every cell at once (the loop vectorises)
/// and the fixed cells, found from the mask's bits, zeroed afterwards.
fn row_residuals(
    u: &[f32],
    b: Option<&[f32]>,
    fixed: &FixedMask,
    (w, h): (usize, usize),
    y: usize,
    out: &mut [f32],
) {
    if y == 0 || y + 1 == h || w < 3 {
        for (x, r) in out.iter_mut().enumerate().take(w) {
            *r = residual_at(u, b, fixed, w, h, x, y);
        }
        return;
    }
    let base = y * w;
    let (left, centre, right) = (
        &u[base..base + w - 2],
        &u[base + 1..base + w - 1],
        &u[base + 2..base + w],
    );
    let (up, down) = (
        &u[base - w + 1..base - 1],
        &u[base + w + 1..base + 2 * w - 1],
    );
    let inner = &mut out[1..w - 1];
    // Same operation order as `differences`.
    match b {
        Some(b) => {
            let rhs = &b[base + 1..base + w - 1];
            for k in 0..w - 2 {
                let c = centre[k];
                inner[k] =
                    rhs[k] + ((((left[k] - c) + (right[k] - c)) + (up[k] - c)) + (down[k] - c));
            }
        }
        None => {
            for k in 0..w - 2 {
                let c = centre[k];
                inner[k] = 0.0 + ((((left[k] - c) + (right[k] - c)) + (up[k] - c)) + (down[k] - c));
            }
        }
    }
    out[0] = residual_at(u, b, fixed, w, h, 0, y);
    out[w - 1] = residual_at(u, b, fixed, w, h, w - 1, y);
    for x0 in (1..w - 1).step_by(64) {
        let n = (w - 1 - x0).min(64);
        let length = if n == 64 { u64::MAX } else { (1u64 << n) - 1 };
        let mut set = fixed.bits64(base + x0) & length;
        while set != 0 {
            out[x0 + set.trailing_zeros() as usize] = 0.0;
            set &= set - 1;
        }
    }
}

/// Number of in-grid neighbours of (`x`, `y`).
#[inline(always)]
fn neighbour_count(w: usize, h: usize, x: usize, y: usize) -> f32 {
    f32::from(u8::from(x > 0) + u8::from(x + 1 < w) + u8::from(y > 0) + u8::from(y + 1 < h))
}

/// The largest `|r_i| / n_i` over free cells: how far one Jacobi sweep would move a cell.
/// This is the solver's stopping quantity (in height units). O(cells).
pub fn max_scaled_residual(
    u: &[f32],
    b: Option<&[f32]>,
    fixed: &FixedMask,
    w: usize,
    h: usize,
) -> f32 {
    // Bands of rows on the available threads (natively), each its own maximum.
    let bands = parallel::bands(w, h);
    let rows_per_band = h.div_ceil(bands).max(1);
    let mut worst = vec![0.0f32; h.div_ceil(rows_per_band)];
    let items: Vec<(usize, &mut f32)> = worst.iter_mut().enumerate().collect();
    parallel::for_each_item(items, |(k, worst)| {
        let mut r = vec![0.0f32; w];
        for y in k * rows_per_band..((k + 1) * rows_per_band).min(h) {
            row_residuals(u, b, fixed, (w, h), y, &mut r);
            if y == 0 || y + 1 == h || w < 3 {
                for (x, r) in r.iter().enumerate() {
                    *worst = worst.max(r.abs() / neighbour_count(w, h, x, y));
                }
            } else {
                // Interior cells have 4 neighbours (the division by 4 is exact).
                let inner = r[1..w - 1].iter().fold(0.0f32, |m, r| m.max(r.abs()));
                *worst = worst
                    .max(inner / 4.0)
                    .max(r[0].abs() / neighbour_count(w, h, 0, y))
                    .max(r[w - 1].abs() / neighbour_count(w, h, w - 1, y));
            }
        }
    });
    worst.into_iter().fold(0.0, f32::max)
}

/// Restricts the residual of the fine level to the right-hand side of the coarse
/// correction equation: `b_c(I, J) = sum of r over the (up to) 2 x 2 children`.
///
/// The sum (not the mean) is right for the unscaled operator: with spacing `h`,
/// `A_h ~ -h^2 Laplacian`, and `A_2h ~ -4 h^2 Laplacian`, so the coarse right-hand side is
/// four times the children's mean. The residual is computed on the fly: no fine-size buffer.
pub fn restrict_residual(
    u: &[f32],
    b: Option<&[f32]>,
    fixed: &FixedMask,
    (w, h): (usize, usize),
    coarse: &mut [f32],
    (cw, _ch): (usize, usize),
) {
    // Row by row over the fine grid: each coarse cell accumulates its children in the order
    // (2y, 2x), (2y, 2x+1), (2y+1, 2x), (2y+1, 2x+1), as the WGSL kernel does.
    let rows_per_band = h.div_ceil(2).div_ceil(parallel::bands(w, h)).max(1);
    parallel::for_each_band(coarse, rows_per_band * cw, |k, band| {
        band.fill(0.0);
        let first_coarse_row = k * rows_per_band;
        let mut r = vec![0.0f32; w];
        for (local, row) in band.chunks_exact_mut(cw).enumerate() {
            let cy = first_coarse_row + local;
            for y in 2 * cy..(2 * cy + 2).min(h) {
                row_residuals(u, b, fixed, (w, h), y, &mut r);
                for (x, r) in r.iter().enumerate() {
                    row[x / 2] += r;
                }
            }
        }
    });
}

/// Coarse-grid coordinate and weights of a fine cell along one axis (cell-centred bilinear
/// interpolation): fine cell `2I` lies a quarter cell before coarse cell `I`, `2I + 1` a
/// quarter after. Returns (near, far, weight of far); clamped at the border (zero flux).
#[inline(always)]
fn axis(x: usize, coarse_len: usize) -> (usize, usize, f32) {
    let near = (x / 2).min(coarse_len - 1);
    let far = if x.is_multiple_of(2) {
        near.saturating_sub(1)
    } else {
        (near + 1).min(coarse_len - 1)
    };
    (near, far, 0.25)
}

/// `u += P e` on free fine cells, `P` the bilinear interpolation from the coarse level
/// (weights 9/16, 3/16, 3/16, 1/16). Fixed cells keep their values exactly.
pub fn prolong_add(
    u: &mut [f32],
    fixed: &FixedMask,
    (w, h): (usize, usize),
    e: &[f32],
    (cw, ch): (usize, usize),
) {
    prolong(u, fixed, (w, h), e, (cw, ch), |cell, value| *cell += value);
}

/// Bilinear interpolation of a coarse solution onto the free cells of the fine level
/// (the full-multigrid initial guess); fixed cells keep their own values.
pub fn prolong_replace(
    u: &mut [f32],
    fixed: &FixedMask,
    (w, h): (usize, usize),
    coarse: &[f32],
    (cw, ch): (usize, usize),
) {
    prolong(u, fixed, (w, h), coarse, (cw, ch), |cell, value| {
        *cell = value
    });
}

#[inline(always)]
fn prolong(
    u: &mut [f32],
    fixed: &FixedMask,
    (w, h): (usize, usize),
    coarse: &[f32],
    (cw, ch): (usize, usize),
    apply: impl Fn(&mut f32, f32) + Sync,
) {
    let rows_per_band = h.div_ceil(parallel::bands(w, h)).max(1);
    parallel::for_each_band(u, rows_per_band * w, |k, band| {
        for (local, row) in band.chunks_exact_mut(w).enumerate() {
            let y = k * rows_per_band + local;
            prolong_row(row, y, fixed, w, coarse, (cw, ch), &apply);
        }
    });
}

#[inline(always)]
fn prolong_row(
    row: &mut [f32],
    y: usize,
    fixed: &FixedMask,
    w: usize,
    coarse: &[f32],
    (cw, ch): (usize, usize),
    apply: &impl Fn(&mut f32, f32),
) {
    let (yn, yf, wy) = axis(y, ch);
    let near_row = &coarse[yn * cw..(yn + 1) * cw];
    let far_row = &coarse[yf * cw..(yf + 1) * cw];
    // A chunk of 64 cells at a time: the interpolation for every cell (no mask test in the
    // loop), then applied to all of them, with the few fixed cells put back exactly.
    const CHUNK: usize = 64;
    let mut values = [0.0f32; CHUNK];
    for x0 in (0..w).step_by(CHUNK) {
        let n = (w - x0).min(CHUNK);
        for (k, value) in values.iter_mut().enumerate().take(n) {
            let (xn, xf, wx) = axis(x0 + k, cw);
            let near = near_row[xn] * (1.0 - wx) + near_row[xf] * wx;
            let far = far_row[xn] * (1.0 - wx) + far_row[xf] * wx;
            *value = near * (1.0 - wy) + far * wy;
        }
        keeping_fixed(&mut row[x0..x0 + n], fixed, y * w + x0, |cells| {
            for (cell, &value) in cells.iter_mut().zip(&values) {
                apply(cell, value);
            }
        });
    }
}

/// Runs `write` on `cells` (at most 64, the grid cells from index `first`), then puts the
/// fixed ones back exactly as they were: the write loop needs no per-cell mask test.
#[inline(always)]
fn keeping_fixed(
    cells: &mut [f32],
    fixed: &FixedMask,
    first: usize,
    write: impl FnOnce(&mut [f32]),
) {
    let n = cells.len().min(64);
    let length = if n == 64 { u64::MAX } else { (1u64 << n) - 1 };
    let fixed_bits = fixed.bits64(first) & length;
    let mut kept = [0.0f32; 64];
    let mut set = fixed_bits;
    while set != 0 {
        let k = set.trailing_zeros() as usize;
        kept[k] = cells[k];
        set &= set - 1;
    }
    write(cells);
    let mut set = fixed_bits;
    while set != 0 {
        let k = set.trailing_zeros() as usize;
        cells[k] = kept[k];
        set &= set - 1;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn prolongation_reproduces_constants_and_linear_ramps_inside() {
        let (cw, ch) = (5, 4);
        let (w, h) = (10, 8);
        let fixed = FixedMask::new(w, h);
        let mut u = vec![0.0; w * h];
        prolong_add(&mut u, &fixed, (w, h), &vec![2.5; cw * ch], (cw, ch));
        assert!(u.iter().all(|&v| v == 2.5));
        // A coarse ramp in x (value = coarse centre position) interpolates to the fine
        // centres away from the clamped border.
        let ramp: Vec<f32> = (0..cw * ch).map(|i| (i % cw) as f32 * 2.0 + 0.5).collect();
        let mut v = vec![0.0; w * h];
        prolong_replace(&mut v, &fixed, (w, h), &ramp, (cw, ch));
        for x in 1..w - 1 {
            assert!(
                (v[3 * w + x] - x as f32).abs() < 1e-5,
                "x={x}: {}",
                v[3 * w + x]
            );
        }
    }

    #[test]
    fn banded_relaxation_gives_the_same_bits_as_serial() {
        // Large enough to be split into bands on a machine with several cores.
        let (w, h) = (301, 263);
        let mut fixed = FixedMask::new(w, h);
        let mut u: Vec<f32> = (0..w * h)
            .map(|i| ((i * 7919) % 1000) as f32 * 0.37)
            .collect();
        for i in (0..w * h).step_by(53) {
            fixed.fix(i % w, i / w);
        }
        let b: Vec<f32> = (0..w * h).map(|i| (i % 17) as f32 * 0.01).collect();
        let mut serial = u.clone();
        for _ in 0..3 {
            relax_red_black(&mut u, Some(&b), &fixed, w, h);
            for colour in 0..2 {
                relax_band(&mut serial, 0, None, None, Some(&b), &fixed, (w, h), colour);
            }
        }
        assert!(
            u.iter()
                .zip(&serial)
                .all(|(a, b)| a.to_bits() == b.to_bits())
        );
    }

    #[test]
    fn restriction_sums_children_and_ignores_fixed_ones() {
        let (w, h) = (3, 3);
        let mut fixed = FixedMask::new(w, h);
        fixed.fix(0, 0);
        let u = vec![0.0; 9];
        let b = vec![1.0; 9];
        let mut coarse = vec![0.0; 4];
        restrict_residual(&u, Some(&b), &fixed, (w, h), &mut coarse, (2, 2));
        // Children: (0,0) fixed, 3 free -> 3; right column 2; bottom row 2; corner 1.
        assert_eq!(coarse, vec![3.0, 2.0, 2.0, 1.0]);
    }
}
