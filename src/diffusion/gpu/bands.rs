//! Tiling a field the device cannot hold in one storage binding: each level of the solver is
//! split into bands of whole rows, every band in buffers of its own, with one ghost row
//! above and below that mirrors the neighbouring band's edge row.
//!
//! The 5-point stencil (eq. 7 of seed 000) reads one row up and one down, so a band's kernels
//! only need its owned rows plus the two ghost rows; after every pass that writes `u`, the
//! host copies each band's edge rows into its neighbours' ghost rows
//! ([`exchange_ghost_rows`], two row copies per band boundary, O(width)). Restriction and
//! prolongation work band by band too: band boundaries on a banded level are even and halve
//! onto the next level's boundaries, so fine band `k` restricts into, and is prolonged from,
//! rows `[start / 2, end / 2)` of the coarse level, which lie in coarse band `k` (or in the
//! coarse level's one buffer once a level fits). Every cell is computed by the same
//! arithmetic, in the same order, as without tiling: the result is the same bits.
//!
//! A field that fits is one band per level without ghost rows (no copies at all).

use std::ops::Range;

use crate::diffusion::FixedMask;
use crate::gpu::{GpuContext, GpuError, read_f32_buffer};

/// Rows of one band: the rows it computes (`owned`) and the rows its buffers hold (`stored`:
/// `owned` plus one ghost row on each side that has a neighbour).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Band {
    pub owned: Range<usize>,
    pub stored: Range<usize>,
}

impl Band {
    /// Cells the band's buffers hold.
    pub fn stored_cells(&self, width: usize) -> usize {
        self.stored.len() * width
    }
}

/// Splits every level (`dims`, finest first, each half the previous one rounded up) into
/// bands whose buffers hold at most `max_bytes` of `f32`. Levels that fit are one band.
///
/// Banded levels share one band count; level `l`'s interior boundaries are the finest
/// level's shifted right by `l`, so the finest level's are multiples of `2^m` for `m` banded
/// levels. Fails with [`GpuError::CannotTile`] when a band of that many rows plus two ghost
/// rows does not fit (a device holding only a few rows of the field).
pub fn plan(dims: &[(usize, usize)], max_bytes: u64) -> Result<Vec<Vec<Band>>, GpuError> {
    let max_cells = usize::try_from(max_bytes / 4).unwrap_or(usize::MAX);
    let banded = dims.iter().take_while(|(w, h)| w * h > max_cells).count();
    let whole = |h: usize| Band {
        owned: 0..h,
        stored: 0..h,
    };
    if banded == 0 {
        return Ok(dims.iter().map(|&(_, h)| vec![whole(h)]).collect());
    }
    let (w0, h0) = dims[0];
    let align = 1usize << banded;
    let max_rows = max_cells / w0.max(1);
    if max_rows < align + 2 {
        return Err(GpuError::CannotTile {
            width: w0,
            height: h0,
            rows: align + 2,
            limit: max_bytes,
        });
    }
    let rows = (max_rows - 2) / align * align;
    let boundaries: Vec<usize> = (rows..h0).step_by(rows).collect();
    Ok(dims
        .iter()
        .enumerate()
        .map(|(l, &(_, h))| {
            if l >= banded {
                return vec![whole(h)];
            }
            let mut edges = vec![0];
            edges.extend(boundaries.iter().map(|b| b >> l));
            edges.push(h);
            edges
                .windows(2)
                .map(|e| Band {
                    owned: e[0]..e[1],
                    stored: e[0].saturating_sub(1)..(e[1] + 1).min(h),
                })
                .collect()
        })
        .collect())
}

/// The index of the band of `coarse` that holds the coarse rows of `fine[k]`: `k` when the
/// coarse level is banded too, else its one band.
pub fn coarse_band(coarse: &[Band], k: usize) -> usize {
    if coarse.len() == 1 { 0 } else { k }
}

/// The fixed bits of `band`'s stored rows, in the kernels' layout (cell `i` of the band in bit
/// `i % 32` of word `i / 32`).
pub fn fixed_words(mask: &FixedMask, band: &Band) -> Vec<u32> {
    let words = mask.words();
    let start = band.stored.start * mask.width();
    let cells = band.stored_cells(mask.width());
    if start == 0 && cells == mask.width() * mask.height() {
        return words.to_vec();
    }
    let (first, shift) = (start >> 5, (start & 31) as u32);
    let word = |k: usize| u64::from(words.get(first + k).copied().unwrap_or(0));
    let mut out: Vec<u32> = (0..cells.div_ceil(32))
        .map(|k| ((word(k) | word(k + 1) << 32) >> shift) as u32)
        .collect();
    // Bits past the band's last cell belong to the next band's rows: clear them.
    if !cells.is_multiple_of(32)
        && let Some(last) = out.last_mut()
    {
        *last &= (1u32 << (cells % 32)) - 1;
    }
    out
}

