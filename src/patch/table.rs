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

use super::bspline::{self, ControlGrid, PatchPoint};
use super::local::{child_face, extract_faces, LocalMesh};
use super::regular::{classify, RegularKind};
use super::single_crease;
use crate::coord::FaceCoord;
use crate::error::{Error, ErrorKind, Result};
use crate::mesh::{ControlMesh, CreaseMethod, Options};
use crate::refine::limit::vertex_limit_frame;
use crate::refine::stencil::StencilTable;
use crate::refine::step;
use crate::refine::Level;

/// Default maximum isolation level.
pub const DEFAULT_MAX_LEVEL: usize = 10;

/// Largest maximum isolation level accepted (by the library, the scene key `max_level` and
/// the command line's `--max-level` alike); patch levels are stored in a byte.
pub const MAX_LEVEL: usize = 16;

/// Deepest on-demand subdivision inside an end cap; points closer than 2^-60 of the cap's size
/// to a vertex take that vertex's exact limit position.
const MAX_ON_DEMAND: usize = 60;

/// Options of the patch table.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PatchOptions {
    /// Maximum isolation level.
    pub max_level: usize,
    /// Use single-crease patches (paper 000) for regular faces with one semi-sharp crease
    /// (uniform crease rule only); otherwise such faces are refined like other features.
    pub single_crease: bool,
}

