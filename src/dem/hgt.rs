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
    if n < 2 {
        return Err(bad(format!(
            "the file is {} bytes, {samples} sample{}: too short for the smallest grid (2 x 2, \
             8 bytes); SRTM tiles are 1201 x 1201 (2,884,802 bytes) or 3601 x 3601 \
             (25,934,402 bytes)",
            bytes.len(),
            if samples == 1 { "" } else { "s" }
        )));
    }
    if n * n != samples {
        return Err(bad(format!(
            "{samples} samples is not a square grid of at least 2 x 2; SRTM tiles are 1201 x \
             1201 (2,884,802 bytes) or 3601 x 3601 (25,934,402 bytes)"
        )));
    }
    limits.check(n as u64, n as u64)?;
    let georef = match tile_name(name) {
        TileName::Corner(lat, lon) => georef_at(lat, lon, n),
        TileName::Other => GeoRef::default(),
        TileName::Impossible(problem) => return Err(bad(problem)),
    };
    let data: Vec<f32> = bytes
        .chunks_exact(2)
        .map(|b| match i16::from_be_bytes([b[0], b[1]]) {
            VOID => f32::NAN,
            v => f32::from(v),
        })
        .collect();
    let field = Heightfield::from_vec(n, n, data).map_err(|_| DemError::Empty)?;
    Ok(Dem { field, georef })
}

/// What a file name says about the tile's place.
#[derive(Debug, PartialEq)]
enum TileName {
    /// South-west corner (lat, lon) in degrees.
    Corner(f64, f64),
    /// Not of the form `N37W122`: the tile is read without georeferencing.
    Other,
    /// Of that form, but no such tile exists on Earth (`N95E999`): an error, not a tile
    /// georeferenced off the globe.
    Impossible(String),
}

fn tile_name(name: &str) -> TileName {
    let parse = || -> Option<(u8, f64, u8, f64)> {
        let stem = name.rsplit(['/', '\\']).next()?;
        let stem = stem.get(..7)?.to_ascii_uppercase();
        let b = stem.as_bytes();
        let lat: f64 = stem.get(1..3)?.parse().ok()?;
        let lon: f64 = stem.get(4..7)?.parse().ok()?;
        (matches!(b[0], b'N' | b'S') && matches!(b[3], b'E' | b'W'))
            .then_some((b[0], lat, b[3], lon))
    };
    let Some((ns, lat, ew, lon)) = parse() else {
        return TileName::Other;
    };
    let lat = if ns == b'N' { lat } else { -lat };
    let lon = if ew == b'E' { lon } else { -lon };
    // A tile's south-west corner: latitudes -90..=89, longitudes -180..=179.
    if !(-90.0..=89.0).contains(&lat) || !(-180.0..=179.0).contains(&lon) {
        return TileName::Impossible(format!(
            "the tile name says latitude {lat}, longitude {lon}; an SRTM tile's south-west \
             corner lies at latitude -90 to 89 and longitude -180 to 179 (rename the file to \
             read it without georeferencing)"
        ));
    }
    TileName::Corner(lat, lon)
}

/// `N37W122` (any case, any extension) to its south-west corner (lat, lon) in degrees; `None`
/// for other names and for corners off the globe.
pub fn corner_from_name(name: &str) -> Option<(f64, f64)> {
    match tile_name(name) {
        TileName::Corner(lat, lon) => Some((lat, lon)),
        _ => None,
    }
}

/// SRTM samples sit on whole arc-second lines: sample (0, 0) is the tile's north-west corner
/// point. As a GeoTIFF (PixelIsArea) the raster's outer corner is half a cell beyond it.
fn georef_at(lat: f64, lon: f64, n: usize) -> GeoRef {
    let step = 1.0 / (n - 1) as f64;
    GeoRef {
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
    }
}

/// Writes a tile (heights rounded to whole metres, NaN as -32768). Only square fields, and
/// only heights that fit: a height beyond -32767..32767 m is refused, never clipped.
pub fn write(field: &Heightfield) -> Result<Vec<u8>, DemError> {
    if field.width() != field.height() {
        return Err(DemError::Write(format!(
            "an SRTM tile is square; this field is {} x {}",
            field.width(),
            field.height()
        )));
    }
    // The reader takes at least 2 x 2 (a tile's edges are shared with its neighbours).
    if field.width() < 2 {
        return Err(DemError::Write(format!(
            "an SRTM tile has at least 2 x 2 samples; this field is {0} x {0}",
            field.width()
        )));
    }
    let outside: Vec<f32> = field
        .data()
        .iter()
        .copied()
        .filter(|z| z.is_finite() && !(-32767.5..32767.5).contains(z))
        .collect();
    if let Some(worst) = outside
        .iter()
        .copied()
        .max_by(|a, b| a.abs().total_cmp(&b.abs()))
    {
        return Err(DemError::Write(format!(
            "{} cells lie outside the SRTM range -32767..32767 m (the farthest at {worst} m) \
             and would be clipped; lower the z scale or write .tif",
            outside.len()
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
        assert_eq!(corner_from_name("S90W180.hgt"), Some((-90.0, -180.0)));
        assert_eq!(corner_from_name("N95E999.hgt"), None);
        let bytes = [0u8; 8];
        let err = read("N95E999.hgt", &bytes, ReadLimits::default()).unwrap_err();
        assert!(err.to_string().contains("latitude 95"), "{err}");
        assert!(read("N90E000.hgt", &bytes, ReadLimits::default()).is_err());
        assert!(read("E00N000.hgt", &bytes, ReadLimits::default()).is_ok());
    }

    #[test]
    fn heights_beyond_the_tile_range_are_refused_not_clipped() {
        let field = Heightfield::from_vec(2, 2, vec![0.0, 40_000.0, -50_000.0, 1.0]).unwrap();
        let err = write(&field).unwrap_err().to_string();
        assert!(err.contains("2 cells") && err.contains("-50000"), "{err}");
        let ok = Heightfield::from_vec(2, 2, vec![32767.0, -32767.0, f32::NAN, 1.0]).unwrap();
        assert!(write(&ok).is_ok());
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
