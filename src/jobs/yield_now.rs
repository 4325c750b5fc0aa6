//! Giving control back to the event loop between chunks of work.

/// On the web: resolves in a new task posted through a `MessageChannel`, so the browser can
/// paint and deliver input and GPU callbacks before the job continues. A message task,
/// unlike `setTimeout(0)`, is not clamped to 4 ms once timers nest, so yielding often costs
/// little (the technique React's scheduler uses). Falls back to `setTimeout(0)`.
#[cfg(target_arch = "wasm32")]
pub async fn yield_now() {
    let promise = js_sys::Promise::new(&mut |resolve, _reject| {
        if !web::post(&resolve) {
            let scheduled = web_sys::window().map(|window| {
                window.set_timeout_with_callback_and_timeout_and_arguments_0(&resolve, 0)
            });
            if !matches!(scheduled, Some(Ok(_))) {
                // No window (a worker) and no channel: resolve at once, still async.
                let _ = resolve.call0(&wasm_bindgen::JsValue::NULL);
            }
        }
    });
    let _ = wasm_bindgen_futures::JsFuture::from(promise).await;
}

#[cfg(target_arch = "wasm32")]
mod web {
    use std::cell::RefCell;
    use std::collections::VecDeque;

    use wasm_bindgen::JsCast;
    use wasm_bindgen::closure::Closure;

    /// One channel for the page; each message resolves the oldest waiting yield.
    struct Channel {
        channel: web_sys::MessageChannel,
        _on_message: Closure<dyn FnMut(web_sys::MessageEvent)>,
    }

    thread_local! {
        static CHANNEL: RefCell<Option<Channel>> = const { RefCell::new(None) };
        static WAITING: RefCell<VecDeque<js_sys::Function>> = const { RefCell::new(VecDeque::new()) };
    }

    fn open() -> Option<Channel> {
        let channel = web_sys::MessageChannel::new().ok()?;
        let on_message = Closure::<dyn FnMut(web_sys::MessageEvent)>::new(|_| {
            if let Some(resolve) = WAITING.with(|w| w.borrow_mut().pop_front()) {
                let _ = resolve.call0(&wasm_bindgen::JsValue::NULL);
            }
        });
        channel
            .port1()
            .set_onmessage(Some(on_message.as_ref().unchecked_ref()));
        Some(Channel {
            channel,
            _on_message: on_message,
        })
    }

    /// Queues `resolve` to be called from a new task; false if no channel could be made.
    pub(super) fn post(resolve: &js_sys::Function) -> bool {
        CHANNEL.with(|slot| {
            let mut slot = slot.borrow_mut();
            if slot.is_none() {
                *slot = open();
            }
            let Some(channel) = slot.as_ref() else {
                return false;
            };
            WAITING.with(|w| w.borrow_mut().push_back(resolve.clone()));
            if channel
                .channel
                .port2()
                .post_message(&wasm_bindgen::JsValue::NULL)
                .is_err()
            {
                WAITING.with(|w| w.borrow_mut().pop_back());
                return false;
            }
            true
        })
    }
}

/// Natively jobs run on worker threads: nothing to yield to.
#[cfg(not(target_arch = "wasm32"))]
pub async fn yield_now() {}
