//! RAW R32 heightmaps (Gaea, World Machine, Houdini, Terrain3D): 32-bit IEEE floats in
//! metres, little-endian, row by row from the north, no header. The heights are stored as
//! they are (no normalisation, so no stepping); the size is the sidecar's `width` and
//! `height`, or a square from the byte count. NaN is no-data.

use super::{Dem, DemError, GeoRef, ReadLimits};
use crate::heightfield::Heightfield;
use crate::jobs::{Cancelled, JobCtx, finish_inline};

/// Encodes `field`, rows bottom-up when `flip_y`.
pub fn write(field: &Heightfield, flip_y: bool) -> Vec<u8> {
    finish_inline(|ctx| async move { write_in(field, flip_y, &ctx).await })
}

/// [`write`] in a job: a tick after each row.
pub async fn write_in(
    field: &Heightfield,
    flip_y: bool,
    ctx: &JobCtx,
) -> Result<Vec<u8>, Cancelled> {
    let w = field.width();
    let mut out = Vec::with_capacity(field.data().len() * 4);
    for y in 0..field.height() {
        ctx.tick_of(y, field.height(), "writing the R32 file")
            .await?;
        let row = if flip_y { field.height() - 1 - y } else { y };
        for z in &field.data()[row * w..(row + 1) * w] {
            out.extend_from_slice(&z.to_le_bytes());
        }
    }
    Ok(out)
}

/// Decodes an R32 file of `size` cells (from its sidecar), else a square from the byte
/// count; `flip_y` undoes a bottom-up write.
pub fn read(
    bytes: &[u8],
    flip_y: bool,
    limits: ReadLimits,
    size: Option<(usize, usize)>,
) -> Result<Dem, DemError> {
    let bad = |problem: String| DemError::Malformed {
        format: "RAW R32",
        problem,
    };
    if bytes.is_empty() {
        return Err(DemError::Empty);
    }
    if !bytes.len().is_multiple_of(4) {
        return Err(bad(format!(
            "{} bytes is not a whole number of 32-bit samples",
            bytes.len()
        )));
    }
    let samples = bytes.len() / 4;
    let (w, h) = match size {
        Some((w, h)) => {
            limits.check(w as u64, h as u64)?;
            if samples != w * h {
                return Err(bad(format!(
                    "the sidecar says {w} x {h} cells ({} bytes), the file has {} bytes",
                    w * h * 4,
                    bytes.len()
                )));
            }
            (w, h)
        }
        None => {
            let n = samples.isqrt();
            if n * n != samples {
                return Err(bad(format!(
                    "{} bytes is not a square grid of 32-bit samples (a non-square file needs \
                     \"width\" and \"height\" in its sidecar .json)",
                    bytes.len()
                )));
            }
            limits.check(n as u64, n as u64)?;
            (n, n)
        }
    };
    let mut data = vec![0.0f32; samples];
    for (i, b) in bytes.chunks_exact(4).enumerate() {
        let (x, y) = (i % w, i / w);
        let row = if flip_y { h - 1 - y } else { y };
        let z = f32::from_le_bytes([b[0], b[1], b[2], b[3]]);
        if z.is_infinite() {
            return Err(bad(format!(
                "the sample at row {y}, column {x} is infinite"
            )));
        }
        data[row * w + x] = z;
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
    fn heights_round_trip_bit_for_bit_in_any_shape() {
        let data: Vec<f32> = (0..12).map(|i| (i as f32 * 0.37).cos() * 812.25).collect();
        let field = Heightfield::from_vec(4, 3, data).unwrap();
        for flip in [false, true] {
            let bytes = write(&field, flip);
            let back = read(&bytes, flip, ReadLimits::default(), Some((4, 3)))
                .unwrap()
                .field;
            for (a, b) in field.data().iter().zip(back.data()) {
                assert_eq!(a.to_bits(), b.to_bits());
            }
            let err = read(&bytes, flip, ReadLimits::default(), None).unwrap_err();
            assert!(err.to_string().contains("square"), "{err}");
        }
        let err = read(&[0; 6], false, ReadLimits::default(), None).unwrap_err();
        assert!(err.to_string().contains("whole number"), "{err}");
        let inf = f32::INFINITY.to_le_bytes();
        let err = read(&inf, false, ReadLimits::default(), None).unwrap_err();
        assert!(err.to_string().contains("infinite"), "{err}");
    }
}
