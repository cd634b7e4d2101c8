//! One worker per CPU: a pool that takes every CPU the process may run on pins its workers,
//! one to each, so that a worker woken for a parallel stage wakes where it slept.
//!
//! Why: rayon's idle workers sleep within microseconds, and a sleeping worker woken for the
//! next parallel stage is placed by the kernel's scheduler. On a virtual machine that packs
//! woken threads onto busy vCPUs (measured here: a Firecracker guest booted with
//! `sched_vcpu_pack`), the woken worker queued behind the thread that woke it for 1.2–2.5 ms
//! (medians; up to 3 ms) after the process had idled 2 ms or more, where a parallel stage of
//! a build lasts 0.1–10 ms. Pinned, it woke in 30–100 µs (`examples/wake_latency.rs`).
//! Embree's TBB workers spin rather than sleep, which hides the same delay.
//!
//! Only where it cannot crowd anything: Linux only, a pool of two threads or more whose size
//! is the number of CPUs the process may run on (its main thread's affinity mask; a smaller
//! pool, or a larger one, is left to the scheduler). `LIMITRAY_PIN_THREADS=0` turns it off. A
//! thread inherits its creator's mask, so the pools (and their workers) that a pinned worker
//! starts are given the process's CPUs back ([`spawn_mask`]).

use std::cell::Cell;

thread_local! {
    /// Whether this thread was pinned by [`pin_current`].
    static PINNED: Cell<bool> = const { Cell::new(false) };
}

/// The CPUs the workers of a pool of `threads` are pinned to, in worker order: the process's
/// CPUs when there are exactly `threads` of them (and `threads` ≥ 2) and pinning is not
/// turned off, else none.
pub fn plan(threads: usize) -> Option<Vec<usize>> {
    let setting = std::env::var_os("LIMITRAY_PIN_THREADS");
    decide(threads, setting.as_deref(), process_cpus())
}

/// [`plan`] given the variable's value and the process's CPUs.
fn decide(
    threads: usize,
    setting: Option<&std::ffi::OsStr>,
    cpus: Option<Vec<usize>>,
) -> Option<Vec<usize>> {
    if threads < 2 || setting.is_some_and(|v| v == "0") {
        return None;
    }
    cpus.filter(|c| c.len() == threads)
}

/// The CPUs the process may run on (its main thread's affinity mask), in increasing order;
/// `None` off Linux or where the kernel does not say.
pub fn process_cpus() -> Option<Vec<usize>> {
    #[cfg(target_os = "linux")]
    {
        // SAFETY: `getpid` cannot fail; the process id is its main thread's id.
        mask_of(unsafe { libc::getpid() })
    }
    #[cfg(not(target_os = "linux"))]
    None
}

/// The affinity mask of thread `tid` (0: the calling thread), in increasing order.
#[cfg(target_os = "linux")]
fn mask_of(tid: libc::pid_t) -> Option<Vec<usize>> {
    // SAFETY: `cpu_set_t` is plain bits (zero is the empty set); the kernel writes at most
    // its size, which is passed.
    let set = unsafe {
        let mut set: libc::cpu_set_t = std::mem::zeroed();
        if libc::sched_getaffinity(tid, std::mem::size_of::<libc::cpu_set_t>(), &mut set) != 0 {
            return None;
        }
        set
    };
    let cpus: Vec<usize> = (0..libc::CPU_SETSIZE as usize)
        // SAFETY: `cpu` is below `CPU_SETSIZE`, the set's size in bits.
        .filter(|&cpu| unsafe { libc::CPU_ISSET(cpu, &set) })
        .collect();
    (!cpus.is_empty()).then_some(cpus)
}

/// Restricts the calling thread to `cpus`. Only a request: where the kernel refuses (or off
/// Linux), the thread runs where the scheduler puts it.
fn set_current(cpus: &[usize]) {
    #[cfg(target_os = "linux")]
    {
        // SAFETY: as in `mask_of`; every CPU set is below `CPU_SETSIZE`.
        unsafe {
            let mut set: libc::cpu_set_t = std::mem::zeroed();
            for &cpu in cpus.iter().filter(|&&c| c < libc::CPU_SETSIZE as usize) {
                libc::CPU_SET(cpu, &mut set);
            }
            libc::sched_setaffinity(0, std::mem::size_of::<libc::cpu_set_t>(), &set);
        }
    }
    #[cfg(not(target_os = "linux"))]
    let _ = cpus;
}