impl Default for PatchOptions {
    fn default() -> Self {
        PatchOptions {
            max_level: DEFAULT_MAX_LEVEL,
            single_crease: true,
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
}

/// A leaf of the quadtree of one (sub-)face.
#[derive(Clone, Debug)]
pub struct Patch {
    /// Kind.
    pub kind: PatchKind,
    /// Subdivision level of the patch (0 = base face).
    pub level: u8,
    /// First control point in [`PatchTable::points`] (16 for B-spline and single-crease
    /// patches, all vertices of the cut-out for end caps).
    pub first_point: u32,
    /// For end caps: index of the shared cut-out.
    pub end_cap: u32,
    /// For end caps: the face within the cut-out.
    pub cap_face: u32,
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
    /// Placeholder for the fields filled in when a patch is attached to its node.
    const UNSET: Patch = Patch {
        kind: PatchKind::EndCap,
        level: 0,
        first_point: 0,
        end_cap: 0,
        cap_face: 0,
        face: 0,
        sub_face: 0,
        origin: [0.0; 2],
        axis_u: [1.0, 0.0],
        axis_v: [0.0, 1.0],
    };
}

#[derive(Clone, Copy, Debug)]
enum Node {
    Inner(u32),
    Leaf(u32),
    Empty,
}

/// A cut-out shared by the end caps of one level: its topology, and its vertices as control
/// points starting at `first_point`.
#[derive(Clone, Debug)]
struct CapMesh {
    level: Level,
    first_point: u32,
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
    /// Base face, sub-face and domain of each node.
    node_info: Vec<(u32, u8, Frame)>,
    /// Inner nodes' children (4 each, in quadrant order).
    children: Vec<[u32; 4]>,
    /// Root node of sub-face `k` of face `f` at `roots[root_offsets[f] + k]`.
    roots: Vec<u32>,
    root_offsets: Vec<u32>,
    /// Control points as combinations of the vertices of all levels (level 0's first, then
    /// each refined cut-out's, see `chain`).
    pub point_stencils: StencilTable,
    /// Refinement chain: for each level, the vertices of the previous level's cut-out (indices
    /// into that level's vertices) and the table that refines them.
    chain: Vec<(Vec<u32>, StencilTable)>,
    /// Control point positions (from the last [`Self::set_positions`]).
    pub points: Vec<[f64; 3]>,
    end_caps: Vec<CapMesh>,
    /// Crease rule.
    pub method: CreaseMethod,
    /// Subdivision options the table was built with (boundary mode, crease rule).
    pub mesh_options: Options,
    /// Options used.
    pub options: PatchOptions,
    /// Build statistics.
    pub stats: PatchStats,
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

/// Frame of a node within its (sub-)face: `(u, v) = o + s a + t b`.
#[derive(Clone, Copy, Debug)]
struct Frame {
    o: [f64; 2],
    a: [f64; 2],
    b: [f64; 2],
}

/// Corner k of the unit square, and the child axes (see `regular::C/U/V`).
const CORNER: [[f64; 2]; 4] = [[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]];
const UAX: [[f64; 2]; 4] = [[1.0, 0.0], [0.0, 1.0], [-1.0, 0.0], [0.0, -1.0]];
const VAX: [[f64; 2]; 4] = [[0.0, 1.0], [-1.0, 0.0], [0.0, -1.0], [1.0, 0.0]];

impl Frame {
    const UNIT: Frame = Frame {
        o: [0.0, 0.0],
        a: [1.0, 0.0],
        b: [0.0, 1.0],
    };
    fn child(&self, k: usize) -> Frame {
        let map = |p: [f64; 2]| {
            [
                self.a[0] * p[0] + self.b[0] * p[1],
                self.a[1] * p[0] + self.b[1] * p[1],
            ]
        };
        let c = map(CORNER[k]);
        let ua = map(UAX[k]);
        let va = map(VAX[k]);
        Frame {
            o: [self.o[0] + c[0], self.o[1] + c[1]],
            a: [ua[0] * 0.5, ua[1] * 0.5],
            b: [va[0] * 0.5, va[1] * 0.5],
        }
    }
    /// First and second derivatives with respect to the (sub-)face's (u, v) from those in
    /// the frame's (s, t). The frame is a rotation and scaling by `h`, so
    /// `s = a·(x − o) / h²` and `t = b·(x − o) / h²`.
    fn face_point(&self, pt: PatchPoint) -> PatchPoint {
        let (a, b) = (self.a, self.b);
        let h2 = a[0] * a[0] + a[1] * a[1];
        let h4 = h2 * h2;
        let d2 = |x: usize, y: usize| -> [f64; 3] {
            std::array::from_fn(|i| {
                (a[x] * a[y] * pt.duu[i]
                    + (a[x] * b[y] + a[y] * b[x]) * pt.duv[i]
                    + b[x] * b[y] * pt.dvv[i])
                    / h4
            })
        };
        PatchPoint {
            p: pt.p,
            du: std::array::from_fn(|i| (pt.du[i] * a[0] + pt.dv[i] * b[0]) / h2),
            dv: std::array::from_fn(|i| (pt.du[i] * a[1] + pt.dv[i] * b[1]) / h2),
            duu: d2(0, 0),
            duv: d2(0, 1),
            dvv: d2(1, 1),
        }
    }
}

/// Which child of a node holds local point (s, t), and the point in the child's coordinates.
fn descend(s: f64, t: f64) -> (usize, f64, f64) {
    let k = match (s >= 0.5, t >= 0.5) {
        (false, false) => 0,
        (true, false) => 1,
        (true, true) => 2,
        (false, true) => 3,
    };
    let d = [s - CORNER[k][0], t - CORNER[k][1]];
    let s2 = 2.0 * (d[0] * UAX[k][0] + d[1] * UAX[k][1]);
    let t2 = 2.0 * (d[0] * VAX[k][0] + d[1] * VAX[k][1]);
    (k, s2.clamp(0.0, 1.0), t2.clamp(0.0, 1.0))
}

/// The corner of the unit square at (s, t), if it is one.
fn corner_index(s: f64, t: f64) -> Option<usize> {
    match (s, t) {
        (0.0, 0.0) => Some(0),
        (1.0, 0.0) => Some(1),
        (1.0, 1.0) => Some(2),
        (0.0, 1.0) => Some(3),
        _ => None,
    }
}

/// A face waiting for refinement at the current level, and where its subtree goes.
#[derive(Clone, Copy, Debug)]
enum Slot {
    /// A quad (or sub-face): its node.
    Quad(u32),
    /// An n-gon of the control mesh: the roots of its `n` sub-faces, consecutive nodes.
    NGon(u32, u32),
    /// Irregular at the maximum level: becomes an end cap (node).
    Cap(u32),
}

fn kind_name(kind: PatchKind) -> &'static str {
    match kind {
        PatchKind::BSpline { closed: 0 } => "regular",
        PatchKind::BSpline { closed: 1 } => "boundary",
        PatchKind::BSpline { .. } => "corner",
        PatchKind::SingleCrease { .. } => "single_crease",
        PatchKind::EndCap => "end_cap",
    }
}

fn patch_kind(kind: RegularKind) -> PatchKind {
    match kind {
        RegularKind::BSpline { closed } => PatchKind::BSpline { closed },
        RegularKind::SingleCrease { edge, sharpness } => {
            PatchKind::SingleCrease { edge, sharpness }
        }
    }
}

impl PatchTable {
    fn add_leaf(&mut self, slot: u32, mut patch: Patch) {
        let (face, sub, fr) = self.node_info[slot as usize];
        patch.face = face;
        patch.sub_face = sub;
        patch.origin = fr.o;
        patch.axis_u = fr.a;
        patch.axis_v = fr.b;
        *self
            .stats
            .by_kind_level
            .entry((kind_name(patch.kind).to_string(), patch.level))
            .or_default() += 1;
        self.patches.push(patch);
        self.nodes[slot as usize] = Node::Leaf((self.patches.len() - 1) as u32);
    }

    fn new_node(&mut self, face: u32, sub: u8, frame: Frame) -> u32 {
        self.node_info.push((face, sub, frame));
        self.nodes.push(Node::Empty);
        (self.nodes.len() - 1) as u32
    }

    /// Settles face `g` of `level` (whose vertices are `rows` over the base vertices) into
    /// node `slot`: a hole, a regular patch, an end cap at the maximum level, or a face to
    /// refine further (returned).
    fn settle(
        &mut self,
        level: &Level,
        offset: u32,
        g: usize,
        slot: u32,
        depth: usize,
    ) -> Option<(u32, Slot)> {
        if level.face_hole[g] {
            self.nodes[slot as usize] = Node::Empty;
            return None;
        }
        if let Some((kind, cps)) = classify(level, g, self.options.single_crease) {
            let first = self.point_stencils.len() as u32;
            for c in &cps {
                let terms: Vec<(u32, f64)> = c.iter().map(|&(v, w)| (offset + v, w)).collect();
                self.point_stencils.push_terms(&terms);
            }
            self.add_leaf(
                slot,
                Patch {
                    kind: patch_kind(kind),
                    level: depth as u8,
                    first_point: first,
                    end_cap: 0,
                    cap_face: 0,
                    ..Patch::UNSET
                },
            );
            return None;
        }
        if depth >= self.options.max_level {
            return Some((g as u32, Slot::Cap(slot)));
        }
        Some((g as u32, Slot::Quad(slot)))
    }
}

impl PatchTable {
    /// Builds the patch table of `mesh` with its own options.
    pub fn new(mesh: &ControlMesh, opts: PatchOptions) -> Result<Self> {
        Self::with_options(mesh, mesh.options, opts)
    }

    /// Builds the patch table with subdivision options overriding the mesh's.
    pub fn with_options(mesh: &ControlMesh, options: Options, opts: PatchOptions) -> Result<Self> {
        if !(1..=MAX_LEVEL).contains(&opts.max_level) {
            return Err(Error::new(
                ErrorKind::Usage,
                format!(
                    "maximum isolation level {} is outside 1..={MAX_LEVEL}",
                    opts.max_level
                ),
            ));
        }
        let (base, _) = Level::base(mesh, &options)?;
        let method = options.crease_method;
        let opts = PatchOptions {
            single_crease: opts.single_crease && method == CreaseMethod::Uniform,
            max_level: opts.max_level.max(1),
        };
        let nb = base.num_vertices();
        let mut table = PatchTable {
            patches: Vec::new(),
            nodes: Vec::new(),
            node_info: Vec::new(),
            children: Vec::new(),
            roots: Vec::new(),
            root_offsets: vec![0],
            point_stencils: StencilTable::new(nb),
            chain: Vec::new(),
            points: Vec::new(),
            end_caps: Vec::new(),
            method,
            mesh_options: options,
            options: opts,
            stats: PatchStats::default(),
        };
        let mut pending: Vec<(u32, Slot)> = Vec::new();
        for f in 0..base.num_faces() {
            let n = base.topo.face_size(f);
            if n == 4 {
                let slot = table.new_node(f as u32, 0, Frame::UNIT);
                table.roots.push(slot);
                if let Some(p) = table.settle(&base, 0, f, slot, 0) {
                    pending.push(p);
                }
            } else {
                let first = table.nodes.len() as u32;
                for k in 0..n {
                    let slot = table.new_node(f as u32, k as u8, Frame::UNIT);
                    table.roots.push(slot);
                }
                if !base.face_hole[f] {
                    pending.push((f as u32, Slot::NGon(first, n as u32)));
                }
            }
            table.root_offsets.push(table.roots.len() as u32);
        }
        // Refine what is irregular, level by level, on the union of two-ring neighbourhoods.
        let mut level = base;
        let mut total = nb as u32;
        let mut depth = 0;
        while !pending.is_empty() {
            let seeds: Vec<u32> = pending.iter().map(|p| p.0).collect();
            let (sub, old, seed_new) = extract_faces(&level, &seeds, 2);
            let (child, t) = step::refine(&sub, method);
            table.chain.push((old, t));
            let child_offset = total;
            total += child.num_vertices() as u32;
            table.stats.refined_vertices += child.num_vertices();
            depth += 1;
            let mut next = Vec::new();
            let mut caps = Vec::new();
            for (&(_, slot), &g) in pending.iter().zip(&seed_new) {
                let g = g as usize;
                let slots: Vec<u32> = match slot {
                    Slot::Cap(_) => unreachable!("end caps are settled at their level"),
                    Slot::NGon(first, n) => (first..first + n).collect(),
                    Slot::Quad(node) => {
                        let (face, sub, fr) = table.node_info[node as usize];
                        let kids: [u32; 4] =
                            std::array::from_fn(|q| table.new_node(face, sub, fr.child(q)));
                        table.children.push(kids);
                        table.nodes[node as usize] = Node::Inner((table.children.len() - 1) as u32);
                        kids.to_vec()
                    }
                };
                for (k, &s) in slots.iter().enumerate() {
                    let c = child_face(&sub, g, k);
                    match table.settle(&child, child_offset, c, s, depth) {
                        Some((c, Slot::Cap(node))) => caps.push((c, node)),
                        Some(p) => next.push(p),
                        None => {}
                    }
                }
            }
            if !caps.is_empty() {
                // One cut-out shared by all end caps of this level.
                let faces: Vec<u32> = caps.iter().map(|c| c.0).collect();
                let (cut, old, new_faces) = extract_faces(&child, &faces, 2);
                let first = table.point_stencils.len() as u32;
                for &v in &old {
                    table.point_stencils.push_terms(&[(child_offset + v, 1.0)]);
                }
                table.end_caps.push(CapMesh {
                    level: cut,
                    first_point: first,
                });
                let cap = (table.end_caps.len() - 1) as u32;
                for (&(_, node), &face) in caps.iter().zip(&new_faces) {
                    table.add_leaf(
                        node,
                        Patch {
                            kind: PatchKind::EndCap,
                            level: depth as u8,
                            first_point: first,
                            end_cap: cap,
                            cap_face: face,
                            ..Patch::UNSET
                        },
                    );
                }
            }
            level = child;
            pending = next;
        }
        table.point_stencils.num_inputs = total as usize;
        table.set_positions(&mesh.positions);
        Ok(table)
    }

    /// Re-poses the table: new control positions, same topology.
    pub fn set_positions(&mut self, base: &[[f64; 3]]) {
        let mut all: Vec<[f64; 3]> = base.to_vec();
        let mut start = 0;
        for (select, t) in &self.chain {
            let sub: Vec<[f64; 3]> = select.iter().map(|&i| all[start + i as usize]).collect();
            let child = t.apply_points(&sub);
            start = all.len();
            all.extend_from_slice(&child);
        }
        self.points = self.point_stencils.apply_points(&all);
    }

    /// Bytes used by the table (stencils, patches, tree, end-cap topology).
    pub fn bytes(&self) -> usize {
        let topo_bytes: usize = self
            .end_caps
            .iter()
            .map(|c| {
                let t = &c.level.topo;
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
                    + c.level.edge_sharpness.len()
                    + c.level.vertex_sharpness.len())
            })
            .sum();
        self.point_stencils.bytes()
            + self
                .chain
                .iter()
                .map(|(sel, t)| sel.len() * 4 + t.bytes())
                .sum::<usize>()
            + self.points.len() * 24
            + self.patches.len() * std::mem::size_of::<Patch>()
            + self.nodes.len() * std::mem::size_of::<Node>()
            + self.children.len() * 16
            + self.roots.len() * 4
            + self.root_offsets.len() * 4
            + topo_bytes
    }

    /// Number of sub-faces of base face `f` (1 for a quad, n for an n-gon).
    pub fn sub_faces(&self, f: usize) -> usize {
        (self.root_offsets[f + 1] - self.root_offsets[f]) as usize
    }

    /// Number of base faces.
    pub fn num_faces(&self) -> usize {
        self.root_offsets.len() - 1
    }

    /// Evaluates the limit surface at `at`; errors when `at` is outside the domain or in a hole.
    pub fn eval(&self, at: FaceCoord) -> Result<Sample> {
        let (face, k, u, v) = (at.face as usize, at.k as usize, at.u, at.v);
        if face >= self.num_faces() {
            return Err(Error::new(
                ErrorKind::Usage,
                format!("face {face} out of range"),
            ));
        }
        if k >= self.sub_faces(face) {
            return Err(Error::new(
                ErrorKind::Usage,
                format!(
                    "face {face} has {} sub-face(s); k = {k} is out of range",
                    self.sub_faces(face)
                ),
            ));
        }
        if !(0.0..=1.0).contains(&u) || !(0.0..=1.0).contains(&v) {
            return Err(Error::new(
                ErrorKind::Usage,
                format!("(u, v) = ({u}, {v}) is outside [0, 1]²"),
            ));
        }
        let mut node = self.roots[self.root_offsets[face] as usize + k] as usize;
        let mut frame = Frame::UNIT;
        let (mut s, mut t) = (u, v);
        loop {
            match self.nodes[node] {
                Node::Empty => {
                    return Err(Error::new(
                        ErrorKind::Usage,
                        format!("face {face} is a hole"),
                    ));
                }
                Node::Inner(c) => {
                    let (q, s2, t2) = descend(s, t);
                    frame = frame.child(q);
                    s = s2;
                    t = t2;
                    node = self.children[c as usize][q] as usize;
                }
                Node::Leaf(p) => {
                    let patch = &self.patches[p as usize];
                    let (pt, extra) = self.eval_patch(patch, s, t);
                    let pt = frame.face_point(pt);
                    return Ok(Sample {
                        p: pt.p,
                        du: pt.du,
                        dv: pt.dv,
                        duu: pt.duu,
                        duv: pt.duv,
                        dvv: pt.dvv,
                        level: patch.level + extra,
                    });
                }
            }
        }
    }

    /// Evaluates many samples in parallel.
    pub fn eval_batch(&self, samples: &[FaceCoord]) -> Vec<Result<Sample>> {
        use rayon::prelude::*;
        samples.par_iter().map(|&at| self.eval(at)).collect()
    }

    fn grid(&self, first: u32) -> ControlGrid {
        std::array::from_fn(|i| self.points[first as usize + i])
    }

    /// Evaluates a leaf at local (s, t); returns the point (derivatives in the leaf's (s, t))
    /// and the number of on-demand levels used.
    fn eval_patch(&self, patch: &Patch, s: f64, t: f64) -> (PatchPoint, u8) {
        match patch.kind {
            PatchKind::BSpline { .. } => (bspline::eval(&self.grid(patch.first_point), s, t), 0),
            PatchKind::SingleCrease { edge, sharpness } => (
                single_crease::eval(
                    &self.grid(patch.first_point),
                    edge as usize,
                    sharpness as f64,
                    s,
                    t,
                ),
                0,
            ),
            PatchKind::EndCap => {
                let cap = &self.end_caps[patch.end_cap as usize];
                let n = cap.level.num_vertices();
                let first = cap.first_point as usize;
                let data: Vec<f64> = self.points[first..first + n]
                    .iter()
                    .flatten()
                    .copied()
                    .collect();
                let mesh = LocalMesh {
                    level: cap.level.clone(),
                    data,
                    width: 3,
                };
                self.on_demand(mesh, patch.cap_face as usize, s, t)
            }
        }
    }

    fn on_demand(&self, mesh: LocalMesh, g0: usize, s0: f64, t0: f64) -> (PatchPoint, u8) {
        // Work on the face's own two-ring from here on.
        let mut mesh = LocalMesh::extract(&mesh.level, &mesh.data, 3, g0, 2);
        let corner_p = corner_index(s0, t0).map(|q| {
            let v = mesh.level.topo.face_vertices(0)[q] as usize;
            let pos: Vec<[f64; 3]> = mesh
                .data
                .chunks_exact(3)
                .map(|c| [c[0], c[1], c[2]])
                .collect();
            vertex_limit_frame(&mesh.level, v, &pos, self.method).position
        });
        // At an exact corner the derivative may not exist (extraordinary vertex): take the
        // exact limit position there, and the derivatives 2^-10 of the patch inside the face.
        let at_corner = corner_p.is_some();
        let (mut s, mut t) = (s0, t0);
        if at_corner {
            let eps = 2f64.powi(-10);
            s = if s0 == 0.0 { eps } else { 1.0 - eps };
            t = if t0 == 0.0 { eps } else { 1.0 - eps };
        }
        let mut frame = Frame::UNIT;
        let mut g = 0usize;
        let mut depth = 0u8;
        let mut result = None;
        for _ in 0..MAX_ON_DEMAND {
            if let Some((kind, cps)) = classify(&mesh.level, g, self.options.single_crease) {
                let grid: ControlGrid = std::array::from_fn(|i| {
                    let mut p = [0.0; 3];
                    for &(v, w) in &cps[i] {
                        let q = mesh.point(v as usize);
                        for c in 0..3 {
                            p[c] += w * q[c];
                        }
                    }
                    p
                });
                let pt = match kind {
                    RegularKind::BSpline { .. } => bspline::eval(&grid, s, t),
                    RegularKind::SingleCrease { edge, sharpness } => {
                        single_crease::eval(&grid, edge as usize, sharpness as f64, s, t)
                    }
                };
                result = Some(pt);
                break;
            }
            let refined = mesh.refine(self.method);
            let (q, s2, t2) = descend(s, t);
            let c = child_face(&mesh.level, g, q);
            mesh = LocalMesh::extract(&refined.level, &refined.data, 3, c, 2);
            g = 0;
            frame = frame.child(q);
            s = s2;
            t = t2;
            depth += 1;
        }
        let mut pt = result.unwrap_or_else(|| {
            // within 2^-60 of a vertex: its exact limit position
            let (q, _, _) = descend(s, t);
            let v = mesh.level.topo.face_vertices(g)[q] as usize;
            let pos: Vec<[f64; 3]> = mesh
                .data
                .chunks_exact(3)
                .map(|c| [c[0], c[1], c[2]])
                .collect();
            let fr = vertex_limit_frame(&mesh.level, v, &pos, self.method);
            PatchPoint {
                p: fr.position,
                ..Default::default()
            }
        });
        pt = frame.face_point(pt);
        if let Some(p) = corner_p {
            pt.p = p;
        }
        (pt, depth)
    }
}
