//! A tiled BigTIFF with overviews, in the layout of a Cloud-Optimised GeoTIFF, written from
//! tiles one at a time: memory holds a few tiles, never the raster.
//!
//! The file (BigTIFF, TIFF 6.0 with the 64-bit offsets of the BigTIFF extension, so past
//! 4 GB): the header, then every image file directory, full resolution first and each
//! overview after it (`NewSubfileType` 1, half the size of the one before, until one tile
//! holds it), then the tiles' data. All directories in the first bytes is what makes a
//! GeoTIFF cloud-optimised (a reader finds every tile from one small read). Tiles are
//! `f32` (`SampleFormat` 3), Deflate-compressed (`Compression` 8), square, a multiple of
//! 16 a side as TIFF asks; an overview cell is the mean of the full-resolution cells it
//! covers (NaN cells left out). The full resolution carries the georeferencing.

use std::io::{Seek, Write};
use std::path::Path;

use flate2::write::ZlibEncoder;

use super::{DemError, GeoRef};

/// What [`write`] wrote.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Written {
    /// Images in the file: full resolution and its overviews.
    pub images: usize,
    pub bytes: u64,
}

/// One directory's entry: tag, type, count and the value's bytes (little-endian).
struct Entry {
    tag: u16,
    kind: u16,
    count: u64,
    bytes: Vec<u8>,
}

const SHORT: u16 = 3;
const LONG: u16 = 4;
const DOUBLE: u16 = 12;
const ASCII: u16 = 2;
const LONG8: u16 = 16;

fn shorts(tag: u16, values: &[u16]) -> Entry {
    Entry {
        tag,
        kind: SHORT,
        count: values.len() as u64,
        bytes: values.iter().flat_map(|v| v.to_le_bytes()).collect(),
    }
}

fn long(tag: u16, value: u32) -> Entry {
    Entry {
        tag,
        kind: LONG,
        count: 1,
        bytes: value.to_le_bytes().to_vec(),
    }
}

fn doubles(tag: u16, values: &[f64]) -> Entry {
    Entry {
        tag,
        kind: DOUBLE,
        count: values.len() as u64,
        bytes: values.iter().flat_map(|v| v.to_le_bytes()).collect(),
    }
}

fn long8s(tag: u16, values: &[u64]) -> Entry {
    Entry {
        tag,
        kind: LONG8,
        count: values.len() as u64,
        bytes: values.iter().flat_map(|v| v.to_le_bytes()).collect(),
    }
}

/// One image of the file: its size and where its tiles' compressed bytes lie in the data.
struct Image {
    width: usize,
    height: usize,
    /// (offset in the data section, length) per tile, row by row.
    tiles: Vec<(u64, u64)>,
}

/// The entries of `image`'s directory, its tiles' offsets shifted by `data_start`.
fn entries(
    image: &Image,
    tile: usize,
    overview: bool,
    georef: Option<&GeoRef>,
    data_start: u64,
) -> Vec<Entry> {
    let offsets: Vec<u64> = image.tiles.iter().map(|t| data_start + t.0).collect();
    let counts: Vec<u64> = image.tiles.iter().map(|t| t.1).collect();
    let mut e = vec![
        long(254, u32::from(overview)),
        long(256, image.width as u32),
        long(257, image.height as u32),
        shorts(258, &[32]),
        shorts(259, &[8]),
        shorts(262, &[1]),
        shorts(277, &[1]),
        shorts(284, &[1]),
        long(322, tile as u32),
        long(323, tile as u32),
        long8s(324, &offsets),
        long8s(325, &counts),
        shorts(339, &[3]),
    ];
    if let Some(g) = georef {
        if let Some(v) = &g.pixel_scale {
            e.push(doubles(33550, v));
        }
        if let Some(v) = &g.tiepoint {
            e.push(doubles(33922, v));
        }
        if let Some(v) = &g.transformation {
            e.push(doubles(34264, v));
        }
        if let Some(v) = &g.geo_keys {
            e.push(shorts(34735, v));
        }
        if let Some(v) = &g.geo_doubles {
            e.push(doubles(34736, v));
        }
        if let Some(v) = &g.geo_ascii {
            let mut bytes = v.as_bytes().to_vec();
            bytes.push(0);
            e.push(Entry {
                tag: 34737,
                kind: ASCII,
                count: bytes.len() as u64,
                bytes,
            });
        }
    }
    e.sort_by_key(|e| e.tag);
    e
}

