//! Every core in the page (issue 35): rayon's pool made of Web Workers that share the stages
//! worker's memory.
//!
//! The page ships two builds of the same code: the page's own (no threads: a page that is not
//! cross-origin isolated cannot make shared memory at all) and, in `threads/`, one compiled
//! with wasm's atomics and bulk memory and a shared memory (`.ci/build-threads`). Where the
//! page is cross-origin isolated (its server sends `Cross-Origin-Opener-Policy: same-origin`
//! and `Cross-Origin-Embedder-Policy: require-corp`, as `.ci/serve`, `trunk serve` and the
//! tests' server do), the stages worker ([`super::worker`]) instantiates the threaded build
//! and calls `start_threads` (`strahler_start_threads` in JavaScript), which starts one more
//! worker per thread, each instantiating the same module on the same memory, and hands each a
//! rayon `ThreadBuilder` to run (rayon's `spawn_handler`: wasm has no `std::thread::spawn`),
//! the way wasm-bindgen's parallel raytracing example and `wasm-bindgen-rayon` build theirs.
//! [`crate::parallel`] then runs its bands on that pool as it does natively; each band is
//! computed alone, so the bits are those of one thread (and of the command line).
//!
//! Only workers block: the stages worker waits in `Atomics.wait` while the pool works, which
//! a page's own thread may not do, so the page's thread never calls into a pool (its build
//! has none). Each thread's worker is made and loaded before the pool is built: a worker
//! starts loading only once its creator returns to its event loop, and rayon's `build`
//! waits for every thread to start.

/// Threads of the pool this instance started (0: none, the code runs on the calling thread).
pub fn pool_threads() -> usize {
    #[cfg(target_feature = "atomics")]
    {
        pool::THREADS.load(std::sync::atomic::Ordering::Acquire)
    }
    #[cfg(not(target_feature = "atomics"))]
    {
        0
    }
}

/// The name of a pool thread's worker: the module's start finds it and does nothing (the
/// thread runs what rayon hands it, nothing else).
pub const THREAD_NAME: &str = "strahler thread";

/// The most threads a pool takes (as natively: [`crate::parallel::threads`]).
pub const MAX_THREADS: usize = 8;

/// Whether this code runs in a pool thread's worker.
pub fn in_pool_thread() -> bool {
    use wasm_bindgen::JsCast;
    js_sys::global()
        .dyn_into::<web_sys::DedicatedWorkerGlobalScope>()
        .is_ok_and(|scope| scope.name() == THREAD_NAME)
}

#[cfg(target_feature = "atomics")]
pub use pool::{start_threads, thread_run};

#[cfg(target_feature = "atomics")]
mod pool {
    use std::sync::atomic::{AtomicUsize, Ordering};

    use js_sys::{Array, Object, Promise, Reflect};
    use wasm_bindgen::prelude::*;
    use wasm_bindgen_futures::JsFuture;

    use super::{MAX_THREADS, THREAD_NAME};

    pub(super) static THREADS: AtomicUsize = AtomicUsize::new(0);

    /// A pool thread's worker: instantiates the module its creator runs on its memory, says
    /// it is ready, then runs the `ThreadBuilder` whose address it is sent.
    const THREAD_BOOT: &str = r#"
self.onmessage = async (first) => {
  try {
    const { glue, module, memory } = first.data;
    const wasm = await import(glue);
    await wasm.default({ module_or_path: module, memory });
    self.onmessage = (e) => wasm.strahler_thread_run(e.data);
    self.postMessage({ ready: true });
  } catch (err) {
    self.postMessage({ failed: String(err) });
  }
};
"#;

    /// Starts rayon's pool of `count` threads (clamped to 1..=[`MAX_THREADS`]) in this
    /// instance, whose glue is at `glue`: resolves to the threads started. Once started, later
    /// calls resolve to that pool's size. Fails, leaving the code on the calling thread, where
    /// a worker cannot be made or loaded.
    #[wasm_bindgen(js_name = strahler_start_threads)]
    pub async fn start_threads(glue: String, count: usize) -> Result<usize, JsValue> {
        let started = THREADS.load(Ordering::Acquire);
        if started > 0 {
            return Ok(started);
        }
        let count = count.clamp(1, MAX_THREADS);
        let url = boot_url()?;
        let mut workers = Vec::with_capacity(count);
        for _ in 0..count {
            workers.push(loaded_worker(&url, &glue).await?);
        }
        let _ = web_sys::Url::revoke_object_url(&url);
        rayon::ThreadPoolBuilder::new()
            .num_threads(count)
            .thread_name(|k| format!("{THREAD_NAME} {k}"))
            .spawn_handler(move |thread| {
                let worker = &workers[thread.index()];
                // The thread's worker owns the builder from here (`thread_run`).
                let address = Box::into_raw(Box::new(thread)) as usize;
                worker
                    .post_message(&JsValue::from(address as u32))
                    .map_err(|e| std::io::Error::other(format!("{e:?}")))
            })
            .build_global()
            .map_err(|e| JsValue::from_str(&format!("rayon's pool: {e}")))?;
        THREADS.store(count, Ordering::Release);
        Ok(count)
    }

    /// Runs the rayon thread at `address` (a `Box<ThreadBuilder>` from [`start_threads`]) on
    /// this worker until the pool ends.
    #[wasm_bindgen(js_name = strahler_thread_run)]
    pub fn thread_run(address: u32) {
        // SAFETY: `address` is the `Box::into_raw` of a `ThreadBuilder` that
        // `start_threads` posted to this worker alone, once; the memory is shared.
        let thread = unsafe { Box::from_raw(address as usize as *mut rayon::ThreadBuilder) };
        thread.run();
    }

    fn boot_url() -> Result<String, JsValue> {
        let bag = web_sys::BlobPropertyBag::new();
        bag.set_type("text/javascript");
        let blob = web_sys::Blob::new_with_str_sequence_and_options(
            &Array::of1(&JsValue::from_str(THREAD_BOOT)),
            &bag,
        )?;
        web_sys::Url::create_object_url_with_blob(&blob)
    }

    /// A thread's worker, its module instantiated on this memory (awaited: see the module
    /// docs).
    async fn loaded_worker(url: &str, glue: &str) -> Result<web_sys::Worker, JsValue> {
        let options = web_sys::WorkerOptions::new();
        options.set_type(web_sys::WorkerType::Module);
        options.set_name(THREAD_NAME);
        let worker = web_sys::Worker::new_with_options(url, &options)?;
        let answer = Promise::new(&mut |resolve, reject| {
            worker.set_onmessage(Some(&resolve));
            worker.set_onerror(Some(&reject));
        });
        let first = Object::new();
        Reflect::set(&first, &"glue".into(), &JsValue::from_str(glue))?;
        Reflect::set(&first, &"module".into(), &wasm_bindgen::module())?;
        Reflect::set(&first, &"memory".into(), &wasm_bindgen::memory())?;
        worker.post_message(&first)?;
        let event = JsFuture::from(answer).await?;
        worker.set_onmessage(None);
        worker.set_onerror(None);
        let data = Reflect::get(&event, &"data".into())?;
        if let Some(failed) = Reflect::get(&data, &"failed".into())?.as_string() {
            return Err(JsValue::from_str(&format!(
                "a thread's worker could not load: {failed}"
            )));
        }
        Ok(worker)
    }
}
