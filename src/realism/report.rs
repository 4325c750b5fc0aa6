//! The realism report as `strahler analyze`, the `generate` report and the app's Realism
//! panel give it: [`super::measure`]'s statistics plus the spectral slope of seed 001's
//! wavelet analysis (eqs. 6-7), so a generated terrain and a real DEM are compared number
//! for number.

use serde::Serialize;

use super::{Realism, RealismParams, measure_with_sinks};
use crate::heightfield::Heightfield;
use crate::wavelet::{self, AnalysisParams, Band};

/// What the realism report gives.
#[derive(Clone, Debug, Serialize)]
pub struct RealismReport {
    #[serde(flatten)]
    pub measures: Realism,
    /// Spectral slope gamma of the wavelet fit, the bands pooled (their mean): 2.5 to 4.5
    /// on real land (seed 001: gamma = 2H + 2 for fBm of Hurst exponent H).
    pub spectral_gamma: Option<f64>,
    /// Per band (H, V, D): gamma and the rms residual of its line fit (log2 units).
    pub wavelet_fits: Vec<BandFit>,
    /// log2 of the detail variance per level, finest first, the bands pooled (their mean).
    pub log2_variance: Vec<Option<f64>>,
    /// Largest distance (log2 units) of a level's pooled log-variance from the least-squares
    /// line through the levels the wavelet fits use: on real land it grows with the number
    /// of levels ([`real_bump`]); a terrain dissected at one spacing has one level standing
    /// out by 2.
    pub spectral_bump: Option<f64>,
    /// How many levels the bump's line is fitted through.
    pub spectral_bump_levels: usize,
}

/// The spectral bump of real land, least and largest, by the number of levels its line is
/// fitted through: windows of the SRTM tile N44E005 (Mont Ventoux, Baronnies, Diois and the
/// southern Vercors; 66 x 92 m cells) of 128^2, 256^2, 512^2 and 1024^2 cells, 16, 16, 16
/// and 9 windows spread over the tile (`docs/features.md`, "The spectral bump and the map's
/// size"). Real spectra bend (Perron, Kirchner and Dietrich 2008, "Spectral signatures of
/// characteristic spatial scales and nonfractal structure in landscapes", JGR 113, F04003:
/// a rollover at the valleys' spacing, smooth hillslopes below it), so the more octaves a
/// line spans, the farther its ends stand from it: a bump is judged against land of as many
/// levels.
const REAL_BUMP: [(usize, f64, f64); 4] =
    [(5, 0.2, 0.8), (6, 0.5, 1.4), (7, 1.1, 1.9), (8, 1.7, 2.1)];

/// The real land's bump for a line through `levels` levels: the measured range of the
/// nearest number of levels measured, and that number.
pub fn real_bump(levels: usize) -> (f64, f64, usize) {
    let (first, last) = (REAL_BUMP[0], REAL_BUMP[REAL_BUMP.len() - 1]);
    let (k, lo, hi) = REAL_BUMP
        .iter()
        .copied()
        .find(|(k, _, _)| *k == levels)
        .unwrap_or(if levels < first.0 { first } else { last });
    (lo, hi, k)
}

#[derive(Clone, Debug, Serialize)]
pub struct BandFit {
    pub band: &'static str,
    pub gamma: f64,
    pub residual: f64,
}

impl RealismReport {
    /// Measures `field` (cells `cell_x` by `cell_y` metres). O(cells x geomorphon radius).
    pub fn of(field: &Heightfield, cell_x: f64, cell_y: f64) -> Self {
        Self::of_terrain(field, cell_x, cell_y, &[])
    }

    /// [`Self::of`] a designed terrain whose water also leaves the map at the interior
    /// cells `sinks` (its river mouths; see [`super::measure_with_sinks`]).
    pub fn of_terrain(field: &Heightfield, cell_x: f64, cell_y: f64, sinks: &[u32]) -> Self {
        // The wavelet analysis needs a void-free field; a DEM with voids gets the rest. The
        // two run at once natively.
        let (measures, analysis) = crate::parallel::join(
            || {
                measure_with_sinks(
                    field.data(),
                    field.width(),
                    field.height(),
                    cell_x,
                    cell_y,
                    &RealismParams::default(),
                    sinks,
                )
            },
            || wavelet::analyze(field, &AnalysisParams::default()).ok(),
        );
        let wavelet_fits: Vec<BandFit> = analysis
            .iter()
            .flat_map(|a| {
                Band::ALL.iter().filter_map(|&b| {
                    a.fits[b.index()].map(|f| BandFit {
                        band: b.label(),
                        gamma: f.gamma,
                        residual: f.residual,
                    })
                })
            })
            .collect();
        let spectral_gamma = analysis.as_ref().and_then(wavelet::Analysis::pooled_gamma);
        let log2_variance: Vec<Option<f64>> = analysis
            .iter()
            .flat_map(|a| {
                a.levels.iter().map(|l| {
                    let v = l.variances.iter().sum::<f64>() / 3.0;
                    (v > 0.0).then(|| v.log2())
                })
            })
            .collect();
        // The bump over the levels the fits use (enough coefficients to be measured).
        let fitted: Vec<Option<f64>> = analysis
            .iter()
            .flat_map(|a| {
                a.levels
                    .iter()
                    .zip(&log2_variance)
                    .map(|(l, v)| v.filter(|_| l.fitted.iter().any(|f| *f)))
            })
            .collect();
        let spectral_bump = spectral_bump(&fitted);
        Self {
            measures,
            spectral_gamma,
            wavelet_fits,
            log2_variance,
            spectral_bump,
            spectral_bump_levels: fitted.iter().flatten().count(),
        }
    }

