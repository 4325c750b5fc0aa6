//! The main crate's DEM readers and writers, compiled from its own files (with the job
//! context their writers tick).

#[path = "../../src/heightfield.rs"]
pub mod heightfield;

#[path = "../../src/dem/mod.rs"]
pub mod dem;

/// The writers step through their rows on a job's context (`run_inline` when called alone).
#[path = "../../src/jobs/mod.rs"]
pub mod jobs;

/// The limits the fuzzers read with: 1 Mi cells (4 MiB as `f32`), so every input stays cheap.
pub const LIMITS: dem::ReadLimits = dem::ReadLimits { max_cells: 1 << 20 };

/// Whether two fields hold the same bits (any NaN equals any NaN: no-data is no-data).
pub fn same_bits(a: &heightfield::Heightfield, b: &heightfield::Heightfield) -> bool {
    a.data().len() == b.data().len()
        && a.data()
            .iter()
            .zip(b.data())
            .all(|(x, y)| x.to_bits() == y.to_bits() || (x.is_nan() && y.is_nan()))
}

/// Checks what every successful read promises: the size is within the limits and the field
/// has exactly `width * height` values.
pub fn check(dem: &dem::Dem) {
    let f = &dem.field;
    assert!((f.width() * f.height()) as u64 <= LIMITS.max_cells);
    assert_eq!(f.data().len(), f.width() * f.height());
}
