//! The realism report as `strahler analyze`, the `generate` report and the app's Realism
//! panel give it: [`super::measure`]'s statistics plus the spectral slope of seed 001's
//! wavelet analysis (eqs. 6-7), so a generated terrain and a real DEM are compared number
//! for number.

use serde::Serialize;

use super::{Realism, RealismParams, measure};
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
        // The wavelet analysis needs a void-free field; a DEM with voids gets the rest. The
        // two run at once natively.
        let (measures, analysis) = crate::parallel::join(
            || {
                measure(
                    field.data(),
                    field.width(),
                    field.height(),
                    cell_x,
                    cell_y,
                    &RealismParams::default(),
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
        let log2_variance = analysis
            .iter()
            .flat_map(|a| {
                a.levels.iter().map(|l| {
                    let v = l.variances.iter().sum::<f64>() / 3.0;
                    (v > 0.0).then(|| v.log2())
                })
            })
            .collect();
        Self {
            measures,
            spectral_gamma,
            wavelet_fits,
            log2_variance,
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
        lines
    }
}
