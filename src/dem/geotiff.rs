//! GeoTIFF: single-band rasters of any integer or float sample type, strips or tiles,
//! uncompressed, LZW or Deflate (with predictors), GDAL_NODATA; written as float32 with the
//! georeferencing carried over and NaN as no-data.

use std::io::Cursor;

use flate2::write::ZlibEncoder;
use tiff::ColorType;
use tiff::decoder::{Decoder, DecodingResult, Limits};
use tiff::encoder::TiffEncoder;
use tiff::tags::Tag;

use super::{Dem, DemError, GeoRef, ReadLimits};
use crate::heightfield::Heightfield;

/// The longest ASCII tag read (GeoAsciiParams, GDAL_NODATA); longer ones are refused before
/// they are read.
pub const MAX_ASCII_TAG: u64 = 64 * 1024;

/// The `tiff` crate's error in words a user can act on: a truncated file or tags that
/// contradict each other, where the crate says "failed to fill whole buffer" or
/// "inconsistent sizes encountered".
fn tiff_message(e: tiff::TiffError) -> String {
    use tiff::{TiffError, TiffFormatError};
    match &e {
        TiffError::IoError(io) if io.kind() == std::io::ErrorKind::UnexpectedEof => {
            "the file ends before the image data its tags describe (truncated?)".into()
        }
        TiffError::FormatError(TiffFormatError::InconsistentSizesEncountered) => {
            "its tags disagree about the size of the image or of its strips or tiles (a \
             damaged or hand-edited file)"
                .into()
        }
        _ => e.to_string(),
    }
}

/// Reads the first image of a GeoTIFF. Cells equal to GDAL_NODATA (and NaN floats) become
/// NaN; a GDAL_NODATA that is not a number is an error, and so is a finite sample beyond the
/// `f32` range. The size is checked against `limits` before the pixels are decoded.
pub fn read(bytes: &[u8], limits: ReadLimits) -> Result<Dem, DemError> {
    let tiff_err = |e: tiff::TiffError| DemError::Tiff(tiff_message(e));
    let mut decoder = Decoder::new(Cursor::new(bytes)).map_err(tiff_err)?;
    let (width, height) = decoder.dimensions().map_err(tiff_err)?;
    limits.check(u64::from(width), u64::from(height))?;
    // ASCII tags longer than the decoder's buffer limit make the `tiff` crate print a debug
    // line: their lengths are checked from the directory first.
    if let Some(ptr) = decoder.ifd_pointer() {
        let dir = decoder.read_directory(ptr).map_err(tiff_err)?;
        for (tag, name) in [
            (Tag::GeoAsciiParamsTag, "GeoAsciiParams"),
            (Tag::GdalNodata, "GDAL_NODATA"),
        ] {
            if let Some(entry) = dir.get(tag)
                && entry.count() > MAX_ASCII_TAG
            {
                return Err(DemError::Tiff(format!(
                    "the {name} tag is {} bytes long; at most {MAX_ASCII_TAG} are read",
                    entry.count()
                )));
            }
        }
    }
    // The decoder's own buffer limit: the raster at 8 bytes a sample (and the ASCII tags).
    let mut decoder_limits = Limits::default();
    decoder_limits.decoding_buffer_size = (u64::from(width) * u64::from(height) * 8)
        .max(MAX_ASCII_TAG)
        .try_into()
        .unwrap_or(usize::MAX);
    decoder = decoder.with_limits(decoder_limits);
    match decoder.colortype().map_err(tiff_err)? {
        ColorType::Gray(_) => {}
        other => {
            return Err(DemError::Unsupported(format!(
                "unsupported GeoTIFF layout: {other:?}: an elevation GeoTIFF has one band of \
                 samples"
            )));
        }
    }
    let bits = match decoder.colortype().map_err(tiff_err)? {
        ColorType::Gray(bits) => u64::from(bits),
        _ => 64,
    };
    check_data_present(&mut decoder, u64::from(width) * u64::from(height), bits)?;
    let georef = GeoRef {
        pixel_scale: decoder.get_tag_f64_vec(Tag::ModelPixelScaleTag).ok(),
        tiepoint: decoder.get_tag_f64_vec(Tag::ModelTiepointTag).ok(),
        transformation: decoder.get_tag_f64_vec(Tag::ModelTransformationTag).ok(),
        geo_keys: decoder.get_tag_u16_vec(Tag::GeoKeyDirectoryTag).ok(),
        geo_doubles: decoder.get_tag_f64_vec(Tag::GeoDoubleParamsTag).ok(),
        geo_ascii: decoder
            .get_tag_ascii_string(Tag::GeoAsciiParamsTag)
            .ok()
            .map(|text| ascii_only(&text)),
    };
    let nodata = match decoder.find_tag(Tag::GdalNodata).map_err(tiff_err)? {
        None => None,
        Some(value) => {
            let text = value
                .into_string()
                .map_err(|_| DemError::Tiff("the GDAL_NODATA tag is not text".into()))?;
            let text = text.trim_matches(char::from(0)).trim();
            Some(text.parse::<f64>().map_err(|_| {
                DemError::Tiff(format!(
                    "the GDAL_NODATA tag '{}' is not a number, so the no-data cells are unknown",
                    super::clip(text)
                ))
            })?)
        }
    };
    let samples = decoder.read_image().map_err(tiff_err)?;
    let values = to_f32(samples, nodata)?;
    if let Some(i) = values.iter().position(|v| v.is_infinite()) {
        let w = width as usize;
        return Err(DemError::Tiff(format!(
            "row {}, column {}: the sample is beyond the 32-bit float range (+-3.4e38) or \
             infinite; mark missing cells with GDAL_NODATA",
            i / w.max(1),
            i % w.max(1)
        )));
    }
    let (w, h) = (width as usize, height as usize);
    if values.len() != w * h {
        return Err(DemError::Tiff(format!(
            "{} samples decoded for {w} x {h} cells",
            values.len()
        )));
    }
    let field = Heightfield::from_vec(w, h, values).map_err(|e| DemError::Tiff(e.to_string()))?;
    Ok(Dem { field, georef })
}

