//! The design holds: the sketch's peaks and ridges stand where they were drawn, at the
//! heights asked for, after the erosion.
//!
//! The solver sets relief by uplift against incision and creep, so a sketched peak left to it
//! is worn to what the uplift around it sustains (a 1200 m peak stood at 150-355 m on a 10 km
//! map). Two things hold it:
//!
//! - during the solve, the held cells ([`crate::skeleton::Skeleton::held`]) have their design
//!   height as a floor ([`pin`]; the solver's floor, applied after every step), so they stand
//!   as divides the whole time and the drainage organises around them rather than across
//!   them;
//! - after it, the flanks are raised to them by a smooth correction under the eroded texture,
//!   in the manner of a residual correction (the eroded surface keeps every valley and gully;
//!   the large scale follows the design):
//!
//! 1. the residual `r = design - eroded` at each held cell, the eroded height being the
//!    highest of its free neighbours within two cells (the flank beside it; the cell itself is
//!    pinned), so that no neighbour rises above it;
//! 2. `r` spread over the map as the harmonic function with those values (`lap r = 0`
//!    elsewhere, the edges free), so it varies smoothly between peaks and ridges of different
//!    residuals (the diffusion stage's multigrid on the CPU, exact to its tolerance);
//! 3. the correction `c = r * d_b / (d_a + d_b)`, with `d_a` the distance to the nearest held
//!    cell and `d_b` that to base level (the rivers and their floors) or the map's edge,
//!    chamfer distances (5 x 5 mask, Borgefors 1986): the whole residual beside the held
//!    cells, none on the rivers and the edge, and a straight flank between them, so the drawn
//!    rivers keep their heights and land beyond a ridge still drains along the edge;
//! 4. `c` carried upstream: no cell is lifted less than the cell it drains to on the eroded
//!    surface, so every drop of that surface is kept and no valley that ran towards a ridge
//!    is dammed into a lake (the land behind it rises with it);
//! 5. the eroded surface plus `c` (the held cells keep their pinned heights), held to the
//!    threshold slope (`slope_limit.rs`) from base level, so no flank the correction steepens
//!    stands above the talus angle: a height the angle cannot carry from the nearest river is
//!    lowered to what it can.
//!
//! The stage then fills what depressions the correction left and measures the drainage, as
//! after every solve. O(cells) for the distances and the correction, the multigrid's
//! O(cells) per cycle for the spread; nothing runs when the scene has no sketch.

use super::slope_limit::Mask;
use super::stage::StageError;
use crate::diffusion::multigrid::{self, MultigridParams};
use crate::diffusion::{Constraints, FixedMask};
use crate::heightfield::Heightfield;
use crate::jobs::JobCtx;

/// Most scan pairs of the threshold-slope limit after the correction (each pair carries a
/// cut across the map; more are needed only where base level bends the paths).
const LIMIT_PASSES: usize = 8;

/// How far the held cells ended from their design, measured after the correction.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Held {
    /// Held cells (the sketch's ridges and peaks off base level).
    pub cells: usize,
    /// Mean of `|design - result|` over them, metres.
    pub mean_error_m: f64,
    /// Largest `design - result` over them (lowered by the talus limit), metres.
    pub max_below_m: f64,
}

/// The job's message while the design is held.
const HOLDING: &str = "eroding: holding the drawn peaks and ridges";

