//! Realism report: the same terrain statistics for a real DEM and a generated heightmap, so
//! that the two can be compared number for number.
//!
//! [`measure`] reports
//! * slope percentiles (Horn 1981 gradient), see [`Realism::slope_deg_percentiles`];
//! * the harmonic fraction (share of cells satisfying Laplace's equation to 0.1 % of the
//!   local gradient), high on diffusion fills, a few per cent on real terrain;
//! * geomorphon class fractions (Jasiewicz and Stepinski 2013);
//! * drainage density from D8 flow accumulation on a Priority-Flood+ε filled copy
//!   (Barnes et al. 2014);
//! * relief and the number of measured cells;
//! * the grid-direction index, flat fraction and hypsometric integral (`landform.rs`) and the
//!   share of straight channel runs (`drainage.rs`): the marks of a synthetic terrain.
//!
//! [`network`] extracts a DEM's channel network (the same fill and D8) as a forest of
//! channel cells and gives it the river statistics of a generated network.
//!
//! Heights are row-major `f32` (row 0 first); non-finite values are no data and are skipped
//! everywhere. Computation is in `f64`. Only `std` is used.

mod drainage;
pub use drainage::{
    descent, drainage_area_m2, drainage_area_m2_with_sinks, drainage_area_m2_with_sinks_in,
    outlets, outlets_in,
};
mod geomorphon;
mod grid;
mod harmonic;
mod landform;
pub mod network;
mod report;
mod slope;
mod ssim;
#[cfg(test)]
mod tests;

pub use self::drainage::{STRAIGHT_RUN_CELLS, STRAIGHT_TOP_SHARE};
pub use self::geomorphon::GEOMORPHON_NAMES;
use self::grid::Grid;
pub use self::landform::FLAT_DEG;
pub use self::network::{ChannelNetwork, ChannelReport, extract_channels};
pub use self::report::{BandFit, RealismReport, comparison_table};
pub use self::ssim::ssim;

/// The realism report of one heightmap. All fields are 0 when nothing could be measured.
#[derive(Clone, Debug, Default, serde::Serialize)]
pub struct Realism {
    /// p10, p25, p50, p75, p90 of the slope in degrees (Horn's 3x3 gradient), over the
    /// interior cells (whole 3x3 window finite); linear interpolation between ranks.
    pub slope_deg_percentiles: [f64; 5],
    /// Fraction of interior cells where `|h_c - m| <= 0.001 * |grad h| * cell`, with `m` the
    /// (cell-size weighted) mean of the 4 neighbours, `grad h` by central differences (m/m)
    /// and `cell` the mean cell size: the 5-point Laplacian deviation is at most 0.1 % of the
    /// height change across one cell. A zero gradient needs a zero deviation.
    pub harmonic_fraction: f64,
    /// Fractions of the geomorphon classes, in the order of [`GEOMORPHON_NAMES`]: flat, peak,
    /// ridge, shoulder, spur, slope, hollow, footslope, valley, pit. Over interior cells whose
    /// 8 lines of sight (cut at the map border) contain no no-data.
    pub geomorphons: [f64; 10],
    /// Channel length (km) per km² of finite cells; channels are the cells whose D8 upstream
    /// area is at least [`Realism::channel_threshold_m2`].
    pub drainage_density_per_km: f64,
    /// The channel initiation threshold used, m².
    pub channel_threshold_m2: f64,
    /// Maximum minus minimum of the finite heights, m.
    pub relief_m: f64,
    /// Slope-weighted mean of `cos(8 aspect)` (central differences): about 0 on real land
    /// (0.005-0.09), 0.2-0.3 where slopes face the 8 grid directions (D8 routing's mark).
    pub grid_direction_index: f64,
    /// Share of the interior cells flatter than [`FLAT_DEG`] degrees.
    pub flat_fraction: f64,
    /// `(mean - min) / (max - min)` of the finite heights (real land 0.15-0.36).
    pub hypsometric_integral: f64,
    /// The share of the highest 5% of the finite cells that lie within a tenth of the map's
    /// side of its edge (36% where high ground is spread evenly; real 10-50 km windows
    /// 45-55%, small ones more; about 100% when the corners stand highest).
    pub frame_share: f64,
    /// Among the [`STRAIGHT_TOP_SHARE`] of cells with the largest D8 drainage area, the share
    /// whose flow kept one direction for [`STRAIGHT_RUN_CELLS`] cells or more (real land
    /// 0.04-0.13).
    pub straight_channel_fraction: f64,
    /// Number of interior cells measured (not on the border, 3x3 window finite).
    pub cells: usize,
}

