//! The feature-adaptive patch table (paper 001 §3.3–4, paper 000) and exact evaluation of the
//! limit surface at any `(face, k, u, v)`.
//!
//! Every base face (every sub-face of an n-gon, after one step) is the root of a quadtree.
//! A node whose face is regular becomes a leaf patch: a bicubic B-spline (interior, boundary
//! and corner patches, infinitely sharp creases acting as boundaries) or a single-crease patch
//! evaluated directly (paper 000). Irregular faces are refined, locally, on a two-ring cut-out
//! ([`super::local`]), down to the maximum isolation level. What is still irregular there
//! (faces at extraordinary vertices, darts, sharpness beyond the level) becomes an end cap:
//! this library's end cap is not an approximation but the cut-out itself, subdivided further on
//! demand at evaluation time until the point falls in a regular sub-patch, or lands exactly on
//! a vertex, whose exact limit mask then applies. Evaluation is therefore exact everywhere.
//!
//! Topology analysis depends only on connectivity and tags: the table keeps every control
//! point as a stencil over the base vertices, so [`PatchTable::set_positions`] re-poses it.
//!
//! The module is split by concept: `tree` (the quadtree of nodes and their frames),
//! `build` (the factory: classification and local refinement), `eval` (the lookup and
//! evaluation of leaves), `lattice` (a domain's lattice of points at once) and `end_cap` (end caps and their on-demand subdivision).

mod build;
mod end_cap;
mod eval;
mod lattice;
pub use eval::LeafLevels;
pub(crate) use lattice::Kept;
pub mod loop_pieces;
pub mod pieces;
pub(crate) mod tree;

use crate::mesh::{CreaseMethod, Options};
use crate::refine::stencil::StencilTable;
use end_cap::CapMesh;
use tree::{Frame, Node};

/// Default maximum isolation level.
pub const DEFAULT_MAX_LEVEL: usize = 10;

/// Largest maximum isolation level accepted (by the library, the scene key `max_level` and
/// the command line's `--max-level` alike); patch levels are stored in a byte.
pub const MAX_LEVEL: usize = 16;

/// Options of the patch table.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PatchOptions {
    /// Maximum isolation level.
    pub max_level: usize,
    /// Use single-crease patches (paper 000) for regular faces with one semi-sharp crease
    /// (under either crease rule); otherwise such faces are refined like other features.
    pub single_crease: bool,
    /// The surface the mesh stands for: exact, one of paper 002's approximations of a Loop
    /// surface, or (`Gregory` on a Catmull-Clark mesh) paper 004's Gregory patches
    /// ([`crate::patch::approx`]).
    pub surface: crate::patch::approx::Approximation,
}

impl Default for PatchOptions {
    fn default() -> Self {
        PatchOptions {
            max_level: DEFAULT_MAX_LEVEL,
            single_crease: true,
            surface: crate::patch::approx::Approximation::Exact,
        }
    }
}

/// The kind of a leaf patch.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum PatchKind {
    /// Bicubic B-spline with `closed` boundary (or infinitely sharp) edges.
    BSpline {
        /// Number of closed edges: 0 regular interior, 1 boundary, 2 corner.
        closed: u8,
    },
    /// Regular patch with one semi-sharp crease on edge `edge`.
    SingleCrease {
        /// Face edge with the crease.
        edge: u8,
        /// Sharpness.
        sharpness: f32,
    },
    /// Irregular at the maximum level: subdivided on demand at evaluation.
    EndCap,
    /// A quad with one smooth extraordinary corner of `valence` at its corner `corner` and
    /// regular, smooth surroundings, at the first level where it is one: evaluated exactly in
    /// constant time by Stam's method ([`crate::patch::stam`]) from `2·valence + 8` control
    /// points.
    Stam {
        /// Valence of the extraordinary vertex.
        valence: u8,
        /// The patch's corner (0..4, as in the patch's (s, t)) at the extraordinary vertex.
        corner: u8,
    },
}

/// A leaf of the quadtree of one (sub-)face.
#[derive(Clone, Debug)]
pub struct Patch {
    /// Kind.
    pub kind: PatchKind,
    /// Subdivision level of the patch (0 = base face).
    pub level: u8,
    /// First control point in [`PatchTable::points`] (16 for B-spline and single-crease
    /// patches, `2n + 8` for Stam patches, all vertices of the level's cut-out for end caps);
    /// for a `direct` patch, the first of its 16 vertex indices in [`PatchTable::direct`].
    pub first_point: u32,
    /// A B-spline or single-crease patch whose 16 control points are vertices of the
    /// refinement ([`PatchTable::verts`]) as they are: no control point of its own (an
    /// interior patch, where no control point is a boundary's reflection).
    pub direct: bool,
    /// For end caps: index of the cap's own neighbourhood (its two-ring, cut out at build time).
    pub end_cap: u32,
    /// Base face.
    pub face: u32,
    /// Sub-face of the base face (0 for quads).
    pub sub_face: u8,
    /// Domain in the (sub-)face's parameters: `(u, v) = origin + s·axis_u + t·axis_v` for the
    /// patch's own `(s, t) ∈ [0, 1]²`.
    pub origin: [f64; 2],
    /// See `origin`.
    pub axis_u: [f64; 2],
    /// See `origin`.
    pub axis_v: [f64; 2],
}

