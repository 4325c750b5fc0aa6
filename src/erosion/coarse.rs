//! Maps larger than the solver's grid, coarse to fine: the design reduced to a grid of
//! blocks, eroded there, brought back to full resolution and refined there by one more step
//! of the same law (see [`refine`]).

use std::ops::Range;

use super::ErosionSettings;
use super::stage::{
    Anchors, FINISHING, FLOOR_CELLS, PREPARING, Prepared, Solved, StageError, floor_near_rivers,
    in_bands, in_row_bands, nearest_channel_in_steps, ranges_of, rock_and_strength_in_bands,
    roughen_from, run_solver, solve, uplift_map,
};
use crate::compute::Backend;
use crate::heightfield::Heightfield;
use crate::jobs::{Cancelled, JobCtx};
use crate::skeleton::CellKind;

/// The largest grid the solver runs on: larger maps are eroded on a grid of whole blocks of
/// cells (at most this many per side), brought back and refined at full resolution.
/// Stream-power erosion with hillslope diffusion has a physical length scale (the valley
/// spacing set by kappa / K, a few cells at the presets' resolution of 10-20 m), so the whole
/// run on a 10 km map at 2.5 m cells would cost 16 times as much for valleys the coarse grid
/// already resolves; the refinement adds the small ones.
pub const MAX_SOLVER_SIDE: usize = 1024;

/// The design of a large map reduced to the solver's grid by blocks of `f` x `f` cells: the
/// mean height of each block, and a block is a channel where any of its cells is (holding
/// the lowest channel height of the block, so rivers still fall towards their mouths): a
/// river where one of its cells is a held river, else a valley, else a grown branch.
/// O(cells), in bands of block rows with the job's ticks between them.
async fn reduce(
    field: &Heightfield,
    kinds: &[CellKind],
    f: usize,
    ctx: &JobCtx,
) -> Result<(Heightfield, Vec<CellKind>), Cancelled> {
    let n = field.width();
    let m = n.div_ceil(f);
    let z = field.data();
    let mut heights = vec![0.0f32; m * m];
    let mut coarse = vec![CellKind::Free; m * m];
    in_bands(ctx, PREPARING, m, n * f, |block_rows| {
        reduce_blocks(z, kinds, n, f, block_rows, &mut heights, &mut coarse);
    })
    .await?;
    let reduced = Heightfield::from_vec(m, m, heights).unwrap_or_else(|_| field.clone());
    Ok((reduced, coarse))
}

/// The blocks of the block rows `block_rows` of [`reduce`] (an `n` x `n` map `z`).
fn reduce_blocks(
    z: &[f32],
    kinds: &[CellKind],
    n: usize,
    f: usize,
    block_rows: Range<usize>,
    heights: &mut [f32],
    coarse: &mut [CellKind],
) {
    let m = n.div_ceil(f);
    for by in block_rows {
        for bx in 0..m {
            let (mut sum, mut count, mut channel) = (0.0f64, 0usize, f32::INFINITY);
            let mut kind = CellKind::Free;
            for y in by * f..((by + 1) * f).min(n) {
                for x in bx * f..((bx + 1) * f).min(n) {
                    let i = y * n + x;
                    sum += f64::from(z[i]);
                    count += 1;
                    let rank = |k: CellKind| match k {
                        CellKind::River => 3,
                        CellKind::Valley => 2,
                        CellKind::Grown => 1,
                        _ => 0,
                    };
                    if rank(kinds[i]) > 0 {
                        channel = channel.min(z[i]);
                        if rank(kinds[i]) > rank(kind) {
                            kind = kinds[i];
                        }
                    }
                }
            }
            let b = by * m + bx;
            coarse[b] = kind;
            heights[b] = if kind == CellKind::Free {
                (sum / count.max(1) as f64) as f32
            } else {
                channel
            };
        }
    }
}

