//! End caps: faces still irregular at the maximum isolation level that are not Stam patches.
//! An end cap is not an approximation but the face's two-ring itself, subdivided further on
//! demand at evaluation time until the point falls in a regular sub-patch, or lands exactly on
//! a vertex, whose exact limit mask then applies. The refined topology and stencils are kept
//! (per cap, a quadtree filled lazily by the queries, down to `CACHE_DEPTH` levels), so a query
//! only applies small stencil tables to the cap's points.

use super::tree::{corner_index, descend, Frame};
use super::PatchTable;
use crate::mesh::CreaseMethod;
use crate::patch::bspline::{self, ControlGrid, PatchPoint};
use crate::patch::local::{child_face, extract_faces, LocalMesh};
use crate::patch::regular::{classify, Combo, RegularKind};
use crate::patch::single_crease;
use crate::refine::limit::vertex_limit_frame;
use crate::refine::stencil::StencilTable;
use crate::refine::{step, Level};
use std::sync::OnceLock;

/// Deepest on-demand subdivision inside an end cap; points closer than 2^-60 of the cap's size
/// to a vertex take that vertex's exact limit position.
const MAX_ON_DEMAND: usize = 60;

/// Deepest on-demand level whose refinement an end cap keeps ([`CapNode`]); deeper levels
/// (points within 2^-20 of the cap's size of an irregular vertex) are refined per query.
const CACHE_DEPTH: usize = 20;

/// The neighbourhood of one end cap, cut out at build time: the two-ring of the cap's face
/// (face 0, same vertex order) and each vertex's control point in [`PatchTable::points`], with
/// the on-demand refinement below it.
#[derive(Clone, Debug)]
pub(super) struct CapMesh {
    pub(super) root: CapNode,
    pub(super) points: Vec<u32>,
}

/// One face of an end cap's on-demand quadtree: its two-ring (face 0, the face), the rows that
/// compute the two-ring's vertices from the parent's (empty at the root), the face's regular
/// patch if it is one, and its children, refined when a query first reaches them. Everything
/// here depends on topology and tags only, so it survives [`PatchTable::set_positions`].
#[derive(Clone, Debug)]
pub(super) struct CapNode {
    pub(super) level: Level,
    rows: StencilTable,
    patch: Option<(RegularKind, [Combo; 16])>,
    kids: [OnceLock<Box<CapNode>>; 4],
}

impl CapNode {
    /// The root of an end cap: face 0 of `level`.
    pub(super) fn root(level: Level, single_crease: bool) -> CapNode {
        CapNode {
            patch: classify(&level, 0, single_crease),
            rows: StencilTable::new(level.num_vertices()),
            level,
            kids: Default::default(),
        }
    }

    /// Child `q` of the node's face after one refinement step, with its own two-ring.
    fn child(&self, q: usize, method: CreaseMethod, single_crease: bool) -> CapNode {
        let (refined, table) = step::refine(&self.level, method);
        let c = child_face(&self.level, 0, q);
        let (level, old, _) = extract_faces(&refined, &[c as u32], 2);
        let mut rows = StencilTable::new(self.level.num_vertices());
        for &v in &old {
            let (idx, w) = table.row(v as usize);
            let terms: Vec<(u32, f64)> = idx.iter().copied().zip(w.iter().copied()).collect();
            rows.push_terms(&terms);
        }
        CapNode {
            patch: classify(&level, 0, single_crease),
            rows,
            level,
            kids: Default::default(),
        }
    }
}

/// A regular patch given as combinations of the points `data` (3 values each), at (s, t).
fn eval_regular(kind: RegularKind, cps: &[Combo; 16], data: &[f64], s: f64, t: f64) -> PatchPoint {
    let grid: ControlGrid = std::array::from_fn(|i| {
        let mut p = [0.0; 3];
        for &(v, w) in &cps[i] {
            let q = &data[3 * v as usize..3 * v as usize + 3];
            for c in 0..3 {
                p[c] += w * q[c];
            }
        }
        p
    });
    match kind {
        RegularKind::BSpline { .. } => bspline::eval(&grid, s, t),
        RegularKind::SingleCrease { edge, sharpness } => {
            single_crease::eval(&grid, edge as usize, sharpness as f64, s, t)
        }
    }
}

fn as_points(data: &[f64]) -> Vec<[f64; 3]> {
    data.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect()
}

