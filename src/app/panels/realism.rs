//! The Realism section: the measures `strahler analyze` gives a real DEM, for the terrain on
//! the map (when turned on, each run measures it: about 0.1 s at 512 x 512).

use egui::RichText;

use super::Action;
use crate::app::session::RunSettings;
use crate::realism::RealismReport;

/// The Realism section (it keeps no state of its own).
#[derive(Default)]
pub struct RealismPanel;

impl RealismPanel {
    pub fn show(
        &mut self,
        ui: &mut egui::Ui,
        run: &RunSettings,
        report: Option<&RealismReport>,
    ) -> Vec<Action> {
        ui.label(RichText::new("Realism").strong()).on_hover_text(
            "Slope distribution, harmonic cells, geomorphons, drainage density, the wavelet \
             spectral slope and bump, the grid-direction index, straight channel runs, flats \
             and the hypsometric integral: compare them with `strahler analyze DEM --compare \
             REAL`.",
        );
        let mut measure = run.measure_realism;
        ui.checkbox(&mut measure, "Measure each terrain");
        if measure {
            match report {
                Some(report) => {
                    for line in report.lines() {
                        ui.label(line);
                    }
                }
                None => {
                    ui.label(RichText::new("Measured with the next terrain").weak());
                }
            }
        }
        if measure == run.measure_realism {
            return Vec::new();
        }
        // The next run (every stage from the cache) measures, or stops measuring.
        vec![Action::Settings(RunSettings {
            measure_realism: measure,
            ..run.clone()
        })]
    }
}
