//! Row bands and item batches for the grid operators (multigrid, wavelet lifting): several
//! threads natively, one on the web (wasm has no threads here). Results do not depend on the
//! number of threads.

use std::sync::OnceLock;

/// Levels smaller than this many cells run on one thread (spawning would cost more).
const MIN_PARALLEL_CELLS: usize = 1 << 16;

/// Worker threads available to the solver: the machine's parallelism natively, 1 on wasm.
pub fn threads() -> usize {
    static THREADS: OnceLock<usize> = OnceLock::new();
    *THREADS.get_or_init(|| {
        if cfg!(target_arch = "wasm32") {
            1
        } else {
            std::thread::available_parallelism().map_or(1, |n| n.get().min(8))
        }
    })
}

/// How many row bands to split a `w` x `h` level into (1 = serial).
pub fn bands(w: usize, h: usize) -> usize {
    if w * h < MIN_PARALLEL_CELLS {
        1
    } else {
        threads().min(h / 4).max(1)
    }
}

/// Calls `f(k, band)` for consecutive chunks of `data` of `band_len` elements, the last on
/// the calling thread and the others on scoped threads.
pub fn for_each_band<T: Send>(data: &mut [T], band_len: usize, f: impl Fn(usize, &mut [T]) + Sync) {
    let band_len = band_len.max(1);
    if data.len() <= band_len {
        f(0, data);
        return;
    }
    #[cfg(not(target_arch = "wasm32"))]
    std::thread::scope(|scope| {
        let mut chunks: Vec<(usize, &mut [T])> = data.chunks_mut(band_len).enumerate().collect();
        let (last_k, last) = chunks.pop().expect("at least two chunks");
        for (k, chunk) in chunks {
            let f = &f;
            scope.spawn(move || f(k, chunk));
        }
        f(last_k, last);
    });
    #[cfg(target_arch = "wasm32")]
    for (k, chunk) in data.chunks_mut(band_len).enumerate() {
        f(k, chunk);
    }
}

/// Calls `f` on every item, the items split into one batch per thread natively (all on the
/// calling thread on wasm). For independent rows of a lifting step and the like.
pub fn for_each_item<T: Send>(items: Vec<T>, f: impl Fn(T) + Sync) {
    let batches = threads().min(items.len()).max(1);
    #[cfg(not(target_arch = "wasm32"))]
    if batches > 1 {
        let per_batch = items.len().div_ceil(batches);
        let mut items = items;
        std::thread::scope(|scope| {
            while items.len() > per_batch {
                let batch = items.split_off(items.len() - per_batch);
                let f = &f;
                scope.spawn(move || batch.into_iter().for_each(f));
            }
            items.into_iter().for_each(&f);
        });
        return;
    }
    let _ = batches;
    items.into_iter().for_each(f);
}

/// Runs `a` and `b` at the same time natively (`b` on a scoped thread), one after the other
/// on wasm; returns both results. For independent measures of one grid.
pub fn join<A: Send, B: Send>(
    a: impl FnOnce() -> A + Send,
    b: impl FnOnce() -> B + Send,
) -> (A, B) {
    #[cfg(not(target_arch = "wasm32"))]
    if threads() > 1 {
        return std::thread::scope(|scope| {
            let other = scope.spawn(b);
            let first = a();
            let second = other
                .join()
                .unwrap_or_else(|panic| std::panic::resume_unwind(panic));
            (first, second)
        });
    }
    (a(), b())
}
