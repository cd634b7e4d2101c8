//! The `limitray` command-line tool.

use clap::{Parser, Subcommand, ValueEnum};
use limitray::error::{Error, ErrorKind};
use limitray::io::output::Output;
use limitray::mesh::obj::{read_obj, write_obj};
use limitray::mesh::{BoundaryInterpolation, ControlMesh, CreaseMethod, Options};
use limitray::patch::{PatchOptions, PatchTable};
use limitray::refine::Refiner;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

#[derive(Parser)]
#[command(
    name = "limitray",
    version,
    about = "Exact Catmull-Clark limit surfaces: refine, evaluate, ray trace"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
    /// Memory budget (e.g. 8G, 512M): work whose estimated size is above it stops with an
    /// error before allocating (default: three quarters of physical memory).
    #[arg(long, global = true, value_parser = parse_memory)]
    memory_limit: Option<u64>,
}

fn parse_memory(s: &str) -> Result<u64, String> {
    limitray::memory::parse_size(s).map_err(|e| e.message)
}

#[derive(Clone, Copy, ValueEnum)]
enum Boundary {
    /// No boundary interpolation (boundary faces become holes).
    None,
    /// Boundary edges sharp, corners of one face smooth.
    Edge,
    /// Boundary edges sharp, corners of one face sharp.
    Corner,
}

#[derive(clap::Args)]
struct RuleArgs {
    /// Use Chaikin's crease rule instead of the uniform one.
    #[arg(long)]
    chaikin: bool,
    /// Boundary interpolation (default: the mesh's tag, else corner = edge-and-corner).
    #[arg(long, value_enum)]
    boundary: Option<Boundary>,
}

impl RuleArgs {
    fn options(&self, mesh: &ControlMesh) -> Options {
        let mut o = mesh.options;
        if self.chaikin {
            o.crease_method = CreaseMethod::Chaikin;
        }
        if let Some(b) = self.boundary {
            o.boundary = match b {
                Boundary::None => BoundaryInterpolation::None,
                Boundary::Edge => BoundaryInterpolation::EdgeOnly,
                Boundary::Corner => BoundaryInterpolation::EdgeAndCorner,
            };
        }
        o
    }
}

