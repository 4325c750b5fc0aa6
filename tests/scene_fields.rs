//! Property tests over the scene's numeric fields (issue 33, "Also"): whatever number a
//! scene file holds in any field, it is either refused with a message naming that field, or
//! the terrain it gives is finite everywhere. The same for the numeric flags of `strahler
//! generate`: refused naming the flag, or a finite terrain.

use proptest::prelude::*;
use serde_json::Value;

use strahler::compute::Backend;
use strahler::jobs::JobCtx;
use strahler::scene::Scene;

/// Every numeric field of a scene, by its path in the file.
const FIELDS: &[&str] = &[
    "size",
    "cell_size",
    "vertical_scale",
    "seed",
    "rivers.0.estuary.0",
    "rivers.0.toward.1",
    "rivers.0.phi",
    "rivers.0.depth",
    "params.theta",
    "params.river_slope",
    "params.wander",
    "params.meanders.angle_deg",
    "params.meanders.wavelength_widths",
    "params.alpha",
    "params.noise.amplitude",
    "params.noise.octaves",
    "params.noise.roughness",
    "params.enrich.passes",
    "params.enrich.distance_limit",
    "params.post.smooth_sigma",
    "params.post.fbm_amplitude",
    "params.post.fbm_frequency",
    "params.post.fbm_octaves",
    "params.post.fbm_roughness",
    "params.post.protect",
    "sketch.ridges.0.points.0.0",
    "sketch.valleys.0.points.1.1",
    "sketch.peaks.0.at.0",
    "sketch.peaks.0.height",
    "detail.levels",
    "detail.window",
    "erosion.uplift_m_per_kyr",
    "erosion.erodibility",
    "erosion.m",
    "erosion.n",
    "erosion.diffusivity",
    "erosion.years",
    "erosion.steps",
    "erosion.talus_deg",
    "erosion.river_band",
    "erosion.roughness_m",
    "erosion.rock_contrast",
    "erosion.strength_spread",
    "erosion.soft_rock_strength",
    "erosion.uplift_contrast",
    "erosion.uplift_scale_m",
    "erosion.rock_patch_m",
    "erosion.strata_m",
    "erosion.strata_contrast",
    "style.gamma.1",
    "style.strength",
    "blend.0.rect.2",
    "blend.0.quarter_turns",
    "blend.0.z_scale",
    "blend.0.feather",
    "textures.rock_slope_deg",
    "textures.snow_above",
    "textures.sediment_area_m2",
    "textures.softness",
    "location.lat",
    "location.lon",
];

/// The scene with every field set (shipped with the tests), made small enough to run often.
fn base() -> Value {
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/tests/data/scenes/every_field.json"
    );
    let mut scene: Value = serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap();
    scene["size"] = 24.into();
    scene["detail"]["levels"] = 0.into();
    scene["erosion"]["steps"] = 2.into();
    scene
}

fn slot<'a>(value: &'a mut Value, path: &str) -> &'a mut Value {
    path.split('.')
        .fold(value, |v, key| match key.parse::<usize>() {
            Ok(i) => &mut v[i],
            Err(_) => &mut v[key],
        })
}

/// Numbers a hostile file holds: edges of every range, tiny and huge magnitudes, fractions
/// where whole numbers belong, and ordinary values.
fn number() -> impl Strategy<Value = Value> {
    let special = prop_oneof![
        Just(0.0),
        Just(-0.0),
        Just(-1.0),
        Just(0.5),
        Just(1e-320),
        Just(1e-45),
        Just(3.4e38),
        Just(-3.4e38),
        Just(1e300),
        Just(-1e300),
        Just(1e39),
        Just(4294967296.0),
    ]
    .prop_map(|v: f64| serde_json::json!(v));
    let whole = prop_oneof![Just(u64::MAX), Just(u64::from(u32::MAX) + 1), 0u64..100,]
        .prop_map(|v| serde_json::json!(v));
    let negative = (-1_000_000i64..0).prop_map(|v| serde_json::json!(v));
    let wide = (-30.0f64..30.0).prop_map(|e| serde_json::json!(10f64.powf(e)));
    prop_oneof![special, whole, negative, wide]
}

