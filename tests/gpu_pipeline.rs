//! The pipeline's GPU stages hand the terrain to each other on the GPU: the hydrology
//! stage's flooded terrain (or the GPU erosion's) goes to the wavelet detail without an
//! upload, the detail's output to the blend, and the blend's (its blocks written over a
//! device copy) to the 3D view.
//! Each copy is its stage's terrain to the bit, and the terrain is the one the stages give
//! from uploads.

mod common;

use std::sync::Arc;

use strahler::blend::BlendBlock;
use strahler::compute::Backend;
use strahler::gpu::{GpuContext, GpuField};
use strahler::heightfield::Heightfield;
use strahler::jobs::JobCtx;
use strahler::pipeline::{Output, Pipeline, RunOptions};
use strahler::scene::{RiverStroke, Scene};

fn bits(field: &Heightfield) -> Vec<u32> {
    field.data().iter().map(|v| v.to_bits()).collect()
}

/// A river, one level of detail and two overlapping blocks of (synthetic) real terrain.
fn scene() -> Scene {
    let mut scene = Scene {
        size: 96,
        seed: 5,
        rivers: vec![RiverStroke {
            estuary: [0.5, 1.0],
            toward: [0.5, 0.4],
            phi: 3,
            depth: 5,
        }],
        erosion: None,
        ..Scene::default()
    };
    scene.detail.levels = 1;
    let reference = strahler::wavelet::fbm::diamond_square(24, 24, 0.8, 11).unwrap();
    let scaled: Vec<f32> = reference.data().iter().map(|v| v * 200.0).collect();
    let reference = Heightfield::from_vec(24, 24, scaled).unwrap();
    for rect in [[0.1, 0.5, 0.45, 0.9], [0.3, 0.6, 0.7, 0.8]] {
        scene
            .blend
            .push(BlendBlock::new("dunes", &reference, rect).unwrap());
    }
    scene
}

fn run(pipeline: &mut Pipeline, scene: &Scene, backend: &Backend) -> Output {
    pollster::block_on(pipeline.run(
        scene,
        &RunOptions::for_scene(scene),
        backend,
        &JobCtx::detached(),
    ))
    .expect("the pipeline runs")
}

fn read(gpu: &GpuContext, field: Option<&GpuField>, stage: &str) -> Heightfield {
    let field = field.unwrap_or_else(|| panic!("{stage}: the terrain stays on the GPU"));
    pollster::block_on(field.read(gpu)).expect("a readback")
}

/// `amplified` (`levels` new levels above `source`) with its interpolation following the
/// source's valleys and crests, as the detail stage ends.
fn following_the_valleys(
    source: &Heightfield,
    levels: u32,
    mut amplified: Heightfield,
) -> Heightfield {
    pollster::block_on(strahler::wavelet::directional::correct_field(
        source,
        levels,
        &mut amplified,
        &JobCtx::detached(),
    ))
    .expect("not cancelled");
    amplified
}

fn mean_difference(a: &Heightfield, b: &Heightfield) -> f64 {
    let sum: f64 = a
        .data()
        .iter()
        .zip(b.data())
        .map(|(x, y)| f64::from(x - y))
        .sum();
    sum / a.data().len() as f64
}

