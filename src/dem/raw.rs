//! RAW R16 heightmaps (Unity's terrain import, World Machine, Gaea): unsigned 16-bit
//! little-endian samples, row by row, no header. The heights are normalised to the field's
//! range (`z = zmin + v / 65535 * (zmax - zmin)`, recorded in the sidecar JSON); Unity reads
//! rows bottom-up, hence the optional Y flip.

use super::{Dem, DemError, GeoRef, ReadLimits};
use crate::heightfield::Heightfield;

/// Encodes `field` (NaN as 0) and returns the bytes and the `(min, max)` range used.
pub fn write(field: &Heightfield, flip_y: bool) -> (Vec<u8>, (f32, f32)) {
    let (lo, hi) = field.finite_range().unwrap_or((0.0, 0.0));
    let span = f64::from(hi - lo);
    let mut out = Vec::with_capacity(field.data().len() * 2);
    let w = field.width();
    for y in 0..field.height() {
        let row = if flip_y { field.height() - 1 - y } else { y };
        for &z in &field.data()[row * w..(row + 1) * w] {
            let v = if z.is_finite() && span > 0.0 {
                ((f64::from(z - lo) / span) * 65535.0)
                    .round()
                    .clamp(0.0, 65535.0) as u16
            } else {
                0
            };
            out.extend_from_slice(&v.to_le_bytes());
        }
    }
    (out, (lo, hi))
}

/// Decodes a square R16 file (the size comes from the byte count) with the height range
/// `z_range`; `flip_y` undoes a bottom-up write.
pub fn read(
    bytes: &[u8],
    z_range: Option<(f32, f32)>,
    flip_y: bool,
    limits: ReadLimits,
) -> Result<Dem, DemError> {
    let bad = |problem: String| DemError::Malformed {
        format: "RAW R16",
        problem,
    };
    if bytes.is_empty() {
        return Err(DemError::Empty);
    }
    let samples = bytes.len() / 2;
    let n = samples.isqrt();
    if !bytes.len().is_multiple_of(2) || n * n != samples {
        return Err(bad(format!(
            "{} bytes is not a square grid of 16-bit samples",
            bytes.len()
        )));
    }
    limits.check(n as u64, n as u64)?;
    let (lo, hi) = z_range.ok_or_else(|| {
        bad("a RAW file does not say its height range; give it (--z-range MIN,MAX)".into())
    })?;
    if !(lo.is_finite() && hi.is_finite()) {
        return Err(bad(format!("the height range {lo},{hi} is not finite")));
    }
    let mut data = vec![0.0f32; samples];
    for (i, b) in bytes.chunks_exact(2).enumerate() {
        let (x, y) = (i % n, i / n);
        let row = if flip_y { n - 1 - y } else { y };
        let v = f64::from(u16::from_le_bytes([b[0], b[1]]));
        data[row * n + x] = (f64::from(lo) + v / 65535.0 * f64::from(hi - lo)) as f32;
    }
    let field = Heightfield::from_vec(n, n, data).map_err(|_| DemError::Empty)?;
    Ok(Dem {
        field,
        georef: GeoRef::default(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trip_within_one_step_with_and_without_flip() {
        let data: Vec<f32> = (0..25).map(|i| (i as f32 * 1.3).sin() * 50.0).collect();
        let field = Heightfield::from_vec(5, 5, data).unwrap();
        for flip in [false, true] {
            let (bytes, range) = write(&field, flip);
            let back = read(&bytes, Some(range), flip, ReadLimits::default()).unwrap();
            let step = (range.1 - range.0) / 65535.0;
            assert!(back.field.max_abs_diff(&field).unwrap() <= step * 0.51);
        }
        let (bytes, _) = write(&field, true);
        // Flipped: the first row written is the field's last.
        let first = u16::from_le_bytes([bytes[0], bytes[1]]);
        let (unflipped, _) = write(&field, false);
        assert_eq!(first, u16::from_le_bytes([unflipped[40], unflipped[41]]));
    }
}
