//! The 3D view inside egui, driven headlessly with egui_kittest on lavapipe: a snapshot of
//! a fixed terrain, and the app's 2D/3D switch, camera API, fly keys and status.

mod common;

use common::app::{wait_idle, wait_until};
use egui_kittest::Harness;
use egui_kittest::kittest::Queryable;
use strahler::app::{CameraRequest, Command, MapsChoice, StrahlerApp, View3d, ViewKind};
use strahler::heightfield::Heightfield;
use strahler::skeleton::RiverPiece;

/// Just the 3D view over an analytic terrain with one river, so the snapshot depends on the
/// renderer alone (not on the generator or on timings).
struct ViewOnly {
    view: View3d,
    field: Heightfield,
    rivers: Vec<RiverPiece>,
    /// Make the rasters on the GPU the view draws with (a context on eframe's device).
    gpu_maps: bool,
    gpu: Option<std::sync::Arc<strahler::gpu::GpuContext>>,
    /// The field on that GPU too, as the pipeline's GPU stages leave it.
    on_gpu: Option<strahler::gpu::GpuField>,
}

impl eframe::App for ViewOnly {
    fn ui(&mut self, ui: &mut egui::Ui, frame: &mut eframe::Frame) {
        egui::CentralPanel::no_frame().show(ui, |ui| {
            let n = self.field.width();
            let cell = 10_000.0 / (n - 1) as f32;
            if self.gpu_maps && self.gpu.is_none() {
                self.gpu = frame.wgpu_render_state().map(|state| {
                    std::sync::Arc::new(strahler::gpu::GpuContext::from_device(
                        &state.adapter,
                        &state.device,
                        &state.queue,
                    ))
                });
                self.on_gpu = self.gpu.as_ref().map(|gpu| {
                    use wgpu::util::DeviceExt;
                    let buffer = gpu
                        .device
                        .create_buffer_init(&wgpu::util::BufferInitDescriptor {
                            label: Some("test terrain"),
                            contents: bytemuck::cast_slice(self.field.data()),
                            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
                        });
                    strahler::gpu::GpuField::new(gpu, buffer, n, n)
                });
            }
            self.view.show(
                ui,
                frame,
                Some((&self.field, 1)),
                self.on_gpu.as_ref(),
                Some((&self.rivers, n)),
                cell,
                self.gpu.as_ref(),
            );
        });
    }
}

fn valley(n: usize) -> (Heightfield, Vec<RiverPiece>) {
    let data = (0..n * n)
        .map(|i| {
            let (x, y) = ((i % n) as f32 / n as f32, (i / n) as f32 / n as f32);
            let across = (x - 0.5 - 0.08 * (7.0 * y).sin()).abs();
            900.0 * across + 250.0 * (9.0 * x).sin() * (6.0 * y).cos() + 600.0 * (1.0 - y)
        })
        .collect();
    // The valley's floor as a river course, a piece a row.
    let floor = |y: usize| {
        [
            (0.5 + 0.08 * (7.0 * y as f32 / n as f32).sin()) * n as f32,
            y as f32,
        ]
    };
    let rivers = (1..n)
        .map(|y| RiverPiece {
            a: floor(y - 1),
            b: floor(y),
            order: 3,
        })
        .collect();
    (Heightfield::from_vec(n, n, data).unwrap(), rivers)
}

/// The widget over [`valley`], its maps made on the CPU or on its GPU.
fn view_only(gpu_maps: bool) -> Harness<'static, ViewOnly> {
    let (field, rivers) = valley(257);
    Harness::builder()
        .with_size(egui::vec2(480.0, 320.0))
        .wgpu()
        .build_eframe(move |_| ViewOnly {
            view: View3d::with_settings(strahler::view3d::View3dSettings {
                snow: true,
                ..Default::default()
            }),
            field,
            rivers,
            gpu_maps,
            gpu: None,
            on_gpu: None,
        })
}

#[test]
fn snapshot_of_the_3d_view() {
    if common::gpu().is_none() {
        return;
    }
    let mut harness = view_only(false);
    // The terrain's textures are prepared in a background job.
    wait_until(&mut harness, "a 3D frame", |h| {
        h.state().view.status().is_some()
    });
    harness.run_steps(2);
    let status = harness.state().view.status().expect("a frame was drawn");
    assert!(status.triangles > 0 && status.chunks > 0, "{status:?}");
    assert_eq!(status.maps, "cpu", "{status:?}");
    // lavapipe renders the same pixels run to run; a few may differ across Mesa versions.
    harness.snapshot_options(
        "view3d",
        &egui_kittest::SnapshotOptions::new().max_failed_pixels(200),
    );
}

