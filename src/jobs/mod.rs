//! Background jobs for pipeline work: progress, cancellation, and a result slot the UI polls.
//!
//! A job body is an `async` function of a [`JobCtx`]. It calls [`JobCtx::checkpoint`] between
//! chunks of work; that records progress, returns [`Cancelled`] once the owner cancelled, and on
//! the web yields to the browser's event loop so the page keeps painting.
//!
//! - Native: each job runs on its own worker thread (`pollster` drives the future there, so GPU
//!   readbacks may block that thread, never the UI thread).
//! - Web: the future runs on the main thread through `wasm_bindgen_futures::spawn_local`; it
//!   must never block, only await. GPU readbacks await `map_async` callbacks; CPU loops yield at
//!   each checkpoint.
//!
//! The UI owns a [`JobHandle`], reads [`JobHandle::progress`] every frame and takes the result
//! with [`JobHandle::try_take`]. Dropping the handle cancels the job.
//!
//! A job's progress only moves forward: one bar per job. A job of several parts (the
//! pipeline's stages) hands each part [`JobCtx::part`], whose fractions 0..1 fill that part's
//! span of the bar; a part that reports a fraction lower than the bar already shows leaves
//! the bar where it is. [`time_left`] estimates the rest from the time so far.

pub mod parcel;
#[cfg(target_arch = "wasm32")]
pub mod threads;
#[cfg(target_arch = "wasm32")]
pub mod worker;
mod yield_now;

use std::future::Future;
use std::sync::atomic::{AtomicBool, AtomicU32, Ordering};
use std::sync::{Arc, Mutex, PoisonError};

use thiserror::Error;

pub use yield_now::yield_now;

/// Cells a pass of [`JobCtx::for_cells`] takes between two ticks: about a millisecond of
/// simple per-cell work.
pub const CELLS_PER_TICK: usize = 1 << 16;

/// Longest run of work between two yields of [`JobCtx::tick`].
pub const TICK_SLICE: std::time::Duration = std::time::Duration::from_millis(25);

/// The job was cancelled by its owner (a newer edit, the user, or a dropped handle).
#[derive(Clone, Copy, Debug, Error, PartialEq, Eq)]
#[error("cancelled")]
pub struct Cancelled;

/// Progress and cancel flags shared between a job and its handle.
#[derive(Debug, Default)]
struct Control {
    /// Progress in [0, 1] stored as `f32` bits; it only grows (non-negative `f32`s order as
    /// their bits do, so `fetch_max` on the bits keeps the largest).
    progress: AtomicU32,
    cancelled: AtomicBool,
    /// What the job is doing now, in words ("sweep 300 of 1000").
    message: Mutex<String>,
    /// When the job last yielded (see [`JobCtx::tick`]).
    last_yield: Mutex<Option<web_time::Instant>>,
    /// The work between ticks, timed only for contexts made by [`JobCtx::timed`].
    slices: Mutex<Option<SliceClock>>,
    /// Never yields: a context of [`run_inline`].
    inline: bool,
    /// Calls of [`JobCtx::tick`] and [`JobCtx::checkpoint`] so far.
    ticks: std::sync::atomic::AtomicU64,
    /// Every tick's place on the bar, in order, for contexts made by [`JobCtx::traced`].
    trace: Mutex<Option<Vec<f32>>>,
}

impl Control {
    fn progress(&self) -> f32 {
        f32::from_bits(self.progress.load(Ordering::Relaxed))
    }

    fn message(&self) -> String {
        self.message
            .lock()
            .unwrap_or_else(PoisonError::into_inner)
            .clone()
    }
}

/// The stretches of work between consecutive [`JobCtx::tick`] or [`JobCtx::checkpoint`]
/// calls (whether they yield or not): on the web each must stay short, as the page is frozen
/// while it runs (a `tick` that is not due yet extends the stretch to the next yield).
#[derive(Debug)]
struct SliceClock {
    /// When the last call returned (or the clock started).
    since: web_time::Instant,
    longest: std::time::Duration,
    /// The message of the tick that ended the longest stretch (what it led up to).
    longest_before: String,
}

/// Handed to a job body: report progress, notice cancellation, yield.
#[derive(Clone, Debug)]
pub struct JobCtx {
    control: Arc<Control>,
    /// The span of the job's bar this context's fractions 0..1 fill (see [`Self::part`]).
    span: (f32, f32),
    /// What this part of the job is about, put before its messages (see [`Self::titled`]).
    title: Option<Arc<str>>,
    /// Whether its checkpoints yield to the event loop (see [`Self::unyielding`]).
    yields: bool,
}

