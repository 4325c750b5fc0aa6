//! `window.strahler`: the automation API for browser tests and power users (the egui canvas
//! is opaque to the DOM). Documented in docs/page-api.md. Every function returns plain JSON-like
//! objects; long-running ones return promises.
//!
//! - `status()`: `{version, ready, compute, computePath, adapter, capabilities, job,
//!   lastRun, lastError}`; `compute` is "webgpu" on the GPU path and "cpu" on the fallback.
//! - `selfTest()`: a promise of the CPU/GPU comparison (`diffusion::selftest::SelfTest`).
//! - `scene()`: the current scene (the document, see `crate::scene`).
//! - `worldPlan({size, tile, world, refine, fill})`: the plan of a world in tiles of the
//!   current scene (`crate::world::Plan`, `refine: false` for no refinement of the erosion
//!   per tile, `fill: true` to fill its depressions exactly tile by tile), the file
//!   `strahler build` takes; throws naming a bad option.
//! - `worldPreview({size, tile, world})`: a promise of that plan's global build as a
//!   GeoTIFF (`Uint8Array`): the bytes of `preview.tif`, the whole world at low resolution,
//!   that `strahler build`'s task 0 writes.
//! - `loadScene(obj)`: replaces the scene; throws an `Error` naming the bad field.
//! - `addRiver([x0, y0], [x1, y1], {phi, depth})`: adds a river stroke (map units, estuary
//!   first); throws on invalid values. Both regenerate the terrain.
//! - `maskFromRivers()`, `paintMask([x0, y0], [x1, y1], {radius, hardness, value, eraser,
//!   target})`: `target` "detail" (the default), "uplift" or "hard-rock".
//! - `loadDem(name, bytes)`: uploads a DEM (`Uint8Array`; the format comes from `name`).
//! - `fillVoids()`: harmonic fill of the uploaded DEM's no-data cells.
//! - `placeBlock({window: [row, col, height, width], rect: [x0, y0, x1, y1], quarterTurns,
//!   mirror, zScale})`: blends a window of the DEM into the map; `moveBlock(index, rect)`.
//! - `exportHeightmap(format, {size, flipY, zScale, preset, tiles, maps, rivers, normals})`:
//!   a promise of the terrain on the map as a file's bytes (`Uint8Array`); `format` is png,
//!   tif, r16, r32, exr, asc, hgt or obj. With `preset` ('unreal', 'unity', 'godot', 'gis',
//!   'gaea-wm'), `tiles` (`[columns, rows]`), `maps` (['normal', 'splat', ...]) or `rivers`
//!   (GeoJSON) it is an engine export (`crate::export`): one file as itself, several as a zip.
//! - `undo()`, `redo()`: one step of the document's history.
//! - `generate({size})`: a promise of the report `strahler generate --report` writes, for the
//!   current scene at `size` (the map is not changed).
//! - `setView('2d' | '3d', {maps})`: the map or the 3D view; `maps` ('auto', 'gpu' or
//!   'cpu', 3D only) chooses where the view's rasters are made. `setCamera({distance, yaw,
//!   pitch})`: the 3D orbit camera (distance in map widths, angles in degrees; shows the 3D
//!   view). `status().view3d` then reports `{triangles, chunks, finestLevel, width, height,
//!   mode, distance, yaw, pitch, maps, fromGpuCopy}` of the last frame.

use wasm_bindgen::JsCast;
use wasm_bindgen::prelude::*;

use crate::app::{Automation, Command};
use crate::diffusion::selftest;
use crate::jobs::JobCtx;
use crate::scene::{Edit, RiverStroke, Scene};

/// Builds `window.strahler` around the shared automation state.
pub(super) fn install(automation: &Automation) {
    let Some(window) = web_sys::window() else {
        return;
    };
    let api = js_sys::Object::new();

    install_reports(&api, automation);
    install_edits(&api, automation);
    install_dem(&api, automation);
    install_outputs(&api, automation);
    install_views(&api, automation);
    set(&api, "version", &JsValue::from_str(crate::VERSION));
    set(&window, "strahler", &api);
}