fn app() -> Harness<'static, StrahlerApp> {
    common::app::harness(1200.0, 800.0)
}

#[test]
fn the_app_switches_to_3d_and_the_camera_drives_the_level_of_detail() {
    if common::gpu().is_none() {
        return;
    }
    let mut harness = app();
    wait_idle(&mut harness);
    assert_eq!(harness.state().view(), ViewKind::Map);
    harness.get_by_label("3D view (3)").click();
    wait_until(&mut harness, "a 3D frame", |h| {
        h.state().view3d_status().is_some()
    });
    assert_eq!(harness.state().view(), ViewKind::ThreeD);
    assert_eq!(harness.state().automation().status().view, "3d");
    harness.get_by_label("Reset view (Home)");
    let first = harness
        .state()
        .view3d_status()
        .expect("the 3D view drew a frame");
    assert!(first.triangles > 0 && first.mode == "orbit", "{first:?}");

    // Scripts move the camera: near the ground many more triangles than 3 map widths away.
    let camera = |harness: &mut Harness<'static, StrahlerApp>, distance: f32, pitch: f32| {
        harness
            .state()
            .automation()
            .push(Command::SetCamera(CameraRequest {
                distance: Some(distance),
                yaw: Some(30.0),
                pitch: Some(pitch),
            }));
        harness.run_steps(3);
        harness.state().view3d_status().unwrap()
    };
    let near = camera(&mut harness, 0.05, 20.0);
    let far = camera(&mut harness, 3.0, 35.0);
    assert!((far.distance - 3.0).abs() < 1e-3 && (far.yaw - 30.0).abs() < 1e-3);
    assert!(near.triangles >= 2 * far.triangles, "{near:?} {far:?}");

    // F flies; W moves forward (letters fly here instead of picking map tools).
    harness.state_mut().set_tool(strahler::app::Tool::Pan);
    harness.key_press(egui::Key::F);
    harness.run_steps(2);
    assert_eq!(harness.state().view3d_status().unwrap().mode, "fly");
    harness.key_press(egui::Key::S);
    harness.key_press(egui::Key::D);
    harness.run_steps(2);
    assert_eq!(harness.state().tool(), strahler::app::Tool::Pan);
    // Scripts choose where the rasters are made: on the app's GPU (lavapipe here, which
    // `auto` leaves to the CPU), then on the CPU again; each move prepares them anew.
    let maps_now = |h: &Harness<'static, StrahlerApp>| h.state().view3d_status().unwrap().maps;
    assert_eq!(maps_now(&harness), "cpu");
    let on_gpu = harness.state().compute_path().gpu().is_some();
    // CI's lavapipe computes: the GPU half must run there.
    if !on_gpu {
        strahler::gpu::skip::no_adapter(&harness.state().compute_path());
    }
    if on_gpu {
        for (choice, expected) in [(MapsChoice::Gpu, "gpu"), (MapsChoice::Cpu, "cpu")] {
            harness
                .state()
                .automation()
                .push(Command::View3dMaps(choice));
            let what = format!("3D maps made on the {expected}");
            wait_until(&mut harness, &what, |h| maps_now(h) == expected);
        }
    }
    // 2 goes back to the map.
    harness.key_press(egui::Key::Num2);
    harness.run_steps(2);
    assert_eq!(harness.state().view(), ViewKind::Map);
}

/// The widget with its maps made on the GPU it draws with (`view3d::gpu_maps`, as the page
/// does on a hardware GPU): the same picture as the CPU's snapshot, up to the rasters'
/// rounding on a few pixels.
#[test]
fn the_3d_view_draws_maps_made_on_its_gpu() {
    if common::gpu().is_none() {
        return;
    }
    let mut harness = view_only(true);
    wait_until(&mut harness, "a 3D frame", |h| {
        h.state().view.status().is_some()
    });
    harness.run_steps(2);
    assert!(
        harness.state().gpu.is_some(),
        "a context on the view's device"
    );
    let status = harness.state().view.status().expect("a frame was drawn");
    assert_eq!(status.maps, "gpu", "{status:?}");
    harness.snapshot_options(
        "view3d",
        &egui_kittest::SnapshotOptions::new().max_failed_pixels(400),
    );
}
