//! A Web Worker for the page's heavy stages: the page's job hands a stage's inputs to it as a
//! [`Parcel`] and awaits the result, so the stage runs on another core while the page's own
//! thread draws and answers input (issue 35).
//!
//! - **One worker, the page's own module.** The worker is a small module script (made as a
//!   blob) that imports the page's wasm-bindgen glue and instantiates the very
//!   `WebAssembly.Module` the page runs, posted to it (compiled once). Its `main` finds no
//!   window and calls [`serve`] instead of starting the app.
//! - **Calls.** [`call`] posts `{id, kind, parcel}` with the arrays' buffers transferred. The
//!   worker runs the handler as a job of its own and posts `{id, progress, message}` about
//!   every [`PROGRESS_EVERY_MS`], and `{id, parcel}` or `{id, failed}` as soon as it ends.
//! - **Cancel.** The page's job sees each progress message through its own
//!   [`JobCtx::tick`]; once its owner cancelled it (a newer edit), it posts `{id, cancel}` and
//!   the worker drops the job, which stops at its next tick.
//! - **No worker** (no module workers, a script blocked, an error while starting): [`call`]
//!   answers [`CallError::Unavailable`] and the caller runs the stage on the page's thread,
//!   as before. [`describe`] says which, for the status line.

use std::cell::RefCell;
use std::collections::{HashMap, VecDeque};
use std::future::Future;
use std::pin::Pin;
use std::rc::Rc;

use js_sys::{Array as JsArray, Object, Reflect};
use wasm_bindgen::closure::Closure;
use wasm_bindgen::{JsCast, JsValue};

use super::parcel::{Array, Parcel};
use super::{Cancelled, JobCtx, JobHandle};

/// How often the worker reports a running job's progress (and so how soon a cancel lands).
const PROGRESS_EVERY_MS: i32 = 30;

/// Why [`call`] returned no result.
#[derive(Debug)]
pub enum CallError {
    /// No worker here: run the stage on this thread.
    Unavailable(String),
    /// The owner cancelled the job.
    Cancelled(Cancelled),
    /// The stage failed in the worker, with its message.
    Failed(String),
}

/// The worker's side: what runs a call of each `kind`.
pub type Handler =
    fn(String, Parcel, JobCtx) -> Pin<Box<dyn Future<Output = Result<Parcel, String>>>>;

/// The bootstrap module: waits for the glue's URL and the compiled module, instantiates it
/// (whose `main` installs the Rust handler), then replays what arrived meanwhile. Where the
/// page is cross-origin isolated and asks for threads, it instantiates the threaded build
/// (`threads/`) instead and starts its pool ([`super::threads`]), keeping the page's messages
/// queued until the pool is up; where that build does not load, the page's own. It then
/// posts `{id: 0, threads, note}`: how many threads the stages run on, and why only one.
const BOOT: &str = r#"
let queued = [];
self.onmessage = async (first) => {
  self.onmessage = (e) => queued.push(e.data);
  const { glue, module, threads } = first.data;
  let count = 1, note = 'one thread: ', loaded = false;
  if (!threads || threads.count < 2) {
    note += 'one was asked for';
  } else if (!self.crossOriginIsolated) {
    note += 'the page is not cross-origin isolated (its server sends no COOP and COEP headers)';
  } else {
    try {
      const wasm = await import(threads.glue);
      await wasm.default({ module_or_path: threads.wasm });
      loaded = true;
      const serve = self.onmessage;
      self.onmessage = (e) => queued.push(e.data);
      try {
        count = await wasm.strahler_start_threads(threads.glue, threads.count);
        note = count + ' threads';
      } finally {
        self.onmessage = serve;
      }
    } catch (err) {
      note += (loaded ? 'the threads did not start: ' : 'the threaded build did not load: ') + err;
    }
  }
  if (!loaded) {
    try {
      const glueModule = await import(glue);
      await glueModule.default({ module_or_path: module });
    } catch (err) {
      self.postMessage({ id: 0, failed: 'the worker could not start: ' + err });
      return;
    }
  }
  self.postMessage({ id: 0, threads: count, note });
  for (const data of queued) self.onmessage({ data });
  queued = [];
};
"#;