#[derive(Subcommand)]
enum Command {
    /// Print a summary of a control mesh: counts, valences, tags, warnings.
    Info {
        /// OBJ file with OpenSubdiv tags.
        mesh: PathBuf,
        #[command(flatten)]
        rules: RuleArgs,
    },
    /// Uniformly refine a mesh and write level N as OBJ (quad faces).
    Refine {
        /// OBJ file with OpenSubdiv tags.
        mesh: PathBuf,
        /// Number of refinement steps.
        #[arg(long, default_value_t = 1)]
        level: usize,
        #[command(flatten)]
        rules: RuleArgs,
        /// Output OBJ file ('-' for standard output).
        #[arg(short = 'o', long = "output")]
        output: PathBuf,
        /// Write the exact limit positions of the level's vertices instead of the level's
        /// control points.
        #[arg(long)]
        limit: bool,
    },
    /// Evaluate the exact limit surface: stdin lines `face u v` or `face k u v`, stdout
    /// `x y z dux duy duz dvx dvy dvz`.
    Eval {
        /// OBJ file with OpenSubdiv tags.
        mesh: PathBuf,
        #[command(flatten)]
        rules: RuleArgs,
        /// Maximum isolation level of the patch table.
        #[arg(long, default_value_t = limitray::patch::table::DEFAULT_MAX_LEVEL)]
        max_level: usize,
    },
    /// Patch-table statistics as JSON (patch counts by type and level, memory).
    Stats {
        /// OBJ file with OpenSubdiv tags.
        mesh: PathBuf,
        #[command(flatten)]
        rules: RuleArgs,
        /// Maximum isolation level.
        #[arg(long, default_value_t = limitray::patch::table::DEFAULT_MAX_LEVEL)]
        max_level: usize,
        /// Isolate semi-sharp creases by subdivision only (no single-crease patches).
        #[arg(long)]
        no_single_crease: bool,
        /// Override every crease's sharpness.
        #[arg(long)]
        sharpness: Option<f32>,
    },
    /// Benchmark patch-table build and random evaluations (JSON line on stdout).
    BenchEval {
        /// OBJ file with OpenSubdiv tags.
        mesh: PathBuf,
        /// Random samples per repetition.
        #[arg(long, default_value_t = 100_000)]
        samples: usize,
        /// Worker threads (0: all available).
        #[arg(long, default_value_t = 0)]
        threads: usize,
        /// Random seed.
        #[arg(long, default_value_t = 1)]
        seed: u64,
    },
    /// Benchmark table building and application (JSON line on stdout).
    BenchRefine(limitray::bench::RefineBenchArgs),
    /// Dice the limit surface into crack-free triangles and write them as OBJ.
    Dice {
        /// OBJ file with OpenSubdiv tags.
        mesh: PathBuf,
        #[command(flatten)]
        rules: RuleArgs,
        #[command(flatten)]
        dice: limitray::cli_trace::DiceArgs,
        /// Output OBJ file ('-' for standard output).
        #[arg(short = 'o', long = "output")]
        output: PathBuf,
    },
    /// Trace rays: stdin lines `ox oy oz dx dy dz`, stdout `hit t face k u v nx ny nz` or `miss`.
    Trace {
        /// OBJ file with OpenSubdiv tags.
        mesh: PathBuf,
        #[command(flatten)]
        rules: RuleArgs,
        #[command(flatten)]
        dice: limitray::cli_trace::DiceArgs,
        /// Refine each hit onto the exact limit surface (Newton, f64).
        #[arg(long)]
        exact: bool,
        #[command(flatten)]
        gpu: limitray::gpu::cli::BackendArgs,
    },
    /// List the Vulkan adapters of the GPU backend (the automatic choice first).
    GpuInfo,
    /// Benchmark primary-hit rays/s on the CPU and the GPU (JSON line on stdout).
    BenchGpu(limitray::gpu::cli::BenchGpuArgs),
    /// Benchmark dicing, BVH build and ray queries (JSON line on stdout).
    BenchTrace(limitray::cli_trace::TraceBenchArgs),
    /// Accuracy of diced hits against the exact limit surface, per rate (JSON lines).
    Accuracy {
        /// OBJ file with OpenSubdiv tags.
        mesh: PathBuf,
        #[command(flatten)]
        rules: RuleArgs,
        #[command(flatten)]
        dice: limitray::cli_trace::DiceArgs,
        /// Rates to measure.
        #[arg(long, value_delimiter = ',', default_value = "1,2,4,8,16,32,64")]
        rates: Vec<u32>,
        /// Random rays per rate.
        #[arg(long, default_value_t = 20_000)]
        rays: usize,
        /// Random seed.
        #[arg(long, default_value_t = 1)]
        seed: u64,
    },
    /// Cross-check the limit surface and the triangle intersector against Embree 4.
    #[cfg(feature = "embree")]
    Crosscheck(limitray::embree::cli::CrosscheckArgs),
    /// Side-by-side benchmark: limitray, Embree on the same triangles, Embree subdivision.
    #[cfg(feature = "embree")]
    Bench(limitray::embree::cli::BenchArgs),
    /// Path trace a scene file to EXR (beauty + AOVs), optionally with a PNG preview.
    Render(limitray::cli_render::RenderArgs),
}

fn load(path: &Path) -> Result<ControlMesh, Error> {
    let mesh = read_obj(path)?;
    for w in &mesh.warnings {
        eprintln!("warning: {w}");
    }
    Ok(mesh)
}

