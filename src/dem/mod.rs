//! Real elevation rasters in and out: GeoTIFF, SRTM `.hgt`, ESRI ASCII grids, PNG and RAW
//! heightmaps, and OBJ meshes, all behind the same [`Dem`] type; [`format`] picks one by
//! file name.
//!
//! Every reader checks the size from the header against [`ReadLimits`] before allocating,
//! turns no-data into NaN, and returns a [`DemError`] that says what is wrong; no panic is
//! reachable from a file's bytes.

pub mod asc;
pub mod format;
pub mod geotiff;
pub mod hgt;
pub mod hillshade;
pub mod obj;
pub mod png16;
pub mod raw;
pub mod resize;

use thiserror::Error;

use crate::heightfield::Heightfield;

/// Why a file could not be read or written.
#[derive(Debug, Error)]
pub enum DemError {
    #[error(
        "{width} x {height} cells exceed the limit of {limit} cells (raise it with --max-cells)"
    )]
    TooLarge { width: u64, height: u64, limit: u64 },
    #[error("not a readable GeoTIFF: {0}")]
    Tiff(String),
    #[error("unsupported GeoTIFF layout: {0}")]
    Unsupported(String),
    #[error("the file has no cells")]
    Empty,
    #[error("not a readable PNG: {0}")]
    Png(String),
    #[error("could not write the file: {0}")]
    Write(String),
    #[error("not a readable {format}: {problem}")]
    Malformed {
        format: &'static str,
        problem: String,
    },
    #[error(
        "{0}: unknown elevation format; use .tif/.tiff (GeoTIFF), .hgt (SRTM), .asc (ESRI \
         ASCII grid), .png (greyscale heightmap) or .r16/.raw (RAW 16-bit)"
    )]
    UnknownFormat(String),
}

/// Size limit checked before any allocation.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ReadLimits {
    /// Largest `width * height` accepted. The default, 8192^2 (256 MiB as `f32`), is what a
    /// browser tab can hold alongside the pipeline's buffers.
    pub max_cells: u64,
}

impl Default for ReadLimits {
    fn default() -> Self {
        Self {
            max_cells: 8192 * 8192,
        }
    }
}

impl ReadLimits {
    pub fn check(&self, width: u64, height: u64) -> Result<(), DemError> {
        if width == 0 || height == 0 {
            return Err(DemError::Empty);
        }
        match width.checked_mul(height) {
            Some(cells) if cells <= self.max_cells => Ok(()),
            _ => Err(DemError::TooLarge {
                width,
                height,
                limit: self.max_cells,
            }),
        }
    }
}

/// GeoTIFF georeferencing, kept verbatim so a written file lands where the read one was.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct GeoRef {
    /// ModelPixelScale (33550): cell size in x, y, z.
    pub pixel_scale: Option<Vec<f64>>,
    /// ModelTiepoint (33922): raster point to model point.
    pub tiepoint: Option<Vec<f64>>,
    /// ModelTransformation (34264): a full affine matrix, instead of scale + tiepoint.
    pub transformation: Option<Vec<f64>>,
    /// GeoKeyDirectory (34735), GeoDoubleParams (34736), GeoAsciiParams (34737): the CRS.
    pub geo_keys: Option<Vec<u16>>,
    pub geo_doubles: Option<Vec<f64>>,
    pub geo_ascii: Option<String>,
}

impl GeoRef {
    /// The georeferencing of a vertex-preserving refinement by `factor` (wavelet levels of
    /// detail): the cell size divides by `factor` and cell (0, 0) keeps its centre, so the
    /// raster's outer corner moves in by half the difference of the old and new cell sizes
    /// (GeoTIFF's default PixelIsArea convention).
    pub fn refined(&self, factor: f64) -> Self {
        self.resampled(factor, factor)
    }

