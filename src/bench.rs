//! Benchmarks exposed through the command line (`limitray bench-refine`) and through
//! criterion (`benches/eval.rs`, which uses [`eval_bench`]'s building blocks).
//!
//! `limitray bench-refine` times the two halves of table-driven refinement, in the manner of
//! OpenSubdiv's reference program `benches/osd/osd_refine_bench.cpp` (whose `--grid N` mesh
//! [`crate::mesh::generate::grid`] reproduces), so that `scripts/bench-refine.sh` can put
//! the two side by side:
//!
//! - **table build**: [`Refiner::new`], i.e. topology analysis of the control mesh, every
//!   level's topology and tags, and one stencil table per level;
//! - **apply**: positions (`f64` × 3) from level 0 through every table to the requested level,
//!   into output buffers allocated (and touched) before timing, as the reference does.
//!
//! Each repetition builds everything anew; the reported times are medians over repetitions.
//!
//! [`eval_bench`] times exact limit-surface evaluation through a [`PatchTable`]: the table
//! build once, then batches of random `(face, k, u, v)` queries ([`eval_queries`]) evaluated in
//! parallel ([`eval_batch`]).

use crate::coord::FaceCoord;
use crate::error::{Error, ErrorKind, Result};
use crate::mesh::obj::read_obj;
use crate::mesh::{generate, ControlMesh, CreaseMethod};
use crate::patch::{PatchOptions, PatchTable};
use crate::refine::Refiner;
use rayon::prelude::*;
use std::path::PathBuf;
use std::time::Instant;

/// Arguments of `limitray bench-refine`.
#[derive(Clone, Debug, clap::Args)]
pub struct RefineBenchArgs {
    /// OBJ file to refine (or use --grid).
    #[arg(required_unless_present = "grid", conflicts_with = "grid")]
    pub mesh: Option<PathBuf>,
    /// Use an N x N grid of unit quads (OpenSubdiv reference benchmark's `--grid N`) instead
    /// of an OBJ file.
    #[arg(long, value_name = "N")]
    pub grid: Option<usize>,
    /// Refinement level.
    #[arg(long, default_value_t = 2)]
    pub level: usize,
    /// Worker threads (default: all available, or RAYON_NUM_THREADS).
    #[arg(long, value_name = "T")]
    pub threads: Option<usize>,
    /// Repetitions; times are medians over them.
    #[arg(long, default_value_t = 5, value_name = "R")]
    pub reps: usize,
    /// Use Chaikin's crease rule instead of the uniform one.
    #[arg(long)]
    pub chaikin: bool,
}

/// Runs the refinement benchmark and returns one JSON line with the fields `mesh`, `level`,
/// `threads`, `reps`, `crease_method`, `base_vertices`, `base_faces`, `refined_vertices`,
/// `refined_faces`, `table_build_ms`, `apply_ms`, `interpolate_ms` (like `apply_ms` but
/// through [`Refiner::interpolate`], which allocates its outputs), `vertices_per_s` (refined
/// vertices / apply time), `table_bytes` and `stencil_weights`. Times are in milliseconds.
pub fn refine_bench(args: &RefineBenchArgs) -> Result<String> {
    let usage = |m: String| Error::new(ErrorKind::Usage, m);
    if args.reps == 0 {
        return Err(usage("--reps must be at least 1".into()));
    }
    if args.threads == Some(0) {
        return Err(usage("--threads must be at least 1".into()));
    }
    let (name, mut mesh) = match (&args.mesh, args.grid) {
        (Some(path), None) => {
            let name = path.file_name().map_or_else(
                || path.display().to_string(),
                |n| n.to_string_lossy().into(),
            );
            (name, read_obj(path)?)
        }
        (None, Some(n)) => (format!("grid{n}"), generate::try_grid(n)?),
        _ => return Err(usage("give either a mesh file or --grid N".into())),
    };
    if args.chaikin {
        mesh.options.crease_method = CreaseMethod::Chaikin;
    }
    let pool = crate::threads::pool(args.threads.unwrap_or(0))?;
    let threads = pool.current_num_threads();
    let level = args.level;

    pool.install(|| {
        let base: &[f64] = mesh.positions.as_flattened();
        let mut t_build = Vec::with_capacity(args.reps);
        let mut t_apply = Vec::with_capacity(args.reps);
        let mut t_interp = Vec::with_capacity(args.reps);
        // bufs[l] holds level l + 1; allocated and touched at the first repetition.
        let mut bufs: Vec<Vec<f64>> = Vec::new();
        let mut stats = None;
        for _ in 0..args.reps {
            let t0 = Instant::now();
            let refiner = Refiner::new(&mesh, level)?;
            t_build.push(ms_since(t0));

            if bufs.is_empty() {
                bufs = refiner
                    .tables
                    .iter()
                    .map(|t| vec![1.0; t.len() * 3])
                    .collect();
            }
            let t0 = Instant::now();
            for (l, table) in refiner.tables.iter().enumerate() {
                let (done, rest) = bufs.split_at_mut(l);
                let src = done.last().map_or(base, |v| v.as_slice());
                table.apply_into(src, 3, &mut rest[0]);
            }
            t_apply.push(ms_since(t0));

            let t0 = Instant::now();
            let out = refiner.interpolate(base, 3, level);
            t_interp.push(ms_since(t0));
            if let Some(last) = bufs.last() {
                debug_assert!(*last == out, "apply paths disagree");
            }

            if stats.is_none() {
                let last = &refiner.levels[level];
                stats = Some((
                    last.num_vertices(),
                    last.num_faces(),
                    refiner.table_bytes(),
                    refiner
                        .tables
                        .iter()
                        .map(|t| t.weights.len())
                        .sum::<usize>(),
                ));
            }
            drop(out);
            drop(refiner);
        }
        let (refined_vertices, refined_faces, table_bytes, stencil_weights) =
            stats.expect("at least one repetition");
        let apply_ms = median(&mut t_apply);
        let line = serde_json::json!({
            "mesh": name,
            "level": level,
            "threads": threads,
            "reps": args.reps,
            "crease_method": match mesh.options.crease_method {
                CreaseMethod::Uniform => "uniform",
                CreaseMethod::Chaikin => "chaikin",
            },
            "base_vertices": mesh.num_vertices(),
            "base_faces": mesh.num_faces(),
            "refined_vertices": refined_vertices,
            "refined_faces": refined_faces,
            "table_build_ms": round4(median(&mut t_build)),
            "apply_ms": round4(apply_ms),
            "interpolate_ms": round4(median(&mut t_interp)),
            "vertices_per_s": if apply_ms > 0.0 {
                (refined_vertices as f64 / (apply_ms * 1e-3)).round()
            } else {
                0.0
            },
            "table_bytes": table_bytes,
            "stencil_weights": stencil_weights,
        });
        Ok(line.to_string())
    })
}

