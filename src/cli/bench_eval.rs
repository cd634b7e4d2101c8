//! `limitray bench-eval`: exact limit evaluation through a [`PatchTable`] — the table build
//! once, then batches of random `(face, k, u, v)` queries ([`crate::harness::eval::eval_queries`]) evaluated in
//! parallel ([`eval_batch`]).

use super::args::{MeshSource, RuleArgs, SurfaceArg, ThreadArgs};
use super::bench_refine::{median, ms_since, round4};
use crate::error::{Error, ErrorKind, Result};
use crate::harness::eval::{eval_batch, eval_queries_near, Near};
use crate::mesh::ControlMesh;
use crate::patch::approx::Approximation;
use crate::patch::{PatchOptions, PatchTable};
use std::time::Instant;

/// Repetitions of the evaluation batch; the median is reported.
pub const EVAL_REPS: usize = 5;

/// Arguments of `limitray bench-eval`.
#[derive(clap::Args, Clone, Debug)]
pub struct BenchEvalArgs {
    /// OBJ file with OpenSubdiv tags.
    pub mesh: std::path::PathBuf,
    /// Random samples per repetition.
    #[arg(long, default_value_t = 100_000)]
    pub samples: usize,
    #[command(flatten)]
    pub threads: ThreadArgs,
    /// Random seed.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Query placement: uniform over the faces, at face centres, or within 2^-10 of an
    /// extraordinary vertex corner.
    #[arg(long, value_enum, default_value_t = Near::Uniform)]
    pub near: Near,
    /// Subdivision rules.
    #[command(flatten)]
    pub rules: RuleArgs,
    /// The surface of a Loop mesh: exact, or paper 002's pn, wm or gregory approximation.
    #[arg(long, value_enum, default_value_t = SurfaceArg::Exact)]
    pub surface: SurfaceArg,
}

/// Runs `limitray bench-eval`: one JSON line on stdout.
pub fn run(args: &BenchEvalArgs) -> Result<()> {
    let (_, m) = MeshSource {
        mesh: Some(args.mesh.clone()),
        grid: None,
    }
    .load()?;
    let mut m = m;
    m.options = args.rules.options(&m);
    let mut v = eval_bench_near(
        &m,
        args.samples,
        args.threads.count(),
        args.seed,
        args.near,
        args.surface.into(),
    )?;
    v["surface"] = crate::patch::approx::Approximation::from(args.surface)
        .name()
        .into();
    println!("{v}");
    Ok(())
}

/// Sum of all coordinates: a checksum that keeps evaluated positions observable.
fn checksum(points: &[[f64; 3]]) -> f64 {
    points.iter().map(|p| p[0] + p[1] + p[2]).sum()
}

/// Benchmarks exact limit evaluation on `mesh`.
///
/// Builds the feature-adaptive [`PatchTable`] (default maximum level, single-crease patches;
/// timed once, in the calling thread), draws `samples` queries with [`crate::harness::eval::eval_queries`] (seeded
/// by `seed`), then evaluates them [`EVAL_REPS`] times with [`eval_batch`] in a rayon pool of
/// `threads` threads. Returns a JSON object with `build_ms`, `eval_ms` (median batch time),
/// `evals_per_s` (`samples` / median batch time), `samples`, `threads`, `reps`, `seed`,
/// `patches`, `bytes` (table memory) and `checksum` (sum of all coordinates of the evaluated
/// positions, identical for every repetition and thread count).
pub fn eval_bench(
    mesh: &ControlMesh,
    samples: usize,
    threads: usize,
    seed: u64,
) -> Result<serde_json::Value> {
    eval_bench_near(
        mesh,
        samples,
        threads,
        seed,
        Near::Uniform,
        Approximation::Exact,
    )
}

/// [`eval_bench`] with the queries placed by `near` ([`eval_queries_near`]) on `surface`
/// (a Loop mesh's approximation, or exact); the JSON also has `near` (its name).
pub fn eval_bench_near(
    mesh: &ControlMesh,
    samples: usize,
    threads: usize,
    seed: u64,
    near: Near,
    surface: Approximation,
) -> Result<serde_json::Value> {
    let usage = |m: String| Error::new(ErrorKind::Usage, m);
    if samples == 0 {
        return Err(usage("samples must be at least 1".into()));
    }
    if threads == 0 {
        return Err(usage("threads must be at least 1".into()));
    }
    let t0 = Instant::now();
    let table = PatchTable::new(
        mesh,
        PatchOptions {
            max_level: crate::patch::table::DEFAULT_MAX_LEVEL,
            single_crease: true,
            surface,
        },
    )?;
    let build_ms = ms_since(t0);
    let queries = eval_queries_near(mesh, &table, samples, seed, near)?;
    let pool = crate::threads::pool(threads)?;

    let mut times = Vec::with_capacity(EVAL_REPS);
    let mut sum = None;
    for _ in 0..EVAL_REPS {
        let t0 = Instant::now();
        let points = pool.install(|| eval_batch(&table, &queries))?;
        times.push(ms_since(t0));
        let c = std::hint::black_box(checksum(&points));
        debug_assert!(sum.is_none_or(|s: f64| s.to_bits() == c.to_bits()));
        sum = Some(c);
    }
    let eval_ms = median(&mut times);
    Ok(serde_json::json!({
        "build_ms": round4(build_ms),
        "eval_ms": round4(eval_ms),
        "evals_per_s": if eval_ms > 0.0 {
            (samples as f64 / (eval_ms * 1e-3)).round()
        } else {
            0.0
        },
        "samples": samples,
        "threads": threads,
        "reps": EVAL_REPS,
        "seed": seed,
        "near": near.name(),
        "patches": table.patches.len(),
        "bytes": table.bytes(),
        "checksum": sum.unwrap_or(0.0),
    }))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::generate;

    #[test]
    fn eval_bench_grid() {
        let mesh = generate::grid(4);
        let v = eval_bench(&mesh, 1000, 2, 7).unwrap();
        assert_eq!(v["samples"], 1000);
        assert_eq!(v["threads"], 2);
        assert_eq!(v["reps"], EVAL_REPS);
        assert!(v["patches"].as_u64().unwrap() >= 16);
        assert!(v["bytes"].as_u64().unwrap() > 0);
        assert!(v["build_ms"].as_f64().unwrap() >= 0.0);
        assert!(v["evals_per_s"].as_f64().unwrap() > 0.0);
        // The grid's limit surface lies within the control hull: x, y in [0, 4], |z| <= 0.1.
        let c = v["checksum"].as_f64().unwrap();
        assert!(c.is_finite() && c > 0.0 && c < 1000.0 * 8.2);
        // Same seed, other thread count: same queries, same positions, same checksum.
        let w = eval_bench(&mesh, 1000, 1, 7).unwrap();
        assert_eq!(v["checksum"], w["checksum"]);
        assert!(eval_bench(&mesh, 0, 1, 7).is_err());
        assert!(eval_bench(&mesh, 10, 0, 7).is_err());
    }
}