/// GeoAsciiParams as the TIFF writer takes it: 7-bit text without NUL. The reader accepts any
/// UTF-8 (and a short tag may hold a NUL between its strings), which the writer refuses, so a
/// file read could not be written back. Each other byte becomes '?', one byte for one, because
/// the GeoKey directory points into this text by byte offset and length (GeoTIFF 1.1, 7.1.4).
fn ascii_only(text: &str) -> String {
    text.bytes()
        .map(|b| {
            if b.is_ascii() && b != 0 {
                char::from(b)
            } else {
                '?'
            }
        })
        .collect()
}

/// The most bytes one byte of compressed samples can decode to: LZW's 12-bit codes stand for
/// at most 4096 bytes each (deflate's limit, 1032, and PackBits', 64, are lower).
const MAX_EXPANSION: u64 = 4096;

/// Refuses a file whose header declares more samples than its strips or tiles can hold, and
/// one whose samples the machine cannot hold, before the decoder allocates them (a 198-byte
/// file declaring 100000^2 cells would otherwise abort the process on a 40 GB allocation).
fn check_data_present<R: std::io::Read + std::io::Seek>(
    decoder: &mut Decoder<R>,
    cells: u64,
    bits: u64,
) -> Result<(), DemError> {
    let need = cells.saturating_mul(bits).div_ceil(8);
    // Every TIFF writer records where its samples are; without the counts the decoder
    // finds out by itself, and only the memory check below applies.
    if let Ok(counts) = decoder
        .get_tag_u64_vec(Tag::StripByteCounts)
        .or_else(|_| decoder.get_tag_u64_vec(Tag::TileByteCounts))
    {
        let stored = counts.iter().fold(0u64, |a, &c| a.saturating_add(c));
        let compressed = decoder.get_tag_u32(Tag::Compression).is_ok_and(|c| c != 1);
        let most = if compressed {
            stored.saturating_mul(MAX_EXPANSION)
        } else {
            stored
        };
        if most < need {
            return Err(DemError::Tiff(format!(
                "the header declares {cells} samples ({need} bytes) but the file stores \
                 {stored} bytes of them{}: it is truncated or its header is wrong",
                if compressed {
                    ", more than any compression expands to"
                } else {
                    ""
                }
            )));
        }
    }
    // The decoder's buffer plus the heights made from it, reserved now so that a size the
    // machine cannot hold is an error, not an abort.
    super::reserve_check(need.saturating_add(cells.saturating_mul(4)))
}

