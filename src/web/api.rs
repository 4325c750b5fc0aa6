//! `window.strahler`: the automation API for browser tests and power users (the egui canvas
//! is opaque to the DOM). Documented in the README. Every function returns plain JSON-like
//! objects; long-running ones return promises.
//!
//! - `status()`: `{version, ready, compute, computePath, adapter, capabilities, job,
//!   lastRun, lastError}`; `compute` is "webgpu" on the GPU path and "cpu" on the fallback.
//! - `selfTest()`: a promise of the CPU/GPU comparison (`compute::selftest::SelfTest`).

use wasm_bindgen::prelude::*;

use crate::app::Automation;
use crate::compute::selftest;
use crate::jobs::JobCtx;

/// Builds `window.strahler` around the shared automation state.
pub(super) fn install(automation: &Automation) {
    let Some(window) = web_sys::window() else {
        return;
    };
    let api = js_sys::Object::new();

    let status_source = automation.clone();
    let status = Closure::<dyn Fn() -> JsValue>::new(move || to_js(&status_source.status()));
    set(&api, "status", status.as_ref());
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
    set(&api, "selfTest", self_test.as_ref());
    self_test.forget();

    set(&api, "version", &JsValue::from_str(crate::VERSION));
    set(&window, "strahler", &api);
}

fn set(target: &JsValue, name: &str, value: &JsValue) {
    if js_sys::Reflect::set(target, &JsValue::from_str(name), value).is_err() {
        log::error!("could not set window.strahler.{name}");
    }
}

/// Serialises through JSON so the result is a plain object (NaN and infinities become null).
fn to_js<T: serde::Serialize>(value: &T) -> JsValue {
    serde_json::to_string(value)
        .ok()
        .and_then(|text| js_sys::JSON::parse(&text).ok())
        .unwrap_or(JsValue::NULL)
}
