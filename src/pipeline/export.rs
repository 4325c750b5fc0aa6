//! What leaves the pipeline as files, shared by the app's export dialog, the page's
//! `exportHeightmap` and `strahler generate`: the heightmap in a chosen format, and the layer
//! pictures.

use crate::dem::GeoRef;
use crate::dem::format::{self, ExportOptions, Exported, Format};
use crate::heightfield::Heightfield;

use super::Output;

/// A layer picture: its file name and PNG bytes.
pub type LayerPng = (&'static str, Vec<u8>);

/// How a heightmap is exported (what the dialog and `exportHeightmap` ask for).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HeightmapExport {
    pub format: Format,
    /// `None`: the terrain's own size.
    pub size: Option<usize>,
    pub flip_y: bool,
    /// Multiplies every height (the scene's vertical scale times the export's own).
    pub z_scale: f32,
}

/// Encodes `field` (cells of `cell` metres) as `export` asks, georeferenced as a local metric
/// grid with its north-west corner at (0, 0).
pub fn encode_heightmap(
    field: &Heightfield,
    cell: f64,
    export: &HeightmapExport,
) -> Result<Exported, String> {
    let georef = GeoRef {
        pixel_scale: Some(vec![cell, cell, 0.0]),
        tiepoint: Some(vec![0.0, 0.0, 0.0, 0.0, cell * field.height() as f64, 0.0]),
        ..Default::default()
    };
    let options = ExportOptions {
        size: export.size,
        flip_y: export.flip_y,
        z_scale: export.z_scale,
        cell_size: cell,
    };
    format::write(export.format, field, &georef, &options).map_err(|e| e.to_string())
}

impl Output {
    /// The skeleton's layers (`rivers.png`, `ridges.png`, `constraints.png`) and, with
    /// erosion, `drainage_area.png` (log scale) and `erosion_depth.png`.
    pub fn layer_pngs(&self) -> Result<Vec<LayerPng>, String> {
        let mut layers =
            crate::terrain::layer_pngs(&self.hydrology.skeleton).map_err(|e| e.to_string())?;
        if let Some(eroded) = &self.erosion {
            layers.extend(
                crate::erosion::layer_pngs(eroded, &self.hydrology.terrain)
                    .map_err(|e| e.to_string())?,
            );
        }
        Ok(layers)
    }
}
