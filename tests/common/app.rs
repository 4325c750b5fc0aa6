//! The app in an egui_kittest harness on a real wgpu device, and waiting for its jobs.
#![allow(dead_code)] // each test crate uses its own part

use std::time::{Duration, Instant};

use egui_kittest::Harness;
use strahler::app::{Automation, Command, StrahlerApp};
use strahler::compute::BackendChoice;

/// The app in a window of `width` x `height` points.
pub fn harness(width: f32, height: f32) -> Harness<'static, StrahlerApp> {
    Harness::builder()
        .with_size(egui::vec2(width, height))
        .wgpu()
        .build_eframe(|cc| {
            // Compute on the GPU, software rasteriser or not (auto would take the CPU beside
            // lavapipe): these tests are of the GPU path.
            let automation = Automation::default();
            automation.push(Command::Compute(BackendChoice::Gpu));
            StrahlerApp::new(cc, automation)
        })
}

/// The app without a GPU renderer: it computes on the CPU path, as in a browser without
/// WebGPU. For tests of the UI and the pipeline that need no GPU (they run everywhere).
pub fn cpu_harness(width: f32, height: f32) -> Harness<'static, StrahlerApp> {
    Harness::builder()
        .with_size(egui::vec2(width, height))
        .build_eframe(|cc| StrahlerApp::new(cc, Automation::default()))
}

/// Steps frames until `done` holds (the UI keeps responding meanwhile); fails after 2 minutes.
pub fn wait_until<T>(
    harness: &mut Harness<'static, T>,
    what: &str,
    done: impl Fn(&Harness<'static, T>) -> bool,
) {
    let start = Instant::now();
    while !done(harness) {
        assert!(
            start.elapsed() < Duration::from_secs(120),
            "{what} never happened"
        );
        harness.step();
        std::thread::sleep(Duration::from_millis(10));
    }
}

/// Steps frames until the app has no job running.
pub fn wait_idle(harness: &mut Harness<'static, StrahlerApp>) {
    wait_until(harness, "the end of the job", |h| !h.state().busy());
    harness.run_steps(3);
}
