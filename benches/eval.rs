//! Criterion benchmarks of exact limit evaluation through the patch table: building the
//! feature-adaptive [`PatchTable`] (default options: maximum level 10, single-crease patches)
//! and evaluating batches of 10,000 random `(face, k, u, v)` queries in rayon pools of 1 and 2
//! threads ([`limitray::harness::eval::eval_queries`], [`limitray::harness::eval::eval_batch`], the pieces of
//! `limitray bench-eval`).
//!
//! `lattice_p`: one bicubic B-spline patch's interior lattice at rates 4, 16 and 64, positions
//! alone ([`limitray::patch::bspline::eval_lattice_p`], what dicing a regular face without
//! normals runs), and with first derivatives ([`limitray::patch::bspline::eval_lattice`], with
//! normals), per lattice.
//!
//! Mesh: OpenSubdiv's `catmark_car.obj` from the shared models; without it the benchmark
//! prints a note and measures nothing. Sample counts are small so that `cargo bench --bench
//! eval` takes about a minute after building; `scripts/bench-eval.sh` runs it and prints the
//! medians.

use criterion::{
    criterion_group, criterion_main, BenchmarkId, Criterion, SamplingMode, Throughput,
};
use limitray::harness::eval::{eval_batch, eval_queries};
use limitray::mesh::obj::read_obj;
use limitray::patch::{PatchOptions, PatchTable};
use std::hint::black_box;
use std::path::Path;
use std::time::Duration;

const CAR: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/../shared/models/opensubdiv/catmark_car.obj"
);

/// Queries per iteration of the evaluation benchmark.
const SAMPLES: usize = 10_000;

/// The interior lattice of one patch (a fixed, non-planar control grid) at several rates.
fn lattice(c: &mut Criterion) {
    let cp: limitray::patch::bspline::ControlGrid = std::array::from_fn(|i| {
        let (x, y) = ((i % 4) as f64, (i / 4) as f64);
        [x, y, 0.25 * (x * y).sin() + 0.1 * x]
    });
    let mut group = c.benchmark_group("lattice_p");
    group
        .sample_size(20)
        .warm_up_time(Duration::from_millis(300))
        .measurement_time(Duration::from_secs(2));
    for rate in [4u32, 16, 64] {
        group.throughput(Throughput::Elements(((rate - 1) * (rate - 1)) as u64));
        group.bench_function(BenchmarkId::from_parameter(rate), |b| {
            b.iter(|| {
                let mut sum = 0.0;
                limitray::patch::bspline::eval_lattice_p(black_box(&cp), rate, rate, |p| {
                    sum += p[0] + p[1] + p[2]
                });
                black_box(sum)
            })
        });
        group.bench_function(BenchmarkId::new("d1", rate), |b| {
            b.iter(|| {
                let mut sum = 0.0;
                limitray::patch::bspline::eval_lattice(black_box(&cp), rate, rate, |p| {
                    sum += p.p[0] + p.du[1] + p.dv[2]
                });
                black_box(sum)
            })
        });
    }
    group.finish();
}

fn eval(c: &mut Criterion) {
    let car = Path::new(CAR);
    if !car.exists() {
        eprintln!("note: {CAR} not found; skipping the eval benchmark");
        return;
    }
    let mesh = match read_obj(car) {
        Ok(m) => m,
        Err(e) => {
            eprintln!("note: cannot read {CAR} ({e}); skipping the eval benchmark");
            return;
        }
    };
    let opts = PatchOptions::default();

    let mut group = c.benchmark_group("eval");
    group
        .sample_size(10)
        .sampling_mode(SamplingMode::Flat)
        .warm_up_time(Duration::from_millis(500))
        .measurement_time(Duration::from_secs(4));

    group.throughput(Throughput::Elements(mesh.num_faces() as u64));
    group.bench_function(BenchmarkId::new("table_build", "catmark_car"), |b| {
        b.iter(|| PatchTable::new(black_box(&mesh), opts).unwrap())
    });

    let table = PatchTable::new(&mesh, opts).unwrap();
    let queries = eval_queries(&table, SAMPLES, 0x5eed).unwrap();
    group.throughput(Throughput::Elements(SAMPLES as u64));
    for threads in [1, 2] {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        group.bench_function(
            BenchmarkId::new("eval_10k", format!("catmark_car/{threads}T")),
            |b| {
                b.iter(|| {
                    let points = pool.install(|| eval_batch(&table, black_box(&queries)).unwrap());
                    black_box(points.iter().map(|p| p[0] + p[1] + p[2]).sum::<f64>())
                })
            },
        );
    }
    group.finish();
}

criterion_group!(benches, lattice, eval);
criterion_main!(benches);
