//! Command-line pieces of the GPU backend: `--backend cpu|gpu` and `--adapter NAME`,
//! `limitray gpu-info`, `limitray trace --backend gpu` and `limitray bench-gpu`.

use super::{GpuContext, GpuTracer, PackedScene, TraceOptions};
use crate::bvh::{MeshBvh, Ray};
use crate::error::{Error, ErrorKind, Result};
use crate::patch::PatchTable;
use std::io::{BufRead, Write};

/// Where rays are traced.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, clap::ValueEnum)]
pub enum Backend {
    /// The CPU (rayon).
    #[default]
    Cpu,
    /// A Vulkan adapter through wgpu (lavapipe on machines without a GPU).
    Gpu,
}

/// Backend options of the command line.
#[derive(clap::Args, Clone, Debug, Default)]
pub struct BackendArgs {
    /// Trace on the CPU or on a Vulkan adapter (wgpu compute).
    #[arg(long, value_enum, default_value_t = Backend::Cpu)]
    pub backend: Backend,
    /// GPU adapter: a case-insensitive substring of its name (default: $LIMITRAY_ADAPTER,
    /// else a real GPU before a CPU implementation). `limitray gpu-info` lists them.
    #[arg(long)]
    pub adapter: Option<String>,
}

/// `limitray gpu-info`: the Vulkan adapters, one per line, the automatic choice first.
pub fn gpu_info() -> Result<String> {
    let list = super::adapters();
    if list.is_empty() {
        return Err(Error::new(
            ErrorKind::Gpu,
            "no Vulkan adapter found (on Debian: bash scripts/setup-lavapipe.sh)",
        ));
    }
    let mut out = String::new();
    for (i, a) in list.iter().enumerate() {
        out.push_str(&format!(
            "{}{}\n",
            if i == 0 { "* " } else { "  " },
            super::device::describe(a)
        ));
    }
    Ok(out)
}

/// `limitray trace` on the chosen backend: the same lines as the CPU path.
pub fn trace(
    bvh: &MeshBvh,
    table: &PatchTable,
    exact: bool,
    backend: &BackendArgs,
    input: impl BufRead,
    output: impl Write,
) -> Result<()> {
    match backend.backend {
        Backend::Cpu => crate::cli_trace::trace(bvh, table, exact, input, output),
        Backend::Gpu => {
            let ctx = GpuContext::new(backend.adapter.as_deref())?;
            crate::cli_trace::trace_with(table, exact, input, output, |rays| {
                super::trace_mesh(&ctx, bvh, rays, TraceOptions::default())
            })
        }
    }
}

/// Options of `limitray bench-gpu`.
#[derive(clap::Args, Clone, Debug)]
pub struct BenchGpuArgs {
    /// OBJ file with OpenSubdiv tags (or `--grid N`).
    pub mesh: Option<std::path::PathBuf>,
    /// Use the generated N×N grid instead of a file.
    #[arg(long)]
    pub grid: Option<usize>,
    /// Uniform dicing rate.
    #[arg(long, default_value_t = 4)]
    pub rate: u32,
    /// Rays per measurement (coherent and incoherent each).
    #[arg(long, default_value_t = 262_144)]
    pub rays: usize,
    /// CPU worker threads.
    #[arg(long, default_value_t = 2)]
    pub threads: usize,
    /// Repetitions; the best is reported.
    #[arg(long, default_value_t = 3)]
    pub reps: usize,
    /// GPU adapter (substring of its name).
    #[arg(long)]
    pub adapter: Option<String>,
}

/// `limitray bench-gpu`: primary-hit rays/s on the CPU and on the GPU, and how many GPU hits
/// differ from the CPU's (triangle or bits of t). One JSON line.
pub fn bench_gpu(args: &BenchGpuArgs) -> Result<String> {
    let mesh = match (&args.mesh, args.grid) {
        (Some(p), _) => crate::mesh::obj::read_obj(p)?,
        (None, Some(n)) => crate::mesh::generate::try_grid(n)?,
        (None, None) => {
            return Err(Error::new(
                ErrorKind::Usage,
                "bench-gpu needs a mesh file or --grid N",
            ))
        }
    };
    let dargs = crate::cli_trace::DiceArgs {
        rate: args.rate,
        edge_length: None,
        max_rate: 256,
        max_level: crate::patch::table::DEFAULT_MAX_LEVEL,
    };
    let (_, d) = crate::cli_trace::dice_mesh(&mesh, mesh.options, &dargs)?;
    let tris = d.triangles.len();
    let bvh = MeshBvh::build(d);
    let ctx = GpuContext::new(args.adapter.as_deref())?;
    let tracer = GpuTracer::new(&ctx, PackedScene::from_mesh(&bvh)?, TraceOptions::default())?;
    let pool = crate::threads::pool(args.threads.max(1))?;
    let bounds = bvh.bounds();
    let sets: [(&str, Vec<Ray>); 2] = [
        ("coherent", crate::cli_trace::camera_rays(bounds, args.rays)),
        (
            "incoherent",
            crate::cli_trace::random_rays(bounds, args.rays, 11),
        ),
    ];
    let mut fields = vec![
        format!("\"triangles\":{tris}"),
        format!("\"cpu_threads\":{}", args.threads.max(1)),
        format!("\"adapter\":{:?}", ctx.describe()),
    ];
    for (name, rays) in &sets {
        let mut cpu_best = f64::INFINITY;
        let mut gpu_best = f64::INFINITY;
        let mut cpu_hits = Vec::new();
        let mut gpu_hits = Vec::new();
        for _ in 0..args.reps.max(1) {
            let t0 = std::time::Instant::now();
            cpu_hits = pool.install(|| bvh.intersect_batch(rays));
            cpu_best = cpu_best.min(t0.elapsed().as_secs_f64());
            let t0 = std::time::Instant::now();
            gpu_hits = tracer.trace_raw(rays)?;
            gpu_best = gpu_best.min(t0.elapsed().as_secs_f64());
        }
        let differ = cpu_hits
            .iter()
            .zip(&gpu_hits)
            .filter(|(c, g)| match c {
                None => g.status != 0,
                Some(h) => {
                    g.status != 1
                        || bvh.tri_index[g.leaf as usize] != h.triangle
                        || g.t.to_bits() != h.t.to_bits()
                }
            })
            .count();
        fields.push(format!(
            "\"{name}\":{{\"rays\":{},\"cpu_rays_per_s\":{:.0},\"gpu_rays_per_s\":{:.0},\"differ\":{differ}}}",
            rays.len(),
            rays.len() as f64 / cpu_best,
            rays.len() as f64 / gpu_best
        ));
    }
    Ok(format!("{{{}}}", fields.join(",")))
}