/// Catmull-Rom (cubic convolution, a = -1/2; Keys 1981, "Cubic convolution interpolation
/// for digital image processing", IEEE TASSP 29) of a coarse `m` x `m` grid (cell centres of
/// blocks of `f` cells) at the centres of the `n` x `n` fine cells, separably: each coarse
/// row across the fine columns once, then each fine row from four of those. Beyond the
/// edge the samples are the odd reflection about the edge cell (`2 c_0 - c_k`), so linear
/// ramps stay linear to the map's border. Bilinear interpolation left every fine cell inside
/// a coarse cell on a bilinear patch, which is harmonic (`a + bx + cy + dxy`), with creases
/// along the coarse grid's lines: on a 4096^2 map from a 1024^2 run, a quarter of the cells,
/// in a pattern of the coarse grid. The cubic keeps the coarse surface's curvature inside the
/// coarse cells and its slope across their edges. O(cells x 4 + m x n x 4), in bands of rows
/// with the job's ticks between them.
async fn expand(
    coarse: &[f32],
    m: usize,
    f: usize,
    n: usize,
    ctx: &JobCtx,
) -> Result<Vec<f32>, Cancelled> {
    let taps = cubic_taps(m, f, n);
    // The coarse rows interpolated across the fine columns (`m` rows of `n`).
    let mut across = vec![0.0f32; m * n];
    in_row_bands(ctx, FINISHING, &mut across, n, |rows, part| {
        for (y, row) in rows.zip(part.chunks_mut(n)) {
            let line = &coarse[y * m..(y + 1) * m];
            for (v, tap) in row.iter_mut().zip(&taps) {
                *v = tap.apply(|k| line[k]);
            }
        }
    })
    .await?;
    let mut out = vec![0.0f32; n * n];
    in_row_bands(ctx, FINISHING, &mut out, n, |rows, part| {
        for (y, row) in rows.zip(part.chunks_mut(n)) {
            let tap = &taps[y];
            for (x, v) in row.iter_mut().enumerate() {
                *v = tap.apply(|k| across[k * n + x]);
            }
        }
    })
    .await?;
    Ok(out)
}

/// Where a fine index falls among the coarse samples: the four samples and their cubic
/// weights.
struct Tap {
    samples: [Sample; 4],
    weights: [f32; 4],
}

/// One sample of a tap: a coarse index, or the odd reflection of `mirror` about `edge`.
#[derive(Clone, Copy)]
enum Sample {
    At(usize),
    Reflected { edge: usize, mirror: usize },
}

impl Tap {
    /// The interpolated value, `at(k)` reading coarse sample `k`.
    fn apply(&self, at: impl Fn(usize) -> f32) -> f32 {
        self.samples
            .iter()
            .zip(&self.weights)
            .map(|(s, w)| {
                w * match *s {
                    Sample::At(k) => at(k),
                    Sample::Reflected { edge, mirror } => 2.0 * at(edge) - at(mirror),
                }
            })
            .sum()
    }
}

/// The taps of the `n` fine centres over `m` coarse ones, `f` fine cells a coarse one.
fn cubic_taps(m: usize, f: usize, n: usize) -> Vec<Tap> {
    let last = m as isize - 1;
    let clamp = |v: isize| v.clamp(0, last) as usize;
    let sample = |k: isize| {
        if k < 0 {
            Sample::Reflected {
                edge: 0,
                mirror: clamp(-k),
            }
        } else if k > last {
            Sample::Reflected {
                edge: last as usize,
                mirror: clamp(2 * last - k),
            }
        } else {
            Sample::At(k as usize)
        }
    };
    (0..n)
        .map(|i| {
            let p = (i as f32 + 0.5) / f as f32 - 0.5;
            let below = p.floor() as isize;
            Tap {
                samples: std::array::from_fn(|j| sample(below - 1 + j as isize)),
                weights: catmull_rom(p - p.floor()),
            }
        })
        .collect()
}

