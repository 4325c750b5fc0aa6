//! Seed 004's smooth subdivision (Sec. 3.1, eqs. 2-3): the CPU reference of what
//! `shaders/bspline.wgsl` evaluates in the 3D view's vertex stage.
//!
//! Eq. 2 computes a new sample `V_ij = S(Lambda, i, j)` from the 3 x 3 coarse samples
//! `Lambda` around it, and eq. 3 makes `S` a weighted sum `sum Lambda_lk M^ij_lk` with the
//! Catmull-Clark weights (the paper's refs. 12, 17). On a regular grid those weights are the
//! tensor products of the cubic B-spline's 1D rules `(1, 6, 1) / 8` (a vertex) and
//! `(1, 1) / 2` (an edge), so [`subdivide`] uses, per parity of the new sample:
//!
//! - vertex (even, even): `[1 6 1; 6 36 6; 1 6 1] / 64`,
//! - edge (odd, even) or (even, odd): `[1 6 1; 1 6 1] / 16` (transposed for the other),
//! - face (odd, odd): `[1 1; 1 1] / 4`.
//!
//! Repeated steps converge to the uniform bicubic B-spline surface whose control points are
//! the coarse samples; [`evaluate`] gives that limit directly at any point (16 control points,
//! the basis [`basis`]), which is what the shader does per vertex instead of running the
//! steps. The limit surface is C2.
//!
//! The B-spline approximates its control points (at a control point it is
//! `[1 4 1; 4 16 4; 1 4 1] / 36` of its neighbourhood), so taken on the raw samples it would
//! lower every peak and raise every pit of the field. The 3D view therefore solves first for
//! the control points whose limit surface passes through the samples ([`interpolating`],
//! cubic B-spline interpolation: a tridiagonal system per row, then per column). Then one
//! surface serves every level of detail: at and above the field's resolution (stride >= 1)
//! the vertices, which sit on samples, get exactly the samples, and below it (stride < 1) the
//! smooth surface between them. A chunk and its children share their common vertices with
//! the same heights, so no crack opens and nothing pops where the stride crosses 1 (see
//! `lod.rs`; the T-junctions between levels are the same as above the field's resolution
//! and the skirts hide them).
//!
//! The map's border: one ring of ghost control points outside the grid, each the linear
//! extrapolation of the two control points inside it (`c_-1 = 2 c_0 - c_1`). That makes the
//! surface pass through the border control points, gives zero second derivative across the
//! border (a natural spline) and keeps linear fields exact up to the border. Subdivision with
//! ghosts commutes with this rule, so [`subdivide`] and [`evaluate`] agree everywhere.
//!
//! Cost: [`interpolating`] O(cells); [`evaluate`] O(1); [`subdivide`] O(output cells).

/// A grid of control points with its ring of ghost points: `width x height` points covering
/// `[0, width - 1] x [0, height - 1]` in their own units, stored `(width + 2) x (height + 2)`.
#[derive(Clone, Debug, PartialEq)]
pub struct ControlNet {
    pub width: usize,
    pub height: usize,
    /// Row-major, ghosts included: point `(x, y)` (from -1) is at `(y + 1) (width + 2) + x + 1`.
    pub points: Vec<f32>,
}

impl ControlNet {
    /// The net of `points` (`width x height`, row-major) with ghosts by linear extrapolation.
    pub fn with_ghosts(points: &[f32], width: usize, height: usize) -> Self {
        let (w, h) = (width.max(1), height.max(1));
        let stride = w + 2;
        let mut out = vec![0.0f32; stride * (h + 2)];
        for y in 0..h {
            out[(y + 1) * stride + 1..(y + 1) * stride + 1 + w]
                .copy_from_slice(&points[y * w..(y + 1) * w]);
        }
        // The neighbour inside used for the extrapolation (none on a one-point axis).
        let (ix, iy) = (usize::from(w > 1), usize::from(h > 1));
        for y in 1..=h {
            let row = &mut out[y * stride..(y + 1) * stride];
            row[0] = 2.0 * row[1] - row[1 + ix];
            row[w + 1] = 2.0 * row[w] - row[w - ix];
        }
        // Rows above and below, ghost columns included (the corners extrapolate twice).
        for x in 0..stride {
            out[x] = 2.0 * out[stride + x] - out[(1 + iy) * stride + x];
            out[(h + 1) * stride + x] = 2.0 * out[h * stride + x] - out[(h - iy) * stride + x];
        }
        Self {
            width: w,
            height: h,
            points: out,
        }
    }

