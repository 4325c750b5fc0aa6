//! The memory a run will use, stated before the work starts, and refused when it would not
//! fit the machine.
//!
//! Each command's use is its peak resident memory per cell, measured with `/usr/bin/time -v`
//! on 2048^2 runs of the release build (the figures are on each [`Work`]), rounded up, plus
//! the program itself. The estimate is compared with what the system says it can still give
//! (`MemAvailable` and free swap in `/proc/meminfo`); where that is unknown (not Linux) the
//! estimate is still printed for large runs.

/// Peak bytes per cell of the terrain (or of the DEM read) for each command.
#[derive(Clone, Copy, Debug)]
pub enum Work {
    /// `generate`: every stage and its layers (measured 99 bytes a cell with erosion).
    Generate,
    /// `analyze`: the wavelet decomposition and the measures (79).
    Analyze,
    /// `amplify`, per cell of the output (70 per source cell with two levels, most of it the
    /// output's).
    Amplify,
    /// `fill` and `blend`: the multigrid hierarchy (19).
    Solve,
    /// `convert`, `features`, `hillshade` and the rest: the DEM and one copy (14).
    Copy,
}

impl Work {
    fn bytes_per_cell(self) -> u64 {
        match self {
            Work::Generate => 112,
            Work::Analyze => 88,
            Work::Amplify => 40,
            Work::Solve => 24,
            Work::Copy => 16,
        }
    }
}

/// The program, its libraries and a GPU context, before any cell.
const BASE_BYTES: u64 = 64 << 20;

/// Runs smaller than this are not announced.
const ANNOUNCE_BYTES: u64 = 1 << 30;

/// The bytes `work` over `cells` cells will hold at its peak.
pub fn estimate(work: Work, cells: u64) -> u64 {
    cells
        .saturating_mul(work.bytes_per_cell())
        .saturating_add(BASE_BYTES)
}

/// [`check`] for `work` over `cells` cells.
pub fn check_cells(what: &str, work: Work, cells: u64) -> Result<(), String> {
    check(what, estimate(work, cells))
}

/// Says (on stderr) how much memory `what` will use (`need` bytes, see [`estimate`]) when that
/// is over 1 GiB, and refuses it, with the numbers, when it is more than the machine can give
/// now.
pub fn check(what: &str, need: u64) -> Result<(), String> {
    let available = available_bytes();
    if let Some(free) = available
        && need > free
    {
        return Err(format!(
            "{what} needs about {} of memory, and this machine can give {} now; use a smaller \
             size, or close other programs",
            gib(need),
            gib(free)
        ));
    }
    if need >= ANNOUNCE_BYTES {
        match available {
            Some(free) => eprintln!(
                "note: {what} will use about {} of memory ({} available)",
                gib(need),
                gib(free)
            ),
            None => eprintln!("note: {what} will use about {} of memory", gib(need)),
        }
    }
    Ok(())
}

fn gib(bytes: u64) -> String {
    crate::dem::format_bytes(bytes)
}

/// What the system can give now: available memory plus free swap (Linux), else unknown.
/// `STRAHLER_MEMORY_AVAILABLE` (bytes) stands in for it, for tests and for shared machines
/// whose limit the system does not show.
fn available_bytes() -> Option<u64> {
    if let Some(v) = std::env::var("STRAHLER_MEMORY_AVAILABLE")
        .ok()
        .and_then(|v| v.trim().parse().ok())
    {
        return Some(v);
    }
    let text = std::fs::read_to_string("/proc/meminfo").ok()?;
    let field = |name: &str| {
        text.lines()
            .find_map(|l| l.strip_prefix(name))
            .and_then(|rest| {
                rest.trim()
                    .trim_end_matches("kB")
                    .trim()
                    .parse::<u64>()
                    .ok()
            })
            .map(|kb| kb * 1024)
    };
    Some(field("MemAvailable:")? + field("SwapFree:").unwrap_or(0))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn estimates_grow_with_cells_and_never_overflow() {
        let small = estimate(Work::Generate, 1 << 20);
        let large = estimate(Work::Generate, 1 << 26);
        assert!(large > 60 * small / 2, "{small} {large}");
        // 8192^2 with erosion measured 4.6 GB.
        let gb = estimate(Work::Generate, 8192 * 8192) as f64 / 1e9;
        assert!((4.6..9.0).contains(&gb), "{gb}");
        assert_eq!(estimate(Work::Analyze, u64::MAX), u64::MAX);
    }
}
