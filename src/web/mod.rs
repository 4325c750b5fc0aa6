//! The browser entry point: starts the eframe app on the page's canvas and exposes
//! `window.strahler` for scripts (see `api`).

mod api;
mod stages;

use wasm_bindgen::JsCast as _;

use crate::app::{Automation, StrahlerApp, wgpu_options};

/// Id of the `<canvas>` in `web/index.html`.
const CANVAS_ID: &str = "strahler_canvas";
/// Id of the loading text shown while the wasm downloads.
const LOADING_ID: &str = "loading_text";

/// Called by `main` on wasm32: in the page, starts the app; in the page's Web Worker (the
/// same module, see [`crate::jobs::worker`]), serves the stages the page hands it.
pub fn start() {
    if crate::jobs::threads::in_pool_thread() {
        // A thread of the stages worker's pool: it runs what rayon hands it.
        return;
    }
    let _ = eframe::WebLogger::init(log::LevelFilter::Info);
    if crate::jobs::worker::in_worker() {
        stages::serve();
        return;
    }
    let automation = Automation::default();
    api::install(&automation);

    wasm_bindgen_futures::spawn_local(async move {
        let Some(document) = web_sys::window().and_then(|w| w.document()) else {
            log::error!("no document: Strahler must run in a browser page");
            return;
        };
        let canvas = document
            .get_element_by_id(CANVAS_ID)
            .and_then(|e| e.dyn_into::<web_sys::HtmlCanvasElement>().ok());
        let Some(canvas) = canvas else {
            show_loading_error(
                &document,
                &format!("The page has no <canvas id=\"{CANVAS_ID}\">."),
            );
            return;
        };
        let options = eframe::WebOptions {
            wgpu_options: wgpu_options(),
            ..Default::default()
        };
        let app_automation = automation.clone();
        let started = eframe::WebRunner::new()
            .start(
                canvas,
                options,
                Box::new(move |cc| Ok(Box::new(StrahlerApp::new(cc, app_automation)))),
            )
            .await;
        match started {
            Ok(()) => {
                if let Some(loading) = document.get_element_by_id(LOADING_ID) {
                    loading.remove();
                }
            }
            Err(err) => {
                let message = format!("Strahler could not start: {err:?}");
                log::error!("{message}");
                automation.update(|s| s.last_error = Some(message.clone()));
                show_loading_error(&document, &message);
            }
        }
    });
}

fn show_loading_error(document: &web_sys::Document, message: &str) {
    if let Some(loading) = document.get_element_by_id(LOADING_ID) {
        loading.set_text_content(Some(message));
    }
}
