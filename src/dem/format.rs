//! Every elevation format by name: which reader or writer a file name selects, and the
//! options the export dialog and `strahler convert` share (size preset, Y flip, z scale).

use super::{
    Dem, DemError, GeoRef, ReadLimits, asc, exr, geotiff, hgt, obj, png16, raw, raw32, resize,
};
use std::borrow::Cow;

use crate::heightfield::Heightfield;
use crate::jobs::JobCtx;

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
    /// OpenEXR, one 32-bit float channel of metres.
    Exr,
    /// RAW R32: little-endian 32-bit floats in metres, size in a sidecar JSON.
    R32,
}

impl Format {
    /// Formats the export dialog offers, in its order.
    pub const EXPORTS: [Format; 8] = [
        Format::Png,
        Format::GeoTiff,
        Format::R16,
        Format::Exr,
        Format::R32,
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
    /// `hgt`, `obj`, `exr`, `r32`.
    pub fn from_key(key: &str) -> Option<Format> {
        Some(match key.to_ascii_lowercase().as_str() {
            "tif" | "tiff" | "geotiff" => Format::GeoTiff,
            "png" => Format::Png,
            "r16" | "raw" => Format::R16,
            "asc" => Format::Asc,
            "hgt" => Format::Hgt,
            "obj" => Format::Obj,
            "exr" => Format::Exr,
            "r32" => Format::R32,
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
            Format::Exr => "exr",
            Format::R32 => "r32",
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
            Format::Exr => "OpenEXR float32 (Godot, Gaea, Houdini)",
            Format::R32 => "RAW R32 float (Gaea, World Machine)",
        }
    }

    pub fn mime(self) -> &'static str {
        match self {
            Format::GeoTiff => "image/tiff",
            Format::Png => "image/png",
            Format::Asc | Format::Obj => "text/plain",
            Format::Exr => "image/x-exr",
            Format::R16 | Format::Hgt | Format::R32 => "application/octet-stream",
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
    if bytes.is_empty() && Format::from_name(name).is_some() {
        return Err(DemError::EmptyFile);
    }
    match Format::from_name(name) {
        Some(Format::GeoTiff) => geotiff::read(bytes, options.limits),
        Some(Format::Png) => png16::read_heightmap(bytes, options.z_range, options.limits),
        Some(Format::R16) => raw::read(bytes, options.z_range, options.flip_y, options.limits),
        Some(Format::Asc) => asc::read(bytes, options.limits),
        Some(Format::Hgt) => hgt::read(name, bytes, options.limits),
        Some(Format::Exr) => exr::read(bytes, options.limits),
        Some(Format::R32) => raw32::read(bytes, options.flip_y, options.limits, None),
        Some(Format::Obj) | None => Err(DemError::UnknownFormat(name.to_owned())),
    }
}

impl Format {
    /// The format's name in messages.
    pub fn name(self) -> &'static str {
        match self {
            Format::GeoTiff => "GeoTIFF",
            Format::Png => "PNG heightmap",
            Format::R16 => "RAW R16 file",
            Format::Asc => "ESRI ASCII grid",
            Format::Hgt => "SRTM .hgt tile",
            Format::Obj => "OBJ mesh",
            Format::Exr => "OpenEXR file",
            Format::R32 => "RAW R32 file",
        }
    }

    /// The most bytes one cell can take in a file of this format (uncompressed float64
    /// GeoTIFF with tile padding; a 16-bit PNG with alpha, stored uncompressed; 16-bit
    /// samples; a long decimal number and its separator in an ASCII grid).
    pub fn max_bytes_per_cell(self) -> u64 {
        match self {
            Format::GeoTiff => 16,
            Format::Png => 8,
            Format::R16 | Format::Hgt => 2,
            Format::Asc => 40,
            Format::R32 => 4,
            // ZIP blocks that did not shrink are stored: 4 bytes a cell plus offsets.
            Format::Exr => 8,
            Format::Obj => 0,
        }
    }
}

/// The checks on a file's length made before it is read, by the page's file inputs as by
/// [`read_file`]: not empty, and no longer than a file of its format within `limits` can be
/// (a 3 GB file is refused before the browser reads it into memory).
pub fn check_length(name: &str, len: u64, limits: ReadLimits) -> Result<(), DemError> {
    let format = Format::from_name(name)
        .filter(|f| *f != Format::Obj)
        .ok_or_else(|| DemError::UnknownFormat(name.to_owned()))?;
    if len == 0 {
        return Err(DemError::EmptyFile);
    }
    let limit = limits.max_file_bytes(format.max_bytes_per_cell());
    if len > limit {
        return Err(DemError::FileTooLarge {
            bytes: len,
            limit,
            why: format!(
                "{}s of at most {} cells can take",
                format.name(),
                limits.max_cells
            ),
        });
    }
    Ok(())
}

/// Reads the elevation file at `path` (format by its name) with every check made before the
/// whole file is read: a regular file; its length within what `limits` allows for the format;
/// the size the header declares (PNG, GeoTIFF, ASCII grid) within `limits`, and the length
/// within what that size can take plus [`super::HEADER_SLACK`].
pub fn read_file(path: &std::path::Path, limits: ReadLimits) -> Result<Vec<u8>, DemError> {
    use std::io::{Read as _, Seek as _, SeekFrom};
    let name = path.to_string_lossy();
    let format = Format::from_name(&name)
        .filter(|f| *f != Format::Obj)
        .ok_or_else(|| DemError::UnknownFormat(name.clone().into_owned()))?;
    let io = |e: std::io::Error| DemError::Io(e.to_string());
    let mut file = super::open_regular(path)?;
    let cap = limits.max_file_bytes(format.max_bytes_per_cell());
    let why = format!(
        "{}s of at most {} cells (--max-cells) can take",
        format.name(),
        limits.max_cells
    );
    let len = super::checked_len(&file, cap, &why)?;
    if len == 0 {
        return Err(DemError::EmptyFile);
    }
    // The size the header declares, when the format has a header.
    let declared = match format {
        Format::Png | Format::Asc => {
            let mut head = Vec::new();
            (&mut file).take(4096).read_to_end(&mut head).map_err(io)?;
            if format == Format::Png {
                png_size(&head)
            } else {
                asc_size(&head)
            }
        }
        Format::GeoTiff => {
            let reader = std::io::BufReader::new(&mut file);
            tiff::decoder::Decoder::new(reader)
                .and_then(|mut d| d.dimensions())
                .ok()
                .map(|(w, h)| (u64::from(w), u64::from(h)))
        }
        _ => None,
    };
    let limit = match declared {
        Some((w, h)) => {
            limits.check(w, h)?;
            let limit = (w * h)
                .saturating_mul(format.max_bytes_per_cell())
                .saturating_add(super::HEADER_SLACK);
            if len > limit {
                return Err(DemError::FileTooLarge {
                    bytes: len,
                    limit,
                    why: format!("a {w} x {h} {} (its header's size) can take", format.name()),
                });
            }
            limit
        }
        None => cap,
    };
    file.seek(SeekFrom::Start(0)).map_err(io)?;
    super::read_rest(&mut file, len, limit, &why)
}

/// Width and height from a PNG's IHDR chunk.
pub(crate) fn png_size(head: &[u8]) -> Option<(u64, u64)> {
    if head.len() < 24 || &head[..8] != b"\x89PNG\r\n\x1a\n" || &head[12..16] != b"IHDR" {
        return None;
    }
    let be = |b: &[u8]| u64::from(u32::from_be_bytes([b[0], b[1], b[2], b[3]]));
    Some((be(&head[16..20]), be(&head[20..24])))
}

/// `ncols` and `nrows` from the first lines of an ASCII grid.
fn asc_size(head: &[u8]) -> Option<(u64, u64)> {
    let text = String::from_utf8_lossy(head);
    let (mut cols, mut rows) = (None, None);
    for line in text.lines().take(8) {
        let mut tokens = line.split_whitespace();
        match (tokens.next().map(str::to_ascii_lowercase), tokens.next()) {
            (Some(k), Some(v)) if k == "ncols" => cols = v.parse().ok(),
            (Some(k), Some(v)) if k == "nrows" => rows = v.parse().ok(),
            _ => {}
        }
    }
    Some((cols?, rows?))
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
    /// The height range 16-bit samples span (PNG, RAW R16), after the z scale; `None`: the
    /// field's own. Tiles of one map share one, so a height is the same sample in each.
    pub z_range: Option<(f32, f32)>,
}

impl Default for ExportOptions {
    fn default() -> Self {
        Self {
            size: None,
            flip_y: false,
            z_scale: 1.0,
            cell_size: 1.0,
            z_range: None,
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

/// Writes `field` in `format`, after the checks every writer relies on:
/// - no value is infinite, before or after the z scale (a height beyond `f32` is refused, not
///   written as `inf`);
/// - PNG and RAW R16 have no no-data value, so a field with no-data (NaN) cells is refused
///   (fill the voids first) rather than written as the minimum height;
/// - the cell size is positive and finite.
pub fn write(
    format: Format,
    field: &Heightfield,
    georef: &GeoRef,
    options: &ExportOptions,
) -> Result<Exported, DemError> {
    crate::jobs::run_inline(
        |ctx| async move { write_in(format, field, georef, options, &ctx).await },
    )
}

/// [`write`] in a job: resampling, the checks and the encoding tick after each row (or
/// strip, or block), with the resampling the first 30% of `ctx`'s part.
pub async fn write_in(
    format: Format,
    field: &Heightfield,
    georef: &GeoRef,
    options: &ExportOptions,
    ctx: &JobCtx,
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
            let resized = resize::resample_filtered_in(field, n, n, &ctx.part(0.0, 0.3))
                .await
                .map_err(|_| DemError::Cancelled)?;
            (
                Cow::Owned(resized),
                georef.resampled(fx, fy),
                options.cell_size / fx,
            )
        }
        _ => (Cow::Borrowed(field), georef.clone(), options.cell_size),
    };
    if options.z_scale != 1.0 {
        let scale = options.z_scale;
        let data = out.to_mut().data_mut();
        let rows = data.len().div_ceil(SCAN_CELLS);
        for (k, part) in data.chunks_mut(SCAN_CELLS).enumerate() {
            ctx.part(0.3, 0.35)
                .tick_of(k, rows, "scaling the heights")
                .await
                .map_err(|_| DemError::Cancelled)?;
            part.iter_mut().for_each(|z| *z *= scale);
        }
    }
    let scan = Scan::of(&out, &ctx.part(0.35, 0.4)).await?;
    if let Some(i) = scan.first_infinite {
        let scaled = if options.z_scale != 1.0 {
            format!(" after the z scale {:?}", options.z_scale)
        } else {
            String::new()
        };
        return Err(DemError::Write(format!(
            "the height at row {}, column {} is beyond the 32-bit float range (+-3.4e38){scaled}; \
             nothing was written",
            i / out.width(),
            i % out.width()
        )));
    }
    if matches!(format, Format::Png | Format::R16) && scan.voids > 0 {
        return Err(DemError::Write(format!(
            "{} no-data cells: a {} has no no-data value (they would read back as the \
             lowest height); fill them first (strahler convert --fill-voids, or strahler \
             fill) or write .tif or .asc",
            scan.voids,
            format.name()
        )));
    }
    if !(cell.is_finite() && cell > 0.0) {
        return Err(DemError::Write(format!(
            "the cell size must be a positive number, got {cell}"
        )));
    }
    let range = options.z_range.or(scan.range);
    if matches!(format, Format::Png | Format::R16)
        && let Some((lo, hi)) = range
    {
        // 16-bit samples are spread over the range: a range wider than an f32 holds would
        // make every sample 0 and the sidecar unreadable.
        super::sidecar::check_range(lo, hi, format.name()).map_err(|problem| {
            DemError::Write(format!("{problem}; write .tif (32-bit floats) instead"))
        })?;
    }
    let sidecar = |range: (f32, f32), decode: &str| {
        format!(
            "{{\n  \"zmin\": {},\n  \"zmax\": {},\n  \"width\": {},\n  \"height\": {},\n  \
             \"cell_size_m\": {},\n  \"flip_y\": {},\n  \"decode\": \"{decode}\"\n}}\n",
            range.0,
            range.1,
            out.width(),
            out.height(),
            cell,
            options.flip_y
        )
    };
    const STEPS: &str = "z = zmin + v / 65535 * (zmax - zmin)";
    let ctx = &ctx.part(0.4, 1.0);
    let cancelled = |_| DemError::Cancelled;
    let range16 = range.unwrap_or((0.0, 0.0));
    let plain = |bytes| Exported {
        bytes,
        sidecar: None,
    };
    Ok(match format {
        Format::GeoTiff => plain(geotiff::write_in(&out, &georef, ctx).await?),
        Format::Png => {
            let (bytes, range) =
                png16::write_heightmap_in(&out, range16, options.flip_y, ctx).await?;
            Exported {
                bytes,
                sidecar: Some(sidecar(range, STEPS)),
            }
        }
        Format::R16 => {
            let (bytes, range) = raw::write_in(&out, options.flip_y, range16, ctx)
                .await
                .map_err(cancelled)?;
            Exported {
                bytes,
                sidecar: Some(sidecar(range, STEPS)),
            }
        }
        Format::Asc => plain(asc::write_in(&out, &georef, cell, ctx).await?),
        Format::Hgt => plain(hgt::write(&out)?),
        Format::Obj => plain(obj::write_in(&out, cell, ctx).await?),
        Format::Exr => plain(exr::write_in(&out, ctx).await?),
        Format::R32 => Exported {
            bytes: raw32::write_in(&out, options.flip_y, ctx)
                .await
                .map_err(cancelled)?,
            sidecar: Some(sidecar(
                scan.range.unwrap_or((0.0, 0.0)),
                "z = little-endian float32 in metres, NaN = no data",
            )),
        },
    })
}

/// Cells [`write_in`] scans between two ticks.
const SCAN_CELLS: usize = 1 << 16;

/// What [`write`] checks of the heights it is about to encode, in one pass.
struct Scan {
    /// The first infinite height, by index.
    first_infinite: Option<usize>,
    /// No-data (NaN) cells.
    voids: usize,
    /// The finite heights' range (`Heightfield::finite_range`).
    range: Option<(f32, f32)>,
}

impl Scan {
    async fn of(field: &Heightfield, ctx: &JobCtx) -> Result<Self, DemError> {
        let mut scan = Scan {
            first_infinite: None,
            voids: 0,
            range: None,
        };
        let parts = field.data().len().div_ceil(SCAN_CELLS);
        for (k, part) in field.data().chunks(SCAN_CELLS).enumerate() {
            ctx.tick_of(k, parts, "checking the heights")
                .await
                .map_err(|_| DemError::Cancelled)?;
            for (i, &z) in part.iter().enumerate() {
                if z.is_nan() {
                    scan.voids += 1;
                } else if z.is_infinite() {
                    scan.first_infinite.get_or_insert(k * SCAN_CELLS + i);
                } else {
                    let (lo, hi) = scan.range.get_or_insert((z, z));
                    *lo = lo.min(z);
                    *hi = hi.max(z);
                }
            }
        }
        Ok(scan)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Issue 33: the page's file inputs take the command line's checks: empty, huge and
    /// lying files are refused by their length before they are read.
    #[test]
    fn lengths_are_checked_before_reading() {
        let limits = ReadLimits::default();
        assert!(matches!(
            check_length("a.tif", 0, limits),
            Err(DemError::EmptyFile)
        ));
        let err = check_length("a.png", 3 << 30, limits).unwrap_err();
        assert!(err.to_string().contains("3221225472 bytes"), "{err}");
        assert!(check_length("a.hgt", 2 * 1201 * 1201, limits).is_ok());
        assert!(matches!(
            check_length("a.obj", 10, limits),
            Err(DemError::UnknownFormat(_))
        ));
        let options = ImportOptions {
            limits,
            z_range: Some((0.0, 1.0)),
            flip_y: false,
        };
        for name in ["a.tif", "a.png", "a.r16", "a.asc", "N44E005.hgt"] {
            let err = read(name, &[], &options).unwrap_err();
            assert_eq!(err.to_string(), "the file is empty (0 bytes)", "{name}");
        }
    }
}
