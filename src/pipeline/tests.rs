//! The pipeline: every stage chained, the cache recomputing only what an edit touched, and
//! pinned checksums of small scenes (the same bits natively, in the browser and on the
//! command line; `tests/cli.rs` and `web/tests/browser.mjs` pin the same values).

use super::*;
use crate::blend::BlendBlock;
use crate::scene::{DetailSettings, RiverStroke, SketchLine, SketchPeak};
use crate::wavelet::{Brush, Mask};

fn river(estuary: [f64; 2], toward: [f64; 2], phi: u32, depth: u32) -> RiverStroke {
    RiverStroke {
        estuary,
        toward,
        phi,
        depth,
    }
}

/// A small scene with sketched ridges, valleys and peaks.
pub fn sketch_scene() -> Scene {
    let mut scene = Scene {
        size: 96,
        seed: 7,
        rivers: vec![river([0.5, 1.0], [0.45, 0.4], 3, 6)],
        ..Scene::default()
    };
    scene.sketch.ridges.push(SketchLine {
        points: vec![[0.1, 0.2], [0.3, 0.1]],
        height: None,
        heights: None,
    });
    scene.sketch.valleys.push(SketchLine {
        points: vec![[0.8, 0.7], [0.9, 0.4]],
        height: None,
        heights: None,
    });
    scene.sketch.peaks.push(SketchPeak {
        at: [0.2, 0.6],
        height: Some(600.0),
    });
    scene.params.noise.octaves = 4;
    scene.params.noise.roughness = 0.6;
    scene
}

/// A small scene with two detail levels and a painted mask.
pub fn detail_scene() -> Scene {
    let mut scene = Scene {
        size: 64,
        seed: 3,
        rivers: vec![river([0.0, 0.5], [0.6, 0.5], 2, 6)],
        ..Scene::default()
    };
    let mut mask = Mask::new(64, 64).unwrap();
    mask.paint_segment(
        glam::DVec2::new(0.2, 0.2),
        glam::DVec2::new(0.8, 0.3),
        &Brush {
            radius: 6.0,
            ..Brush::default()
        },
    );
    scene.detail = DetailSettings {
        levels: 2,
        scope: "local".into(),
        window: 3,
        mask_png: None,
    };
    scene.detail.set_mask(Some(&mask));
    scene
}

/// A small scene with a block of (synthetic) real terrain blended in.
pub fn block_scene() -> Scene {
    let mut scene = Scene {
        size: 64,
        seed: 5,
        rivers: vec![river([1.0, 0.3], [0.5, 0.4], 3, 5)],
        ..Scene::default()
    };
    let reference = crate::wavelet::fbm::diamond_square(24, 24, 0.8, 11).unwrap();
    let scaled: Vec<f32> = reference.data().iter().map(|v| v * 200.0).collect();
    let reference = Heightfield::from_vec(24, 24, scaled).unwrap();
    scene
        .blend
        .push(BlendBlock::new("dunes", &reference, [0.1, 0.5, 0.45, 0.9]).unwrap());
    scene
}

/// Plateau country: the mesas terrain type, its beds of hard and soft rock on a 6.4 km map
/// (the beds are in metres; on a map this wide the land crosses several).
/// The default river with meanders at 80 degrees, 20 channel widths a wave: large enough
/// (384^2) that the trunk's lower links draw their loops (the sine-generated curve, `libm`'s
/// Bessel function and trigonometry, the same bits in the browser).
pub fn meanders_scene() -> Scene {
    let mut scene = Scene {
        size: 384,
        seed: 13,
        rivers: vec![river([0.5, 1.0], [0.5, 0.35], 3, 5)],
        ..Scene::default()
    };
    scene.params.meanders = crate::river::hydraulic::Meanders {
        angle_deg: 80.0,
        wavelength_widths: 20.0,
    };
    scene
}

pub fn mesas_scene() -> Scene {
    Scene {
        size: 64,
        cell_size: 100.0,
        seed: 11,
        rivers: vec![
            river([0.5, 1.0], [0.5, 0.3], 3, 6),
            river([0.0, 0.2], [0.4, 0.3], 2, 5),
        ],
        erosion: crate::erosion::ErosionSettings::preset("mesas"),
        ..Scene::default()
    }
}