/// The reports: `status`, `selfTest` and `scene`.
fn install_reports(api: &js_sys::Object, automation: &Automation) {
    let status_source = automation.clone();
    let status = Closure::<dyn Fn() -> JsValue>::new(move || {
        let mut status = status_source.status();
        status.memory_bytes = wasm_bindgen::memory()
            .dyn_into::<js_sys::WebAssembly::Memory>()
            .ok()
            .and_then(|m| m.buffer().dyn_into::<js_sys::ArrayBuffer>().ok())
            .map(|b| f64::from(b.byte_length()));
        to_js(&status)
    });
    set(api, "status", status.as_ref());
    status.forget();

    let test_source = automation.clone();
    let self_test = Closure::<dyn Fn() -> js_sys::Promise>::new(move || {
        let automation = test_source.clone();
        wasm_bindgen_futures::future_to_promise(async move {
            let path = automation
                .compute_path()
                .ok_or_else(|| JsValue::from_str("Strahler has not started yet"))?;
            let result = selftest::run(&path, &JobCtx::detached())
                .await
                .map_err(|err| JsValue::from_str(&err.to_string()))?;
            Ok(to_js(&result))
        })
    });
    set(api, "selfTest", self_test.as_ref());
    self_test.forget();

    let scene_source = automation.clone();
    let scene = Closure::<dyn Fn() -> JsValue>::new(move || match scene_source.scene() {
        Some(scene) => to_js(&scene),
        None => JsValue::NULL,
    });
    set(api, "scene", scene.as_ref());
    scene.forget();

    let plan_source = automation.clone();
    let world_plan =
        Closure::<dyn Fn(JsValue) -> Result<JsValue, JsValue>>::new(move |options: JsValue| {
            Ok(to_js(&world_plan_of(&plan_source, &options, "worldPlan")?))
        });
    set(api, "worldPlan", world_plan.as_ref());
    world_plan.forget();

    let preview_source = automation.clone();
    let world_preview =
        Closure::<dyn Fn(JsValue) -> Result<js_sys::Promise, JsValue>>::new(move |options| {
            let plan = world_plan_of(&preview_source, &options, "worldPreview")?;
            Ok(wasm_bindgen_futures::future_to_promise(async move {
                let global = crate::world::task::build_global(&plan, &JobCtx::detached())
                    .await
                    .map_err(|e| error(format!("worldPreview: {e}")))?;
                Ok(js_sys::Uint8Array::from(&global.preview[..]).into())
            }))
        });
    set(api, "worldPreview", world_preview.as_ref());
    world_preview.forget();
}

/// The plan `options` (`{size, tile, world, refine, fill}`) ask for of the scene on the map; `name`
/// (the function's) heads the error naming a bad option.
fn world_plan_of(
    automation: &Automation,
    options: &JsValue,
    name: &str,
) -> Result<crate::world::Plan, JsValue> {
    let scene = automation
        .scene()
        .ok_or_else(|| error("Strahler has not started yet"))?;
    let get = |key: &str| {
        js_sys::Reflect::get(options, &JsValue::from_str(key))
            .map_err(|_| error("options must be an object like {size: 16384}"))
    };
    let number = |key: &str| -> Result<Option<usize>, JsValue> {
        let value = get(key)?;
        match value.as_f64() {
            None if value.is_undefined() => Ok(None),
            Some(v) if v.fract() == 0.0 && (1.0..=1e9).contains(&v) => Ok(Some(v as usize)),
            _ => Err(error(format!(
                "{name}: {key} must be a whole number of cells"
            ))),
        }
    };
    let size = number("size")?.ok_or_else(|| error(format!("{name}: give {{size}}")))?;
    let tile = number("tile")?.unwrap_or(2048);
    let plan = crate::world::Plan::new(&scene, size, tile, number("world")?)
        .map_err(|e| error(format!("{name}: {e}")))?;
    let flag = |key: &str, default: bool| -> Result<bool, JsValue> {
        let value = get(key)?;
        match value.as_bool() {
            Some(on) => Ok(on),
            None if value.is_undefined() => Ok(default),
            None => Err(error(format!("{name}: {key} must be true or false"))),
        }
    };
    let mut plan = plan;
    if !flag("refine", true)? {
        plan = plan.without_refinement();
    }
    if flag("fill", false)? {
        plan = plan.with_fill();
    }
    Ok(plan)
}

