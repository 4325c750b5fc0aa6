//! The bottom bar: gathers what [`super::panels::StatusBar`] shows (the compute path, the
//! running job, the tool, the pointer) from the app.

use super::StrahlerApp;
use super::panels::{JobLine, StatusInfo};
use crate::jobs::JobHandle;

pub(super) fn show(ui: &mut egui::Ui, app: &mut StrahlerApp) {
    let job = app
        .session
        .job()
        .map(line)
        .or_else(|| app.check.job.as_ref().map(line))
        .or_else(|| app.export.running.first().map(|e| line(&e.job)));
    let info = StatusInfo {
        path: &app.path,
        job,
        map: app.session.on_map(),
        tool: app.canvas.tool,
        hover: app.canvas.hover,
        worker: worker_words(),
    };
    let bar = &mut app.panels.status;
    egui::Panel::bottom("status").show(ui, |ui| bar.show(ui, &info));
}

/// A job's line in the bar.
fn line<T>(job: &JobHandle<T>) -> JobLine {
    JobLine {
        name: job.name().to_owned(),
        progress: job.progress(),
        message: job.message(),
        left: job.time_left(),
    }
}

/// Where the page's heavy stages run; `None` natively (every job has its own thread there).
pub(super) fn worker_words() -> Option<String> {
    #[cfg(target_arch = "wasm32")]
    return Some(crate::jobs::worker::describe());
    #[cfg(not(target_arch = "wasm32"))]
    None
}

/// The threads the page's Web Worker computes on, once it started; `None` natively.
pub(super) fn worker_threads() -> Option<u32> {
    #[cfg(target_arch = "wasm32")]
    return crate::jobs::worker::threads().map(|t| t.count);
    #[cfg(not(target_arch = "wasm32"))]
    None
}
