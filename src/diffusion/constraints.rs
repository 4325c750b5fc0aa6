//! The diffusion problem: starting heights plus the set of cells that must not move.

use thiserror::Error;

use crate::heightfield::Heightfield;

#[derive(Debug, Error, PartialEq)]
pub enum ConstraintsError {
    #[error("the fixed-cell mask is {mask_w}x{mask_h} but the field is {field_w}x{field_h}")]
    SizeMismatch {
        mask_w: usize,
        mask_h: usize,
        field_w: usize,
        field_h: usize,
    },
    #[error("fixed cell ({x}, {y}) has a non-finite height")]
    NonFiniteFixed { x: usize, y: usize },
}

/// One bit per cell: set = fixed (a diffusion source), clear = free.
///
/// Packed 32 cells per `u32`, cell `i` in bit `i % 32` of word `i / 32`, which is also the
/// layout the WGSL kernels read, so the mask uploads as is (1/32 of a field's memory).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct FixedMask {
    width: usize,
    height: usize,
    words: Vec<u32>,
}

impl FixedMask {
    /// All cells free.
    pub fn new(width: usize, height: usize) -> Self {
        Self {
            width,
            height,
            words: vec![0; (width * height).div_ceil(32)],
        }
    }

    pub fn width(&self) -> usize {
        self.width
    }

    pub fn height(&self) -> usize {
        self.height
    }

    /// The packed words, for upload.
    /// The mask of `words` in [`Self::words`]' layout; `None` if their count does not fit
    /// `width x height`.
    pub fn from_words(width: usize, height: usize, words: Vec<u32>) -> Option<Self> {
        (words.len() == (width * height).div_ceil(32)).then_some(Self {
            width,
            height,
            words,
        })
    }

    pub fn words(&self) -> &[u32] {
        &self.words
    }

    /// The fixed bits of cells `i..i + 64` (bit `k` for cell `i + k`; cells past the end
    /// read as free).
    #[inline]
    pub fn bits64(&self, i: usize) -> u64 {
        let (word, shift) = (i >> 5, i & 31);
        let at = |k: usize| u128::from(self.words.get(word + k).copied().unwrap_or(0));
        ((at(0) | at(1) << 32 | at(2) << 64) >> shift) as u64
    }

    #[inline]
    pub fn is_fixed_index(&self, i: usize) -> bool {
        (self.words[i >> 5] >> (i & 31)) & 1 == 1
    }

    /// Whether (`x`, `y`) is fixed; cells outside the grid are not.
    pub fn is_fixed(&self, x: usize, y: usize) -> bool {
        x < self.width && y < self.height && self.is_fixed_index(y * self.width + x)
    }

    /// Fixes (`x`, `y`); cells outside the grid are ignored.
    pub fn fix(&mut self, x: usize, y: usize) {
        if x < self.width && y < self.height {
            self.fix_index(y * self.width + x);
        }
    }

    /// Fixes the cell at row-major index `i`; indices past the grid are ignored.
    #[inline]
    pub fn fix_index(&mut self, i: usize) {
        if i < self.width * self.height {
            self.words[i >> 5] |= 1 << (i & 31);
        }
    }

    pub fn count(&self) -> usize {
        self.words.iter().map(|w| w.count_ones() as usize).sum()
    }
}

/// Starting heights and fixed cells. Free cells' starting heights are only the iteration's
/// initial guess; fixed cells' heights are kept exactly.
#[derive(Clone, Debug)]
pub struct Constraints {
    initial: Heightfield,
    fixed: FixedMask,
}

impl Constraints {
    /// Checks that sizes agree and every fixed height is finite.
    pub fn new(initial: Heightfield, fixed: FixedMask) -> Result<Self, ConstraintsError> {
        if (fixed.width(), fixed.height()) != (initial.width(), initial.height()) {
            return Err(ConstraintsError::SizeMismatch {
                mask_w: fixed.width(),
                mask_h: fixed.height(),
                field_w: initial.width(),
                field_h: initial.height(),
            });
        }
        for (i, v) in initial.data().iter().enumerate() {
            if fixed.is_fixed_index(i) && !v.is_finite() {
                return Err(ConstraintsError::NonFiniteFixed {
                    x: i % initial.width(),
                    y: i / initial.width(),
                });
            }
        }
        Ok(Self { initial, fixed })
    }

    pub fn initial(&self) -> &Heightfield {
        &self.initial
    }

    pub fn fixed(&self) -> &FixedMask {
        &self.fixed
    }

    pub fn width(&self) -> usize {
        self.initial.width()
    }

    pub fn height(&self) -> usize {
        self.initial.height()
    }
}
