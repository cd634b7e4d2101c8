//! `limitray approx-error`: how far paper 002's approximations of a Loop surface are from the
//! exact limit surface ([`crate::harness::approx_error`]), one line per surface.

use super::args::{load, RuleArgs, SchemeArg, SurfaceArg, ThreadArgs};
use crate::error::{Error, ErrorKind, Result};
use crate::harness::approx_error::{ErrorOptions, Reference};
use crate::mesh::Scheme;
use crate::patch::approx::{Approximation, TriApprox};
use crate::patch::LoopSurface;
use std::path::PathBuf;

/// Arguments of `approx-error`.
#[derive(clap::Args, Clone, Debug)]
pub struct ApproxErrorCmd {
    /// OBJ control mesh (triangles).
    pub mesh: PathBuf,
    /// Subdivision rules (the scheme defaults to loop here: the approximations are Loop's).
    #[command(flatten)]
    pub rules: RuleArgs,
    /// Surfaces to measure, comma-separated.
    #[arg(
        long,
        value_enum,
        value_delimiter = ',',
        default_value = "pn,wm,gregory"
    )]
    pub surface: Vec<SurfaceArg>,
    /// Points drawn on each surface (each direction).
    #[arg(long, default_value_t = 100_000)]
    pub samples: usize,
    /// Random seed.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Segments per triangle edge of the tessellations that seed the projections.
    #[arg(long, default_value_t = 8)]
    pub tess: usize,
    /// One JSON object per surface and line instead of a table.
    #[arg(long)]
    pub json: bool,
    /// Worker threads.
    #[command(flatten)]
    pub threads: ThreadArgs,
}

/// Runs `approx-error`.
pub fn run(args: &ApproxErrorCmd) -> Result<()> {
    if args.tess == 0 || args.tess > 64 {
        return Err(Error::new(ErrorKind::Usage, "--tess must be in 1..=64"));
    }
    if args.samples == 0 || args.samples > 100_000_000 {
        return Err(Error::new(
            ErrorKind::Usage,
            "--samples must be in 1..=100000000",
        ));
    }
    let mesh = load(&args.mesh)?;
    let mut rules = args.rules.clone();
    rules.scheme.get_or_insert(SchemeArg::Loop);
    let options = rules.options(&mesh);
    if options.scheme != Scheme::Loop {
        return Err(Error::new(
            ErrorKind::Usage,
            "approx-error measures paper 002's approximations of Loop surfaces: use --scheme loop",
        ));
    }
    args.threads.pool()?.install(|| {
        let exact = LoopSurface::new(&mesh, options)?;
        let opts = ErrorOptions {
            samples: args.samples,
            seed: args.seed,
            tess: args.tess,
        };
        let reference = Reference::new(&exact, opts)?;
        if !args.json {
            println!(
                "{}: {} triangles; distances relative to the bounding-box diagonal, {} points each way",
                args.mesh.display(),
                exact.num_faces(),
                args.samples
            );
            println!(
                "{:<8} {:>10} {:>10} {:>10} {:>12} {:>14}",
                "surface", "max", "mean", "rms", "max_reverse", "normal_max_deg"
            );
        }
        for &s in &args.surface {
            let kind: Approximation = s.into();
            if kind == Approximation::Exact {
                return Err(Error::new(
                    ErrorKind::Usage,
                    "--surface lists approximations (pn, wm, gregory): the exact surface is the reference",
                ));
            }
            let approx = TriApprox::new(&exact, kind)?;
            let e = reference.measure(&approx)?;
            if args.json {
                println!("{}", e.json());
            } else {
                println!(
                    "{:<8} {:>10.3e} {:>10.3e} {:>10.3e} {:>12.3e} {:>14.3}",
                    kind.name(),
                    e.max,
                    e.mean,
                    e.rms,
                    e.max_reverse,
                    e.normal_max_deg
                );
            }
        }
        Ok(())
    })
}
