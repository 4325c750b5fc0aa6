//! SRTM .hgt reader.
#![no_main]

use libfuzzer_sys::fuzz_target;
use strahler_fuzz::{LIMITS, check, dem};

fuzz_target!(|data: &[u8]| {
    if let Ok(read) = dem::hgt::read("N45E006.hgt", data, LIMITS) {
        check(&read);
        assert_eq!(read.field.width(), read.field.height());
        let bytes = dem::hgt::write(&read.field).expect("square");
        assert_eq!(bytes, data, "whole-metre tiles round-trip byte for byte");
    }
});
