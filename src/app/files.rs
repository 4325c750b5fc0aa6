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
        let dir = std::env::current_dir().map_err(|e| e.to_string())?;
        save_in(&dir, name, bytes)
    }
}

/// [`save`] natively, in `dir`.
#[cfg(not(target_arch = "wasm32"))]
fn save_in(dir: &std::path::Path, name: &str, bytes: &[u8]) -> Result<String, String> {
    {
        use std::io::Write as _;
        let path = dir.join(name);
        // Never replace a file: a name already taken is refused (callers pick free names with
        // `free_stem`), and a failed write removes what it began.
        let mut file = std::fs::OpenOptions::new()
            .write(true)
            .create_new(true)
            .open(&path)
            .map_err(|e| format!("cannot create {}: {e}", path.display()))?;
        if let Err(e) = file.write_all(bytes).and_then(|()| file.sync_all()) {
            drop(file);
            let _ = std::fs::remove_file(&path);
            return Err(format!("cannot write {}: {e}", path.display()));
        }
        Ok(format!("saved {}", path.display()))
    }
}

/// A file stem free for every one of `extensions` in the working directory natively
/// (`stem`, then `stem-2`, `stem-3`, ...), so a save never replaces a file; in the browser
/// downloads never overwrite, so `stem` itself.
pub fn free_stem(stem: &str, extensions: &[&str]) -> String {
    #[cfg(target_arch = "wasm32")]
    {
        let _ = extensions;
        stem.to_owned()
    }
    #[cfg(not(target_arch = "wasm32"))]
    {
        free_stem_in(
            &std::env::current_dir().unwrap_or_default(),
            stem,
            extensions,
        )
    }
}

/// [`free_stem`] natively, in `dir`.
#[cfg(not(target_arch = "wasm32"))]
fn free_stem_in(dir: &std::path::Path, stem: &str, extensions: &[&str]) -> String {
    let taken = |s: &str| {
        extensions
            .iter()
            .any(|e| dir.join(format!("{s}{e}")).exists())
    };
    let mut candidate = stem.to_owned();
    let mut k = 2;
    while taken(&candidate) && k < 10_000 {
        candidate = format!("{stem}-{k}");
        k += 1;
    }
    candidate
}

#[cfg(all(test, not(target_arch = "wasm32")))]
mod tests {
    use super::*;

    /// Issue 33: the page's file inputs refuse empty and oversized files by their length,
    /// before the browser reads them, with the command line's messages.
    #[test]
    fn picked_files_are_checked_before_they_are_read() {
        let empty = check_elevation_file("dem.tif", 0).unwrap_err();
        assert!(empty.contains("empty (0 bytes)"), "{empty}");
        let huge = check_elevation_file("dem.png", 3 << 30).unwrap_err();
        assert!(huge.contains("3221225472 bytes"), "{huge}");
        assert!(check_elevation_file("dem.tif", 1 << 20).is_ok());
        assert!(check_scene_file("a.json", 0).is_err());
        let big = check_scene_file("a.json", crate::scene::MAX_SCENE_BYTES + 1).unwrap_err();
        assert!(big.contains("scene file"), "{big}");
        assert!(check_scene_file("a.json", 100).is_ok());
    }

    /// A save never replaces a file: a taken name is refused, and free stems skip names taken
    /// by any of the extensions saved together (a heightmap and its sidecar).
    #[test]
    fn saves_never_replace_a_file() {
        let dir = std::env::temp_dir().join(format!("strahler-files-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        std::fs::write(dir.join("strahler-heightmap.json"), b"the user's notes").unwrap();
        let stem = free_stem_in(&dir, "strahler-heightmap", &[".png", ".json"]);
        assert_eq!(stem, "strahler-heightmap-2");
        save_in(&dir, &format!("{stem}.png"), b"png").unwrap();
        assert!(save_in(&dir, "strahler-heightmap.json", b"sidecar").is_err());
        assert_eq!(
            std::fs::read(dir.join("strahler-heightmap.json")).unwrap(),
            b"the user's notes"
        );
        let next = free_stem_in(&dir, "strahler-heightmap", &[".png", ".json"]);
        assert_eq!(next, "strahler-heightmap-3");
        std::fs::remove_dir_all(&dir).unwrap();
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

/// [`pick_file`]'s check for an elevation file or a mask PNG: the command line's length rules.
#[cfg(any(target_arch = "wasm32", test))]
pub fn check_elevation_file(name: &str, len: u64) -> Result<(), String> {
    crate::dem::format::check_length(name, len, crate::dem::ReadLimits::default())
        .map_err(|e| e.to_string())
}

/// [`pick_file`]'s check for a scene file: not empty, within the scene's size limit.
#[cfg(any(target_arch = "wasm32", test))]
pub fn check_scene_file(_name: &str, len: u64) -> Result<(), String> {
    let limit = crate::scene::MAX_SCENE_BYTES;
    match len {
        0 => Err("the file is empty (0 bytes)".into()),
        n if n > limit => Err(format!(
            "the file is {n} bytes, more than the {limit} bytes a scene file may take; not read"
        )),
        _ => Ok(()),
    }
}

/// Opens the browser's file picker for `accept`; the chosen file arrives at the app as the
/// command `command` makes of its name and bytes, or, refused by `check`, as
/// `Command::FileRefused` shown at `place` (the section that asked for it).
#[cfg(target_arch = "wasm32")]
pub fn pick_into(
    automation: &super::Automation,
    accept: &str,
    check: fn(&str, u64) -> Result<(), String>,
    place: super::Place,
    command: fn(String, Vec<u8>) -> super::Command,
) -> Result<(), String> {
    let automation = automation.clone();
    pick_file(accept, check, move |name, read| {
        automation.push(match read {
            Ok(bytes) => command(name, bytes),
            Err(message) => super::Command::FileRefused {
                name,
                message,
                place,
            },
        });
    })
}

/// Opens the browser's file picker for `accept` (e.g. ".tif,.png"); the chosen file's name
/// and bytes go to `deliver` once read. `check` sees the name and length first, before the
/// browser reads the file into memory: what it refuses is delivered as the message instead
/// of the bytes (a 3 GB or empty file is never read). Nothing happens if the user cancels.
#[cfg(target_arch = "wasm32")]
pub fn pick_file(
    accept: &str,
    check: fn(&str, u64) -> Result<(), String>,
    deliver: impl Fn(String, Result<Vec<u8>, String>) + 'static,
) -> Result<(), String> {
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
        let name = file.name();
        if let Err(message) = check(&name, file.size() as u64) {
            deliver(name, Err(message));
            return;
        }
        wasm_bindgen_futures::spawn_local(async move {
            match wasm_bindgen_futures::JsFuture::from(file.array_buffer()).await {
                Ok(buffer) => deliver(name, Ok(js_sys::Uint8Array::new(&buffer).to_vec())),
                Err(err) => deliver(name, Err(format!("the browser could not read it: {err:?}"))),
            }
        });
    });
    input.set_onchange(Some(on_change.as_ref().unchecked_ref()));
    // The input lives as long as the page may still deliver its file.
    on_change.forget();
    input.click();
    Ok(())
}
