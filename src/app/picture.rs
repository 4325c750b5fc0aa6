//! The map's picture of the final terrain: its shaded relief and contour lines, drawn as a
//! job. Both are O(cells) (the relief about 0.4 s at 2048^2 in the browser), so they must not
//! hold the UI thread when a large terrain arrives; natively the job has a thread, in the
//! browser it draws in bands of rows and yields between them.

use std::sync::Arc;

use egui::{ColorImage, Pos2};

use super::layers;
use super::relief::shaded_relief_stepped;
use crate::heightfield::Heightfield;
use crate::jobs::{Cancelled, JobCtx};

/// A terrain with what the map draws of it.
#[derive(Clone)]
pub struct Picture {
    pub field: Arc<Heightfield>,
    pub relief: ColorImage,
    /// Contour segments (map units), every "nice" interval for the height range.
    pub contours: Vec<(Pos2, Pos2)>,
}

/// Draws `field` within a job (yielding between bands of rows).
pub async fn draw(
    field: Arc<Heightfield>,
    cell_size: f32,
    job: &JobCtx,
) -> Result<Picture, Cancelled> {
    let relief = shaded_relief_stepped(&field, cell_size, job).await?;
    let contours = contours(&field);
    Ok(Picture {
        field,
        relief,
        contours,
    })
}

/// Contour lines of `field` at a "nice" interval for its height range.
fn contours(field: &Heightfield) -> Vec<(Pos2, Pos2)> {
    match field.finite_range() {
        Some((lo, hi)) => layers::contours(field, layers::contour_interval(hi - lo)),
        None => Vec::new(),
    }
}
