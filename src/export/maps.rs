//! Texture maps at the export size, for the engine's material: a tangent-space normal map,
//! slope, curvature, flow (drainage area), erosion and deposition, the rivers' water mask, and
//! a four-channel splat map of rock, grass, sediment and snow.
//!
//! Gradients are central differences (one-sided at the edges) on vertices `spacing` metres
//! apart; image rows run north to south, so "up" in the picture is north.

use crate::heightfield::Heightfield;
use crate::jobs::{Cancelled, JobCtx, finish_inline};

/// Tangent-space normal map conventions: OpenGL (Unity, Godot, Blender) has green towards
/// the top of the image; DirectX (Unreal) towards its bottom.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum NormalConvention {
    OpenGl,
    DirectX,
}

/// `(dz/dx east, dz/dy north)` at every vertex.
pub fn gradients(field: &Heightfield, spacing: f64) -> Vec<(f64, f64)> {
    (0..field.data().len())
        .map(|i| gradient(field, spacing, i))
        .collect()
}

/// `(dz/dx east, dz/dy north)` at vertex `i`: central differences, one-sided at the edges.
fn gradient(field: &Heightfield, spacing: f64, i: usize) -> (f64, f64) {
    let (w, h) = (field.width(), field.height());
    let d = field.data();
    let at = |x: usize, y: usize| f64::from(d[y * w + x]);
    let (x, y) = (i % w, i / w);
    let (xa, xb) = (x.saturating_sub(1), (x + 1).min(w - 1));
    let (ya, yb) = (y.saturating_sub(1), (y + 1).min(h - 1));
    let dx = (at(xb, y) - at(xa, y)) / ((xb - xa).max(1) as f64 * spacing);
    // Rows run south: north is -y.
    let dy = (at(x, ya) - at(x, yb)) / ((yb - ya).max(1) as f64 * spacing);
    (dx, dy)
}

/// Unit normal `(x east, y north, z up)` of a surface with gradient `(gx, gy)`.
pub fn normal((gx, gy): (f64, f64)) -> [f64; 3] {
    let n = [-gx, -gy, 1.0];
    let len = (n[0] * n[0] + n[1] * n[1] + 1.0).sqrt();
    [n[0] / len, n[1] / len, n[2] / len]
}

fn unit_to_byte(v: f64) -> u8 {
    ((v * 0.5 + 0.5) * 255.0).round().clamp(0.0, 255.0) as u8
}

/// The normal map, RGB interleaved: `(n + 1) / 2` of each component, green per `convention`.
/// A no-data vertex gets the flat normal.
pub fn normal_map(field: &Heightfield, spacing: f64, convention: NormalConvention) -> Vec<u8> {
    finish_inline(|ctx| async move { normal_map_in(field, spacing, convention, &ctx).await })
}

/// [`normal_map`] in a job: a tick every [`crate::jobs::CELLS_PER_TICK`] vertices.
pub async fn normal_map_in(
    field: &Heightfield,
    spacing: f64,
    convention: NormalConvention,
    ctx: &JobCtx,
) -> Result<Vec<u8>, Cancelled> {
    let mut out = Vec::with_capacity(field.data().len() * 3);
    ctx.for_cells(field.data().len(), "the normal map", |cells| {
        for i in cells {
            let g = gradient(field, spacing, i);
            let g = if g.0.is_finite() && g.1.is_finite() {
                g
            } else {
                (0.0, 0.0)
            };
            let n = normal(g);
            let green = match convention {
                NormalConvention::OpenGl => n[1],
                NormalConvention::DirectX => -n[1],
            };
            out.extend([unit_to_byte(n[0]), unit_to_byte(green), unit_to_byte(n[2])]);
        }
    })
    .await?;
    Ok(out)
}

/// Slope in degrees at every vertex (NaN at no-data).
pub fn slope_degrees(field: &Heightfield, spacing: f64) -> Vec<f64> {
    finish_inline(|ctx| async move { slope_degrees_in(field, spacing, &ctx).await })
}

/// [`slope_degrees`] in a job: a tick every [`crate::jobs::CELLS_PER_TICK`] vertices.
pub async fn slope_degrees_in(
    field: &Heightfield,
    spacing: f64,
    ctx: &JobCtx,
) -> Result<Vec<f64>, Cancelled> {
    ctx.map_cells(field.data().len(), "slopes", |i| {
        let (gx, gy) = gradient(field, spacing, i);
        gx.hypot(gy).atan().to_degrees()
    })
    .await
}

