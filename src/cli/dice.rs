//! `limitray dice`: the diced limit surface as OBJ.

use super::args::{finish_output, load, open_output, DiceArgs, RuleArgs};
use crate::dice::{dice, DicedMesh};
use crate::error::Result;
use crate::mesh::obj::ObjWriter;
use crate::mesh::ControlMesh;
use crate::patch::PatchTable;
use std::io::Write;
use std::path::PathBuf;

/// Arguments of `limitray dice`.
#[derive(clap::Args, Clone, Debug)]
pub struct DiceCmd {
    /// OBJ file with OpenSubdiv tags.
    pub mesh: PathBuf,
    #[command(flatten)]
    pub rules: RuleArgs,
    #[command(flatten)]
    pub dice: DiceArgs,
    /// Output OBJ file ('-' for standard output).
    #[arg(short = 'o', long = "output")]
    pub output: PathBuf,
}

/// Runs `limitray dice`.
pub fn run(args: &DiceCmd) -> Result<()> {
    let out = open_output(&args.output)?;
    let m = load(&args.mesh)?;
    let (_, d) = dice_mesh(&m, args.rules.options(&m), &args.dice)?;
    finish_output(out, &args.output, |w| write_diced(w, &d))
}

/// Builds the patch table and dices `mesh` under `options`.
pub fn dice_mesh(
    mesh: &ControlMesh,
    options: crate::mesh::Options,
    args: &DiceArgs,
) -> Result<(PatchTable, DicedMesh)> {
    let table = table_for(mesh, options, args)?;
    let d = dice(&table, mesh, &args.options())?;
    Ok((table, d))
}

/// Builds the patch table and dices `mesh` under `options` straight into the grid core
/// ([`crate::grid::GridMesh::dice`]); returns the grid mesh with the number of triangles.
pub fn dice_grid(
    mesh: &ControlMesh,
    options: crate::mesh::Options,
    args: &DiceArgs,
) -> Result<(crate::grid::GridMesh, usize)> {
    let table = table_for(mesh, options, args)?;
    let grid = crate::grid::GridMesh::dice(&table, mesh, &args.options())?;
    let triangles = grid.triangles;
    Ok((grid, triangles))
}

/// The patch table of `mesh` under `options`, with a warning when the rate is above the
/// maximum rate.
fn table_for(
    mesh: &ControlMesh,
    options: crate::mesh::Options,
    args: &DiceArgs,
) -> Result<PatchTable> {
    let table = PatchTable::with_options(mesh, options, args.patch_options())?;
    if args.edge_length.is_none() && args.rate > args.max_rate.max(1) {
        eprintln!(
            "warning: rate {} is above --max-rate {}; {} segments per edge are used",
            args.rate,
            args.max_rate,
            args.max_rate.max(1)
        );
    }
    Ok(table)
}

/// Writes a diced mesh as OBJ: `v`, `vn`, `vt` (the vertex's `(u, v)` in its face, at the f32
/// precision of the diced vertices), and `f` with 1-based `v/vt/vn` indices.
pub fn write_diced<W: Write + ?Sized>(w: &mut W, d: &DicedMesh) -> std::io::Result<()> {
    let mut o = ObjWriter::new(w);
    o.comment(&format!(
        "limitray diced limit surface: {} vertices, {} triangles",
        d.positions.len(),
        d.triangles.len()
    ))?;
    o.vertices("v", &d.positions)?;
    o.vertices("vn", &d.normals)?;
    let uv: Vec<[f32; 2]> = d.params.iter().map(|p| [p.u as f32, p.v as f32]).collect();
    o.vertices("vt", &uv)?;
    let offsets: Vec<u32> = (0..=d.triangles.len() as u32).map(|i| 3 * i).collect();
    o.faces(&offsets, d.triangles.as_flattened(), true)
}
