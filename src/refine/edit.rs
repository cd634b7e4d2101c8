//! Hierarchical edits ([`crate::mesh::edit`]) applied during uniform refinement: sharpness and
//! hole edits change a level's tags before the next level is derived from it; position edits
//! change a level's points after its stencils computed them, before the next level's stencils
//! read them (paper 001 §6.3: an edit acts on an element as it is created).

use super::crease;
use super::level::Level;
use super::step;
use crate::error::{ErrorKind, Result};
use crate::mesh::{ControlMesh, EditKind, EditOp, Element, Scheme};

/// A position edit resolved to a vertex of its level.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PositionEdit {
    /// The vertex of the level.
    pub vertex: u32,
    /// Operation.
    pub op: EditOp,
    /// Value.
    pub value: [f64; 3],
}

impl PositionEdit {
    /// Applies the edit to `points` (the level's positions).
    pub fn apply(&self, points: &mut [[f64; 3]]) {
        let p = &mut points[self.vertex as usize];
        for (x, v) in p.iter_mut().zip(self.value) {
            *x = self.op.apply(*x, v);
        }
    }
}

/// Refuses edits where they cannot apply: under the Loop scheme (only Catmull-Clark's child
/// numbering is defined here, and the corpus's edited shapes are all Catmull-Clark).
pub fn check_scheme(mesh: &ControlMesh, scheme: Scheme) -> Result<()> {
    if scheme == Scheme::Loop && !mesh.edits.is_empty() {
        return Err(mesh.error_at(
            ErrorKind::Usage,
            Element::Edit(0),
            "hierarchical edits are supported on Catmull-Clark meshes only",
        ));
    }
    Ok(())
}

/// One step down an edit's path: sub-face `k` (in the path's numbering) of face `f` of
/// `parent`, reached with rotation `r`; returns the child face and its rotation.
///
/// Hbr numbers a quad's children so that child `k`'s corner `k` (not its corner 0) is the
/// child of the parent's corner `k`: the children keep their parent's orientation. So corner
/// `j` of the face a path reaches is our corner `(j + r) mod 4`, where `r` is minus the last
/// sub-face index when that step split a quad, and 0 when it split another polygon (whose
/// children Hbr, like us, starts at the parent's corner). Sub-face `k` of a face with
/// rotation `r` is our child `(k + r) mod n`. (Measured: catmark_square_hedit0's level-2 and
/// level-3 edits match Hbr's baselines only with this rotation.)
pub fn step_path(parent: &Level, f: usize, r: u32, k: u32) -> (usize, u32) {
    let n = parent.topo.face_size(f) as u32;
    let ours = (k + r) % n;
    let child = step::child_face(parent, f, ours as usize);
    (child, if n == 4 { (4 - ours) % 4 } else { 0 })
}

/// The face at the end of edit `i`'s path, and its rotation ([`step_path`]); `parents` holds
/// every level above the edit's.
fn resolve_face(parents: &[Level], mesh: &ControlMesh, i: usize) -> (usize, u32) {
    let e = &mesh.edits[i];
    let (mut f, mut r) = (e.face as usize, 0u32);
    for (l, &k) in e.path.iter().enumerate() {
        (f, r) = step_path(&parents[l], f, r, k);
    }
    (f, r)
}

/// Our index of corner or edge `x` of a face reached with rotation `r`, of `n` corners.
fn local(x: u32, r: u32, n: usize) -> usize {
    ((x + r) % n as u32) as usize
}

/// Applies a sharpness or hole edit to face `f` (rotation `r`) of `lvl`; position edits are
/// [`position_edit`]'s.
pub fn apply_tag(lvl: &mut Level, f: usize, r: u32, kind: &EditKind) {
    let n = lvl.topo.face_size(f);
    match *kind {
        EditKind::VertexSharpness { corner, op, value } => {
            let v = lvl.topo.face_vertices(f)[local(corner, r, n)] as usize;
            let s = op.apply(lvl.vertex_sharpness[v] as f64, value as f64) as f32;
            lvl.vertex_sharpness[v] = crease::canonical(s);
        }
        EditKind::EdgeSharpness { edge, op, value } => {
            let e = lvl.topo.face_edge_list(f)[local(edge, r, n)] as usize;
            let s = op.apply(lvl.edge_sharpness[e] as f64, value as f64) as f32;
            lvl.edge_sharpness[e] = crease::canonical(s);
        }
        EditKind::Hole => lvl.face_hole[f] = true,
        EditKind::Position { .. } => {}
    }
}

/// A position edit on face `f` (rotation `r`) of `lvl`, resolved to its vertex (`None` for
/// the other kinds).
pub fn position_edit(lvl: &Level, f: usize, r: u32, kind: &EditKind) -> Option<PositionEdit> {
    let EditKind::Position { corner, op, value } = *kind else {
        return None;
    };
    let fv = lvl.topo.face_vertices(f);
    Some(PositionEdit {
        vertex: fv[local(corner, r, fv.len())],
        op,
        value,
    })
}

/// Applies the sharpness and hole edits of `mesh` that act at level `parents.len()` to `lvl`,
/// that level (`parents` holds the levels above it).
pub fn apply_tags(parents: &[Level], lvl: &mut Level, mesh: &ControlMesh) {
    let level = parents.len();
    for (i, e) in mesh.edits.iter().enumerate() {
        if e.level() == level {
            let (f, r) = resolve_face(parents, mesh, i);
            apply_tag(lvl, f, r, &e.kind);
        }
    }
}

/// The position edits of `mesh` acting at each level of `levels` (element `l` for level `l`).
pub fn position_edits(levels: &[Level], mesh: &ControlMesh) -> Vec<Vec<PositionEdit>> {
    let mut out = vec![Vec::new(); levels.len()];
    for (i, e) in mesh.edits.iter().enumerate() {
        let level = e.level();
        if level >= levels.len() {
            continue;
        }
        let (f, r) = resolve_face(&levels[..level], mesh, i);
        out[level].extend(position_edit(&levels[level], f, r, &e.kind));
    }
    out
}