/// Slope as 8 bits: 0 = flat, 255 = vertical (`degrees / 90 * 255`).
pub async fn slope_map(slopes: &[f64], ctx: &JobCtx) -> Result<Vec<u8>, Cancelled> {
    ctx.map_cells(slopes.len(), "the slope map", |i| {
        let s = slopes[i];
        if s.is_finite() {
            (s / 90.0 * 255.0).round().clamp(0.0, 255.0) as u8
        } else {
            0
        }
    })
    .await
}

/// Curvature as 8 bits: the Laplacian (1/m) of the surface, 128 = planar, above = concave
/// (hollows, valleys), below = convex (ridges), scaled so the 99th percentile of |Laplacian|
/// reaches the ends; and that scale (1/m per step).
pub fn curvature_map(field: &Heightfield, spacing: f64) -> (Vec<u8>, f64) {
    finish_inline(|ctx| async move { curvature_map_in(field, spacing, &ctx).await })
}

/// [`curvature_map`] in a job: every pass ticks (the percentile is found by a histogram of
/// the values' bits, not a sort, so that it can).
pub async fn curvature_map_in(
    field: &Heightfield,
    spacing: f64,
    ctx: &JobCtx,
) -> Result<(Vec<u8>, f64), Cancelled> {
    const WHAT: &str = "the curvature map";
    let (w, h) = (field.width(), field.height());
    let d = field.data();
    let at = |x: usize, y: usize| f64::from(d[y * w + x]);
    let [laplacian, scale, mapping] = ctx.parts();
    let lap = laplacian
        .map_cells(w * h, WHAT, |i| {
            let (x, y) = (i % w, i / w);
            let (xa, xb) = (x.saturating_sub(1), (x + 1).min(w - 1));
            let (ya, yb) = (y.saturating_sub(1), (y + 1).min(h - 1));
            (at(xa, y) + at(xb, y) + at(x, ya) + at(x, yb) - 4.0 * at(x, y)) / (spacing * spacing)
        })
        .await?;
    let p99 = percentile_of_magnitudes(&lap, 99, &scale)
        .await?
        .filter(|v| *v > 0.0)
        .unwrap_or(1.0);
    let per_step = p99 / 127.0;
    let bytes = mapping
        .map_cells(lap.len(), WHAT, |i| {
            let v = lap[i];
            if v.is_finite() {
                (128.0 + v / per_step).round().clamp(0.0, 255.0) as u8
            } else {
                128
            }
        })
        .await?;
    Ok((bytes, per_step))
}

/// The value of rank `(count - 1) * percent / 100` (0-based, ascending) among the finite
/// `|v|` of `values`, as a sort would find it; `None` when none is finite. Two passes: a
/// histogram of the top 16 bits of each magnitude (non-negative `f64`s order as their bits
/// do) finds the bucket holding that rank, then the bucket's values are sorted.
async fn percentile_of_magnitudes(
    values: &[f64],
    percent: usize,
    ctx: &JobCtx,
) -> Result<Option<f64>, Cancelled> {
    const WHAT: &str = "the curvature's scale";
    let bucket = |v: f64| (v.abs().to_bits() >> 48) as usize;
    let [counting, picking] = ctx.parts();
    let mut counts = vec![0usize; 1 << 16];
    counting
        .for_cells(values.len(), WHAT, |cells| {
            for &v in values[cells].iter().filter(|v| v.is_finite()) {
                counts[bucket(v)] += 1;
            }
        })
        .await?;
    let total: usize = counts.iter().sum();
    if total == 0 {
        return Ok(None);
    }
    let mut rank = (total - 1) * percent / 100;
    let Some(chosen) = counts.iter().position(|&c| {
        if rank < c {
            true
        } else {
            rank -= c;
            false
        }
    }) else {
        return Ok(None);
    };
    let mut inside = Vec::new();
    picking
        .for_cells(values.len(), WHAT, |cells| {
            let picked = values[cells]
                .iter()
                .filter(|v| v.is_finite() && bucket(**v) == chosen);
            inside.extend(picked.map(|v| v.abs()));
        })
        .await?;
    inside.sort_by(f64::total_cmp);
    Ok(inside.get(rank).copied())
}

