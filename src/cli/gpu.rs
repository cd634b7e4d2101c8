//! `limitray gpu-info` and `limitray bench-gpu` (feature `gpu`).

use super::args::{DiceArgs, MeshSource};
use super::dice::dice_grid;
use crate::bvh::Ray;
use crate::error::{Error, ErrorKind, Result};
use crate::gpu::{GpuContext, GpuTracer, PackedScene, TraceOptions};
use crate::harness::rays::{camera_rays, random_rays};

/// `limitray gpu-info`: the Vulkan adapters, one per line, the automatic choice first.
pub fn gpu_info() -> Result<String> {
    let list = crate::gpu::adapters();
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
            crate::gpu::device::describe(a)
        ));
    }
    Ok(out)
}

/// Options of `limitray bench-gpu`.
#[derive(clap::Args, Clone, Debug)]
pub struct BenchGpuArgs {
    #[command(flatten)]
    pub source: MeshSource,
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
/// differ from the CPU's (triangle or bits of t). One JSON object.
pub fn bench_gpu(args: &BenchGpuArgs) -> Result<serde_json::Value> {
    let (_, mesh) = args.source.load()?;
    let dargs = DiceArgs {
        rate: args.rate,
        ..DiceArgs::default()
    };
    let (bvh, tris) = dice_grid(&mesh, mesh.options, &dargs)?;
    let ctx = GpuContext::new(args.adapter.as_deref())?;
    let tracer = GpuTracer::new(&ctx, PackedScene::from_mesh(&bvh)?, TraceOptions::default())?;
    let threads = args.threads.max(1);
    let pool = crate::harness::pool(threads)?;
    let bounds = bvh.bounds();
    let sets: [(&str, Vec<Ray>); 2] = [
        ("coherent", camera_rays(bounds, args.rays)),
        ("incoherent", random_rays(bounds, args.rays, 11)),
    ];
    let mut out = serde_json::json!({
        "triangles": tris,
        "cpu_threads": threads,
        "adapter": ctx.describe(),
    });
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
                Some(h) => g.status != 1 || g.leaf != h.leaf || g.t.to_bits() != h.t.to_bits(),
            })
            .count();
        out[*name] = serde_json::json!({
            "rays": rays.len(),
            "cpu_rays_per_s": (rays.len() as f64 / cpu_best).round(),
            "gpu_rays_per_s": (rays.len() as f64 / gpu_best).round(),
            "differ": differ,
        });
    }
    Ok(out)
}