fn run(cli: Cli) -> Result<(), Error> {
    match cli.command {
        Command::Info { mesh, rules } => {
            let m = load(&mesh)?;
            let opts = rules.options(&m);
            let r = Refiner::with_options(&m, opts, 0)?;
            for w in &r.warnings {
                eprintln!("warning: {w}");
            }
            println!(
                "{}",
                limitray::info::summary(&mesh.display().to_string(), &m, &r.levels[0], &opts)
            );
            Ok(())
        }
        Command::Refine {
            mesh,
            level,
            rules,
            output,
            limit,
        } => {
            let mut out = Output::create(&output)?;
            let m = load(&mesh)?;
            let opts = rules.options(&m);
            let r = Refiner::with_options(&m, opts, level)?;
            for w in &r.warnings {
                eprintln!("warning: {w}");
            }
            let mut pos = r.refine_positions(&m.positions, level);
            let lvl = &r.levels[level];
            if limit {
                pos = limitray::refine::limit::limit_positions(lvl, &pos, opts.crease_method);
            }
            let mut offsets = vec![0u32];
            let mut verts = Vec::new();
            for f in 0..lvl.num_faces() {
                if !lvl.face_hole[f] {
                    verts.extend_from_slice(lvl.topo.face_vertices(f));
                    offsets.push(verts.len() as u32);
                }
            }
            let io_err = |e: std::io::Error| {
                Error::new(ErrorKind::Io, e.to_string()).in_file(output.display().to_string())
            };
            write_obj(&mut out, &pos, &offsets, &verts).map_err(io_err)?;
            out.commit()
        }
        Command::Eval {
            mesh,
            rules,
            max_level,
        } => {
            let m = load(&mesh)?;
            let opts = rules.options(&m);
            let table = PatchTable::with_options(
                &m,
                opts,
                PatchOptions {
                    max_level,
                    ..PatchOptions::default()
                },
            )?;
            limitray::cli_eval::run(&table, std::io::stdin().lock(), std::io::stdout().lock())
        }
        Command::Stats {
            mesh,
            rules,
            max_level,
            no_single_crease,
            sharpness,
        } => {
            let mut m = load(&mesh)?;
            if let Some(s) = sharpness {
                if s.is_nan() || s < 0.0 {
                    return Err(Error::new(
                        ErrorKind::Usage,
                        format!("--sharpness {s} must be ≥ 0"),
                    ));
                }
                for c in &mut m.creases {
                    c.sharpness = s;
                }
            }
            let opts = rules.options(&m);
            let t0 = std::time::Instant::now();
            let table = PatchTable::with_options(
                &m,
                opts,
                PatchOptions {
                    max_level,
                    single_crease: !no_single_crease,
                },
            )?;
            let ms = t0.elapsed().as_secs_f64() * 1e3;
            println!(
                "{}",
                limitray::info::patch_stats(&mesh.display().to_string(), &table, ms)
            );
            Ok(())
        }
        Command::BenchEval {
            mesh,
            samples,
            threads,
            seed,
        } => {
            let m = load(&mesh)?;
            let threads = if threads == 0 {
                std::thread::available_parallelism().map_or(1, |n| n.get())
            } else {
                threads
            };
            let v = limitray::bench::eval_bench(&m, samples, threads, seed)?;
            println!("{v}");
            Ok(())
        }
        Command::Render(args) => limitray::cli_render::run(&args).map(|_| ()),
        Command::BenchRefine(args) => {
            let line = limitray::bench::refine_bench(&args)?;
            println!("{line}");
            Ok(())
        }
        Command::Dice {
            mesh,
            rules,
            dice,
            output,
        } => {
            let mut out = Output::create(&output)?;
            let m = load(&mesh)?;
            let (_, d) = limitray::cli_trace::dice_mesh(&m, rules.options(&m), &dice)?;
            let io_err = |e: std::io::Error| {
                Error::new(ErrorKind::Io, e.to_string()).in_file(output.display().to_string())
            };
            limitray::cli_trace::write_diced(&mut out, &d).map_err(io_err)?;
            out.commit()
        }
        Command::Trace {
            mesh,
            rules,
            dice,
            exact,
            gpu,
        } => {
            let m = load(&mesh)?;
            let (table, d) = limitray::cli_trace::dice_mesh(&m, rules.options(&m), &dice)?;
            let bvh = limitray::bvh::MeshBvh::build(d);
            limitray::gpu::cli::trace(
                &bvh,
                &table,
                exact,
                &gpu,
                std::io::stdin().lock(),
                std::io::stdout().lock(),
            )
        }
        Command::GpuInfo => {
            print!("{}", limitray::gpu::cli::gpu_info()?);
            Ok(())
        }
        Command::BenchGpu(args) => {
            println!("{}", limitray::gpu::cli::bench_gpu(&args)?);
            Ok(())
        }
        Command::BenchTrace(args) => {
            println!("{}", limitray::cli_trace::trace_bench(&args)?);
            Ok(())
        }
        Command::Accuracy {
            mesh,
            rules,
            dice,
            rates,
            rays,
            seed,
        } => {
            let m = load(&mesh)?;
            for line in limitray::cli_trace::accuracy_table(
                &m,
                rules.options(&m),
                &dice,
                &rates,
                rays,
                seed,
            )? {
                println!("{line}");
            }
            Ok(())
        }
        #[cfg(feature = "embree")]
        Command::Crosscheck(args) => limitray::embree::cli::run_crosscheck(&args),
        #[cfg(feature = "embree")]
        Command::Bench(args) => limitray::embree::cli::run_bench(&args),
    }
}

fn main() -> ExitCode {
    // Behave like other command-line tools when the reader of our output goes away
    // (`limitray info … | head`): end quietly on SIGPIPE instead of panicking in `println!`.
    #[cfg(unix)]
    // SAFETY: restoring the default disposition of SIGPIPE before any thread exists.
    unsafe {
        libc::signal(libc::SIGPIPE, libc::SIG_DFL);
    }
    let cli = Cli::parse();
    if let Some(bytes) = cli.memory_limit {
        limitray::memory::set_limit(bytes);
    }
    match run(cli) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::from(2)
        }
    }
}
