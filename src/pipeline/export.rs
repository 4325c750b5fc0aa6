//! What leaves the pipeline as files, shared by the app's export dialog, the page's
//! `exportHeightmap` and `strahler generate`: the heightmap in a chosen format, the layer
//! pictures, and engine exports (`crate::export`: presets, tiles, texture maps, GeoJSON).

use std::sync::Arc;

use crate::dem::format::{self, ExportOptions, Exported, Format};
use crate::heightfield::Heightfield;
use crate::jobs::JobCtx;
use crate::scene::Scene;

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
    /// The map's centre on Earth, `[lon, lat]` (the scene's location): georeferenced in its
    /// UTM zone.
    pub centre_lonlat: Option<[f64; 2]>,
}

/// Encodes `field` (cells of `cell` metres) as `export` asks, georeferenced in the UTM zone
/// of its location, or as a local metric grid with its south-west corner at (0, 0).
pub fn encode_heightmap(
    field: &Heightfield,
    cell: f64,
    export: &HeightmapExport,
) -> Result<Exported, String> {
    crate::jobs::run_inline(
        |ctx| async move { encode_heightmap_in(field, cell, export, &ctx).await },
    )
}

/// [`encode_heightmap`] in a job: every row ticks (`format::write_in`).
pub async fn encode_heightmap_in(
    field: &Heightfield,
    cell: f64,
    export: &HeightmapExport,
    ctx: &JobCtx,
) -> Result<Exported, String> {
    let width_m = cell * field.width() as f64;
    let georef = crate::export::map_georef(export.centre_lonlat, width_m, cell, 0.0, 0.0);
    let options = ExportOptions {
        size: export.size,
        flip_y: export.flip_y,
        z_scale: export.z_scale,
        cell_size: cell,
        z_range: None,
    };
    format::write_in(export.format, field, &georef, &options, ctx)
        .await
        .map_err(|e| e.to_string())
}

impl Output {
    /// What an engine export of this terrain reads, owned so a job can take it
    /// ([`ExportSource::files`]): the scene gives its splat-map rules and its place on Earth.
    pub fn export_source(&self, scene: &Scene) -> ExportSource {
        ExportSource {
            field: self.field.clone(),
            cell_m: self.cell_m,
            networks: self
                .hydrology
                .rivers
                .iter()
                .map(|r| r.network.clone())
                .collect(),
            ridges: self.hydrology.ridges.clone(),
            skeleton_cells: self.hydrology.skeleton.size,
            river_courses: self.hydrology.skeleton.courses.clone(),
            base: Arc::new(self.base().clone()),
            lowered: self
                .erosion
                .as_ref()
                .map(|e| e.depth(&self.hydrology.terrain)),
            splat: scene.textures.splat(),
            centre_lonlat: scene.location.map(|l| [l.lon, l.lat]),
        }
    }

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

/// An engine export's inputs (see [`Output::export_source`]).
#[derive(Clone, Debug)]
pub struct ExportSource {
    field: Arc<Heightfield>,
    cell_m: f64,
    networks: Vec<crate::river::RiverNetwork>,
    ridges: Vec<crate::ridge::RidgeSegment>,
    skeleton_cells: usize,
    river_courses: Vec<crate::skeleton::RiverPiece>,
    /// The terrain before detail and blocks, on the skeleton's grid.
    base: Arc<Heightfield>,
    lowered: Option<Vec<f32>>,
    splat: crate::export::SplatRules,
    centre_lonlat: Option<[f64; 2]>,
}

impl ExportSource {
    /// Every file of `request` (`crate::export::files`), with progress and cancellation
    /// through `ctx`.
    pub async fn files(
        &self,
        request: &crate::export::Request,
        ctx: &JobCtx,
    ) -> Result<Vec<crate::export::File>, String> {
        let n = self.skeleton_cells;
        let skeleton_cell =
            self.cell_m * (self.field.width().max(2) - 1) as f64 / (n.max(2) - 1) as f64;
        // Drainage area on the skeleton's grid by D8 over the terrain before detail, for the
        // rivers' GeoJSON (the erosion's own area treats the rivers as base level: they
        // gather nothing).
        let area: Vec<f32> = if request.rivers {
            ctx.checkpoint(0.0, "exporting: routing water")
                .await
                .map_err(|_| "cancelled".to_owned())?;
            let part = ctx.part(0.0, RIVERS_SHARE);
            let base = self.base.data();
            crate::realism::drainage_area_m2_with_sinks_in(base, n, n, skeleton_cell, &[], &part)
                .await
                .map_err(|_| "cancelled".to_owned())?
                .map(|a| a.into_iter().map(|v| v as f32).collect())
                .unwrap_or_else(|| vec![0.0; n * n])
        } else {
            Vec::new()
        };
        let inputs = crate::export::Inputs {
            field: &self.field,
            cell_m: self.cell_m,
            networks: &self.networks,
            ridges: &self.ridges,
            skeleton_cells: n,
            river_courses: &self.river_courses,
            area_m2: &area,
            lowered: self.lowered.as_deref(),
            splat: self.splat,
            georef: None,
            centre_lonlat: self.centre_lonlat,
        };
        let rest = if request.rivers {
            ctx.part(RIVERS_SHARE, 1.0)
        } else {
            ctx.clone()
        };
        crate::export::files(&inputs, request, &rest).await
    }
}

/// The share of an export's bar the rivers' routing takes, when asked for.
const RIVERS_SHARE: f32 = 0.1;