    /// Control point `(x, y)`, `-1 <= x <= width`, `-1 <= y <= height`.
    pub fn at(&self, x: isize, y: isize) -> f32 {
        self.points[(y + 1) as usize * (self.width + 2) + (x + 1) as usize]
    }

    /// The interior points (no ghosts), row-major.
    pub fn interior(&self) -> Vec<f32> {
        (0..self.height as isize)
            .flat_map(|y| (0..self.width as isize).map(move |x| (x, y)))
            .map(|(x, y)| self.at(x, y))
            .collect()
    }
}

/// One subdivision step (eqs. 2-3 with the masks above): the net of twice the resolution,
/// `(2 width - 1) x (2 height - 1)` points over the same domain, ghosts included (the new
/// ghosts are the edge and vertex points the masks give from the old ghosts).
pub fn subdivide(net: &ControlNet) -> ControlNet {
    let (w, h) = (net.width, net.height);
    let (nw, nh) = (2 * w - 1, 2 * h - 1);
    let stride = nw + 2;
    let mut points = vec![0.0f32; stride * (nh + 2)];
    // 1D rules: a new point at half-index k (-1..=2n-1) from the old points around k / 2.
    let weights = |k: isize| -> [(isize, f32); 3] {
        if k % 2 == 0 {
            let i = k / 2;
            [(i - 1, 1.0 / 8.0), (i, 6.0 / 8.0), (i + 1, 1.0 / 8.0)]
        } else {
            let i = (k - 1).div_euclid(2);
            [(i, 0.5), (i + 1, 0.5), (i, 0.0)]
        }
    };
    for ky in -1..=nh as isize {
        for kx in -1..=nw as isize {
            let mut v = 0.0f32;
            for (y, wy) in weights(ky) {
                for (x, wx) in weights(kx) {
                    if wx != 0.0 && wy != 0.0 {
                        v += wx * wy * net.at(x, y);
                    }
                }
            }
            points[(ky + 1) as usize * stride + (kx + 1) as usize] = v;
        }
    }
    ControlNet {
        width: nw,
        height: nh,
        points,
    }
}

/// The uniform cubic B-spline basis at `t` in `[0, 1]`: the weights of the control points
/// `i - 1, i, i + 1, i + 2` for a point `i + t`. They sum to 1 and are never negative.
pub fn basis(t: f32) -> [f32; 4] {
    let s = 1.0 - t;
    let (t2, t3) = (t * t, t * t * t);
    [
        s * s * s / 6.0,
        (3.0 * t3 - 6.0 * t2 + 4.0) / 6.0,
        (-3.0 * t3 + 3.0 * t2 + 3.0 * t + 1.0) / 6.0,
        t3 / 6.0,
    ]
}

/// The limit surface of the control points `points` (`width x height`, row-major, ghosts
/// implicit) at `(x, y)` (clamped to the grid): the same arithmetic, in the same order, as
/// `bspline_height` in `shaders/bspline.wgsl`.
pub fn evaluate(points: &[f32], width: usize, height: usize, x: f32, y: f32) -> f32 {
    let (w, h) = (width.max(1) as isize, height.max(1) as isize);
    let qx = x.clamp(0.0, (w - 1) as f32);
    let qy = y.clamp(0.0, (h - 1) as f32);
    let bx = qx.floor().clamp(0.0, (w - 2).max(0) as f32);
    let by = qy.floor().clamp(0.0, (h - 2).max(0) as f32);
    let (wx, wy) = (basis((qx - bx).min(1.0)), basis((qy - by).min(1.0)));
    let (ix, iy) = (bx as isize, by as isize);
    let at = |x: isize, y: isize| points[(y.clamp(0, h - 1) * w + x.clamp(0, w - 1)) as usize];
    let row = |y: isize| {
        let mut r = [at(ix - 1, y), at(ix, y), at(ix + 1, y), at(ix + 2, y)];
        if ix - 1 < 0 {
            r[0] = 2.0 * r[1] - r[2];
        }
        if ix + 2 > w - 1 {
            r[3] = 2.0 * r[2] - r[1];
        }
        r[0] * wx[0] + r[1] * wx[1] + r[2] * wx[2] + r[3] * wx[3]
    };
    let mut c = [row(iy - 1), row(iy), row(iy + 1), row(iy + 2)];
    if iy - 1 < 0 {
        c[0] = 2.0 * c[1] - c[2];
    }
    if iy + 2 > h - 1 {
        c[3] = 2.0 * c[2] - c[1];
    }
    c[0] * wy[0] + c[1] * wy[1] + c[2] * wy[2] + c[3] * wy[3]
}

