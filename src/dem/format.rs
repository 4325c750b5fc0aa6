//! Every elevation format by name: which reader or writer a file name selects, and the
//! options the export dialog and `strahler convert` share (size preset, Y flip, z scale).

use super::{Dem, DemError, GeoRef, ReadLimits, asc, geotiff, hgt, obj, png16, raw, resize};
use crate::heightfield::Heightfield;

/// A file format.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Format {
    /// Float32 GeoTIFF (reads int16/uint16/int32/float32/float64 too).
    GeoTiff,
    /// 16-bit greyscale PNG (reads 8-bit too), range in a text chunk and a sidecar JSON.
    Png,
    /// RAW R16, little-endian, range in a sidecar JSON.
    R16,
    /// ESRI ASCII grid.
    Asc,
    /// SRTM tile.
    Hgt,
    /// Wavefront OBJ mesh (export only).
    Obj,
}

impl Format {
    /// Formats the export dialog offers, in its order.
    pub const EXPORTS: [Format; 6] = [
        Format::Png,
        Format::GeoTiff,
        Format::R16,
        Format::Asc,
        Format::Obj,
        Format::Hgt,
    ];

    /// From a file name's extension (any case).
    pub fn from_name(name: &str) -> Option<Format> {
        let ext = name.rsplit_once('.')?.1.to_ascii_lowercase();
        Self::from_key(&ext)
    }

    /// From a short key or extension: `png`, `tif`/`tiff`/`geotiff`, `r16`/`raw`, `asc`,
    /// `hgt`, `obj`.
    pub fn from_key(key: &str) -> Option<Format> {
        Some(match key.to_ascii_lowercase().as_str() {
            "tif" | "tiff" | "geotiff" => Format::GeoTiff,
            "png" => Format::Png,
            "r16" | "raw" => Format::R16,
            "asc" => Format::Asc,
            "hgt" => Format::Hgt,
            "obj" => Format::Obj,
            _ => return None,
        })
    }

    /// The file extension written.
    pub fn extension(self) -> &'static str {
        match self {
            Format::GeoTiff => "tif",
            Format::Png => "png",
            Format::R16 => "r16",
            Format::Asc => "asc",
            Format::Hgt => "hgt",
            Format::Obj => "obj",
        }
    }

    /// What the export dialog shows.
    pub fn label(self) -> &'static str {
        match self {
            Format::GeoTiff => "GeoTIFF float32 (GIS)",
            Format::Png => "PNG 16-bit (engines, editors)",
            Format::R16 => "RAW R16 (Unity, World Machine)",
            Format::Asc => "ESRI ASCII grid (GIS)",
            Format::Hgt => "SRTM .hgt (whole metres)",
            Format::Obj => "OBJ mesh (Blender, 3D tools)",
        }
    }

    pub fn mime(self) -> &'static str {
        match self {
            Format::GeoTiff => "image/tiff",
            Format::Png => "image/png",
            Format::Asc | Format::Obj => "text/plain",
            Format::R16 | Format::Hgt => "application/octet-stream",
        }
    }

    /// Whether the file needs the height range from elsewhere (a sidecar or the user).
    pub fn needs_range(self) -> bool {
        matches!(self, Format::R16)
    }
}

/// How to read.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ImportOptions {
    pub limits: ReadLimits,
    /// Height range for PNG and RAW files that do not carry one.
    pub z_range: Option<(f32, f32)>,
    /// RAW files written bottom-up (Unity).
    pub flip_y: bool,
}

/// Reads `bytes` as the format `name`'s extension says.
pub fn read(name: &str, bytes: &[u8], options: &ImportOptions) -> Result<Dem, DemError> {
    match Format::from_name(name) {
        Some(Format::GeoTiff) => geotiff::read(bytes, options.limits),
        Some(Format::Png) => png16::read_heightmap(bytes, options.z_range, options.limits),
        Some(Format::R16) => raw::read(bytes, options.z_range, options.flip_y, options.limits),
        Some(Format::Asc) => asc::read(bytes, options.limits),
        Some(Format::Hgt) => hgt::read(name, bytes, options.limits),
        Some(Format::Obj) | None => Err(DemError::UnknownFormat(name.to_owned())),
    }
}

