//! `limitray bench-trace`: patch table, dicing and grid-core build times, and ray queries per
//! second.

use super::args::{MeshSource, RuleArgs, SurfaceArg, ThreadArgs};
use crate::dice::{dice, DiceOptions, DiceRate};
use crate::error::Result;
use crate::grid::GridMesh;
use crate::harness::rays::{camera_rays, random_rays};
use crate::patch::{PatchOptions, PatchTable};
use rayon::prelude::*;

/// Options of `limitray bench-trace`.
#[derive(clap::Args, Clone, Debug)]
pub struct TraceBenchArgs {
    #[command(flatten)]
    pub source: MeshSource,
    /// Uniform dicing rate.
    #[arg(long, default_value_t = 4)]
    pub rate: u32,
    /// Rays per measurement (coherent and incoherent each).
    #[arg(long, default_value_t = 1_000_000)]
    pub rays: usize,
    #[command(flatten)]
    pub threads: ThreadArgs,
    /// Repetitions of each ray measurement; the median is reported. The build is measured
    /// once: the process's first (cold: its pages are all new) unless `--warm` builds first,
    /// where `limitray bench` reports the median of several builds in one process (warm) for
    /// both engines.
    #[arg(long, default_value_t = 5)]
    pub reps: usize,
    /// Builds made and dropped before the measured one, so that it runs warm (the allocator's
    /// memory already paged in), as `limitray bench` measures builds; its times and
    /// `--stages` are then those of a warm build.
    #[arg(long, default_value_t = 0)]
    pub warm: usize,
    /// Subdivision rules.
    #[command(flatten)]
    pub rules: RuleArgs,
    /// The surface of a Loop mesh: exact, or paper 002's pn, wm or gregory approximation.
    #[arg(long, value_enum, default_value_t = SurfaceArg::Exact)]
    pub surface: SurfaceArg,
    /// Measure the reference intersector (`trace --exact`) instead of the diced surface: the
    /// same rays (widened to f64), closest hits only; `--rate` then only picks the rays' box
    /// (the diced surface's at rate 1, as without `--exact`).
    #[arg(long)]
    pub exact: bool,
    /// Displace the diced surface (`noise:AMPLITUDE:FREQUENCY` or `map:FILE:SCALE`, as `dice`);
    /// the dicing time then includes the displacement.
    #[arg(long, value_parser = super::args::parse_displacement)]
    pub displace: Option<crate::dice::Displacement>,
    /// Also time the build stage by stage (`crate::stages`): `stages_ms`, a list of `[stage,
    /// milliseconds]` in the order the stages first ended (table, dicing, grid), which add up
    /// to the build's time but for the gaps between the named stages.
    #[arg(long)]
    pub stages: bool,
    /// Build the grid core for tracing alone, without shading normals (`GridMesh::
    /// dice_geometry`: hits then carry the geometric normal as their shading normal).
    #[arg(long)]
    pub no_shading_normals: bool,
}

/// Median of wall-clock seconds of `reps` runs of `f`.
fn median_secs(reps: usize, mut f: impl FnMut()) -> f64 {
    let mut times: Vec<f64> = (0..reps.max(1))
        .map(|_| {
            let t = std::time::Instant::now();
            f();
            t.elapsed().as_secs_f64()
        })
        .collect();
    times.sort_by(f64::total_cmp);
    times[times.len() / 2]
}

/// Rounds to `digits` decimals for the JSON report.
fn round(x: f64, digits: i32) -> f64 {
    let s = 10f64.powi(digits);
    (x * s).round() / s
}

