//! The `render` subcommand: scene file → EXR (beauty + AOVs) and an optional PNG preview.

use crate::error::{Error, ErrorKind, Result};
use crate::render::{read_scene, World};
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use std::path::PathBuf;
use std::time::Instant;

/// Which renderer runs the paths.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum Backend {
    /// The CPU path tracer (rayon).
    Cpu,
    /// The wgpu compute backend on a Vulkan adapter (`limitray::gpu`).
    Gpu,
}

/// Arguments of `limitray render`.
#[derive(Clone, Debug, clap::Args)]
pub struct RenderArgs {
    /// Scene file (TOML).
    pub scene: PathBuf,
    /// Output EXR file (RGBA + AOVs).
    #[arg(short = 'o', long = "output")]
    pub output: PathBuf,
    /// Also write a tone-mapped sRGB PNG preview.
    #[arg(long)]
    pub png: Option<PathBuf>,
    /// Also write the coloured-levels view: the patch level of each pixel's first hit as a
    /// colour (blue 0, green 1, yellow 2, orange 3, red 4, magenta 5, violet 6, white ≥ 7).
    #[arg(long)]
    pub levels_png: Option<PathBuf>,
    /// Samples per pixel (overrides the scene).
    #[arg(long)]
    pub spp: Option<u32>,
    /// Resolution WIDTHxHEIGHT (overrides the scene).
    #[arg(long, value_parser = parse_res)]
    pub res: Option<(u32, u32)>,
    /// Maximum path depth (overrides the scene).
    #[arg(long)]
    pub max_depth: Option<u32>,
    /// Random seed (overrides the scene).
    #[arg(long)]
    pub seed: Option<u32>,
    /// Worker threads (0: all available).
    #[arg(long, default_value_t = 0)]
    pub threads: usize,
    /// Renderer.
    #[arg(long, value_enum, default_value_t = Backend::Cpu)]
    pub backend: Backend,
    /// GPU adapter for `--backend gpu`: a case-insensitive substring of its name (default:
    /// $LIMITRAY_ADAPTER, else a real GPU before a CPU implementation).
    #[arg(long)]
    pub adapter: Option<String>,
    /// No progress bar and no summary on stderr.
    #[arg(long)]
    pub quiet: bool,
}

fn parse_res(s: &str) -> std::result::Result<(u32, u32), String> {
    let (w, h) = s
        .split_once(['x', 'X'])
        .ok_or_else(|| format!("expected WIDTHxHEIGHT, not '{s}'"))?;
    let w: u32 = w
        .trim()
        .parse()
        .map_err(|_| format!("bad width in '{s}'"))?;
    let h: u32 = h
        .trim()
        .parse()
        .map_err(|_| format!("bad height in '{s}'"))?;
    if !(1..=16384).contains(&w) || !(1..=16384).contains(&h) {
        return Err(format!("resolution {w}x{h} out of range 1..=16384"));
    }
    Ok((w, h))
}

/// What a render measured.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RenderReport {
    /// Load → patch tables → dice → BVH, seconds.
    pub first_pixel_s: f64,
    /// Path tracing, seconds.
    pub render_s: f64,
    /// Camera samples per second.
    pub samples_per_s: f64,
    /// Triangles in the scene.
    pub triangles: usize,
}

/// Runs `limitray render`.
pub fn run(args: &RenderArgs) -> Result<RenderReport> {
    if args.spp == Some(0) {
        return Err(Error::new(ErrorKind::Usage, "--spp must be at least 1"));
    }
    let mut builder = rayon::ThreadPoolBuilder::new();
    if args.threads > 0 {
        builder = builder.num_threads(args.threads);
    }
    let pool = builder
        .build()
        .map_err(|e| Error::new(ErrorKind::Usage, format!("thread pool: {e}")))?;
    pool.install(|| render_in_pool(args))
}

