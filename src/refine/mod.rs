//! Table-driven Catmull-Clark refinement (paper 001 §3.1–3.2, paper 004 §3) and Loop
//! refinement (paper 002 §2, [`loop_step`]).
//!
//! [`Refiner::new`] analyses topology and tags once and builds one [`StencilTable`] per level;
//! applying the tables to positions or any other primvar is a separate parallel step, so an
//! animated mesh re-poses without re-analysis.

mod child_topology;
pub mod crease;
pub mod edit;
pub mod fvar;
pub mod fvar_mesh;
pub mod level;
pub mod limit;
pub mod loop_rules;
pub mod loop_step;
pub mod rules;
pub mod stencil;
pub mod step;

pub use level::Level;
pub use stencil::{Real, StencilTable};

use crate::error::{Error, ErrorKind, Result};
use crate::mesh::{ControlMesh, CreaseMethod, Options, Scheme};

/// Deepest uniform refinement the refiner accepts (each level has four times the faces).
pub const MAX_LEVEL: usize = 12;

/// Bytes of topology, tags and sharpness per face of a refined (all-quad, mostly valence-4)
/// level: face, edge and vertex adjacency (152: about 38 `u32`s per face with two edges and
/// one vertex per face) and per-element tags (13).
const LEVEL_BYTES_PER_FACE: f64 = 165.0;
/// Bytes of the stencil table that makes a level, per face of that level: 6.25 terms of 12
/// bytes and one row offset of 4 bytes per vertex (one vertex per face).
const STENCIL_BYTES_PER_FACE: f64 = 79.0;
/// Allowance for vectors grown by doubling while a level is built.
const GROWTH: f64 = 1.5;
/// Bytes per vertex of the positions computed from the tables (two levels at a time, `f64`).
const POSITION_BYTES_PER_FACE: f64 = 48.0;

/// Upper estimate of the memory a [`Refiner`] to `max_level` and the positions of its last
/// level take: level `l ≥ 1` has `4^(l-1)` quads per base face-vertex.
pub fn estimate_bytes(mesh: &ControlMesh, max_level: usize) -> f64 {
    let quads1 = mesh.face_verts.len() as f64;
    let mut total = quads1 * LEVEL_BYTES_PER_FACE;
    let mut faces = quads1;
    for _ in 1..=max_level {
        total += faces * (LEVEL_BYTES_PER_FACE + STENCIL_BYTES_PER_FACE) * GROWTH;
        faces *= 4.0;
    }
    total + faces / 4.0 * POSITION_BYTES_PER_FACE
}

/// One uniform refinement step of `parent` under its own scheme ([`Level::scheme`]).
pub fn refine_once(parent: &Level, method: CreaseMethod) -> (Level, StencilTable) {
    match parent.scheme {
        Scheme::Catmark => step::refine(parent, method),
        Scheme::Loop => loop_step::refine(parent, method),
    }
}

/// Uniform refinement of a control mesh to a fixed level: every level's topology and tags, and
/// the stencil tables between consecutive levels.
#[derive(Clone, Debug)]
pub struct Refiner {
    /// `levels[0]` is the control mesh; `levels[l]` is refinement level `l`.
    pub levels: Vec<Level>,
    /// `tables[l]` computes level `l + 1` vertices from level `l` vertices.
    pub tables: Vec<StencilTable>,
    /// Options used.
    pub options: Options,
    /// Remarks made while building level 0 (ignored tags).
    pub warnings: Vec<String>,
    /// The mesh's hierarchical position edits acting at each level (`position_edits[l]` for
    /// level `l`), applied by [`Refiner::refine_positions`].
    pub position_edits: Vec<Vec<edit::PositionEdit>>,
}

impl Refiner {
    /// Analyses `mesh` (with its own options) and builds tables up to `max_level`.
    pub fn new(mesh: &ControlMesh, max_level: usize) -> Result<Self> {
        Self::with_options(mesh, mesh.options, max_level)
    }