    /// [`GeoRef::refined`] with separate factors for x and y (an export size preset on a
    /// non-square raster): cell sizes divide by `fx`, `fy`; cell (0, 0) keeps its centre.
    pub fn resampled(&self, fx: f64, fy: f64) -> Self {
        let mut out = self.clone();
        if let (Some(scale), Some(tie)) = (&mut out.pixel_scale, &mut out.tiepoint) {
            if scale.len() >= 2 && tie.len() >= 6 && tie[0] == 0.0 && tie[1] == 0.0 {
                let (sx, sy) = (scale[0], scale[1]);
                scale[0] = sx / fx;
                scale[1] = sy / fy;
                tie[3] += (sx - scale[0]) / 2.0;
                tie[4] -= (sy - scale[1]) / 2.0;
            } else if scale.len() >= 2 {
                scale[0] /= fx;
                scale[1] /= fy;
            }
        }
        if let Some(m) = &mut out.transformation
            && m.len() >= 16
        {
            // Rows (x, y, z, 1) of a 4x4 matrix: raster (i, j) columns 0 and 1.
            let (a, b, e, f) = (m[0], m[1], m[4], m[5]);
            m[0] /= fx;
            m[1] /= fy;
            m[4] /= fx;
            m[5] /= fy;
            m[3] += (a - m[0]) / 2.0 + (b - m[1]) / 2.0;
            m[7] += (e - m[4]) / 2.0 + (f - m[5]) / 2.0;
        }
        out
    }

    /// The CRS as `EPSG:code` from the GeoKey directory (projected or geographic), when the
    /// file says.
    pub fn crs_label(&self) -> Option<String> {
        let keys = self.geo_keys.as_ref()?;
        // Header of 4 shorts, then (key, location, count, value) entries.
        let entries = keys.get(4..)?.chunks_exact(4);
        let mut geographic = None;
        for e in entries {
            match (e[0], e[1]) {
                (3072, 0) if e[3] != 0 && e[3] != 32767 => {
                    return Some(format!("EPSG:{}", e[3]));
                }
                (2048, 0) if e[3] != 0 && e[3] != 32767 => geographic = Some(e[3]),
                _ => {}
            }
        }
        geographic
            .map(|c| format!("EPSG:{c}"))
            .or_else(|| self.geo_ascii.clone().filter(|a| !a.trim().is_empty()))
    }

    /// Horizontal cell size in metres: the CRS's units, or for a geographic CRS (degrees,
    /// any EPSG:4xxx code) the degrees converted at the raster's latitude (WGS 84 mean
    /// radius). `None` where the file gives no cell size.
    pub fn cell_size_m(&self, rows: usize) -> Option<(f64, f64)> {
        let (cx, cy) = self.cell_size()?;
        let geographic = self.crs_label().is_some_and(|c| c.starts_with("EPSG:4"));
        if !geographic {
            return Some((cx, cy));
        }
        let top = self
            .tiepoint
            .as_ref()
            .filter(|t| t.len() >= 6)
            .map(|t| t[4])?;
        let lat = (top - cy * rows as f64 / 2.0).to_radians();
        let metres_per_degree = 6_371_008.8 * std::f64::consts::PI / 180.0;
        Some((cx * metres_per_degree * lat.cos(), cy * metres_per_degree))
    }

    /// Horizontal cell size in the CRS's units, when the file says.
    pub fn cell_size(&self) -> Option<(f64, f64)> {
        let s = self.pixel_scale.as_ref()?;
        (s.len() >= 2 && s[0] > 0.0 && s[1] > 0.0).then(|| (s[0], s[1]))
    }
}

/// An elevation raster: heights (NaN where there is no data) and where they are.
#[derive(Clone, Debug)]
pub struct Dem {
    pub field: Heightfield,
    pub georef: GeoRef,
}

impl Dem {
    /// Number of no-data (NaN) cells.
    pub fn void_cells(&self) -> usize {
        self.field.data().iter().filter(|v| v.is_nan()).count()
    }
}
