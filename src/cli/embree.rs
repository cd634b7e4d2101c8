//! `limitray crosscheck` and `limitray bench` (feature `embree`).

use super::args::MeshSource;
use crate::embree::bench::{bench, BenchOptions};
use crate::embree::crosscheck::{crosscheck, EDGE_TOLERANCE, T_TOLERANCE};
use crate::error::{Error, ErrorKind, Result};

/// Arguments of `limitray crosscheck`.
#[derive(clap::Args, Debug)]
pub struct CrosscheckArgs {
    #[command(flatten)]
    pub source: MeshSource,
    /// Uniform rate: limitray's dicing rate and Embree's tessellation rate.
    #[arg(long, default_value_t = 16, value_name = "R")]
    pub rate: u32,
    /// Number of incoherent random rays (also the number of random parameter samples).
    #[arg(long, default_value_t = 100_000, value_name = "N")]
    pub rays: usize,
    /// Seed of the random rays.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Print JSON instead of the summary.
    #[arg(long)]
    pub json: bool,
}

/// Arguments of `limitray bench`.
#[derive(clap::Args, Debug)]
pub struct BenchArgs {
    #[command(flatten)]
    pub source: MeshSource,
    /// Uniform rate: limitray's dicing rate and Embree's tessellation rate.
    #[arg(long, default_value_t = 16, value_name = "R")]
    pub rate: u32,
    /// Rays per measurement (coherent camera rays and incoherent rays each).
    #[arg(long, default_value_t = 1_000_000, value_name = "N")]
    pub rays: usize,
    /// Worker threads (0: all available), for limitray and Embree alike.
    #[arg(long, default_value_t = 0, value_name = "T")]
    pub threads: usize,
    /// Repetitions; times are medians over them.
    #[arg(long, default_value_t = 3, value_name = "R")]
    pub reps: usize,
    /// Rays per leak count.
    #[arg(long, default_value_t = 100_000, value_name = "N")]
    pub leak_rays: usize,
    /// Seed of the random rays.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Print JSON instead of the table.
    #[arg(long)]
    pub json: bool,
    /// Displace both engines' surfaces by `noise:AMPLITUDE:FREQUENCY` (limitray's dicing and
    /// Embree's displacement callback evaluate the same noise at the limit point).
    #[arg(long, value_name = "SPEC")]
    pub displace: Option<String>,
    /// Build limitray's grid core for tracing alone, without the shading normals its hits
    /// interpolate (their shading normal is then the geometric one), as Embree's engines
    /// here give geometric normals only.
    #[arg(long)]
    pub no_shading_normals: bool,
}

/// Runs `limitray crosscheck`: prints the agreement figures (text, or JSON with `--json`).
pub fn run_crosscheck(args: &CrosscheckArgs) -> Result<()> {
    if args.rays == 0 {
        return Err(Error::new(ErrorKind::Usage, "--rays must be at least 1"));
    }
    let (name, mesh) = args.source.load()?;
    let r = crosscheck(&mesh, args.rate, args.rays, args.seed)?;
    if args.json {
        let mut v = r.json();
        v["mesh"] = serde_json::json!(name);
        println!("{v}");
        return Ok(());
    }
    let s = &r.surface;
    let i = &s.interpolation;
    let t = &r.triangles;
    println!(
        "{name}: rate {}, {} rays, Embree {}",
        r.rate, s.rays, r.embree_version
    );
    println!("surface (limitray diced + BVH vs Embree subdivision geometry, Chaikin creases):");
    println!(
        "  hit/miss agree {:.6} ({} of {}; limitray hits {}, Embree hits {}); same face {} of {} both-hit",
        s.agreement(),
        s.hit_miss_agree,
        s.rays,
        s.limitray_hits,
        s.embree_hits,
        s.same_face,
        s.dt.count
    );
    println!(
        "  |Δt| / diagonal: max {:.3e}, mean {:.3e} (tessellations differ within a micro-quad)",
        s.dt.max, s.dt.mean
    );
    println!(
        "  rtcInterpolate vs exact eval / diagonal: random params max {:.3e} mean {:.3e} at {:?}; at hits max {:.3e} mean {:.3e} at {:?}",
        i.params.max, i.params.mean, i.params.worst, i.hits.max, i.hits.mean, i.hits.worst
    );
    println!(
        "  Embree hit point vs exact limit point / diagonal: max {:.3e}, mean {:.3e}",
        i.hit_points.max, i.hit_points.mean
    );
    println!(
        "triangles (limitray BVH vs Embree on the same {} triangles):",
        t.triangles
    );
    println!(
        "  same triangle or both miss {:.6} ({} + {} + {} of {}); strict (|Δt| ≤ {:e} t) {:.6}",
        t.agreement(),
        t.same_hit,
        t.same_oblique,
        t.both_miss,
        t.rays,
        T_TOLERANCE,
        t.strict_agreement()
    );
    println!(
        "  max |Δt|/t same triangle {:.3e}; oblique {} (max |Δt| cosθ / t {:.3e}, max cosθ {:.3})",
        t.max_dt_same, t.same_oblique, t.max_dt_cos_oblique, t.max_cos_oblique
    );
    println!(
        "  disagreements: {} edge-grazing (within {:e} of an edge; max {:.3e}), {} other",
        t.edge_grazing, EDGE_TOLERANCE, t.max_edge_distance_grazing, t.other
    );
    Ok(())
}

/// Runs `limitray bench`: prints the side-by-side table (or JSON with `--json`).
pub fn run_bench(args: &BenchArgs) -> Result<()> {
    let (name, mesh) = args.source.load()?;
    let opts = BenchOptions {
        rate: args.rate,
        rays: args.rays,
        threads: args.threads,
        reps: args.reps,
        leak_rays: args.leak_rays,
        seed: args.seed,
        shading_normals: !args.no_shading_normals,
        displace: match &args.displace {
            None => None,
            Some(spec) => match crate::dice::Displacement::parse(spec) {
                Ok(crate::dice::Displacement::Noise {
                    amplitude,
                    frequency,
                }) => Some((amplitude, frequency)),
                Err(e) if spec.starts_with("noise:") => return Err(e),
                _ => {
                    return Err(Error::new(
                        ErrorKind::Usage,
                        format!(
                            "--displace {spec:?}: bench takes noise:AMPLITUDE:FREQUENCY only \
                             (Embree's side evaluates the noise in its displacement callback)"
                        ),
                    ))
                }
            },
        },
    };
    let r = bench(&mesh, &opts)?;
    if args.json {
        for mut v in r.json_lines() {
            v["mesh"] = serde_json::json!(name);
            println!("{v}");
        }
    } else {
        println!("{name}");
        print!("{}", r.table());
    }
    Ok(())
}
