//! The pieces of a Loop limit surface, for the reference intersector ([`crate::exact`]).
//!
//! Each face's tree ([`crate::patch::LoopSurface`]) gives them: a regular leaf is a quartic
//! polynomial over its triangle, cut into three [`Shape::Quartic`] squares of half the
//! triangle's side (the lower-left one inside the triangle, the two on its hypotenuse half
//! inside; the fourth, wholly beyond it, is dropped); a leaf at an irregular vertex is a
//! [`Shape::LoopCap`], bounded by its cut-out's hull and refined once per split, its regular
//! children becoming quartic pieces in turn. A piece's frame maps its own `(s, t)` to the
//! face's triangle parameter, so hits come out in the face's `(u, v)` with `k = 0`.

use super::pieces::{is_hole, Piece, Shape};
use super::tree::Frame;
use super::PatchTable;
use crate::patch::local::LocalMesh;
use crate::patch::loop_box;
use crate::patch::loop_surface::Leaf;
use crate::patch::quartic;
use crate::refine::loop_step::child_uv;

/// The frame of child triangle `k` ([`child_uv`]) in its parent's triangle parameter.
fn child_frame(k: usize) -> Frame {
    let o = child_uv(k, 0.0, 0.0);
    let a = child_uv(k, 1.0, 0.0);
    let b = child_uv(k, 0.0, 1.0);
    Frame {
        o: [o.0, o.1],
        a: [a.0 - o.0, a.1 - o.1],
        b: [b.0 - o.0, b.1 - o.1],
    }
}

fn max_abs<const N: usize>(pts: &[[f64; 3]; N]) -> f64 {
    pts.iter().flatten().fold(0.0f64, |m, x| m.max(x.abs()))
}

/// Pushes the quartic pieces of the regular patch of control points `cps`
/// ([`loop_box::LATTICE`] order) over the triangle `frame`.
fn regular_pieces(cps: &[[f64; 3]; 12], face: u32, frame: Frame, depth: u8, out: &mut Vec<Piece>) {
    let m = loop_box::bezier_matrix();
    let tri: [[f64; 3]; 15] = std::array::from_fn(|n| {
        std::array::from_fn(|c| (0..12).map(|i| m[n][i] * cps[i][c]).sum())
    });
    // Rounding of the net (12 products and sums per point, weights summing to ≤ `gain` in
    // absolute value) and of the conversion to the tensor grid.
    let gain = m
        .iter()
        .map(|r| r.iter().map(|w| w.abs()).sum::<f64>())
        .fold(0.0, f64::max);
    let net_pad = 16.0 * f64::EPSILON * gain * max_abs(cps);
    for (&q, (grid, conv)) in quartic::QUADRANTS.iter().zip(quartic::from_triangle(&tri)) {
        let corner = [[0.0, 0.0], [0.5, 0.0], [0.5, 0.5], [0.0, 0.5]][q];
        let quadrant = Frame {
            o: corner,
            a: [0.5, 0.0],
            b: [0.0, 0.5],
        };
        out.push(Piece {
            face,
            k: 0,
            frame: frame.then(&quadrant),
            depth,
            shape: Shape::Quartic {
                grid: Box::new(grid),
                c: corner[0] + corner[1],
                h: 0.5,
                pad: net_pad + conv * max_abs(&tri),
            },
        });
    }
}

impl PatchTable {
    /// Pushes the pieces of Loop face `f` (none for holes, or for a Catmull-Clark table).
    pub fn loop_pieces(&self, f: usize, out: &mut Vec<Piece>) {
        let Some(surface) = self.loop_surface() else {
            return;
        };
        surface.leaves(f, &mut |path, leaf| {
            let frame = path
                .iter()
                .fold(Frame::UNIT, |fr, &k| fr.then(&child_frame(k as usize)));
            match leaf {
                Leaf::Regular(cps) => regular_pieces(cps, f as u32, frame, 0, out),
                Leaf::Cap(mesh) => out.push(Piece {
                    face: f as u32,
                    k: 0,
                    frame,
                    depth: 0,
                    shape: Shape::LoopCap(Box::new(mesh.clone())),
                }),
            }
        });
    }

