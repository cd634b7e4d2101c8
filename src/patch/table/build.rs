//! The factory of a patch table: every base face (every sub-face of an n-gon) becomes the root
//! of a quadtree; regular faces become leaf patches, quads with one smooth extraordinary
//! corner become Stam patches (`stam`) at the first level where they are one, other irregular
//! faces are refined level by level on the union of their two-ring cut-outs, and what is still
//! irregular at the maximum level becomes a Stam patch or an end cap (`end_cap`).

use super::end_cap::{CapMesh, CapNode};
use super::tree::{Frame, Node};
use super::{Patch, PatchKind, PatchOptions, PatchStats, PatchTable, MAX_LEVEL};
use crate::error::{Error, ErrorKind, Result};
use crate::mesh::{ControlMesh, Options, Scheme};
use crate::patch::approx::{Approximation, QuadApprox, TriApprox};
use crate::patch::local::{child_face, extract_faces, extract_faces_within};
use crate::patch::regular::{
    classify, interior_points_by, regular_corner, regular_corners, RegularKind,
};
use crate::patch::stam;
use crate::patch::LoopSurface;
use crate::refine::stencil::StencilTable;
use crate::refine::step;
use crate::refine::{edit, Level};
use crate::threads::split_off;
use std::mem::MaybeUninit;