// ---------------------------------------------------------------- the page's side

#[derive(Default)]
struct Inbox {
    messages: VecDeque<JsValue>,
    wake: Option<js_sys::Function>,
}

struct Remote {
    worker: web_sys::Worker,
    inboxes: Rc<RefCell<HashMap<u32, Inbox>>>,
    /// Set once the worker failed to start: every waiting and later call is unavailable.
    broken: Rc<RefCell<Option<String>>>,
    /// How many threads the worker's stages run on, and why (set once it started).
    threads: Rc<RefCell<Option<Threads>>>,
    next_id: u32,
    _on_message: Closure<dyn FnMut(JsValue)>,
    _on_error: Closure<dyn FnMut(JsValue)>,
}

thread_local! {
    static REMOTE: RefCell<Option<Result<Remote, String>>> = const { RefCell::new(None) };
}

/// Runs the `kind` handler in the worker on `parcel`, with its progress on `ctx`.
pub async fn call(kind: &str, parcel: Parcel, ctx: &JobCtx) -> Result<Parcel, CallError> {
    let (id, inboxes, broken) = post(kind, parcel)?;
    let finish = |inboxes: &Rc<RefCell<HashMap<u32, Inbox>>>| {
        inboxes.borrow_mut().remove(&id);
    };
    loop {
        let message = next_message(id, &inboxes).await;
        if let Some(reason) = broken.borrow().clone() {
            finish(&inboxes);
            return Err(CallError::Unavailable(reason));
        }
        if let Some(failed) = string(&message, "failed") {
            finish(&inboxes);
            return Err(CallError::Failed(failed));
        }
        let packed = Reflect::get(&message, &"parcel".into()).unwrap_or(JsValue::UNDEFINED);
        if !packed.is_undefined() {
            finish(&inboxes);
            return from_js(&packed).map_err(CallError::Failed);
        }
        let progress = Reflect::get(&message, &"progress".into())
            .ok()
            .and_then(|p| p.as_f64())
            .unwrap_or(0.0) as f32;
        let words = string(&message, "message").unwrap_or_default();
        if let Err(cancelled) = ctx.tick(progress, &words).await {
            finish(&inboxes);
            cancel(id);
            return Err(CallError::Cancelled(cancelled));
        }
    }
}

/// How many threads the worker's stages run on (1: the calling thread alone), and in words
/// why ("2 threads", "one thread: the page is not cross-origin isolated ...").
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Threads {
    pub count: u32,
    pub note: String,
}

/// The worker's threads, once it started (`None` before, and without a worker).
pub fn threads() -> Option<Threads> {
    REMOTE.with(|slot| match slot.borrow().as_ref() {
        Some(Ok(remote)) if remote.broken.borrow().is_none() => remote.threads.borrow().clone(),
        _ => None,
    })
}

/// What the worker runs (the stages that call [`call`]), for the status line.
const STAGES: &str = "the diffusion and the erosion";

/// Whether a worker runs the page's heavy stages, in words for the status line.
pub fn describe() -> String {
    let without = |reason: &str| format!("no Web Worker ({reason}): {STAGES} run on the page");
    REMOTE.with(|slot| match slot.borrow().as_ref() {
        None => "a Web Worker starts with the first terrain".into(),
        Some(Ok(remote)) => match remote.broken.borrow().as_ref() {
            Some(reason) => without(reason),
            None => match remote.threads.borrow().as_ref() {
                Some(threads) => format!("{STAGES} run in a Web Worker ({})", threads.note),
                None => format!("{STAGES} run in a Web Worker"),
            },
        },
        Some(Err(reason)) => without(reason),
    })
}

type Posted = (
    u32,
    Rc<RefCell<HashMap<u32, Inbox>>>,
    Rc<RefCell<Option<String>>>,
);

