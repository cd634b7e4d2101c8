//! Worker pools of a requested size: the one cap on `--threads` everywhere, and an error
//! rather than a panic when the threads cannot be made.

use crate::error::{Error, ErrorKind, Result};

/// Most worker threads accepted (`--threads` of every command).
pub const MAX_THREADS: usize = 1024;

/// A rayon pool of `threads` workers (0: one per available core), pinned one to each CPU
/// where it takes every CPU the process may use ([`crate::affinity`]). More than
/// [`MAX_THREADS`], or a failure to start them, is an error naming `--threads`.
pub fn pool(threads: usize) -> Result<rayon::ThreadPool> {
    if threads > MAX_THREADS {
        return Err(Error::new(
            ErrorKind::Usage,
            format!("--threads {threads} is above the maximum of {MAX_THREADS}"),
        ));
    }
    // The size rayon gives the pool (0: `RAYON_NUM_THREADS`, else one per available core).
    let n = match threads {
        0 => std::env::var("RAYON_NUM_THREADS")
            .ok()
            .and_then(|v| v.parse::<usize>().ok())
            .filter(|&n| n > 0)
            .unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get())),
        n => n,
    };
    let cpus = crate::affinity::plan(n);
    // Made from a pinned worker, unpinned workers get the process's CPUs, not its one.
    let inherit = crate::affinity::spawn_mask();
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .start_handler(move |i| match cpus.as_ref().and_then(|c| c.get(i)) {
            Some(&cpu) => crate::affinity::pin_current(cpu),
            None => crate::affinity::apply_spawn_mask(&inherit),
        })
        .build()
        .map_err(|e| {
            Error::new(
                ErrorKind::Usage,
                format!("cannot start {threads} worker threads ({e}); lower --threads"),
            )
        })
}

thread_local! {
    static SEQUENTIAL: std::cell::Cell<bool> = const { std::cell::Cell::new(false) };
}

/// Runs `work` on this thread with forking turned off: while it runs, [`may_fork`] is false
/// here, so the parallel helpers (refinement rows, stencil application, topology) run their
/// loops in place.
///
/// Lazily built caches (`OnceLock::get_or_init`) need this. Forking inside an initialiser
/// deadlocks at 0% CPU in two ways: a thread outside the pool hands its loop to the workers
/// and waits, while every worker waits for the cell it holds (seen: two test threads and the
/// Loop Bézier matrix); or a worker, waiting in a join, steals a job that asks for the cell
/// it is itself initialising.
pub fn sequential<T>(work: impl FnOnce() -> T) -> T {
    struct Restore(bool);
    impl Drop for Restore {
        fn drop(&mut self) {
            SEQUENTIAL.with(|s| s.set(self.0));
        }
    }
    let _restore = Restore(SEQUENTIAL.with(|s| s.replace(true)));
    work()
}

/// False inside [`sequential`]: parallel helpers check it before splitting their work.
pub fn may_fork() -> bool {
    !SEQUENTIAL.with(|s| s.get())
}

/// The `with_min_len` a parallel helper gives its iterator: 1 normally, and unsplittable
/// inside [`sequential`], so that rayon runs the whole loop in place.
pub fn min_len() -> usize {
    if may_fork() {
        1
    } else {
        usize::MAX
    }
}

/// The first `n` items of `rest`, which keeps the others (a worker's share of an output
/// split between workers in order).
pub(crate) fn split_off<'a, T>(rest: &mut &'a mut [T], n: usize) -> &'a mut [T] {
    let (head, tail) = std::mem::take(rest).split_at_mut(n);
    *rest = tail;
    head
}

#[cfg(test)]
mod tests {
    #[test]
    fn sequential_nests_and_restores() {
        assert!(super::may_fork());
        let inner = super::sequential(|| {
            let nested = super::sequential(super::may_fork);
            (nested, super::may_fork())
        });
        assert_eq!(inner, (false, false));
        assert!(super::may_fork());
    }

    #[test]
    fn caps() {
        let e = super::pool(5000).err().unwrap();
        assert_eq!(e.to_string(), "--threads 5000 is above the maximum of 1024");
        assert_eq!(super::pool(3).unwrap().current_num_threads(), 3);
        assert!(super::pool(0).unwrap().current_num_threads() >= 1);
    }
}