/// Converts decoded samples to `f32` heights, mapping no-data and NaN to NaN. Infinite
/// samples and finite ones beyond `f32` come out infinite (the caller refuses them).
fn to_f32(samples: DecodingResult, nodata: Option<f64>) -> Result<Vec<f32>, DemError> {
    fn map<T: Copy>(v: Vec<T>, nodata: Option<f64>, f: impl Fn(T) -> f64) -> Vec<f32> {
        v.into_iter()
            .map(|s| {
                let x = f(s);
                if x.is_nan() || nodata.is_some_and(|n| x == n || (n.is_nan() && x.is_nan())) {
                    f32::NAN
                } else {
                    x as f32
                }
            })
            .collect()
    }
    Ok(match samples {
        DecodingResult::U8(v) => map(v, nodata, f64::from),
        DecodingResult::U16(v) => map(v, nodata, f64::from),
        DecodingResult::U32(v) => map(v, nodata, f64::from),
        DecodingResult::I8(v) => map(v, nodata, f64::from),
        DecodingResult::I16(v) => map(v, nodata, f64::from),
        DecodingResult::I32(v) => map(v, nodata, f64::from),
        DecodingResult::F32(v) => map(v, nodata, f64::from),
        DecodingResult::F64(v) => map(v, nodata, |x| x),
        DecodingResult::U64(v) => map(v, nodata, |x| x as f64),
        DecodingResult::I64(v) => map(v, nodata, |x| x as f64),
        DecodingResult::F16(v) => map(v, nodata, |x| f64::from(x.to_f32())),
    })
}

/// Writes `field` as a Deflate-compressed float32 GeoTIFF (the fast level: on terrain floats it
/// compresses within 0.2% of the default level in a third of the time) with `georef`'s tags and
/// GDAL_NODATA = nan when the field has no-data cells.
pub fn write(field: &Heightfield, georef: &GeoRef) -> Result<Vec<u8>, DemError> {
    crate::jobs::run_inline(|ctx| async move { write_in(field, georef, &ctx).await })
}

/// Uncompressed bytes in a strip (GDAL's habit is 8 KiB; larger strips compress a little
/// better and make a shorter offset table).
const STRIP_BYTES: usize = 64 * 1024;

