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

use super::args::MeshSource;
use crate::error::{Error, ErrorKind, Result};
use crate::mesh::CreaseMethod;
use crate::refine::Refiner;
use std::time::Instant;

/// Arguments of `limitray bench-refine`.
#[derive(Clone, Debug, clap::Args)]
pub struct RefineBenchArgs {
    /// The mesh, or `--grid N` (OpenSubdiv's reference benchmark's N x N grid).
    #[command(flatten)]
    pub source: MeshSource,
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
    let (_, mut mesh) = args.source.load()?;
    let name = match (&args.source.mesh, args.source.grid) {
        (Some(path), _) => path.file_name().map_or_else(
            || path.display().to_string(),
            |n| n.to_string_lossy().into(),
        ),
        (None, n) => format!("grid{}", n.unwrap_or(0)),
    };
    if args.chaikin {
        mesh.options.crease_method = CreaseMethod::Chaikin;
    }
    let pool = crate::harness::pool(args.threads.unwrap_or(0))?;
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

/// Milliseconds elapsed since `t0`.
pub(crate) fn ms_since(t0: Instant) -> f64 {
    t0.elapsed().as_secs_f64() * 1e3
}

/// Median of `v` (mean of the two middle values for an even count); 0 when empty.
pub(crate) fn median(v: &mut [f64]) -> f64 {
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
pub(crate) fn round4(x: f64) -> f64 {
    (x * 1e4).round() / 1e4
}

/// Runs `limitray bench-refine`: one JSON line on stdout.
pub fn run(args: &RefineBenchArgs) -> Result<()> {
    println!("{}", refine_bench(args)?);
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn args(grid: usize, level: usize) -> RefineBenchArgs {
        RefineBenchArgs {
            source: MeshSource {
                mesh: None,
                grid: Some(grid),
            },
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
        a.source.grid = None;
        assert!(refine_bench(&a).is_err());
    }

    #[test]
    fn median_odd_even() {
        assert_eq!(median(&mut [3.0, 1.0, 2.0]), 2.0);
        assert_eq!(median(&mut [4.0, 1.0, 2.0, 3.0]), 2.5);
        assert_eq!(median(&mut []), 0.0);
    }
}