/// The sizes the export dialog offers besides the terrain's own.
pub const SIZE_PRESETS: [usize; 11] =
    [257, 513, 1025, 2049, 4097, 8193, 256, 512, 1024, 2048, 4096];

/// How to write.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ExportOptions {
    /// Resample to `size x size` cells (corners kept), or keep the terrain's size.
    pub size: Option<usize>,
    /// Write rows bottom-up (PNG and RAW; georeferenced formats stay north-up).
    pub flip_y: bool,
    /// Multiplies the heights.
    pub z_scale: f32,
    /// Horizontal cell size in metres at the terrain's own size, for formats without
    /// georeferencing (OBJ, ASCII, the sidecar).
    pub cell_size: f64,
}

impl Default for ExportOptions {
    fn default() -> Self {
        Self {
            size: None,
            flip_y: false,
            z_scale: 1.0,
            cell_size: 1.0,
        }
    }
}

/// A written file: its bytes, and a sidecar JSON (height range, size, cell size) for the
/// formats that need one.
#[derive(Clone, Debug, PartialEq)]
pub struct Exported {
    pub bytes: Vec<u8>,
    pub sidecar: Option<String>,
}

/// Writes `field` in `format`.
pub fn write(
    format: Format,
    field: &Heightfield,
    georef: &GeoRef,
    options: &ExportOptions,
) -> Result<Exported, DemError> {
    if !(options.z_scale.is_finite() && options.z_scale != 0.0) {
        return Err(DemError::Write(format!(
            "the z scale must be a non-zero number, got {}",
            options.z_scale
        )));
    }
    let (mut out, georef, cell) = match options.size {
        Some(n) if (n, n) != (field.width(), field.height()) => {
            if !(2..=8193).contains(&n) {
                return Err(DemError::Write(format!(
                    "the export size must be 2 to 8193 cells, got {n}"
                )));
            }
            let fx = (n - 1) as f64 / (field.width().max(2) - 1) as f64;
            let fy = (n - 1) as f64 / (field.height().max(2) - 1) as f64;
            (
                resize::resample_corners(field, n, n),
                georef.resampled(fx, fy),
                options.cell_size / fx,
            )
        }
        _ => (field.clone(), georef.clone(), options.cell_size),
    };
    if options.z_scale != 1.0 {
        out.data_mut()
            .iter_mut()
            .for_each(|z| *z *= options.z_scale);
    }
    if options.flip_y && matches!(format, Format::Png) {
        out = resize::flipped_y(&out);
    }
    let sidecar = |range: (f32, f32)| {
        format!(
            "{{\n  \"zmin\": {},\n  \"zmax\": {},\n  \"width\": {},\n  \"height\": {},\n  \
             \"cell_size_m\": {},\n  \"flip_y\": {},\n  \"decode\": \"z = zmin + v / 65535 * (zmax - zmin)\"\n}}\n",
            range.0,
            range.1,
            out.width(),
            out.height(),
            cell,
            options.flip_y
        )
    };
    Ok(match format {
        Format::GeoTiff => Exported {
            bytes: geotiff::write(&out, &georef)?,
            sidecar: None,
        },
        Format::Png => {
            let (bytes, range) = png16::write_heightmap(&out)?;
            Exported {
                bytes,
                sidecar: Some(sidecar(range)),
            }
        }
        Format::R16 => {
            let (bytes, range) = raw::write(&out, options.flip_y);
            Exported {
                bytes,
                sidecar: Some(sidecar(range)),
            }
        }
        Format::Asc => Exported {
            bytes: asc::write(&out, &georef, cell),
            sidecar: None,
        },
        Format::Hgt => Exported {
            bytes: hgt::write(&out)?,
            sidecar: None,
        },
        Format::Obj => Exported {
            bytes: obj::write(&out, cell)?,
            sidecar: None,
        },
    })
}
