//! The scene parser (`Scene::from_json`, what `strahler generate`, the app's Open and the page's
//! `loadScene` read), and the whole pipeline on every scene it accepts, at a small size.
#![no_main]

use libfuzzer_sys::fuzz_target;
use strahler::compute::Backend;
use strahler::jobs::JobCtx;
use strahler::pipeline::{Pipeline, RunOptions};
use strahler::scene::Scene;

/// Cells per side the accepted scenes are generated at: small enough for thousands of runs,
/// large enough for every stage (rivers, ridges, skeleton, diffusion levels, erosion, detail).
const SIZE: usize = 33;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let Ok(scene) = Scene::from_json(text) else {
        return;
    };
    // What an accepted scene promises: it writes back to JSON that reads as the same scene
    // (autosave and Save rely on this), and every stage runs on it without panicking.
    let again = Scene::from_json(&scene.to_json()).expect("a saved scene reads back");
    assert_eq!(again, scene, "a scene changes when saved and read back");
    let options = RunOptions {
        size: SIZE,
        realism: false,
        ..RunOptions::for_scene(&scene)
    };
    let (mut pipeline, ctx) = (Pipeline::new(), JobCtx::detached());
    if let Ok(output) = pollster::block_on(pipeline.run(&scene, &options, &Backend::Cpu, &ctx)) {
        let terrain = &output.field;
        assert!(terrain.width() >= SIZE && terrain.height() >= 1);
        assert!(
            terrain.data().iter().all(|h| h.is_finite()),
            "non-finite heights"
        );
    }
});