/// The Catmull-Rom weights of the samples at -1, 0, 1 and 2 for a point `t` in [0, 1) past
/// sample 0; they sum to 1 and reproduce linear ramps.
fn catmull_rom(t: f32) -> [f32; 4] {
    let (t2, t3) = (t * t, t * t * t);
    [
        0.5 * (-t3 + 2.0 * t2 - t),
        0.5 * (3.0 * t3 - 5.0 * t2 + 2.0),
        0.5 * (-3.0 * t3 + 4.0 * t2 + t),
        0.5 * (t3 - t2),
    ]
}

/// Erodes the `n` x `n` `field` (cells `cell_m` wide, `base` its base level at full
/// resolution) on a grid of `factor` x `factor` blocks, then brings the result back to full
/// resolution: interpolated heights, river and bank cells at their designed heights, the
/// near-river floor ([`FLOOR_CELLS`] coarse cells) at full resolution, and [`refine`]s it.
#[allow(clippy::too_many_arguments)]
pub(super) async fn erode_coarse_to_fine(
    field: &Heightfield,
    kinds: &[CellKind],
    anchors: Anchors<'_>,
    mut base: Vec<bool>,
    settings: &ErosionSettings,
    cell_m: f64,
    seed: u64,
    factor: usize,
    backend: &Backend,
    ctx: &JobCtx,
) -> Result<Solved, StageError> {
    let n = field.width();
    let (coarse, coarse_kinds) = reduce(field, kinds, factor, ctx).await?;
    let m = coarse.width();
    let coarse_cell_m = cell_m * factor as f64;
    let coarse_held = super::hold::coarsen(anchors.held, n, factor, m);
    let coarse_mouths = super::hold::coarsen(anchors.mouths, n, factor, m);
    let coarse_anchors = Anchors {
        held: &coarse_held,
        mouths: &coarse_mouths,
        // The kinds already tell the grown branches.
        trunk: &[],
        order: &[],
        painted: anchors.painted,
        heights: &[],
        // The floors are cut at full resolution, before the coarse run.
        belt: &[],
    };
    let coarse_run = solve(
        &coarse,
        &coarse_kinds,
        coarse_anchors,
        settings,
        coarse_cell_m,
        seed,
        backend,
        ctx,
    )
    .await?;
    let eroded = coarse_run.heights;
    ctx.tick(FINISHING.0, FINISHING.1).await?;
    let up = expand(&eroded, m, factor, n, ctx).await?;
    // The floor only needs the cells near a river (the walk's fields go before the
    // refinement allocates its own).
    let (floor, uplift) = {
        let near = nearest_channel_in_steps(field, kinds, ctx, FINISHING).await?;
        ctx.tick(FINISHING.0, FINISHING.1).await?;
        let mut floor = floor_near_rivers(&near, FLOOR_CELLS * factor as f32);
        super::hold::pin(&mut floor, field.data(), anchors.held);
        // The coarse run's uplift at full resolution: its ranges (positions in metres) and
        // the painted uplift resampled to the full grid.
        let rate = settings.uplift_m_per_kyr / 1000.0;
        let mut uplift = uplift_map(field, kinds, &near.base, rate);
        let ranges = ranges_of(settings, (n, cell_m, seed), &near, anchors.held);
        in_row_bands(ctx, FINISHING, &mut uplift, n, |rows, part| {
            ranges.raise(rows.start, part);
        })
        .await?;
        anchors.painted.raise(&mut uplift, n);
        (floor, uplift)
    };
    let mut heights = field.data().to_vec();
    in_row_bands(ctx, FINISHING, &mut heights, n, |rows, part| {
        let cells = rows.start * n..rows.end * n;
        for (i, h) in cells.zip(part) {
            if !base[i] {
                *h = up[i].max(floor[i]);
            }
        }
    })
    .await?;
    drop(up);
    open_blocks(
        &coarse_run.outlets,
        (&eroded, m, factor),
        n,
        &mut base,
        &mut heights,
    );
    let guide = super::guide::guided_receivers_in(field.data(), kinds, n, ctx).await?;
    let (mut rock, strength) = rock_and_strength_in_bands(settings, n, cell_m, seed, ctx).await?;
    anchors.painted.harden(&mut rock, n);
    let fine = Refinement {
        guide,
        heights,
        base,
        floor,
        uplift,
        fill_on_gpu: anchors.mouths.is_empty(),
        // The coarse run's rock, at full resolution (positions in metres: the same patches;
        // the painted hard rock resampled to the full grid), and its strength with the
        // octaves the full grid resolves.
        erodibility: rock,
        strength,
    };
    refine(
        fine,
        n,
        (cell_m, coarse_cell_m),
        settings,
        crate::terrain::stage_seed(seed, "refinement"),
        backend,
        ctx,
    )
    .await
}