/// The scene's edits: `loadScene`, `addRiver`, `maskFromRivers` and `paintMask`.
fn install_edits(api: &js_sys::Object, automation: &Automation) {
    let load_target = automation.clone();
    let load_scene = Closure::<dyn Fn(JsValue) -> Result<js_sys::Promise, JsValue>>::new(
        move |value: JsValue| {
            let scene = Scene::from_json(&json_text(&value)?).map_err(error)?;
            Ok(applied(
                &load_target,
                Command::Edit(Edit::Replace(Box::new(scene))),
            ))
        },
    );
    set(api, "loadScene", load_scene.as_ref());
    load_scene.forget();

    let river_target = automation.clone();
    let add_river =
        Closure::<dyn Fn(JsValue, JsValue, JsValue) -> Result<js_sys::Promise, JsValue>>::new(
            move |from: JsValue, to: JsValue, options: JsValue| {
                let text = format!(
                    r#"{{"version": {}, "rivers": [{{"estuary": {}, "toward": {}{}}}]}}"#,
                    crate::scene::VERSION,
                    json_text(&from)?,
                    json_text(&to)?,
                    river_options(&options)?
                );
                let scene = Scene::from_json(&text).map_err(error)?;
                let river: RiverStroke = scene.rivers[0];
                Ok(applied(&river_target, Command::Edit(Edit::AddRiver(river))))
            },
        );
    set(api, "addRiver", add_river.as_ref());
    add_river.forget();

    let mask_target = automation.clone();
    let mask_from_rivers = Closure::<dyn Fn() -> js_sys::Promise>::new(move || {
        applied(&mask_target, Command::MaskFromRivers)
    });
    set(api, "maskFromRivers", mask_from_rivers.as_ref());
    mask_from_rivers.forget();

    let paint_target = automation.clone();
    let paint_mask =
        Closure::<dyn Fn(JsValue, JsValue, JsValue) -> Result<js_sys::Promise, JsValue>>::new(
            move |from: JsValue, to: JsValue, options: JsValue| {
                let point = |v: &JsValue| -> Result<glam::DVec2, JsValue> {
                    let p: [f64; 2] = serde_json::from_str(&json_text(v)?)
                        .map_err(|_| error("points are [x, y] in map units"))?;
                    if !p.iter().all(|c| c.is_finite()) {
                        return Err(error("points must be finite"));
                    }
                    Ok(glam::DVec2::new(p[0], p[1]))
                };
                let mut brush = crate::wavelet::Brush::default();
                let mut kind = crate::scene::MaskKind::Detail;
                if !(options.is_undefined() || options.is_null()) {
                    if let Some(name) = js_sys::Reflect::get(&options, &JsValue::from_str("target"))
                        .ok()
                        .and_then(|v| v.as_string())
                    {
                        kind = crate::scene::MaskKind::from_name(&name).ok_or_else(|| {
                            error("target is one of \"detail\", \"uplift\", \"hard-rock\"")
                        })?;
                    }
                    let get = |key: &str| {
                        js_sys::Reflect::get(&options, &JsValue::from_str(key))
                            .ok()
                            .and_then(|v| v.as_f64())
                    };
                    if let Some(r) = get("radius") {
                        brush.radius = r as f32;
                    }
                    if let Some(h) = get("hardness") {
                        brush.hardness = h as f32;
                    }
                    if let Some(v) = get("value") {
                        brush.value = v as f32;
                    }
                    brush.eraser = js_sys::Reflect::get(&options, &JsValue::from_str("eraser"))
                        .ok()
                        .and_then(|v| v.as_bool())
                        .unwrap_or(false);
                }
                if !(brush.radius.is_finite()
                    && brush.hardness.is_finite()
                    && brush.value.is_finite())
                {
                    return Err(error("brush values must be finite numbers"));
                }
                let command = Command::PaintMask(kind, point(&from)?, point(&to)?, brush);
                Ok(applied(&paint_target, command))
            },
        );
    set(api, "paintMask", paint_mask.as_ref());
    paint_mask.forget();
}