    /// Pushes the children of a Loop cap piece: its cut-out refined once, each child triangle
    /// a quartic piece where regular, another cap piece where not (holes dropped).
    pub(super) fn split_loop_cap(&self, piece: &Piece, mesh: &LocalMesh, out: &mut Vec<Piece>) {
        let Some(surface) = self.loop_surface() else {
            return;
        };
        let depth = piece.depth + 1;
        let refined = mesh.refine(surface.crease_method());
        for k in 0..4 {
            // Face 0's children are faces 0..4 of the refined cut-out.
            let child = LocalMesh::extract(&refined.level, &refined.data, 3, k, 2);
            let frame = piece.frame.then(&child_frame(k));
            if let Some(cps) = loop_box::gather(&child.level, 0) {
                let cps = cps.map(|p| p.position(|i| point(&child, i)));
                regular_pieces(&cps, piece.face, frame, depth, out);
            } else if child.level.topo.num_faces() > 0 && !is_hole(&child) {
                out.push(Piece {
                    face: piece.face,
                    k: 0,
                    frame,
                    depth,
                    shape: Shape::LoopCap(Box::new(child)),
                });
            }
        }
    }
}

fn point(mesh: &LocalMesh, i: u32) -> [f64; 3] {
    let p = mesh.point(i as usize);
    [p[0], p[1], p[2]]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::coord::FaceCoord;
    use crate::harness::rng::SplitMix64;
    use crate::mesh::{shapes, Scheme};
    use crate::patch::PatchOptions;

    /// Every point of every face lies in exactly the pieces whose part of the triangle holds
    /// it, and a quartic piece's polynomial there is the surface (1e-13 of the diagonal);
    /// splitting a cap piece keeps that.
    #[test]
    fn pieces_cover_the_faces_and_equal_the_surface() {
        let mut mesh = shapes::blob();
        mesh.options.scheme = Scheme::Loop;
        let table = PatchTable::new(&mesh, PatchOptions::default()).unwrap();
        let diag = mesh.diagonal();
        let mut r = SplitMix64::new(5);
        let mut caps = 0;
        for f in 0..table.num_faces() {
            let mut pieces = Vec::new();
            table.loop_pieces(f, &mut pieces);
            // Split the caps twice, to check their children too.
            for _ in 0..2 {
                let mut next = Vec::new();
                for p in pieces {
                    if let Shape::LoopCap(m) = &p.shape {
                        caps += 1;
                        table.split_loop_cap(&p, m, &mut next);
                    } else {
                        next.push(p);
                    }
                }
                pieces = next;
            }
            for _ in 0..20 {
                let (mut u, mut v) = (r.next_f64(), r.next_f64());
                if u + v > 1.0 {
                    (u, v) = (1.0 - u, 1.0 - v);
                }
                let want = table
                    .eval_triangle(FaceCoord::new(f as u32, 0, u, v))
                    .unwrap()
                    .p;
                let holding: Vec<&Piece> = pieces
                    .iter()
                    .filter(|p| {
                        let [s, t] = p.local_st(u, v);
                        let inside = (-1e-12..=1.0 + 1e-12).contains(&s)
                            && (-1e-12..=1.0 + 1e-12).contains(&t);
                        let in_tri = matches!(p.shape, Shape::LoopCap(_))
                            .then(|| s + t <= 1.0 + 1e-12)
                            .unwrap_or(true);
                        inside && in_tri && p.holds(s, t)
                    })
                    .collect();
                assert!(!holding.is_empty(), "face {f} ({u}, {v}) in no piece");
                for p in holding {
                    if let Shape::Quartic { grid, .. } = &p.shape {
                        let [s, t] = p.local_st(u, v);
                        let got = quartic::eval(grid, s, t);
                        let d = (0..3).map(|c| (got[c] - want[c]).abs()).fold(0.0, f64::max);
                        assert!(d <= 1e-13 * diag, "face {f}: {d:e}");
                    }
                }
            }
        }
        assert!(caps > 0, "the blob has irregular vertices");
    }
}
