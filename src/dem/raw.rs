//! RAW R16 heightmaps (Unity's terrain import, World Machine, Gaea): unsigned 16-bit
//! little-endian samples, row by row, no header. The heights are normalised to the field's
//! range (`z = zmin + v / 65535 * (zmax - zmin)`, recorded in the sidecar JSON); Unity reads
//! rows bottom-up, hence the optional Y flip.

use super::{Dem, DemError, GeoRef, ReadLimits};
use crate::heightfield::Heightfield;
use crate::jobs::{Cancelled, JobCtx, finish_inline};

/// Encodes `field` and returns the bytes and the `(min, max)` range used. R16 has no no-data
/// value: [`super::format::write`] refuses fields with no-data cells before they get here
/// (a NaN would be written as 0, the minimum).
pub fn write(field: &Heightfield, flip_y: bool) -> (Vec<u8>, (f32, f32)) {
    let range = field.finite_range().unwrap_or((0.0, 0.0));
    finish_inline(|ctx| async move { write_in(field, flip_y, range, &ctx).await })
}

/// [`write`] spread over the range `(lo, hi)` instead of the field's own (tiles of one map
/// share one range; heights outside it are clamped), in a job: a tick after each row.
pub async fn write_in(
    field: &Heightfield,
    flip_y: bool,
    (lo, hi): (f32, f32),
    ctx: &JobCtx,
) -> Result<(Vec<u8>, (f32, f32)), Cancelled> {
    let span = f64::from(hi - lo);
    let mut out = Vec::with_capacity(field.data().len() * 2);
    let w = field.width();
    for y in 0..field.height() {
        ctx.tick_of(y, field.height(), "writing the R16 file")
            .await?;
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
    Ok((out, (lo, hi)))
}

/// Decodes a square R16 file (the size comes from the byte count) with the height range
/// `z_range`; `flip_y` undoes a bottom-up write.
pub fn read(
    bytes: &[u8],
    z_range: Option<(f32, f32)>,
    flip_y: bool,
    limits: ReadLimits,
) -> Result<Dem, DemError> {
    read_sized(bytes, z_range, flip_y, limits, None)
}

/// [`read`] with the size `(width, height)` when the sidecar says it (any shape; the byte
/// count must match), else a square from the byte count.
pub fn read_sized(
    bytes: &[u8],
    z_range: Option<(f32, f32)>,
    flip_y: bool,
    limits: ReadLimits,
    size: Option<(usize, usize)>,
) -> Result<Dem, DemError> {
    let bad = |problem: String| DemError::Malformed {
        format: "RAW R16",
        problem,
    };
    if bytes.is_empty() {
        return Err(DemError::Empty);
    }
    let samples = bytes.len() / 2;
    let (w, h) = match size {
        Some((w, h)) => {
            limits.check(w as u64, h as u64)?;
            if !bytes.len().is_multiple_of(2) || samples != w * h {
                return Err(bad(format!(
                    "the sidecar says {w} x {h} cells ({} bytes), the file has {} bytes",
                    w * h * 2,
                    bytes.len()
                )));
            }
            (w, h)
        }
        None => {
            let n = samples.isqrt();
            if !bytes.len().is_multiple_of(2) || n * n != samples {
                return Err(bad(format!(
                    "{} bytes is not a square grid of 16-bit samples (a non-square file \
                     needs \"width\" and \"height\" in its sidecar .json)",
                    bytes.len()
                )));
            }
            limits.check(n as u64, n as u64)?;
            (n, n)
        }
    };
    let (lo, hi) = z_range.ok_or_else(|| {
        bad("a RAW file does not say its height range; give it (--z-range MIN,MAX)".into())
    })?;
    super::sidecar::check_range(lo, hi, "RAW R16").map_err(bad)?;
    let mut data = vec![0.0f32; samples];
    for (i, b) in bytes.chunks_exact(2).enumerate() {
        let (x, y) = (i % w, i / w);
        let row = if flip_y { h - 1 - y } else { y };
        let v = f64::from(u16::from_le_bytes([b[0], b[1]]));
        data[row * w + x] = (f64::from(lo) + v / 65535.0 * f64::from(hi - lo)) as f32;
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

    #[test]
    fn non_square_files_read_with_their_size_and_bad_ranges_are_refused() {
        let data: Vec<f32> = (0..12).map(|i| i as f32).collect();
        let field = Heightfield::from_vec(4, 3, data).unwrap();
        for flip in [false, true] {
            let (bytes, range) = write(&field, flip);
            assert!(read(&bytes, Some(range), flip, ReadLimits::default()).is_err());
            let back = read_sized(
                &bytes,
                Some(range),
                flip,
                ReadLimits::default(),
                Some((4, 3)),
            )
            .unwrap();
            assert_eq!((back.field.width(), back.field.height()), (4, 3));
            assert!(back.field.max_abs_diff(&field).unwrap() < 1e-3);
            let err = read_sized(
                &bytes,
                Some(range),
                flip,
                ReadLimits::default(),
                Some((3, 3)),
            )
            .unwrap_err();
            assert!(err.to_string().contains("3 x 3"), "{err}");
        }
        let (bytes, _) = write(&Heightfield::filled(2, 2, 1.0).unwrap(), false);
        let err = read(&bytes, Some((5.0, 1.0)), false, ReadLimits::default()).unwrap_err();
        assert!(err.to_string().contains("inverted"), "{err}");
        let err = read(&bytes, Some((-3e38, 3e38)), false, ReadLimits::default()).unwrap_err();
        assert!(err.to_string().contains("spans more"), "{err}");
    }
}