    /// Like [`Refiner::new`] with explicit options that override the mesh's.
    pub fn with_options(mesh: &ControlMesh, options: Options, max_level: usize) -> Result<Self> {
        if max_level > MAX_LEVEL {
            return Err(Error::new(
                ErrorKind::Usage,
                format!("level {max_level} is above the maximum of {MAX_LEVEL}"),
            ));
        }
        crate::memory::check(
            &format!("uniform refinement to level {max_level}"),
            estimate_bytes(mesh, max_level),
            "lower the level (--level)",
        )?;
        let (mut base, warnings) = Level::base(mesh, &options)?;
        edit::apply_tags(&[], &mut base, mesh);
        let mut levels = vec![base];
        let mut tables = Vec::with_capacity(max_level);
        for _ in 0..max_level {
            let (mut child, table) = refine_once(levels.last().unwrap(), options.crease_method);
            edit::apply_tags(&levels, &mut child, mesh);
            levels.push(child);
            tables.push(table);
        }
        let position_edits = edit::position_edits(&levels, mesh);
        Ok(Refiner {
            levels,
            tables,
            options,
            warnings,
            position_edits,
        })
    }

    /// The deepest level built.
    pub fn max_level(&self) -> usize {
        self.tables.len()
    }

    /// Interpolates a vertex primvar (`width` components per vertex) from level 0 to every
    /// level; element `l` of the result holds level `l`.
    pub fn interpolate_all<T: Real>(&self, base: &[T], width: usize) -> Vec<Vec<T>> {
        let mut out = vec![base.to_vec()];
        for t in &self.tables {
            let next = t.apply(out.last().unwrap(), width);
            out.push(next);
        }
        out
    }

    /// Interpolates a vertex primvar from level 0 to `level`.
    pub fn interpolate<T: Real>(&self, base: &[T], width: usize, level: usize) -> Vec<T> {
        let mut cur = base.to_vec();
        for t in &self.tables[..level] {
            cur = t.apply(&cur, width);
        }
        cur
    }

    /// Positions of `level`, from control positions, with the mesh's hierarchical position
    /// edits applied at each level as its points are made ([`edit`]), that level's own
    /// included: the points the surface is refined from.
    pub fn refine_positions(&self, base: &[[f64; 3]], level: usize) -> Vec<[f64; 3]> {
        self.refine_positions_with(base, level, true)
    }

    /// [`Self::refine_positions`], with the position edits that act on `level` itself applied
    /// or not. OpenSubdiv's Hbr writes a level's points before that level's own edits (they
    /// take effect when it is refined further: its baselines of catmark_square_hedit0 show a
    /// level-2 edit at 3 steps and not at 2); `false` reproduces those baselines.
    pub fn refine_positions_with(
        &self,
        base: &[[f64; 3]],
        level: usize,
        own_edits: bool,
    ) -> Vec<[f64; 3]> {
        let mut cur = base.to_vec();
        for l in 0..=level {
            if l > 0 {
                let flat = self.tables[l - 1].apply(cur.as_flattened(), 3);
                cur = flat.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect();
            }
            if l < level || own_edits {
                for e in &self.position_edits[l] {
                    e.apply(&mut cur);
                }
            }
        }
        cur
    }

    /// The face-varying texture coordinates of `mesh` (its `vt` and `f v/vt` corners) refined
    /// to `level` in the options' [`crate::mesh::FVarMode`]: values and, parallel to
    /// `levels[level].topo.face_verts`, each face corner's value index. Catmull-Clark only; a
    /// mesh without texture coordinates is an error.
    pub fn refine_uvs(&self, mesh: &ControlMesh, level: usize) -> Result<fvar::FVarLevel> {
        if mesh.face_uvs.is_empty() {
            return Err(Error::new(
                ErrorKind::Usage,
                "the mesh has no texture coordinates (no `vt` in its faces)",
            ));
        }
        if self.options.scheme != Scheme::Catmark {
            return Err(Error::new(
                ErrorKind::Usage,
                "face-varying refinement is built for Catmull-Clark meshes only",
            ));
        }
        if level >= self.levels.len() {
            return Err(Error::new(
                ErrorKind::Usage,
                format!(
                    "level {level} is beyond the refiner's {}",
                    self.levels.len() - 1
                ),
            ));
        }
        let mut cur = fvar::FVarLevel {
            values: mesh.uvs.clone(),
            corners: mesh.face_uvs.clone(),
        };
        for l in 0..level {
            cur = fvar::refine(&self.levels[l], &cur, &self.tables[l], self.options.fvar);
        }
        Ok(cur)
    }

    /// Bytes used by the stencil tables.
    pub fn table_bytes(&self) -> usize {
        self.tables.iter().map(|t| t.bytes()).sum()
    }
}