/// Adds to `eroded` (`n` x `n`) the correction that brings the `held`
/// cells back to their `design` heights (module docs); `base` cells keep their heights and the
/// result's slopes stay within `limit` where it is set (the talus angle varied by the rock's
/// strength, as the solver held them: a plain angle left planar fans round a held peak).
/// Returns how close the held cells came; `None` when there are none.
#[allow(clippy::too_many_arguments)]
pub(super) async fn hold_design(
    eroded: &mut [f32],
    design: &[f32],
    held: &[u32],
    base: &[bool],
    n: usize,
    limit: Option<&Mask>,
    ctx: &JobCtx,
) -> Result<Option<Held>, StageError> {
    let held: Vec<usize> = held
        .iter()
        .map(|&i| i as usize)
        .filter(|&i| i < eroded.len() && !base[i])
        .collect();
    if held.is_empty() {
        return Ok(None);
    }
    ctx.tick(0.92, HOLDING).await?;
    let is_held = mask_of(&held, eroded.len());
    let spread = spread_residual(eroded, design, &held, &is_held, base, n, ctx).await?;
    // Each whole-map pass below is one slice of the page's main thread: the job ticks
    // between them (the same result).
    ctx.tick(0.93, HOLDING).await?;
    let to_held = distances(&is_held, n);
    ctx.tick(0.93, HOLDING).await?;
    // The correction fades to nothing at the map's edge too: land beyond a drawn ridge drains
    // along the edge to the rivers, and a lift that stayed whole out there would dam it.
    let mut ends = base.to_vec();
    for k in 0..n {
        for i in [k, (n - 1) * n + k, k * n, k * n + n - 1] {
            ends[i] = true;
        }
    }
    let to_base = distances(&ends, n);
    ctx.tick(0.94, HOLDING).await?;
    let mut lift = vec![0.0f32; eroded.len()];
    for i in 0..eroded.len() {
        lift[i] = if base[i] {
            0.0
        } else if is_held[i] {
            // Pinned by the solver's floor already; here too for a surface solved without it.
            (design[i] - eroded[i]).max(0.0)
        } else {
            let (a, b) = (to_held[i], to_base[i]);
            let share = if !b.is_finite() || a + b <= 0.0 {
                1.0
            } else {
                b / (a + b)
            };
            spread[i] * share
        };
    }
    ctx.tick(0.94, HOLDING).await?;
    carry_upstream(&mut lift, eroded, base, n);
    ctx.tick(0.95, HOLDING).await?;
    for (h, c) in eroded.iter_mut().zip(&lift) {
        *h += c;
    }
    if let Some(mask) = limit {
        for _ in 0..LIMIT_PASSES {
            ctx.tick(0.95, HOLDING).await?;
            let forward = mask.scan(eroded, base, 0..n, true);
            let backward = mask.scan(eroded, base, 0..n, false);
            if !(forward || backward) {
                break;
            }
        }
    }
    Ok(Some(measure(eroded, design, &held)))
}

/// The residual at the held cells spread harmonically over the map (step 2 of the module docs).
async fn spread_residual(
    eroded: &[f32],
    design: &[f32],
    held: &[usize],
    is_held: &[bool],
    base: &[bool],
    n: usize,
    ctx: &JobCtx,
) -> Result<Vec<f32>, StageError> {
    let residual: Vec<f32> = held
        .iter()
        .map(|&i| design[i] - at_foot(eroded, is_held, base, n, i))
        .collect();
    let mean = residual.iter().map(|r| f64::from(*r)).sum::<f64>() / residual.len() as f64;
    let mut initial = vec![mean as f32; n * n];
    let mut fixed = FixedMask::new(n, n);
    for (&i, &r) in held.iter().zip(&residual) {
        initial[i] = r;
        fixed.fix_index(i);
    }
    let problem = Constraints::new(Heightfield::from_vec(n, n, initial)?, fixed)
        .map_err(|e| StageError::Hold(e.to_string()))?;
    let solved = multigrid::solve(&problem, None, &MultigridParams::default(), ctx)
        .await
        .map_err(|e| match e {
            crate::diffusion::DiffusionError::Cancelled(c) => StageError::Cancelled(c),
            other => StageError::Hold(other.to_string()),
        })?;
    Ok(solved.field.into_vec())
}

/// The highest eroded height of the cells within two cells of `i` that are neither held nor
/// base level (`eroded[i]` when there are none): lifted by the residual, none of them rises
/// above the held cell.
fn at_foot(eroded: &[f32], is_held: &[bool], base: &[bool], n: usize, i: usize) -> f32 {
    let (x, y) = ((i % n) as isize, (i / n) as isize);
    let mut top = f32::NEG_INFINITY;
    for dy in -2..=2isize {
        for dx in -2..=2isize {
            let (nx, ny) = (x + dx, y + dy);
            if nx < 0 || ny < 0 || nx >= n as isize || ny >= n as isize {
                continue;
            }
            let j = ny as usize * n + nx as usize;
            if !is_held[j] && !base[j] {
                top = top.max(eroded[j]);
            }
        }
    }
    if top.is_finite() { top } else { eroded[i] }
}

/// Raises `floor` at the `held` cells to their `design` heights: the solver lowers no held
/// cell below its drawn height (first point of the module docs). O(held cells).
pub(super) fn pin(floor: &mut [f32], design: &[f32], held: &[u32]) {
    for &i in held {
        if let (Some(f), Some(d)) = (floor.get_mut(i as usize), design.get(i as usize)) {
            *f = f.max(*d);
        }
    }
}