/// [`write`] in a job: the strips are compressed one at a time (zlib, as TIFF's Deflate,
/// compression 8, takes it) with a tick after each, then the directory is written with
/// their offsets (TIFF 6.0, sec. 3 "Bilevel Images", strips; the `tiff` crate writes the
/// header and the directory).
pub async fn write_in(
    field: &Heightfield,
    georef: &GeoRef,
    ctx: &crate::jobs::JobCtx,
) -> Result<Vec<u8>, DemError> {
    use std::io::Write as _;
    let err = |e: tiff::TiffError| DemError::Write(e.to_string());
    let io = |e: std::io::Error| DemError::Write(e.to_string());
    let too_big = |_| DemError::Write("the GeoTIFF would pass 4 GB".into());
    let (w, h) = (field.width(), field.height());
    let rows_per_strip = (STRIP_BYTES / (w * 4)).clamp(1, h);
    let mut out = Cursor::new(Vec::new());
    let mut encoder = TiffEncoder::new(&mut out).map_err(err)?;
    let mut dir = encoder.image_directory().map_err(err)?;
    let (mut offsets, mut counts) = (Vec::<u32>::new(), Vec::<u32>::new());
    let mut raw = Vec::with_capacity(rows_per_strip * w * 4);
    for (k, strip) in field.data().chunks(rows_per_strip * w).enumerate() {
        ctx.tick_of(k * rows_per_strip, h, "writing the GeoTIFF")
            .await
            .map_err(|_| DemError::Cancelled)?;
        raw.clear();
        strip
            .iter()
            .for_each(|z| raw.extend_from_slice(&z.to_ne_bytes()));
        let mut zlib = ZlibEncoder::new(Vec::new(), flate2::Compression::fast());
        zlib.write_all(&raw).map_err(io)?;
        let bytes = zlib.finish().map_err(io)?;
        let offset = dir.write_data(bytes.as_slice()).map_err(err)?;
        offsets.push(u32::try_from(offset).map_err(too_big)?);
        counts.push(u32::try_from(bytes.len()).map_err(too_big)?);
    }
    let tag = |dir: &mut tiff::encoder::DirectoryEncoder<'_, _, _>, t, v: u16| {
        dir.write_tag(t, v).map_err(err)
    };
    dir.write_tag(Tag::ImageWidth, w as u32).map_err(err)?;
    dir.write_tag(Tag::ImageLength, h as u32).map_err(err)?;
    tag(&mut dir, Tag::BitsPerSample, 32)?;
    // 8: Deflate (Adobe), as the crate and GDAL write it.
    tag(&mut dir, Tag::Compression, 8)?;
    // 1: BlackIsZero.
    tag(&mut dir, Tag::PhotometricInterpretation, 1)?;
    dir.write_tag(Tag::StripOffsets, offsets.as_slice())
        .map_err(err)?;
    tag(&mut dir, Tag::SamplesPerPixel, 1)?;
    dir.write_tag(Tag::RowsPerStrip, rows_per_strip as u32)
        .map_err(err)?;
    dir.write_tag(Tag::StripByteCounts, counts.as_slice())
        .map_err(err)?;
    // No physical resolution (unit 1: none, 1 pixel per unit), as the crate writes it.
    let one = tiff::encoder::Rational { n: 1, d: 1 };
    dir.write_tag(Tag::XResolution, one.clone()).map_err(err)?;
    dir.write_tag(Tag::YResolution, one).map_err(err)?;
    tag(&mut dir, Tag::ResolutionUnit, 1)?;
    // 1: no predictor; 1: chunky; 3: IEEE floating point.
    tag(&mut dir, Tag::Predictor, 1)?;
    tag(&mut dir, Tag::PlanarConfiguration, 1)?;
    tag(&mut dir, Tag::SampleFormat, 3)?;
    if let Some(v) = &georef.pixel_scale {
        dir.write_tag(Tag::ModelPixelScaleTag, v.as_slice())
            .map_err(err)?;
    }
    if let Some(v) = &georef.tiepoint {
        dir.write_tag(Tag::ModelTiepointTag, v.as_slice())
            .map_err(err)?;
    }
    if let Some(v) = &georef.transformation {
        dir.write_tag(Tag::ModelTransformationTag, v.as_slice())
            .map_err(err)?;
    }
    if let Some(v) = &georef.geo_keys {
        dir.write_tag(Tag::GeoKeyDirectoryTag, v.as_slice())
            .map_err(err)?;
    }
    if let Some(v) = &georef.geo_doubles {
        dir.write_tag(Tag::GeoDoubleParamsTag, v.as_slice())
            .map_err(err)?;
    }
    if let Some(v) = &georef.geo_ascii {
        dir.write_tag(Tag::GeoAsciiParamsTag, v.as_str())
            .map_err(err)?;
    }
    if field.data().iter().any(|v| v.is_nan()) {
        dir.write_tag(Tag::GdalNodata, "nan").map_err(err)?;
    }
    dir.finish().map_err(err)?;
    Ok(out.into_inner())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn float_round_trip_is_bit_exact_and_keeps_georeferencing() {
        let data: Vec<f32> = (0..35).map(|i| (i as f32 * 1.37).sin() * 100.0).collect();
        let mut data = data;
        data[4] = f32::NAN;
        let field = Heightfield::from_vec(7, 5, data).unwrap();
        let georef = GeoRef {
            pixel_scale: Some(vec![90.0, 90.0, 0.0]),
            tiepoint: Some(vec![0.0, 0.0, 0.0, 500_000.0, 9_000_000.0, 0.0]),
            geo_keys: Some(vec![1, 1, 0, 1, 3072, 0, 1, 32725]),
            ..Default::default()
        };
        let bytes = write(&field, &georef).unwrap();
        let dem = read(&bytes, ReadLimits::default()).unwrap();
        assert_eq!(dem.georef, georef);
        for (a, b) in dem.field.data().iter().zip(field.data()) {
            assert!(a.to_bits() == b.to_bits() || (a.is_nan() && b.is_nan()));
        }
        assert_eq!(dem.void_cells(), 1);
    }

    #[test]
    fn size_is_refused_before_decoding() {
        let field = Heightfield::filled(64, 64, 1.0).unwrap();
        let bytes = write(&field, &GeoRef::default()).unwrap();
        let err = read(&bytes, ReadLimits { max_cells: 1000 }).unwrap_err();
        assert!(
            err.to_string().contains("exceed the limit of 1000 cells"),
            "{err}"
        );
    }

    /// A 2 x 2 float64 GeoTIFF with `values` and an optional GDAL_NODATA string.
    fn f64_tiff(values: &[f64; 4], nodata: Option<&str>) -> Vec<u8> {
        use tiff::encoder::colortype::Gray64Float;
        let mut out = Cursor::new(Vec::new());
        let mut encoder = TiffEncoder::new(&mut out).unwrap();
        let mut image = encoder.new_image::<Gray64Float>(2, 2).unwrap();
        if let Some(text) = nodata {
            image.encoder().write_tag(Tag::GdalNodata, text).unwrap();
        }
        image.write_data(values).unwrap();
        out.into_inner()
    }

    #[test]
    fn nodata_must_be_a_number_and_samples_must_fit_f32() {
        let ok = read(
            &f64_tiff(&[1.0, -9999.0, 3.0, 4.0], Some("-9999")),
            Default::default(),
        )
        .unwrap();
        assert!(ok.field.data()[1].is_nan());
        let err = read(
            &f64_tiff(&[1.0; 4], Some("none at all")),
            Default::default(),
        )
        .unwrap_err()
        .to_string();
        assert!(
            err.contains("GDAL_NODATA") && err.contains("none at all"),
            "{err}"
        );
        let long = "x".repeat(5000);
        let err = read(&f64_tiff(&[1.0; 4], Some(&long)), Default::default())
            .unwrap_err()
            .to_string();
        assert!(err.len() < 300, "{err}");
        let huge = [1.0, 1e300, 3.0, 4.0];
        let err = read(&f64_tiff(&huge, None), Default::default())
            .unwrap_err()
            .to_string();
        assert!(
            err.contains("row 0, column 1") && err.contains("32-bit"),
            "{err}"
        );
        let inf = [1.0, 2.0, f64::NEG_INFINITY, 4.0];
        assert!(read(&f64_tiff(&inf, None), Default::default()).is_err());
        // An infinite GDAL_NODATA marks the infinite cells as no-data.
        let marked = read(&f64_tiff(&inf, Some("-inf")), Default::default()).unwrap();
        assert_eq!(marked.void_cells(), 1);
    }

    #[test]
    fn geo_ascii_params_beyond_ascii_are_kept_byte_for_byte_and_write_back() {
        let field = Heightfield::filled(3, 2, 7.0).unwrap();
        let georef = GeoRef {
            geo_ascii: Some("Lambert|WGS 84|".into()),
            ..Default::default()
        };
        let mut bytes = write(&field, &georef).unwrap();
        // 'é' in UTF-8 over "La": the tag's length in bytes stays the same.
        let at = bytes.windows(7).position(|w| w == b"Lambert").unwrap();
        bytes[at..at + 2].copy_from_slice("é".as_bytes());
        let read_back = read(&bytes, ReadLimits::default()).unwrap();
        let text = read_back.georef.geo_ascii.clone().unwrap();
        assert_eq!(text, "??mbert|WGS 84|");
        let again = read(
            &write(&read_back.field, &read_back.georef).unwrap(),
            Default::default(),
        );
        assert_eq!(
            again.unwrap().georef.geo_ascii.as_deref(),
            Some(text.as_str())
        );
        assert_eq!(ascii_only("a\0b"), "a?b");
    }

    #[test]
    fn garbage_and_truncation_are_errors_not_panics() {
        assert!(read(b"not a tiff at all", ReadLimits::default()).is_err());
        let field = Heightfield::filled(40, 30, 2.5).unwrap();
        let bytes = write(&field, &GeoRef::default()).unwrap();
        for cut in [8, 40, bytes.len() / 2, bytes.len() - 3] {
            assert!(
                read(&bytes[..cut], ReadLimits::default()).is_err(),
                "cut at {cut}"
            );
        }
    }
}