impl JobCtx {
    /// A context not attached to any handle: never cancelled, progress goes nowhere (the
    /// command line may read it: [`Self::progress`]). For the command line and tests, which
    /// run stages to completion.
    pub fn detached() -> Self {
        Self {
            control: Arc::default(),
            span: (0.0, 1.0),
            title: None,
            yields: true,
        }
    }

    /// The fraction `done / total` of this context's part (for loops over rows or cells),
    /// as [`Self::tick`]: yields once the slice is due.
    pub async fn tick_of(&self, done: usize, total: usize, message: &str) -> Result<(), Cancelled> {
        self.tick(done as f32 / total.max(1) as f32, message).await
    }

    /// `cell(i)` of every `i` in `0..n`, with a tick every [`CELLS_PER_TICK`] cells: for
    /// passes over every cell of a large grid.
    pub async fn map_cells<T>(
        &self,
        n: usize,
        message: &str,
        mut cell: impl FnMut(usize) -> T,
    ) -> Result<Vec<T>, Cancelled> {
        let mut out = Vec::with_capacity(n);
        self.for_cells(n, message, |cells| out.extend(cells.map(&mut cell)))
            .await?;
        Ok(out)
    }

    /// `work` over `0..n` in ranges of [`CELLS_PER_TICK`], with a tick before each.
    pub async fn for_cells(
        &self,
        n: usize,
        message: &str,
        mut work: impl FnMut(std::ops::Range<usize>),
    ) -> Result<(), Cancelled> {
        let mut start = 0;
        while start < n {
            self.tick_of(start, n, message).await?;
            let end = start.saturating_add(CELLS_PER_TICK).min(n);
            work(start..end);
            start = end;
        }
        Ok(())
    }

    /// This context's part cut into `N` equal parts, in order: for the passes of one
    /// function (`let [scan, write] = ctx.parts();`), so each moves the bar over its own
    /// share instead of the first filling it all.
    pub fn parts<const N: usize>(&self) -> [Self; N] {
        std::array::from_fn(|k| self.part(k as f32 / N as f32, (k + 1) as f32 / N as f32))
    }

    /// The context of one part of the job, which fills `from..to` of this context's span
    /// (both in 0..=1, `from <= to`): its fraction 0 is `from`, 1 is `to`. Cancelling and
    /// yielding are shared with the whole job.
    pub fn part(&self, from: f32, to: f32) -> Self {
        let (a, b) = self.span;
        let at = |f: f32| a + (b - a) * f.clamp(0.0, 1.0);
        Self {
            control: Arc::clone(&self.control),
            span: (at(from), at(to.max(from))),
            title: self.title.clone(),
            yields: self.yields,
        }
    }

    /// This context with its messages (and its parts') read as `"{title}: {message}"`: a
    /// job of several files says which file a pass is working on ("exporting the normal
    /// map (5 of 6 files): encoding the PNG").
    pub fn titled(&self, title: &str) -> Self {
        Self {
            title: Some(title.into()),
            ..self.clone()
        }
    }

    /// This context, and its parts, never yielding at their checkpoints (they still record
    /// progress and notice a cancel; awaits of real events, a GPU readback or a Web Worker's
    /// reply, still wait): for a job so small that it costs less than one repaint of the page
    /// (the coarse pass of an edit, tens of milliseconds), which would otherwise wait behind
    /// a repaint at each yield.
    pub fn unyielding(&self) -> Self {
        Self {
            yields: false,
            ..self.clone()
        }
    }

    /// The job's progress so far in [0, 1] (the whole bar, not this part's fraction).
    pub fn progress(&self) -> f32 {
        self.control.progress()
    }

    /// How many times the job has ticked (or passed a checkpoint) so far: the chances it
    /// gave the page to paint, were they due.
    pub fn ticks(&self) -> u64 {
        self.control.ticks.load(Ordering::Relaxed)
    }

    /// The job's last reported activity, in words.
    pub fn message(&self) -> String {
        self.control.message()
    }

    /// A detached context that also times the work between its ticks (see
    /// [`Self::longest_slice`]): for benchmarks of how long a job would hold the browser's
    /// main thread. The clock starts now.
    pub fn timed() -> Self {
        let ctx = Self::detached();
        *ctx.slices() = Some(SliceClock {
            since: web_time::Instant::now(),
            longest: std::time::Duration::ZERO,
            longest_before: String::new(),
        });
        ctx
    }

