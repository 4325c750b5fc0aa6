//! PNG heightmaps: 16-bit greyscale, linear (no gamma or sRGB chunk), big-endian samples, the
//! height range in a text chunk (`strahler:z_range` = "min,max" in metres), and 8-bit masks
//! for the layer images.

use std::io::Write as _;

use super::DemError;
use crate::heightfield::Heightfield;
use crate::jobs::{JobCtx, run_inline};

/// Encodes `field` so that `z = min + v / 65535 * (max - min)`. A PNG heightmap has no
/// no-data value: [`super::format::write`] refuses fields with no-data cells before they get
/// here (a NaN would be written as 0, the minimum). Returns the bytes and the `(min, max)`
/// range used.
pub fn write_heightmap(field: &Heightfield) -> Result<(Vec<u8>, (f32, f32)), DemError> {
    let range = field.finite_range().unwrap_or((0.0, 0.0));
    run_inline(|ctx| async move { write_heightmap_in(field, range, false, &ctx).await })
}

/// [`write_heightmap`] spread over the range `(lo, hi)` instead of the field's own (tiles of
/// one map share one range; heights outside it are clamped), rows bottom-up when `flip_y`,
/// in a job: a tick after each row.
pub async fn write_heightmap_in(
    field: &Heightfield,
    (lo, hi): (f32, f32),
    flip_y: bool,
    ctx: &JobCtx,
) -> Result<(Vec<u8>, (f32, f32)), DemError> {
    let span = f64::from(hi - lo);
    let w = field.width();
    let sample = |z: f32| {
        if z.is_finite() && span > 0.0 {
            ((f64::from(z - lo) / span) * 65535.0)
                .round()
                .clamp(0.0, 65535.0) as u16
        } else {
            0
        }
    };
    let shape = Shape {
        width: w,
        height: field.height(),
        colour: png::ColorType::Grayscale,
        depth: png::BitDepth::Sixteen,
    };
    let text = ("strahler:z_range".to_owned(), format!("{lo},{hi}"));
    let last = field.height().saturating_sub(1);
    let row = |y: usize, out: &mut Vec<u8>| {
        let y = if flip_y { last - y } else { y };
        for &z in &field.data()[y * w..(y + 1) * w] {
            out.extend_from_slice(&sample(z).to_be_bytes());
        }
    };
    let bytes = encode_rows(shape, Some(text), row, ctx).await?;
    Ok((bytes, (lo, hi)))
}

/// Encodes an 8-bit greyscale image (masks, layers).
pub fn write_grey8(width: usize, height: usize, values: &[u8]) -> Result<Vec<u8>, DemError> {
    run_inline(|ctx| async move { write_grey8_in(width, height, values, &ctx).await })
}

/// [`write_grey8`] in a job: a tick after each row.
pub async fn write_grey8_in(
    width: usize,
    height: usize,
    values: &[u8],
    ctx: &JobCtx,
) -> Result<Vec<u8>, DemError> {
    let shape = Shape {
        width,
        height,
        colour: png::ColorType::Grayscale,
        depth: png::BitDepth::Eight,
    };
    encode_slice(shape, values, ctx).await
}

/// Encodes an 8-bit colour image with `channels` 3 (RGB) or 4 (RGBA) interleaved samples a
/// pixel (normal and splat maps).
pub fn write_colour8(
    width: usize,
    height: usize,
    channels: usize,
    values: &[u8],
) -> Result<Vec<u8>, DemError> {
    run_inline(|ctx| async move { write_colour8_in(width, height, channels, values, &ctx).await })
}

/// [`write_colour8`] in a job: a tick after each row.
pub async fn write_colour8_in(
    width: usize,
    height: usize,
    channels: usize,
    values: &[u8],
    ctx: &JobCtx,
) -> Result<Vec<u8>, DemError> {
    let colour = match channels {
        3 => png::ColorType::Rgb,
        4 => png::ColorType::Rgba,
        _ => return Err(DemError::Write(format!("{channels} channels a pixel"))),
    };
    let shape = Shape {
        width,
        height,
        colour,
        depth: png::BitDepth::Eight,
    };
    encode_slice(shape, values, ctx).await
}