/// The DEM panel: `loadDem`, `extractFeatures`, `fillVoids`, `placeBlock` and `moveBlock`.
fn install_dem(api: &js_sys::Object, automation: &Automation) {
    let dem_target = automation.clone();
    let load_dem = Closure::<dyn Fn(String, js_sys::Uint8Array) -> js_sys::Promise>::new(
        move |name: String, bytes: js_sys::Uint8Array| {
            let command = Command::LoadDem {
                name,
                bytes: bytes.to_vec(),
            };
            applied(&dem_target, command)
        },
    );
    set(api, "loadDem", load_dem.as_ref());
    load_dem.forget();

    let fill_target = automation.clone();
    let features_target = automation.clone();
    let extract_features = Closure::<dyn Fn() -> js_sys::Promise>::new(move || {
        finished(&features_target, Command::ExtractFeatures)
    });
    set(api, "extractFeatures", extract_features.as_ref());
    extract_features.forget();

    let fill_voids = Closure::<dyn Fn() -> js_sys::Promise>::new(move || {
        finished(&fill_target, Command::FillVoids)
    });
    set(api, "fillVoids", fill_voids.as_ref());
    fill_voids.forget();

    let place_target = automation.clone();
    let place_block = Closure::<dyn Fn(JsValue) -> Result<js_sys::Promise, JsValue>>::new(
        move |options: JsValue| {
            let o: PlaceOptions = serde_json::from_str(&json_text(&options)?).map_err(|e| {
                error(format!(
                    "placeBlock({{window: [row, col, height, width], rect: [x0, y0, x1, y1], \
                     quarterTurns, mirror, zScale, feather}}): {e}"
                ))
            })?;
            let command = Command::PlaceBlock {
                window: o.window,
                rect: o.rect,
                quarter_turns: o.quarter_turns,
                mirror: o.mirror,
                z_scale: o.z_scale,
                feather: o.feather,
            };
            Ok(applied(&place_target, command))
        },
    );
    set(api, "placeBlock", place_block.as_ref());
    place_block.forget();

    let move_target = automation.clone();
    let move_block = Closure::<dyn Fn(u32, JsValue) -> Result<js_sys::Promise, JsValue>>::new(
        move |index: u32, rect: JsValue| {
            let rect: [f64; 4] = serde_json::from_str(&json_text(&rect)?)
                .map_err(|_| error("rect is [x0, y0, x1, y1] in map units"))?;
            let command = Command::Edit(Edit::SetBlockRect {
                index: index as usize,
                rect,
            });
            Ok(applied(&move_target, command))
        },
    );
    set(api, "moveBlock", move_block.as_ref());
    move_block.forget();
}

