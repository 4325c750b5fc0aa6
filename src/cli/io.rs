//! Reading and writing elevation files by extension, for every subcommand.

use std::path::Path;

use crate::dem::{self, Dem, GeoRef, ReadLimits};
use crate::heightfield::Heightfield;

type Result<T> = std::result::Result<T, Box<dyn std::error::Error>>;

fn extension(path: &Path) -> Option<String> {
    path.extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase)
}

/// Reads a DEM: GeoTIFF (`.tif`, `.tiff`) or a greyscale PNG heightmap whose height range
/// comes from `z_range`, its text chunk, or a sidecar `.json` with `zmin`/`zmax`.
pub fn read_dem(path: &Path, limits: ReadLimits, z_range: Option<(f32, f32)>) -> Result<Dem> {
    let bytes = std::fs::read(path).map_err(|e| format!("cannot read {}: {e}", path.display()))?;
    let named = |e: dem::DemError| format!("{}: {e}", path.display());
    match extension(path).as_deref() {
        Some("tif" | "tiff") => Ok(dem::geotiff::read(&bytes, limits).map_err(named)?),
        Some("png") => {
            let range = z_range.or_else(|| sidecar_range(&path.with_extension("json")));
            Ok(dem::png16::read_heightmap(&bytes, range, limits).map_err(named)?)
        }
        _ => Err(format!(
            "{}: unknown elevation format; use .tif/.tiff (GeoTIFF) or .png (greyscale heightmap)",
            path.display()
        )
        .into()),
    }
}

/// `zmin`/`zmax` from a sidecar JSON (as written by `strahler generate` and the shared DEMs).
fn sidecar_range(path: &Path) -> Option<(f32, f32)> {
    let text = std::fs::read_to_string(path).ok()?;
    let json: serde_json::Value = serde_json::from_str(&text).ok()?;
    let get = |k: &str| json.get(k)?.as_f64().map(|v| v as f32);
    Some((get("zmin")?, get("zmax")?))
}

/// Writes `field`: float32 GeoTIFF (`.tif`) with `georef`, or 16-bit PNG (`.png`) with its
/// height range in a text chunk and a sidecar `.json` (with `cell_size_m` when known).
pub fn write_dem(
    path: &Path,
    field: &Heightfield,
    georef: &GeoRef,
    cell_size_m: Option<f64>,
) -> Result<()> {
    let write = |p: &Path, bytes: &[u8]| {
        std::fs::write(p, bytes).map_err(|e| format!("cannot write {}: {e}", p.display()))
    };
    match extension(path).as_deref() {
        Some("tif" | "tiff") => write(path, &dem::geotiff::write(field, georef)?)?,
        Some("png") => {
            let (bytes, (lo, hi)) = dem::png16::write_heightmap(field)?;
            write(path, &bytes)?;
            let meta = serde_json::json!({
                "zmin": lo, "zmax": hi, "width": field.width(), "height": field.height(),
                "cell_size_m": cell_size_m,
                "decode": "z = zmin + v / 65535 * (zmax - zmin)"
            });
            write(
                &path.with_extension("json"),
                serde_json::to_string_pretty(&meta)?.as_bytes(),
            )?;
        }
        _ => {
            return Err(format!(
                "{}: use a .tif (float32 GeoTIFF) or .png (16-bit) file name",
                path.display()
            )
            .into());
        }
    }
    Ok(())
}
