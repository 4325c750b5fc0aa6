//! Row bands and items for the grid operators (multigrid, wavelet lifting): natively on
//! rayon's thread pool (made once, its threads reused by every call); on the web, on rayon's
//! pool of Web Workers in the page's stages worker where the threaded build runs there
//! ([`crate::jobs::threads`]: a cross-origin isolated page), else on the calling thread. Each
//! band or item is computed alone, whichever thread takes it, so results do not depend on
//! the number of threads: the page computes the bits the command line does, on one thread
//! or several.

#[cfg(not(target_arch = "wasm32"))]
use std::sync::OnceLock;
use std::sync::atomic::{AtomicU32, Ordering};

/// Levels smaller than this many cells run on one thread (spawning would cost more).
const MIN_PARALLEL_CELLS: usize = 1 << 16;

/// Worker threads available to the solver: the machine's parallelism natively; on wasm the
/// threads of the pool started in this instance (1 where none was: the page's own thread, a
/// build without threads, a worker whose pool is not up yet).
pub fn threads() -> usize {
    #[cfg(target_arch = "wasm32")]
    {
        crate::jobs::threads::pool_threads().max(1)
    }
    #[cfg(not(target_arch = "wasm32"))]
    {
        static THREADS: OnceLock<usize> = OnceLock::new();
        *THREADS.get_or_init(|| std::thread::available_parallelism().map_or(1, |n| n.get().min(8)))
    }
}

/// Whether rayon's pool may be called: always natively; on wasm only once this instance
/// started its pool of Web Workers (rayon's own default pool would spawn `std` threads,
/// which wasm has not).
#[cfg(any(not(target_arch = "wasm32"), target_feature = "atomics"))]
fn pool_up() -> bool {
    threads() > 1
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
/// pool where there is one (the caller waits for them), else one after the other.
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
    #[cfg(any(not(target_arch = "wasm32"), target_feature = "atomics"))]
    if pool_up() {
        use rayon::prelude::*;
        data.par_chunks_mut(band_len)
            .enumerate()
            .for_each(|(k, chunk)| f(k, chunk));
        return;
    }
    for (k, chunk) in data.chunks_mut(band_len).enumerate() {
        f(k, chunk);
    }
}

/// Calls `f` on every item: on rayon's pool where there is one (work-stealing, so items of
/// unequal cost balance), else all on the calling thread. For independent rows of a lifting
/// step and the like.
pub fn for_each_item<T: Send>(items: Vec<T>, f: impl Fn(T) + Sync + Send) {
    #[cfg(any(not(target_arch = "wasm32"), target_feature = "atomics"))]
    if pool_up() && items.len() > 1 {
        use rayon::prelude::*;
        items.into_par_iter().for_each(f);
        return;
    }
    items.into_iter().for_each(f);
}

/// Runs `a` and `b` at the same time on rayon's pool where there is one, else one after the
/// other; returns both results. For independent measures of one grid.
pub fn join<A: Send, B: Send>(
    a: impl FnOnce() -> A + Send,
    b: impl FnOnce() -> B + Send,
) -> (A, B) {
    #[cfg(any(not(target_arch = "wasm32"), target_feature = "atomics"))]
    if pool_up() {
        return rayon::join(a, b);
    }
    (a(), b())
}

/// A field of `f32` that the items of [`for_each_item`] read and write at once, each item
/// only cells no other item reads or writes (the runs of independent trees of a drainage
/// stack, say). Relaxed atomic loads and stores: plain moves on x86 and wasm, and where a
/// caller's partition were wrong, wrong values, never undefined behaviour.
pub struct SharedField<'a>(&'a [AtomicU32]);

// The cast below needs `f32`'s alignment to be at least `AtomicU32`'s.
const _: () = assert!(std::mem::align_of::<f32>() >= std::mem::align_of::<AtomicU32>());

impl<'a> SharedField<'a> {
    /// Shares `field` for as long as it is borrowed.
    pub fn new(field: &'a mut [f32]) -> Self {
        // SAFETY: `AtomicU32` has the size of `f32` and an alignment it meets (checked at
        // compile time above), and every bit pattern is valid for both; the exclusive borrow
        // lasts as long as the view, so the field is only reached through its atomics.
        let cells = unsafe { &*(std::ptr::from_mut(field) as *const [AtomicU32]) };
        SharedField(cells)
    }

    #[inline]
    pub fn get(&self, i: usize) -> f32 {
        f32::from_bits(self.0[i].load(Ordering::Relaxed))
    }

    #[inline]
    pub fn set(&self, i: usize, value: f32) {
        self.0[i].store(value.to_bits(), Ordering::Relaxed);
    }
}

/// A field's cells read and written one at a time: a plain slice (one thread), or a
/// [`SharedField`] that the items of [`for_each_item`] share.
pub trait Cells {
    fn get(&self, i: usize) -> f32;
    fn set(&mut self, i: usize, value: f32);
}

impl Cells for [f32] {
    #[inline]
    fn get(&self, i: usize) -> f32 {
        self[i]
    }

    #[inline]
    fn set(&mut self, i: usize, value: f32) {
        self[i] = value;
    }
}

impl Cells for &SharedField<'_> {
    #[inline]
    fn get(&self, i: usize) -> f32 {
        SharedField::get(self, i)
    }

    #[inline]
    fn set(&mut self, i: usize, value: f32) {
        SharedField::set(self, i, value);
    }
}
