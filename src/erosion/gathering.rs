//! Where water gathers, rock fails at lower angles: the threshold-slope limit
//! (`slope_limit.rs`) of each step takes every cell's strength factor times
//! [`factor`] of the drainage area through it.
//!
//! In steep land the valleys below a few square kilometres are not cut by rivers but scoured
//! by debris flows, and their beds fall with drainage area from the hillslopes' threshold
//! angle: on slope-area plots the colluvial and debris-flow valleys form a curved, gently
//! falling regime between the threshold hillslopes and the fluvial power law (Montgomery and
//! Foufoula-Georgiou 1993, "Channel network source representation using digital elevation
//! models", WRR 29(12); Stock and Dietrich 2003, "Valley incision by debris flows: evidence
//! of a topographic signature", WRR 39(4)). Weathering, seepage and the debris of the slopes
//! above all concentrate where flow converges, so a hollow stands gentler than the face
//! around it.
//!
//! The solver's limit held every cell to its rock's angle alone, so a face at that angle
//! failed as one plane, striped along its fall lines by the rock's strength field, and no
//! hollow could deepen into it: a gully's sides would stand steeper than the face. With the
//! factor, the flow that converges on a hollow lowers the angle it stands at, the limit
//! cuts it down, and the next step routes more water into it: faces dissect into gullies and
//! spurs, the channel network's heads reach into them, and long straight runs of the
//! drainage down planar faces break up.
//!
//! The factor is a power of the specific catchment area `a = A / cell` (the area drained per
//! metre of contour): on a planar face it is the distance from the divide whatever the grid,
//! so the faces of coarse and fine maps alike are left alone up to [`FROM_M`], and a hollow,
//! where flow converges, passes it within a few cells. It falls as `(a / FROM_M)^-1/4` to
//! [`WEAKEST`], where the stream-power law has long taken over (the slopes of channels
//! draining square kilometres are far below any threshold angle). `FROM_M`, the exponent and
//! `WEAKEST` are this project's, set on the realism measures of the default design at 2, 10
//! and 50 km (docs/features.md, "Water gathering weakens the rock"); the papers give the
//! regime's shape, not a law for its slope.

/// Specific catchment area (metres: drainage area per metre of contour) from which the
/// rock is weakened: longer than most threshold hillslopes' flow paths, so that faces keep
/// their angle and hollows do not.
pub const FROM_M: f32 = 300.0;

/// The weakest factor, reached at `FROM_M / WEAKEST^4` (1,250 m of specific area): valleys
/// draining more are channels, whose slopes the stream-power law sets well below it. At 0.6
/// and 0.5 the valleys cut further into the peaks: the default design's relief at 10 km fell
/// from 707 m to 634 and 588 m and its hypsometric integral rose from 0.37 to 0.40 and 0.41
/// (real land 0.15 to 0.36).
pub const WEAKEST: f32 = 0.7;

/// The factor on the strength of a cell `cell_m` wide through which `area_m2` drains:
/// `(a / FROM_M)^(-1/4)` for the specific catchment area `a = area_m2 / cell_m` past
/// [`FROM_M`], never under [`WEAKEST`]; 1 up to `FROM_M`.
pub fn factor(area_m2: f32, cell_m: f32) -> f32 {
    let ratio = area_m2 / (cell_m * FROM_M);
    if ratio <= 1.0 {
        return 1.0;
    }
    (1.0 / ratio.sqrt().sqrt()).max(WEAKEST)
}

/// Fills `out` with each cell's strength factor, `rock` (empty: 1 everywhere) times
/// [`factor`] of its drainage area `area` (m^2) on cells `cell_m` wide.
pub fn weaken(rock: &[f32], area: &[f32], cell_m: f32, out: &mut Vec<f32>) {
    out.clear();
    if rock.is_empty() {
        out.extend(area.iter().map(|&a| factor(a, cell_m)));
    } else {
        out.extend(rock.iter().zip(area).map(|(&r, &a)| r * factor(a, cell_m)));
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The factor is 1 on hillslopes, falls monotonically past `FROM_M` as the fourth root,
    /// and stops at `WEAKEST`; the same specific area gives the same factor on any grid.
    #[test]
    fn the_factor_falls_with_specific_area_to_the_weakest() {
        assert_eq!(factor(4.0, 2.0), 1.0);
        assert_eq!(factor(FROM_M * 10.0, 10.0), 1.0);
        let twice = factor(2.0 * FROM_M * 10.0, 10.0);
        assert!((twice - 2f32.powf(-0.25)).abs() < 1e-6, "{twice}");
        assert_eq!(factor(2.0 * FROM_M * 50.0, 50.0), twice);
        assert_eq!(factor(1.0e12, 2.0), WEAKEST);
        let mut last = 1.0;
        for k in 0..200 {
            let f = factor(FROM_M * 2.0 * 1.05f32.powi(k), 2.0);
            assert!(f <= last && f >= WEAKEST, "{f} after {last}");
            last = f;
        }
        assert_eq!(last, WEAKEST);
    }

    /// The rock's own factors are scaled, not replaced; no rock is rock of factor 1.
    #[test]
    fn weakening_scales_the_rocks_factors() {
        let area = [1.0, 1.0e9];
        let mut out = Vec::new();
        weaken(&[], &area, 10.0, &mut out);
        assert_eq!(out, vec![1.0, WEAKEST]);
        weaken(&[0.5, 0.8], &area, 10.0, &mut out);
        assert_eq!(out, vec![0.5, 0.8 * WEAKEST]);
    }
}