/// Bytes of a directory of `entries` with its values that do not fit in an entry.
fn directory_len(entries: &[Entry]) -> u64 {
    let outside: u64 = entries
        .iter()
        .filter(|e| e.bytes.len() > 8)
        .map(|e| (e.bytes.len() as u64).next_multiple_of(8))
        .sum();
    8 + 20 * entries.len() as u64 + 8 + outside
}

/// The directory at `at`, the next one at `next` (0: none).
fn directory_bytes(entries: &[Entry], at: u64, next: u64) -> Vec<u8> {
    let mut head = Vec::new();
    let mut tail = Vec::new();
    let mut outside_at = at + 8 + 20 * entries.len() as u64 + 8;
    head.extend_from_slice(&(entries.len() as u64).to_le_bytes());
    for e in entries {
        head.extend_from_slice(&e.tag.to_le_bytes());
        head.extend_from_slice(&e.kind.to_le_bytes());
        head.extend_from_slice(&e.count.to_le_bytes());
        if e.bytes.len() <= 8 {
            let mut value = e.bytes.clone();
            value.resize(8, 0);
            head.extend_from_slice(&value);
        } else {
            head.extend_from_slice(&outside_at.to_le_bytes());
            let mut value = e.bytes.clone();
            value.resize(value.len().next_multiple_of(8), 0);
            outside_at += value.len() as u64;
            tail.extend_from_slice(&value);
        }
    }
    head.extend_from_slice(&next.to_le_bytes());
    head.extend_from_slice(&tail);
    head
}

/// Writes the `width x height` raster whose `tile x tile` tiles `tile_of(row, col)` gives
/// (row-major `f32`, the edge tiles cut to the raster: `min(tile, width - col * tile)`
/// wide) to `path` as a tiled BigTIFF with overviews; the full resolution carries `georef`.
/// Written to a temporary file beside `path`, renamed at the end. Reads each tile once per
/// image (the overviews average the full resolution). O(cells x images) time, O(tile^2)
/// memory.
pub fn write(
    path: &Path,
    width: usize,
    height: usize,
    tile: usize,
    georef: &GeoRef,
    mut tile_of: impl FnMut(usize, usize) -> Result<Vec<f32>, DemError>,
) -> Result<Written, DemError> {
    if tile == 0 || !tile.is_multiple_of(16) || width == 0 || height == 0 {
        return Err(DemError::Write(format!(
            "a tiled TIFF needs tiles a multiple of 16 a side and a raster, got tile {tile}, \
             {width} x {height}"
        )));
    }
    let io = |e: std::io::Error| DemError::Write(format!("{}: {e}", path.display()));
    let name = path
        .file_name()
        .map_or("out".into(), |n| n.to_string_lossy().into_owned());
    let data_path = path.with_file_name(format!(".{name}.{}.data", std::process::id()));
    let part_path = path.with_file_name(format!(".{name}.{}.part", std::process::id()));
    let mut data = std::fs::File::create(&data_path).map_err(io)?;
    let mut images = Vec::new();
    let (mut w, mut h, mut factor) = (width, height, 1usize);
    loop {
        let tiles = compress_image(&mut data, width, height, tile, factor, &mut tile_of)?;
        images.push(Image {
            width: w,
            height: h,
            tiles,
        });
        if w <= tile && h <= tile {
            break;
        }
        (w, h, factor) = (w.div_ceil(2), h.div_ceil(2), factor * 2);
    }
    data.flush().map_err(io)?;
    // Directories first, then the data.
    let dirs: Vec<Vec<Entry>> = images
        .iter()
        .enumerate()
        .map(|(k, image)| entries(image, tile, k > 0, (k == 0).then_some(georef), 0))
        .collect();
    let lens: Vec<u64> = dirs.iter().map(|d| directory_len(d)).collect();
    let data_start = 16 + lens.iter().sum::<u64>();
    let mut out = std::io::BufWriter::new(std::fs::File::create(&part_path).map_err(io)?);
    out.write_all(b"II").map_err(io)?;
    out.write_all(&43u16.to_le_bytes()).map_err(io)?;
    out.write_all(&8u16.to_le_bytes()).map_err(io)?;
    out.write_all(&0u16.to_le_bytes()).map_err(io)?;
    out.write_all(&16u64.to_le_bytes()).map_err(io)?;
    let mut at = 16u64;
    for (k, image) in images.iter().enumerate() {
        let entries = entries(image, tile, k > 0, (k == 0).then_some(georef), data_start);
        let next = if k + 1 < images.len() {
            at + lens[k]
        } else {
            0
        };
        out.write_all(&directory_bytes(&entries, at, next))
            .map_err(io)?;
        at += lens[k];
    }
    let mut data = std::fs::File::open(&data_path).map_err(io)?;
    let copied = std::io::copy(&mut data, &mut out).map_err(io)?;
    out.flush().map_err(io)?;
    drop(out);
    let _ = std::fs::remove_file(&data_path);
    std::fs::rename(&part_path, path).map_err(io)?;
    Ok(Written {
        images: images.len(),
        bytes: data_start + copied,
    })
}

