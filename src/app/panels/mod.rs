//! The side panel's sections as components, in the style of egui's demo app: each owns its
//! UI state, reads the scene (and the output it reports on) and returns what it wants changed
//! as [`Action`]s, which the app applies in one place ([`super::StrahlerApp::act`]). A new
//! scene field needs the scene, its stage and its panel only. Each panel is tested alone in
//! `tests/panels.rs`.

mod check;
mod dem;
mod detail;
mod document;
mod erosion;
mod export;
mod mask;
mod realism;
mod rivers;
mod solver;
mod start;
mod status;
mod style;
mod terrain;

pub use check::{AGREEMENT, CheckPanel, CheckReport};
pub use dem::{DEFAULT_Z_RANGE, DemAction, DemInfo, DemPanel, DemView, NetworkTable, NetworksView};
pub use detail::DetailPanel;
pub use document::{DocumentAction, DocumentPanel, DocumentView};
pub use erosion::ErosionPanel;
pub use export::{ExportDialog, ExportInfo};
pub use mask::{MaskAction, MaskPanel, MaskView, kind_words};
pub use realism::RealismPanel;
pub use rivers::RiversPanel;
pub use solver::{Report as SolverReport, SolverPanel};
pub use start::{DESIGN_ONLY, SIZES, StartPanel};
pub use status::{JobLine, StatusBar, StatusInfo, tool_hint};
pub use style::StylePanel;
pub use terrain::TerrainPanel;

use super::map_view::Tool;
use super::session::RunSettings;
use crate::scene::Edit;

/// What a panel asks for.
#[derive(Clone, Debug, PartialEq)]
pub enum Action {
    /// A change to the document.
    Edit(Edit),
    /// New run settings (the solver, preview, realism).
    Settings(RunSettings),
    /// Pick a map tool.
    Tool(Tool),
    /// Run again although nothing changed.
    Generate,
    /// Run at the full grid size (with Preview on).
    GenerateFullSize,
    /// Cancel the running terrain job.
    Cancel,
    /// Run the compute check: the same problems on the CPU and the GPU.
    CompareBackends,
    /// Say something went wrong.
    Error(String),
    /// Forget the error shown.
    DismissError,
    /// Something for the mask tools.
    Mask(MaskAction),
    /// Something for the DEM panel.
    Dem(DemAction),
    /// Something for the document: undo, redo, save, open, export.
    Document(DocumentAction),
    /// Write an export (and the skeleton's layers with `layers`).
    Export {
        request: crate::export::Request,
        layers: bool,
    },
    /// Save the plan of a world in tiles of the scene (`strahler build`'s input).
    SaveWorldPlan {
        size: usize,
        tile: usize,
        fill: bool,
    },
    /// Build and save that world's preview (its global build, `strahler build`'s
    /// `preview.tif`).
    SaveWorldPreview { size: usize, tile: usize },
}

/// Every panel of the side panel, with its own state.
#[derive(Default)]
pub struct Panels {
    pub start: StartPanel,
    pub check: CheckPanel,
    pub rivers: RiversPanel,
    pub terrain: TerrainPanel,
    pub solver: SolverPanel,
    pub erosion: ErosionPanel,
    pub style: StylePanel,
    pub realism: RealismPanel,
    pub detail: DetailPanel,
    pub mask: MaskPanel,
    pub dem: DemPanel,
    pub document: DocumentPanel,
    pub status: StatusBar,
}

/// The error of an action taken in a section, beside its buttons (the top of the side panel
/// lists it too), with a button that asks to dismiss it.
fn error_row(ui: &mut egui::Ui, error: Option<&str>) -> Option<Action> {
    let error = error?;
    let mut dismissed = false;
    ui.horizontal_wrapped(|ui| {
        ui.colored_label(ui.visuals().error_fg_color, error);
        dismissed = ui.small_button("Dismiss").clicked();
    });
    dismissed.then_some(Action::DismissError)
}