/// `values` on a log scale over their positive range, as 8 bits (0 = the smallest, 255 = the
/// largest); used for drainage area.
pub async fn log_map(values: &[f64], ctx: &JobCtx) -> Result<Vec<u8>, Cancelled> {
    const WHAT: &str = "the flow map";
    let log = |v: f64| if v > 0.0 { v.log10() } else { f64::NAN };
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    let [ranging, mapping] = ctx.parts();
    ranging
        .for_cells(values.len(), WHAT, |cells| {
            for v in values[cells]
                .iter()
                .map(|v| log(*v))
                .filter(|v| v.is_finite())
            {
                lo = lo.min(v);
                hi = hi.max(v);
            }
        })
        .await?;
    let span = (hi - lo).max(1e-12);
    mapping
        .map_cells(values.len(), WHAT, |i| {
            let v = log(values[i]);
            if v.is_finite() {
                ((v - lo) / span * 255.0).round() as u8
            } else {
                0
            }
        })
        .await
}

/// Erosion (positive: lowered) and deposition (negative) in metres as 8 bits: 128 = unchanged,
/// 255 = the most lowered, 0 = the most raised (one scale for both); and that scale (m per
/// step).
pub async fn erosion_map(lowered: &[f32], ctx: &JobCtx) -> Result<(Vec<u8>, f64), Cancelled> {
    const WHAT: &str = "the erosion map";
    let mut max = 0.0f64;
    let [ranging, mapping] = ctx.parts();
    ranging
        .for_cells(lowered.len(), WHAT, |cells| {
            for v in lowered[cells].iter().filter(|v| v.is_finite()) {
                max = max.max(f64::from(v.abs()));
            }
        })
        .await?;
    let per_step = max.max(1e-6) / 127.0;
    let bytes = mapping
        .map_cells(lowered.len(), WHAT, |i| {
            let v = lowered[i];
            if v.is_finite() {
                (128.0 + f64::from(v) / per_step).round().clamp(0.0, 255.0) as u8
            } else {
                128
            }
        })
        .await?;
    Ok((bytes, per_step))
}

/// Watershed labels as 8 bits from every cell's `outlet` (`u32::MAX`: no-data) and upstream
/// `area`: the basins of the outlets in `first` (the drawn rivers' estuaries) are 1, 2, ...
/// in that order, then the other basins draining at least `min_area` by size, up to 255
/// labels; 0 is every smaller basin (slivers along the map's edge) and no-data.
pub fn basin_labels(outlet: &[u32], area: &[f64], first: &[u32], min_area: f64) -> Vec<u8> {
    finish_inline(|ctx| async move { basin_labels_in(outlet, area, first, min_area, &ctx).await })
}

/// [`basin_labels`] in a job: a tick every [`crate::jobs::CELLS_PER_TICK`] cells.
pub async fn basin_labels_in(
    outlet: &[u32],
    area: &[f64],
    first: &[u32],
    min_area: f64,
    ctx: &JobCtx,
) -> Result<Vec<u8>, Cancelled> {
    const WHAT: &str = "the basin map";
    let mut order: Vec<u32> = Vec::new();
    for o in first {
        if *o != u32::MAX && !order.contains(o) {
            order.push(*o);
        }
    }
    let mut others: Vec<u32> = Vec::new();
    let [finding, labelling] = ctx.parts();
    finding
        .for_cells(outlet.len(), WHAT, |cells| {
            let own = cells.filter(|&i| outlet[i] == i as u32 && area[i] >= min_area);
            others.extend(own.map(|i| i as u32).filter(|o| !order.contains(o)));
        })
        .await?;
    others.sort_by(|a, b| {
        area[*b as usize]
            .total_cmp(&area[*a as usize])
            .then(a.cmp(b))
    });
    order.extend(others);
    order.truncate(255);
    let mut label = std::collections::HashMap::with_capacity(order.len());
    for (k, o) in order.iter().enumerate() {
        label.insert(*o, k as u8 + 1);
    }
    labelling
        .map_cells(outlet.len(), WHAT, |i| {
            label.get(&outlet[i]).copied().unwrap_or(0)
        })
        .await
}

/// Where each material starts (the scene's `textures`; see `crate::scene::TextureRules`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SplatRules {
    /// Ground steeper than this is rock (degrees).
    pub rock_slope_deg: f64,
    /// Snow above this fraction of the height range.
    pub snow_above: f64,
    /// Ground draining more than this is sediment (river beds, fans), m^2.
    pub sediment_area_m2: f64,
    /// Width of each transition, as a fraction of its threshold.
    pub softness: f64,
}

impl Default for SplatRules {
    fn default() -> Self {
        Self {
            rock_slope_deg: 35.0,
            snow_above: 0.8,
            sediment_area_m2: 1e6,
            softness: 0.15,
        }
    }
}

