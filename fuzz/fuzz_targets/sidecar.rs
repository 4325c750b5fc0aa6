//! Sidecar JSON reader (the `.json` beside PNG and RAW R16 heightmaps), and the RAW R16
//! reader with the size a sidecar gives.
#![no_main]

use libfuzzer_sys::fuzz_target;
use strahler_fuzz::{LIMITS, check, dem};

fuzz_target!(|data: &[u8]| {
    if let Ok(sidecar) = dem::sidecar::parse(data) {
        // What a parsed sidecar promises: a finite, ordered range with a finite span, and a
        // positive size.
        if let Some((lo, hi)) = sidecar.z_range {
            assert!(lo.is_finite() && hi.is_finite() && lo <= hi && (hi - lo).is_finite());
        }
        if let Some((w, h)) = sidecar.size {
            assert!(w > 0 && h > 0);
            // A RAW file of that size reads (or is refused by the limits), never panics.
            let cells = (w as u64).saturating_mul(h as u64);
            if cells <= LIMITS.max_cells {
                let bytes = vec![0x5a; (cells * 2) as usize];
                let read = dem::raw::read_sized(
                    &bytes,
                    sidecar.z_range.or(Some((0.0, 1.0))),
                    sidecar.flip_y.unwrap_or(false),
                    LIMITS,
                    Some((w, h)),
                )
                .expect("a file of the sidecar's size reads");
                check(&read);
                assert!(read.field.data().iter().all(|v| v.is_finite()));
            }
        }
    }
});