/// The faces of `level` that share a vertex with a face an edit's path has reached
/// (`tracks`: edit, face, rotation): they are refined further, so that every patch whose
/// control points an edited element could reach is built below the edit.
fn near_edits(level: &Level, tracks: &[(usize, u32, u32)]) -> std::collections::HashSet<u32> {
    let mut out = std::collections::HashSet::new();
    for &(_, f, _) in tracks {
        for &v in level.topo.face_vertices(f as usize) {
            out.extend(level.topo.vertex_faces(v as usize).iter().copied());
        }
    }
    out
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

/// The names of the patch kinds in [`PatchStats::by_kind_level`], by [`kind_index`].
const KIND_NAMES: [&str; 6] = [
    "regular",
    "boundary",
    "corner",
    "single_crease",
    "end_cap",
    "stam",
];

/// Where a patch kind's name is in [`KIND_NAMES`].
fn kind_index(kind: PatchKind) -> usize {
    match kind {
        PatchKind::BSpline { closed: 0 } => 0,
        PatchKind::BSpline { closed: 1 } => 1,
        PatchKind::BSpline { .. } => 2,
        PatchKind::SingleCrease { .. } => 3,
        PatchKind::EndCap => 4,
        PatchKind::Stam { .. } => 5,
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
        self.patches.push(patch);
        self.nodes[slot as usize] = Node::Leaf((self.patches.len() - 1) as u32);
    }

    /// Makes Stam's matrices for `valence` if no patch has needed them yet.
    fn make_stam_basis(&mut self, valence: usize) {
        if self.stam.len() <= valence {
            self.stam.resize(valence + 1, None);
        }
        if self.stam[valence].is_none() {
            self.stam[valence] = Some(stam::basis(valence));
        }
    }

    fn new_node(&mut self, face: u32, sub: u8, frame: Frame) -> u32 {
        self.node_info.push((face, sub, frame));
        self.nodes.push(Node::Empty);
        (self.nodes.len() - 1) as u32
    }

    /// Decides faces `jobs` (face of `level`, forced) in parallel, in chunks (bounded
    /// memory), and settles them into their nodes `slot_of(i)`, in parallel too: each run of
    /// decisions knows how many patches, control-point rows and direct vertices it adds, so
    /// its output is written in place where a sequential pass in job order would have put it
    /// (the table is the same). Each worker writes its decisions and their rows into buffers
    /// of its own (a few allocations per chunk, not one per row freed by another thread).
    /// Returns the faces to refine further.
    fn settle_all(
        &mut self,
        level: &Level,
        offset: u32,
        jobs: &[(u32, bool)],
        slot_of: impl Fn(usize) -> u32 + Sync,
        depth: usize,
    ) -> Vec<(u32, Slot)> {
        use rayon::prelude::*;
        const CHUNK: usize = 8192;
        let (single_crease, use_stam) = (self.options.single_crease, self.use_stam);
        let mut out = Vec::new();
        // At most a patch per job, sixteen vertices per direct patch: reserved once (only
        // what is written is paged in; grown chunk by chunk, the arrays were copied).
        self.patches.reserve(jobs.len());
        if depth == 0 {
            self.direct.reserve(16 * jobs.len());
        }
        // At level 0 (every face a job), each vertex's test as a regular interior corner once,
        // not once per face at it; below it the jobs are a few faces of a cut-out's level,
        // whose corners are tested where met.
        let corners = if depth == 0 {
            regular_corners(level)
        } else {
            Vec::new()
        };
        for (c, chunk) in jobs.chunks(CHUNK).enumerate() {
            let parts: Vec<Decided> = chunk
                .par_iter()
                .with_min_len(256)
                .fold(Decided::default, |mut part, &(g, forced)| {
                    let found = decide(
                        level,
                        &corners,
                        (g as usize, depth),
                        forced,
                        single_crease,
                        use_stam,
                        &mut part,
                    );
                    part.found.push(found);
                    part
                })
                .collect();
            // Stam's matrices for the valences met, made once before the parallel pass.
            for part in &parts {
                for &found in &part.found {
                    if let Found::Stam(_, n) = found {
                        self.make_stam_basis((n - 8) / 2);
                    }
                }
            }
            // Where each part's output starts.
            let mut at = Sizes {
                job: c * CHUNK,
                patches: self.patches.len(),
                rows: self.point_stencils.len(),
                terms: self.point_stencils.indices.len(),
                direct: self.direct.len(),
            };
            let sizes: Vec<Sizes> = parts.iter().map(Sizes::of).collect();
            let mut starts = Vec::with_capacity(parts.len());
            for n in &sizes {
                starts.push(at);
                at = at.add(n);
            }
            let first = starts.first().copied().unwrap_or(at);
            let added_rows = at.rows - first.rows;
            let Self {
                patches,
                point_stencils,
                direct,
                node_info,
                options,
                ..
            } = self;
            let max_level = options.max_level;
            let node_info = &node_info[..];
            // Every part's slices of the arrays' spare capacity, filled in parallel.
            let mut room = Spare {
                patches: spare(patches, at.patches - first.patches),
                offsets: spare(&mut point_stencils.offsets, at.rows - first.rows),
                indices: spare(&mut point_stencils.indices, at.terms - first.terms),
                weights: spare(&mut point_stencils.weights, at.terms - first.terms),
                direct: spare(direct, at.direct - first.direct),
            };
            // Each job's node, if it is settled (made here, not in the workers: their
            // allocations would grow heaps of their own).
            let mut nodes = vec![None; chunk.len()];
            let mut work = Vec::with_capacity(parts.len());
            let mut rest = &mut nodes[..];
            for ((part, &s), n) in parts.iter().zip(&starts).zip(&sizes) {
                let part_nodes = split_off(&mut rest, n.job);
                work.push((part, s, room.split_off(n), part_nodes));
            }
            let refine: Vec<Vec<(u32, Slot)>> = work
                .into_par_iter()
                .map(|(part, s, slices, nodes)| {
                    settle_part(
                        part,
                        s,
                        (slices, nodes),
                        (offset, depth, max_level),
                        |i| (jobs[i].0, slot_of(i)),
                        node_info,
                    )
                })
                .collect();
            // SAFETY: `settle_part` wrote every item of its slices (it checks its counts and
            // panics otherwise, before these lengths are set), so the arrays' first `at.*`
            // items are initialised.
            unsafe {
                patches.set_len(at.patches);
                point_stencils
                    .offsets
                    .set_len(point_stencils.offsets.len() + added_rows);
                point_stencils.indices.set_len(at.terms);
                point_stencils.weights.set_len(at.terms);
                direct.set_len(at.direct);
            }
            for (i, node) in nodes.into_iter().enumerate() {
                if let Some(node) = node {
                    self.nodes[slot_of(c * CHUNK + i) as usize] = node;
                }
            }
            out.extend(refine.into_iter().flatten());
        }
        out
    }
}

/// What a face of a level becomes, decided from the level alone (so faces are decided in
/// parallel and settled in order); its control points are rows of a [`Decided`].
#[derive(Clone, Copy)]
enum Found {
    /// A hole: no surface.
    Hole,
    /// A Stam patch: the extraordinary corner, and the number of control points (rows of one
    /// term each, in [`stam::gather`]'s order).
    Stam(usize, usize),
    /// A regular patch: sixteen rows, its control points' combinations.
    Regular(RegularKind),
    /// A regular patch of level 0 whose control points are vertices as they are: sixteen
    /// vertices (read from the table's vertices, [`super::Patch::direct`]).
    Direct(RegularKind),
    /// Irregular: refined further, or an end cap at the maximum level.
    Irregular,
}

impl Found {
    /// Whether the face becomes a patch.
    fn is_patch(&self) -> bool {
        matches!(self, Found::Stam(..) | Found::Regular(_) | Found::Direct(_))
    }
}

/// A run of decisions and their control points: rows of terms, and direct patches'
/// vertices, sixteen each (in the level's numbering).
#[derive(Default)]
struct Decided {
    found: Vec<Found>,
    ends: Vec<u32>,
    terms: Vec<(u32, f64)>,
    direct: Vec<u32>,
}

impl Decided {
    fn push_row(&mut self, terms: impl IntoIterator<Item = (u32, f64)>) {
        self.terms.extend(terms);
        self.ends.push(self.terms.len() as u32);
    }
}

/// Counts of what a run of decisions adds, or where its output starts: jobs, patches,
/// control-point rows, their terms, direct patches' vertices.
#[derive(Clone, Copy, Default)]
struct Sizes {
    job: usize,
    patches: usize,
    rows: usize,
    terms: usize,
    direct: usize,
}

impl Sizes {
    /// What the run of decisions `part` adds.
    fn of(part: &Decided) -> Sizes {
        Sizes {
            job: part.found.len(),
            patches: part.found.iter().filter(|f| f.is_patch()).count(),
            rows: part.ends.len(),
            terms: part.terms.len(),
            direct: part.direct.len(),
        }
    }

    /// Each count plus `n`'s.
    fn add(self, n: &Sizes) -> Sizes {
        Sizes {
            job: self.job + n.job,
            patches: self.patches + n.patches,
            rows: self.rows + n.rows,
            terms: self.terms + n.terms,
            direct: self.direct + n.direct,
        }
    }
}

/// Uninitialised room at the ends of the table's arrays, where a run of decisions settles.
struct Spare<'a> {
    patches: &'a mut [MaybeUninit<Patch>],
    offsets: &'a mut [MaybeUninit<u32>],
    indices: &'a mut [MaybeUninit<u32>],
    weights: &'a mut [MaybeUninit<f64>],
    direct: &'a mut [MaybeUninit<u32>],
}