/// The cells of an `m` x `m` grid of `factor` x `factor` blocks (of an `n` x `n` one) that
/// hold one of `held`, ascending and each once.
pub(super) fn coarsen(held: &[u32], n: usize, factor: usize, m: usize) -> Vec<u32> {
    let mut coarse: Vec<u32> = held
        .iter()
        .map(|&i| {
            let (x, y) = (i as usize % n, i as usize / n);
            ((y / factor) * m + x / factor) as u32
        })
        .collect();
    coarse.sort_unstable();
    coarse.dedup();
    coarse
}

/// Makes `lift` non-decreasing upstream along the steepest descent of `eroded` (each cell
/// lifted at least as much as the neighbour it drains to), so every drop of the eroded surface
/// is kept and the correction dams no valley: land that drained towards a drawn ridge and
/// around it is carried up with it instead of being left as a lake. Cells in ascending order of
/// height, so a receiver's lift is final before its donors'. O(cells log cells).
fn carry_upstream(lift: &mut [f32], eroded: &[f32], base: &[bool], n: usize) {
    let mut order: Vec<u32> = (0..eroded.len() as u32).collect();
    order.sort_unstable_by(|a, b| eroded[*a as usize].total_cmp(&eroded[*b as usize]));
    for &i in &order {
        let i = i as usize;
        if base[i] {
            continue;
        }
        let (x, y) = ((i % n) as isize, (i / n) as isize);
        let mut steepest: Option<(f32, usize)> = None;
        for dy in -1..=1isize {
            for dx in -1..=1isize {
                let (nx, ny) = (x + dx, y + dy);
                if (dx, dy) == (0, 0) || nx < 0 || ny < 0 || nx >= n as isize || ny >= n as isize {
                    continue;
                }
                let j = ny as usize * n + nx as usize;
                let slope = (eroded[i] - eroded[j]) / ((dx * dx + dy * dy) as f32).sqrt();
                if slope > 0.0 && steepest.is_none_or(|(s, _)| slope > s) {
                    steepest = Some((slope, j));
                }
            }
        }
        if let Some((_, r)) = steepest {
            lift[i] = lift[i].max(lift[r]);
        }
    }
}

/// `true` at the listed cells of a field of `len` cells.
fn mask_of(cells: &[usize], len: usize) -> Vec<bool> {
    let mut mask = vec![false; len];
    for &i in cells {
        mask[i] = true;
    }
    mask
}

/// The chamfer distance (in cells) from each cell to the nearest `source` cell, infinite
/// when there is none: the threshold-slope scans of a unit slope from sources at 0 (one
/// forward and one backward scan are exact for a mask without obstacles; Borgefors 1986).
fn distances(source: &[bool], n: usize) -> Vec<f32> {
    let mut d: Vec<f32> = source
        .iter()
        .map(|s| if *s { 0.0 } else { f32::INFINITY })
        .collect();
    let unit = Mask::new(n, n, 1.0, 45.0);
    unit.scan(&mut d, source, 0..n, true);
    unit.scan(&mut d, source, 0..n, false);
    d
}