/// Copies each band's edge rows into its neighbours' ghost rows: the last owned row of band
/// `k` into band `k + 1`'s top ghost row and the first owned row of band `k + 1` into band
/// `k`'s bottom ghost row. `buffers[k]` holds band `k`'s stored rows of `width` `f32`s.
pub fn exchange_ghost_rows(
    encoder: &mut wgpu::CommandEncoder,
    bands: &[Band],
    buffers: &[&wgpu::Buffer],
    width: usize,
) {
    let row_bytes = (width * 4) as u64;
    let offset = |band: &Band, row: usize| ((row - band.stored.start) * width * 4) as u64;
    for k in 0..bands.len().saturating_sub(1) {
        let (upper, lower) = (&bands[k], &bands[k + 1]);
        let edge = upper.owned.end - 1;
        encoder.copy_buffer_to_buffer(
            buffers[k],
            offset(upper, edge),
            buffers[k + 1],
            offset(lower, edge),
            row_bytes,
        );
        let edge = lower.owned.start;
        encoder.copy_buffer_to_buffer(
            buffers[k + 1],
            offset(lower, edge),
            buffers[k],
            offset(upper, edge),
            row_bytes,
        );
    }
}

/// The owned rows of every band, read back from `buffers` (band `k`'s stored rows of `width`
/// `f32`s) and joined into the level's field.
pub async fn read_owned_rows(
    gpu: &GpuContext,
    bands: &[Band],
    buffers: &[&wgpu::Buffer],
    width: usize,
) -> Result<Vec<f32>, GpuError> {
    let mut data = Vec::with_capacity(bands.last().map_or(0, |b| b.owned.end) * width);
    for (band, buffer) in bands.iter().zip(buffers) {
        let stored = read_f32_buffer(gpu, buffer, band.stored_cells(width)).await?;
        let skip = (band.owned.start - band.stored.start) * width;
        data.extend_from_slice(&stored[skip..skip + band.owned.len() * width]);
    }
    Ok(data)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn halving(w: usize, h: usize) -> Vec<(usize, usize)> {
        let mut dims = vec![(w, h)];
        while dims[dims.len() - 1].0 > 4 || dims[dims.len() - 1].1 > 4 {
            let (w, h) = dims[dims.len() - 1];
            dims.push((w.div_ceil(2), h.div_ceil(2)));
        }
        dims
    }

    #[test]
    fn a_field_that_fits_is_one_band_per_level() {
        let dims = halving(64, 48);
        let bands = plan(&dims, 64 * 48 * 4).unwrap();
        for (level, &(_, h)) in bands.iter().zip(&dims) {
            assert_eq!(
                level,
                &vec![Band {
                    owned: 0..h,
                    stored: 0..h
                }]
            );
        }
    }

    #[test]
    fn bands_fit_cover_every_row_once_and_halve_onto_the_next_level() {
        for (w, h, max_bytes) in [
            (256, 256, 64 * 1024),
            (300, 257, 40_000),
            (1024, 1000, 65_536),
        ] {
            let dims = halving(w, h);
            let bands = plan(&dims, max_bytes).unwrap();
            for (l, (level, &(w, h))) in bands.iter().zip(&dims).enumerate() {
                let mut next = 0;
                for band in level {
                    assert_eq!(band.owned.start, next, "level {l}: rows in order, no gap");
                    assert!(!band.owned.is_empty());
                    assert!(
                        (band.stored_cells(w) * 4) as u64 <= max_bytes,
                        "level {l} fits"
                    );
                    next = band.owned.end;
                }
                assert_eq!(next, h, "level {l} covers every row");
                if level.len() > 1 {
                    let coarse = &bands[l + 1];
                    for (k, band) in level.iter().enumerate() {
                        assert_eq!(band.owned.start % 2, 0, "even boundaries on level {l}");
                        let c = &coarse[coarse_band(coarse, k)];
                        let rows = band.owned.start / 2..band.owned.end.div_ceil(2);
                        assert!(c.owned.start <= rows.start && rows.end <= c.owned.end);
                        assert!(c.stored.start <= rows.start.saturating_sub(1));
                        assert!((rows.end + 1).min(dims[l + 1].1) <= c.stored.end);
                    }
                }
            }
            assert!(
                bands[0].len() > 1,
                "{w} x {h} in {max_bytes} bytes is tiled"
            );
        }
    }

    #[test]
    fn a_device_holding_a_few_rows_is_refused() {
        let dims = halving(4096, 4096);
        let err = plan(&dims, 64 * 1024).unwrap_err();
        assert!(
            matches!(err, GpuError::CannotTile { width: 4096, .. }),
            "{err}"
        );
    }

    #[test]
    fn fixed_words_of_a_band_are_its_rows_bits() {
        let (w, h) = (37, 29);
        let mut mask = FixedMask::new(w, h);
        for i in (0..w * h).filter(|i| i % 7 == 0 || i % 11 == 3) {
            mask.fix(i % w, i / w);
        }
        let band = Band {
            owned: 10..20,
            stored: 9..21,
        };
        let words = fixed_words(&mask, &band);
        let cells = band.stored_cells(w);
        assert_eq!(words.len(), cells.div_ceil(32));
        for j in 0..words.len() * 32 {
            let bit = (words[j >> 5] >> (j & 31)) & 1 == 1;
            let expected = j < cells && mask.is_fixed_index(band.stored.start * w + j);
            assert_eq!(bit, expected, "cell {j} of the band");
        }
    }
}