/// Compresses the tiles of the image `factor` times coarser than the `width x height`
/// raster into `data`; returns each tile's (offset, length) there.
fn compress_image(
    data: &mut std::fs::File,
    width: usize,
    height: usize,
    tile: usize,
    factor: usize,
    tile_of: &mut impl FnMut(usize, usize) -> Result<Vec<f32>, DemError>,
) -> Result<Vec<(u64, u64)>, DemError> {
    let io = |e: std::io::Error| DemError::Write(e.to_string());
    let (w, h) = (width.div_ceil(factor), height.div_ceil(factor));
    let mut out = Vec::new();
    let mut offset = data.stream_position().map_err(io)?;
    for row in 0..h.div_ceil(tile) {
        for col in 0..w.div_ceil(tile) {
            let cells = coarse_tile(width, height, tile, factor, row, col, tile_of)?;
            let raw: Vec<u8> = cells.iter().flat_map(|v| v.to_le_bytes()).collect();
            let mut zlib = ZlibEncoder::new(Vec::new(), flate2::Compression::fast());
            zlib.write_all(&raw).map_err(io)?;
            let bytes = zlib.finish().map_err(io)?;
            data.write_all(&bytes).map_err(io)?;
            out.push((offset, bytes.len() as u64));
            offset += bytes.len() as u64;
        }
    }
    Ok(out)
}

