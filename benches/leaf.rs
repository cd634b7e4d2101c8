//! Criterion benchmark of the grid core's leaf test ([`limitray::grid::window`]): one ray
//! against the eight triangles of a 3×3-vertex window, with the scalar reference, the SSE2
//! test (four lanes at a time) and the AVX2 test (eight lanes at once, where the processor
//! has it). The windows are jittered unit grids and the rays are aimed at points of the
//! window's footprint from random origins above and below it, as rays that pass a window's
//! box are: about half hit. `cargo bench --bench leaf` takes about half a minute.

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use limitray::bvh::triangle::PreparedRay;
use limitray::bvh::Ray;
use limitray::grid::window::{self, lane_mask, window_scalar, Rows, Window};
use limitray::harness::rng::SplitMix64;
use std::hint::black_box;
use std::time::Duration;

/// Window/ray pairs per iteration.
const PAIRS: usize = 4096;

fn leaf(c: &mut Criterion) {
    let mut rng = SplitMix64(5);
    let mut pairs = Vec::with_capacity(PAIRS);
    for i in 0..PAIRS {
        let mut w: Window = [[0f32; 9]; 3];
        for (k, grid) in [
            [0.0, 0.0],
            [1.0, 0.0],
            [2.0, 0.0],
            [0.0, 1.0],
            [1.0, 1.0],
            [2.0, 1.0],
            [0.0, 2.0],
            [1.0, 2.0],
            [2.0, 2.0],
        ]
        .into_iter()
        .enumerate()
        {
            let mut jitter = || ((rng.next_f64() - 0.5) * 0.6) as f32;
            w[0][k] = grid[0] + jitter();
            w[1][k] = grid[1] + jitter();
            w[2][k] = jitter();
        }
        let o = [
            ((rng.next_f64() - 0.5) * 8.0) as f32,
            ((rng.next_f64() - 0.5) * 8.0) as f32,
            ((rng.next_f64() + 0.2) * if i % 2 == 0 { -4.0 } else { 4.0 }) as f32,
        ];
        let target = [
            (rng.next_f64() * 2.4 - 0.2) as f32,
            (rng.next_f64() * 2.4 - 0.2) as f32,
            0.0,
        ];
        let d: [f32; 3] = std::array::from_fn(|a| target[a] - o[a]);
        let r = PreparedRay::new(&Ray::new(o, d)).expect("a non-zero direction");
        pairs.push((r, w, window::lone_coords(&w)));
    }
    let lanes = lane_mask(2, 2);
    let prepared: Vec<(PreparedRay, Window, Rows)> = pairs
        .iter()
        .map(|(r, w, coords)| (*r, *w, Rows::lone(coords)))
        .collect();

    let mut group = c.benchmark_group("leaf");
    group
        .sample_size(20)
        .warm_up_time(Duration::from_millis(500))
        .measurement_time(Duration::from_secs(3))
        .throughput(Throughput::Elements(PAIRS as u64));
    group.bench_function("scalar", |b| {
        b.iter(|| {
            prepared
                .iter()
                .filter(|(r, w, _)| window_scalar(r, w, lanes, f32::INFINITY).is_some())
                .count()
        })
    });
    group.bench_function("sse2", |b| {
        b.iter(|| {
            prepared
                .iter()
                .filter(|(r, _, rows)| {
                    // SAFETY: without AVX2 only the x86-64 baseline is used.
                    unsafe {
                        window::window_with::<false>(r, black_box(rows), lanes, f32::INFINITY)
                    }
                    .is_some()
                })
                .count()
        })
    });
    #[cfg(target_arch = "x86_64")]
    if window::has_avx2() {
        group.bench_function("avx2", |b| {
            b.iter(|| {
                prepared
                    .iter()
                    .filter(|(r, _, rows)| {
                        // SAFETY: AVX2 is present (detected).
                        unsafe {
                            window::window_with::<true>(r, black_box(rows), lanes, f32::INFINITY)
                        }
                        .is_some()
                    })
                    .count()
            })
        });
    } else {
        eprintln!("note: this processor has no AVX2; the avx2 leaf test is not measured");
    }
    group.finish();
}

criterion_group!(benches, leaf);
criterion_main!(benches);
