//! Cache prefetch hints: a pass that reads scattered items in an order it knows asks for the
//! item a few steps ahead, so that the cache misses overlap instead of following each other.

/// How many items ahead a gather asks for (enough to cover a miss to memory at a few tens of
/// nanoseconds of work per item).
pub const AHEAD: usize = 8;

/// Hints that the `bytes` bytes from `p` (`bytes > 0`) will be read soon: every cache line
/// they touch. No effect on memory and never a fault, whatever `p`.
#[inline(always)]
pub fn prefetch_bytes<T>(p: *const T, bytes: usize) {
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::x86_64::{_mm_prefetch, _MM_HINT_T0};
        let first = (p as usize) % 64;
        let line = (p as *const i8).wrapping_sub(first);
        for l in 0..(first + bytes).div_ceil(64) {
            // SAFETY: a prefetch never faults and has no effect on memory.
            unsafe { _mm_prefetch::<_MM_HINT_T0>(line.wrapping_add(64 * l)) };
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = (p, bytes);
}

/// [`prefetch_bytes`] of the item `item` points to (or would: a slice's `get` past its end
/// gives `None`, and nothing is asked).
#[inline(always)]
pub fn prefetch<T>(item: Option<&T>) {
    if let Some(item) = item {
        prefetch_bytes(item as *const T, std::mem::size_of::<T>());
    }
}