/// Runs `limitray bench-trace`: dicing, grid build, and closest-hit rays/s, as one JSON line.
pub fn trace_bench(args: &TraceBenchArgs) -> Result<serde_json::Value> {
    let (_, mesh) = args.source.load()?;
    let threads = args.threads.count();
    if args.exact {
        if args.displace.is_some() {
            return Err(crate::error::Error::new(
                crate::error::ErrorKind::Usage,
                "--exact measures the exact limit surface, which --displace leaves: drop one",
            ));
        }
        if args.stages {
            return Err(crate::error::Error::new(
                crate::error::ErrorKind::Usage,
                "--stages times the diced build's stages, which --exact does not run: drop one",
            ));
        }
        return args
            .threads
            .pool()?
            .install(|| exact_bench(args, &mesh, threads));
    }
    args.threads.pool()?.install(|| {
        let build = || -> Result<_> {
            let t0 = std::time::Instant::now();
            let table = PatchTable::with_options(
                &mesh,
                args.rules.options(&mesh),
                PatchOptions {
                    surface: args.surface.into(),
                    ..PatchOptions::default()
                },
            )?;
            let t1 = std::time::Instant::now();
            // Dicing stores the blocks (`dice_ms`); the grid stage is the strips and the top
            // level (`grid_ms`).
            let (bvh, t2) = GridMesh::dice_staged(
                &table,
                &mesh,
                &DiceOptions {
                    rate: DiceRate::Uniform(args.rate),
                    max_rate: 1024,
                    displace: args.displace.clone(),
                },
                None,
                !args.no_shading_normals,
            )?;
            Ok((table, bvh, [t0, t1, t2, std::time::Instant::now()]))
        };
        for _ in 0..args.warm {
            drop(build()?);
        }
        let recording = args.stages.then(crate::stages::Recording::start);
        // The table stays alive while the rays run, as it did before `--warm`.
        let (_table, bvh, [t0, t1, t2, t3]) = build()?;
        let stages = recording.map(crate::stages::Recording::finish);
        let tris = bvh.triangles;
        let bounds = bvh.bounds();
        let ms =
            |a: std::time::Instant, b: std::time::Instant| round((b - a).as_secs_f64() * 1e3, 1);
        let mut out = serde_json::json!({
            "surface": crate::patch::approx::Approximation::from(args.surface).name(),
            "triangles": tris,
            "threads": threads,
            "warm": args.warm,
            "shading_normals": bvh.shading_normals,
            "table_ms": ms(t0, t1),
            "dice_ms": ms(t1, t2),
            "grid_ms": ms(t2, t3),
            "blocks": bvh.blocks.len(),
            "loose_triangles": bvh.loose.len(),
            "top_nodes": bvh.top.nodes.len(),
            "top_depth": bvh.top.depth,
            "top_stack": bvh.top.stack,
            "bytes_per_triangle": round(bvh.bytes() as f64 / tris.max(1) as f64, 1),
            "leaf_test": crate::grid::window::leaf_isa(),
        });
        if let Some(stages) = stages {
            out["stages_ms"] = stages
                .into_iter()
                .map(|(name, s)| serde_json::json!([name, round(s * 1e3, 2)]))
                .collect();
        }
        let sets = [
            ("coherent", camera_rays(bounds, args.rays)),
            ("incoherent", random_rays(bounds, args.rays, 11)),
        ];
        for (name, rays) in &sets {
            let mut hits = 0;
            let med = median_secs(args.reps, || {
                hits = rays
                    .par_iter()
                    .with_min_len(256)
                    .filter(|r| bvh.intersect(r).is_some())
                    .count();
            });
            out[format!("{name}_mrays_per_s")] = round(rays.len() as f64 / med / 1e6, 3).into();
            out[format!("{name}_hits")] = hits.into();
        }
        // Any-hit (shadow) queries on the incoherent rays.
        let rays = &sets[1].1;
        let med = median_secs(args.reps, || {
            let n = rays
                .par_iter()
                .with_min_len(256)
                .filter(|r| bvh.occluded(r))
                .count();
            std::hint::black_box(n);
        });
        out["incoherent_anyhit_mrays_per_s"] = round(rays.len() as f64 / med / 1e6, 3).into();
        Ok(out)
    })
}

/// `bench-trace --exact`: the reference intersector's build (patch table, pieces and their
/// hierarchy) and closest-hit rays/s on the rays the diced bench traces.
fn exact_bench(
    args: &TraceBenchArgs,
    mesh: &crate::mesh::ControlMesh,
    threads: usize,
) -> Result<serde_json::Value> {
    let options = args.rules.options(mesh);
    let t0 = std::time::Instant::now();
    let table = std::sync::Arc::new(PatchTable::with_options(
        mesh,
        options,
        PatchOptions {
            surface: args.surface.into(),
            ..PatchOptions::default()
        },
    )?);
    let t1 = std::time::Instant::now();
    let tracer = crate::exact::ExactTracer::new(table.clone(), mesh)?;
    let t2 = std::time::Instant::now();
    // The rays' box: the limit surface's, as the diced bench has it (dicing not timed).
    let coarse = dice(
        &table,
        mesh,
        &DiceOptions {
            rate: DiceRate::Uniform(1),
            max_rate: 1024,
            displace: None,
        },
    )?;
    let mut bounds = [[f32::INFINITY; 3], [f32::NEG_INFINITY; 3]];
    for p in &coarse.positions {
        for c in 0..3 {
            bounds[0][c] = bounds[0][c].min(p[c]);
            bounds[1][c] = bounds[1][c].max(p[c]);
        }
    }
    let ms = |a: std::time::Instant, b: std::time::Instant| round((b - a).as_secs_f64() * 1e3, 1);
    let mut out = serde_json::json!({
        "engine": "exact",
        "threads": threads,
        "table_ms": ms(t0, t1),
        "pieces_ms": ms(t1, t2),
        "pieces": tracer.num_pieces(),
    });
    for (name, rays) in [
        ("coherent", camera_rays(bounds, args.rays)),
        ("incoherent", random_rays(bounds, args.rays, 11)),
    ] {
        let rays: Vec<crate::bvh::Ray64> = rays.iter().map(|r| r.into()).collect();
        let mut hits = 0;
        let mut grazing = 0;
        let med = median_secs(args.reps, || {
            let answers: Vec<_> = rays
                .par_iter()
                .with_min_len(16)
                .map(|r| tracer.trace(r))
                .collect();
            hits = answers.iter().filter(|a| a.hit.is_some()).count();
            grazing = answers
                .iter()
                .filter(|a| a.graze.is_some() || a.hit.is_some_and(|h| h.grazing))
                .count();
        });
        out[format!("{name}_mrays_per_s")] = round(rays.len() as f64 / med / 1e6, 4).into();
        out[format!("{name}_hits")] = hits.into();
        out[format!("{name}_grazing")] = grazing.into();
    }
    Ok(out)
}

/// Runs `limitray bench-trace`: one JSON line on stdout.
pub fn run(args: &TraceBenchArgs) -> Result<()> {
    println!("{}", trace_bench(args)?);
    Ok(())
}