impl Patch {
    /// The patch's frame within its domain: the frame of its node, the same bits as the
    /// quadtree's descent composes.
    pub(crate) fn frame(&self) -> Frame {
        Frame {
            o: self.origin,
            a: self.axis_u,
            b: self.axis_v,
        }
    }

    /// Placeholder for the fields filled in when a patch is attached to its node.
    const UNSET: Patch = Patch {
        kind: PatchKind::EndCap,
        level: 0,
        first_point: 0,
        direct: false,
        end_cap: 0,
        face: 0,
        sub_face: 0,
        origin: [0.0; 2],
        axis_u: [1.0, 0.0],
        axis_v: [0.0, 1.0],
    };
}

/// Counts for `limitray stats`.
#[derive(Clone, Debug, Default)]
pub struct PatchStats {
    /// Patches per (kind name, level).
    pub by_kind_level: std::collections::BTreeMap<(String, u8), usize>,
    /// Vertices created by local refinement while building.
    pub refined_vertices: usize,
}

/// The patch table of a control mesh.
#[derive(Clone, Debug)]
pub struct PatchTable {
    /// Leaf patches.
    pub patches: Vec<Patch>,
    nodes: Vec<Node>,
    /// Base face, sub-face and domain of each node (while building; emptied after).
    node_info: Vec<(u32, u8, Frame)>,
    /// Inner nodes' children (4 each, in quadrant order), as node indices while building.
    children: Vec<[u32; 4]>,
    /// The same children as nodes (`kids[c][q] = nodes[children[c][q]]`), filled at the end of
    /// the build: the lookup reads one array per level instead of two.
    kids: Vec<[Node; 4]>,
    /// Root node of sub-face `k` of face `f` at `roots[root_offsets[f] + k]`.
    roots: Vec<u32>,
    root_offsets: Vec<u32>,
    /// Control points as combinations of the vertices of all levels (level 0's first, then
    /// each refined cut-out's, see `chain`).
    pub point_stencils: StencilTable,
    /// Refinement chain: for each level, the vertices of the previous level's cut-out (indices
    /// into that level's vertices) and the table that refines them.
    chain: Vec<(Vec<u32>, StencilTable)>,
    /// Hierarchical position edits on each refined cut-out of `chain` (its vertex numbering).
    chain_edits: Vec<Vec<crate::refine::edit::PositionEdit>>,
    /// Hierarchical position edits on the control vertices.
    base_edits: Vec<crate::refine::edit::PositionEdit>,
    /// Control point positions (from the last [`Self::set_positions`]).
    pub points: Vec<[f64; 3]>,
    /// The vertices of the refinement (the base vertices, then each refined level's), from
    /// the last [`Self::set_positions`]: what `direct` patches read.
    pub verts: Vec<[f64; 3]>,
    /// Direct patches' control points: 16 indices into [`Self::verts`] each.
    pub direct: Vec<u32>,
    end_caps: Vec<CapMesh>,
    /// Stam's matrices by valence (shared, see [`crate::patch::stam::basis`]).
    stam: Vec<Option<std::sync::Arc<crate::patch::stam::StamBasis>>>,
    /// Whether Stam patches are made (always, but for tests comparing with end caps).
    use_stam: bool,
    /// Crease rule.
    pub method: CreaseMethod,
    /// Subdivision options the table was built with (boundary mode, crease rule).
    pub mesh_options: Options,
    /// Options used.
    pub options: PatchOptions,
    /// Build statistics.
    pub stats: PatchStats,
    /// Under the Loop scheme the surface's evaluator (and `patches` is empty): `eval` at
    /// `(face, k, u, v)` is [`LoopSurface::eval_sub_quad`].
    loop_surface: Option<std::sync::Arc<crate::patch::LoopSurface>>,
    /// Under the Loop scheme with an approximate surface, its patches: `eval` is
    /// [`crate::patch::approx::TriApprox::eval_sub_quad`].
    approx: Option<std::sync::Arc<crate::patch::approx::TriApprox>>,
    /// Under Catmull-Clark with `--surface gregory`, paper 004's Gregory patches: `eval` is
    /// [`crate::patch::approx::QuadApprox::eval`].
    quad_approx: Option<std::sync::Arc<crate::patch::approx::QuadApprox>>,
    /// The control mesh's level 0 the table was built on (topology and tags), kept so that
    /// dicing need not build it again; `None` when edits at level 0 changed the table's copy,
    /// and under the Loop scheme.
    base_level: Option<std::sync::Arc<crate::refine::Level>>,
}

