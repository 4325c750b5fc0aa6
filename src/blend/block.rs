//! A placed block as the scene stores it: the reference R (a 16-bit PNG, so the scene is
//! self-contained and re-solves after a reload), its transform and where it sits on the map.

use base64::Engine as _;
use serde::Serialize;

use crate::dem::{ReadLimits, png16};
use crate::heightfield::Heightfield;

use super::{BlendError, BlockRect, Transform, guide};

/// One blended block of real terrain.
/// Serialised only into the pipeline's stage keys; the scene file has its own schema
/// (`crate::scene`'s `file` module).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct BlendBlock {
    /// Where the reference came from (file name and pixel window), for the user.
    pub name: String,
    /// The reference block R as a base64 16-bit greyscale PNG with its height range in a
    /// `zmin,zmax` text chunk (heights quantised to 1/65535 of that range).
    pub reference_png: String,
    /// The block on the map, `[x0, y0, x1, y1]` in map units (0..1, y down).
    pub rect: [f64; 4],
    /// Clockwise quarter turns of the reference, 0 to 3.
    pub quarter_turns: u8,
    /// Mirror the reference left-right before turning it.
    pub mirror: bool,
    /// Multiplies the reference's heights (and so its gradients).
    pub z_scale: f32,
    /// The share of the block's shorter side over which its change of the terrain fades in
    /// from its edge, 0 to [`super::poisson::MAX_FEATHER`] (0: the paper's eq. 9 alone;
    /// `poisson`'s module docs).
    pub feather: f32,
}

impl BlendBlock {
    /// A block guided by `reference` (finite heights), placed on `rect` (map units).
    pub fn new(name: &str, reference: &Heightfield, rect: [f64; 4]) -> Result<Self, BlendError> {
        if let Some(i) = reference.data().iter().position(|v| !v.is_finite()) {
            return Err(BlendError::ReferenceVoid {
                row: i / reference.width(),
                col: i % reference.width(),
            });
        }
        let (png, _) = png16::write_heightmap(reference).map_err(|e| BlendError::Block {
            index: 0,
            name: name.to_owned(),
            problem: e.to_string(),
        })?;
        Ok(Self {
            name: name.to_owned(),
            reference_png: base64::engine::general_purpose::STANDARD.encode(png),
            rect,
            quarter_turns: 0,
            mirror: false,
            z_scale: 1.0,
            feather: super::poisson::DEFAULT_FEATHER,
        })
    }

    pub fn transform(&self) -> Transform {
        Transform {
            quarter_turns: self.quarter_turns % 4,
            mirror: self.mirror,
            z_scale: self.z_scale,
        }
    }

    /// The reference's cells as its PNG header declares them, read without decoding it
    /// (`None` when the header is not a PNG's; [`BlendBlock::validate`] says why).
    pub fn reference_cells(&self) -> Option<u64> {
        // 32 base64 characters are the first 24 bytes: the signature and IHDR's size.
        let head = self.reference_png.trim().get(..32)?;
        let bytes = base64::engine::general_purpose::STANDARD
            .decode(head)
            .ok()?;
        crate::dem::format::png_size(&bytes).map(|(w, h)| w.saturating_mul(h))
    }

    /// The decoded reference block (before the transform).
    pub fn reference(&self) -> Result<Heightfield, String> {
        let bytes = base64::engine::general_purpose::STANDARD
            .decode(self.reference_png.trim())
            .map_err(|e| format!("reference_png is not base64: {e}"))?;
        png16::read_heightmap(&bytes, None, ReadLimits::default())
            .map(|dem| dem.field)
            .map_err(|e| format!("reference_png: {e}"))
    }

    /// The block's cells on a `width` x `height` terrain: the map-unit rectangle scaled by
    /// `(n - 1)` (vertex-registered, like every map coordinate), rounded, at least 3 x 3.
    pub fn rect_on(&self, width: usize, height: usize) -> BlockRect {
        let cell = |u: f64, n: usize| (u.clamp(0.0, 1.0) * (n.max(1) - 1) as f64).round() as usize;
        let (c0, c1) = (cell(self.rect[0], width), cell(self.rect[2], width));
        let (r0, r1) = (cell(self.rect[1], height), cell(self.rect[3], height));
        BlockRect {
            row: r0.min(r1),
            col: c0.min(c1),
            height: r0.abs_diff(r1) + 1,
            width: c0.abs_diff(c1) + 1,
        }
    }

    /// The transformed reference resampled onto `rect`'s cells: the guidance of the solve.
    pub fn guide(&self, rect: BlockRect) -> Result<Heightfield, BlendError> {
        let reference = self.reference().map_err(|problem| BlendError::Block {
            index: 0,
            name: self.name.clone(),
            problem,
        })?;
        let turned = self.transform().apply(&reference);
        Ok(guide::resample(&turned, rect.width, rect.height))
    }

    /// Checks the values a scene file could get wrong; `Err((field, problem))`.
    pub fn validate(&self) -> Result<(), (&'static str, String)> {
        let [x0, y0, x1, y1] = self.rect;
        if !self
            .rect
            .iter()
            .all(|v| v.is_finite() && (0.0..=1.0).contains(v))
            || x0 >= x1
            || y0 >= y1
        {
            return Err((
                "rect",
                format!(
                    "must be [x0, y0, x1, y1] with 0 <= x0 < x1 <= 1 and 0 <= y0 < y1 <= 1, got {:?}",
                    self.rect
                ),
            ));
        }
        if self.quarter_turns > 3 {
            return Err((
                "quarter_turns",
                format!("must be 0 to 3, got {}", self.quarter_turns),
            ));
        }
        if !(self.z_scale.is_finite() && self.z_scale.abs() <= 100.0) {
            return Err((
                "z_scale",
                format!("must be a number from -100 to 100, got {}", self.z_scale),
            ));
        }
        let max = super::poisson::MAX_FEATHER;
        if !(self.feather.is_finite() && (0.0..=max).contains(&self.feather)) {
            return Err((
                "feather",
                format!("must be a number from 0 to {max}, got {}", self.feather),
            ));
        }
        let reference = self.reference().map_err(|p| ("reference_png", p))?;
        if let Some(i) = reference.data().iter().position(|v| !v.is_finite()) {
            return Err((
                "reference_png",
                format!("has no data at cell {i}; fill voids before placing a block"),
            ));
        }
        Ok(())
    }
}