    /// The longest stretch of work so far between consecutive [`Self::tick`] or
    /// [`Self::checkpoint`] calls, counting the stretch from [`Self::timed`] to the first call
    /// and from the last call to now; `None` for contexts that do not time.
    pub fn longest_slice(&self) -> Option<std::time::Duration> {
        self.slices()
            .as_ref()
            .map(|clock| clock.longest.max(clock.since.elapsed()))
    }

    fn slices(&self) -> std::sync::MutexGuard<'_, Option<SliceClock>> {
        self.control
            .slices
            .lock()
            .unwrap_or_else(PoisonError::into_inner)
    }

    /// Ends the current stretch of work (timed contexts only).
    fn end_slice(&self, message: &str) {
        if let Some(clock) = self.slices().as_mut() {
            let elapsed = clock.since.elapsed();
            if elapsed > clock.longest {
                clock.longest = elapsed;
                message.clone_into(&mut clock.longest_before);
            }
        }
    }

    /// The message of the tick that ended the longest stretch so far ([`Self::timed`]
    /// contexts; empty before the first tick): where a benchmark looks first.
    pub fn longest_slice_before(&self) -> String {
        self.slices()
            .as_ref()
            .map(|clock| clock.longest_before.clone())
            .unwrap_or_default()
    }

    /// Starts the next stretch of work (timed contexts only).
    fn start_slice(&self) {
        if let Some(clock) = self.slices().as_mut() {
            clock.since = web_time::Instant::now();
        }
    }

    /// Records `fraction` (clamped to [0, 1]) and `message`, yields to the event loop on the
    /// web, and returns `Err(Cancelled)` if the owner cancelled the job.
    pub async fn checkpoint(&self, fraction: f32, message: &str) -> Result<(), Cancelled> {
        self.count_tick(fraction);
        self.end_slice(message);
        self.set_progress(fraction, message);
        if !self.control.inline && self.yields {
            yield_now().await;
        }
        *self
            .control
            .last_yield
            .lock()
            .unwrap_or_else(PoisonError::into_inner) = Some(web_time::Instant::now());
        self.start_slice();
        self.check()
    }

    /// A [`Self::checkpoint`] once [`TICK_SLICE`] has passed since the last yield, else only
    /// the cancel check: for loops of many short steps (a few milliseconds each), so the page
    /// gets a frame about every slice without paying a yield (a browser timer, >= 4 ms when
    /// nested) per step.
    pub async fn tick(&self, fraction: f32, message: &str) -> Result<(), Cancelled> {
        let due = self
            .control
            .last_yield
            .lock()
            .unwrap_or_else(PoisonError::into_inner)
            .is_none_or(|at| at.elapsed() >= TICK_SLICE);
        if due {
            self.checkpoint(fraction, message).await
        } else {
            self.count_tick(fraction);
            self.end_slice(message);
            self.start_slice();
            self.check()
        }
    }

    /// Like [`Self::checkpoint`] without yielding: for tight loops that yield elsewhere.
    /// `fraction` is of this context's part; the job's bar never moves back.
    pub fn set_progress(&self, fraction: f32, message: &str) {
        let fraction = if fraction.is_finite() {
            fraction.clamp(0.0, 1.0)
        } else {
            0.0
        };
        let global = self.on_bar(fraction);
        self.control
            .progress
            .fetch_max(global.to_bits(), Ordering::Relaxed);
        let mut text = self
            .control
            .message
            .lock()
            .unwrap_or_else(PoisonError::into_inner);
        text.clear();
        if let Some(title) = &self.title
            && title.as_ref() != message
        {
            text.push_str(title);
            text.push_str(": ");
        }
        text.push_str(message);
    }

    /// Where `fraction` (finite, of this context's part) lies on the job's bar.
    fn on_bar(&self, fraction: f32) -> f32 {
        let (a, b) = self.span;
        (a + (b - a) * fraction.clamp(0.0, 1.0)).clamp(0.0, 1.0)
    }

    /// Counts a tick, and traces its place on the bar ([`Self::traced`] contexts).
    fn count_tick(&self, fraction: f32) {
        self.control.ticks.fetch_add(1, Ordering::Relaxed);
        let mut trace = self
            .control
            .trace
            .lock()
            .unwrap_or_else(PoisonError::into_inner);
        if let Some(trace) = trace.as_mut() {
            trace.push(self.on_bar(if fraction.is_finite() { fraction } else { 0.0 }));
        }
    }

    /// A context that never yields and records where every tick lies on the bar, before the
    /// bar keeps the largest ([`Self::trace`]): for tests that a job's parts report in
    /// order, each over its own share.
    pub fn traced() -> Self {
        Self {
            control: Arc::new(Control {
                inline: true,
                trace: Mutex::new(Some(Vec::new())),
                ..Control::default()
            }),
            span: (0.0, 1.0),
            title: None,
            yields: true,
        }
    }

    /// Where each tick so far lay on the bar, in order (empty unless [`Self::traced`]).
    pub fn trace(&self) -> Vec<f32> {
        self.control
            .trace
            .lock()
            .unwrap_or_else(PoisonError::into_inner)
            .clone()
            .unwrap_or_default()
    }

    /// `Err(Cancelled)` once the owner cancelled.
    pub fn check(&self) -> Result<(), Cancelled> {
        if self.control.cancelled.load(Ordering::Relaxed) {
            Err(Cancelled)
        } else {
            Ok(())
        }
    }
}