/// Fails early (before a long render) when an output file's folder does not exist.
fn check_output(path: &std::path::Path) -> Result<()> {
    match path.parent() {
        Some(dir) if !dir.as_os_str().is_empty() && !dir.is_dir() => Err(Error::new(
            ErrorKind::Io,
            format!("folder {} does not exist", dir.display()),
        )
        .in_file(path.display().to_string())),
        _ => Ok(()),
    }
}

fn render_in_pool(args: &RenderArgs) -> Result<RenderReport> {
    check_output(&args.output)?;
    for p in [&args.png, &args.levels_png].into_iter().flatten() {
        check_output(p)?;
    }
    let desc = read_scene(&args.scene)?;
    let mut settings = desc.render;
    if let Some(s) = args.spp {
        settings.spp = s;
    }
    if let Some((w, h)) = args.res {
        settings.width = w;
        settings.height = h;
    }
    if let Some(d) = args.max_depth {
        settings.max_depth = d;
    }
    if let Some(s) = args.seed {
        settings.seed = s;
    }
    let world = World::build(&desc, settings)?;
    let st = world.stats;
    if !args.quiet {
        eprintln!(
            "{}: {} triangles ({:.1} MiB); load {:.3} s, patches {:.3} s, dice {:.3} s, BVH {:.3} s: first pixel after {:.3} s",
            args.scene.display(),
            st.triangles,
            st.bytes as f64 / (1024.0 * 1024.0),
            st.load_s,
            st.patch_s,
            st.dice_s,
            st.bvh_s,
            st.total_s()
        );
    }
    let bar = if args.quiet {
        ProgressBar::hidden()
    } else {
        let b = ProgressBar::with_draw_target(None, ProgressDrawTarget::stderr());
        b.set_style(
            ProgressStyle::with_template(
                "{elapsed_precise} [{bar:40}] {percent:>3}% tiles {pos}/{len}, ETA {eta}",
            )
            .expect("static template")
            .progress_chars("=> "),
        );
        b
    };
    // GPU set-up (device, upload, kernel compilation) is not part of the render time.
    let gpu_ctx = match args.backend {
        Backend::Cpu => None,
        Backend::Gpu => Some(crate::gpu::GpuContext::new(args.adapter.as_deref())?),
    };
    let gpu = match &gpu_ctx {
        None => None,
        Some(ctx) => {
            let t = Instant::now();
            let g = crate::gpu::render::GpuRenderer::new(ctx, &world, None)?;
            if !args.quiet {
                eprintln!(
                    "GPU: {}; upload and kernels {:.2} s",
                    ctx.describe(),
                    t.elapsed().as_secs_f64()
                );
            }
            Some(g)
        }
    };
    let t0 = Instant::now();
    let film = match &gpu {
        None => world.render(&|n| {
            if bar.length().is_none() {
                bar.set_length(n as u64);
            }
            bar.inc(1);
        }),
        Some(g) => {
            bar.set_length(1000);
            g.render(&world, &|x| bar.set_position((x * 1000.0) as u64))?
        }
    };
    let render_s = t0.elapsed().as_secs_f64();
    bar.finish_and_clear();
    crate::render::output::write_film(&args.output, &film)?;
    if let Some(png) = &args.png {
        crate::render::output::write_preview(png, &film, settings.exposure)?;
    }
    if let Some(png) = &args.levels_png {
        crate::render::output::write_levels_preview(png, &film, settings.exposure)?;
    }
    let samples = settings.width as f64 * settings.height as f64 * settings.spp as f64;
    let report = RenderReport {
        first_pixel_s: st.total_s(),
        render_s,
        samples_per_s: samples / render_s.max(1e-9),
        triangles: st.triangles,
    };
    if !args.quiet {
        eprintln!(
            "rendered {}x{} at {} spp in {:.2} s ({:.0} samples/s); wrote {}",
            settings.width,
            settings.height,
            settings.spp,
            render_s,
            report.samples_per_s,
            args.output.display()
        );
    }
    Ok(report)
}