impl<'a> Spare<'a> {
    /// The room of the next run, which adds `n`.
    fn split_off(&mut self, n: &Sizes) -> Spare<'a> {
        Spare {
            patches: split_off(&mut self.patches, n.patches),
            offsets: split_off(&mut self.offsets, n.rows),
            indices: split_off(&mut self.indices, n.terms),
            weights: split_off(&mut self.weights, n.terms),
            direct: split_off(&mut self.direct, n.direct),
        }
    }
}

/// The first `n` items of `v`'s spare capacity (reserved here).
fn spare<T>(v: &mut Vec<T>, n: usize) -> &mut [MaybeUninit<T>] {
    v.reserve(n);
    &mut v.spare_capacity_mut()[..n]
}

/// Settles the run of decisions `part`, whose output starts at `at`, into `out` (exactly
/// filled): control points' rows (their vertices numbered from `offset` among the table's
/// refined vertices), direct patches' vertices, the patches (each placed in its node's frame,
/// `node_info`), and each job's node in `nodes`; job `i`'s face and node are `job(i)`. A hole
/// empties its node; an irregular face (no node yet) is refined further, or becomes an end cap
/// at the maximum level (returned, in order).
fn settle_part(
    part: &Decided,
    at: Sizes,
    (out, nodes): (Spare<'_>, &mut [Option<Node>]),
    (offset, depth, max_level): (u32, usize, usize),
    job: impl Fn(usize) -> (u32, u32),
    node_info: &[(u32, u8, Frame)],
) -> Vec<(u32, Slot)> {
    for ((i, w), &(v, weight)) in out
        .indices
        .iter_mut()
        .zip(out.weights.iter_mut())
        .zip(&part.terms)
    {
        i.write(offset + v);
        w.write(weight);
    }
    for (o, &end) in out.offsets.iter_mut().zip(&part.ends) {
        o.write(at.terms as u32 + end);
    }
    for (o, &v) in out.direct.iter_mut().zip(&part.direct) {
        o.write(offset + v);
    }
    assert!(
        out.indices.len() == part.terms.len()
            && out.weights.len() == part.terms.len()
            && out.offsets.len() == part.ends.len()
            && out.direct.len() == part.direct.len(),
        "a run's rows and direct vertices fill its room"
    );
    let mut refine = Vec::new();
    let (mut patches, mut row, mut direct) = (0, at.rows as u32, at.direct as u32);
    for (i, &found) in part.found.iter().enumerate() {
        let (g, slot) = job(at.job + i);
        // The patch's kind, its first control point (a row, or a direct patch's first
        // vertex) and whether it is direct.
        let (kind, first_point, is_direct) = match found {
            Found::Hole => {
                nodes[i] = Some(Node::Empty);
                continue;
            }
            Found::Irregular => {
                refine.push(if depth >= max_level {
                    (g, Slot::Cap(slot))
                } else {
                    (g, Slot::Quad(slot))
                });
                continue;
            }
            Found::Stam(corner, n) => {
                let kind = PatchKind::Stam {
                    valence: ((n - 8) / 2) as u8,
                    corner: corner as u8,
                };
                row += n as u32;
                (kind, row - n as u32, false)
            }
            Found::Regular(kind) => {
                row += 16;
                (patch_kind(kind), row - 16, false)
            }
            Found::Direct(kind) => {
                direct += 16;
                (patch_kind(kind), direct - 16, true)
            }
        };
        let (face, sub, fr) = node_info[slot as usize];
        out.patches[patches].write(Patch {
            kind,
            level: depth as u8,
            first_point,
            direct: is_direct,
            end_cap: 0,
            face,
            sub_face: sub,
            origin: fr.o,
            axis_u: fr.a,
            axis_v: fr.b,
        });
        nodes[i] = Some(Node::Leaf((at.patches + patches) as u32));
        patches += 1;
    }
    assert!(
        patches == out.patches.len()
            && row as usize == at.rows + part.ends.len()
            && direct as usize == at.direct + part.direct.len(),
        "a run's patches fill its room and use its rows"
    );
    refine
}

/// Decides face `g` of `level` (whose vertices are regular corners where `corners` says so,
/// [`regular_corners`], or where [`regular_corner`] finds them beyond its end), writing its
/// control points' rows to `part`. A `forced` face is refined whatever it is (a hierarchical
/// edit acts below it); with `use_stam`, a quad with one smooth extraordinary corner is exact
/// in constant time from its one-ring, with no need to isolate it to the maximum level.
fn decide(
    level: &Level,
    corners: &[bool],
    (g, depth): (usize, usize),
    forced: bool,
    single_crease: bool,
    use_stam: bool,
    part: &mut Decided,
) -> Found {
    if level.face_hole[g] {
        return Found::Hole;
    }
    if forced {
        return Found::Irregular;
    }
    // The common case first, with no combinations built: a regular interior face, whose
    // control points are vertices as they are (what `classify` gives it, below).
    let regular = |v: usize| match corners.get(v) {
        Some(&r) => r,
        None => regular_corner(level, v),
    };
    if let Some(points) = interior_points_by(level, g, regular) {
        let kind = RegularKind::BSpline { closed: 0 };
        if depth == 0 {
            part.direct.extend_from_slice(&points);
            return Found::Direct(kind);
        }
        for &v in &points {
            part.push_row([(v, 1.0)]);
        }
        return Found::Regular(kind);
    }
    if let Some((kind, cps)) = classify(level, g, single_crease) {
        // Control points that are vertices as they are are read from the vertices, at level
        // 0 (whose patches are whole domains, gathered once per lattice; deeper ones are
        // evaluated point by point under trees, where a gather per point costs more than it
        // saves).
        if depth == 0
            && cps
                .iter()
                .all(|c| matches!(c.terms(), [(_, w)] if *w == 1.0))
        {
            part.direct.extend(cps.iter().map(|c| c.terms()[0].0));
            return Found::Direct(kind);
        }
        for c in &cps {
            part.push_row(c.iter().copied());
        }
        return Found::Regular(kind);
    }
    if use_stam {
        if let Some((corner, verts)) = stam::gather(level, g) {
            for &v in &verts {
                part.push_row([(v, 1.0)]);
            }
            return Found::Stam(corner, verts.len());
        }
    }
    Found::Irregular
}

impl PatchTable {
    /// Settles the faces `caps` of `child` (face, node) that are irregular at the maximum level
    /// into end caps, each with its own two-ring cut out now, once, for on-demand subdivision
    /// at evaluation time. ([`Self::settle`] has already made a Stam patch of every face of
    /// that level that is Stam's configuration, unless an edit deeper than the maximum level
    /// forced it; such an edit cannot act, and the end cap evaluates the same surface.)
    fn settle_caps(&mut self, child: &Level, child_offset: u32, caps: &[(u32, u32)], depth: usize) {
        // One cut-out holding the two-rings of all caps of this level.
        let faces: Vec<u32> = caps.iter().map(|c| c.0).collect();
        let (cut, old, new_faces) = extract_faces(child, &faces, 2);
        let mut cut_first = None;
        for (&(_, node), &face) in caps.iter().zip(&new_faces) {
            let face = face as usize;
            // The cut-out's vertices become control points (once per level), and the cap keeps
            // its own two-ring of it.
            let first = *cut_first.get_or_insert_with(|| {
                let first = self.point_stencils.len() as u32;
                for &v in &old {
                    self.point_stencils.push_terms(&[(child_offset + v, 1.0)]);
                }
                first
            });
            let (level, verts, _) = extract_faces(&cut, &[face as u32], 2);
            self.end_caps.push(CapMesh {
                root: CapNode::root(level, self.options.single_crease),
                points: verts.iter().map(|&v| first + v).collect(),
            });
            self.add_leaf(
                node,
                Patch {
                    kind: PatchKind::EndCap,
                    level: depth as u8,
                    first_point: first,
                    end_cap: (self.end_caps.len() - 1) as u32,
                    ..Patch::UNSET
                },
            );
        }
    }

    /// Builds the patch table of `mesh` with its own options.
    pub fn new(mesh: &ControlMesh, opts: PatchOptions) -> Result<Self> {
        Self::with_options(mesh, mesh.options, opts)
    }

    /// Builds the patch table with subdivision options overriding the mesh's.
    pub fn with_options(mesh: &ControlMesh, options: Options, opts: PatchOptions) -> Result<Self> {
        Self::build(mesh, options, opts, true)
    }

    /// [`Self::with_options`], with Stam patches at smooth extraordinary vertices (`stam`) or
    /// every end cap subdivided on demand (for tests comparing the two).
    pub(crate) fn build(
        mesh: &ControlMesh,
        options: Options,
        opts: PatchOptions,
        stam: bool,
    ) -> Result<Self> {
        if !(1..=MAX_LEVEL).contains(&opts.max_level) {
            return Err(Error::new(
                ErrorKind::Usage,
                format!(
                    "maximum isolation level {} is outside 1..={MAX_LEVEL}",
                    opts.max_level
                ),
            ));
        }
        let (mut base, _) = Level::base(mesh, &options)?;
        edit::apply_tags(&[], &mut base, mesh);
        crate::stages::mark("table: level 0");
        let method = options.crease_method;
        // Faces under a hierarchical edit are isolated at least one level below it.
        let deepest = mesh.edits.iter().map(|e| e.level()).max().unwrap_or(0);
        if deepest >= MAX_LEVEL {
            let i = mesh
                .edits
                .iter()
                .position(|e| e.level() == deepest)
                .unwrap_or(0);
            return Err(mesh.error_at(
                ErrorKind::Usage,
                crate::mesh::Element::Edit(i),
                format!(
                    "an edit at level {deepest} is below the deepest isolation level {MAX_LEVEL}"
                ),
            ));
        }
        let opts = PatchOptions {
            // Chaikin's rule too: `classify` makes a single-crease patch only where the crease
            // continues at both ends with the same sharpness and nothing else is sharp at its
            // ends, where Chaikin's decrement is the uniform one at every level.
            single_crease: opts.single_crease,
            max_level: opts.max_level.max(1).max(deepest + 1),
            surface: opts.surface,
        };
        if matches!(opts.surface, Approximation::Pn | Approximation::Wm)
            && options.scheme != Scheme::Loop
        {
            return Err(Error::new(
                ErrorKind::Usage,
                format!(
                    "surface `{}` approximates Loop meshes (paper 002); a Catmull-Clark mesh \
                     takes `exact` or `gregory` (paper 004's Gregory patches)",
                    opts.surface
                ),
            ));
        }
        let nb = base.num_vertices();
        let mut table = PatchTable {
            patches: Vec::new(),
            nodes: Vec::new(),
            node_info: Vec::new(),
            children: Vec::new(),
            kids: Vec::new(),
            roots: Vec::new(),
            root_offsets: vec![0],
            point_stencils: StencilTable::new(nb),
            chain: Vec::new(),
            chain_edits: Vec::new(),
            base_edits: Vec::new(),
            points: Vec::new(),
            verts: Vec::new(),
            direct: Vec::new(),
            end_caps: Vec::new(),
            stam: Vec::new(),
            use_stam: stam,
            method,
            mesh_options: options,
            options: opts,
            stats: PatchStats::default(),
            loop_surface: None,
            approx: None,
            quad_approx: None,
            base_level: None,
        };
        if options.scheme == Scheme::Loop {
            // A Loop mesh's surface is its own evaluator; each triangle is three sub-quads
            // (the domains of dicing), as a Catmull-Clark triangle's sub-faces are.
            let exact = LoopSurface::new(mesh, options)?;
            if opts.surface != Approximation::Exact {
                table.approx = Some(std::sync::Arc::new(TriApprox::new(&exact, opts.surface)?));
            }
            table.loop_surface = Some(std::sync::Arc::new(exact));
            table.root_offsets = (0..=base.num_faces() as u32).map(|f| 3 * f).collect();
            return Ok(table);
        }
        table.base_edits = mesh
            .edits
            .iter()
            .filter(|e| e.level() == 0)
            .filter_map(|e| edit::position_edit(&base, e.face as usize, 0, &e.kind))
            .collect();
        // Edits below level 0, each with the face its path has reached (in the current
        // level's numbering) and the path's rotation there.
        let mut tracks: Vec<(usize, u32, u32)> = (0..mesh.edits.len())
            .filter(|&i| mesh.edits[i].level() > 0)
            .map(|i| (i, mesh.edits[i].face, 0))
            .collect();
        let mut forced = near_edits(&base, &tracks);
        let mut pending: Vec<(u32, Slot)> = Vec::new();
        // Quads are settled after every root exists (nodes are only made here, so their
        // numbering is unchanged), n-gons are refined first.
        let mut quads: Vec<(u32, bool)> = Vec::with_capacity(base.num_faces());
        let mut quad_slots: Vec<u32> = Vec::with_capacity(base.num_faces());
        // A root per quad, per sub-face of another face (reserved: grown by doubling, the
        // arrays were copied and paged in again).
        let roots: usize = (0..base.num_faces())
            .map(|f| match base.topo.face_size(f) {
                4 => 1,
                n => n,
            })
            .sum();
        table.nodes.reserve(roots);
        table.node_info.reserve(roots);
        table.roots.reserve(roots);
        table.root_offsets.reserve(base.num_faces());
        for f in 0..base.num_faces() {
            let n = base.topo.face_size(f);
            if n == 4 {
                let slot = table.new_node(f as u32, 0, Frame::UNIT);
                table.roots.push(slot);
                quads.push((f as u32, forced.contains(&(f as u32))));
                quad_slots.push(slot);
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
        crate::stages::mark("table: roots");
        let mut settled = table.settle_all(&base, 0, &quads, |i| quad_slots[i], 0);
        // Pending faces in base face order, as one pass over the faces would list them.
        crate::stages::mark("table: level-0 patches");
        settled.append(&mut pending);
        settled.sort_by_key(|p| p.0);
        let mut pending = settled;
        // Refine what is irregular, level by level, on the union of two-ring neighbourhoods.
        let mut refined: Option<Level> = None;
        let mut total = nb as u32;
        let mut depth = 0;
        while !pending.is_empty() {
            let level = refined.as_ref().unwrap_or(&base);
            let seeds: Vec<u32> = pending.iter().map(|p| p.0).collect();
            // Two rings around the seeds support the stencils; the first is refined (its
            // children hold the next level's two rings around the seeds' children).
            let (sub, old, seed_new, inner) = extract_faces_within(level, &seeds, 2);
            crate::stages::mark("table: refinement: cut-outs");
            let (mut child, t) = step::refine_inner(&sub, inner, method);
            // Follow each edit's path one level down; apply the edits that act here.
            let mut edits_here = Vec::new();
            let seed_of: std::collections::HashMap<u32, usize> = if tracks.is_empty() {
                Default::default()
            } else {
                seeds.iter().enumerate().map(|(s, &f)| (f, s)).collect()
            };
            tracks.retain_mut(|(i, f, r)| {
                let e = &mesh.edits[*i];
                // The face a path reaches is forced, so it is a seed (unless it is a hole).
                let Some(&s) = seed_of.get(f) else {
                    return false;
                };
                let (c, rc) = edit::step_path(&sub, seed_new[s] as usize, *r, e.path[depth]);
                if e.level() > depth + 1 {
                    (*f, *r) = (c as u32, rc);
                    return true;
                }
                edit::apply_tag(&mut child, c, rc, &e.kind);
                edits_here.extend(edit::position_edit(&child, c, rc, &e.kind));
                false
            });
            table.chain.push((old, t));
            table.chain_edits.push(edits_here);
            forced = near_edits(&child, &tracks);
            let child_offset = total;
            total += child.num_vertices() as u32;
            table.stats.refined_vertices += child.num_vertices();
            depth += 1;
            let mut jobs: Vec<(u32, bool)> = Vec::new();
            let mut job_slots: Vec<u32> = Vec::new();
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
                    let c = child_face(&sub, g, k) as u32;
                    jobs.push((c, forced.contains(&c)));
                    job_slots.push(s);
                }
            }
            crate::stages::mark("table: refinement: steps");
            let mut next = Vec::new();
            let mut caps = Vec::new();
            for p in table.settle_all(&child, child_offset, &jobs, |i| job_slots[i], depth) {
                match p {
                    (c, Slot::Cap(node)) => caps.push((c, node)),
                    p => next.push(p),
                }
            }
            if !caps.is_empty() {
                table.settle_caps(&child, child_offset, &caps, depth);
            }
            refined = Some(child);
            pending = next;
            crate::stages::mark("table: refinement: patches");
        }
        drop(refined);
        // Dicing reads level 0 too: kept unless edits at level 0 changed its tags or holes.
        if mesh.edits.iter().all(|e| e.level() > 0) {
            table.base_level = Some(std::sync::Arc::new(base));
        }
        table.point_stencils.num_inputs = total as usize;
        // Patches per kind and level, counted once here in an array by level and kind (a map
        // entry per patch took a 316² grid 1.5 ms).
        let mut counts = vec![[0usize; KIND_NAMES.len()]; 256];
        for p in &table.patches {
            counts[p.level as usize][kind_index(p.kind)] += 1;
        }
        table.stats.by_kind_level = counts
            .iter()
            .enumerate()
            .flat_map(|(level, row)| {
                row.iter()
                    .zip(KIND_NAMES)
                    .filter(|(&n, _)| n > 0)
                    .map(move |(&n, kind)| ((kind.to_string(), level as u8), n))
            })
            .collect();
        table.kids = table
            .children
            .iter()
            .map(|c| c.map(|n| table.nodes[n as usize]))
            .collect();
        table.children = Vec::new();
        table.node_info = Vec::new();
        table.set_positions(&mesh.positions);
        if opts.surface == Approximation::Gregory {
            table.quad_approx = Some(std::sync::Arc::new(QuadApprox::new(mesh, options, &table)?));
        }
        crate::stages::mark("table: tree, stats and points");
        Ok(table)
    }

    /// Re-poses the table: new control positions, same topology.
    pub fn set_positions(&mut self, base: &[[f64; 3]]) {
        if let Some(surface) = &mut self.loop_surface {
            let surface = std::sync::Arc::make_mut(surface);
            if let Err(e) = surface.set_positions(base) {
                panic!("PatchTable::set_positions: {e}");
            }
            if let Some(approx) = &mut self.approx {
                match TriApprox::new(surface, approx.kind()) {
                    Ok(a) => *approx = std::sync::Arc::new(a),
                    Err(e) => panic!("PatchTable::set_positions: {e}"),
                }
            }
            return;
        }
        let mut all: Vec<[f64; 3]> = base.to_vec();
        for e in &self.base_edits {
            e.apply(&mut all);
        }
        let mut start = 0;
        for ((select, t), edits) in self.chain.iter().zip(&self.chain_edits) {
            let sub: Vec<[f64; 3]> = select.iter().map(|&i| all[start + i as usize]).collect();
            let mut child = t.apply_points(&sub);
            for e in edits {
                e.apply(&mut child);
            }
            start = all.len();
            all.extend_from_slice(&child);
        }
        self.points = self.point_stencils.apply_points(&all);
        self.verts = all;
        if let Some(q) = self.quad_approx.take() {
            match q.with_positions(base, self) {
                Ok(a) => self.quad_approx = Some(std::sync::Arc::new(a)),
                Err(e) => panic!("PatchTable::set_positions: {e}"),
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use crate::coord::FaceCoord;
    use crate::patch::{PatchOptions, PatchTable};

    /// Level-0 patches whose control points are vertices read them from the vertices, the
    /// bits a stencil row of one unit term gives (`0 + 1·x`): on a 6 × 6 grid the 16 interior
    /// patches are direct (boundary ones, with phantom rows, are not); re-posed, a direct
    /// patch evaluates as a table built on the moved mesh, bit for bit.
    #[test]
    fn direct_patches_read_the_vertices() {
        let mut mesh = crate::mesh::generate::grid(6);
        // Off the plane, with negative zeros, so that the sum's sign of zero is checked.
        for (i, p) in mesh.positions.iter_mut().enumerate() {
            p[2] = if i % 3 == 0 {
                -0.0
            } else {
                0.25 * (i % 5) as f64
            };
        }
        let mut table = PatchTable::new(&mesh, PatchOptions::default()).unwrap();
        let direct: Vec<usize> = (0..table.patches.len())
            .filter(|&p| table.patches[p].direct)
            .collect();
        assert_eq!(direct.len(), 16, "the interior patches are direct");
        for &p in &direct {
            let patch = &table.patches[p];
            let first = patch.first_point as usize;
            let grid = table.grid(patch);
            for (i, cp) in grid.iter().enumerate() {
                let v = table.verts[table.direct[first + i] as usize];
                let summed = v.map(|x| 0.0 + 1.0 * x);
                assert_eq!(cp.map(f64::to_bits), summed.map(f64::to_bits), "patch {p}");
            }
        }
        let moved: Vec<[f64; 3]> = mesh
            .positions
            .iter()
            .map(|p| [p[0] - 0.5, 3.0 * p[1], p[2] + 1.0])
            .collect();
        table.set_positions(&moved);
        mesh.positions = moved;
        let fresh = PatchTable::new(&mesh, PatchOptions::default()).unwrap();
        for &p in &direct {
            let patch = &table.patches[p];
            let at = FaceCoord::quad(patch.face, 0.3, 0.6);
            let (a, b) = (table.eval(at).unwrap(), fresh.eval(at).unwrap());
            assert_eq!(a.p.map(f64::to_bits), b.p.map(f64::to_bits), "patch {p}");
        }
    }

    /// The statistics count patches by kind and level: a 6 × 6 grid is 16 interior, 16
    /// boundary and 4 corner B-spline patches at level 0; on a mesh with extraordinary
    /// vertices the counts add up to the patches, with deeper levels present.
    #[test]
    fn patch_counts_by_kind_and_level() {
        let table =
            PatchTable::new(&crate::mesh::generate::grid(6), PatchOptions::default()).unwrap();
        let got: Vec<(&str, u8, usize)> = table
            .stats
            .by_kind_level
            .iter()
            .map(|((k, l), &n)| (k.as_str(), *l, n))
            .collect();
        assert_eq!(
            got,
            [("boundary", 0, 16), ("corner", 0, 4), ("regular", 0, 16)]
        );
        let table =
            PatchTable::new(&crate::mesh::shapes::gear(7), PatchOptions::default()).unwrap();
        let total: usize = table.stats.by_kind_level.values().sum();
        assert_eq!(total, table.patches.len());
        assert!(table.stats.by_kind_level.keys().any(|(_, l)| *l > 0));
    }
}
