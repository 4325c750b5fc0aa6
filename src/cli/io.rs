//! Reading and writing elevation files by extension, for every subcommand (the formats live
//! in [`crate::dem::format`]).

use std::path::Path;

use crate::dem::format::{self, ExportOptions, Format, ImportOptions};
use crate::dem::{Dem, GeoRef, ReadLimits};
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

/// [`read_dem`] with every import option.
pub fn read_dem_with(path: &Path, options: &ImportOptions) -> Result<Dem> {
    let bytes = std::fs::read(path).map_err(|e| format!("cannot read {}: {e}", path.display()))?;
    let name = path.to_string_lossy();
    let mut options = *options;
    if options.z_range.is_none() {
        let sidecar = sidecar_json(&path.with_extension("json"));
        options.z_range = sidecar.as_ref().and_then(|j| {
            let get = |k: &str| j.get(k)?.as_f64().map(|v| v as f32);
            Some((get("zmin")?, get("zmax")?))
        });
        if Format::from_name(&name) == Some(Format::R16)
            && let Some(flip) = sidecar.as_ref().and_then(|j| j.get("flip_y")?.as_bool())
        {
            options.flip_y = flip;
        }
    }
    Ok(format::read(&name, &bytes, &options).map_err(|e| format!("{}: {e}", path.display()))?)
}

fn sidecar_json(path: &Path) -> Option<serde_json::Value> {
    serde_json::from_str(&std::fs::read_to_string(path).ok()?).ok()
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
                .or_else(|| georef.cell_size().map(|c| c.0))
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
    let name = path.to_string_lossy();
    let format = Format::from_name(&name).ok_or_else(|| {
        format!(
            "{}: unknown output format; use .tif, .png, .r16, .asc, .hgt or .obj",
            path.display()
        )
    })?;
    let out = format::write(format, field, georef, options)
        .map_err(|e| format!("{}: {e}", path.display()))?;
    outputs.write(path, &out.bytes)?;
    if let Some(json) = &out.sidecar {
        outputs.write(&super::output::sidecar_of(path), json.as_bytes())?;
    }
    Ok(())
}
