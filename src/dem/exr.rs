//! OpenEXR heightmaps (Godot's heightmap plugins, Gaea, World Machine, Houdini): one 32-bit
//! float channel of heights in metres, no normalisation and so no stepping (OpenEXR 2.0,
//! "Technical Introduction"; encoded with the `exr` crate).
//!
//! Written as one scanline layer with ZIP16 compression (lossless), the channel named `R` so
//! that tools reading EXR as colour images (Godot's `Image.load_exr`, Terrain3D) take it as
//! their red channel. Read: the channel named `Y`, `R`, `Z` or `height` (any case), else the
//! only one; half, float and unsigned-int samples become `f32`; the first flat layer, largest
//! resolution level. The header's size is checked against [`ReadLimits`] before any pixel is
//! decoded. No-data is written as NaN (EXR has no no-data value; NaN reads back as no-data).

use std::io::Cursor;

use exr::block::writer::ChunksWriter as _;
use exr::block::{UncompressedBlock, enumerate_ordered_header_block_indices};
use exr::meta::BlockDescription;
use exr::meta::Headers;
use exr::meta::attribute::{ChannelDescription, SampleType};
use exr::meta::header::Header;
use exr::prelude::{Compression, LineOrder, ReadChannels as _, ReadLayers as _, SmallVec};

use super::{Dem, DemError, GeoRef, ReadLimits};
use crate::heightfield::Heightfield;

fn bad(problem: String) -> DemError {
    DemError::Malformed {
        format: "OpenEXR",
        problem,
    }
}

/// Encodes `field` as a one-channel float EXR.
pub fn write(field: &Heightfield) -> Result<Vec<u8>, DemError> {
    crate::jobs::run_inline(|ctx| async move { write_in(field, &ctx).await })
}

/// [`write`] in a job: the blocks of 16 scanlines are compressed one at a time with a tick
/// after each (the crate's block API), then written with the header and offset table.
pub async fn write_in(field: &Heightfield, ctx: &crate::jobs::JobCtx) -> Result<Vec<u8>, DemError> {
    let fail = |e: exr::error::Error| DemError::Write(format!("OpenEXR: {e}"));
    let (w, h) = (field.width(), field.height());
    let channel = ChannelDescription::named("R", SampleType::F32);
    let header = Header::new("height".into(), (w, h), SmallVec::from_vec(vec![channel]))
        .with_encoding(
            Compression::ZIP16,
            BlockDescription::ScanLines,
            LineOrder::Increasing,
        );
    let headers: Headers = SmallVec::from_vec(vec![header]);
    let mut chunks = Vec::with_capacity(headers[0].chunk_count);
    for (index, block) in enumerate_ordered_header_block_indices(&headers) {
        let (y0, rows) = (block.pixel_position.y(), block.pixel_size.height());
        ctx.tick_of(y0, h, "writing the OpenEXR file")
            .await
            .map_err(|_| DemError::Cancelled)?;
        let x0 = block.pixel_position.x();
        let width = block.pixel_size.width();
        let mut data = Vec::with_capacity(rows * width * 4);
        for y in y0..y0 + rows {
            for z in &field.data()[y * w + x0..y * w + x0 + width] {
                data.extend_from_slice(&z.to_ne_bytes());
            }
        }
        let block = UncompressedBlock { index: block, data };
        chunks.push((index, block.compress_to_chunk(&headers).map_err(fail)?));
    }
    let mut bytes = Vec::new();
    exr::block::write(Cursor::new(&mut bytes), headers, true, |_, writer| {
        for (index, chunk) in chunks {
            writer.write_chunk(index, chunk)?;
        }
        Ok(())
    })
    .map_err(fail)?;
    Ok(bytes)
}

/// The channel a heightmap is in: by name, else the only one.
fn height_channel(names: &[String]) -> Result<usize, DemError> {
    let known = ["y", "r", "z", "height"];
    for want in known {
        if let Some(i) = names.iter().position(|n| n.eq_ignore_ascii_case(want)) {
            return Ok(i);
        }
    }
    match names.len() {
        1 => Ok(0),
        _ => Err(DemError::Unsupported(format!(
            "this OpenEXR file has the channels {} and none is a height: name it Y, R, Z or \
             height, or keep only one",
            names.join(", ")
        ))),
    }
}

/// Decodes an EXR heightmap within `limits`.
pub fn read(bytes: &[u8], limits: ReadLimits) -> Result<Dem, DemError> {
    let meta = exr::meta::MetaData::read_from_buffered(Cursor::new(bytes), false)
        .map_err(|e| bad(e.to_string()))?;
    let header = meta
        .headers
        .iter()
        .find(|h| !h.deep)
        .ok_or_else(|| bad("no flat (non-deep) layer".into()))?;
    let size = header.layer_size;
    limits.check(size.0 as u64, size.1 as u64)?;
    let image = exr::prelude::read()
        .no_deep_data()
        .largest_resolution_level()
        .all_channels()
        .first_valid_layer()
        .all_attributes()
        .non_parallel()
        .from_buffered(Cursor::new(bytes))
        .map_err(|e| bad(e.to_string()))?;
    let layer = &image.layer_data;
    let channels = &layer.channel_data.list;
    let names: Vec<String> = channels.iter().map(|c| c.name.to_string()).collect();
    let channel = &channels[height_channel(&names)?];
    let (w, h) = (layer.size.0, layer.size.1);
    let data: Vec<f32> = channel.sample_data.values_as_f32().collect();
    if data.len() != w * h {
        return Err(bad(format!("{} samples for {w} x {h} pixels", data.len())));
    }
    let field = Heightfield::from_vec(w, h, data).map_err(|_| DemError::Empty)?;
    Ok(Dem {
        field,
        georef: GeoRef::default(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn heights_round_trip_bit_for_bit() {
        let data: Vec<f32> = (0..7 * 5)
            .map(|i| (i as f32 * 0.731).sin() * 1234.567 - 12.0)
            .collect();
        let mut field = Heightfield::from_vec(7, 5, data).unwrap();
        field.data_mut()[3] = f32::NAN;
        let bytes = write(&field).unwrap();
        let back = read(&bytes, ReadLimits::default()).unwrap().field;
        assert_eq!((back.width(), back.height()), (7, 5));
        for (a, b) in field.data().iter().zip(back.data()) {
            assert_eq!(a.to_bits(), b.to_bits());
        }
    }

    #[test]
    fn limits_and_garbage_are_refused_by_name() {
        let bytes = write(&Heightfield::filled(40, 30, 1.0).unwrap()).unwrap();
        let err = read(&bytes, ReadLimits { max_cells: 100 }).unwrap_err();
        assert!(err.to_string().contains("40 x 30"), "{err}");
        let err = read(b"not an exr file at all", ReadLimits::default()).unwrap_err();
        assert!(err.to_string().contains("OpenEXR"), "{err}");
        let err = read(&bytes[..bytes.len() / 2], ReadLimits::default()).unwrap_err();
        assert!(err.to_string().contains("OpenEXR"), "{err}");
    }
}
