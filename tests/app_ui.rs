//! The app's first screen driven headlessly with egui_kittest on a real wgpu device
//! (lavapipe on CI): map, side panel, status bar, the fill job and the compute check.

mod common;

use std::time::{Duration, Instant};

use egui_kittest::Harness;
use egui_kittest::kittest::Queryable;
use strahler::app::{Automation, StrahlerApp};

fn harness() -> Harness<'static, StrahlerApp> {
    Harness::builder()
        .with_size(egui::vec2(1200.0, 800.0))
        .wgpu()
        .build_eframe(|cc| StrahlerApp::new(cc, Automation::default()))
}

/// Steps frames until the app has no job running (the UI keeps responding meanwhile).
fn wait_idle(harness: &mut Harness<'static, StrahlerApp>) {
    let start = Instant::now();
    while harness.state().busy() {
        assert!(
            start.elapsed() < Duration::from_secs(120),
            "job never finished"
        );
        harness.step();
        std::thread::sleep(Duration::from_millis(10));
    }
    harness.run_steps(3);
}

#[test]
fn first_screen_names_the_compute_path_and_shows_terrain() {
    if common::gpu().is_none() {
        return;
    }
    let mut harness = harness();
    harness.run_steps(2);
    let path = harness.state().compute_path().to_string();
    assert!(path.starts_with("GPU: "), "{path}");
    // The status bar says it in words.
    harness.get_by_label(&path);
    harness.get_by_label("Strahler");
    harness.get_by_label("Fill terrain");

    // The first fill starts by itself; once done the map holds relief with real range.
    wait_idle(&mut harness);
    let terrain = harness
        .state()
        .terrain()
        .expect("the first fill shows terrain");
    let (lo, hi) = terrain.finite_range().unwrap();
    assert!(lo >= 0.0 && hi <= 620.0 && hi - lo > 300.0, "{lo}..{hi}");
    let status = harness.state().automation().status();
    assert!(status.ready);
    assert_ne!(status.compute, "cpu");
    assert_eq!(status.compute_path, path);
    assert!(status.last_run.is_some());
    harness.get_by_label_contains("Last fill: 512 x 512, multigrid");
    assert!(status.last_run.as_ref().is_some_and(|r| r.converged));
}

#[test]
fn compute_check_reports_agreement() {
    if common::gpu().is_none() {
        return;
    }
    let mut harness = harness();
    wait_idle(&mut harness);
    harness.get_by_label("Compare CPU and GPU").click();
    harness.run_steps(2);
    wait_idle(&mut harness);
    harness.get_by_label_contains("CPU and GPU agree");
}

#[test]
fn fill_can_be_cancelled_and_the_ui_keeps_the_old_terrain() {
    if common::gpu().is_none() {
        return;
    }
    let mut harness = harness();
    wait_idle(&mut harness);
    let before = harness.state().terrain().unwrap().checksum();
    harness.state_mut().settings_mut().multigrid = false;
    harness.state_mut().settings_mut().sweeps = 5_000_000;
    harness.get_by_label("Fill terrain").click();
    harness.run_steps(3);
    assert!(harness.state().busy());
    harness.get_by_label("Cancel").click();
    wait_idle(&mut harness);
    assert_eq!(harness.state().terrain().unwrap().checksum(), before);
}

#[test]
fn solver_switch_shows_the_matching_parameter_and_runs_jacobi() {
    if common::gpu().is_none() {
        return;
    }
    let mut harness = harness();
    wait_idle(&mut harness);
    harness.get_by_label("Tolerance");
    assert!(harness.query_by_label("Sweeps").is_none());
    harness.get_by_label("Jacobi").click();
    harness.run_steps(2);
    harness.get_by_label("Sweeps");
    assert!(!harness.state().settings().multigrid);
    harness.state_mut().settings_mut().sweeps = 40;
    harness.get_by_label("Fill terrain").click();
    harness.run_steps(2);
    wait_idle(&mut harness);
    harness.get_by_label_contains("Jacobi on the");
    harness.get_by_label_contains("40 sweeps");
}
