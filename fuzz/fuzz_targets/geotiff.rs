//! GeoTIFF reader: any bytes give a DEM or an error; a DEM written back reads back the same.
#![no_main]

use libfuzzer_sys::fuzz_target;
use strahler_fuzz::{LIMITS, check, dem, same_bits};

fuzz_target!(|data: &[u8]| {
    if let Ok(read) = dem::geotiff::read(data, LIMITS) {
        check(&read);
        let bytes = dem::geotiff::write(&read.field, &read.georef).expect("a read DEM writes");
        let back = dem::geotiff::read(&bytes, LIMITS).expect("a written DEM reads");
        assert!(same_bits(&back.field, &read.field));
    }
});
