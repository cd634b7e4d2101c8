//! The exact limit position at a dyadic `(face, k, u, v)` from refined limit masks: the
//! neighbourhood of the face is refined locally until the point is a vertex, whose limit mask
//! (refine::limit) then gives the position. This shares the rules with the patch table but not
//! its evaluation (patch recognition, B-spline and single-crease bases, end-cap descent), so it
//! checks our evaluation where Far's is approximate (its end caps and patches at the maximum
//! isolation level).

use limitray::mesh::ControlMesh;
use limitray::patch::local::{child_face, LocalMesh};
use limitray::refine::limit::vertex_limit_frame;
use limitray::refine::Level;

/// Deepest level searched for the vertex.
const MAX_DEPTH: usize = 24;

/// A vertex's limit mask is exact only once every semi-sharp feature at it has decayed
/// (sharpness below 10 is gone after 10 levels); until then the refinement goes on, the point
/// staying at the same corner of the child face.
const MIN_DEPTH: usize = 11;

/// Child quadrant corners and axes (the ptex orientation of child faces, see
/// refine/step.rs: child k has (0, 0) at corner k and u towards the midpoint of edge k).
const CORNER: [[f64; 2]; 4] = [[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]];
const UAX: [[f64; 2]; 4] = [[1.0, 0.0], [0.0, 1.0], [-1.0, 0.0], [0.0, -1.0]];
const VAX: [[f64; 2]; 4] = [[0.0, 1.0], [-1.0, 0.0], [0.0, -1.0], [1.0, 0.0]];

fn corner(s: f64, t: f64) -> Option<usize> {
    CORNER.iter().position(|c| c[0] == s && c[1] == t)
}

/// The exact limit position at `(face, k, u, v)`, or `None` when the point is not dyadic to
/// [`MAX_DEPTH`] levels or the face is a hole.
pub fn limit_at(mesh: &ControlMesh, face: usize, k: usize, u: f64, v: f64) -> Option<[f64; 3]> {
    let (base, _) = Level::base(mesh, &mesh.options).ok()?;
    if base.face_hole[face] {
        return None;
    }
    let method = mesh.options.crease_method;
    let data: Vec<f64> = mesh.positions.iter().flatten().copied().collect();
    let mut m = LocalMesh::extract(&base, &data, 3, face, 2);
    if base.topo.face_size(face) != 4 {
        let r = m.refine(method);
        let c = child_face(&m.level, 0, k);
        m = LocalMesh::extract(&r.level, &r.data, 3, c, 2);
    }
    let (mut s, mut t) = (u, v);
    for depth in 0..MAX_DEPTH {
        if let Some(q) = corner(s, t).filter(|_| depth >= MIN_DEPTH) {
            let vtx = m.level.topo.face_vertices(0)[q] as usize;
            let pos: Vec<[f64; 3]> = m.data.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect();
            return Some(vertex_limit_frame(&m.level, vtx, &pos, method).position);
        }
        let q = match (s >= 0.5, t >= 0.5) {
            (false, false) => 0,
            (true, false) => 1,
            (true, true) => 2,
            (false, true) => 3,
        };
        let d = [s - CORNER[q][0], t - CORNER[q][1]];
        s = 2.0 * (d[0] * UAX[q][0] + d[1] * UAX[q][1]);
        t = 2.0 * (d[0] * VAX[q][0] + d[1] * VAX[q][1]);
        let r = m.refine(method);
        let c = child_face(&m.level, 0, q);
        m = LocalMesh::extract(&r.level, &r.data, 3, c, 2);
    }
    None
}