/// The outputs and the history: `exportHeightmap`, `undo`, `redo` and `generate`.
fn install_outputs(api: &js_sys::Object, automation: &Automation) {
    let export_source = automation.clone();
    let export = Closure::<dyn Fn(String, JsValue) -> js_sys::Promise>::new(
        move |format: String, options: JsValue| {
            let automation = export_source.clone();
            wasm_bindgen_futures::future_to_promise(async move {
                settled(&automation).await;
                let o = export_options(&options)?;
                if o.wants_package() {
                    return package_bytes(&automation, &format, o)
                        .await
                        .map(JsValue::from);
                }
                export_bytes(&automation, &format, &o)
                    .await
                    .map(JsValue::from)
            })
        },
    );
    set(api, "exportHeightmap", export.as_ref());
    export.forget();

    let undo_target = automation.clone();
    let undo =
        Closure::<dyn Fn() -> js_sys::Promise>::new(move || applied(&undo_target, Command::Undo));
    set(api, "undo", undo.as_ref());
    undo.forget();
    let redo_target = automation.clone();
    let redo =
        Closure::<dyn Fn() -> js_sys::Promise>::new(move || applied(&redo_target, Command::Redo));
    set(api, "redo", redo.as_ref());
    redo.forget();

    let generate_source = automation.clone();
    let generate = Closure::<dyn Fn(JsValue) -> js_sys::Promise>::new(move |options: JsValue| {
        let automation = generate_source.clone();
        let size = js_sys::Reflect::get(&options, &JsValue::from_str("size"))
            .ok()
            .and_then(|v| v.as_f64());
        let realism = js_sys::Reflect::get(&options, &JsValue::from_str("realism"))
            .ok()
            .and_then(|v| v.as_bool())
            .unwrap_or(false);
        let choice = js_sys::Reflect::get(&options, &JsValue::from_str("backend"))
            .ok()
            .and_then(|v| v.as_string());
        wasm_bindgen_futures::future_to_promise(async move {
            // 'auto' (the default), 'cpu' or 'gpu' (every stage on the GPU, as the command
            // line's --backend gpu; an error where the page has none).
            let choice: crate::compute::BackendChoice = match choice {
                Some(name) => name.parse().map_err(error)?,
                None => crate::compute::BackendChoice::Auto,
            };
            let path = automation
                .compute_path()
                .ok_or_else(|| error("Strahler has not started yet"))?;
            let mut scene = automation
                .scene()
                .ok_or_else(|| error("Strahler has not started yet"))?;
            if let Some(size) = size {
                // The map keeps its width: a larger size means finer cells.
                let width = scene.map_width();
                scene.size = size as usize;
                scene.cell_size = width / scene.size.max(1) as f64;
            }
            scene.validate().map_err(error)?;
            let backend = choice.resolve(&path).map_err(error)?;
            // The realism measures are one O(cells x 80) pass that cannot yield: only on
            // request ({realism: true}), so a large generation keeps the page responsive.
            let options = crate::pipeline::RunOptions {
                realism,
                ..crate::pipeline::RunOptions::for_scene(&scene)
            };
            let output = crate::pipeline::Pipeline::new()
                .run(&scene, &options, &backend, &JobCtx::detached())
                .await
                .map_err(error)?;
            Ok(to_js(&output.report))
        })
    });
    set(api, "generate", generate.as_ref());
    generate.forget();

    let compute_target = automation.clone();
    let set_compute =
        Closure::<dyn Fn(String) -> Result<js_sys::Promise, JsValue>>::new(move |name: String| {
            // As the Advanced section's "Compute on": 'auto', 'cpu' or 'gpu'; 'gpu' is an
            // error where the page has no GPU that computes (thrown at once once the app has
            // started; before, the app refuses it as it applies it and the promise rejects).
            let choice: crate::compute::BackendChoice = name.parse().map_err(error)?;
            if let Some(path) = compute_target.compute_path() {
                choice.resolve(&path).map_err(error)?;
            }
            Ok(finished(&compute_target, Command::Compute(choice)))
        });
    set(api, "setCompute", set_compute.as_ref());
    set_compute.forget();
}