/// Tile (`row`, `col`) of the image `factor` times coarser: `tile x tile` cells (padded with
/// 0 past the image), each the mean of the full-resolution cells it covers.
fn coarse_tile(
    width: usize,
    height: usize,
    tile: usize,
    factor: usize,
    row: usize,
    col: usize,
    tile_of: &mut impl FnMut(usize, usize) -> Result<Vec<f32>, DemError>,
) -> Result<Vec<f32>, DemError> {
    let mut sum = vec![0.0f64; tile * tile];
    let mut count = vec![0u32; tile * tile];
    // Full-resolution cells this tile covers, and the source tiles holding them.
    let (x0, y0) = (col * tile * factor, row * tile * factor);
    let (x1, y1) = (
        (x0 + tile * factor).min(width),
        (y0 + tile * factor).min(height),
    );
    if x0 >= x1 || y0 >= y1 {
        return Ok(vec![0.0; tile * tile]);
    }
    for source_row in y0 / tile..=(y1 - 1) / tile {
        for source_col in x0 / tile..=(x1 - 1) / tile {
            let cells = tile_of(source_row, source_col)?;
            let sw = tile.min(width - source_col * tile);
            let sh = tile.min(height - source_row * tile);
            if cells.len() != sw * sh {
                return Err(DemError::Write(format!(
                    "tile ({source_row}, {source_col}) has {} cells, not {sw} x {sh}",
                    cells.len()
                )));
            }
            for sy in 0..sh {
                let y = source_row * tile + sy;
                if y < y0 || y >= y1 {
                    continue;
                }
                for sx in 0..sw {
                    let x = source_col * tile + sx;
                    let v = cells[sy * sw + sx];
                    if x < x0 || x >= x1 || v.is_nan() {
                        continue;
                    }
                    let k = ((y - y0) / factor) * tile + (x - x0) / factor;
                    sum[k] += f64::from(v);
                    count[k] += 1;
                }
            }
        }
    }
    Ok(sum
        .iter()
        .zip(&count)
        .map(|(s, n)| {
            if *n > 0 {
                (*s / f64::from(*n)) as f32
            } else {
                0.0
            }
        })
        .collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A raster written tile by tile reads back (with the `tiff` crate) bit for bit, tiled,
    /// as a BigTIFF, with its overviews halving down to one tile, each the mean of what it
    /// covers, and the georeferencing on the full resolution.
    #[test]
    fn a_tiled_bigtiff_reads_back_with_its_overviews() {
        use tiff::decoder::{Decoder, DecodingResult};
        let (width, height, tile) = (100, 70, 32);
        let value = |x: usize, y: usize| (x as f32) * 0.5 - (y as f32) * 1.25 + 3.0;
        let tile_of = |row: usize, col: usize| {
            let (x0, y0) = (col * tile, row * tile);
            let (w, h) = (tile.min(width - x0), tile.min(height - y0));
            Ok((0..w * h).map(|k| value(x0 + k % w, y0 + k / w)).collect())
        };
        let dir = std::env::temp_dir().join(format!("strahler-cog-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("t.tif");
        let georef = GeoRef {
            pixel_scale: Some(vec![10.0, 10.0, 0.0]),
            tiepoint: Some(vec![0.0, 0.0, 0.0, 0.0, 1000.0, 0.0]),
            ..GeoRef::default()
        };
        let written = write(&path, width, height, tile, &georef, tile_of).unwrap();
        assert_eq!(written.images, 3, "100 x 70, 50 x 35, 25 x 18");
        let bytes = std::fs::read(&path).unwrap();
        assert_eq!(&bytes[..4], b"II\x2b\x00", "a BigTIFF");
        let mut decoder = Decoder::new(std::io::Cursor::new(bytes)).unwrap();
        assert_eq!(decoder.dimensions().unwrap(), (100, 70));
        assert_eq!(decoder.chunk_dimensions(), (32, 32), "tiled");
        let scale = decoder
            .get_tag_f64_vec(tiff::tags::Tag::ModelPixelScaleTag)
            .unwrap();
        assert_eq!(scale, vec![10.0, 10.0, 0.0]);
        let DecodingResult::F32(full) = decoder.read_image().unwrap() else {
            panic!("f32 samples");
        };
        for y in 0..height {
            for x in 0..width {
                assert_eq!(full[y * width + x].to_bits(), value(x, y).to_bits());
            }
        }
        decoder.next_image().unwrap();
        assert_eq!(decoder.dimensions().unwrap(), (50, 35));
        let DecodingResult::F32(half) = decoder.read_image().unwrap() else {
            panic!("f32 samples");
        };
        let mean = (value(20, 10) + value(21, 10) + value(20, 11) + value(21, 11)) / 4.0;
        assert!((half[5 * 50 + 10] - mean).abs() < 1e-5);
        decoder.next_image().unwrap();
        assert_eq!(decoder.dimensions().unwrap(), (25, 18));
        assert!(!decoder.more_images());
        let _ = std::fs::remove_dir_all(&dir);
    }
}