/// The size and sample layout of an image to encode.
struct Shape {
    width: usize,
    height: usize,
    colour: png::ColorType,
    depth: png::BitDepth,
}

impl Shape {
    /// Bytes a row of samples takes.
    fn row_bytes(&self) -> usize {
        let bytes = if self.depth == png::BitDepth::Sixteen {
            2
        } else {
            1
        };
        self.width * self.colour.samples() * bytes
    }
}

/// `values` (rows of samples, top first) encoded, a row at a time.
async fn encode_slice(shape: Shape, values: &[u8], ctx: &JobCtx) -> Result<Vec<u8>, DemError> {
    let len = shape.row_bytes();
    if values.len() != len * shape.height {
        return Err(DemError::Write(format!(
            "{} bytes for a {} x {} image of {len} bytes a row",
            values.len(),
            shape.width,
            shape.height
        )));
    }
    let row = |y: usize, out: &mut Vec<u8>| out.extend_from_slice(&values[y * len..(y + 1) * len]);
    encode_rows(shape, None, row, ctx).await
}

/// A PNG of `shape` whose row `y` (top first) `row(y, out)` appends to `out`, with an
/// optional text chunk. The rows stream through the encoder (Deflate as they come), with
/// a tick after each, so no row's work holds the page.
async fn encode_rows(
    shape: Shape,
    text: Option<(String, String)>,
    mut row: impl FnMut(usize, &mut Vec<u8>),
    ctx: &JobCtx,
) -> Result<Vec<u8>, DemError> {
    let err = |e: png::EncodingError| DemError::Write(e.to_string());
    let io = |e: std::io::Error| DemError::Write(e.to_string());
    let mut out = Vec::new();
    {
        let mut encoder = png::Encoder::new(&mut out, shape.width as u32, shape.height as u32);
        encoder.set_color(shape.colour);
        encoder.set_depth(shape.depth);
        if let Some((key, value)) = text {
            encoder.add_text_chunk(key, value).map_err(err)?;
        }
        let mut writer = encoder.write_header().map_err(err)?;
        let mut stream = writer.stream_writer_with_size(1 << 16).map_err(err)?;
        let mut bytes = Vec::with_capacity(shape.row_bytes());
        for y in 0..shape.height {
            ctx.tick_of(y, shape.height, "encoding the PNG")
                .await
                .map_err(|_| DemError::Cancelled)?;
            bytes.clear();
            row(y, &mut bytes);
            stream.write_all(&bytes).map_err(io)?;
        }
        stream.finish().map_err(err)?;
        writer.finish().map_err(err)?;
    }
    Ok(out)
}