/// How close the held cells came to their design heights.
fn measure(result: &[f32], design: &[f32], held: &[usize]) -> Held {
    let (mut sum, mut below) = (0.0f64, 0.0f64);
    for &i in held {
        let d = f64::from(design[i] - result[i]);
        sum += d.abs();
        below = below.max(d);
    }
    Held {
        cells: held.len(),
        mean_error_m: sum / held.len() as f64,
        max_below_m: below,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A chamfer distance is within 3% of the Euclidean one (the 5 x 5 mask's bound).
    #[test]
    fn distances_are_nearly_euclidean() {
        let n = 41;
        let mut source = vec![false; n * n];
        source[20 * n + 20] = true;
        let d = distances(&source, n);
        for y in 0..n {
            for x in 0..n {
                let e = (((x as f32) - 20.0).powi(2) + ((y as f32) - 20.0).powi(2)).sqrt();
                assert!((d[y * n + x] - e).abs() <= 0.03 * e + 1e-4, "{x},{y}");
            }
        }
    }

    /// A peak worn down to a plain stands at its height again, the base level untouched, the
    /// flanks falling to it within the talus angle.
    #[test]
    fn a_worn_peak_stands_again_within_the_talus_angle() {
        let n = 65;
        let plain = Mask::new(n, n, 10.0, 35.0);
        let (eroded, _, _) = worn_peak_held(n, 150.0, &plain);
        assert_eq!(eroded[32 * n + 32], 150.0);
        let flanks = flank_slopes(&eroded, n, 10.0, 35.0);
        assert!(!flanks.is_empty(), "the peak stands above the ramp");
    }

    /// A peak higher than the angle can carry from the base is cut to it: with one angle
    /// the flanks are a cone of planes, every cell at the angle; where the rock's strength
    /// varies under the angle (as the solver's limit holds it), the flanks are not.
    #[test]
    fn held_flanks_follow_the_rocks_strength_not_one_angle() {
        let (n, cell_m) = (65, 10.0);
        let plain = Mask::new(n, n, cell_m, 35.0);
        let mut factors = vec![0.0f32; n * n];
        super::super::SlopeStrength::new(n, cell_m, 3, 0.3).rows(0, &mut factors);
        let varied = Mask::new(n, n, cell_m, 35.0).with_strength(factors);
        let spread = |mask: &Mask| {
            let (eroded, _, _) = worn_peak_held(n, 600.0, mask);
            let ratios = flank_slopes(&eroded, n, cell_m as f32, 35.0);
            let mean = ratios.iter().sum::<f32>() / ratios.len() as f32;
            let var = ratios.iter().map(|r| (r - mean).powi(2)).sum::<f32>() / ratios.len() as f32;
            var.sqrt() / mean
        };
        let (one_angle, strength) = (spread(&plain), spread(&varied));
        assert!(
            one_angle < 0.03,
            "one angle: a cone of planes ({one_angle})"
        );
        assert!(
            strength > 0.05 && strength > 3.0 * one_angle,
            "the rock's strength breaks the planes: {strength} vs {one_angle}"
        );
    }

    /// Each raised cell's steepest descent (8 neighbours) over the talus angle's, asserting
    /// that none is over the angle.
    fn flank_slopes(eroded: &[f32], n: usize, cell_m: f32, talus_deg: f32) -> Vec<f32> {
        let rise = talus_deg.to_radians().tan() * cell_m;
        let mut ratios = Vec::new();
        for y in 1..n - 1 {
            for x in 1..n - 1 {
                let i = y * n + x;
                let ramp = y as f32 * 0.5;
                let steepest = [(1, 0), (0, 1), (1, 1), (1, -1)]
                    .iter()
                    .flat_map(|&(dx, dy): &(isize, isize)| {
                        let d = ((dx * dx + dy * dy) as f32).sqrt();
                        [1isize, -1].map(|s| {
                            let j = (i as isize + s * (dy * n as isize + dx)) as usize;
                            (eroded[i] - eroded[j]) / d
                        })
                    })
                    .fold(f32::MIN, f32::max);
                assert!(steepest <= rise * 1.001, "over the angle at {x},{y}");
                if eroded[i] > ramp + 20.0 {
                    ratios.push(steepest / rise);
                }
            }
        }
        ratios
    }

    /// A peak of `height` metres on a ramp held back up within `limit`: the result, the ramp
    /// and the base; the base and the ramp's cells far from the peak are untouched.
    fn worn_peak_held(n: usize, height: f32, limit: &Mask) -> (Vec<f32>, Vec<f32>, Vec<bool>) {
        let mut eroded = vec![0.0f32; n * n];
        let mut design = vec![0.0f32; n * n];
        let base: Vec<bool> = (0..n * n).map(|i| i % n == 0 || i % n == n - 1).collect();
        let peak = 32 * n + 32;
        design[peak] = height;
        // The eroded surface keeps a texture (a ramp across the map).
        for (i, e) in eroded.iter_mut().enumerate() {
            *e = (i / n) as f32 * 0.5;
        }
        let texture = eroded.clone();
        let held = pollster::block_on(hold_design(
            &mut eroded,
            &design,
            &[peak as u32],
            &base,
            n,
            Some(limit),
            &JobCtx::detached(),
        ))
        .unwrap()
        .unwrap();
        assert!(held.max_below_m >= -1.0, "{held:?}");
        assert!(eroded[peak] <= height);
        for i in (0..n * n).filter(|i| base[*i]) {
            assert_eq!(eroded[i], texture[i]);
        }
        (eroded, texture, base)
    }
}
