//! A finished run, with what the map shows of it prepared in the job (O(cells) work kept off
//! the UI thread).

use crate::diffusion::selftest::RunSummary;
use crate::pipeline::{Output, Pipeline, PipelineError};

use super::picture::Picture;

/// A finished run with what the UI shows of it, prepared in the job (O(cells), so not on
/// the UI thread), and the updated stage cache.
pub struct Arrived {
    pub pipeline: Pipeline,
    pub output: Output,
    pub shown: Box<Shown>,
}

/// What the map shows of a finished run.
pub struct Shown {
    /// The skeleton's cells as an overlay image.
    pub constraints: egui::ColorImage,
    pub summary: RunSummary,
    /// The map's picture of the final terrain.
    pub picture: Picture,
    /// With erosion: the picture of the terrain before it.
    pub before: Option<Picture>,
    /// With erosion: its drainage-area and erosion-depth overlays.
    pub erosion_layers: Option<[egui::ColorImage; 2]>,
}

impl Arrived {
    pub async fn prepare(
        pipeline: Pipeline,
        output: Output,
        job: &crate::jobs::JobCtx,
    ) -> Result<Self, PipelineError> {
        job.tick(1.0, "preparing the map").await?;
        let g = &output.hydrology;
        let (w, h) = (g.terrain.width(), g.terrain.height());
        let constraints = super::layers::constraints_image(&g.skeleton.kinds, w, h);
        job.tick(1.0, "preparing the map").await?;
        // The diffusion stage's numbers, with the checksum and range of the terrain on the map
        // (after every stage): the one `strahler generate` reports for the same scene.
        let mut summary = crate::terrain::run_summary(g);
        let r = &output.report.terrain;
        summary.checksum = r.checksum.clone();
        [summary.min, summary.max] = r.height_range;
        let picture = super::picture::draw(output.field.clone(), output.cell_m as f32, job).await?;
        let before = match &output.erosion {
            Some(_) => {
                let cell = output.cell_m * output.field.width() as f64
                    / output.hydrology.terrain.width() as f64;
                let field = output.hydrology.terrain.clone();
                Some(super::picture::draw(field, cell as f32, job).await?)
            }
            None => None,
        };
        job.tick(1.0, "preparing the map").await?;
        let erosion_layers = output
            .erosion
            .as_ref()
            .map(|e| super::layers::erosion_images(e, &output.hydrology.terrain));
        Ok(Self {
            pipeline,
            output,
            shown: Box::new(Shown {
                constraints,
                summary,
                picture,
                before,
                erosion_layers,
            }),
        })
    }
}
