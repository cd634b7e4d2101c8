//! One worker per CPU: a pool that takes every CPU the process may run on pins its workers,
//! one to each, so that a worker woken for a parallel stage wakes where it slept.
//!
//! Why: rayon's idle workers sleep within microseconds, and a sleeping worker woken for the
//! next parallel stage is placed by the kernel's scheduler. On a virtual machine that packs
//! woken threads onto busy vCPUs (measured here: a Firecracker guest booted with
//! `sched_vcpu_pack`), the woken worker queued behind the thread that woke it for 1.5–3 ms
//! after the process had idled 2 ms or more, where a parallel stage of a build lasts 0.1–10
//! ms. Pinned, it woke in 40–90 µs. Embree's TBB workers spin rather than sleep, which hides
//! the same delay.
//!
//! Only where it cannot crowd anything: Linux only, a pool of two threads or more whose size
//! is the number of CPUs in the process's affinity mask (a smaller pool, or a larger one, is
//! left to the scheduler). `LIMITRAY_PIN_THREADS=0` turns it off.

/// The CPUs the workers of a pool of `threads` are pinned to, in worker order: the process's
/// allowed CPUs when there are exactly `threads` of them (and `threads` ≥ 2) and pinning is
/// not turned off, else none.
pub fn plan(threads: usize) -> Option<Vec<usize>> {
    let setting = std::env::var_os("LIMITRAY_PIN_THREADS");
    decide(threads, setting.as_deref(), allowed())
}

/// [`plan`] given the variable's value and the allowed CPUs.
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

/// The CPUs this thread may run on (its affinity mask), in increasing order; `None` off
/// Linux or where the kernel does not say.
#[cfg(target_os = "linux")]
fn allowed() -> Option<Vec<usize>> {
    // SAFETY: `cpu_set_t` is plain bits (zero is the empty set); the kernel writes at most
    // its size, which is passed.
    let set = unsafe {
        let mut set: libc::cpu_set_t = std::mem::zeroed();
        if libc::sched_getaffinity(0, std::mem::size_of::<libc::cpu_set_t>(), &mut set) != 0 {
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

#[cfg(not(target_os = "linux"))]
fn allowed() -> Option<Vec<usize>> {
    None
}

/// Pins the calling thread to `cpu` (a worker's start handler). Only a request: where the
/// kernel refuses, the thread runs where the scheduler puts it, as unpinned.
pub fn pin_current(cpu: usize) {
    #[cfg(target_os = "linux")]
    {
        if cpu >= libc::CPU_SETSIZE as usize {
            return;
        }
        // SAFETY: as in `allowed`; `cpu` is below `CPU_SETSIZE`.
        unsafe {
            let mut set: libc::cpu_set_t = std::mem::zeroed();
            libc::CPU_SET(cpu, &mut set);
            libc::sched_setaffinity(0, std::mem::size_of::<libc::cpu_set_t>(), &set);
        }
    }
    #[cfg(not(target_os = "linux"))]
    let _ = cpu;
}

/// The calling thread's CPUs (its affinity mask), for tests; `None` as [`plan`] has it.
#[cfg(test)]
pub(crate) fn current() -> Option<Vec<usize>> {
    allowed()
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

    /// A pool of every allowed CPU pins worker `i` to the `i`-th of them (each worker then
    /// reports that one CPU as its mask), and the thread that made the pool keeps its mask;
    /// any other size pins nothing.
    #[test]
    fn pools_of_every_cpu_pin_one_worker_to_each() {
        let Some(cpus) = super::current() else {
            println!("no affinity mask on this platform: nothing pinned");
            assert_eq!(super::plan(2), None);
            return;
        };
        let n = cpus.len();
        assert_eq!(super::plan(n + 1), None);
        assert_eq!(super::plan(1), None);
        if n < 2 {
            println!("one allowed CPU: pools of one thread are never pinned");
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
    }
}
