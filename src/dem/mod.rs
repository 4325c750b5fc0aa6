//! Real elevation rasters in and out: GeoTIFF, SRTM `.hgt`, ESRI ASCII grids, PNG and RAW
//! heightmaps, and OBJ meshes, all behind the same [`Dem`] type; [`format`] picks one by
//! file name.
//!
//! Every reader checks the size from the header against [`ReadLimits`] before allocating,
//! turns no-data into NaN, and returns a [`DemError`] that says what is wrong; no panic is
//! reachable from a file's bytes.
//!
//! Rules for every reader of a file (see [`format::read_file`] and [`read_bounded`]):
//! - only regular files are read (not `/dev/zero`, pipes or folders);
//! - the file's length is checked against the limit before it is read: for a raster, the
//!   size its header declares (checked against [`ReadLimits`]) times the most bytes a cell
//!   can take in that format, plus [`HEADER_SLACK`]; for other files a fixed cap;
//! - at most that many bytes are ever read, even from a file that grows meanwhile;
//! - an error message quotes at most [`CLIP_CHARS`] characters of the file's content
//!   ([`clip`]).

pub mod asc;
pub mod cog;
pub mod exr;
pub mod format;
pub mod geotiff;
pub mod hgt;
pub mod hillshade;
pub mod obj;
pub mod png16;
pub mod raw;
pub mod raw32;
pub mod resize;
pub mod sidecar;
pub mod utm;

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
    /// A layout or kind of file the readers do not take (the message names the format), or
    /// a PNG without its height range.
    #[error("{0}")]
    Unsupported(String),
    #[error("the file has no cells")]
    Empty,
    #[error("the file is empty (0 bytes)")]
    EmptyFile,
    #[error("not a readable PNG: {0}")]
    Png(String),
    #[error("could not write the file: {0}")]
    Write(String),
    /// The job writing the file was cancelled (a newer export, or the user).
    #[error("cancelled")]
    Cancelled,
    #[error("not a readable {format}: {problem}")]
    Malformed {
        format: &'static str,
        problem: String,
    },
    #[error(
        "{0}: unknown elevation format; use .tif/.tiff (GeoTIFF), .hgt (SRTM), .asc (ESRI \
         ASCII grid), .png (greyscale heightmap), .r16/.raw (RAW 16-bit), .r32 (RAW float) or .exr \
         (OpenEXR)"
    )]
    UnknownFormat(String),
    #[error("the file is {bytes} bytes, more than the {limit} bytes {why}; not read")]
    FileTooLarge { bytes: u64, limit: u64, why: String },
    #[error(
        "it is {0}, not a regular file: give the path of a file (pipes, devices and folders are refused)"
    )]
    NotAFile(String),
    #[error("cannot read the file: {0}")]
    Io(String),
    #[error(
        "reading it needs {} of memory, more than this machine can give; use a smaller file",
        format_bytes(*bytes)
    )]
    OutOfMemory { bytes: u64 },
}

/// `bytes` in words: "3.2 GiB", "512 MiB".
pub fn format_bytes(bytes: u64) -> String {
    let b = bytes as f64;
    if b >= f64::from(1u32 << 30) {
        format!("{:.1} GiB", b / f64::from(1u32 << 30))
    } else {
        format!("{:.0} MiB", b / f64::from(1u32 << 20))
    }
}

/// The most characters of a file's content an error message quotes.
pub const CLIP_CHARS: usize = 40;

/// `text` as quoted in an error message: at most [`CLIP_CHARS`] characters, then how long it
/// really was.
pub fn clip(text: &str) -> String {
    match text.char_indices().nth(CLIP_CHARS) {
        None => text.to_owned(),
        Some((end, _)) => format!("{}... ({} bytes)", &text[..end], text.len()),
    }
}

/// Bytes a raster file may take beyond its cells: headers, tags, text chunks (a PNG may carry
/// megabytes of metadata).
pub const HEADER_SLACK: u64 = 16 << 20;