/// 0 below `edge * (1 - soft)`, 1 above `edge * (1 + soft)`, smooth between.
fn step(value: f64, edge: f64, soft: f64) -> f64 {
    let width = (edge.abs() * soft).max(1e-9);
    let t = ((value - (edge - width)) / (2.0 * width)).clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

/// The four weights `[rock, grass, sediment, snow]` of a vertex, summing to 1: snow on high
/// ground that is not too steep to hold it, rock on steep ground, sediment where much water
/// gathers on gentle ground, grass on the rest.
pub fn splat_weights(
    slope_deg: f64,
    relative_height: f64,
    area_m2: f64,
    rules: &SplatRules,
) -> [f64; 4] {
    let soft = rules.softness;
    let rock = step(slope_deg, rules.rock_slope_deg, soft);
    let snow = step(relative_height, rules.snow_above, soft) * (1.0 - step(slope_deg, 50.0, soft));
    let sediment = step(
        area_m2.max(1.0).log10(),
        rules.sediment_area_m2.max(1.0).log10(),
        soft * 0.2,
    ) * (1.0 - rock);
    let mut w = [rock, 0.0, sediment, snow];
    let taken: f64 = w.iter().sum();
    if taken > 1.0 {
        w.iter_mut().for_each(|v| *v /= taken);
    } else {
        w[1] = 1.0 - taken;
    }
    w
}

/// The splat map, RGBA interleaved (rock, grass, sediment, snow), each vertex's four bytes
/// summing to exactly 255.
pub async fn splat_map(
    field: &Heightfield,
    slopes: &[f64],
    area_m2: &[f64],
    rules: &SplatRules,
    ctx: &JobCtx,
) -> Result<Vec<u8>, Cancelled> {
    let [ranging, weighing] = ctx.parts();
    let (lo, hi) = field.finite_range_in(&ranging).await?.unwrap_or((0.0, 1.0));
    let span = f64::from(hi - lo).max(1e-9);
    let mut out = Vec::with_capacity(slopes.len() * 4);
    weighing
        .for_cells(field.data().len(), "the splat map", |cells| {
            for i in cells {
                let z = field.data()[i];
                let relative = (f64::from(z) - f64::from(lo)) / span;
                let w = if z.is_finite() {
                    splat_weights(slopes[i], relative, area_m2[i], rules)
                } else {
                    [0.0, 1.0, 0.0, 0.0]
                };
                out.extend(to_bytes_summing_255(w));
            }
        })
        .await?;
    Ok(out)
}

/// Weights summing to 1 as bytes summing to 255 (largest remainder rounding).
fn to_bytes_summing_255(w: [f64; 4]) -> [u8; 4] {
    let scaled = w.map(|v| v.max(0.0) * 255.0);
    let mut bytes = scaled.map(|v| v.floor() as u8);
    let mut left = 255 - bytes.iter().map(|b| u32::from(*b)).sum::<u32>().min(255);
    let mut order = [0usize, 1, 2, 3];
    order.sort_by(|&a, &b| {
        (scaled[b] - scaled[b].floor()).total_cmp(&(scaled[a] - scaled[a].floor()))
    });
    for k in order.iter().cycle() {
        if left == 0 {
            break;
        }
        bytes[*k] += 1;
        left -= 1;
    }
    bytes
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A plane rising 0.3 east and 0.2 north has the normal (-0.3, -0.2, 1) / |.| everywhere,
    /// edges included; DirectX flips green.
    #[test]
    fn a_plane_of_known_slope_gives_its_analytic_normal() {
        let (w, h, s) = (9, 7, 2.0);
        let data: Vec<f32> = (0..w * h)
            .map(|i| {
                let (x, y) = ((i % w) as f64 * s, (i / w) as f64 * s);
                (0.3 * x - 0.2 * y) as f32
            })
            .collect();
        let field = Heightfield::from_vec(w, h, data).unwrap();
        let len = (0.09f64 + 0.04 + 1.0).sqrt();
        let want = [-0.3 / len, -0.2 / len, 1.0 / len];
        for g in gradients(&field, s) {
            let n = normal(g);
            for k in 0..3 {
                assert!((n[k] - want[k]).abs() < 1e-6, "{n:?} vs {want:?}");
            }
        }
        let gl = normal_map(&field, s, NormalConvention::OpenGl);
        let dx = normal_map(&field, s, NormalConvention::DirectX);
        assert_eq!(gl[0], unit_to_byte(want[0]));
        assert_eq!(gl[1], unit_to_byte(want[1]));
        assert_eq!(dx[1], unit_to_byte(-want[1]));
        let slope = slope_degrees(&field, s)[30];
        assert!((slope - 0.13f64.sqrt().atan().to_degrees()).abs() < 1e-6);
    }

    #[test]
    fn splat_weights_sum_to_one_and_bytes_to_255() {
        let rules = SplatRules::default();
        for slope in [0.0, 20.0, 34.0, 36.0, 60.0, 89.0] {
            for rel in [0.0, 0.5, 0.79, 0.81, 1.0] {
                for area in [0.0, 1e3, 9e5, 1.1e6, 1e9] {
                    let w = splat_weights(slope, rel, area, &rules);
                    assert!((w.iter().sum::<f64>() - 1.0).abs() < 1e-12, "{w:?}");
                    assert!(w.iter().all(|v| *v >= 0.0));
                    let b = to_bytes_summing_255(w);
                    assert_eq!(b.iter().map(|v| u32::from(*v)).sum::<u32>(), 255);
                }
            }
        }
        assert!(splat_weights(60.0, 0.2, 10.0, &rules)[0] > 0.99);
        assert!(splat_weights(5.0, 0.95, 10.0, &rules)[3] > 0.99);
        assert!(splat_weights(2.0, 0.2, 1e8, &rules)[2] > 0.99);
        assert!(splat_weights(10.0, 0.3, 10.0, &rules)[1] > 0.99);
    }

    /// A V-shaped valley draining south: its outlet's basin is label 1 and holds most of the
    /// map; the edge's slivers stay 0 (below the area threshold).
    #[test]
    fn basins_are_labelled_estuaries_first() {
        let (w, h) = (21, 41);
        let data: Vec<f32> = (0..w * h)
            .map(|i| {
                let (x, y) = ((i % w) as f32, (i / w) as f32);
                (x - 10.0).abs() * 2.0 + (h as f32 - y)
            })
            .collect();
        let field = Heightfield::from_vec(w, h, data).unwrap();
        let (outlet, area) = crate::realism::outlets(field.data(), w, h, 1.0, &[]).unwrap();
        let estuary = outlet[(h - 1) * w + 10];
        let labels = basin_labels(&outlet, &area, &[estuary], 20.0);
        assert_eq!(labels[(h - 1) * w + 10], 1);
        assert_eq!(labels[5 * w + 2], 1, "the valley side drains into it");
        assert!(labels.iter().filter(|l| **l == 1).count() * 2 > w * h);
        assert_eq!(labels[0], 0, "a corner sliver");
    }

    #[test]
    fn curvature_and_erosion_are_centred() {
        let field = Heightfield::filled(5, 5, 3.0).unwrap();
        let (bytes, _) = curvature_map(&field, 1.0);
        assert!(bytes.iter().all(|b| *b == 128));
        let (bytes, per_step) =
            finish_inline(|ctx| async move { erosion_map(&[2.0, -1.0, 0.0], &ctx).await });
        assert_eq!(bytes, vec![255, 65, 128]);
        assert!((per_step - 2.0 / 127.0).abs() < 1e-12);
        let logs =
            finish_inline(|ctx| async move { log_map(&[1.0, 10.0, 100.0, 0.0], &ctx).await });
        assert_eq!(logs, vec![0, 128, 255, 0]);
    }

    /// The curvature's scale found by a histogram of the bits is the value a sort finds,
    /// with ties, no-data, signs and values across many octaves.
    #[test]
    fn the_percentile_by_histogram_is_the_sorted_ones() {
        let mut values: Vec<f64> = (0..20_000u64)
            .map(|i| {
                let r = crate::noise::splitmix64(i) as f64 / u64::MAX as f64;
                let v = (r * 40.0 - 20.0).exp2() * if i % 3 == 0 { -1.0 } else { 1.0 };
                if i % 7 == 0 { 0.25 } else { v }
            })
            .collect();
        values.extend([f64::NAN, f64::INFINITY, 0.0, -0.0]);
        for percent in [0, 1, 50, 99, 100] {
            let mut sorted: Vec<f64> = values
                .iter()
                .filter(|v| v.is_finite())
                .map(|v| v.abs())
                .collect();
            sorted.sort_by(f64::total_cmp);
            let want = sorted[(sorted.len() - 1) * percent / 100];
            let values = &values;
            let got = finish_inline(|ctx| async move {
                percentile_of_magnitudes(values, percent, &ctx).await
            });
            assert_eq!(got, Some(want), "{percent}%");
        }
        let none =
            finish_inline(
                |ctx| async move { percentile_of_magnitudes(&[f64::NAN], 99, &ctx).await },
            );
        assert_eq!(none, None);
    }
}
