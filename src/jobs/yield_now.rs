//! Giving control back to the event loop between chunks of work.

/// On the web: resolves on the next macrotask (`setTimeout(0)`), so the browser can paint and
/// deliver input and GPU callbacks before the job continues.
#[cfg(target_arch = "wasm32")]
pub async fn yield_now() {
    let promise = js_sys::Promise::new(&mut |resolve, _reject| {
        let scheduled = web_sys::window().map(|window| {
            window.set_timeout_with_callback_and_timeout_and_arguments_0(&resolve, 0)
        });
        if !matches!(scheduled, Some(Ok(_))) {
            // No window (a worker) or the timer failed: resolve at once, still async.
            let _ = resolve.call0(&wasm_bindgen::JsValue::NULL);
        }
    });
    let _ = wasm_bindgen_futures::JsFuture::from(promise).await;
}

/// Natively jobs run on worker threads: nothing to yield to.
#[cfg(not(target_arch = "wasm32"))]
pub async fn yield_now() {}