impl PatchTable {
    /// Evaluates end cap `cap` at its face's (s0, t0) by subdivision on demand; returns the
    /// point (derivatives in (s0, t0)) and the number of levels subdivided.
    pub(super) fn on_demand(&self, cap: &CapMesh, s0: f64, t0: f64) -> (PatchPoint, u8) {
        let sc = self.options.single_crease;
        let mut data: Vec<f64> = cap
            .points
            .iter()
            .flat_map(|&i| self.points[i as usize])
            .collect();
        let corner_p = corner_index(s0, t0).map(|q| {
            let v = cap.root.level.topo.face_vertices(0)[q] as usize;
            vertex_limit_frame(&cap.root.level, v, &as_points(&data), self.method).position
        });
        // At an exact corner the derivative may not exist (extraordinary vertex): take the
        // exact limit position there, and the derivatives 2^-10 of the patch inside the face.
        let (mut s, mut t) = (s0, t0);
        if corner_p.is_some() {
            let eps = 2f64.powi(-10);
            s = if s0 == 0.0 { eps } else { 1.0 - eps };
            t = if t0 == 0.0 { eps } else { 1.0 - eps };
        }
        let mut frame = Frame::UNIT;
        let mut depth = 0usize;
        let mut result = None;
        // The kept levels: refined once, by the first query that reaches them.
        let mut node = &cap.root;
        while depth < CACHE_DEPTH.min(MAX_ON_DEMAND) {
            if let Some((kind, cps)) = &node.patch {
                result = Some(eval_regular(*kind, cps, &data, s, t));
                break;
            }
            let (q, s2, t2) = descend(s, t);
            // Built without forking: see `threads::sequential` for the deadlock a fork risks.
            let child = node.kids[q].get_or_init(|| {
                crate::threads::sequential(|| Box::new(node.child(q, self.method, sc)))
            });
            data = child.rows.apply(&data, 3);
            node = child;
            frame = frame.child(q);
            s = s2;
            t = t2;
            depth += 1;
        }
        // Deeper: refined per query, not kept.
        let mut deep: Option<LocalMesh> = None;
        if result.is_none() {
            let mut mesh = LocalMesh {
                level: node.level.clone(),
                data: std::mem::take(&mut data),
                width: 3,
            };
            while depth < MAX_ON_DEMAND {
                if let Some((kind, cps)) = classify(&mesh.level, 0, sc) {
                    result = Some(eval_regular(kind, &cps, &mesh.data, s, t));
                    break;
                }
                let refined = mesh.refine(self.method);
                let (q, s2, t2) = descend(s, t);
                let c = child_face(&mesh.level, 0, q);
                mesh = LocalMesh::extract(&refined.level, &refined.data, 3, c, 2);
                frame = frame.child(q);
                s = s2;
                t = t2;
                depth += 1;
            }
            deep = Some(mesh);
        }
        let mut pt = result.unwrap_or_else(|| {
            // within 2^-60 of a vertex: its exact limit position
            let (level, data) = match &deep {
                Some(m) => (&m.level, &m.data),
                None => (&node.level, &data),
            };
            let (q, _, _) = descend(s, t);
            let v = level.topo.face_vertices(0)[q] as usize;
            let fr = vertex_limit_frame(level, v, &as_points(data), self.method);
            PatchPoint {
                p: fr.position,
                ..Default::default()
            }
        });
        pt = frame.face_point(pt);
        if let Some(p) = corner_p {
            pt.p = p;
        }
        (pt, depth as u8)
    }
}

#[cfg(test)]
mod tests {
    use crate::coord::FaceCoord;
    use crate::harness::rng::SplitMix64;
    use crate::mesh::{generate, EdgeCrease, SHARPNESS_INFINITE};
    use crate::patch::table::{PatchKind, PatchOptions, PatchTable};

    #[test]
    fn kept_refinement_gives_the_same_bits_as_a_cold_table() {
        // A dart (one infinitely sharp edge at a valence-5 vertex): end caps, not Stam patches.
        let mut mesh = generate::star(5, 3);
        mesh.creases.push(EdgeCrease {
            v0: 0,
            v1: 1,
            sharpness: SHARPNESS_INFINITE,
        });
        let warm = PatchTable::new(&mesh, PatchOptions::default()).unwrap();
        assert!(warm.patches.iter().any(|p| p.kind == PatchKind::EndCap));
        let mut rng = SplitMix64::new(3);
        let queries: Vec<FaceCoord> = (0..400)
            .map(|_| {
                // Face 9·i has the dart at (0, 0); distances 2^-k down to 2^-70 cross the kept
                // depth (cap at level 10, CACHE_DEPTH levels more).
                let f = 9 * rng.below(5) as u32;
                let r = 2f64.powi(-(rng.below(71) as i32));
                FaceCoord::quad(f, r * rng.next_f64(), r * rng.next_f64())
            })
            .collect();
        let first: Vec<_> = queries.iter().map(|&q| warm.eval(q).unwrap()).collect();
        // Same queries again on the now warm table, and in reverse order on a cold one.
        let cold = PatchTable::new(&mesh, PatchOptions::default()).unwrap();
        for (i, &q) in queries.iter().enumerate().rev() {
            assert_eq!(warm.eval(q).unwrap(), first[i]);
            assert_eq!(cold.eval(q).unwrap(), first[i]);
        }
        // Deep queries reached below the kept levels.
        assert!(first
            .iter()
            .any(|s| s.level as usize > 10 + super::CACHE_DEPTH));
    }
}