fn post(kind: &str, parcel: Parcel) -> Result<Posted, CallError> {
    REMOTE.with(|slot| {
        let mut slot = slot.borrow_mut();
        let remote = slot
            .get_or_insert_with(start)
            .as_mut()
            .map_err(|reason| CallError::Unavailable(reason.clone()))?;
        if let Some(reason) = remote.broken.borrow().clone() {
            return Err(CallError::Unavailable(reason));
        }
        remote.next_id += 1;
        let id = remote.next_id;
        remote.inboxes.borrow_mut().insert(id, Inbox::default());
        let (packed, transfer) = to_js(parcel);
        let message = object(&[
            ("id", JsValue::from(id)),
            ("kind", JsValue::from_str(kind)),
            ("parcel", packed),
        ]);
        if let Err(err) = remote
            .worker
            .post_message_with_transfer(&message, &transfer)
        {
            remote.inboxes.borrow_mut().remove(&id);
            return Err(CallError::Unavailable(format!(
                "posting to it failed: {}",
                message_of(&err)
            )));
        }
        Ok((id, Rc::clone(&remote.inboxes), Rc::clone(&remote.broken)))
    })
}

fn cancel(id: u32) {
    REMOTE.with(|slot| {
        if let Some(Ok(remote)) = slot.borrow().as_ref() {
            let message = object(&[("id", JsValue::from(id)), ("cancel", JsValue::TRUE)]);
            let _ = remote.worker.post_message(&message);
        }
    });
}

/// The next message for call `id` (or any, once the worker broke).
async fn next_message(id: u32, inboxes: &Rc<RefCell<HashMap<u32, Inbox>>>) -> JsValue {
    if let Some(message) = inboxes
        .borrow_mut()
        .get_mut(&id)
        .and_then(|inbox| inbox.messages.pop_front())
    {
        return message;
    }
    let inboxes = Rc::clone(inboxes);
    let promise = js_sys::Promise::new(&mut |resolve, _| {
        if let Some(inbox) = inboxes.borrow_mut().get_mut(&id) {
            inbox.wake = Some(resolve);
        }
    });
    let _ = wasm_bindgen_futures::JsFuture::from(promise).await;
    inboxes
        .borrow_mut()
        .get_mut(&id)
        .and_then(|inbox| inbox.messages.pop_front())
        .unwrap_or(JsValue::UNDEFINED)
}

/// Starts the worker, or says why there is none.
fn start() -> Result<Remote, String> {
    let glue = glue_url().ok_or("the page's script was not found")?;
    let blob = web_sys::Blob::new_with_str_sequence_and_options(
        &JsArray::of1(&JsValue::from_str(BOOT)),
        &{
            let bag = web_sys::BlobPropertyBag::new();
            bag.set_type("text/javascript");
            bag
        },
    )
    .map_err(|e| message_of(&e))?;
    let url = web_sys::Url::create_object_url_with_blob(&blob).map_err(|e| message_of(&e))?;
    let options = web_sys::WorkerOptions::new();
    options.set_type(web_sys::WorkerType::Module);
    options.set_name("strahler stages");
    let worker = web_sys::Worker::new_with_options(&url, &options)
        .map_err(|e| format!("this browser has no module workers: {}", message_of(&e)))?;
    let inboxes: Rc<RefCell<HashMap<u32, Inbox>>> = Rc::default();
    let broken: Rc<RefCell<Option<String>>> = Rc::default();
    let threads: Rc<RefCell<Option<Threads>>> = Rc::default();
    let on_message = {
        let (inboxes, broken) = (Rc::clone(&inboxes), Rc::clone(&broken));
        let threads = Rc::clone(&threads);
        Closure::<dyn FnMut(JsValue)>::new(move |event: JsValue| {
            let data = Reflect::get(&event, &"data".into()).unwrap_or(JsValue::UNDEFINED);
            let id = Reflect::get(&data, &"id".into())
                .ok()
                .and_then(|v| v.as_f64())
                .unwrap_or(0.0) as u32;
            let started = Reflect::get(&data, &"threads".into())
                .ok()
                .and_then(|v| v.as_f64());
            if let (0, Some(count)) = (id, started) {
                let note = string(&data, "note").unwrap_or_default();
                *threads.borrow_mut() = Some(Threads {
                    count: count as u32,
                    note,
                });
                return;
            }
            if id == 0 {
                let reason = string(&data, "failed").unwrap_or_else(|| "it stopped".into());
                break_all(&inboxes, &broken, reason);
                return;
            }
            let mut boxes = inboxes.borrow_mut();
            if let Some(inbox) = boxes.get_mut(&id) {
                inbox.messages.push_back(data);
                if let Some(wake) = inbox.wake.take() {
                    let _ = wake.call0(&JsValue::NULL);
                }
            }
        })
    };
    let on_error = {
        let (inboxes, broken) = (Rc::clone(&inboxes), Rc::clone(&broken));
        Closure::<dyn FnMut(JsValue)>::new(move |event: JsValue| {
            let reason = string(&event, "message").unwrap_or_else(|| "it failed to load".into());
            log::warn!("the stages' Web Worker failed: {reason}");
            break_all(&inboxes, &broken, reason);
        })
    };
    worker.set_onmessage(Some(on_message.as_ref().unchecked_ref()));
    worker.set_onerror(Some(on_error.as_ref().unchecked_ref()));
    let first = object(&[
        ("glue", JsValue::from_str(&glue)),
        ("module", wasm_bindgen::module()),
        ("threads", threaded_build(&glue)),
    ]);
    worker
        .post_message(&first)
        .map_err(|e| format!("the module could not be posted: {}", message_of(&e)))?;
    Ok(Remote {
        worker,
        inboxes,
        broken,
        threads,
        next_id: 0,
        _on_message: on_message,
        _on_error: on_error,
    })
}

