//! Row bands and items for the grid operators (multigrid, wavelet lifting): natively on
//! rayon's thread pool (made once, its threads reused by every call), one thread on the web
//! (this wasm build has no threads). Each band or item is computed alone, whichever thread
//! takes it, so results do not depend on the number of threads.

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

/// Calls `f(k, band)` for consecutive chunks of `data` of `band_len` elements: on rayon's
/// pool natively (the caller waits for them), one after the other on wasm.
pub fn for_each_band<T: Send>(
    data: &mut [T],
    band_len: usize,
    f: impl Fn(usize, &mut [T]) + Sync + Send,
) {
    let band_len = band_len.max(1);
    if data.len() <= band_len {
        f(0, data);
        return;
    }
    #[cfg(not(target_arch = "wasm32"))]
    {
        use rayon::prelude::*;
        data.par_chunks_mut(band_len)
            .enumerate()
            .for_each(|(k, chunk)| f(k, chunk));
    }
    #[cfg(target_arch = "wasm32")]
    for (k, chunk) in data.chunks_mut(band_len).enumerate() {
        f(k, chunk);
    }
}

/// Calls `f` on every item: on rayon's pool natively (work-stealing, so items of unequal
/// cost balance), all on the calling thread on wasm. For independent rows of a lifting step
/// and the like.
pub fn for_each_item<T: Send>(items: Vec<T>, f: impl Fn(T) + Sync + Send) {
    #[cfg(not(target_arch = "wasm32"))]
    if threads() > 1 && items.len() > 1 {
        use rayon::prelude::*;
        items.into_par_iter().for_each(f);
        return;
    }
    items.into_iter().for_each(f);
}

/// Runs `a` and `b` at the same time natively (on rayon's pool), one after the other on
/// wasm; returns both results. For independent measures of one grid.
pub fn join<A: Send, B: Send>(
    a: impl FnOnce() -> A + Send,
    b: impl FnOnce() -> B + Send,
) -> (A, B) {
    #[cfg(not(target_arch = "wasm32"))]
    if threads() > 1 {
        return rayon::join(a, b);
    }
    (a(), b())
}