/// Reads an 8- or 16-bit greyscale PNG heightmap as `z = min + v / vmax * (max - min)`. The
/// range is `z_range` when given, else the `strahler:z_range` text chunk written by
/// [`write_heightmap`]; without either the file's heights are unknown and it is an error.
/// The size is checked against `limits` from the header, before any allocation.
pub fn read_heightmap(
    bytes: &[u8],
    z_range: Option<(f32, f32)>,
    limits: super::ReadLimits,
) -> Result<super::Dem, DemError> {
    let bad = |e: png::DecodingError| DemError::Png(e.to_string());
    let malformed = |problem: String| DemError::Malformed {
        format: "PNG heightmap",
        problem,
    };
    let mut decoder = png::Decoder::new(std::io::Cursor::new(bytes));
    decoder.set_transformations(png::Transformations::EXPAND);
    let mut reader = decoder.read_info().map_err(bad)?;
    let (width, height) = (reader.info().width as usize, reader.info().height as usize);
    limits.check(width as u64, height as u64)?;
    let color = reader.info().color_type;
    if !matches!(
        color,
        png::ColorType::Grayscale | png::ColorType::GrayscaleAlpha
    ) {
        return Err(DemError::Unsupported(format!(
            "unsupported PNG: a {color:?} PNG is not a heightmap; use greyscale (8 or 16 bits)"
        )));
    }
    let chunk = reader
        .info()
        .uncompressed_latin1_text
        .iter()
        .find(|t| t.keyword == "strahler:z_range");
    let from_chunk = match chunk {
        Some(t) if z_range.is_none() => Some(parse_range(&t.text).ok_or_else(|| {
            malformed(format!(
                "the strahler:z_range text chunk '{}' is not MIN,MAX",
                super::clip(&t.text)
            ))
        })?),
        _ => None,
    };
    let (lo, hi) = z_range.or(from_chunk).ok_or_else(|| {
        DemError::Unsupported(
            "the PNG does not say its height range; give it (--z-range MIN,MAX)".into(),
        )
    })?;
    let source = if z_range.is_some() {
        "the given range"
    } else {
        "the strahler:z_range text chunk"
    };
    super::sidecar::check_range(lo, hi, source).map_err(malformed)?;
    let size = reader
        .output_buffer_size()
        .ok_or_else(|| DemError::Png("the image is too large to decode".into()))?;
    let mut buf = vec![0u8; size];
    let frame = reader.next_frame(&mut buf).map_err(bad)?;
    let wide = frame.bit_depth == png::BitDepth::Sixteen;
    let channels = frame.color_type.samples();
    let vmax = if wide { 65535.0 } else { 255.0 };
    let mut data = Vec::with_capacity(width * height);
    for y in 0..height {
        let row = &buf[y * frame.line_size..(y + 1) * frame.line_size];
        for x in 0..width {
            let v = if wide {
                let k = 2 * x * channels;
                f64::from(u16::from_be_bytes([row[k], row[k + 1]]))
            } else {
                f64::from(row[x * channels])
            };
            data.push((f64::from(lo) + v / vmax * f64::from(hi - lo)) as f32);
        }
    }
    let field = Heightfield::from_vec(width, height, data).map_err(|_| DemError::Empty)?;
    Ok(super::Dem {
        field,
        georef: super::GeoRef::default(),
    })
}

/// "min,max" to a pair of numbers.
pub fn parse_range(text: &str) -> Option<(f32, f32)> {
    let (a, b) = text.split_once(',')?;
    Some((a.trim().parse().ok()?, b.trim().parse().ok()?))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn heightmap_round_trips_within_one_step() {
        let data: Vec<f32> = (0..12 * 7)
            .map(|i| 100.0 + (i as f32 * 0.7).sin() * 40.0)
            .collect();
        let field = Heightfield::from_vec(12, 7, data).unwrap();
        let (bytes, (lo, hi)) = write_heightmap(&field).unwrap();
        let decoder = png::Decoder::new(std::io::Cursor::new(bytes));
        let mut reader = decoder.read_info().unwrap();
        let info = reader.info();
        assert_eq!(
            (info.width, info.height, info.bit_depth),
            (12, 7, png::BitDepth::Sixteen)
        );
        assert!(info.gamma().is_none() && info.srgb.is_none());
        let text = &info.uncompressed_latin1_text;
        assert!(text.iter().any(|t| t.keyword == "strahler:z_range"));
        let mut buf = vec![0; reader.output_buffer_size().unwrap()];
        reader.next_frame(&mut buf).unwrap();
        let step = (hi - lo) / 65535.0;
        for (i, z) in field.data().iter().enumerate() {
            let v = u16::from_be_bytes([buf[2 * i], buf[2 * i + 1]]);
            let back = lo + f32::from(v) / 65535.0 * (hi - lo);
            assert!((back - z).abs() <= step, "{back} vs {z}");
        }
    }
}