/// The last name in a field's path (what a message names, whatever its form).
fn leaf(path: &str) -> &str {
    path.split('.')
        .rev()
        .find(|k| k.parse::<usize>().is_err())
        .unwrap_or(path)
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 96, failure_persistence: None, ..ProptestConfig::default() })]

    #[test]
    fn every_scene_number_is_refused_by_name_or_gives_finite_heights(
        field in proptest::sample::select(FIELDS),
        value in number(),
    ) {
        let mut scene = base();
        *slot(&mut scene, field) = value.clone();
        let text = serde_json::to_string(&scene).unwrap();
        match Scene::from_json(&text) {
            Err(err) => {
                let message = err.to_string();
                prop_assert!(
                    message.contains(leaf(field)),
                    "{field} = {value}: the message does not name the field: {message}"
                );
            }
            Ok(parsed) => {
                let out = pollster::block_on(strahler::pipeline::generate(
                    &parsed,
                    &Backend::Cpu,
                    &JobCtx::detached(),
                ));
                match out {
                    Ok(out) => {
                        let bad = out.field.data().iter().filter(|v| !v.is_finite()).count();
                        prop_assert_eq!(bad, 0, "{} = {}: {} heights are not finite", field, value, bad);
                    }
                    Err(err) => {
                        let message = err.to_string();
                        prop_assert!(
                            message.contains(leaf(field)),
                            "{field} = {value} was accepted, then the run failed: {message}"
                        );
                    }
                }
            }
        }
    }
}

fn strahler(args: &[String]) -> std::process::Output {
    std::process::Command::new(env!("CARGO_BIN_EXE_strahler"))
        .args(args)
        .output()
        .expect("the binary runs")
}

/// The numeric flags of `generate`, with a small map so each case runs in a moment.
const FLAGS: &[&str] = &[
    "--size",
    "--map-width",
    "--seed",
    "--theta",
    "--slope",
    "--wander",
    "--meander",
    "--meander-wavelength",
    "--alpha",
];

proptest! {
    #![proptest_config(ProptestConfig { cases: 24, failure_persistence: None, ..ProptestConfig::default() })]

    #[test]
    fn every_generate_flag_is_refused_by_name_or_gives_finite_heights(
        flag in proptest::sample::select(FLAGS),
        value in number(),
    ) {
        let dir = std::path::Path::new(env!("CARGO_TARGET_TMPDIR")).join("flags");
        std::fs::create_dir_all(&dir).unwrap();
        let out = dir.join("t.tif");
        let _ = std::fs::remove_file(&out);
        let text = value.to_string();
        let mut args: Vec<String> = ["generate", "--backend", "cpu", "--erosion", "none"]
            .iter()
            .map(|s| s.to_string())
            .collect();
        if flag != "--size" {
            args.extend(["--size".into(), "24".into()]);
        }
        args.extend([flag.to_string(), text.clone(), "--out".into(), out.display().to_string()]);
        let run = strahler(&args);
        let err = String::from_utf8_lossy(&run.stderr);
        if run.status.success() {
            let bytes = std::fs::read(&out).unwrap();
            let dem = strahler::dem::geotiff::read(&bytes, Default::default()).unwrap();
            prop_assert!(dem.field.data().iter().all(|v| v.is_finite()), "{} {}", flag, text);
        } else {
            prop_assert!(matches!(run.status.code(), Some(1 | 2)), "{} {}: {}", flag, text, err);
            prop_assert!(
                err.contains(flag) || err.contains(&flag[2..]),
                "{flag} {text}: the message does not name the flag: {err}"
            );
        }
    }
}