type Slot<T> = Arc<Mutex<Option<T>>>;

/// The owner's side of a running job.
#[derive(Debug)]
pub struct JobHandle<T> {
    name: String,
    control: Arc<Control>,
    result: Slot<T>,
    started: web_time::Instant,
}

impl<T> JobHandle<T> {
    pub fn name(&self) -> &str {
        &self.name
    }

    /// About how long the job still needs, from its progress and the time since it started
    /// ([`time_left`]).
    pub fn time_left(&self) -> Option<std::time::Duration> {
        time_left(self.progress(), self.started.elapsed())
    }

    /// Last reported progress in [0, 1].
    pub fn progress(&self) -> f32 {
        self.control.progress()
    }

    /// Last reported activity, in words.
    pub fn message(&self) -> String {
        self.control.message()
    }

    /// Asks the job to stop at its next checkpoint.
    pub fn cancel(&self) {
        self.control.cancelled.store(true, Ordering::Relaxed);
    }

    /// The job's output once it finished; `None` while it runs (and after it was taken).
    pub fn try_take(&self) -> Option<T> {
        self.result
            .lock()
            .unwrap_or_else(PoisonError::into_inner)
            .take()
    }
}

impl<T> Drop for JobHandle<T> {
    fn drop(&mut self) {
        self.cancel();
    }
}

/// About how long a job at `progress` (0..1) after `elapsed` still needs, at the rate so far:
/// `elapsed (1 - p) / p`. `None` until the estimate means something (a second in and 2% done)
/// and once the job is done.
pub fn time_left(progress: f32, elapsed: std::time::Duration) -> Option<std::time::Duration> {
    let p = f64::from(progress);
    let ready = (0.02..1.0).contains(&p) && elapsed >= std::time::Duration::from_secs(1);
    ready.then(|| elapsed.mul_f64((1.0 - p) / p))
}

/// A time left in words: "a second", "12 s", "3 min 5 s", "2 h 4 min".
pub fn time_words(d: std::time::Duration) -> String {
    let s = d.as_secs();
    match s {
        0..2 => "a second".to_owned(),
        2..60 => format!("{s} s"),
        60..3600 => format!("{} min {} s", s / 60, s % 60),
        _ => format!("{} h {} min", s / 3600, (s % 3600) / 60),
    }
}

/// Runs `body` to completion here and now, on a context that never yields and is never
/// cancelled: for synchronous callers (the command line, tests, small inputs) of work a
/// job steps through with ticks (an export's encoders and maps). The body may await only
/// its context (CPU work), so it finishes in one poll.
///
/// # Panics
/// If the body awaits anything else (a GPU readback): that is a programming error.
pub fn run_inline<T, Fut>(body: impl FnOnce(JobCtx) -> Fut) -> T
where
    Fut: Future<Output = T>,
{
    let ctx = JobCtx {
        control: Arc::new(Control {
            inline: true,
            ..Control::default()
        }),
        span: (0.0, 1.0),
        title: None,
        yields: true,
    };
    let mut future = std::pin::pin!(body(ctx));
    let mut waker = std::task::Context::from_waker(std::task::Waker::noop());
    match future.as_mut().poll(&mut waker) {
        std::task::Poll::Ready(value) => value,
        std::task::Poll::Pending => panic!("an inline run awaited more than its context"),
    }
}