    /// The report as lines of text (`strahler analyze`, `strahler generate`).
    pub fn lines(&self) -> Vec<String> {
        let m = &self.measures;
        let p = m.slope_deg_percentiles;
        let mut lines = vec![
            format!(
                "slope (degrees) p10 {:.1}, p25 {:.1}, median {:.1}, p75 {:.1}, p90 {:.1}",
                p[0], p[1], p[2], p[3], p[4]
            ),
            format!(
                "harmonic cells (Laplace to 0.1% of the local gradient): {:.1}% (real land: a few %)",
                m.harmonic_fraction * 100.0
            ),
            format!(
                "drainage density {:.2} km/km^2 (channels from {:.2} km^2); relief {:.0} m",
                m.drainage_density_per_km,
                m.channel_threshold_m2 / 1e6,
                m.relief_m
            ),
        ];
        let classes: Vec<String> = super::GEOMORPHON_NAMES
            .iter()
            .zip(m.geomorphons)
            .map(|(name, f)| format!("{name} {:.1}%", f * 100.0))
            .collect();
        lines.push(format!("geomorphons: {}", classes.join(", ")));
        match self.spectral_gamma {
            Some(g) => lines.push(format!(
                "spectral slope gamma {g:.2} (bands pooled; real land 2.5 to 4.5); fit residuals {}",
                self.wavelet_fits
                    .iter()
                    .map(|f| format!("{} {:.2}", f.band, f.residual))
                    .collect::<Vec<_>>()
                    .join(", ")
            )),
            None => lines.push("spectral slope: no wavelet fit (voids or too small)".into()),
        }
        if let Some(b) = self.spectral_bump {
            let levels = self.spectral_bump_levels;
            let (lo, hi, measured) = real_bump(levels);
            let like = if measured == levels {
                format!("SRTM windows over {levels} levels {lo:.1} to {hi:.1}")
            } else {
                format!("{levels} levels; SRTM windows over {measured} {lo:.1} to {hi:.1}")
            };
            lines.push(format!(
                "spectral bump {b:.2} log2 units (largest level off the line; {like})"
            ));
        }
        lines.push(format!(
            "grid-direction index {:.3} (real land 0.005 to 0.09); straight channel runs {:.1}% \
             (real 4 to 13%)",
            m.grid_direction_index,
            m.straight_channel_fraction * 100.0
        ));
        lines.push(format!(
            "flats (under {} degrees) {:.1}% (mountains about 1%); hypsometric integral {:.2} \
             (real 0.15 to 0.36)",
            super::FLAT_DEG,
            m.flat_fraction * 100.0,
            m.hypsometric_integral
        ));
        lines.push(format!(
            "high ground on the frame {:.0}% (the top 5% of cells within a tenth of the side of \
             the edge; real 10-50 km windows 45 to 55%, spread evenly 36%)",
            m.frame_share * 100.0
        ));
        lines
    }
}

impl RealismReport {
    /// `self` and `other` (e.g. a real DEM) side by side, a measure a line, with the range of
    /// real land where one is known (`shared/docs/realism.md`).
    pub fn comparison_lines(&self, other: &RealismReport, names: (&str, &str)) -> Vec<String> {
        comparison_table(&[(names.0, self), (names.1, other)], &[])
    }
}

