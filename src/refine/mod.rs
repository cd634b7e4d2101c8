//! Table-driven Catmull-Clark refinement (paper 001 §3.1–3.2, paper 004 §3).
//!
//! [`Refiner::new`] analyses topology and tags once and builds one [`StencilTable`] per level;
//! applying the tables to positions or any other primvar is a separate parallel step, so an
//! animated mesh re-poses without re-analysis.

pub mod crease;
pub mod level;
pub mod limit;
pub mod rules;
pub mod stencil;
pub mod step;

pub use level::Level;
pub use stencil::{Real, StencilTable};

use crate::error::{Error, ErrorKind, Result};
use crate::mesh::{ControlMesh, Options};

/// Deepest uniform refinement the refiner accepts (each level has four times the faces).
pub const MAX_LEVEL: usize = 12;

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
        let (base, warnings) = Level::base(mesh, &options)?;
        let mut levels = vec![base];
        let mut tables = Vec::with_capacity(max_level);
        for _ in 0..max_level {
            let (child, table) = step::refine(levels.last().unwrap(), options.crease_method);
            levels.push(child);
            tables.push(table);
        }
        Ok(Refiner {
            levels,
            tables,
            options,
            warnings,
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

    /// Positions of `level`, from control positions.
    pub fn refine_positions(&self, base: &[[f64; 3]], level: usize) -> Vec<[f64; 3]> {
        let flat = self.interpolate(base.as_flattened(), 3, level);
        flat.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect()
    }

    /// Bytes used by the stencil tables.
    pub fn table_bytes(&self) -> usize {
        self.tables.iter().map(|t| t.bytes()).sum()
    }
}
