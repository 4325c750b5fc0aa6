//! Reading and writing elevation files by extension, for every subcommand (the formats live
//! in [`crate::dem::format`]).

use std::path::Path;

use crate::dem::format::{self, ExportOptions, Format, ImportOptions};
use crate::dem::sidecar::{self, Sidecar};
use crate::dem::{Dem, DemError, GeoRef, ReadLimits, raw};
use crate::heightfield::Heightfield;

use super::output::Outputs;

type Result<T> = std::result::Result<T, Box<dyn std::error::Error>>;

/// Reads a DEM in any supported format. PNG and RAW heightmaps take their height range from
/// `z_range`, a PNG text chunk, or a sidecar `.json` with `zmin`/`zmax`.
pub fn read_dem(path: &Path, limits: ReadLimits, z_range: Option<(f32, f32)>) -> Result<Dem> {
    read_dem_with(
        path,
        &ImportOptions {
            limits,
            z_range,
            flip_y: false,
        },
    )
}

/// [`read_dem`] with every import option. The file is read through
/// [`format::read_file`] (size checked from its length and header first). A PNG or RAW
/// file's sidecar `.json`, when present, gives the height range (unless `z_range` is given),
/// the file's width and height (a PNG's must match it) and its row order; a malformed
/// sidecar is an error that names it.
pub fn read_dem_with(path: &Path, options: &ImportOptions) -> Result<Dem> {
    let name = path.to_string_lossy();
    let at = |e: DemError| format!("{}: {e}", path.display());
    let format = Format::from_name(&name);
    let bytes = format::read_file(path, options.limits).map_err(at)?;
    let mut options = *options;
    let sidecar = match format {
        Some(Format::Png | Format::R16 | Format::R32) => {
            read_sidecar(&super::output::sidecar_of(path))?
        }
        _ => Sidecar::default(),
    };
    options.z_range = options.z_range.or(sidecar.z_range);
    if format == Some(Format::R32) {
        let flip_y = options.flip_y || sidecar.flip_y == Some(true);
        return Ok(
            crate::dem::raw32::read(&bytes, flip_y, options.limits, sidecar.size).map_err(at)?,
        );
    }
    if format == Some(Format::R16) {
        options.flip_y |= sidecar.flip_y == Some(true);
        return Ok(raw::read_sized(
            &bytes,
            options.z_range,
            options.flip_y,
            options.limits,
            sidecar.size,
        )
        .map_err(at)?);
    }
    let mut dem = format::read(&name, &bytes, &options).map_err(at)?;
    if format == Some(Format::Png) {
        // A sidecar describes its own heightmap: its size must be the PNG's, and a PNG
        // written bottom-up (`flip_y`, for Unity) is read back top-down.
        let (w, h) = (dem.field.width(), dem.field.height());
        if let Some((sw, sh)) = sidecar.size
            && (sw, sh) != (w, h)
        {
            return Err(format!(
                "{}: the sidecar {} says {sw} x {sh} cells, but the PNG holds {w} x {h}: \
                 it belongs to another heightmap (give the range with --z-range and move it \
                 away)",
                path.display(),
                super::output::sidecar_of(path).display()
            )
            .into());
        }
        if sidecar.flip_y == Some(true) {
            dem.field = crate::dem::resize::flipped_y(&dem.field);
        }
    }
    Ok(dem)
}

/// The sidecar at `path`, or nothing said when there is none.
fn read_sidecar(path: &Path) -> Result<Sidecar> {
    if !path.exists() {
        return Ok(Sidecar::default());
    }
    let at = |e: DemError| format!("{}: {e}", path.display());
    let bytes =
        crate::dem::read_bounded(path, sidecar::MAX_BYTES, "a sidecar may take").map_err(at)?;
    Ok(sidecar::parse(&bytes).map_err(at)?)
}

/// Writes `field` in the format of `path`'s extension; PNG and RAW also get a sidecar `.json`.
/// `path` must have been claimed with [`Outputs::claim_dem`]; both files are written atomically.
pub fn write_dem(
    outputs: &Outputs,
    path: &Path,
    field: &Heightfield,
    georef: &GeoRef,
    cell_size_m: Option<f64>,
) -> Result<()> {
    write_dem_with(
        outputs,
        path,
        field,
        georef,
        &ExportOptions {
            cell_size: cell_size_m
                .or_else(|| georef.cell_size_m(field.height()).map(|c| c.0))
                .unwrap_or(1.0),
            ..Default::default()
        },
    )
}

/// [`write_dem`] with every export option. Everything is encoded (and every check on the
/// values made) before the first byte is written.
pub fn write_dem_with(
    outputs: &Outputs,
    path: &Path,
    field: &Heightfield,
    georef: &GeoRef,
    options: &ExportOptions,
) -> Result<()> {
    let out = format::write(output_format(path)?, field, georef, options)
        .map_err(|e| format!("{}: {e}", path.display()))?;
    write_exported(outputs, path, &out)
}

/// The heightmap format `path`'s extension names.
pub fn output_format(path: &Path) -> Result<Format> {
    Format::from_name(&path.to_string_lossy()).ok_or_else(|| {
        format!(
            "{}: unknown output format; use .tif, .png, .r16, .r32, .exr, .asc, .hgt or .obj",
            path.display()
        )
        .into()
    })
}

/// Writes an encoded heightmap to `path`, and its sidecar (the height range of PNG and RAW
/// files) beside it.
pub fn write_exported(outputs: &Outputs, path: &Path, out: &format::Exported) -> Result<()> {
    outputs.write(path, &out.bytes)?;
    if let Some(json) = &out.sidecar {
        outputs.write(&super::output::sidecar_of(path), json.as_bytes())?;
    }
    Ok(())
}