/// Repetitions of the timed evaluation batch in [`eval_bench`]; the median is reported.
pub const EVAL_REPS: usize = 5;

/// SplitMix64 (Steele, Lea and Flood 2014): a small, fast, deterministic generator, enough to
/// spread benchmark queries (not for statistics).
#[derive(Clone, Debug)]
pub struct SplitMix64(pub u64);

impl SplitMix64 {
    /// Next 64 random bits.
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }

    /// Uniform in `[0, 1)` (53 random bits).
    pub fn next_f64(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
    }

    /// Uniform in `0..n` (`n > 0`; multiply-shift, bias below 2^-32 for the sizes used here).
    pub fn below(&mut self, n: usize) -> usize {
        ((u128::from(self.next_u64()) * n as u128) >> 64) as usize
    }
}

/// `samples` random queries, deterministic in `seed`: the face uniform over the base faces
/// that are not holes, the sub-face uniform over that face's sub-faces, `u` and `v` uniform in
/// `[0, 1)`. A face counts as a hole when evaluating its centre fails (the table marks holes,
/// whether tagged or made by the boundary rule, as empty). Fails when every face is a hole.
pub fn eval_queries(table: &PatchTable, samples: usize, seed: u64) -> Result<Vec<FaceCoord>> {
    let faces: Vec<u32> = (0..table.num_faces())
        .filter(|&f| table.eval(FaceCoord::quad(f as u32, 0.5, 0.5)).is_ok())
        .map(|f| u32::try_from(f).expect("face index fits u32"))
        .collect();
    if faces.is_empty() && samples > 0 {
        return Err(Error::new(
            ErrorKind::Usage,
            "the mesh has no faces to evaluate (all are holes)",
        ));
    }
    let mut rng = SplitMix64(seed);
    Ok((0..samples)
        .map(|_| {
            let face = faces[rng.below(faces.len())];
            let k = rng.below(table.sub_faces(face as usize)) as u32;
            let u = rng.next_f64();
            let v = rng.next_f64();
            FaceCoord { face, k, u, v }
        })
        .collect())
}

/// Evaluates `queries` in parallel (rayon, in the current pool) and returns the limit
/// positions in query order.
pub fn eval_batch(table: &PatchTable, queries: &[FaceCoord]) -> Result<Vec<[f64; 3]>> {
    queries
        .par_iter()
        .map(|q| table.eval(*q).map(|s| s.p))
        .collect()
}

/// Sum of all coordinates: a checksum that keeps evaluated positions observable.
fn checksum(points: &[[f64; 3]]) -> f64 {
    points.iter().map(|p| p[0] + p[1] + p[2]).sum()
}