fn run(pipeline: &mut Pipeline, scene: &Scene) -> Output {
    pollster::block_on(pipeline.run(
        scene,
        &RunOptions::for_scene(scene),
        &Backend::Cpu,
        &JobCtx::detached(),
    ))
    .unwrap()
}

#[test]
fn every_stage_runs_and_a_later_stage_changes_the_terrain() {
    let scene = detail_scene();
    let out = run(&mut Pipeline::new(), &scene);
    assert_eq!(out.computed, ["hydrology", "erosion", "detail"]);
    // 64 cells become 2 * 64 - 1 = 127, then 253.
    assert_eq!(out.field.width(), 253);
    assert_eq!(out.report.terrain.size, 253);
    let mut plain = scene.clone();
    plain.detail = DetailSettings::default();
    let without = run(&mut Pipeline::new(), &plain);
    assert_ne!(out.report.terrain.checksum, without.report.terrain.checksum);
    // The hydrology is the same with and without detail.
    assert_eq!(
        out.report.hydrology_checksum,
        without.report.hydrology_checksum
    );
    let d = out.report.detail.as_ref().unwrap();
    assert!(d.rms_unmasked > 0.0);
    assert!(d.rms_masked.is_some_and(|m| m < d.rms_unmasked), "{d:?}");
}

/// Whether `pipeline` has the terrain (hydrology and erosion) of `scene` at its own size.
fn has_terrain(pipeline: &Pipeline, scene: &Scene) -> bool {
    pipeline.has_terrain_for(scene, &RunOptions::for_scene(scene), &Backend::Cpu)
}

#[test]
fn an_edit_recomputes_only_the_stages_it_touched() {
    let mut scene = block_scene();
    scene.detail.levels = 1;
    let mut pipeline = Pipeline::new();
    assert!(!has_terrain(&pipeline, &scene));
    let first = run(&mut pipeline, &scene);
    assert!(has_terrain(&pipeline, &scene));
    assert_eq!(first.computed, ["hydrology", "erosion", "detail", "blend"]);

    // Nothing changed: nothing recomputed, the same outputs shared.
    let again = run(&mut pipeline, &scene);
    assert!(again.computed.is_empty());
    assert!(Arc::ptr_eq(&again.field, &first.field));
    assert!(Arc::ptr_eq(&again.hydrology, &first.hydrology));

    // A block moved: only the blend.
    scene.blend[0].rect = [0.2, 0.5, 0.55, 0.9];
    let moved = run(&mut pipeline, &scene);
    assert_eq!(moved.computed, ["blend"]);
    assert_ne!(moved.report.terrain.checksum, first.report.terrain.checksum);

    // A mask stroke: detail and what follows.
    let mut mask = Mask::new(64, 64).unwrap();
    mask.paint_segment(
        glam::DVec2::new(0.5, 0.1),
        glam::DVec2::new(0.5, 0.9),
        &Brush::default(),
    );
    scene.detail.set_mask(Some(&mask));
    assert!(
        has_terrain(&pipeline, &scene),
        "the terrain is before the mask"
    );
    assert_eq!(run(&mut pipeline, &scene).computed, ["detail", "blend"]);

    // An erosion parameter: erosion and what follows.
    if let Some(e) = scene.erosion.as_mut() {
        e.diffusivity *= 2.0;
    }
    assert!(!has_terrain(&pipeline, &scene), "the erosion is part of it");
    assert_eq!(
        run(&mut pipeline, &scene).computed,
        ["erosion", "detail", "blend"]
    );

    // A river edit: everything.
    scene.rivers[0].phi = 2;
    assert!(!has_terrain(&pipeline, &scene));
    assert_eq!(
        run(&mut pipeline, &scene).computed,
        ["hydrology", "erosion", "detail", "blend"]
    );

    // Erosion turned off: the later stages start from the hydrology again.
    scene.erosion = None;
    assert_eq!(run(&mut pipeline, &scene).computed, ["detail", "blend"]);
}

