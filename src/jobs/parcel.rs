//! What a job sends to a Web Worker and gets back ([`super::worker`]): a JSON header and
//! typed arrays, in an order both sides agree on.
//!
//! The arrays cross to the worker as transferable buffers (moved, not cloned by the
//! structured-clone algorithm); the header carries the small values. JSON round trips of
//! `f64` are exact here because `serde_json` parses with its `float_roundtrip` feature, so a
//! stage run in the worker gets the very numbers the page holds and returns the page's bits.

use std::collections::VecDeque;

use serde::Serialize;
use serde::de::DeserializeOwned;
use thiserror::Error;

/// One typed array of a [`Parcel`].
#[derive(Clone, Debug, PartialEq)]
pub enum Array {
    F32(Vec<f32>),
    U32(Vec<u32>),
    U8(Vec<u8>),
}

impl Array {
    fn kind(&self) -> &'static str {
        match self {
            Array::F32(_) => "f32",
            Array::U32(_) => "u32",
            Array::U8(_) => "u8",
        }
    }
}

/// A parcel that does not hold what its reader expects (a version mismatch between the page
/// and its worker, or a defect): the stage then runs on the page's thread.
#[derive(Debug, Error, PartialEq)]
pub enum ParcelError {
    #[error("the parcel's header does not parse: {0}")]
    Header(String),
    #[error("the parcel has no array left where a {0} array was expected")]
    Missing(&'static str),
    #[error("the parcel has a {found} array where a {expected} array was expected")]
    Kind {
        expected: &'static str,
        found: &'static str,
    },
    #[error("the parcel's {what} has {found} values, not {expected}")]
    Length {
        what: &'static str,
        expected: usize,
        found: usize,
    },
}

/// A header and arrays, read back in the order they were put.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Parcel {
    pub header: String,
    pub arrays: VecDeque<Array>,
}

impl Parcel {
    /// A parcel whose header is `header` as JSON.
    pub fn new(header: &impl Serialize) -> Self {
        Self {
            // Serialising plain data (numbers, strings, enums) to a string cannot fail.
            header: serde_json::to_string(header).unwrap_or_default(),
            arrays: VecDeque::new(),
        }
    }

    /// The header, parsed.
    pub fn header<T: DeserializeOwned>(&self) -> Result<T, ParcelError> {
        serde_json::from_str(&self.header).map_err(|e| ParcelError::Header(e.to_string()))
    }

    /// Appends an array.
    pub fn with(mut self, array: Array) -> Self {
        self.arrays.push_back(array);
        self
    }

    /// The next array, which must hold `f32`s.
    pub fn f32s(&mut self) -> Result<Vec<f32>, ParcelError> {
        match self.next("f32")? {
            Array::F32(v) => Ok(v),
            other => Err(wrong("f32", &other)),
        }
    }

    /// The next array, which must hold `u32`s.
    pub fn u32s(&mut self) -> Result<Vec<u32>, ParcelError> {
        match self.next("u32")? {
            Array::U32(v) => Ok(v),
            other => Err(wrong("u32", &other)),
        }
    }

    /// The next array, which must hold bytes.
    pub fn u8s(&mut self) -> Result<Vec<u8>, ParcelError> {
        match self.next("u8")? {
            Array::U8(v) => Ok(v),
            other => Err(wrong("u8", &other)),
        }
    }

    fn next(&mut self, expected: &'static str) -> Result<Array, ParcelError> {
        self.arrays
            .pop_front()
            .ok_or(ParcelError::Missing(expected))
    }
}

fn wrong(expected: &'static str, found: &Array) -> ParcelError {
    ParcelError::Kind {
        expected,
        found: found.kind(),
    }
}

/// `Ok(values)` when it has `expected` of them, for the arrays whose length a header fixes.
pub fn sized<T>(
    what: &'static str,
    values: Vec<T>,
    expected: usize,
) -> Result<Vec<T>, ParcelError> {
    if values.len() == expected {
        Ok(values)
    } else {
        Err(ParcelError::Length {
            what,
            expected,
            found: values.len(),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[derive(Debug, PartialEq, Serialize, serde::Deserialize)]
    struct Header {
        x: f64,
        name: String,
    }

    #[test]
    fn a_parcel_gives_back_its_header_and_arrays_in_order() {
        // Values whose shortest decimal form has 17 digits: the JSON must bring back their bits.
        let x = 0.1f64 + 0.2;
        let mut parcel = Parcel::new(&Header {
            x,
            name: "erosion".into(),
        })
        .with(Array::F32(vec![1.5, f32::MIN_POSITIVE]))
        .with(Array::U32(vec![7]))
        .with(Array::U8(vec![1, 2, 3]));
        let header: Header = parcel.header().unwrap();
        assert_eq!(header.x.to_bits(), x.to_bits());
        assert_eq!(parcel.f32s().unwrap(), vec![1.5, f32::MIN_POSITIVE]);
        assert_eq!(parcel.u32s().unwrap(), vec![7]);
        assert_eq!(parcel.u8s().unwrap(), vec![1, 2, 3]);
        assert_eq!(parcel.u8s(), Err(ParcelError::Missing("u8")));
    }

    #[test]
    fn f64s_round_trip_through_the_header_bit_for_bit() {
        let mut state = 0x9e37_79b9_7f4a_7c15u64;
        for _ in 0..20_000 {
            // A spread of magnitudes and mantissas (xorshift).
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            let x = f64::from_bits(state & 0x7fef_ffff_ffff_ffff);
            let back: f64 = Parcel::new(&x).header().unwrap();
            assert_eq!(back.to_bits(), x.to_bits(), "{x:e}");
        }
    }

    #[test]
    fn a_parcel_that_does_not_hold_what_is_read_says_so() {
        let mut parcel = Parcel::new(&1).with(Array::U8(vec![1]));
        assert_eq!(
            parcel.f32s(),
            Err(ParcelError::Kind {
                expected: "f32",
                found: "u8"
            })
        );
        assert!(matches!(
            Parcel::new(&"text").header::<f64>(),
            Err(ParcelError::Header(_))
        ));
        assert_eq!(
            sized("field", vec![1.0f32], 4),
            Err(ParcelError::Length {
                what: "field",
                expected: 4,
                found: 1
            })
        );
    }
}
