//! The uploaded DEM kept in the browser for the next visit (issue 35: a reload forgets
//! nothing): the DEM as the panel holds it (its voids filled if they were), written as a
//! float32 GeoTIFF into IndexedDB, which holds files of hundreds of megabytes where the
//! scene's local storage holds about 5 MB. A reload reads it back bit for bit and hands it to
//! the app as `Command::RestoreDem`. A write the browser refuses (its quota) is reported
//! as `Command::FileRefused`, naming the file; the DEM stays in the panel for this visit.
//!
//! Natively there is nothing to keep: the DEM is a file the user opens again.

#[cfg(target_arch = "wasm32")]
use super::Command;
use super::automation::Automation;
use crate::dem::Dem;

/// Keeps `dem` (shown as `name`) for the next visit, replacing the one kept before.
pub fn keep(name: &str, dem: &Dem, automation: &Automation) {
    #[cfg(target_arch = "wasm32")]
    {
        let bytes = match crate::dem::geotiff::write(&dem.field, &dem.georef) {
            Ok(bytes) => bytes,
            Err(err) => return refused(automation, name, &err.to_string()),
        };
        let (name, automation) = (name.to_owned(), automation.clone());
        wasm_bindgen_futures::spawn_local(async move {
            if let Err(err) = idb::put(&name, &bytes).await {
                refused(&automation, &name, &err);
            }
        });
    }
    #[cfg(not(target_arch = "wasm32"))]
    let _ = (name, dem, automation);
}

/// Reads the DEM kept by an earlier visit, if any, into a `Command::RestoreDem`.
pub fn restore(automation: &Automation) {
    #[cfg(target_arch = "wasm32")]
    {
        let automation = automation.clone();
        wasm_bindgen_futures::spawn_local(async move {
            match idb::get().await {
                Ok(Some((name, bytes))) => {
                    automation.push(Command::RestoreDem { name, bytes });
                }
                Ok(None) => {}
                Err(err) => log::warn!("the DEM kept in this browser could not be read: {err}"),
            }
        });
    }
    #[cfg(not(target_arch = "wasm32"))]
    let _ = automation;
}

/// Reports a DEM the browser would not keep.
#[cfg(target_arch = "wasm32")]
fn refused(automation: &Automation, name: &str, why: &str) {
    automation.push(Command::FileRefused {
        place: super::Place::Dem,
        name: name.to_owned(),
        message: format!(
            "kept for this visit only: the browser would not store it for the next ({why}); \
             free some of its storage or upload it again after a reload"
        ),
    });
}

/// Reads a kept DEM's bytes (a float32 GeoTIFF).
pub fn read(bytes: &[u8]) -> Result<Dem, crate::dem::DemError> {
    crate::dem::geotiff::read(bytes, crate::dem::ReadLimits::default())
}

/// IndexedDB: one database, one object store, one record ([`KEY`]) holding the DEM's name
/// and bytes. Each request is awaited through a promise settled by its callbacks.
#[cfg(target_arch = "wasm32")]
mod idb {
    use js_sys::{Object, Promise, Reflect, Uint8Array};
    use wasm_bindgen::JsCast;
    use wasm_bindgen::prelude::*;
    use wasm_bindgen_futures::JsFuture;
    use web_sys::{IdbDatabase, IdbRequest, IdbTransaction, IdbTransactionMode};

    const DATABASE: &str = "strahler";
    const STORE: &str = "files";
    const KEY: &str = "dem";

    /// The words of a failed request or transaction (a `DOMException`'s name and message).
    fn words(error: &JsValue) -> String {
        match error.dyn_ref::<web_sys::DomException>() {
            Some(e) => format!("{}: {}", e.name(), e.message()),
            None => error.as_string().unwrap_or_else(|| format!("{error:?}")),
        }
    }