/// Parameters of [`measure`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RealismParams {
    /// Geomorphon search radius `L` in cells (default 10; 0 is treated as 1).
    pub geomorphon_radius_cells: usize,
    /// Geomorphon flatness threshold `t` in degrees (default 1; clamped to 0..=89).
    pub flat_deg: f64,
    /// Channel initiation area in m²; `None` (or not positive / not finite) uses
    /// [`default_channel_area_m2`].
    pub channel_area_m2: Option<f64>,
}

impl Default for RealismParams {
    fn default() -> Self {
        Self {
            geomorphon_radius_cells: 10,
            flat_deg: 1.0,
            channel_area_m2: None,
        }
    }
}

/// Default channel initiation area: 0.1 km², but at least 10 cells so that coarse maps do
/// not turn every cell into a channel.
pub fn default_channel_area_m2(cell_x_m: f64, cell_y_m: f64) -> f64 {
    let cell_area = (cell_x_m * cell_y_m).abs();
    if cell_area.is_finite() {
        1e5_f64.max(10.0 * cell_area)
    } else {
        1e5
    }
}

/// Measures the realism statistics of a `width x height` row-major heightmap with cells of
/// `cell_x_m` (along a row) by `cell_y_m` (along a column) metres.
///
/// Never panics: a shape that does not match `heights.len()`, a zero / non-finite cell size,
/// or a map without any finite interior cell gives a report with `cells == 0` (and zeros
/// elsewhere, except `relief_m` and `channel_threshold_m2` where they can be computed).
pub fn measure(
    heights: &[f32],
    width: usize,
    height: usize,
    cell_x_m: f64,
    cell_y_m: f64,
    params: &RealismParams,
) -> Realism {
    measure_with_sinks(heights, width, height, cell_x_m, cell_y_m, params, &[])
}

/// [`measure`] of a designed terrain whose water also leaves the map at the interior cells
/// `sinks` (its river mouths, [`crate::skeleton::Skeleton::mouths`]): the drainage measures
/// route to them as to the border instead of filling their catchments.
pub fn measure_with_sinks(
    heights: &[f32],
    width: usize,
    height: usize,
    cell_x_m: f64,
    cell_y_m: f64,
    params: &RealismParams,
    sinks: &[u32],
) -> Realism {
    let threshold = params
        .channel_area_m2
        .filter(|a| a.is_finite() && *a > 0.0)
        .unwrap_or_else(|| default_channel_area_m2(cell_x_m, cell_y_m));
    let mut report = Realism {
        channel_threshold_m2: threshold,
        ..Realism::default()
    };
    let Some(g) = Grid::new(heights, width, height, cell_x_m, cell_y_m) else {
        return report;
    };
    let g = g.with_sinks(sinks);
    report.relief_m = g.finite_range().map_or(0.0, |(lo, hi)| hi - lo);
    let interior = g.interior_mask();
    report.cells = interior.iter().filter(|m| **m).count();
    let flat_deg = if params.flat_deg.is_finite() {
        params.flat_deg.clamp(0.0, 89.0)
    } else {
        0.0
    };
    // The drainage (a serial flood and routing) beside the local measures, natively.
    let (flow, local) = crate::parallel::join(
        || drainage::drainage(&g, threshold),
        || {
            (report.cells > 0).then(|| {
                let mut slopes = slope::slopes_deg(&g, &interior);
                let percentiles = slope::percentiles(&mut slopes, &slope::PERCENTILES);
                drop(slopes);
                let harmonic = harmonic::harmonic_fraction(&g, &interior);
                let radius = params.geomorphon_radius_cells.max(1);
                let forms = geomorphon::class_fractions(&g, &interior, radius, flat_deg);
                (
                    percentiles,
                    harmonic,
                    forms,
                    landform::landform(&g, &interior),
                )
            })
        },
    );
    report.drainage_density_per_km = flow.density_per_km;
    report.straight_channel_fraction = flow.straight_fraction;
    if let Some((percentiles, harmonic, forms, land)) = local {
        report.slope_deg_percentiles = percentiles;
        report.harmonic_fraction = harmonic;
        report.geomorphons = forms;
        report.grid_direction_index = land.grid_direction_index;
        report.flat_fraction = land.flat_fraction;
        report.hypsometric_integral = land.hypsometric_integral;
        report.frame_share = land.frame_share;
    }
    report
}