/// [`run_inline`] of a body that can only fail by being cancelled, which nothing does there.
pub fn finish_inline<T, Fut>(body: impl FnOnce(JobCtx) -> Fut) -> T
where
    Fut: Future<Output = Result<T, Cancelled>>,
{
    match run_inline(body) {
        Ok(value) => value,
        Err(Cancelled) => unreachable!("nothing cancels an inline run"),
    }
}

/// What a job's body, result and `on_finish` must be: `Send` natively, where the job runs on
/// a thread of its own; nothing on the web, where it runs on the thread that spawned it (in
/// the threaded build, which the page's stages worker runs, wgpu's objects are not `Send`).
#[cfg(not(target_arch = "wasm32"))]
pub trait JobSend: Send {}
#[cfg(not(target_arch = "wasm32"))]
impl<T: Send> JobSend for T {}
/// What a job's body, result and `on_finish` must be: nothing on the web, where a job runs
/// on the thread that spawned it.
#[cfg(target_arch = "wasm32")]
pub trait JobSend {}
#[cfg(target_arch = "wasm32")]
impl<T> JobSend for T {}

/// The operating system refused a worker thread (native only).
#[derive(Debug, Error)]
#[error("could not start a worker thread for {name}: {source}")]
pub struct SpawnError {
    name: String,
    source: std::io::Error,
}

/// Starts `body` in the background and returns its handle.
///
/// `on_finish` runs after the result is stored (from the worker thread natively): the app
/// passes `egui::Context::request_repaint` so the frame loop picks the result up at once.
pub fn spawn<T, F, Fut>(
    name: &str,
    body: F,
    on_finish: impl FnOnce() + JobSend + 'static,
) -> Result<JobHandle<T>, SpawnError>
where
    T: JobSend + 'static,
    F: FnOnce(JobCtx) -> Fut + JobSend + 'static,
    Fut: Future<Output = T> + 'static,
{
    let control = Arc::new(Control::default());
    let result: Slot<T> = Arc::default();
    let ctx = JobCtx {
        control: Arc::clone(&control),
        span: (0.0, 1.0),
        title: None,
        yields: true,
    };
    let slot = Arc::clone(&result);
    // The future is built where it runs: natively inside the worker thread, so only the
    // closure (not the future, which may hold GPU error scopes) has to be `Send`.
    let run = move || async move {
        let output = body(ctx).await;
        *slot.lock().unwrap_or_else(PoisonError::into_inner) = Some(output);
        on_finish();
    };

    #[cfg(not(target_arch = "wasm32"))]
    std::thread::Builder::new()
        .name(format!("job: {name}"))
        .spawn(move || pollster::block_on(run()))
        .map_err(|source| SpawnError {
            name: name.to_owned(),
            source,
        })?;
    #[cfg(target_arch = "wasm32")]
    wasm_bindgen_futures::spawn_local(run());

    Ok(JobHandle {
        name: name.to_owned(),
        control,
        result,
        started: web_time::Instant::now(),
    })
}

#[cfg(all(test, not(target_arch = "wasm32")))]
mod tests {
    use super::*;
    use std::time::{Duration, Instant};

    fn wait_for<T>(handle: &JobHandle<T>) -> T {
        let start = Instant::now();
        loop {
            if let Some(out) = handle.try_take() {
                return out;
            }
            assert!(
                start.elapsed() < Duration::from_secs(30),
                "job never finished"
            );
            std::thread::sleep(Duration::from_millis(1));
        }
    }

    #[test]
    fn an_unyielding_context_still_reports_progress_and_notices_a_cancel() {
        let ctx = JobCtx::detached().unyielding();
        let half = ctx.part(0.0, 0.5);
        assert!(!half.yields, "its parts do not yield either");
        pollster::block_on(half.checkpoint(1.0, "half way")).unwrap();
        assert_eq!(
            (ctx.progress(), ctx.message(), ctx.ticks()),
            (0.5, "half way".into(), 1)
        );
        ctx.control.cancelled.store(true, Ordering::Relaxed);
        assert_eq!(
            pollster::block_on(half.checkpoint(1.0, "on")),
            Err(Cancelled)
        );
    }

    #[test]
    fn runs_to_completion_and_reports_progress() {
        let handle = spawn(
            "count",
            |ctx| async move {
                let mut sum = 0u64;
                for i in 0..100u64 {
                    sum += i;
                    ctx.checkpoint(i as f32 / 100.0, "counting").await?;
                }
                ctx.set_progress(1.0, "done");
                Ok::<_, Cancelled>(sum)
            },
            || {},
        )
        .unwrap();
        assert_eq!(wait_for(&handle), Ok(4950));
        assert_eq!(handle.progress(), 1.0);
        assert_eq!(handle.message(), "done");
    }