#[test]
fn preview_and_full_size_keep_their_own_stages() {
    let scene = sketch_scene();
    let mut pipeline = Pipeline::new();
    let preview = RunOptions {
        size: 48,
        ..RunOptions::for_scene(&scene)
    };
    let full = RunOptions::for_scene(&scene);
    let go = |p: &mut Pipeline, o: &RunOptions| {
        pollster::block_on(p.run(&scene, o, &Backend::Cpu, &JobCtx::detached())).unwrap()
    };
    assert_eq!(
        go(&mut pipeline, &preview).computed,
        ["hydrology", "erosion"]
    );
    assert_eq!(go(&mut pipeline, &full).computed, ["hydrology", "erosion"]);
    let small = go(&mut pipeline, &preview);
    assert!(small.computed.is_empty(), "the preview's stages were kept");
    assert_eq!(small.field.width(), 48);
    // The preview keeps the map's width: its cells are larger.
    assert!((small.cell_m - scene.map_width() / 48.0).abs() < 1e-9);
}

/// The golden scenes, as `tests/data/scenes/` holds them (made by [`write_golden_scenes`]).
fn golden_scenes() -> [(&'static str, Scene); 5] {
    let read = |text: &str| Scene::from_json(text).unwrap();
    [
        (
            "sketch",
            read(include_str!("../../tests/data/scenes/sketch.json")),
        ),
        (
            "detail",
            read(include_str!("../../tests/data/scenes/detail.json")),
        ),
        (
            "block",
            read(include_str!("../../tests/data/scenes/block.json")),
        ),
        (
            "mesas",
            read(include_str!("../../tests/data/scenes/mesas.json")),
        ),
        (
            "meanders",
            read(include_str!("../../tests/data/scenes/meanders.json")),
        ),
    ]
}

/// Golden checksums: the terrain's bits are promised to be the same natively, in the browser
/// and for `strahler generate` (`tests/cli.rs` and `web/tests/browser.mjs` check the same
/// values from `tests/data/scenes/checksums.json`). A change here is a change of every user's
/// terrain: update that file with it, and say so.
#[test]
fn golden_scenes_have_pinned_checksums() {
    let pinned: std::collections::BTreeMap<String, String> =
        serde_json::from_str(include_str!("../../tests/data/scenes/checksums.json")).unwrap();
    for (name, scene) in golden_scenes() {
        let out = run(&mut Pipeline::new(), &scene);
        assert_eq!(
            Some(&out.report.terrain.checksum),
            pinned.get(name),
            "scene {name}"
        );
    }
    // The mesas' beds are in play: without them the same scene is another terrain.
    let mut flat_rock = mesas_scene();
    if let Some(e) = flat_rock.erosion.as_mut() {
        e.strata_m = 0.0;
    }
    assert_ne!(
        run(&mut Pipeline::new(), &flat_rock)
            .report
            .terrain
            .checksum,
        run(&mut Pipeline::new(), &mesas_scene())
            .report
            .terrain
            .checksum
    );
}

/// A scene with every field away from its default (`tests/app_ui.rs` round-trips it through
/// the app).
fn every_field_scene() -> Scene {
    let mut scene = block_scene();
    let detail = detail_scene().detail;
    scene.size = 80;
    scene.cell_size = 25.0;
    scene.vertical_scale = 1.5;
    scene.seed = 42;
    scene.rivers.push(river([0.0, 0.9], [0.3, 0.8], 2, 4));
    scene.sketch = sketch_scene().sketch;
    scene.params.theta = 35.0;
    scene.params.river_slope = 0.02;
    scene.params.wander = 0.12;
    scene.params.meanders = crate::river::hydraulic::Meanders {
        angle_deg: 60.0,
        wavelength_widths: 14.0,
    };
    scene.params.alpha = 0.2;
    scene.params.noise.amplitude = 30.0;
    scene.params.noise.octaves = 5;
    scene.params.noise.roughness = 0.6;
    scene.params.enrich.passes = 3;
    scene.params.enrich.distance_limit = 4;
    scene.params.enrich.distance_rule = crate::skeleton::enrich::DistanceRule::Points;
    scene.params.post.smooth_sigma = 0.5;
    scene.params.post.fbm_amplitude = 2.0;
    scene.params.post.fbm_octaves = 3;
    scene.location = Some(crate::scene::Location {
        lat: 45.9,
        lon: 6.9,
    });
    scene.textures = crate::scene::TextureRules {
        rock_slope_deg: 40.0,
        snow_above: 0.7,
        sediment_area_m2: 500000.0,
        softness: 0.2,
    };
    scene.detail = DetailSettings {
        levels: 1,
        window: 5,
        ..detail
    };
    let mut erosion = crate::erosion::ErosionSettings::preset("badlands").unwrap();
    erosion.steps = 3;
    erosion.river_band = 2;
    erosion.rock_contrast = 3.0;
    erosion.rock_patch_m = 700.0;
    erosion.strata_m = 90.0;
    erosion.strata_contrast = 5.0;
    erosion.strength_spread = 0.45;
    erosion.uplift_contrast = 3.0;
    erosion.uplift_scale_m = 12_000.0;
    erosion.relief = crate::erosion::Relief::Physics;
    erosion.border = crate::erosion::Border::Closed;
    scene.erosion = Some(erosion);
    let mut painted = Mask::new(16, 16).unwrap();
    painted.paint_segment(
        glam::DVec2::new(0.2, 0.2),
        glam::DVec2::new(0.7, 0.4),
        &Brush::default(),
    );
    scene.set_mask(crate::scene::MaskKind::Uplift, Some(&painted));
    scene.set_mask(crate::scene::MaskKind::HardRock, Some(&painted));
    scene.style = Some(crate::scene::StyleSettings {
        strength: 0.5,
        ..crate::scene::StyleSettings::bundled("lowland").unwrap()
    });
    scene
}

/// The style stage sits between erosion and detail: changing it re-runs it and what
/// follows, and it keeps every river cell's height and the drainage along the rivers.
#[test]
fn the_style_stage_adds_detail_and_keeps_the_rivers() {
    let mut scene = detail_scene();
    scene.style = crate::scene::StyleSettings::bundled("lowland");
    let mut pipeline = Pipeline::new();
    let out = run(&mut pipeline, &scene);
    assert_eq!(out.computed, ["hydrology", "erosion", "style", "detail"]);
    let styled = out.style.as_ref().unwrap();
    assert!(styled.stats.added_rms > 0.0, "{:?}", styled.stats);
    let before = out.erosion.as_ref().unwrap().field.clone();
    for (i, kind) in out.hydrology.skeleton.kinds.iter().enumerate() {
        if *kind == crate::skeleton::CellKind::River {
            assert_eq!(styled.field.data()[i], before.data()[i]);
        }
    }
    assert!(
        styled.drainage.river_fraction >= 0.99,
        "{:?}",
        styled.drainage
    );
    assert_eq!(styled.drainage.pit_cells, 0);
    if let Some(style) = scene.style.as_mut() {
        style.strength = 0.5;
    }
    assert_eq!(run(&mut pipeline, &scene).computed, ["style", "detail"]);
}

/// The golden scenes are the files; this writes them from the constructors above (run by
/// hand with `--ignored` when a scene is changed on purpose).
#[test]
#[ignore]
fn write_golden_scenes() {
    let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/data/scenes");
    std::fs::create_dir_all(dir).unwrap();
    let mut sums = std::collections::BTreeMap::new();
    for (name, scene) in [
        ("sketch", sketch_scene()),
        ("detail", detail_scene()),
        ("block", block_scene()),
        ("mesas", mesas_scene()),
        ("meanders", meanders_scene()),
    ] {
        std::fs::write(format!("{dir}/{name}.json"), scene.to_json()).unwrap();
        let out = run(&mut Pipeline::new(), &scene);
        sums.insert(name, out.report.terrain.checksum);
    }
    std::fs::write(
        format!("{dir}/every_field.json"),
        every_field_scene().to_json(),
    )
    .unwrap();
    let text = serde_json::to_string_pretty(&sums).unwrap();
    std::fs::write(format!("{dir}/checksums.json"), text + "\n").unwrap();
}

/// One bar per run: the stages fill their spans of it in order (the bar is past the
/// terrain's share whenever erosion reports, past both when the report is measured), and it
/// never moves back while the run goes on.
#[cfg(not(target_arch = "wasm32"))]
#[test]
fn a_run_fills_one_bar_in_stage_order() {
    use std::sync::atomic::{AtomicBool, Ordering};
    let scene = Scene {
        size: 128,
        rivers: vec![river([0.5, 1.0], [0.5, 0.35], 3, 5)],
        ..Scene::default()
    };
    let options = RunOptions {
        realism: true,
        ..RunOptions::for_scene(&scene)
    };
    let ctx = JobCtx::detached();
    let done = AtomicBool::new(false);
    let samples = std::thread::scope(|scope| {
        let watcher = scope.spawn(|| {
            let mut samples = Vec::new();
            while !done.load(Ordering::Relaxed) {
                // The message first: a stage stores its progress before its message.
                let message = ctx.message();
                samples.push((ctx.progress(), message));
                std::thread::sleep(std::time::Duration::from_micros(200));
            }
            samples
        });
        let mut pipeline = Pipeline::new();
        let run = pipeline.run(&scene, &options, &Backend::Cpu, &ctx);
        let result = pollster::block_on(run);
        done.store(true, Ordering::Relaxed);
        result.expect("the pipeline runs");
        watcher.join().expect("the watcher ends")
    });
    let spans = bar_spans(&scene, &options);
    let (erosion, report) = (spans[Bar::Erosion as usize], spans[Bar::Report as usize]);
    assert!(
        erosion.1 - erosion.0 > 0.5,
        "erosion is most of a run: {spans:?}"
    );
    let mut eroding = 0;
    for pair in samples.windows(2) {
        assert!(pair[1].0 >= pair[0].0, "the bar moved back: {pair:?}");
    }
    for (progress, message) in &samples {
        if message.starts_with("eroding") {
            eroding += 1;
            assert!(*progress >= erosion.0, "{progress} {message}");
        }
        if message.starts_with("measuring realism") {
            assert!(*progress >= report.0, "{progress} {message}");
        }
    }
    assert!(eroding > 0, "the watcher saw the erosion");
    assert_eq!(ctx.progress(), 1.0, "a finished run fills the bar");
}

/// Painted hard rock across a drawn river narrows its valley floor (a floor's half-width goes
/// as the square root of the erodibility, `erosion::floodplain`): in the rows under the
/// paint, under half as many cells lie within the floor's few metres above the river as in
/// the same rows unpainted; rows far from the paint keep their floor.
#[test]
fn painted_hard_rock_narrows_a_rivers_floor() {
    let n = 192;
    let mut scene = Scene {
        size: n,
        cell_size: 100.0,
        seed: 3,
        rivers: vec![river([0.5, 1.0], [0.5, 0.0], 2, 4)],
        ..Scene::default()
    };
    if let Some(erosion) = scene.erosion.as_mut() {
        erosion.rock_contrast = 1.0;
    }
    let mut pipeline = Pipeline::new();
    let plain = run(&mut pipeline, &scene);
    let mut mask = Mask::new(n, n).unwrap();
    let brush = Brush {
        radius: 24.0,
        hardness: 1.0,
        value: 1.0,
        eraser: false,
    };
    mask.paint_segment(
        glam::DVec2::new(0.0, 0.7),
        glam::DVec2::new(1.0, 0.7),
        &brush,
    );
    let mut painted = scene.clone();
    painted.set_mask(crate::scene::MaskKind::HardRock, Some(&mask));
    let hard = run(&mut pipeline, &painted);
    let values = mask.values();
    let covered = |y: usize| (0..n).all(|x| values[y * n + x] > 0.99);
    let bare = |y: usize| (0..n).all(|x| values[y * n + x] == 0.0);
    // Cells standing less than 15 m above their row's lowest (the river): its floor.
    let low = |z: &[f32], rows: &[usize]| {
        rows.iter()
            .map(|&y| {
                let row = &z[y * n..(y + 1) * n];
                let river = row.iter().copied().fold(f32::INFINITY, f32::min);
                row.iter().filter(|h| **h - river < 15.0).count()
            })
            .sum::<usize>()
    };
    let under: Vec<usize> = (1..n - 1).filter(|&y| covered(y)).collect();
    let away: Vec<usize> = (n / 8..n / 3).filter(|&y| bare(y)).collect();
    assert!(
        under.len() > 10 && away.len() > 10,
        "{} {}",
        under.len(),
        away.len()
    );
    let (before, after) = (
        low(plain.field.data(), &under),
        low(hard.field.data(), &under),
    );
    // Measured: 222 -> 92; the harder rock alone (its land standing higher, the floor's
    // width as before) gave 186.
    assert!(
        after * 2 <= before,
        "{after} floor cells under the hard rock, {before} without it"
    );
    let (before, after) = (
        low(plain.field.data(), &away),
        low(hard.field.data(), &away),
    );
    assert!(
        after * 10 >= before * 9,
        "{after} floor cells away from the paint, {before} without it"
    );
}

/// Painted hard rock (the scene's `erosion_masks`): a change of the mask re-runs the erosion,
/// not the hydrology; the land under the painted rock stands higher than the same scene's
/// without it, and the mask travels through the scene file.
#[test]
fn painted_hard_rock_stands_higher_and_re_runs_only_the_erosion() {
    // A 9.6 km map: on a map of 2 km the slopes stand at the talus angle whatever the rock.
    let scene = Scene {
        size: 96,
        cell_size: 100.0,
        seed: 4,
        rivers: vec![river([0.5, 1.0], [0.5, 0.2], 3, 6)],
        ..Scene::default()
    };
    let mut pipeline = Pipeline::new();
    let plain = run(&mut pipeline, &scene);
    let mut mask = Mask::new(96, 96).unwrap();
    mask.paint_segment(
        glam::DVec2::new(0.15, 0.3),
        glam::DVec2::new(0.35, 0.7),
        &Brush {
            radius: 12.0,
            hardness: 1.0,
            value: 1.0,
            eraser: false,
        },
    );
    let mut painted = scene.clone();
    painted.set_mask(crate::scene::MaskKind::HardRock, Some(&mask));
    let hard = run(&mut pipeline, &painted);
    assert_eq!(hard.computed, ["erosion"]);
    let values = mask.values();
    let rise = |inside: bool| {
        let cells: Vec<usize> = (0..values.len())
            .filter(|i| {
                if inside {
                    values[*i] > 0.9
                } else {
                    values[*i] == 0.0
                }
            })
            .collect();
        cells
            .iter()
            .map(|i| f64::from(hard.field.data()[*i] - plain.field.data()[*i]))
            .sum::<f64>()
            / cells.len() as f64
    };
    let (under, elsewhere) = (rise(true), rise(false));
    assert!(
        under > 5.0 && under > 5.0 * elsewhere.abs(),
        "{under} m under the hard rock, {elsewhere} m elsewhere"
    );
    let back = Scene::from_json(&painted.to_json()).unwrap();
    assert_eq!(back.erosion_masks, painted.erosion_masks);
    assert!(back.erosion_masks.hard_rock_png.is_some());

    // Painted rock is as strong as the hard units: under the painting the slopes are those
    // of rock with no soft units, where the unpainted land stands gentler on its soft units.
    let mut one_strength = painted.clone();
    if let Some(e) = one_strength.erosion.as_mut() {
        e.soft_rock_strength = 1.0;
    }
    let sound = run(&mut pipeline, &one_strength);
    let mean_slope = |field: &Heightfield, inside: bool| {
        let (n, z) = (96, field.data());
        let (mut sum, mut count) = (0.0, 0);
        for y in 1..n - 1 {
            for x in 1..n - 1 {
                let i = y * n + x;
                if (values[i] > 0.9) != inside || (!inside && values[i] > 0.0) {
                    continue;
                }
                let gx = f64::from(z[i + 1] - z[i - 1]) / 200.0;
                let gy = f64::from(z[i + n] - z[i - n]) / 200.0;
                sum += gx.hypot(gy);
                count += 1;
            }
        }
        sum / f64::from(count)
    };
    let under = mean_slope(&hard.field, true) / mean_slope(&sound.field, true);
    let elsewhere = mean_slope(&hard.field, false) / mean_slope(&sound.field, false);
    assert!(
        under > 0.9 && elsewhere < under - 0.05,
        "mean slope with soft units over without: {under} under the painting, {elsewhere} elsewhere"
    );
}
