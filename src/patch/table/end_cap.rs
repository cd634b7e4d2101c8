//! End caps: faces still irregular at the maximum isolation level. An end cap is not an
//! approximation but the cut-out itself, subdivided further on demand at evaluation time until
//! the point falls in a regular sub-patch, or lands exactly on a vertex, whose exact limit mask
//! then applies.

use super::tree::{corner_index, descend, Frame};
use super::PatchTable;
use crate::patch::bspline::{self, ControlGrid, PatchPoint};
use crate::patch::local::{child_face, LocalMesh};
use crate::patch::regular::{classify, RegularKind};
use crate::patch::single_crease;
use crate::refine::limit::vertex_limit_frame;
use crate::refine::Level;

/// Deepest on-demand subdivision inside an end cap; points closer than 2^-60 of the cap's size
/// to a vertex take that vertex's exact limit position.
const MAX_ON_DEMAND: usize = 60;

/// The neighbourhood of one end cap, cut out at build time: the two-ring of the cap's face
/// (face 0, same vertex order) and each vertex's control point in [`PatchTable::points`].
#[derive(Clone, Debug)]
pub(super) struct CapMesh {
    pub(super) level: Level,
    pub(super) points: Vec<u32>,
}

impl PatchTable {
    /// Evaluates end cap `cap` at its face's (s0, t0) by subdivision on demand; returns the
    /// point (derivatives in (s0, t0)) and the number of levels subdivided.
    pub(super) fn on_demand(&self, cap: &CapMesh, s0: f64, t0: f64) -> (PatchPoint, u8) {
        let data: Vec<f64> = cap
            .points
            .iter()
            .flat_map(|&i| self.points[i as usize])
            .collect();
        let mut mesh = LocalMesh {
            level: cap.level.clone(),
            data,
            width: 3,
        };
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