/// Pins the calling thread to `cpu` (a worker's start handler).
pub fn pin_current(cpu: usize) {
    set_current(&[cpu]);
    PINNED.with(|p| p.set(true));
}

/// What a thread started from this one should run on instead of inheriting this thread's
/// mask: the process's CPUs where this thread is a pinned worker, else `None` (inherit).
/// Taken by the pool builders before they start their workers, applied by
/// [`apply_spawn_mask`] in each worker's start handler.
pub fn spawn_mask() -> Option<Vec<usize>> {
    if PINNED.with(|p| p.get()) {
        process_cpus()
    } else {
        None
    }
}

/// Applies [`spawn_mask`]'s answer (taken in the creating thread) to the calling thread.
pub fn apply_spawn_mask(mask: &Option<Vec<usize>>) {
    if let Some(cpus) = mask {
        set_current(cpus);
    }
}

/// The calling thread's CPUs (its affinity mask), for tests.
#[cfg(all(test, target_os = "linux"))]
pub(crate) fn current() -> Option<Vec<usize>> {
    mask_of(0)
}

#[cfg(all(test, not(target_os = "linux")))]
pub(crate) fn current() -> Option<Vec<usize>> {
    None
}

#[cfg(test)]
mod tests {
    /// Pinned only for a pool of two threads or more that takes every allowed CPU, and not
    /// with the variable at `0` (any other value leaves pinning on).
    #[test]
    fn who_is_pinned() {
        use std::ffi::OsStr;
        let four = || Some(vec![0, 1, 4, 5]);
        assert_eq!(super::decide(4, None, four()), four());
        assert_eq!(super::decide(4, Some(OsStr::new("1")), four()), four());
        assert_eq!(super::decide(4, Some(OsStr::new("0")), four()), None);
        assert_eq!(super::decide(3, None, four()), None);
        assert_eq!(super::decide(5, None, four()), None);
        assert_eq!(super::decide(1, None, Some(vec![3])), None);
        assert_eq!(super::decide(2, None, None), None);
    }

    /// A pool of every CPU of the process pins worker `i` to the `i`-th of them (each worker
    /// then reports that one CPU as its mask), and the thread that made the pool keeps its
    /// mask; any other size pins nothing. Pools and threads a pinned worker starts get the
    /// process's CPUs back, not its one (as `bvh::mesh::build_deep`'s pool does).
    #[test]
    fn pools_of_every_cpu_pin_one_worker_to_each() {
        let Some(cpus) = super::process_cpus() else {
            println!("no affinity mask on this platform: nothing pinned");
            assert_eq!(super::plan(2), None);
            return;
        };
        let n = cpus.len();
        assert_eq!(super::plan(n + 1), None);
        assert_eq!(super::plan(1), None);
        if n < 2 {
            println!("one CPU: pools of one thread are never pinned");
            assert_eq!(super::plan(n), None);
            return;
        }
        assert_eq!(super::plan(n).as_deref(), Some(&cpus[..]));
        let pool = crate::threads::pool(n).unwrap();
        let masks = pool.broadcast(|_| super::current());
        let expect: Vec<Option<Vec<usize>>> = cpus.iter().map(|&c| Some(vec![c])).collect();
        assert_eq!(masks, expect);
        use rayon::prelude::*;
        let sum: u64 = pool.install(|| (0..100_000u64).into_par_iter().sum());
        assert_eq!(sum, 100_000 * 99_999 / 2);
        // The calling thread is not a worker: its mask is untouched.
        assert_eq!(super::current().as_deref(), Some(&cpus[..]));
        // From a pinned worker: a pool of fewer threads, and the deep build's pool.
        let (small, deep) = pool.install(|| {
            let small = crate::threads::pool(n - 1).unwrap();
            let small = small.broadcast(|_| super::current());
            let deep = crate::bvh::mesh::build_deep(|| rayon::broadcast(|_| super::current()));
            (small, deep)
        });
        assert!(
            small.iter().all(|m| m.as_deref() == Some(&cpus[..])),
            "{small:?}"
        );
        assert!(
            deep.iter().all(|m| m.as_deref() == Some(&cpus[..])),
            "{deep:?}"
        );
    }
}
