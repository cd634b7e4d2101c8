//! Criterion benchmarks of table-driven refinement: building the stencil tables
//! ([`Refiner::new`], topology analysis included) and applying them to positions.
//!
//! Meshes: the generated 100 × 100 grid at level 2 and, when the shared OpenSubdiv models are
//! present, `catmark_car.obj` at level 3. Sample counts are kept small so that
//! `cargo bench --bench refine` takes about a minute; `limitray bench-refine` and
//! `scripts/bench-refine.sh` give the numbers compared with OpenSubdiv in BENCHMARKS.md.

use criterion::{
    criterion_group, criterion_main, BenchmarkId, Criterion, SamplingMode, Throughput,
};
use limitray::mesh::{generate, obj::read_obj, ControlMesh};
use limitray::refine::Refiner;
use std::hint::black_box;
use std::path::Path;
use std::time::Duration;

const CAR: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/../shared/models/opensubdiv/catmark_car.obj"
);

/// The meshes to run: name, mesh and level.
fn cases() -> Vec<(String, ControlMesh, usize)> {
    let mut cases = vec![("grid100".to_string(), generate::grid(100), 2)];
    let car = Path::new(CAR);
    if car.exists() {
        match read_obj(car) {
            Ok(mesh) => cases.push(("catmark_car".to_string(), mesh, 3)),
            Err(e) => eprintln!("skipping {CAR}: {e}"),
        }
    }
    cases
}

fn refine(c: &mut Criterion) {
    let mut group = c.benchmark_group("refine");
    group
        .sample_size(10)
        .sampling_mode(SamplingMode::Flat)
        .warm_up_time(Duration::from_millis(500))
        .measurement_time(Duration::from_secs(3));
    for (name, mesh, level) in cases() {
        let id = format!("{name}/L{level}");
        // Table build throughput counts control faces; apply throughput counts refined vertices.
        group.throughput(Throughput::Elements(mesh.num_faces() as u64));
        group.bench_with_input(BenchmarkId::new("table_build", &id), &mesh, |b, m| {
            b.iter(|| Refiner::new(black_box(m), level).unwrap())
        });

        let refiner = Refiner::new(&mesh, level).unwrap();
        let base: &[f64] = mesh.positions.as_flattened();
        // Output buffers of every level, allocated once: the apply timing excludes allocation.
        let mut bufs: Vec<Vec<f64>> = refiner
            .tables
            .iter()
            .map(|t| vec![0.0; t.len() * 3])
            .collect();
        let refined = refiner.levels[level].num_vertices() as u64;
        group.throughput(Throughput::Elements(refined));
        group.bench_function(BenchmarkId::new("apply", &id), |b| {
            b.iter(|| {
                for (l, table) in refiner.tables.iter().enumerate() {
                    let (done, rest) = bufs.split_at_mut(l);
                    let src = done.last().map_or(base, |v| v.as_slice());
                    table.apply_into(black_box(src), 3, &mut rest[0]);
                }
                black_box(bufs.last().map(|v| v[0]))
            })
        });
    }
    group.finish();
}

criterion_group!(benches, refine);
criterion_main!(benches);
