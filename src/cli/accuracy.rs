//! `limitray accuracy`: the distance of diced hits from the reference intersector's exact first
//! hits on the same rays, per rate.

use super::args::{load, DiceArgs, RuleArgs};
use crate::bvh::MeshBvh;
use crate::dice::dice;
use crate::error::Result;
use crate::exact::ExactTracer;
use crate::mesh::ControlMesh;
use crate::patch::PatchTable;
use std::path::PathBuf;

/// Arguments of `limitray accuracy`.
#[derive(clap::Args, Clone, Debug)]
pub struct AccuracyCmd {
    /// OBJ file with OpenSubdiv tags.
    pub mesh: PathBuf,
    #[command(flatten)]
    pub rules: RuleArgs,
    #[command(flatten)]
    pub dice: DiceArgs,
    /// Rates to measure.
    #[arg(long, value_delimiter = ',', default_value = "1,2,4,8,16,32,64")]
    pub rates: Vec<u32>,
    /// Random rays per rate.
    #[arg(long, default_value_t = 20_000)]
    pub rays: usize,
    /// Random seed.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
}

/// Runs `limitray accuracy`: one JSON line per rate.
pub fn run(args: &AccuracyCmd) -> Result<()> {
    let m = load(&args.mesh)?;
    for line in accuracy_table(
        &m,
        args.rules.options(&m),
        &args.dice,
        &args.rates,
        args.rays,
        args.seed,
    )? {
        println!("{line}");
    }
    Ok(())
}

/// One row of the accuracy table per rate, as JSON lines.
pub fn accuracy_table(
    mesh: &ControlMesh,
    options: crate::mesh::Options,
    args: &DiceArgs,
    rates: &[u32],
    rays: usize,
    seed: u64,
) -> Result<Vec<String>> {
    let diag = mesh.diagonal();
    let table = std::sync::Arc::new(PatchTable::with_options(
        mesh,
        options,
        args.patch_options(),
    )?);
    let exact = ExactTracer::new(table.clone(), mesh)?;
    let mut out = Vec::new();
    for &r in rates {
        let a = DiceArgs {
            rate: r,
            edge_length: None,
            ..args.clone()
        };
        if r > args.max_rate.max(1) {
            eprintln!(
                "warning: rate {r} is above --max-rate {}; {} segments per edge are used",
                args.max_rate,
                args.max_rate.max(1)
            );
        }
        let d = dice(&table, mesh, &a.options())?;
        let tris = d.triangles.len();
        let bvh = MeshBvh::build(d);
        let acc = crate::harness::probe::accuracy(&exact, &bvh, rays, seed);
        let v = serde_json::json!({
            "rate": r,
            "rate_used": r.min(args.max_rate.max(1)),
            "triangles": tris,
            "rays": acc.samples,
            "disagree": acc.disagree,
            "grazing": acc.grazing,
            "max_surface_rel": significant(acc.max_surface / diag),
            "mean_surface_rel": significant(acc.mean_surface / diag),
            "max_param_rel": significant(acc.max_param / diag),
            "mean_param_rel": significant(acc.mean_param / diag),
            "max_bound_ratio": significant(acc.max_bound_ratio),
        });
        out.push(v.to_string());
    }
    Ok(out)
}

/// `x` to 4 significant digits; non-finite values (no sample) become JSON `null`.
fn significant(x: f64) -> serde_json::Value {
    if !x.is_finite() {
        return serde_json::Value::Null;
    }
    format!("{x:.3e}")
        .parse::<f64>()
        .map_or(serde_json::Value::Null, serde_json::Value::from)
}