/// The coarse run's border outlets (cells of an `m` x `m` grid of `factor` x `factor`
/// blocks, [`super::outlets`]) at full resolution: the border cells of their blocks become
/// base level, held at their block's height in the coarse run (`eroded`, the outlet's own), so
/// the valleys the coarse run cut to them still leave the map. O(n).
fn open_blocks(
    outlets: &[usize],
    (eroded, m, factor): (&[f32], usize, usize),
    n: usize,
    base: &mut [bool],
    heights: &mut [f32],
) {
    for &block in outlets {
        let (bx, by) = (block % m, block / m);
        let xs = bx * factor..((bx + 1) * factor).min(n);
        let ys = by * factor..((by + 1) * factor).min(n);
        for y in ys {
            for x in xs.clone() {
                if x == 0 || y == 0 || x == n - 1 || y == n - 1 {
                    base[y * n + x] = true;
                    heights[y * n + x] = eroded[block];
                }
            }
        }
    }
}

/// A map eroded on a coarser grid and brought back to full resolution: the interpolated
/// heights (river and bank cells at their designed heights), the base level, the
/// near-river floor and the rock's erodibility factors, all at full resolution.
struct Refinement {
    heights: Vec<f32>,
    base: Vec<bool>,
    floor: Vec<f32>,
    /// The rock's uplift rate at each cell, m/yr (the coarse run's).
    uplift: Vec<f32>,
    erodibility: Vec<f32>,
    /// The rock's strength factors on the talus slope (empty: none).
    strength: Vec<f32>,
    /// Whether the GPU may fill the step's pits from the border (no river mouth inside).
    fill_on_gpu: bool,
    /// The grown branches' guided receivers at full resolution (empty: none).
    guide: Vec<u8>,
}

