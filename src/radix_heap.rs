//! A monotone priority queue (radix heap, Ahuja, Mehlhorn, Orlin and Tarjan 1990) for the
//! Priority-Floods (the terrain's conditioning and the realism report's drainage): the heights it pops never decrease, which is exactly what flooding from
//! the border needs, and its operations are bucket pushes and pops instead of a binary
//! heap's sift through memory. Amortised O(log range) per element with a small constant.

/// Map `f32` to `u32` preserving order (for non-NaN values): negative numbers have their
/// bits flipped, positive ones their sign bit set.
#[inline]
pub fn ordered_key(v: f32) -> u32 {
    let bits = v.to_bits();
    if bits & 0x8000_0000 != 0 {
        !bits
    } else {
        bits | 0x8000_0000
    }
}

/// [`ordered_key`] for `f64`.
#[inline]
pub fn ordered_key_f64(v: f64) -> u64 {
    let bits = v.to_bits();
    if bits >> 63 == 1 {
        !bits
    } else {
        bits | (1 << 63)
    }
}

/// An unsigned key a [`RadixHeap`] sorts by its bits.
pub trait RadixKey: Copy + Ord {
    /// Bits in the key.
    const BITS: usize;
    /// One more than the index of the highest bit in which `self` and `other` differ; 0
    /// when they are equal.
    fn differing_bits(self, other: Self) -> usize;
    /// The smallest key.
    const ZERO: Self;
}

impl RadixKey for u32 {
    const BITS: usize = 32;
    const ZERO: Self = 0;
    #[inline]
    fn differing_bits(self, other: Self) -> usize {
        32 - (self ^ other).leading_zeros() as usize
    }
}

impl RadixKey for u64 {
    const BITS: usize = 64;
    const ZERO: Self = 0;
    #[inline]
    fn differing_bits(self, other: Self) -> usize {
        64 - (self ^ other).leading_zeros() as usize
    }
}

/// Pops `(key, value)` pairs in non-decreasing key order; pushes must not be below the last
/// key popped. Pairs with equal keys pop in no particular order.
pub struct RadixHeap<K: RadixKey = u32> {
    /// The last key popped (every key in the heap is at least this).
    last: K,
    /// Bucket `b` holds keys whose highest bit differing from `last` is bit `b - 1`
    /// (bucket 0: keys equal to `last`); `K::BITS + 1` of them.
    buckets: Vec<Vec<(K, u32)>>,
    len: usize,
}

impl<K: RadixKey> RadixHeap<K> {
    pub fn new() -> Self {
        Self {
            last: K::ZERO,
            buckets: (0..=K::BITS).map(|_| Vec::new()).collect(),
            len: 0,
        }
    }

    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    #[inline]
    fn bucket(&self, key: K) -> usize {
        key.differing_bits(self.last)
    }

    /// Adds `value` with `key` (at least the last key popped; smaller keys are treated as
    /// equal to it).
    #[inline]
    pub fn push(&mut self, key: K, value: u32) {
        let key = key.max(self.last);
        let b = self.bucket(key);
        self.buckets[b].push((key, value));
        self.len += 1;
    }

    /// The pair with the smallest key.
    pub fn pop(&mut self) -> Option<(K, u32)> {
        if self.buckets[0].is_empty() {
            let b = (1..=K::BITS).find(|&b| !self.buckets[b].is_empty())?;
            let moved = std::mem::take(&mut self.buckets[b]);
            self.last = moved.iter().map(|&(k, _)| k).min().unwrap_or(self.last);
            for (k, v) in moved.iter().copied() {
                let nb = self.bucket(k);
                self.buckets[nb].push((k, v));
            }
            // Keep the emptied bucket's allocation for later use.
            let mut moved = moved;
            moved.clear();
            if self.buckets[b].is_empty() {
                self.buckets[b] = moved;
            }
        }
        let popped = self.buckets[0].pop();
        if popped.is_some() {
            self.len -= 1;
        }
        popped
    }
}

impl<K: RadixKey> Default for RadixHeap<K> {
    fn default() -> Self {
        Self::new()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn keys_keep_the_order_of_their_floats() {
        let values = [-1e30f32, -2.5, -0.0, 0.0, 1e-30, 0.5, 3.0, 7e20];
        for pair in values.windows(2) {
            assert!(ordered_key(pair[0]) <= ordered_key(pair[1]), "{pair:?}");
            let (a, b) = (f64::from(pair[0]), f64::from(pair[1]));
            assert!(ordered_key_f64(a) <= ordered_key_f64(b), "{pair:?}");
        }
    }

    #[test]
    fn pops_in_key_order_with_monotone_pushes() {
        let mut heap = RadixHeap::<u32>::new();
        let mut state = 12345u32;
        let mut next = || {
            state ^= state << 13;
            state ^= state >> 17;
            state ^= state << 5;
            state
        };
        for i in 0..1000 {
            heap.push(next() >> 4, i);
        }
        let mut last = 0;
        let mut popped = 0;
        while let Some((k, _)) = heap.pop() {
            assert!(k >= last);
            last = k;
            popped += 1;
            // Monotone pushes while popping, as the flood does.
            if popped % 3 == 0 && popped < 3000 {
                heap.push(k + (next() >> 20), popped);
            }
        }
        assert!(popped >= 1000 && heap.is_empty());
    }
}
