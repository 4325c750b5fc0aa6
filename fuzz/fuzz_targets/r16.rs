//! RAW R16 reader, both row orders.
#![no_main]

use libfuzzer_sys::fuzz_target;
use strahler_fuzz::{LIMITS, check, dem};

fuzz_target!(|data: &[u8]| {
    for flip in [false, true] {
        if let Ok(read) = dem::raw::read(data, Some((0.0, 1000.0)), flip, LIMITS) {
            check(&read);
            let (bytes, _) = dem::raw::write(&read.field, flip);
            assert_eq!(bytes.len(), data.len());
        }
    }
});
