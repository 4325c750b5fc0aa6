//! RAW R32 reader, both row orders, square and sized by a sidecar.
#![no_main]

use libfuzzer_sys::fuzz_target;
use strahler_fuzz::{LIMITS, check, dem, same_bits};

fuzz_target!(|data: &[u8]| {
    let width = usize::from(data.first().copied().unwrap_or(1)).max(1);
    let sized = (data.len() / 4 / width).max(1);
    for flip in [false, true] {
        for size in [None, Some((width, sized))] {
            if let Ok(read) = dem::raw32::read(data, flip, LIMITS, size) {
                check(&read);
                let bytes = dem::raw32::write(&read.field, flip);
                assert_eq!(bytes.len(), data.len());
                let again = dem::raw32::read(&bytes, flip, LIMITS, size).expect("reads again");
                assert!(same_bits(&read.field, &again.field));
            }
        }
    }
});