/// A limit-surface sample.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Sample {
    /// Position.
    pub p: [f64; 3],
    /// `∂P/∂u` in the (sub-)face's parameterisation.
    pub du: [f64; 3],
    /// `∂P/∂v`.
    pub dv: [f64; 3],
    /// `∂²P/∂u²`.
    pub duu: [f64; 3],
    /// `∂²P/∂u∂v`.
    pub duv: [f64; 3],
    /// `∂²P/∂v²`.
    pub dvv: [f64; 3],
    /// Level of the patch that was evaluated.
    pub level: u8,
}

impl PatchTable {
    /// Level 0 of `mesh` as this table was built on it, when the table kept it (see
    /// `base_level`) and `mesh` has the table's numbers of faces and vertices; else built
    /// again.
    pub(crate) fn base_level_of<'a>(
        &'a self,
        mesh: &crate::mesh::ControlMesh,
        built: &'a mut Option<crate::refine::Level>,
    ) -> crate::error::Result<&'a crate::refine::Level> {
        match self.base_level.as_deref() {
            Some(l)
                if l.num_faces() == mesh.num_faces() && l.num_vertices() == mesh.num_vertices() =>
            {
                Ok(l)
            }
            _ => Ok(built.insert(crate::refine::Level::base(mesh, &self.mesh_options)?.0)),
        }
    }

    /// Bytes used by the table (stencils, patches, tree, end-cap topology, the base level kept
    /// for dicing; not the levels that end caps refine lazily when queries reach them, nor the
    /// shared Stam matrices).
    pub fn bytes(&self) -> usize {
        let level_bytes = |l: &crate::refine::Level| {
            let t = &l.topo;
            4 * (t.face_offsets.len()
                + t.face_verts.len()
                + t.face_edges.len()
                + 2 * t.edge_verts.len()
                + t.edge_face_offsets.len()
                + t.edge_faces.len()
                + t.vert_face_offsets.len()
                + 2 * t.vert_faces.len()
                + t.vert_edge_offsets.len()
                + t.vert_edges.len()
                + l.edge_sharpness.len()
                + l.vertex_sharpness.len())
                + l.face_hole.len()
        };
        let topo_bytes: usize = self
            .end_caps
            .iter()
            .map(|c| level_bytes(&c.root.level) + 4 * c.points.len())
            .sum::<usize>()
            + self.base_level.as_deref().map_or(0, level_bytes);
        self.loop_surface.as_ref().map_or(0, |s| s.bytes())
            + self.approx.as_ref().map_or(0, |s| s.bytes())
            + self.quad_approx.as_ref().map_or(0, |s| s.bytes())
            + self.point_stencils.bytes()
            + self
                .chain
                .iter()
                .map(|(sel, t)| sel.len() * 4 + t.bytes())
                .sum::<usize>()
            + self.points.len() * 24
            + self.verts.len() * 24
            + self.direct.len() * 4
            + self.patches.len() * std::mem::size_of::<Patch>()
            + self.nodes.len() * std::mem::size_of::<Node>()
            + self.kids.len() * std::mem::size_of::<[Node; 4]>()
            + self.roots.len() * 4
            + self.root_offsets.len() * 4
            + topo_bytes
    }

    /// The Loop evaluator when the table's mesh is subdivided with the Loop scheme.
    pub fn loop_surface(&self) -> Option<&crate::patch::LoopSurface> {
        self.loop_surface.as_deref()
    }

    /// The approximate Loop surface evaluated instead of the exact one, if any.
    pub fn approx(&self) -> Option<&crate::patch::approx::TriApprox> {
        self.approx.as_deref()
    }

    /// The Gregory-patch approximation of a Catmull-Clark surface evaluated instead of the
    /// exact one, if any.
    pub fn quad_approx(&self) -> Option<&crate::patch::approx::QuadApprox> {
        self.quad_approx.as_deref()
    }

    /// Whether `eval` answers with an approximation rather than the exact limit surface.
    pub fn is_approximate(&self) -> bool {
        self.approx.is_some() || self.quad_approx.is_some()
    }

    /// Number of sub-faces of base face `f` (1 for a quad, n for an n-gon; 3 for a Loop
    /// triangle).
    pub fn sub_faces(&self, f: usize) -> usize {
        (self.root_offsets[f + 1] - self.root_offsets[f]) as usize
    }

    /// Number of base faces.
    pub fn num_faces(&self) -> usize {
        self.root_offsets.len() - 1
    }
}