    /// Parts fill their spans of one bar, which never moves back: a part that starts again
    /// at 0 holds the bar until it passes it.
    #[test]
    fn parts_fill_their_spans_and_the_bar_only_moves_forward() {
        let ctx = JobCtx::detached();
        let first = ctx.part(0.0, 0.25);
        first.set_progress(0.5, "first");
        assert_eq!(ctx.progress(), 0.125);
        let second = ctx.part(0.25, 1.0);
        second.set_progress(0.0, "second");
        assert_eq!((ctx.progress(), ctx.message().as_str()), (0.25, "second"));
        let inner = second.part(0.5, 1.0);
        inner.set_progress(0.5, "inner");
        assert_eq!(ctx.progress(), 0.25 + 0.75 * 0.75);
        second.set_progress(0.1, "back");
        assert_eq!(ctx.progress(), 0.25 + 0.75 * 0.75, "never back");
        inner.set_progress(f32::NAN, "nan");
        assert_eq!(ctx.progress(), 0.25 + 0.75 * 0.75);
        ctx.set_progress(1.0, "done");
        assert_eq!(ctx.progress(), 1.0);
    }

    #[test]
    fn time_left_follows_the_rate_so_far() {
        let ten = Duration::from_secs(10);
        assert_eq!(time_left(0.25, ten), Some(Duration::from_secs(30)));
        assert_eq!(time_left(0.01, ten), None, "too early to say");
        assert_eq!(time_left(0.5, Duration::from_millis(200)), None);
        assert_eq!(time_left(1.0, ten), None, "done");
        assert_eq!(time_words(Duration::from_secs(7500)), "2 h 5 min");
        assert_eq!(time_words(Duration::from_secs(65)), "1 min 5 s");
        assert_eq!(time_words(Duration::from_millis(400)), "a second");
    }

    #[test]
    fn cancel_stops_at_the_next_checkpoint() {
        let (started_tx, started_rx) = std::sync::mpsc::channel();
        let handle = spawn(
            "forever",
            move |ctx| async move {
                let _ = started_tx.send(());
                loop {
                    ctx.checkpoint(0.5, "spinning").await?;
                    std::thread::sleep(Duration::from_millis(1));
                }
                #[allow(unreachable_code)]
                Ok::<(), Cancelled>(())
            },
            || {},
        )
        .unwrap();
        started_rx.recv().unwrap();
        handle.cancel();
        assert_eq!(wait_for(&handle), Err(Cancelled));
    }

    /// Only a timed context times its slices; a slice ends at every tick, due or not.
    /// A titled part's messages say what they are about, its own parts' too; the title is
    /// not said twice.
    #[test]
    fn a_titled_part_puts_its_title_before_its_messages() {
        let ctx = JobCtx::detached();
        let file = ctx
            .part(0.5, 1.0)
            .titled("exporting the normal map (5 of 6 files)");
        file.set_progress(0.0, "exporting the normal map (5 of 6 files)");
        assert_eq!(ctx.message(), "exporting the normal map (5 of 6 files)");
        file.part(0.5, 1.0).set_progress(0.5, "encoding the PNG");
        assert_eq!(
            ctx.message(),
            "exporting the normal map (5 of 6 files): encoding the PNG"
        );
        assert_eq!(ctx.progress(), 0.875);
        ctx.set_progress(0.9, "zipping the files");
        assert_eq!(ctx.message(), "zipping the files");
    }

    #[test]
    fn a_timed_context_keeps_its_longest_slice() {
        assert_eq!(JobCtx::detached().longest_slice(), None);
        let ctx = JobCtx::timed();
        pollster::block_on(async {
            ctx.checkpoint(0.0, "start").await.unwrap();
            std::thread::sleep(Duration::from_millis(3));
            ctx.tick(0.5, "not due").await.unwrap();
            ctx.tick(0.6, "at once").await.unwrap();
        });
        let longest = ctx.longest_slice().unwrap();
        assert!(longest >= Duration::from_millis(3), "{longest:?}");
    }

    #[test]
    fn on_finish_runs_after_the_result_is_stored() {
        let (tx, rx) = std::sync::mpsc::channel();
        let handle = spawn("answer", |_ctx| async { 42 }, move || tx.send(()).unwrap()).unwrap();
        rx.recv_timeout(Duration::from_secs(30)).unwrap();
        assert_eq!(handle.try_take(), Some(42));
    }
}