/// The views: `setView` and `setCamera`.
fn install_views(api: &js_sys::Object, automation: &Automation) {
    let view_target = automation.clone();
    let set_view = Closure::<dyn Fn(String, JsValue) -> Result<js_sys::Promise, JsValue>>::new(
        move |view: String, options: JsValue| {
            let view = match view.as_str() {
                "2d" => crate::app::ViewKind::Map,
                "3d" => crate::app::ViewKind::ThreeD,
                other => return Err(error(format!("setView('2d' | '3d'), not '{other}'"))),
            };
            let o: ViewOptions = if options.is_undefined() || options.is_null() {
                ViewOptions { maps: None }
            } else {
                serde_json::from_str(&json_text(&options)?)
                    .map_err(|e| error(format!("setView options: {e}")))?
            };
            let Some(maps) = o.maps else {
                return Ok(applied(&view_target, Command::SetView(view)));
            };
            if view != crate::app::ViewKind::ThreeD {
                return Err(error("setView options: maps applies to the 3D view ('3d')"));
            }
            let maps = match maps.as_str() {
                "auto" => crate::app::MapsChoice::Auto,
                "gpu" => crate::app::MapsChoice::Gpu,
                "cpu" => crate::app::MapsChoice::Cpu,
                other => {
                    return Err(error(format!(
                        "setView options: maps is 'auto', 'gpu' or 'cpu', not '{other}'"
                    )));
                }
            };
            // As generate({backend: 'gpu'}): an error where the page computes on the CPU.
            if let (
                crate::app::MapsChoice::Gpu,
                Some(crate::compute::ComputePath::Cpu { reason }),
            ) = (maps, view_target.compute_path())
            {
                return Err(error(format!(
                    "setView options: maps 'gpu' needs a GPU that computes, but {reason}"
                )));
            }
            Ok(applied(&view_target, Command::View3dMaps(maps)))
        },
    );
    set(api, "setView", set_view.as_ref());
    set_view.forget();

    let camera_target = automation.clone();
    let set_camera = Closure::<dyn Fn(JsValue) -> Result<js_sys::Promise, JsValue>>::new(
        move |options: JsValue| {
            let o: CameraOptions = serde_json::from_str(&json_text(&options)?).map_err(|e| {
                error(format!(
                    "setCamera({{distance (map widths), yaw, pitch (degrees)}}): {e}"
                ))
            })?;
            let command = Command::SetCamera(crate::app::CameraRequest {
                distance: o.distance,
                yaw: o.yaw,
                pitch: o.pitch,
            });
            Ok(applied(&camera_target, command))
        },
    );
    set(api, "setCamera", set_camera.as_ref());
    set_camera.forget();
}

/// `exportHeightmap`'s options, read strictly (an unknown key is named).
fn export_options(options: &JsValue) -> Result<ExportOptions, JsValue> {
    if options.is_undefined() || options.is_null() {
        return Ok(ExportOptions::default());
    }
    serde_json::from_str(&json_text(options)?).map_err(|e| {
        error(format!(
            "exportHeightmap options {{size, flipY, zScale, preset, tiles, maps, rivers, \
             normals}}: {e}"
        ))
    })
}

fn export_format(format: &str) -> Result<crate::dem::format::Format, JsValue> {
    crate::dem::format::Format::from_key(format).ok_or_else(|| {
        error(format!(
            "unknown format {format:?}: use png, tif, r16, r32, exr, asc, hgt or obj"
        ))
    })
}

/// `exportHeightmap` with a preset, tiles, maps or rivers: the app makes the files of the
/// terrain on the map (`crate::export::files`); one file comes back as itself, several as
/// one zip.
async fn package_bytes(
    automation: &Automation,
    format: &str,
    o: ExportOptions,
) -> Result<js_sys::Uint8Array, JsValue> {
    use crate::export::{Engine, MapKind, NormalConvention, Request};
    let fmt = export_format(format)?;
    let native = automation
        .terrain()
        .map(|(field, _)| field.width())
        .ok_or_else(|| error("there is no terrain yet"))?;
    let mut request = match &o.preset {
        Some(key) => Request::for_engine(
            Engine::from_key(key).ok_or_else(|| {
                error(format!(
                    "unknown preset {key:?}: use unreal, unity, godot, gis or gaea-wm"
                ))
            })?,
            native,
        ),
        None => Request::heightmap(fmt),
    };
    request.format = fmt;
    if o.size.is_some() {
        request.size = o.size;
    }
    request.flip_y |= o.flip_y;
    request.z_scale =
        o.z_scale.unwrap_or(1.0) * automation.scene().map_or(1.0, |s| s.vertical_scale as f32);
    request.tiles = o.tiles;
    request.rivers = o.rivers;
    for key in &o.maps {
        request.maps.push(MapKind::from_key(key).ok_or_else(|| {
            error(format!(
                "unknown map {key:?}: use normal, slope, curvature, flow, erosion, water, splat or basins"
            ))
        })?);
    }
    match o.normals.as_deref() {
        None => {}
        Some("gl") => request.normals = NormalConvention::OpenGl,
        Some("dx") => request.normals = NormalConvention::DirectX,
        Some(other) => return Err(error(format!("normals are 'gl' or 'dx', got {other:?}"))),
    }
    let number = automation.push(Command::Export(Box::new(request)));
    loop {
        if let Some(result) = automation.take_export(number) {
            let bytes = result.map_err(error)?;
            return Ok(js_sys::Uint8Array::from(bytes.as_slice()));
        }
        sleep(10).await;
    }
}

