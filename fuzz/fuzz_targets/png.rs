//! PNG heightmap reader, with the range from the file and from the user.
#![no_main]

use libfuzzer_sys::fuzz_target;
use strahler_fuzz::{LIMITS, check, dem};

fuzz_target!(|data: &[u8]| {
    if let Ok(read) = dem::png16::read_heightmap(data, None, LIMITS) {
        check(&read);
    }
    if let Ok(read) = dem::png16::read_heightmap(data, Some((-10.0, 2000.0)), LIMITS) {
        check(&read);
        assert!(read.field.data().iter().all(|v| v.is_finite()));
    }
});
