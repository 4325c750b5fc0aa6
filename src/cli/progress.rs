//! The progress bar of the long commands (`generate`, `convert`) on standard error: the job's
//! one bar ([`JobCtx::progress`], which only moves forward), what it is doing and about how
//! long it still needs ([`crate::jobs::time_left`]).
//!
//! On a terminal the bar is redrawn in place a few times a second and cleared at the end; in
//! a log (`--progress always` without a terminal) it is a line at each new stage or tenth of
//! the bar; `never`, or `auto` without a terminal, prints nothing, so scripts and pipes see
//! only the results.

use std::io::{IsTerminal, Write};
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use crate::jobs::{JobCtx, time_left, time_words};

/// When to show the progress bar.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, clap::ValueEnum)]
pub enum When {
    /// On a terminal only.
    #[default]
    Auto,
    /// Always: redrawn in place on a terminal, else a line at each stage and tenth.
    Always,
    /// Never.
    Never,
}

/// How often the bar is redrawn.
const REDRAW: Duration = Duration::from_millis(200);
/// Width of the bar in characters.
const WIDTH: usize = 24;

/// Runs `work` with a context whose progress is shown on standard error while it runs.
pub fn with_bar<T>(when: When, work: impl FnOnce(&JobCtx) -> T) -> T {
    let ctx = JobCtx::detached();
    let terminal = std::io::stderr().is_terminal();
    let show = match when {
        When::Auto => terminal,
        When::Always => true,
        When::Never => false,
    };
    if !show {
        return work(&ctx);
    }
    let done = AtomicBool::new(false);
    std::thread::scope(|scope| {
        scope.spawn(|| draw_until(&ctx, &done, terminal));
        let out = work(&ctx);
        done.store(true, Ordering::Relaxed);
        out
    })
}

/// Draws the bar of `ctx` until `done`; clears it on a terminal at the end.
fn draw_until(ctx: &JobCtx, done: &AtomicBool, terminal: bool) {
    let started = Instant::now();
    let mut last_line = None;
    while !done.load(Ordering::Relaxed) {
        std::thread::sleep(REDRAW);
        let (progress, message) = (ctx.progress(), ctx.message());
        if message.is_empty() {
            continue;
        }
        let line = bar_line(progress, &message, time_left(progress, started.elapsed()));
        let mut err = std::io::stderr().lock();
        if terminal {
            let _ = write!(err, "\r\x1b[2K{line}");
        } else {
            // A line per stage (the words before a colon) and per tenth of the bar.
            let key = (stage_of(&message).to_owned(), (progress * 10.0) as u32);
            if last_line.as_ref() != Some(&key) {
                let _ = writeln!(err, "{line}");
                last_line = Some(key);
            }
        }
        let _ = err.flush();
    }
    if terminal {
        let _ = write!(std::io::stderr(), "\r\x1b[2K");
    }
}

/// The stage a message names: its words before the first colon ("eroding: step 3 of 20").
fn stage_of(message: &str) -> &str {
    message.split(':').next().unwrap_or(message)
}

/// `[#########...............]  38%  eroding: step 7 of 20  (about 12 s left)`.
fn bar_line(progress: f32, message: &str, left: Option<Duration>) -> String {
    let p = progress.clamp(0.0, 1.0);
    let filled = (p * WIDTH as f32).round() as usize;
    let bar: String = (0..WIDTH)
        .map(|k| if k < filled { '#' } else { '.' })
        .collect();
    let left = left.map_or(String::new(), |d| {
        format!("  (about {} left)", time_words(d))
    });
    format!("[{bar}] {:>3.0}%  {message}{left}", p * 100.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_line_shows_the_bar_the_stage_and_the_time_left() {
        let line = bar_line(0.5, "eroding: step 10 of 20", Some(Duration::from_secs(65)));
        assert_eq!(
            line,
            "[############............]  50%  eroding: step 10 of 20  (about 1 min 5 s left)"
        );
        assert!(bar_line(0.0, "rivers", None).starts_with("[........................]   0%"));
        assert_eq!(stage_of("eroding: step 3 of 20"), "eroding");
    }
}
