//! GeoTIFF reader: any bytes give a DEM or an error; a DEM written back reads back the same.
#![no_main]

use libfuzzer_sys::fuzz_target;
use strahler_fuzz::{LIMITS, check, dem};

fuzz_target!(|data: &[u8]| {
    if let Ok(read) = dem::geotiff::read(data, LIMITS) {
        check(&read);
        let bytes = dem::geotiff::write(&read.field, &read.georef).expect("a read DEM writes");
        let back = dem::geotiff::read(&bytes, LIMITS).expect("a written DEM reads");
        assert!(
            back.field
                .data()
                .iter()
                .zip(read.field.data())
                .all(|(a, b)| a.to_bits() == b.to_bits() || (a.is_nan() && b.is_nan()))
        );
    }
});