/// The elimination factors of the interpolation system along an axis of `n` samples:
/// `c_0 = f_0`, `(c_(i-1) + 4 c_i + c_(i+1)) / 6 = f_i`, `c_(n-1) = f_(n-1)` (the surface
/// at a sample is `(1, 4, 1) / 6` of its control points; at the border the ghost rule
/// reduces it to the control point). Returns, per row of the system, the pivot and the
/// super-diagonal after elimination (Thomas algorithm; the system is diagonally dominant, so
/// it is stable without pivoting).
pub(super) fn thomas_factors(n: usize) -> (Vec<f64>, Vec<f64>) {
    let mut pivot = vec![1.0f64; n];
    let mut upper = vec![0.0f64; n];
    for i in 1..n.saturating_sub(1) {
        // Row i: 1/6, 4/6, 1/6; the previous row's upper is divided by its pivot already.
        pivot[i] = 4.0 / 6.0 - (1.0 / 6.0) * upper[i - 1];
        upper[i] = (1.0 / 6.0) / pivot[i];
    }
    (pivot, upper)
}

/// Solves the interpolation system in place along rows of `len` values `step` apart.
fn solve_line(values: &mut [f32], start: usize, step: usize, len: usize, f: &(Vec<f64>, Vec<f64>)) {
    let (pivot, upper) = f;
    if len < 3 {
        return; // The border rows are identities: the samples are their control points.
    }
    let mut rhs = vec![0.0f64; len];
    rhs[0] = f64::from(values[start]);
    for i in 1..len {
        let v = f64::from(values[start + i * step]);
        rhs[i] = if i == len - 1 {
            v
        } else {
            (v - (1.0 / 6.0) * rhs[i - 1]) / pivot[i]
        };
    }
    let mut next = rhs[len - 1];
    values[start + (len - 1) * step] = next as f32;
    for i in (0..len - 1).rev() {
        next = rhs[i] - upper[i] * next;
        values[start + i * step] = next as f32;
    }
}

/// Solves the rows `rows` of a `width`-wide grid in place (the first half of
/// [`interpolating`]).
pub fn interpolate_rows(values: &mut [f32], width: usize, rows: std::ops::Range<usize>) {
    let f = thomas_factors(width);
    for y in rows {
        solve_line(values, y * width, 1, width, &f);
    }
}

/// Columns solved per block: a block's rows are gathered into a `COLUMN_BLOCK`-wide copy
/// (64 KiB per 256 rows) so each column's solve walks a small, cached stride.
const COLUMN_BLOCK: usize = 64;

/// The columns `columns` of a `width x height` grid, solved on a copy gathered into a block
/// `columns.len()` wide, row-major.
fn solved_block(
    values: &[f32],
    width: usize,
    height: usize,
    columns: &std::ops::Range<usize>,
    f: &(Vec<f64>, Vec<f64>),
) -> Vec<f32> {
    let n = columns.len();
    let mut block = Vec::with_capacity(n * height);
    for row in values.chunks_exact(width).take(height) {
        block.extend_from_slice(&row[columns.clone()]);
    }
    for x in 0..n {
        solve_line(&mut block, x, n, height, f);
    }
    block
}

/// Writes a [`solved_block`] back into its columns.
fn scatter_block(
    values: &mut [f32],
    width: usize,
    columns: &std::ops::Range<usize>,
    block: &[f32],
) {
    for (row, solved) in values
        .chunks_exact_mut(width)
        .zip(block.chunks_exact(columns.len()))
    {
        row[columns.clone()].copy_from_slice(solved);
    }
}

/// Solves the columns `columns` of a `width x height` grid in place (the second half), in
/// blocks of [`COLUMN_BLOCK`] columns, one block per thread natively: each column gets the
/// same arithmetic as alone.
pub fn interpolate_columns(
    values: &mut [f32],
    width: usize,
    height: usize,
    columns: std::ops::Range<usize>,
) {
    let f = thomas_factors(height);
    let blocks: Vec<_> = columns
        .clone()
        .step_by(COLUMN_BLOCK)
        .map(|start| start..(start + COLUMN_BLOCK).min(columns.end))
        .collect();
    // One block per thread at a time, so the copies take threads x 64 columns of memory.
    for batch in blocks.chunks(crate::parallel::threads()) {
        let mut solved = vec![Vec::new(); batch.len()];
        let shared: &[f32] = values;
        crate::parallel::for_each_item(
            batch.iter().zip(solved.iter_mut()).collect(),
            |(columns, out)| *out = solved_block(shared, width, height, columns, &f),
        );
        for (columns, block) in batch.iter().zip(&solved) {
            scatter_block(values, width, columns, block);
        }
    }
}

