//! The eframe application: map in the centre, pipeline controls on the left, status below.
//!
//! The same code runs in a native window and in the browser. Heavy work runs as
//! [`crate::jobs`] jobs; the frame loop only polls their progress and takes their results.

mod automation;
mod map_view;
mod relief;
mod side_panel;
mod status_bar;

use std::sync::Arc;

pub use automation::{Automation, JobStatus, Status};
pub use map_view::{Hover, MapView};
pub use side_panel::FillSettings;

use crate::compute::selftest::{RunSummary, SelfTest};
use crate::compute::{ComputePath, CpuReason};
use crate::diffusion::{DiffusionError, Filled};
use crate::gpu::{GpuContext, device_descriptor};
use crate::jobs::JobHandle;

/// Width of the demo map in metres (sets the cell size for shading and readouts).
pub const MAP_WIDTH_M: f32 = 10_000.0;

/// eframe's wgpu setup for Strahler: the adapter's full limits, so compute on large fields
/// works on the device egui draws with. On the web eframe tries WebGPU first and falls back
/// to WebGL2, which has no compute shaders: the app then computes on the CPU.
pub fn wgpu_options() -> egui_wgpu::WgpuConfiguration {
    let mut create = egui_wgpu::WgpuSetupCreateNew::without_display_handle();
    create.device_descriptor = Arc::new(device_descriptor);
    egui_wgpu::WgpuConfiguration {
        wgpu_setup: egui_wgpu::WgpuSetup::CreateNew(create),
        ..Default::default()
    }
}

/// The application state.
pub struct StrahlerApp {
    path: ComputePath,
    automation: Automation,
    map: MapView,
    settings: FillSettings,
    fill_job: Option<JobHandle<Result<Filled, DiffusionError>>>,
    selftest_job: Option<JobHandle<Result<SelfTest, DiffusionError>>>,
    last_run: Option<(usize, RunSummary)>,
    selftest: Option<Result<SelfTest, String>>,
    error: Option<String>,
    hover: Option<Hover>,
}

impl StrahlerApp {
    /// Builds the app from eframe's creation context and starts the first fill, so the
    /// first screen shows terrain.
    pub fn new(cc: &eframe::CreationContext<'_>, automation: Automation) -> Self {
        let (path, adapter, caps) = match &cc.wgpu_render_state {
            Some(state) => {
                let gpu = GpuContext::from_render_state(state);
                let (adapter, caps) = (gpu.adapter.clone(), gpu.caps.clone());
                (ComputePath::from_context(gpu), Some(adapter), Some(caps))
            }
            None => (
                ComputePath::Cpu {
                    reason: CpuReason::NoAdapter("the window was created without wgpu".into()),
                },
                None,
                None,
            ),
        };
        log::info!("compute path: {path}");
        automation.set_compute_path(&path, adapter, caps);
        let mut app = Self {
            path,
            automation,
            map: MapView::default(),
            settings: FillSettings::default(),
            fill_job: None,
            selftest_job: None,
            last_run: None,
            selftest: None,
            error: None,
            hover: None,
        };
        app.start_fill(&cc.egui_ctx);
        app
    }

    pub fn compute_path(&self) -> &ComputePath {
        &self.path
    }

    pub fn automation(&self) -> &Automation {
        &self.automation
    }

    /// The terrain on the map, if any.
    pub fn terrain(&self) -> Option<&crate::heightfield::Heightfield> {
        self.map.field()
    }

    /// The diffusion controls.
    pub fn settings(&self) -> &FillSettings {
        &self.settings
    }

    /// The diffusion controls (tests and automation change them like the user would).
    pub fn settings_mut(&mut self) -> &mut FillSettings {
        &mut self.settings
    }

    /// Whether a job is running.
    pub fn busy(&self) -> bool {
        self.fill_job.is_some() || self.selftest_job.is_some()
    }

    /// Starts the diffusion fill with the current settings, cancelling a running one.
    pub fn start_fill(&mut self, ctx: &egui::Context) {
        let backend = match self.settings.backend.resolve(&self.path) {
            Ok(backend) => backend,
            Err(err) => {
                self.set_error(err.to_string());
                return;
            }
        };
        let (size, method) = (self.settings.size, self.settings.method());
        let repaint = ctx.clone();
        let spawned = crate::jobs::spawn(
            "diffusion",
            move |job| async move {
                let problem = crate::diffusion::demo::valley_and_peaks(size);
                crate::diffusion::fill(&backend, &problem, method, &job).await
            },
            move || repaint.request_repaint(),
        );
        match spawned {
            // Replacing the handle drops (and so cancels) a stale job.
            Ok(handle) => self.fill_job = Some(handle),
            Err(err) => self.set_error(err.to_string()),
        }
    }

    /// Runs the CPU/GPU self-test in the background.
    pub fn start_selftest(&mut self, ctx: &egui::Context) {
        let path = self.path.clone();
        let repaint = ctx.clone();
        let spawned = crate::jobs::spawn(
            "self-test",
            move |job| async move { crate::compute::selftest::run(&path, &job).await },
            move || repaint.request_repaint(),
        );
        match spawned {
            Ok(handle) => self.selftest_job = Some(handle),
            Err(err) => self.set_error(err.to_string()),
        }
    }

    fn set_error(&mut self, message: String) {
        log::warn!("{message}");
        self.automation
            .update(|s| s.last_error = Some(message.clone()));
        self.error = Some(message);
    }

    /// Takes finished results and publishes job progress. Called once per frame.
    fn poll_jobs(&mut self, ctx: &egui::Context) {
        if let Some(result) = self.fill_job.as_ref().and_then(JobHandle::try_take) {
            self.fill_job = None;
            match result {
                Ok(filled) => {
                    let size = filled.field.width();
                    let summary = RunSummary::from(&filled);
                    self.map
                        .set_field(ctx, filled.field, MAP_WIDTH_M / size as f32);
                    self.automation
                        .update(|s| s.last_run = Some(summary.clone()));
                    self.last_run = Some((size, summary));
                    self.error = None;
                }
                Err(DiffusionError::Cancelled(_)) => {}
                Err(err) => self.set_error(format!("Diffusion failed: {err}")),
            }
        }
        if let Some(result) = self.selftest_job.as_ref().and_then(JobHandle::try_take) {
            self.selftest_job = None;
            self.selftest = Some(result.map_err(|err| err.to_string()));
        }
        let job = self
            .fill_job
            .as_ref()
            .map(|j| (j.name().to_owned(), j.progress(), j.message()))
            .or_else(|| {
                self.selftest_job
                    .as_ref()
                    .map(|j| (j.name().to_owned(), j.progress(), j.message()))
            });
        self.automation.update(|s| {
            s.job = job.map(|(name, progress, message)| JobStatus {
                name,
                progress,
                message,
            })
        });
        if self.busy() {
            // Keep the progress bar moving (10 Hz is enough, and leaves the CPU path its time);
            // results also trigger a repaint when they land.
            ctx.request_repaint_after(std::time::Duration::from_millis(100));
        }
    }
}

impl eframe::App for StrahlerApp {
    fn ui(&mut self, ui: &mut egui::Ui, _frame: &mut eframe::Frame) {
        let ctx = ui.ctx().clone();
        self.poll_jobs(&ctx);
        status_bar::show(ui, self);
        side_panel::show(ui, self);
        egui::CentralPanel::no_frame().show(ui, |ui| {
            self.hover = self.map.show(ui);
        });
    }
}
