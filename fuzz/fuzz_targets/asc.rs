//! ESRI ASCII grid reader: a grid that reads writes back and reads back bit-exactly.
#![no_main]

use libfuzzer_sys::fuzz_target;
use strahler_fuzz::{LIMITS, check, dem, same_bits};

fuzz_target!(|data: &[u8]| {
    if let Ok(read) = dem::asc::read(data, LIMITS) {
        check(&read);
        assert!(read.field.data().iter().all(|v| !v.is_infinite()));
        let bytes = dem::asc::write(&read.field, &read.georef, 1.0).expect("a read grid writes");
        let back = dem::asc::read(&bytes, LIMITS).expect("a written grid reads");
        assert!(same_bits(&back.field, &read.field));
    }
});