/// The control points whose limit surface ([`evaluate`]) passes through `samples`
/// (`width x height`, row-major) at every sample: cubic B-spline interpolation, rows then
/// columns, each in bands or blocks on all threads natively (the same bits as one thread).
/// O(cells). Samples must be finite.
pub fn interpolating(samples: &[f32], width: usize, height: usize) -> Vec<f32> {
    let mut c = samples[..width * height].to_vec();
    let rows = height.div_ceil(crate::parallel::threads()).max(1);
    crate::parallel::for_each_band(&mut c, rows * width.max(1), |_, band| {
        interpolate_rows(band, width, 0..band.len() / width.max(1));
    });
    interpolate_columns(&mut c, width, height, 0..width);
    c
}

#[cfg(test)]
mod tests {
    use super::*;

    fn random_grid(w: usize, h: usize, seed: u32) -> Vec<f32> {
        (0..w * h)
            .map(|i| {
                let mut v = (i as u32 ^ seed.wrapping_mul(0x9e37_79b9)).wrapping_mul(2_654_435_761);
                v ^= v >> 15;
                v = v.wrapping_mul(2_246_822_519);
                v ^= v >> 13;
                (v & 0xffff) as f32 / 65535.0 * 2.0 - 1.0
            })
            .collect()
    }

    #[test]
    fn the_basis_is_a_partition_of_unity_and_matches_the_vertex_limit_mask() {
        for k in 0..=20 {
            let b = basis(k as f32 / 20.0);
            assert!((b.iter().sum::<f32>() - 1.0).abs() < 1e-6);
            assert!(b.iter().all(|&w| w >= 0.0));
        }
        let at_zero = basis(0.0);
        assert_eq!(at_zero.map(|w| (w * 6.0).round()), [1.0, 4.0, 1.0, 0.0]);
    }

    #[test]
    fn repeated_subdivision_converges_to_the_b_spline() {
        let (w, h) = (9, 7);
        let points = random_grid(w, h, 1);
        let mut net = ControlNet::with_ghosts(&points, w, h);
        let mut errors = Vec::new();
        for step in 1..=7 {
            net = subdivide(&net);
            let scale = (1usize << step) as f32;
            let mut worst = 0.0f32;
            let mut worst_limit_mask = 0.0f32;
            for y in 0..net.height as isize {
                for x in 0..net.width as isize {
                    let (px, py) = (x as f32 / scale, y as f32 / scale);
                    let limit = evaluate(&points, w, h, px, py);
                    worst = worst.max((net.at(x, y) - limit).abs());
                    // A net point's own limit: the vertex limit mask of its neighbourhood.
                    let mut m = 0.0;
                    for (dy, wy) in [(-1, 1.0), (0, 4.0), (1, 1.0)] {
                        for (dx, wx) in [(-1, 1.0), (0, 4.0), (1, 1.0)] {
                            m += wx * wy * net.at(x + dx, y + dy) / 36.0;
                        }
                    }
                    worst_limit_mask = worst_limit_mask.max((m - limit).abs());
                }
            }
            assert!(worst_limit_mask < 2e-5, "step {step}: {worst_limit_mask}");
            errors.push(worst);
        }
        // Each step divides the distance to the limit by about 4 (second differences).
        for pair in errors.windows(2) {
            assert!(pair[1] < 0.4 * pair[0], "{errors:?}");
        }
        assert!(errors[6] < 5e-4, "{errors:?}");
    }

    #[test]
    fn linear_fields_are_reproduced_exactly_up_to_the_border() {
        let (w, h) = (11, 6);
        let f = |x: f32, y: f32| 3.0 + 0.5 * x - 1.25 * y;
        let points: Vec<f32> = (0..w * h)
            .map(|i| f((i % w) as f32, (i / w) as f32))
            .collect();
        for k in 0..=60 {
            let (x, y) = (
                k as f32 * (w - 1) as f32 / 60.0,
                (k * 7 % 61) as f32 * (h - 1) as f32 / 60.0,
            );
            assert!((evaluate(&points, w, h, x, y) - f(x, y)).abs() < 1e-5);
        }
        // The interpolating control points of a linear field are the field itself.
        let c = interpolating(&points, w, h);
        for (a, b) in c.iter().zip(&points) {
            assert!((a - b).abs() < 1e-5);
        }
    }

