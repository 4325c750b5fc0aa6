//! A row-major raster of `f32` heights: row 0 is north, column 0 is west.

use thiserror::Error;

/// Errors building a [`Heightfield`].
#[derive(Debug, Error, PartialEq)]
pub enum HeightfieldError {
    #[error("a heightfield needs at least 1x1 cells, got {width}x{height}")]
    Empty { width: usize, height: usize },
    #[error("{width}x{height} cells need {expected} values, got {actual}")]
    LengthMismatch {
        width: usize,
        height: usize,
        expected: usize,
        actual: usize,
    },
}

/// A `width` x `height` grid of heights in metres, stored row by row.
#[derive(Clone, Debug, PartialEq)]
pub struct Heightfield {
    width: usize,
    height: usize,
    data: Vec<f32>,
}

impl Heightfield {
    /// A field with every cell set to `value`.
    pub fn filled(width: usize, height: usize, value: f32) -> Result<Self, HeightfieldError> {
        if width == 0 || height == 0 {
            return Err(HeightfieldError::Empty { width, height });
        }
        Ok(Self {
            width,
            height,
            data: vec![value; width * height],
        })
    }

    /// Wraps row-major `data`; its length must be `width * height`.
    pub fn from_vec(width: usize, height: usize, data: Vec<f32>) -> Result<Self, HeightfieldError> {
        if width == 0 || height == 0 {
            return Err(HeightfieldError::Empty { width, height });
        }
        if data.len() != width * height {
            return Err(HeightfieldError::LengthMismatch {
                width,
                height,
                expected: width * height,
                actual: data.len(),
            });
        }
        Ok(Self {
            width,
            height,
            data,
        })
    }

    pub fn width(&self) -> usize {
        self.width
    }

    pub fn height(&self) -> usize {
        self.height
    }

    /// The heights, row by row.
    pub fn data(&self) -> &[f32] {
        &self.data
    }

    pub fn data_mut(&mut self) -> &mut [f32] {
        &mut self.data
    }

    pub fn into_vec(self) -> Vec<f32> {
        self.data
    }

    /// Index of cell (`x`, `y`) in [`Self::data`].
    #[inline]
    pub fn index(&self, x: usize, y: usize) -> usize {
        y * self.width + x
    }

    /// Height at (`x`, `y`), `None` outside the grid.
    pub fn get(&self, x: usize, y: usize) -> Option<f32> {
        (x < self.width && y < self.height).then(|| self.data[self.index(x, y)])
    }

    /// Smallest and largest finite height, `None` if no cell is finite.
    pub fn finite_range(&self) -> Option<(f32, f32)> {
        self.data
            .iter()
            .filter(|v| v.is_finite())
            .fold(None, |acc, &v| match acc {
                None => Some((v, v)),
                Some((lo, hi)) => Some((lo.min(v), hi.max(v))),
            })
    }

    /// [`Self::finite_range`] in a job: a tick every [`crate::jobs::CELLS_PER_TICK`] cells.
    pub async fn finite_range_in(
        &self,
        ctx: &crate::jobs::JobCtx,
    ) -> Result<Option<(f32, f32)>, crate::jobs::Cancelled> {
        let mut range: Option<(f32, f32)> = None;
        ctx.for_cells(self.data.len(), "measuring the heights", |cells| {
            for &v in self.data[cells].iter().filter(|v| v.is_finite()) {
                let (lo, hi) = range.get_or_insert((v, v));
                *lo = lo.min(v);
                *hi = hi.max(v);
            }
        })
        .await?;
        Ok(range)
    }

    /// Largest absolute difference to `other` (same size), or `None` if the sizes differ.
    pub fn max_abs_diff(&self, other: &Heightfield) -> Option<f32> {
        (self.width == other.width && self.height == other.height).then(|| {
            self.data
                .iter()
                .zip(&other.data)
                .map(|(a, b)| (a - b).abs())
                .fold(0.0, f32::max)
        })
    }

    /// FNV-1a hash of the exact bits of every height, as 16 hex digits.
    ///
    /// Two runs of the same scene and seed must give the same checksum on every platform
    /// (native and wasm); tests and the browser self-test compare these strings.
    pub fn checksum(&self) -> String {
        let mut sum = Checksum::default();
        sum.add(&self.data);
        sum.hex()
    }
}

/// The FNV-1a state behind [`Heightfield::checksum`], for hashing a field in parts (a job
/// that yields between them): adding the cells in order in any number of slices gives the
/// same checksum.
#[derive(Clone, Copy, Debug)]
pub struct Checksum(u64);

impl Default for Checksum {
    fn default() -> Self {
        Self(0xcbf2_9ce4_8422_2325)
    }
}

impl Checksum {
    /// Hashes the exact bits of `values`, little-endian bytes.
    pub fn add(&mut self, values: &[f32]) {
        for v in values {
            for byte in v.to_bits().to_le_bytes() {
                self.0 ^= u64::from(byte);
                self.0 = self.0.wrapping_mul(0x0000_0100_0000_01b3);
            }
        }
    }

    /// 16 hex digits.
    pub fn hex(&self) -> String {
        format!("{:016x}", self.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rejects_empty_and_mismatched_sizes() {
        assert!(matches!(
            Heightfield::filled(0, 4, 0.0),
            Err(HeightfieldError::Empty { .. })
        ));
        assert_eq!(
            Heightfield::from_vec(2, 2, vec![0.0; 3]),
            Err(HeightfieldError::LengthMismatch {
                width: 2,
                height: 2,
                expected: 4,
                actual: 3
            })
        );
    }

    #[test]
    fn range_skips_non_finite_cells() {
        let f = Heightfield::from_vec(2, 2, vec![f32::NAN, -3.0, 7.5, f32::INFINITY]).unwrap();
        assert_eq!(f.finite_range(), Some((-3.0, 7.5)));
    }

    #[test]
    fn checksum_sees_a_single_bit() {
        let a = Heightfield::filled(8, 8, 1.0).unwrap();
        let mut b = a.clone();
        b.data_mut()[63] = f32::from_bits(1.0f32.to_bits() + 1);
        assert_eq!(a.checksum(), a.clone().checksum());
        assert_ne!(a.checksum(), b.checksum());
    }

    #[test]
    fn a_checksum_in_parts_is_the_whole_checksum() {
        let data: Vec<f32> = (0..1000).map(|i| (i as f32).sqrt()).collect();
        let field = Heightfield::from_vec(40, 25, data.clone()).unwrap();
        let mut parts = Checksum::default();
        for part in data.chunks(77) {
            parts.add(part);
        }
        assert_eq!(parts.hex(), field.checksum());
        // The FNV-1a offset basis: the checksum of nothing.
        assert_eq!(Checksum::default().hex(), "cbf29ce484222325");
    }
}
