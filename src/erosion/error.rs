//! Errors reported for invalid caller input.

use std::fmt;

/// Why an [`Eroder`](super::Eroder) could not be built.
#[derive(Debug, Clone, PartialEq)]
pub enum ErosionError {
    /// `width` or `height` is zero, or the cell count does not fit a `u32` index.
    BadDimensions { width: usize, height: usize },
    /// An input slice does not have `width * height` entries.
    SizeMismatch {
        what: &'static str,
        expected: usize,
        got: usize,
    },
    /// A parameter is out of range; `field` names the [`ErosionParams`](super::ErosionParams) field.
    InvalidParam {
        field: &'static str,
        problem: String,
    },
    /// `cell_m` is not a finite number > 0.
    BadCellSize(f64),
    /// An input array holds a NaN or an infinity.
    NonFinite { what: &'static str, index: usize },
    /// `base_level` has no `true` cell, so water has nowhere to go.
    NoBaseLevel,
    /// A factor that must be above 0 (the erodibility's) is 0 or below.
    NotPositive { what: &'static str, index: usize },
}

impl fmt::Display for ErosionError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::BadDimensions { width, height } => {
                write!(f, "grid size {width} x {height} is empty or too large")
            }
            Self::SizeMismatch {
                what,
                expected,
                got,
            } => {
                write!(f, "{what} has {got} cells, expected {expected}")
            }
            Self::InvalidParam { field, problem } => write!(f, "parameter `{field}`: {problem}"),
            Self::BadCellSize(c) => write!(f, "cell size {c} m must be a finite number > 0"),
            Self::NonFinite { what, index } => {
                write!(f, "{what}[{index}] is not a finite number")
            }
            Self::NoBaseLevel => write!(f, "base_level marks no cell; rivers need an outlet"),
            Self::NotPositive { what, index } => write!(f, "{what}[{index}] must be above 0"),
        }
    }
}

impl std::error::Error for ErosionError {}
