//! The erosion stage's map layers as 8-bit PNGs: drainage area on a log scale and the depth
//! of erosion.

use super::Eroded;
use crate::dem::DemError;
use crate::heightfield::Heightfield;

/// Drainage area as 8-bit grey: log10 of the area in m^2, from the smallest to the largest
/// area, to 1..255 (0 where there is none). One value per cell of `eroded.field`.
pub fn drainage_grey(eroded: &Eroded) -> Vec<u8> {
    let area = eroded.drainage_area.data();
    let (lo, hi) = area
        .iter()
        .filter(|a| a.is_finite() && **a > 0.0)
        .fold((f32::INFINITY, 0.0f32), |(lo, hi), &a| {
            (lo.min(a), hi.max(a))
        });
    let (llo, lhi) = (lo.max(1e-6).log10(), hi.max(1e-6).log10());
    let span = (lhi - llo).max(1e-6);
    area.iter()
        .map(|&a| {
            if a > 0.0 && a.is_finite() {
                (1.0 + 254.0 * ((a.log10() - llo) / span).clamp(0.0, 1.0)).round() as u8
            } else {
                0
            }
        })
        .collect()
}

/// Erosion depth as 8-bit grey: 0 = unchanged or raised, 255 = the deepest cut below
/// `before` (the terrain the stage started from).
pub fn depth_grey(eroded: &Eroded, before: &Heightfield) -> Vec<u8> {
    let depth = eroded.depth(before);
    let deepest = depth.iter().copied().fold(0.0f32, f32::max).max(1e-6);
    depth
        .iter()
        .map(|&d| (255.0 * (d / deepest).clamp(0.0, 1.0)).round() as u8)
        .collect()
}

/// `drainage_area.png` ([`drainage_grey`]) and `erosion_depth.png` ([`depth_grey`]).
pub fn layer_pngs(
    eroded: &Eroded,
    before: &Heightfield,
) -> Result<Vec<(&'static str, Vec<u8>)>, DemError> {
    let (w, h) = (eroded.field.width(), eroded.field.height());
    Ok(vec![
        (
            "drainage_area.png",
            crate::dem::png16::write_grey8(w, h, &drainage_grey(eroded))?,
        ),
        (
            "erosion_depth.png",
            crate::dem::png16::write_grey8(w, h, &depth_grey(eroded, before))?,
        ),
    ])
}