/// The realism measures of several terrains side by side, a column each (named), the range
/// of real land last; `extra` rows (a label and a value per column) come first.
pub fn comparison_table(
    columns: &[(&str, &RealismReport)],
    extra: &[(&str, Vec<String>)],
) -> Vec<String> {
    let row = |f: &dyn Fn(&RealismReport) -> String| -> Vec<String> {
        columns.iter().map(|(_, r)| f(r)).collect()
    };
    // The real bump over as many levels as the first column's line spans.
    let bump_levels = columns.first().map_or(0, |(_, r)| r.spectral_bump_levels);
    let (lo, hi, measured) = real_bump(bump_levels);
    let real_bump = format!("{lo:.1}-{hi:.1} (SRTM, {measured} levels)");
    let mut rows: Vec<(&str, Vec<String>, &str)> = extra
        .iter()
        .map(|(label, values)| (*label, values.clone(), ""))
        .collect();
    rows.extend([
        (
            "relief (m)",
            row(&|r| format!("{:.0}", r.measures.relief_m)),
            "",
        ),
        ("slope p10 (deg)", row(&|r| slope(r, 0)), ""),
        ("slope median (deg)", row(&|r| slope(r, 2)), ""),
        ("slope p90 (deg)", row(&|r| slope(r, 4)), ""),
        (
            "grid-direction index",
            row(&|r| format!("{:.3}", r.measures.grid_direction_index)),
            "0.005-0.09",
        ),
        (
            "straight channel runs",
            row(&|r| percent(r.measures.straight_channel_fraction)),
            "4-13%",
        ),
        (
            "flats (< 0.5 deg)",
            row(&|r| percent(r.measures.flat_fraction)),
            "~1% (mountains)",
        ),
        (
            "harmonic cells",
            row(&|r| percent(r.measures.harmonic_fraction)),
            "2-5%",
        ),
        (
            "hypsometric integral",
            row(&|r| format!("{:.2}", r.measures.hypsometric_integral)),
            "0.15-0.36",
        ),
        (
            "high ground on the frame",
            row(&|r| percent(r.measures.frame_share)),
            "45-55% (10-50 km)",
        ),
        (
            "spectral slope gamma",
            row(&|r| optional(r.spectral_gamma)),
            "2.5-4.5",
        ),
        (
            "spectral bump (log2)",
            row(&|r| optional(r.spectral_bump)),
            &real_bump,
        ),
        (
            "drainage density (/km)",
            row(&|r| format!("{:.2}", r.measures.drainage_density_per_km)),
            "",
        ),
    ]);
    let mut header = format!("{:<24}", "");
    for (name, _) in columns {
        header.push_str(&format!("{:>14}", clip(name)));
    }
    header.push_str("  real land");
    let mut lines = vec![header];
    for (label, values, real) in rows {
        let mut line = format!("{label:<24}");
        for v in values {
            line.push_str(&format!("{v:>14}"));
        }
        line.push_str(&format!("  {real}"));
        lines.push(line.trim_end().to_string());
    }
    lines
}

fn slope(r: &RealismReport, k: usize) -> String {
    format!("{:.1}", r.measures.slope_deg_percentiles[k])
}

fn percent(f: f64) -> String {
    format!("{:.1}%", f * 100.0)
}

fn optional(v: Option<f64>) -> String {
    v.map_or("-".to_owned(), |v| format!("{v:.2}"))
}

/// The last 13 characters of a column's name.
fn clip(name: &str) -> String {
    let chars: Vec<char> = name.chars().collect();
    chars[chars.len().saturating_sub(13)..].iter().collect()
}

/// The largest distance of a level's value from the least-squares line through the levels
/// that have one (`None` with fewer than 3).
pub(super) fn spectral_bump(log2_variance: &[Option<f64>]) -> Option<f64> {
    let points: Vec<(f64, f64)> = log2_variance
        .iter()
        .enumerate()
        .filter_map(|(k, v)| v.map(|v| (k as f64, v)))
        .collect();
    if points.len() < 3 {
        return None;
    }
    let n = points.len() as f64;
    let (mx, my) = points
        .iter()
        .fold((0.0, 0.0), |(a, b), (x, y)| (a + x / n, b + y / n));
    let sxy: f64 = points.iter().map(|(x, y)| (x - mx) * (y - my)).sum();
    let sxx: f64 = points.iter().map(|(x, _)| (x - mx) * (x - mx)).sum();
    let slope = sxy / sxx;
    points
        .iter()
        .map(|(x, y)| (y - my - slope * (x - mx)).abs())
        .reduce(f64::max)
}

#[cfg(test)]
mod tests {
    use super::{real_bump, spectral_bump};

    #[test]
    fn real_land_bends_more_over_more_levels() {
        let (lo6, hi6, k6) = real_bump(6);
        let (lo8, hi8, k8) = real_bump(8);
        assert_eq!((k6, k8), (6, 8));
        assert!(lo6 < lo8 && hi6 < hi8);
        assert_eq!(
            real_bump(3).2,
            5,
            "fewer levels than measured: the fewest measured"
        );
        assert_eq!(real_bump(10).2, 8, "more: the most measured");
    }

    #[test]
    fn bump_is_the_largest_distance_from_the_line() {
        assert_eq!(spectral_bump(&[Some(1.0), None, Some(3.0)]), None);
        let line: Vec<Option<f64>> = (0..6).map(|k| Some(2.0 * k as f64 - 1.0)).collect();
        assert!(spectral_bump(&line).expect("a fit") < 1e-12);
        let mut bumped = line.clone();
        bumped[2] = Some(3.0 + 2.0);
        let b = spectral_bump(&bumped).expect("a fit");
        assert!(b > 1.5 && b < 2.0, "{b}");
    }
}
