//! Measures how long a parallel stage waits for a sleeping worker: after the process idles
//! for a gap, a worker calls `rayon::join` on a 3 ms task and a task that records when it
//! starts; the start is the time the second worker took to wake and steal it (3 ms when it
//! never did). Run on a pool of every CPU as `limitray::threads::pool` makes it (pinned, one
//! worker per CPU, where it takes every CPU: see `limitray::affinity`) and on a plain rayon
//! pool of the same size:
//!
//!     cargo run --release --example wake_latency
//!
//! On this project's build machines (2 vCPUs, a guest kernel that packs woken threads onto
//! busy vCPUs) the plain pool's worker started after 1.2–2.5 ms (medians) once the process had
//! idled 2 ms or more, the pinned pool's after 30–100 µs.

use std::time::{Duration, Instant};

fn spin(d: Duration) {
    let t = Instant::now();
    while t.elapsed() < d {
        std::hint::spin_loop();
    }
}

/// Median and 90th percentile of the second task's start (µs) after each gap.
fn measure(pool: &rayon::ThreadPool, gaps_us: &[u64], rounds: usize) -> Vec<(u64, u64, u64)> {
    pool.install(|| {
        gaps_us
            .iter()
            .map(|&gap| {
                let mut starts: Vec<u64> = (0..rounds)
                    .map(|_| {
                        std::thread::sleep(Duration::from_micros(gap));
                        let t0 = Instant::now();
                        let (_, b) =
                            rayon::join(|| spin(Duration::from_millis(3)), || t0.elapsed());
                        b.as_micros() as u64
                    })
                    .collect();
                starts.sort_unstable();
                (gap, starts[rounds / 2], starts[rounds * 9 / 10])
            })
            .collect()
    })
}

fn main() {
    let n = std::thread::available_parallelism().map_or(1, |n| n.get());
    if n < 2 {
        println!("one CPU: no second worker to wake");
        return;
    }
    let gaps = [0, 1000, 2000, 10_000, 50_000];
    let pinned = limitray::threads::pool(n).expect("pool");
    let plain = rayon::ThreadPoolBuilder::new()
        .num_threads(n)
        .build()
        .expect("pool");
    println!("{n} workers; pinned: {:?}", limitray::affinity::plan(n));
    println!("gap µs | limitray::threads::pool med / p90 µs | plain rayon med / p90 µs");
    for _ in 0..2 {
        let a = measure(&pinned, &gaps, 30);
        let b = measure(&plain, &gaps, 30);
        for ((gap, am, a9), (_, bm, b9)) in a.into_iter().zip(b) {
            println!("{gap:>6} | {am:>6} / {a9:>6} | {bm:>6} / {b9:>6}");
        }
    }
}
