//! Criterion benchmark of the grid core's octahedral normal encoding
//! ([`limitray::oct::oct_encode`] one by one, and [`limitray::oct::oct_encode_all`]
//! as the grid build calls it): 4096 random unit normals per iteration, as the grid build
//! encodes one per stored vertex. `cargo bench --bench encode` takes a few seconds.

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use limitray::harness::rng::SplitMix64;
use limitray::oct::{oct_encode, oct_encode_all};
use std::hint::black_box;
use std::time::Duration;

/// Normals per iteration.
const NORMALS: usize = 4096;

fn encode(c: &mut Criterion) {
    let mut rng = SplitMix64(9);
    let normals: Vec<[f32; 3]> = (0..NORMALS)
        .map(|_| {
            let n = [0; 3].map(|_| rng.next_f64() * 2.0 - 1.0);
            let l = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
            n.map(|x| (x / l) as f32)
        })
        .collect();
    let mut group = c.benchmark_group("oct_encode");
    group
        .throughput(Throughput::Elements(NORMALS as u64))
        .measurement_time(Duration::from_secs(3));
    group.bench_function("random_unit", |b| {
        b.iter(|| {
            let mut acc = 0u32;
            for &n in black_box(&normals) {
                acc ^= oct_encode(n);
            }
            acc
        })
    });
    group.bench_function("random_unit_batch", |b| {
        let mut codes = vec![0u32; NORMALS];
        b.iter(|| {
            oct_encode_all(black_box(&normals), &mut codes);
            codes[NORMALS - 1]
        })
    });
    group.finish();
}

criterion_group!(benches, encode);
criterion_main!(benches);
