//! The `render` subcommand: scene file → EXR (beauty + AOVs) and an optional PNG preview.

use crate::error::{Error, ErrorKind, Result};
use crate::io::output::Output;
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
    /// Output EXR file (RGBA + AOVs); '-' for standard output. Written to a temporary file
    /// and renamed over the target when complete; checked before the render starts.
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
    /// The surface of the scene's meshes (overrides their `surface` key): exact, or paper
    /// 002's pn, wm or gregory approximation of Loop meshes; exact and gregory (paper 004's
    /// Gregory patches) apply to Catmull-Clark meshes too.
    #[arg(long, value_enum)]
    pub surface: Option<super::args::SurfaceArg>,
    /// Displace every mesh of the scene along its limit normal (overrides their `displace`
    /// key): `noise:AMPLITUDE:FREQUENCY`, in each mesh's object space.
    #[arg(long, value_parser = super::args::parse_displacement)]
    pub displace: Option<crate::dice::Displacement>,
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
    let max = crate::render::scene::MAX_RESOLUTION;
    if !(1..=max).contains(&w) || !(1..=max).contains(&h) {
        return Err(format!("resolution {w}x{h} out of range 1..={max}"));
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
    use crate::render::scene::{MAX_DEPTH, MAX_SPP};
    if let Some(s) = args.spp.filter(|s| !(1..=MAX_SPP).contains(s)) {
        return Err(Error::new(
            ErrorKind::Usage,
            format!("--spp {s} is outside 1..={MAX_SPP} (the scene's render.spp range)"),
        ));
    }
    if let Some(d) = args.max_depth.filter(|&d| d > MAX_DEPTH) {
        return Err(Error::new(
            ErrorKind::Usage,
            format!("--max-depth {d} is above {MAX_DEPTH} (the scene's render.max_depth range)"),
        ));
    }
    let pool = crate::harness::pool(args.threads)?;
    pool.install(|| render_in_pool(args))
}

fn render_in_pool(args: &RenderArgs) -> Result<RenderReport> {
    // Every output path is checked (and its temporary file made) before any work.
    let paths: Vec<&PathBuf> = std::iter::once(&args.output)
        .chain(args.png.iter())
        .chain(args.levels_png.iter())
        .collect();
    if paths.iter().filter(|p| p.as_os_str() == "-").count() > 1 {
        return Err(Error::new(
            ErrorKind::Usage,
            "only one output can be standard output ('-')",
        ));
    }
    format_matches(&args.output, "EXR", &["exr"])?;
    for p in args.png.iter().chain(args.levels_png.iter()) {
        format_matches(p, "PNG", &["png"])?;
    }
    let mut exr_out = Output::create(&args.output)?;
    let mut png_out = args.png.as_deref().map(Output::create).transpose()?;
    let mut levels_out = args.levels_png.as_deref().map(Output::create).transpose()?;
    let mut desc = read_scene(&args.scene)?;
    if let Some(s) = args.surface {
        let s: crate::patch::approx::Approximation = s.into();
        let catmark_too = matches!(
            s,
            crate::patch::approx::Approximation::Exact
                | crate::patch::approx::Approximation::Gregory
        );
        for m in desc
            .meshes
            .iter_mut()
            .filter(|m| catmark_too || m.scheme == crate::mesh::Scheme::Loop)
        {
            m.surface = s;
        }
    }
    if let Some(d) = &args.displace {
        for m in &mut desc.meshes {
            m.displace = Some(d.clone());
        }
    }
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
    for w in &world.warnings {
        eprintln!("warning: {w}");
    }
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
    #[cfg(feature = "gpu")]
    let gpu_ctx = match args.backend {
        Backend::Cpu => None,
        Backend::Gpu => Some(crate::gpu::GpuContext::new(args.adapter.as_deref())?),
    };
    #[cfg(feature = "gpu")]
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
    #[cfg(not(feature = "gpu"))]
    if args.backend == Backend::Gpu {
        return Err(Error::new(
            ErrorKind::Usage,
            "this limitray was built without the `gpu` feature",
        ));
    }
    let progress = |n: usize| {
        if bar.length().is_none() {
            bar.set_length(n as u64);
        }
        bar.inc(1);
    };
    let t0 = Instant::now();
    #[cfg(feature = "gpu")]
    let film = match &gpu {
        None => world.render(&progress),
        Some(g) => {
            bar.set_length(1000);
            g.render(&world, &|x| bar.set_position((x * 1000.0) as u64))?
        }
    };
    #[cfg(not(feature = "gpu"))]
    let film = world.render(&progress);
    let render_s = t0.elapsed().as_secs_f64();
    bar.finish_and_clear();
    crate::render::output::write_film_to(&mut exr_out, &film)?;
    if let Some(out) = &mut png_out {
        crate::render::output::write_preview_to(out, &film, settings.exposure)?;
    }
    if let Some(out) = &mut levels_out {
        crate::render::output::write_levels_preview_to(out, &film, settings.exposure)?;
    }
    exr_out.commit()?;
    for out in [png_out, levels_out].into_iter().flatten() {
        out.commit()?;
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

/// Runs `limitray render`, discarding the report.
/// Extensions of image formats a user may type by mistake; an output named with one of them
/// (other than its own) is refused before any work, since the file would hold another format.
const IMAGE_EXTENSIONS: &[&str] = &[
    "exr", "png", "jpg", "jpeg", "tif", "tiff", "hdr", "bmp", "tga", "ppm", "pfm", "webp", "gif",
];

/// Refuses `path` when its extension names an image format other than `allowed` (no
/// extension, standard output and unknown extensions are accepted).
fn format_matches(path: &std::path::Path, format: &str, allowed: &[&str]) -> Result<()> {
    let Some(ext) = path.extension().and_then(|e| e.to_str()) else {
        return Ok(());
    };
    let ext = ext.to_ascii_lowercase();
    if IMAGE_EXTENSIONS.contains(&ext.as_str()) && !allowed.contains(&ext.as_str()) {
        return Err(Error::new(
            ErrorKind::Usage,
            format!(
                "{}: this output is written as {format}, but its extension .{ext} names another format",
                path.display()
            ),
        ));
    }
    Ok(())
}

pub fn run_cmd(args: &RenderArgs) -> Result<()> {
    run(args).map(|_| ())
}