#[test]
fn gpu_stages_hand_the_terrain_on() {
    let Some(gpu) = common::gpu() else { return };
    // Every stage on the GPU (beside lavapipe the flood would be the CPU's, which raises
    // cells after the readback, so the hydrology stage keeps no GPU copy there).
    let gpu = Arc::new(gpu.with_all_stages());
    let backend = Backend::Gpu(gpu.clone());
    let scene = scene();
    let mut pipeline = Pipeline::new();
    let out = run(&mut pipeline, &scene, &backend);
    assert_eq!(out.computed, ["hydrology", "detail", "blend"]);

    // Each stage's GPU copy is its terrain.
    let hydrology = read(&gpu, out.hydrology.gpu.as_ref(), "hydrology");
    assert!(bits(&hydrology) == bits(&out.hydrology.terrain));
    let detail = out.detail.as_ref().expect("a detail stage");
    assert!(bits(&read(&gpu, detail.gpu.as_ref(), "detail")) == bits(&detail.field));
    let blend = out.blend.as_ref().expect("a blend stage");
    assert!(bits(&read(&gpu, blend.gpu.as_ref(), "blend")) == bits(&blend.field));
    assert!(bits(&read(&gpu, out.gpu.as_ref(), "output")) == bits(&out.field));

    // The same terrain as the stages give from the CPU's copies, uploaded.
    let params = scene
        .detail
        .params(strahler::terrain::stage_seed(scene.seed, "detail"));
    let mut uploaded = pollster::block_on(strahler::wavelet::amplify_on(
        &backend,
        &out.hydrology.terrain,
        &params,
        None,
        &JobCtx::detached(),
    ))
    .expect("the detail from an upload");
    let synthesised = uploaded.field.clone();
    uploaded.field =
        following_the_valleys(&out.hydrology.terrain, params.levels, synthesised.clone());
    assert!(bits(&uploaded.field) == bits(&detail.field));
    assert!(
        bits(&synthesised) != bits(&detail.field),
        "the correction moved cells"
    );
    // The stage's RMS, summed on the GPU here, is the CPU's measure of its synthesis (before
    // the interpolation follows the valleys).
    let measured = strahler::wavelet::synthesis::detail_rms(
        &out.hydrology.terrain,
        &synthesised,
        params.levels,
        None,
    );
    assert!(uploaded.rms.is_some(), "the GPU measured the RMS");
    assert!(
        (detail.rms.unmasked - measured.unmasked).abs() <= 1e-3 * measured.unmasked,
        "{:?} against {measured:?}",
        detail.rms
    );
    // And the detail stage reads the copy it is given, not the CPU's: a copy raised by
    // 100 m raises its output by 100 m.
    let raised = common::gpu_copy(&gpu, &out.hydrology.terrain, 100.0);
    let from_raised = pollster::block_on(strahler::wavelet::amplify_from(
        &backend,
        &out.hydrology.terrain,
        Some(&raised),
        &params,
        None,
        &JobCtx::detached(),
    ))
    .expect("the detail from a GPU copy");
    let shift = mean_difference(&from_raised.field, &synthesised);
    assert!((shift - 100.0).abs() < 0.01, "raised by {shift}");
    let mut blended = uploaded.field.clone();
    pollster::block_on(strahler::blend::apply_blocks(
        &backend,
        &mut blended,
        &scene.blend,
        &JobCtx::detached(),
    ))
    .expect("the blocks blend");
    assert!(bits(&blended) == bits(&out.field));
    // The blocks changed the terrain, so the blend's copy is not the detail's.
    assert!(bits(&blended) != bits(&uploaded.field));

    // Moving a block re-runs the blend alone, from the detail's cached GPU copy.
    let mut moved = scene.clone();
    moved.blend[1].rect = [0.35, 0.55, 0.75, 0.75];
    let again = run(&mut pipeline, &moved, &backend);
    assert_eq!(again.computed, ["blend"]);
    assert!(bits(&read(&gpu, again.gpu.as_ref(), "moved block")) == bits(&again.field));
    assert!(bits(&again.field) != bits(&out.field));

    // Erosion on the GPU hands its terrain on too (its solver's flooded heights), and the
    // detail after it reads that copy.
    let mut eroded = scene.clone();
    eroded.erosion = Some(strahler::erosion::ErosionSettings::default());
    let after = run(&mut pipeline, &eroded, &backend);
    let erosion = after.erosion.as_ref().expect("an erosion stage");
    assert_eq!(erosion.report.backend, "gpu");
    assert!(bits(&read(&gpu, erosion.gpu.as_ref(), "erosion")) == bits(&erosion.field));
    let uploaded = pollster::block_on(strahler::wavelet::amplify_on(
        &backend,
        &erosion.field,
        &params,
        None,
        &JobCtx::detached(),
    ))
    .expect("the detail from an upload");
    let detail = after.detail.as_ref().expect("a detail stage");
    let uploaded = following_the_valleys(&erosion.field, params.levels, uploaded.field);
    assert!(bits(&uploaded) == bits(&detail.field));
    assert!(bits(&read(&gpu, after.gpu.as_ref(), "after erosion")) == bits(&after.field));

    // A CPU stage (style) ends the chain: the detail after it uploads the styled terrain and
    // hands its own output on.
    let mut styled = eroded.clone();
    styled.style = strahler::scene::StyleSettings::bundled("mountains");
    let after = run(&mut pipeline, &styled, &backend);
    assert_eq!(after.computed, ["style", "detail", "blend"]);
    assert!(bits(&read(&gpu, after.gpu.as_ref(), "after style")) == bits(&after.field));
}

/// On the CPU no stage keeps a GPU copy.
#[test]
fn cpu_stages_keep_no_gpu_copy() {
    let mut scene = scene();
    scene.erosion = Some(strahler::erosion::ErosionSettings::default());
    let out = run(&mut Pipeline::new(), &scene, &Backend::Cpu);
    assert!(out.hydrology.gpu.is_none());
    assert!(out.erosion.as_ref().is_some_and(|e| e.gpu.is_none()));
    assert!(out.detail.as_ref().is_some_and(|d| d.gpu.is_none()));
    assert!(out.blend.as_ref().is_some_and(|b| b.gpu.is_none()));
    assert!(out.gpu.is_none());
}

/// "Compute on: auto" takes a hardware GPU and the CPU beside a software rasteriser (every
/// stage is slower on one: it runs on the same cores); "gpu" takes any GPU with every stage
/// on it; "cpu" the CPU.
#[test]
fn auto_computes_on_the_cpu_beside_a_software_rasteriser() {
    use strahler::compute::{BackendChoice, ComputePath};
    let Some(gpu) = common::gpu() else {
        return;
    };
    let software = gpu.is_software();
    let path = ComputePath::from_context(gpu);
    let key = |choice: BackendChoice| choice.resolve(&path).unwrap().key();
    assert_eq!(
        key(BackendChoice::Auto),
        if software { "cpu" } else { "gpu" }
    );
    assert_eq!(key(BackendChoice::Gpu), "gpu");
    assert_eq!(key(BackendChoice::Cpu), "cpu");
    match BackendChoice::Gpu.resolve(&path).unwrap() {
        Backend::Gpu(context) => assert!(context.runs_heavy_stages()),
        Backend::Cpu => unreachable!(),
    }
}
