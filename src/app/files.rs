//! Saving files the user asked for: a download in the browser, a file in the working
//! directory natively (the path is reported back).

/// Saves `bytes` as `name` (with `mime` on the web). Returns where the file went, in words.
pub fn save(name: &str, mime: &str, bytes: &[u8]) -> Result<String, String> {
    #[cfg(target_arch = "wasm32")]
    {
        download(name, mime, bytes).map_err(|e| format!("the download failed: {e:?}"))?;
        Ok(format!("downloaded {name}"))
    }
    #[cfg(not(target_arch = "wasm32"))]
    {
        let _ = mime;
        let path = std::env::current_dir()
            .map_err(|e| e.to_string())?
            .join(name);
        std::fs::write(&path, bytes)
            .map_err(|e| format!("cannot write {}: {e}", path.display()))?;
        Ok(format!("saved {}", path.display()))
    }
}

#[cfg(target_arch = "wasm32")]
fn download(name: &str, mime: &str, bytes: &[u8]) -> Result<(), wasm_bindgen::JsValue> {
    use wasm_bindgen::JsCast;
    let array = js_sys::Uint8Array::from(bytes);
    let parts = js_sys::Array::of1(&array);
    let options = web_sys::BlobPropertyBag::new();
    options.set_type(mime);
    let blob = web_sys::Blob::new_with_u8_array_sequence_and_options(&parts, &options)?;
    let url = web_sys::Url::create_object_url_with_blob(&blob)?;
    let document = web_sys::window()
        .and_then(|w| w.document())
        .ok_or("no document")?;
    let anchor: web_sys::HtmlAnchorElement = document.create_element("a")?.dyn_into()?;
    anchor.set_href(&url);
    anchor.set_download(name);
    anchor.click();
    web_sys::Url::revoke_object_url(&url)?;
    Ok(())
}

/// Opens the browser's file picker for `accept` (e.g. ".tif,.png"); the chosen file's name
/// and bytes go to `deliver` once read. Nothing happens if the user cancels.
#[cfg(target_arch = "wasm32")]
pub fn pick_file(accept: &str, deliver: impl Fn(String, Vec<u8>) + 'static) -> Result<(), String> {
    use wasm_bindgen::JsCast;
    use wasm_bindgen::closure::Closure;
    let fail = |e: wasm_bindgen::JsValue| format!("the file picker failed: {e:?}");
    let document = web_sys::window()
        .and_then(|w| w.document())
        .ok_or("no document")?;
    let input: web_sys::HtmlInputElement = document
        .create_element("input")
        .map_err(fail)?
        .dyn_into()
        .map_err(|_| "not an input element".to_owned())?;
    input.set_type("file");
    input.set_accept(accept);
    let source = input.clone();
    let deliver = std::rc::Rc::new(deliver);
    let on_change = Closure::<dyn Fn()>::new(move || {
        let Some(file) = source.files().and_then(|files| files.get(0)) else {
            return;
        };
        let deliver = deliver.clone();
        wasm_bindgen_futures::spawn_local(async move {
            let name = file.name();
            match wasm_bindgen_futures::JsFuture::from(file.array_buffer()).await {
                Ok(buffer) => deliver(name, js_sys::Uint8Array::new(&buffer).to_vec()),
                Err(err) => log::warn!("cannot read {name}: {err:?}"),
            }
        });
    });
    input.set_onchange(Some(on_change.as_ref().unchecked_ref()));
    // The input lives as long as the page may still deliver its file.
    on_change.forget();
    input.click();
    Ok(())
}
