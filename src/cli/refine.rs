//! `limitray refine`: uniform refinement to level N, written as OBJ.

use super::args::{finish_output, load, open_output, RuleArgs};
use crate::error::{Error, ErrorKind, Result};
use crate::mesh::obj::{write_obj, ObjWriter};
use crate::mesh::Scheme;
use crate::patch::LoopSurface;
use crate::refine::Refiner;
use std::path::PathBuf;

/// Arguments of `limitray refine`.
#[derive(clap::Args, Clone, Debug)]
pub struct RefineCmd {
    /// OBJ file with OpenSubdiv tags.
    pub mesh: PathBuf,
    /// Number of refinement steps.
    #[arg(long, default_value_t = 1)]
    pub level: usize,
    #[command(flatten)]
    pub rules: RuleArgs,
    /// Output OBJ file ('-' for standard output).
    #[arg(short = 'o', long = "output")]
    pub output: PathBuf,
    /// Write the exact limit positions of the level's vertices instead of the level's
    /// control points.
    #[arg(long)]
    pub limit: bool,
    /// Apply the hierarchical position edits that act on the written level itself. Without
    /// it, as in OpenSubdiv's Hbr, a level's points are written before that level's own
    /// edits, which take effect when it is refined further (and in the limit, `--limit`).
    #[arg(long)]
    pub level_edits: bool,
    /// Also refine the mesh's texture coordinates (face-varying, in the `--fvar` mode) and
    /// write them as `vt` lines, faces as `f v/vt …`.
    #[arg(long)]
    pub uv: bool,
}

/// Runs `limitray refine`.
pub fn run(args: &RefineCmd) -> Result<()> {
    let out = open_output(&args.output)?;
    let m = load(&args.mesh)?;
    let opts = args.rules.options(&m);
    let level = args.level;
    let r = Refiner::with_options(&m, opts, level)?;
    for w in &r.warnings {
        eprintln!("warning: {w}");
    }
    let mut pos = r.refine_positions_with(&m.positions, level, args.level_edits || args.limit);
    let lvl = &r.levels[level];
    let uvs = if args.uv {
        if args.limit {
            return Err(Error::new(
                ErrorKind::Usage,
                "--uv writes the refined texture coordinates of a level; it does not combine \
                 with --limit",
            ));
        }
        Some(
            r.refine_uvs(&m, level)
                .map_err(|e| e.in_file(args.mesh.display().to_string()))?,
        )
    } else {
        None
    };
    if args.limit {
        pos = match opts.scheme {
            Scheme::Catmark => crate::refine::limit::limit_positions(lvl, &pos, opts.crease_method),
            Scheme::Loop => LoopSurface::new(&m, opts)?.limit_positions(lvl, level, &pos)?,
        };
    }
    let mut offsets = vec![0u32];
    let mut verts = Vec::new();
    let mut corners = Vec::new();
    for f in 0..lvl.num_faces() {
        if !lvl.face_hole[f] {
            verts.extend_from_slice(lvl.topo.face_vertices(f));
            offsets.push(verts.len() as u32);
            if let Some(u) = &uvs {
                let o = lvl.topo.face_offsets[f] as usize;
                corners.extend_from_slice(&u.corners[o..o + lvl.topo.face_size(f)]);
            }
        }
    }
    finish_output(out, &args.output, |w| match &uvs {
        None => write_obj(w, &pos, &offsets, &verts),
        Some(u) => {
            let mut o = ObjWriter::new(w);
            o.vertices("v", &pos)?;
            o.vertices("vt", &u.values)?;
            o.faces_with_uvs(&offsets, &verts, &corners)
        }
    })
}