    #[test]
    fn quadratics_are_shifted_by_a_sixth_of_their_curvature_and_interpolated_exactly() {
        // Away from the border (the ghosts are linear), control points on a quadratic give
        // the same quadratic raised by f'' / 6: the B-spline approximates, it does not
        // interpolate. The interpolating control points give the quadratic itself.
        let (w, h) = (41, 41);
        let f = |x: f32, y: f32| 0.02 * (x - 20.0) * (x - 20.0) - 0.01 * (y - 17.0) * (y - 17.0);
        let samples: Vec<f32> = (0..w * h)
            .map(|i| f((i % w) as f32, (i / w) as f32))
            .collect();
        let shift = (0.04 - 0.02) / 6.0;
        let c = interpolating(&samples, w, h);
        for k in 0..40 {
            let (x, y) = (15.0 + k as f32 * 0.27, 14.0 + k as f32 * 0.31);
            let approx = evaluate(&samples, w, h, x, y);
            assert!(
                (approx - f(x, y) - shift).abs() < 1e-4,
                "{x} {y}: {approx} vs {}",
                f(x, y)
            );
            let interp = evaluate(&c, w, h, x, y);
            assert!(
                (interp - f(x, y)).abs() < 1e-4,
                "{x} {y}: {interp} vs {}",
                f(x, y)
            );
        }
    }

    #[test]
    fn blocked_and_banded_solves_give_the_bits_of_one_line_at_a_time() {
        // Several column blocks and a partial one, several row bands; a thin grid too.
        for (w, h, seed) in [(150, 97, 3), (3, 200, 4), (200, 3, 5), (64, 64, 6)] {
            let samples = random_grid(w, h, seed);
            let mut serial = samples.clone();
            let f = thomas_factors(w);
            for y in 0..h {
                solve_line(&mut serial, y * w, 1, w, &f);
            }
            let f = thomas_factors(h);
            for x in 0..w {
                solve_line(&mut serial, x, w, h, &f);
            }
            let bits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
            assert_eq!(
                bits(&interpolating(&samples, w, h)),
                bits(&serial),
                "{w} x {h}"
            );
            // The page's steps: rows, then columns in runs of 100.
            let mut stepped = samples.clone();
            interpolate_rows(&mut stepped, w, 0..h);
            for start in (0..w).step_by(100) {
                interpolate_columns(&mut stepped, w, h, start..(start + 100).min(w));
            }
            assert_eq!(bits(&stepped), bits(&serial), "{w} x {h} in steps");
        }
    }

    #[test]
    fn interpolating_control_points_honour_every_sample() {
        for (w, h) in [(1, 1), (2, 3), (17, 9), (64, 33)] {
            let samples = random_grid(w, h, 7);
            let c = interpolating(&samples, w, h);
            for y in 0..h {
                for x in 0..w {
                    let v = evaluate(&c, w, h, x as f32, y as f32);
                    assert!(
                        (v - samples[y * w + x]).abs() < 1e-4,
                        "{w}x{h} ({x}, {y}): {v}"
                    );
                }
            }
        }
    }

    #[test]
    fn the_ghost_net_matches_the_implicit_ghosts() {
        let (w, h) = (5, 4);
        let points = random_grid(w, h, 3);
        let net = ControlNet::with_ghosts(&points, w, h);
        assert_eq!(net.interior(), points);
        assert!((net.at(-1, 2) - (2.0 * net.at(0, 2) - net.at(1, 2))).abs() < 1e-6);
        assert!((net.at(5, 3) - (2.0 * net.at(4, 3) - net.at(3, 3))).abs() < 1e-6);
        assert!((net.at(-1, -1) - (2.0 * net.at(-1, 0) - net.at(-1, 1))).abs() < 1e-6);
        // The limit of the net at its points equals the direct evaluation.
        let v = evaluate(&points, w, h, 0.0, 0.0);
        let mut m = 0.0;
        for (dy, wy) in [(-1, 1.0), (0, 4.0), (1, 1.0)] {
            for (dx, wx) in [(-1, 1.0), (0, 4.0), (1, 1.0)] {
                m += wx * wy * net.at(dx, dy) / 36.0;
            }
        }
        assert!((v - m).abs() < 1e-5);
    }
}
