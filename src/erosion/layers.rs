//! The erosion stage's map layers as 8-bit PNGs: drainage area on a log scale and the depth
//! of erosion.

use super::Eroded;
use crate::dem::DemError;
use crate::heightfield::Heightfield;

/// `drainage_area.png` (log10 of the area in m^2, from one cell to the largest area, to 1..255)
/// and `erosion_depth.png` (0 = unchanged or raised, 255 = the deepest cut).
pub fn layer_pngs(
    eroded: &Eroded,
    before: &Heightfield,
) -> Result<Vec<(&'static str, Vec<u8>)>, DemError> {
    let (w, h) = (eroded.field.width(), eroded.field.height());
    let area = eroded.drainage_area.data();
    let (lo, hi) = area
        .iter()
        .filter(|a| a.is_finite() && **a > 0.0)
        .fold((f32::INFINITY, 0.0f32), |(lo, hi), &a| {
            (lo.min(a), hi.max(a))
        });
    let (llo, lhi) = (lo.max(1e-6).log10(), hi.max(1e-6).log10());
    let span = (lhi - llo).max(1e-6);
    let area_px: Vec<u8> = area
        .iter()
        .map(|&a| {
            if a > 0.0 && a.is_finite() {
                (1.0 + 254.0 * ((a.log10() - llo) / span).clamp(0.0, 1.0)).round() as u8
            } else {
                0
            }
        })
        .collect();
    let depth = eroded.depth(before);
    let deepest = depth.iter().copied().fold(0.0f32, f32::max).max(1e-6);
    let depth_px: Vec<u8> = depth
        .iter()
        .map(|&d| (255.0 * (d / deepest).clamp(0.0, 1.0)).round() as u8)
        .collect();
    Ok(vec![
        (
            "drainage_area.png",
            crate::dem::png16::write_grey8(w, h, &area_px)?,
        ),
        (
            "erosion_depth.png",
            crate::dem::png16::write_grey8(w, h, &depth_px)?,
        ),
    ])
}