/// Where the threaded build lies (`threads/strahler.js` and `threads/strahler_bg.wasm`
/// beside the page's glue at `glue`) and how many threads to ask of it: the page's
/// `?threads=N`, else the machine's cores (`navigator.hardwareConcurrency`), at most
/// [`super::threads::MAX_THREADS`].
fn threaded_build(glue: &str) -> JsValue {
    let Some(window) = web_sys::window() else {
        return JsValue::UNDEFINED;
    };
    let asked = window
        .location()
        .search()
        .ok()
        .and_then(|search| web_sys::UrlSearchParams::new_with_str(&search).ok())
        .and_then(|params| params.get("threads"))
        .and_then(|n| n.trim().parse::<usize>().ok());
    let cores = window.navigator().hardware_concurrency() as usize;
    let count = asked.unwrap_or(cores).clamp(1, super::threads::MAX_THREADS);
    let url = |name: &str| {
        web_sys::Url::new_with_base(&format!("threads/{name}"), glue)
            .map(|u| JsValue::from_str(&u.href()))
            .unwrap_or(JsValue::UNDEFINED)
    };
    object(&[
        ("glue", url("strahler.js")),
        ("wasm", url("strahler_bg.wasm")),
        ("count", JsValue::from(count as u32)),
    ])
}

/// Marks the worker broken and wakes every waiting call (each then answers unavailable).
fn break_all(
    inboxes: &Rc<RefCell<HashMap<u32, Inbox>>>,
    broken: &Rc<RefCell<Option<String>>>,
    reason: String,
) {
    *broken.borrow_mut() = Some(reason);
    for inbox in inboxes.borrow_mut().values_mut() {
        inbox.messages.push_back(JsValue::UNDEFINED);
        if let Some(wake) = inbox.wake.take() {
            let _ = wake.call0(&JsValue::NULL);
        }
    }
}

/// The URL of the page's wasm-bindgen glue: the module the page's start script imports
/// (`import init from './strahler.js'`, or Trunk's hashed name), made absolute.
fn glue_url() -> Option<String> {
    let document = web_sys::window()?.document()?;
    let scripts = document.query_selector_all("script[type=module]").ok()?;
    let base = document.base_uri().ok().flatten()?;
    (0..scripts.length()).find_map(|k| {
        let text = scripts.get(k)?.text_content()?;
        let path = imported_path(&text)?;
        web_sys::Url::new_with_base(path, &base)
            .ok()
            .map(|u| u.href())
    })
}