/// `exportHeightmap`'s work: the terrain on the map encoded as `format`, yielding to the
/// page after each slice of rows.
async fn export_bytes(
    export_source: &Automation,
    format: &str,
    o: &ExportOptions,
) -> Result<js_sys::Uint8Array, JsValue> {
    let fmt = export_format(format)?;
    let (field, cell) = export_source
        .terrain()
        .ok_or_else(|| error("there is no terrain yet"))?;
    let export = crate::pipeline::HeightmapExport {
        format: fmt,
        size: o.size,
        flip_y: o.flip_y,
        // The scene's vertical scale applies to every export, the option on top.
        z_scale: o.z_scale.unwrap_or(1.0)
            * export_source
                .scene()
                .map_or(1.0, |s| s.vertical_scale as f32),
        centre_lonlat: export_source
            .scene()
            .and_then(|s| s.location)
            .map(|l| [l.lon, l.lat]),
    };
    let ctx = JobCtx::detached();
    let out = crate::pipeline::encode_heightmap_in(&field, cell, &export, &ctx)
        .await
        .map_err(error)?;
    Ok(js_sys::Uint8Array::from(out.bytes.as_slice()))
}

/// Queues `command` and returns a promise that resolves once the app has applied it and
/// published the scene, so `scene()` shows the change (scripts never poll); it rejects with
/// the app's message when the app refused the command (an edit out of range, say).
fn applied(automation: &Automation, command: Command) -> js_sys::Promise {
    let number = automation.push(command);
    let automation = automation.clone();
    wasm_bindgen_futures::future_to_promise(async move {
        while automation.applied() < number {
            sleep(10).await;
        }
        outcome(&automation, number)
    })
}

/// A promise of `command` that resolves once it is applied and the jobs it started are
/// done (a command that runs as a job: its result is in the scene or the DEM panel, and
/// the terrain of the scene it made is computed); it rejects with the app's message when
/// the app refused the command (`extractFeatures()` with no DEM, say).
fn finished(automation: &Automation, command: Command) -> js_sys::Promise {
    let number = automation.push(command);
    let automation = automation.clone();
    wasm_bindgen_futures::future_to_promise(async move {
        // Every command queued so far, this one included, applied and no job running.
        settled(&automation).await;
        outcome(&automation, number)
    })
}

/// What an applied command's promise settles with: nothing, or the app's refusal.
fn outcome(automation: &Automation, number: u64) -> Result<JsValue, JsValue> {
    match automation.take_refusal(number) {
        Some(message) => Err(error(message)),
        None => Ok(JsValue::UNDEFINED),
    }
}

/// Waits until every queued command is applied and no job is computing the terrain, so an
/// export takes the terrain of the scene as it stands.
async fn settled(automation: &Automation) {
    loop {
        let status = automation.status();
        let pending = automation.applied() < automation.queued();
        let computing = status.job.is_some();
        if !pending && !computing {
            return;
        }
        sleep(20).await;
    }
}