    /// The request's result once it succeeds.
    async fn settle(request: &IdbRequest) -> Result<JsValue, String> {
        let promise = Promise::new(&mut |resolve, reject| {
            let done = request.clone();
            let on_success = Closure::once_into_js(move || {
                let value = done.result().unwrap_or(JsValue::UNDEFINED);
                let _ = resolve.call1(&JsValue::NULL, &value);
            });
            let failed = request.clone();
            let on_error = Closure::once_into_js(move || {
                let error = failed
                    .error()
                    .ok()
                    .flatten()
                    .map_or(JsValue::from_str("the request failed"), JsValue::from);
                let _ = reject.call1(&JsValue::NULL, &error);
            });
            request.set_onsuccess(Some(on_success.unchecked_ref()));
            request.set_onerror(Some(on_error.unchecked_ref()));
        });
        JsFuture::from(promise).await.map_err(|e| words(&e))
    }

    /// The transaction's end: `Ok` once committed, the reason when aborted (a quota hit
    /// shows here, as a `QuotaExceededError`).
    async fn committed(tx: &IdbTransaction) -> Result<(), String> {
        let promise = Promise::new(&mut |resolve, reject| {
            let on_complete = Closure::once_into_js(move || {
                let _ = resolve.call0(&JsValue::NULL);
            });
            let failed = tx.clone();
            let fail = move || {
                let error = failed.error().map_or(
                    JsValue::from_str("the transaction was aborted"),
                    JsValue::from,
                );
                let _ = reject.call1(&JsValue::NULL, &error);
            };
            let on_abort = Closure::once_into_js(fail);
            tx.set_oncomplete(Some(on_complete.unchecked_ref()));
            tx.set_onabort(Some(on_abort.unchecked_ref()));
        });
        JsFuture::from(promise)
            .await
            .map(|_| ())
            .map_err(|e| words(&e))
    }

    async fn open() -> Result<IdbDatabase, String> {
        let factory = web_sys::window()
            .ok_or("no window")?
            .indexed_db()
            .map_err(|e| words(&e))?
            .ok_or("this browser has no IndexedDB")?;
        let request = factory.open_with_u32(DATABASE, 1).map_err(|e| words(&e))?;
        let upgrading = request.clone();
        let on_upgrade = Closure::once_into_js(move || {
            if let Ok(db) = upgrading.result() {
                let _ = db
                    .unchecked_into::<IdbDatabase>()
                    .create_object_store(STORE);
            }
        });
        request.set_onupgradeneeded(Some(on_upgrade.unchecked_ref()));
        Ok(settle(&request).await?.unchecked_into())
    }

    /// Stores `bytes` under `name`, replacing the record kept before.
    pub async fn put(name: &str, bytes: &[u8]) -> Result<(), String> {
        let db = open().await?;
        let tx = db
            .transaction_with_str_and_mode(STORE, IdbTransactionMode::Readwrite)
            .map_err(|e| words(&e))?;
        let store = tx.object_store(STORE).map_err(|e| words(&e))?;
        let record = Object::new();
        let set = |field: &str, value: &JsValue| Reflect::set(&record, &field.into(), value);
        set("name", &JsValue::from_str(name)).map_err(|e| words(&e))?;
        set("bytes", &Uint8Array::from(bytes).into()).map_err(|e| words(&e))?;
        let request = store
            .put_with_key(&record, &JsValue::from_str(KEY))
            .map_err(|e| words(&e))?;
        settle(&request).await?;
        let result = committed(&tx).await;
        db.close();
        result
    }

    /// The record kept, if any: its name and bytes.
    pub async fn get() -> Result<Option<(String, Vec<u8>)>, String> {
        let db = open().await?;
        let tx = db.transaction_with_str(STORE).map_err(|e| words(&e))?;
        let store = tx.object_store(STORE).map_err(|e| words(&e))?;
        let request = store.get(&JsValue::from_str(KEY)).map_err(|e| words(&e))?;
        let record = settle(&request).await?;
        db.close();
        if record.is_undefined() || record.is_null() {
            return Ok(None);
        }
        let field = |name: &str| Reflect::get(&record, &name.into()).map_err(|e| words(&e));
        let name = field("name")?
            .as_string()
            .ok_or("the kept DEM has no name")?;
        let bytes = field("bytes")?
            .dyn_into::<Uint8Array>()
            .map_err(|_| "the kept DEM has no bytes")?
            .to_vec();
        Ok(Some((name, bytes)))
    }
}