/// The path in `... from './x.js'` of a script that starts the glue (`import init`).
fn imported_path(script: &str) -> Option<&str> {
    let at = script.find("import init")?;
    let rest = &script[at..];
    let from = rest.find(" from ")? + " from ".len();
    let rest = rest[from..].trim_start();
    let quote = rest.chars().next().filter(|c| *c == '\'' || *c == '"')?;
    let end = rest[1..].find(quote)?;
    Some(&rest[1..1 + end])
}

// ---------------------------------------------------------------- the worker's side

/// Whether this code runs in a dedicated worker (no window).
pub fn in_worker() -> bool {
    js_sys::global()
        .dyn_into::<web_sys::DedicatedWorkerGlobalScope>()
        .is_ok()
}

/// The worker's running calls by id (dropping one cancels it).
type Running = Rc<RefCell<HashMap<u32, JobHandle<Result<Parcel, String>>>>>;

/// Serves calls in this worker with `handler`, for the worker's lifetime.
pub fn serve(handler: Handler) {
    let Ok(scope) = js_sys::global().dyn_into::<web_sys::DedicatedWorkerGlobalScope>() else {
        return;
    };
    let running: Running = Rc::default();
    let reply_scope = scope.clone();
    let on_message = Closure::<dyn FnMut(JsValue)>::new(move |event: JsValue| {
        let data = Reflect::get(&event, &"data".into()).unwrap_or(JsValue::UNDEFINED);
        let id = Reflect::get(&data, &"id".into())
            .ok()
            .and_then(|v| v.as_f64())
            .unwrap_or(0.0) as u32;
        if Reflect::get(&data, &"cancel".into()).is_ok_and(|c| c.is_truthy()) {
            // Dropping the handle cancels the job at its next tick.
            running.borrow_mut().remove(&id);
            return;
        }
        let kind = string(&data, "kind").unwrap_or_default();
        let packed = Reflect::get(&data, &"parcel".into()).unwrap_or(JsValue::UNDEFINED);
        let scope = reply_scope.clone();
        let parcel = match from_js(&packed) {
            Ok(parcel) => parcel,
            Err(message) => {
                reply(&scope, id, Err(message));
                return;
            }
        };
        let name = kind.clone();
        // The result goes back the moment the job ends, not at the next progress report: a
        // coarse pass's solves take a few milliseconds, and waiting for the report added
        // up to [`PROGRESS_EVERY_MS`] to each of them.
        let finished = {
            let (scope, running) = (scope.clone(), Rc::clone(&running));
            move || post_result(&scope, id, &running)
        };
        let job = super::spawn(&name, move |ctx| handler(kind, parcel, ctx), finished);
        match job {
            Ok(job) => {
                running.borrow_mut().insert(id, job);
                wasm_bindgen_futures::spawn_local(watch(scope, id, Rc::clone(&running)));
            }
            Err(err) => reply(&scope, id, Err(err.to_string())),
        }
    });
    scope.set_onmessage(Some(on_message.as_ref().unchecked_ref()));
    // The worker serves until the page closes it.
    on_message.forget();
}

/// Posts job `id`'s result and forgets the job, once it has one (its `on_finish`).
fn post_result(scope: &web_sys::DedicatedWorkerGlobalScope, id: u32, running: &Running) {
    let mut jobs = running.borrow_mut();
    let Some(result) = jobs.get(&id).and_then(JobHandle::try_take) else {
        return; // cancelled, or not finished
    };
    jobs.remove(&id);
    drop(jobs);
    reply(scope, id, result);
}

/// Reports job `id`'s progress until it has posted its result or is cancelled.
async fn watch(scope: web_sys::DedicatedWorkerGlobalScope, id: u32, running: Running) {
    loop {
        sleep(&scope, PROGRESS_EVERY_MS).await;
        // The job posts its result when it ends; this only covers an end its `on_finish`
        // could not see (the job not yet listed).
        post_result(&scope, id, &running);
        let jobs = running.borrow();
        let Some(job) = jobs.get(&id) else {
            return; // finished and posted, or cancelled
        };
        let message = object(&[
            ("id", JsValue::from(id)),
            ("progress", JsValue::from(job.progress())),
            ("message", JsValue::from_str(&job.message())),
        ]);
        let _ = scope.post_message(&message);
    }
}