/// A timer of `ms` milliseconds that lets the page paint meanwhile.
async fn sleep(ms: i32) {
    let promise = js_sys::Promise::new(&mut |resolve, _reject| {
        let scheduled = web_sys::window().map(|window| {
            window.set_timeout_with_callback_and_timeout_and_arguments_0(&resolve, ms)
        });
        if !matches!(scheduled, Some(Ok(_))) {
            let _ = resolve.call0(&JsValue::NULL);
        }
    });
    let _ = wasm_bindgen_futures::JsFuture::from(promise).await;
}

fn set(target: &JsValue, name: &str, value: &JsValue) {
    if js_sys::Reflect::set(target, &JsValue::from_str(name), value).is_err() {
        log::error!("could not set window.strahler.{name}");
    }
}

/// `JSON.stringify(value)`, or an `Error` if it cannot be.
fn json_text(value: &JsValue) -> Result<String, JsValue> {
    js_sys::JSON::stringify(value)
        .ok()
        .and_then(|s| s.as_string())
        .ok_or_else(|| error("expected a JSON value"))
}

/// `, "phi": P, "depth": D` from an options object (either may be absent).
fn river_options(options: &JsValue) -> Result<String, JsValue> {
    if options.is_undefined() || options.is_null() {
        return Ok(String::new());
    }
    let mut out = String::new();
    for key in ["phi", "depth"] {
        let value = js_sys::Reflect::get(options, &JsValue::from_str(key))
            .map_err(|_| error("options must be an object like {phi: 3, depth: 8}"))?;
        if !value.is_undefined() {
            out.push_str(&format!(r#", "{key}": {}"#, json_text(&value)?));
        }
    }
    Ok(out)
}

fn error(message: impl ToString) -> JsValue {
    js_sys::Error::new(&message.to_string()).into()
}

/// Serialises through JSON so the result is a plain object (NaN and infinities become null).
fn to_js<T: serde::Serialize>(value: &T) -> JsValue {
    serde_json::to_string(value)
        .ok()
        .and_then(|text| js_sys::JSON::parse(&text).ok())
        .unwrap_or(JsValue::NULL)
}

/// `placeBlock`'s argument.
#[derive(serde::Deserialize)]
#[serde(deny_unknown_fields, rename_all = "camelCase")]
struct PlaceOptions {
    window: [usize; 4],
    rect: [f64; 4],
    #[serde(default)]
    quarter_turns: u8,
    #[serde(default)]
    mirror: bool,
    #[serde(default = "one")]
    z_scale: f32,
    #[serde(default = "default_feather")]
    feather: f32,
}

fn default_feather() -> f32 {
    crate::blend::poisson::DEFAULT_FEATHER
}

/// `setView`'s options.
#[derive(serde::Deserialize)]
#[serde(deny_unknown_fields)]
struct ViewOptions {
    maps: Option<String>,
}

/// `setCamera`'s argument.
#[derive(serde::Deserialize)]
#[serde(deny_unknown_fields)]
struct CameraOptions {
    distance: Option<f32>,
    yaw: Option<f32>,
    pitch: Option<f32>,
}

fn one() -> f32 {
    1.0
}

/// `exportHeightmap`'s options.
#[derive(Default, serde::Deserialize)]
#[serde(deny_unknown_fields, rename_all = "camelCase")]
struct ExportOptions {
    size: Option<usize>,
    #[serde(default)]
    flip_y: bool,
    z_scale: Option<f32>,
    /// unreal, unity, godot, gis or gaea-wm.
    preset: Option<String>,
    /// `[columns, rows]`.
    tiles: Option<(usize, usize)>,
    #[serde(default)]
    maps: Vec<String>,
    #[serde(default)]
    rivers: bool,
    /// 'gl' or 'dx'.
    normals: Option<String>,
}

impl ExportOptions {
    fn wants_package(&self) -> bool {
        self.preset.is_some() || self.tiles.is_some() || !self.maps.is_empty() || self.rivers
    }
}