/// The refinement at full resolution of a map eroded on a coarser grid: one more step of
/// the same law, as long as one step of the coarse run (`years / steps`), with its uplift
/// (without it the step's incision, unbalanced, lowered the default scene's 10 km map, its
/// uplift alike everywhere, by 66 m on average at 2048^2: relief 626 m against 703 m at
/// 1024^2, now 722 m, and its heights correlated at 0.935 with the 1024^2 map's, now 0.948)
/// and hillslope creep reaching as many
/// cells as in a coarse step (`kappa` times `(cell / coarse cell)^2`; as the run's last
/// step, half a step of it, see `diffusion::Creep`: it smooths the
/// roughening below the coarse cell; at full strength one long implicit step relaxed the
/// fine grid towards a harmonic surface, 9% of the default scene's cells at 2048^2 and 28%
/// at 4096^2, 4.0% and 6.2% with it), on the interpolated
/// heights roughened at the full grid's scale. Interpolation alone leaves no channel finer
/// than a coarse cell (and the design's 1-cell river lines standing as levees); the step
/// cuts the small valleys the finer grid resolves and routes the water at full resolution
/// (its drainage area is the stage's layer). This is
/// the coarse-to-fine use of a landscape-evolution model (a coarse run for the large
/// valleys, a short run at the target resolution for the small ones); Braun & Willett's
/// scheme is implicit, so one long step is stable. O(cells), on the coarse run's backend.
async fn refine(
    fine: Refinement,
    n: usize,
    (cell_m, coarse_cell_m): (f64, f64),
    settings: &ErosionSettings,
    seed: u64,
    backend: &Backend,
    ctx: &JobCtx,
) -> Result<Solved, StageError> {
    let Refinement {
        mut heights,
        base,
        floor,
        uplift,
        erodibility,
        strength,
        fill_on_gpu,
        guide,
    } = fine;
    let roughness_m = settings.roughness_m * cell_m / coarse_cell_m;
    in_row_bands(ctx, FINISHING, &mut heights, n, |rows, h| {
        let cells = rows.start * n..rows.end * n;
        roughen_from(h, &base[cells.clone()], roughness_m, seed, cells.start);
    })
    .await?;
    // The pits the roughening left that are one cell alone, raised at once (the routing's
    // lakes would raise them one by one, spilling into each other).
    let grid = super::grid::Grid {
        width: n,
        height: n,
        cell: cell_m,
    };
    let mut lone = Vec::new();
    in_bands(ctx, FINISHING, n, n, |rows| {
        lone.extend(super::fill::lone_pits(grid, &heights, &base, &guide, rows));
    })
    .await?;
    for (i, raised) in lone {
        heights[i as usize] = raised;
    }
    let mut params = settings.params();
    params.years /= f64::from(params.steps.max(1));
    params.steps = 1;
    // Creep as far in cells as in a coarse step: a coarse step's creep at the fine grid
    // (`kappa dt / cell^2` of 80 at 4096^2) relaxes the surface towards a harmonic one,
    // wiping out what the step cuts.
    params.diffusivity *= (cell_m / coarse_cell_m).powi(2);
    let prepared = Prepared {
        heights,
        base,
        uplift,
        floor,
        seed,
        erodibility,
        strata: settings.strata(),
        strength,
        guide,
        // The coarse run's outlets are in `base` already.
        outlets: Vec::new(),
    };
    run_solver(prepared, n, cell_m, params, fill_on_gpu, backend, ctx).await
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Blocks reduce to their mean (channels to their lowest channel cell) and a change
    /// interpolated back reproduces a linear ramp exactly inside the map.
    #[test]
    fn reduce_and_expand_keep_channels_and_linear_changes() {
        let n = 12;
        let f = 3;
        let data: Vec<f32> = (0..n * n).map(|i| (i % n) as f32).collect();
        let field = Heightfield::from_vec(n, n, data).unwrap();
        let mut kinds = vec![CellKind::Free; n * n];
        kinds[n + 1] = CellKind::River; // block (0, 0), height 1
        kinds[2] = CellKind::River; // block (0, 0), height 2
        let ctx = JobCtx::detached();
        let (coarse, coarse_kinds) = pollster::block_on(reduce(&field, &kinds, f, &ctx)).unwrap();
        assert_eq!(coarse.width(), 4);
        assert_eq!(coarse_kinds[0], CellKind::River);
        assert_eq!(coarse.data()[0], 1.0, "the lowest channel cell");
        // Block (1, 0) holds columns 3..6: mean 4.
        assert_eq!(coarse.data()[1], 4.0);
        assert_eq!(coarse_kinds[1], CellKind::Free);
        // A linear change in x on the coarse grid (block centres at 1, 4, 7, 10) comes back
        // as the same line at every fine cell, to the map's edge.
        let ramp: Vec<f32> = (0..16).map(|i| (1 + 3 * (i % 4)) as f32).collect();
        let fine = pollster::block_on(expand(&ramp, 4, f, n, &ctx)).unwrap();
        for y in 0..n {
            for x in 0..n {
                assert!(
                    (fine[y * n + x] - x as f32).abs() < 1e-5,
                    "{x}: {}",
                    fine[y * n + x]
                );
            }
        }
    }
}