fn reply(scope: &web_sys::DedicatedWorkerGlobalScope, id: u32, result: Result<Parcel, String>) {
    let posted = match result {
        Ok(parcel) => {
            let (packed, transfer) = to_js(parcel);
            let message = object(&[("id", JsValue::from(id)), ("parcel", packed)]);
            scope.post_message_with_transfer(&message, &transfer)
        }
        Err(failed) => {
            let message = object(&[
                ("id", JsValue::from(id)),
                ("failed", JsValue::from_str(&failed)),
            ]);
            scope.post_message(&message)
        }
    };
    if let Err(err) = posted {
        log::error!("the worker could not post its result: {err:?}");
    }
}

async fn sleep(scope: &web_sys::DedicatedWorkerGlobalScope, ms: i32) {
    let promise = js_sys::Promise::new(&mut |resolve, _| {
        let _ = scope.set_timeout_with_callback_and_timeout_and_arguments_0(&resolve, ms);
    });
    let _ = wasm_bindgen_futures::JsFuture::from(promise).await;
}

// ---------------------------------------------------------------- parcels as JS values

/// `{header, arrays}`, and the arrays' buffers to transfer.
fn to_js(parcel: Parcel) -> (JsValue, JsArray) {
    let arrays = JsArray::new();
    let transfer = JsArray::new();
    for array in parcel.arrays {
        let typed: JsValue = match array {
            Array::F32(v) => js_sys::Float32Array::from(v.as_slice()).into(),
            Array::U32(v) => js_sys::Uint32Array::from(v.as_slice()).into(),
            Array::U8(v) => js_sys::Uint8Array::from(v.as_slice()).into(),
        };
        if let Ok(buffer) = Reflect::get(&typed, &"buffer".into()) {
            transfer.push(&buffer);
        }
        arrays.push(&typed);
    }
    let packed = object(&[
        ("header", JsValue::from_str(&parcel.header)),
        ("arrays", arrays.into()),
    ]);
    (packed, transfer)
}

fn from_js(packed: &JsValue) -> Result<Parcel, String> {
    let header = string(packed, "header").ok_or("a parcel without a header")?;
    let arrays = Reflect::get(packed, &"arrays".into())
        .ok()
        .and_then(|a| a.dyn_into::<JsArray>().ok())
        .ok_or("a parcel without arrays")?;
    let mut parcel = Parcel {
        header,
        arrays: VecDeque::new(),
    };
    for value in arrays.iter() {
        let array = if let Some(a) = value.dyn_ref::<js_sys::Float32Array>() {
            Array::F32(a.to_vec())
        } else if let Some(a) = value.dyn_ref::<js_sys::Uint32Array>() {
            Array::U32(a.to_vec())
        } else if let Some(a) = value.dyn_ref::<js_sys::Uint8Array>() {
            Array::U8(a.to_vec())
        } else {
            return Err("a parcel array of an unknown type".into());
        };
        parcel.arrays.push_back(array);
    }
    Ok(parcel)
}

fn object(fields: &[(&str, JsValue)]) -> JsValue {
    let object = Object::new();
    for (key, value) in fields {
        let _ = Reflect::set(&object, &JsValue::from_str(key), value);
    }
    object.into()
}

/// A thrown value in words: an `Error`'s message (not its stack), else its text.
fn message_of(value: &JsValue) -> String {
    if let Some(error) = value.dyn_ref::<js_sys::Error>() {
        return String::from(error.message());
    }
    value
        .as_string()
        .unwrap_or_else(|| "an unknown error".into())
}

fn string(value: &JsValue, key: &str) -> Option<String> {
    Reflect::get(value, &JsValue::from_str(key))
        .ok()
        .and_then(|v| v.as_string())
}
