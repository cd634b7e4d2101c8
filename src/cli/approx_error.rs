//! `limitray approx-error`: how far paper 002's approximations of a Loop surface (or paper
//! 004's Gregory patches of a Catmull-Clark surface) are from the exact limit surface
//! ([`crate::harness::approx_error`]), one line per surface.

use super::args::{load, RuleArgs, SchemeArg, SurfaceArg, ThreadArgs};
use crate::error::{Error, ErrorKind, Result};
use crate::harness::approx_error::{ErrorOptions, Reference};
use crate::mesh::Scheme;
use crate::patch::approx::Approximation;
use crate::patch::{PatchOptions, PatchTable};
use std::path::PathBuf;

/// Arguments of `approx-error`.
#[derive(clap::Args, Clone, Debug)]
pub struct ApproxErrorCmd {
    /// OBJ control mesh.
    pub mesh: PathBuf,
    /// Subdivision rules (the scheme defaults to loop here: paper 002's approximations are
    /// Loop's; `--scheme catmark` measures paper 004's Gregory patches).
    #[command(flatten)]
    pub rules: RuleArgs,
    /// Surfaces to measure, comma-separated (default pn,wm,gregory under Loop, gregory under
    /// Catmull-Clark).
    #[arg(long, value_enum, value_delimiter = ',')]
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
    let surfaces: Vec<Approximation> = match (args.surface.is_empty(), options.scheme) {
        (false, _) => args.surface.iter().map(|&s| s.into()).collect(),
        (true, Scheme::Loop) => vec![Approximation::Pn, Approximation::Wm, Approximation::Gregory],
        (true, Scheme::Catmark) => vec![Approximation::Gregory],
    };
    if surfaces.contains(&Approximation::Exact) {
        return Err(Error::new(
            ErrorKind::Usage,
            "--surface lists approximations (pn, wm, gregory): the exact surface is the reference",
        ));
    }
    args.threads.pool()?.install(|| {
        let table = |surface| {
            PatchTable::with_options(
                &mesh,
                options,
                PatchOptions {
                    surface,
                    ..PatchOptions::default()
                },
            )
        };
        let exact = table(Approximation::Exact)?;
        let opts = ErrorOptions {
            samples: args.samples,
            seed: args.seed,
            tess: args.tess,
        };
        let reference = Reference::new(&exact, opts)?;
        if !args.json {
            println!(
                "{}: {} faces; distances relative to the bounding-box diagonal, {} points each way",
                args.mesh.display(),
                exact.num_faces(),
                args.samples
            );
            println!(
                "{:<8} {:>10} {:>10} {:>10} {:>12} {:>14}",
                "surface", "max", "mean", "rms", "max_reverse", "normal_max_deg"
            );
        }
        for &kind in &surfaces {
            let e = reference.measure(&table(kind)?)?;
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