/// Reads a regular file of at most `limit` bytes (`why` says where the limit comes from, for
/// the message). The length is checked before anything is read, and no more than `limit`
/// bytes are read even from a file that grows meanwhile.
pub fn read_bounded(path: &std::path::Path, limit: u64, why: &str) -> Result<Vec<u8>, DemError> {
    let mut file = open_regular(path)?;
    let len = checked_len(&file, limit, why)?;
    read_rest(&mut file, len, limit, why)
}

/// Opens a file to read it, refusing anything but a regular file before a byte is read.
/// On Unix the file is opened without waiting (`O_NONBLOCK`), so a named pipe with no writer
/// is refused by its kind instead of blocking the run forever; the flag changes nothing for
/// a regular file.
pub fn open_regular(path: &std::path::Path) -> Result<std::fs::File, DemError> {
    let mut options = std::fs::OpenOptions::new();
    options.read(true);
    #[cfg(unix)]
    {
        use std::os::unix::fs::OpenOptionsExt as _;
        options.custom_flags(libc::O_NONBLOCK);
    }
    let file = options
        .open(path)
        .map_err(|e| DemError::Io(e.to_string()))?;
    let meta = file.metadata().map_err(|e| DemError::Io(e.to_string()))?;
    if !meta.is_file() {
        return Err(DemError::NotAFile(file_kind(&meta).into()));
    }
    Ok(file)
}

/// What a path that is not a regular file is, in words.
pub fn file_kind(meta: &std::fs::Metadata) -> &'static str {
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt as _;
        let t = meta.file_type();
        if t.is_fifo() {
            return "a named pipe (FIFO)";
        }
        if t.is_char_device() || t.is_block_device() {
            return "a device";
        }
        if t.is_socket() {
            return "a socket";
        }
    }
    if meta.is_dir() {
        "a folder"
    } else if meta.is_file() {
        "a regular file"
    } else {
        "not a regular file"
    }
}

/// The length of an open file, refusing anything but a regular file of at most `limit` bytes.
pub(crate) fn checked_len(file: &std::fs::File, limit: u64, why: &str) -> Result<u64, DemError> {
    let meta = file.metadata().map_err(|e| DemError::Io(e.to_string()))?;
    if !meta.is_file() {
        return Err(DemError::NotAFile(file_kind(&meta).into()));
    }
    if meta.len() > limit {
        return Err(DemError::FileTooLarge {
            bytes: meta.len(),
            limit,
            why: why.to_owned(),
        });
    }
    Ok(meta.len())
}

/// Reads the whole of `file` from its current position, at most `limit` bytes.
pub(crate) fn read_rest(
    file: &mut std::fs::File,
    len: u64,
    limit: u64,
    why: &str,
) -> Result<Vec<u8>, DemError> {
    use std::io::Read as _;
    let mut bytes = Vec::with_capacity(usize::try_from(len.min(limit)).unwrap_or(0));
    file.take(limit.saturating_add(1))
        .read_to_end(&mut bytes)
        .map_err(|e| DemError::Io(e.to_string()))?;
    if bytes.len() as u64 > limit {
        return Err(DemError::FileTooLarge {
            bytes: bytes.len() as u64,
            limit,
            why: why.to_owned(),
        });
    }
    Ok(bytes)
}

/// Checks that `bytes` can be allocated now, so that a file declaring more cells than the
/// machine can hold is refused with a message instead of aborting the process.
pub fn reserve_check(bytes: u64) -> Result<(), DemError> {
    let mut probe: Vec<u8> = Vec::new();
    usize::try_from(bytes)
        .ok()
        .and_then(|n| probe.try_reserve_exact(n).ok())
        .ok_or(DemError::OutOfMemory { bytes })
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
    /// The largest file of a format taking at most `bytes_per_cell` bytes a cell, plus
    /// [`HEADER_SLACK`].
    pub fn max_file_bytes(&self, bytes_per_cell: u64) -> u64 {
        self.max_cells
            .saturating_mul(bytes_per_cell)
            .saturating_add(HEADER_SLACK)
    }

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
