//! The `limitray` command-line tool (feature `cli`): one file per subcommand, the argument
//! groups they share in [`args`]. `src/main.rs` only calls [`main`]. This module is the tool's
//! implementation, not part of the library's API.

pub mod accuracy;
pub mod approx_error;
pub mod args;
pub mod bench_eval;
pub mod bench_refine;
pub mod bench_trace;
pub mod dice;
#[cfg(feature = "embree")]
pub mod embree;
pub mod eval;
#[cfg(feature = "gpu")]
pub mod gpu;
pub mod info;
pub mod refine;
#[cfg(feature = "render")]
pub mod render;
pub mod trace;

use crate::error::Result;
use clap::{Parser, Subcommand};
use std::process::ExitCode;

/// The command line.
#[derive(Parser)]
#[command(
    name = "limitray",
    version,
    about = "Exact Catmull-Clark limit surfaces: refine, evaluate, ray trace"
)]
pub struct Cli {
    /// The subcommand.
    #[command(subcommand)]
    pub command: Command,
    /// Memory budget (e.g. 8G, 512M): work whose estimated size is above it stops with an
    /// error before allocating (default: three quarters of physical memory).
    #[arg(long, global = true, value_parser = parse_memory)]
    pub memory_limit: Option<u64>,
}

fn parse_memory(s: &str) -> std::result::Result<u64, String> {
    crate::memory::parse_size(s).map_err(|e| e.message)
}

/// The subcommands.
#[derive(Subcommand)]
pub enum Command {
    /// Print a summary of a control mesh: counts, valences, tags, warnings.
    Info(info::InfoCmd),
    /// Uniformly refine a mesh and write level N as OBJ (quad faces).
    Refine(refine::RefineCmd),
    /// Evaluate the exact limit surface: stdin lines `face u v` or `face k u v`, stdout
    /// `x y z dux duy duz dvx dvy dvz`.
    Eval(eval::EvalCmd),
    /// Patch-table statistics as JSON (patch counts by type and level, memory).
    Stats(info::StatsCmd),
    /// Benchmark patch-table build and random evaluations (JSON line on stdout).
    BenchEval(bench_eval::BenchEvalArgs),
    /// Benchmark table building and application (JSON line on stdout).
    BenchRefine(bench_refine::RefineBenchArgs),
    /// Dice the limit surface into crack-free triangles and write them as OBJ.
    Dice(dice::DiceCmd),
    /// Trace rays: stdin lines `ox oy oz dx dy dz`, stdout `hit t face k u v nx ny nz` or `miss`.
    Trace(trace::TraceCmd),
    /// List the Vulkan adapters of the GPU backend (the automatic choice first).
    #[cfg(feature = "gpu")]
    GpuInfo,
    /// Benchmark primary-hit rays/s on the CPU and the GPU (JSON line on stdout).
    #[cfg(feature = "gpu")]
    BenchGpu(gpu::BenchGpuArgs),
    /// Benchmark dicing, BVH build and ray queries (JSON line on stdout).
    BenchTrace(bench_trace::TraceBenchArgs),
    /// Accuracy of diced hits against the exact limit surface, per rate (JSON lines).
    Accuracy(accuracy::AccuracyCmd),
    /// Distance of paper 002's approximations (pn, wm, gregory) to the exact Loop surface.
    ApproxError(approx_error::ApproxErrorCmd),
    /// Cross-check the limit surface and the triangle intersector against Embree 4.
    #[cfg(feature = "embree")]
    Crosscheck(embree::CrosscheckArgs),
    /// Side-by-side benchmark: limitray, Embree on the same triangles, Embree subdivision.
    #[cfg(feature = "embree")]
    Bench(embree::BenchArgs),
    /// Path trace a scene file to EXR (beauty + AOVs), optionally with a PNG preview.
    #[cfg(feature = "render")]
    Render(render::RenderArgs),
}

/// Runs one subcommand.
pub fn run(cli: Cli) -> Result<()> {
    match cli.command {
        Command::Info(a) => info::run_info(&a),
        Command::Refine(a) => refine::run(&a),
        Command::Eval(a) => eval::run_cmd(&a),
        Command::Stats(a) => info::run_stats(&a),
        Command::BenchEval(a) => bench_eval::run(&a),
        Command::BenchRefine(a) => bench_refine::run(&a),
        Command::Dice(a) => dice::run(&a),
        Command::Trace(a) => trace::run(&a),
        #[cfg(feature = "gpu")]
        Command::GpuInfo => {
            print!("{}", gpu::gpu_info()?);
            Ok(())
        }
        #[cfg(feature = "gpu")]
        Command::BenchGpu(a) => {
            println!("{}", gpu::bench_gpu(&a)?);
            Ok(())
        }
        Command::BenchTrace(a) => bench_trace::run(&a),
        Command::Accuracy(a) => accuracy::run(&a),
        Command::ApproxError(a) => approx_error::run(&a),
        #[cfg(feature = "embree")]
        Command::Crosscheck(a) => embree::run_crosscheck(&a),
        #[cfg(feature = "embree")]
        Command::Bench(a) => embree::run_bench(&a),
        #[cfg(feature = "render")]
        Command::Render(a) => render::run_cmd(&a),
    }
}

/// The tool's entry point: parses the command line, runs it, prints an error and exits 2 on
/// failure.
pub fn main() -> ExitCode {
    // Behave like other command-line tools when the reader of our output goes away
    // (`limitray info … | head`): end quietly on SIGPIPE instead of panicking in `println!`.
    #[cfg(unix)]
    // SAFETY: restoring the default disposition of SIGPIPE before any thread exists.
    unsafe {
        libc::signal(libc::SIGPIPE, libc::SIG_DFL);
    }
    let cli = Cli::parse();
    if let Some(bytes) = cli.memory_limit {
        crate::memory::set_limit(bytes);
    }
    match run(cli) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::from(2)
        }
    }
}
