//! SRTM `.hgt` tiles: a square grid of big-endian `i16` metres, rows from north to south,
//! no header. 1201^2 (3 arc-seconds) and 3601^2 (1 arc-second) are the sizes NASA ships;
//! any square size is accepted. -32768 marks a void. The tile name (`N37W122.hgt`) gives
//! its south-west corner, from which the georeferencing (EPSG:4326) is rebuilt.

use super::{Dem, DemError, GeoRef, ReadLimits};
use crate::heightfield::Heightfield;

/// The SRTM void value.
pub const VOID: i16 = -32768;

/// Reads a tile. `name` is the file name (for the georeferencing; may be empty).
pub fn read(name: &str, bytes: &[u8], limits: ReadLimits) -> Result<Dem, DemError> {
    let bad = |problem: String| DemError::Malformed {
        format: "SRTM .hgt",
        problem,
    };
    if bytes.is_empty() {
        return Err(DemError::Empty);
    }
    if !bytes.len().is_multiple_of(2) {
        return Err(bad(format!(
            "{} bytes is not a whole number of 16-bit samples (truncated?)",
            bytes.len()
        )));
    }
    let samples = bytes.len() / 2;
    let n = samples.isqrt();
    if n * n != samples || n < 2 {
        return Err(bad(format!(
            "{samples} samples is not a square grid; SRTM tiles are 1201 x 1201 (2,884,802 \
             bytes) or 3601 x 3601 (25,934,402 bytes)"
        )));
    }
    limits.check(n as u64, n as u64)?;
    let data: Vec<f32> = bytes
        .chunks_exact(2)
        .map(|b| match i16::from_be_bytes([b[0], b[1]]) {
            VOID => f32::NAN,
            v => f32::from(v),
        })
        .collect();
    let field = Heightfield::from_vec(n, n, data).map_err(|_| DemError::Empty)?;
    Ok(Dem {
        field,
        georef: georef_from_name(name, n).unwrap_or_default(),
    })
}

/// `N37W122` (any case, any extension) to its south-west corner (lat, lon) in degrees.
pub fn corner_from_name(name: &str) -> Option<(f64, f64)> {
    let stem = name.rsplit(['/', '\\']).next()?;
    let stem = stem.get(..7)?.to_ascii_uppercase();
    let b = stem.as_bytes();
    let lat: f64 = stem.get(1..3)?.parse().ok()?;
    let lon: f64 = stem.get(4..7)?.parse().ok()?;
    let lat = match b[0] {
        b'N' => lat,
        b'S' => -lat,
        _ => return None,
    };
    let lon = match b[3] {
        b'E' => lon,
        b'W' => -lon,
        _ => return None,
    };
    Some((lat, lon))
}

/// SRTM samples sit on whole arc-second lines: sample (0, 0) is the tile's north-west corner
/// point. As a GeoTIFF (PixelIsArea) the raster's outer corner is half a cell beyond it.
fn georef_from_name(name: &str, n: usize) -> Option<GeoRef> {
    let (lat, lon) = corner_from_name(name)?;
    let step = 1.0 / (n - 1) as f64;
    Some(GeoRef {
        pixel_scale: Some(vec![step, step, 0.0]),
        tiepoint: Some(vec![
            0.0,
            0.0,
            0.0,
            lon - step / 2.0,
            lat + 1.0 + step / 2.0,
            0.0,
        ]),
        transformation: None,
        // GTModelType = geographic, GTRasterType = PixelIsArea, GeographicType = 4326.
        geo_keys: Some(vec![
            1, 1, 0, 3, 1024, 0, 1, 2, 1025, 0, 1, 1, 2048, 0, 1, 4326,
        ]),
        geo_doubles: None,
        geo_ascii: None,
    })
}

/// Writes a tile (heights rounded to whole metres, NaN as -32768). Only square fields.
pub fn write(field: &Heightfield) -> Result<Vec<u8>, DemError> {
    if field.width() != field.height() {
        return Err(DemError::Write(format!(
            "an SRTM tile is square; this field is {} x {}",
            field.width(),
            field.height()
        )));
    }
    let mut out = Vec::with_capacity(field.data().len() * 2);
    for &z in field.data() {
        let v = if z.is_finite() {
            z.round().clamp(-32767.0, 32767.0) as i16
        } else {
            VOID
        };
        out.extend_from_slice(&v.to_be_bytes());
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tile_names_give_the_corner() {
        assert_eq!(corner_from_name("N37W122.hgt"), Some((37.0, -122.0)));
        assert_eq!(corner_from_name("dir/s05e010.HGT"), Some((-5.0, 10.0)));
        assert_eq!(corner_from_name("x.hgt"), None);
    }

    #[test]
    fn voids_become_nan_and_odd_sizes_are_errors() {
        let mut bytes = Vec::new();
        for v in [1i16, -32768, 300, -5] {
            bytes.extend_from_slice(&v.to_be_bytes());
        }
        let dem = read("N00E000.hgt", &bytes, ReadLimits::default()).unwrap();
        assert_eq!(dem.field.width(), 2);
        assert!(dem.field.data()[1].is_nan());
        assert_eq!(dem.field.data()[3], -5.0);
        assert!(dem.georef.pixel_scale.is_some());
        assert!(read("a.hgt", &bytes[..7], ReadLimits::default()).is_err());
        assert!(read("a.hgt", &bytes[..6], ReadLimits::default()).is_err());
        let tiny = ReadLimits { max_cells: 3 };
        assert!(matches!(
            read("a.hgt", &bytes, tiny),
            Err(DemError::TooLarge { .. })
        ));
    }
}