/// Benchmarks exact limit evaluation on `mesh`.
///
/// Builds the feature-adaptive [`PatchTable`] (default maximum level, single-crease patches;
/// timed once, in the calling thread), draws `samples` queries with [`eval_queries`] (seeded
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
        },
    )?;
    let build_ms = ms_since(t0);
    let queries = eval_queries(&table, samples, seed)?;
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
        "patches": table.patches.len(),
        "bytes": table.bytes(),
        "checksum": sum.unwrap_or(0.0),
    }))
}

/// Milliseconds elapsed since `t0`.
fn ms_since(t0: Instant) -> f64 {
    t0.elapsed().as_secs_f64() * 1e3
}

/// Median of `v` (mean of the two middle values for an even count); 0 when empty.
fn median(v: &mut [f64]) -> f64 {
    if v.is_empty() {
        return 0.0;
    }
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

/// Rounds to four decimals, as the reference program prints its times.
fn round4(x: f64) -> f64 {
    (x * 1e4).round() / 1e4
}

#[cfg(test)]
mod tests {
    use super::*;

    fn args(grid: usize, level: usize) -> RefineBenchArgs {
        RefineBenchArgs {
            mesh: None,
            grid: Some(grid),
            level,
            threads: Some(1),
            reps: 2,
            chaikin: false,
        }
    }

    #[test]
    fn grid_json() {
        let line = refine_bench(&args(4, 2)).unwrap();
        let v: serde_json::Value = serde_json::from_str(&line).unwrap();
        assert_eq!(v["mesh"], "grid4");
        assert_eq!(v["base_vertices"], 25);
        assert_eq!(v["base_faces"], 16);
        assert_eq!(v["refined_faces"], 256);
        assert_eq!(v["refined_vertices"], 17 * 17);
        assert_eq!(v["threads"], 1);
        assert!(v["table_bytes"].as_u64().unwrap() > 0);
        assert!(v["table_build_ms"].as_f64().unwrap() >= 0.0);
    }

    #[test]
    fn rejects_bad_args() {
        let mut a = args(2, 1);
        a.reps = 0;
        assert!(refine_bench(&a).is_err());
        let mut a = args(2, 1);
        a.grid = None;
        assert!(refine_bench(&a).is_err());
    }

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

    #[test]
    fn eval_queries_skip_holes_and_are_deterministic() {
        let mut mesh = generate::grid(4);
        mesh.holes = vec![5, 6];
        let table = PatchTable::new(&mesh, PatchOptions::default()).unwrap();
        let a = eval_queries(&table, 2000, 42).unwrap();
        assert_eq!(a, eval_queries(&table, 2000, 42).unwrap());
        assert_ne!(a, eval_queries(&table, 2000, 43).unwrap());
        let mut seen = [0usize; 16];
        for q in &a {
            assert!(q.face != 5 && q.face != 6, "query on a hole: {q:?}");
            assert_eq!(q.k, 0);
            assert!((0.0..1.0).contains(&q.u) && (0.0..1.0).contains(&q.v));
            seen[q.face as usize] += 1;
        }
        // Roughly uniform over the 14 other faces (2000 / 14 ≈ 143 each).
        assert!(seen
            .iter()
            .enumerate()
            .all(|(f, &n)| f == 5 || f == 6 || (80..220).contains(&n)));
        let points = eval_batch(&table, &a).unwrap();
        assert_eq!(points.len(), a.len());
        // All faces holes: nothing to sample.
        mesh.holes = (0..16).collect();
        let table = PatchTable::new(&mesh, PatchOptions::default()).unwrap();
        assert!(eval_queries(&table, 10, 1).is_err());
    }

    #[test]
    fn eval_queries_pentagon_sub_faces() {
        // A single pentagon has five sub-faces; all should be drawn.
        let pos = (0..5)
            .map(|i| {
                let a = i as f64 * std::f64::consts::TAU / 5.0;
                [a.cos(), a.sin(), 0.0]
            })
            .collect();
        let mesh = crate::mesh::MeshBuilder::new()
            .positions(pos)
            .faces(&[5], &[0, 1, 2, 3, 4])
            .build()
            .unwrap();
        let table = PatchTable::new(&mesh, PatchOptions::default()).unwrap();
        assert_eq!(table.sub_faces(0), 5);
        let q = eval_queries(&table, 500, 3).unwrap();
        let mut seen = [false; 5];
        for x in &q {
            seen[x.k as usize] = true;
        }
        assert!(seen.iter().all(|&s| s));
        assert_eq!(eval_batch(&table, &q).unwrap().len(), 500);
    }

    #[test]
    fn median_odd_even() {
        assert_eq!(median(&mut [3.0, 1.0, 2.0]), 2.0);
        assert_eq!(median(&mut [4.0, 1.0, 2.0, 3.0]), 2.5);
        assert_eq!(median(&mut []), 0.0);
    }
}
