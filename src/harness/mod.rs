//! The test and benchmark harness: the one random generator ([`rng`]), ray generators for
//! benchmarks and tests ([`rays`]), probes of diced surfaces (inside points, leak counts,
//! accuracy against the exact surface: [`probe`]), evaluation queries ([`eval`]) and the
//! worker pool every command and benchmark runs in.

pub mod approx_error;
pub mod closest;
pub mod eval;
pub mod probe;
pub mod rays;
pub mod rng;

use crate::error::Result;

/// `threads`, or the machine's available parallelism when `threads` is 0.
pub fn thread_count(threads: usize) -> usize {
    if threads == 0 {
        std::thread::available_parallelism().map_or(1, |n| n.get())
    } else {
        threads
    }
}

/// A rayon pool of [`thread_count`]`(threads)` worker threads, through [`crate::threads::pool`]
/// (the one cap on `--threads`).
pub fn pool(threads: usize) -> Result<rayon::ThreadPool> {
    crate::threads::pool(thread_count(threads))
}
