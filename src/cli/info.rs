//! `limitray info` (a JSON summary of a control mesh) and `limitray stats` (of its patch table).

use super::args::{load, RuleArgs};
use crate::error::{Error, ErrorKind, Result};
use crate::mesh::{ControlMesh, Options};
use crate::patch::{PatchOptions, PatchTable};
use crate::refine::{Level, Refiner};
use std::path::PathBuf;

/// Arguments of `limitray info`.
#[derive(clap::Args, Clone, Debug)]
pub struct InfoCmd {
    /// OBJ file with OpenSubdiv tags.
    pub mesh: PathBuf,
    #[command(flatten)]
    pub rules: RuleArgs,
}

/// Runs `limitray info`.
pub fn run_info(args: &InfoCmd) -> Result<()> {
    let m = load(&args.mesh)?;
    let opts = args.rules.options(&m);
    let r = Refiner::with_options(&m, opts, 0)?;
    for w in &r.warnings {
        eprintln!("warning: {w}");
    }
    println!(
        "{}",
        summary(&args.mesh.display().to_string(), &m, &r.levels[0], &opts)
    );
    Ok(())
}

/// Arguments of `limitray stats`.
#[derive(clap::Args, Clone, Debug)]
pub struct StatsCmd {
    /// OBJ file with OpenSubdiv tags.
    pub mesh: PathBuf,
    #[command(flatten)]
    pub rules: RuleArgs,
    /// Maximum isolation level.
    #[arg(long, default_value_t = crate::patch::table::DEFAULT_MAX_LEVEL)]
    pub max_level: usize,
    /// Isolate semi-sharp creases by subdivision only (no single-crease patches).
    #[arg(long)]
    pub no_single_crease: bool,
    /// Override every crease's sharpness.
    #[arg(long)]
    pub sharpness: Option<f32>,
}

/// Runs `limitray stats`.
pub fn run_stats(args: &StatsCmd) -> Result<()> {
    let mut m = load(&args.mesh)?;
    if let Some(s) = args.sharpness {
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
    let opts = args.rules.options(&m);
    let t0 = std::time::Instant::now();
    let table = PatchTable::with_options(
        &m,
        opts,
        PatchOptions {
            max_level: args.max_level,
            single_crease: !args.no_single_crease,
            ..PatchOptions::default()
        },
    )?;
    let ms = t0.elapsed().as_secs_f64() * 1e3;
    println!(
        "{}",
        patch_stats(&args.mesh.display().to_string(), &table, ms)
    );
    Ok(())
}

/// A JSON summary of a control mesh and its level-0 analysis.
pub fn summary(name: &str, mesh: &ControlMesh, level: &Level, options: &Options) -> String {
    let topo = &level.topo;
    let mut valence_hist = std::collections::BTreeMap::new();
    let mut max_valence = 0;
    for v in 0..topo.num_vertices {
        let n = topo.vertex_edges(v).len();
        max_valence = max_valence.max(n);
        *valence_hist.entry(n).or_insert(0usize) += 1;
    }
    let mut face_sizes = std::collections::BTreeMap::new();
    for f in 0..topo.num_faces() {
        *face_sizes.entry(topo.face_size(f)).or_insert(0usize) += 1;
    }
    let boundary = topo.vert_tags.iter().filter(|t| t.boundary).count();
    let nonmanifold = topo.vert_tags.iter().filter(|t| t.nonmanifold).count();
    let boundary_edges = (0..topo.num_edges())
        .filter(|&e| topo.edge_is_boundary(e as u32))
        .count();
    let nonmanifold_edges = topo.edge_nonmanifold.iter().filter(|&&b| b).count();
    let [lo, hi] = mesh.bounds();
    let v = serde_json::json!({
        "mesh": name,
        "vertices": topo.num_vertices,
        "faces": topo.num_faces(),
        "edges": topo.num_edges(),
        "face_sizes": face_sizes.iter().map(|(k, v)| (k.to_string(), serde_json::Value::from(*v))).collect::<serde_json::Map<_, _>>(),
        "valences": valence_hist.iter().map(|(k, v)| (k.to_string(), serde_json::Value::from(*v))).collect::<serde_json::Map<_, _>>(),
        "max_valence": max_valence,
        "boundary_vertices": boundary,
        "boundary_edges": boundary_edges,
        "nonmanifold_vertices": nonmanifold,
        "nonmanifold_edges": nonmanifold_edges,
        "creases": mesh.creases.len(),
        "corners": mesh.corners.len(),
        "hierarchical_edits": mesh.edits.len(),
        "holes": level.face_hole.iter().filter(|&&h| h).count(),
        "boundary_interpolation": format!("{:?}", options.boundary),
        "crease_method": format!("{:?}", options.crease_method),
        "scheme": options.scheme.name(),
        "bounds": [lo, hi],
        "warnings": mesh.warnings.len(),
    });
    serde_json::to_string_pretty(&v).unwrap_or_default()
}

/// A JSON summary of a patch table (`limitray stats`).
pub fn patch_stats(name: &str, table: &PatchTable, build_ms: f64) -> String {
    let mut by_kind = serde_json::Map::new();
    let mut by_level = serde_json::Map::new();
    let mut detail = serde_json::Map::new();
    for ((kind, level), &n) in &table.stats.by_kind_level {
        let e = by_kind
            .entry(kind.clone())
            .or_insert(serde_json::Value::from(0usize));
        *e = serde_json::Value::from(e.as_u64().unwrap_or(0) as usize + n);
        let e = by_level
            .entry(level.to_string())
            .or_insert(serde_json::Value::from(0usize));
        *e = serde_json::Value::from(e.as_u64().unwrap_or(0) as usize + n);
        detail.insert(format!("{kind}@{level}"), serde_json::Value::from(n));
    }
    let v = serde_json::json!({
        "mesh": name,
        "patches_total": table.patches.len(),
        "bytes_total": table.bytes(),
        "patches_by_type": by_kind,
        "patches_by_level": by_level,
        "patches_by_type_and_level": detail,
        "refined_vertices": table.stats.refined_vertices,
        "control_points": table.points.len(),
        "stencil_bytes": table.point_stencils.bytes(),
        "max_level": table.options.max_level,
        "single_crease": table.options.single_crease,
        "build_ms": build_ms,
    });
    serde_json::to_string_pretty(&v).unwrap_or_default()
}
