//! OpenEXR reader: what reads writes back and reads again to the same bits.
#![no_main]

use libfuzzer_sys::fuzz_target;
use strahler_fuzz::{LIMITS, check, dem, same_bits};

fuzz_target!(|data: &[u8]| {
    if let Ok(read) = dem::exr::read(data, LIMITS) {
        check(&read);
        let bytes = dem::exr::write(&read.field).expect("a field read writes");
        let again = dem::exr::read(&bytes, LIMITS).expect("what was written reads");
        assert!(same_bits(&read.field, &again.field));
    }
});
