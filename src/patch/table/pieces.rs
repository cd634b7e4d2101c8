//! The limit surface of a patch table as pieces with certain bounds, for the reference
//! intersector ([`crate::exact`]).
//!
//! A piece is a part of one (sub-)face's domain, an affine image of `[0, 1]²` (a quadtree frame),
//! with a description of the surface over it that bounds it:
//!
//! - [`Shape::Bezier`]: the surface is exactly a bicubic polynomial there, given by its
//!   Bernstein points (B-spline leaves; each polynomial segment of a single-crease leaf; the
//!   regular rings of Stam patches and of end caps). The points' convex hull bounds it and
//!   de Casteljau splits it.
//! - [`Shape::StamCorner`] and [`Shape::Cap`]: a square at an irregular vertex, bounded by the
//!   convex hull of the control points that define it (every subdivision rule, sharp or not,
//!   has non-negative weights, so the limit surface over a face lies in the hull of the
//!   points it is computed from). Splitting one subdivides those points once: regular
//!   children become Bézier pieces, the child at the irregular vertex another hull piece.
//!
//! Pieces partition every face's domain (holes have none), so a search over them sees the
//! whole surface and nothing else.

use super::tree::{Frame, CORNER, UAX, VAX};
use super::{PatchKind, PatchTable};
use crate::patch::bezier::{self, BezierGrid};
use crate::patch::bspline::ControlGrid;
use crate::patch::local::{child_face, LocalMesh};
use crate::patch::quartic::{self, QuarticGrid};
use crate::patch::regular::{classify, Combo, RegularKind};
use crate::patch::single_crease::SingleCreasePatch;
use crate::patch::stam::MAX_DEPTH;

/// A piece of the limit surface over part of one (sub-)face.
#[derive(Clone, Debug)]
pub struct Piece {
    /// Base face.
    pub face: u32,
    /// Sub-face.
    pub k: u32,
    /// The piece's domain in the (sub-)face's `(u, v)`: `frame` maps the piece's own
    /// `(s, t) ∈ [0, 1]²` there.
    pub(crate) frame: Frame,
    /// Splits since the table's leaf (bounds the work on one ray).
    pub depth: u8,
    /// The surface over the piece.
    pub shape: Shape,
}

/// What a [`Piece`] knows of the surface over it.
#[derive(Clone, Debug)]
pub enum Shape {
    /// Exactly the bicubic patch of these Bernstein points over the piece's `(s, t)`.
    Bezier(Box<BezierGrid>),
    /// The corner square at depth `m` of Stam patch `patch`: its surface lies in the hull of
    /// `points` (`A^m` times the patch's control points).
    StamCorner {
        /// Index of the patch in [`PatchTable::patches`].
        patch: u32,
        /// Depth below the patch.
        m: u8,
        /// The square's control points.
        points: Vec<[f64; 3]>,
    },
    /// A face of an end cap's on-demand subdivision that is still irregular: face 0 of `mesh`
    /// (its two-ring, positions as data); its surface lies in the hull of the mesh's points.
    Cap(Box<LocalMesh>),
    /// Exactly the quartic of this tensor grid over the piece's `(s, t)`, a part of a regular
    /// Loop patch ([`crate::patch::quartic`]). The piece's square lies in the square of the
    /// patch's triangle, and only its part where `c + h (s + t) ≤ 1` is the triangle's: the
    /// rest is the polynomial continued beyond it (not the surface).
    Quartic {
        /// The Bernstein points over the piece's square.
        grid: Box<QuarticGrid>,
        /// `s + t` of the triangle's parameter at the square's corner `(0, 0)`.
        c: f64,
        /// The square's side in the triangle's parameter.
        h: f64,
        /// A bound on the rounding of the grid's points (absolute).
        pad: f64,
    },
    /// A triangle of a Loop cut-out that is still irregular: face 0 of `mesh` (its two-ring,
    /// positions as data). The piece's `(s, t)` is that triangle's parameter; its surface lies
    /// in the hull of the mesh's points (Loop's rules have non-negative weights).
    LoopCap(Box<LocalMesh>),
}

impl Piece {
    /// The points whose convex hull contains the surface over the piece.
    pub fn hull(&self) -> std::borrow::Cow<'_, [[f64; 3]]> {
        match &self.shape {
            Shape::Bezier(g) => std::borrow::Cow::Borrowed(&g[..]),
            Shape::StamCorner { points, .. } => std::borrow::Cow::Borrowed(points),
            Shape::Quartic { grid, .. } => std::borrow::Cow::Borrowed(&grid[..]),
            Shape::Cap(mesh) | Shape::LoopCap(mesh) => std::borrow::Cow::Owned(
                mesh.data
                    .chunks_exact(3)
                    .map(|c| [c[0], c[1], c[2]])
                    .collect(),
            ),
        }
    }

    /// A bound on the rounding of [`Self::hull`]'s points beyond the splits' own (absolute).
    pub fn pad(&self) -> f64 {
        match &self.shape {
            Shape::Quartic { pad, .. } => *pad,
            _ => 0.0,
        }
    }

    /// The middle of the piece's domain in its own `(s, t)`: the centroid of a triangle, the
    /// centre of a square.
    pub fn centre(&self) -> (f64, f64) {
        match &self.shape {
            Shape::LoopCap(_) => (1.0 / 3.0, 1.0 / 3.0),
            _ => (0.5, 0.5),
        }
    }

    /// Whether the piece's own `(s, t)` is on its surface: always for a square piece; for a
    /// quartic piece, within its triangle's part (up to 2^-40 of the triangle's parameter).
    pub fn holds(&self, s: f64, t: f64) -> bool {
        match &self.shape {
            Shape::Quartic { c, h, .. } => c + h * (s + t) <= 1.0 + 2f64.powi(-40),
            _ => true,
        }
    }

    /// Maps the piece's own `(s, t)` to the (sub-)face's `(u, v)`.
    pub fn face_uv(&self, s: f64, t: f64) -> [f64; 2] {
        let f = &self.frame;
        [
            f.o[0] + s * f.a[0] + t * f.b[0],
            f.o[1] + s * f.a[1] + t * f.b[1],
        ]
    }

    /// The piece's own `(s, t)` of the (sub-)face's `(u, v)` (the inverse of
    /// [`Self::face_uv`]).
    pub fn local_st(&self, u: f64, v: f64) -> [f64; 2] {
        let f = &self.frame;
        let (x, y) = (u - f.o[0], v - f.o[1]);
        let det = f.a[0] * f.b[1] - f.a[1] * f.b[0];
        [
            (x * f.b[1] - y * f.b[0]) / det,
            (f.a[0] * y - f.a[1] * x) / det,
        ]
    }

    /// The frame of quadrant `q` (the square's corners' order) of the piece's square.
    fn quadrant(&self, q: usize) -> Frame {
        // Quadrants keep the axes (unlike the table's rotated children).
        let c = [0.5 * CORNER[q][0], 0.5 * CORNER[q][1]];
        let f = &self.frame;
        Frame {
            o: [
                f.o[0] + c[0] * f.a[0] + c[1] * f.b[0],
                f.o[1] + c[0] * f.a[1] + c[1] * f.b[1],
            ],
            a: [0.5 * f.a[0], 0.5 * f.a[1]],
            b: [0.5 * f.b[0], 0.5 * f.b[1]],
        }
    }

    /// The four quadrants of a Bézier piece.
    pub fn split_bezier(&self, g: &BezierGrid) -> [Piece; 4] {
        let kids = bezier::split(g);
        std::array::from_fn(|q| Piece {
            face: self.face,
            k: self.k,
            frame: self.quadrant(q),
            depth: self.depth.saturating_add(1),
            shape: Shape::Bezier(Box::new(kids[q])),
        })
    }

    /// Pushes the quadrants of a quartic piece that hold part of its triangle.
    pub fn split_quartic(&self, out: &mut Vec<Piece>) {
        let Shape::Quartic { grid, c, h, pad } = &self.shape else {
            return;
        };
        let kids = quartic::split(grid);
        for (q, kid) in kids.into_iter().enumerate() {
            let c = c + 0.5 * h * (CORNER[q][0] + CORNER[q][1]);
            if c >= 1.0 {
                continue;
            }
            out.push(Piece {
                face: self.face,
                k: self.k,
                frame: self.quadrant(q),
                depth: self.depth.saturating_add(1),
                shape: Shape::Quartic {
                    grid: Box::new(kid),
                    c,
                    h: 0.5 * h,
                    pad: *pad,
                },
            });
        }
    }
}

/// Frame of a sub-rectangle `[s0, s1] × [t0, t1]` of `f`'s square.
fn sub_rect(f: &Frame, s0: f64, s1: f64, t0: f64, t1: f64) -> Frame {
    Frame {
        o: [
            f.o[0] + s0 * f.a[0] + t0 * f.b[0],
            f.o[1] + s0 * f.a[1] + t0 * f.b[1],
        ],
        a: [(s1 - s0) * f.a[0], (s1 - s0) * f.a[1]],
        b: [(t1 - t0) * f.b[0], (t1 - t0) * f.b[1]],
    }
}

/// Pushes the Bézier pieces of a regular patch of `grid` over `frame`.
fn regular_pieces(
    kind: RegularKind,
    grid: &ControlGrid,
    face: u32,
    k: u32,
    frame: Frame,
    depth: u8,
    out: &mut Vec<Piece>,
) {
    let mut push = |g: BezierGrid, frame: Frame| {
        out.push(Piece {
            face,
            k,
            frame,
            depth,
            shape: Shape::Bezier(Box::new(g)),
        })
    };
    match kind {
        RegularKind::BSpline { .. } => push(bezier::from_bspline(grid, 0.0, 1.0, 0.0, 1.0), frame),
        RegularKind::SingleCrease { edge, sharpness } => {
            let patch = SingleCreasePatch::new(grid, edge as usize, sharpness as f64);
            for (i, seg) in patch.curve().segments().iter().enumerate() {
                let (a, b) = (seg.start, seg.end);
                // The curve parameter runs across the crease (see `single_crease`).
                let (s0, s1, t0, t1) = match edge {
                    0 => (0.0, 1.0, 1.0 - b, 1.0 - a),
                    1 => (a, b, 0.0, 1.0),
                    2 => (0.0, 1.0, a, b),
                    _ => (1.0 - b, 1.0 - a, 0.0, 1.0),
                };
                if s1 > s0 && t1 > t0 {
                    push(
                        bezier::from_bspline(patch.grid(i), s0, s1, t0, t1),
                        sub_rect(&frame, s0, s1, t0, t1),
                    );
                }
            }
        }
    }
}

/// The control grid of a regular patch given as combinations of the points `data`.
fn combo_grid(cps: &[Combo; 16], data: &[f64]) -> ControlGrid {
    std::array::from_fn(|i| {
        let mut p = [0.0; 3];
        for &(v, w) in &cps[i] {
            let q = &data[3 * v as usize..3 * v as usize + 3];
            for c in 0..3 {
                p[c] += w * q[c];
            }
        }
        p
    })
}

/// Deepest split of a hull piece (as deep as evaluation subdivides).
pub const MAX_HULL_DEPTH: u8 = MAX_DEPTH as u8;

impl PatchTable {
    /// Pushes the pieces of leaf patch `p` (none for holes; they have no patches).
    pub fn patch_pieces(&self, p: usize, out: &mut Vec<Piece>) {
        let patch = &self.patches[p];
        let frame = Frame {
            o: patch.origin,
            a: patch.axis_u,
            b: patch.axis_v,
        };
        let (face, k) = (patch.face, patch.sub_face as u32);
        let grid = || -> ControlGrid { *self.grid(patch) };
        match patch.kind {
            PatchKind::BSpline { closed } => regular_pieces(
                RegularKind::BSpline { closed },
                &grid(),
                face,
                k,
                frame,
                0,
                out,
            ),
            PatchKind::SingleCrease { edge, sharpness } => regular_pieces(
                RegularKind::SingleCrease { edge, sharpness },
                &grid(),
                face,
                k,
                frame,
                0,
                out,
            ),
            PatchKind::Stam { valence, corner } => {
                let size = 2 * valence as usize + 8;
                let first = patch.first_point as usize;
                let c = corner as usize;
                let rot = Frame {
                    o: CORNER[c],
                    a: UAX[c],
                    b: VAX[c],
                };
                out.push(Piece {
                    face,
                    k,
                    frame: frame.then(&rot),
                    depth: 0,
                    shape: Shape::StamCorner {
                        patch: p as u32,
                        m: 0,
                        points: self.points[first..first + size].to_vec(),
                    },
                });
            }
            PatchKind::EndCap => {
                let cap = &self.end_caps[patch.end_cap as usize];
                let data: Vec<f64> = cap
                    .points
                    .iter()
                    .flat_map(|&i| self.points[i as usize])
                    .collect();
                out.push(Piece {
                    face,
                    k,
                    frame,
                    depth: 0,
                    shape: Shape::Cap(Box::new(LocalMesh {
                        level: cap.root.level.clone(),
                        data,
                        width: 3,
                    })),
                });
            }
        }
    }

    /// Pushes the children of a hull piece (nothing for Bézier and quartic pieces, which
    /// [`Piece::split_bezier`] and [`Piece::split_quartic`] split, and nothing below
    /// [`MAX_HULL_DEPTH`]).
    pub fn split_hull(&self, piece: &Piece, out: &mut Vec<Piece>) {
        if piece.depth >= MAX_HULL_DEPTH {
            return;
        }
        let depth = piece.depth + 1;
        match &piece.shape {
            Shape::Bezier(_) => {}
            Shape::StamCorner { patch, m, points } => {
                let p = &self.patches[*patch as usize];
                let PatchKind::Stam { valence, .. } = p.kind else {
                    return;
                };
                let basis = self.stam[valence as usize]
                    .as_ref()
                    .expect("the table holds the matrices of its Stam patches");
                let m = *m as usize + 1;
                if m > MAX_DEPTH {
                    return;
                }
                let first = p.first_point as usize;
                let cps = &self.points[first..first + basis.size];
                for q in 1..4 {
                    let g = basis.grid(m, q, cps);
                    out.push(Piece {
                        face: piece.face,
                        k: piece.k,
                        frame: piece.frame.child(q),
                        depth,
                        shape: Shape::Bezier(Box::new(bezier::from_bspline(
                            &g, 0.0, 1.0, 0.0, 1.0,
                        ))),
                    });
                }
                out.push(Piece {
                    face: piece.face,
                    k: piece.k,
                    frame: piece.frame.child(0),
                    depth,
                    shape: Shape::StamCorner {
                        patch: *patch,
                        m: m as u8,
                        points: basis.corner_child(points),
                    },
                });
            }
            Shape::Quartic { .. } => {}
            Shape::LoopCap(mesh) => self.split_loop_cap(piece, mesh, out),
            Shape::Cap(mesh) => {
                let sc = self.options.single_crease;
                let refined = mesh.refine(self.method);
                for q in 0..4 {
                    let c = child_face(&mesh.level, 0, q);
                    let child = LocalMesh::extract(&refined.level, &refined.data, 3, c, 2);
                    let frame = piece.frame.child(q);
                    match classify(&child.level, 0, sc) {
                        Some((kind, cps)) => regular_pieces(
                            kind,
                            &combo_grid(&cps, &child.data),
                            piece.face,
                            piece.k,
                            frame,
                            depth,
                            out,
                        ),
                        None => {
                            if child.level.topo.num_faces() == 0 || is_hole(&child) {
                                continue;
                            }
                            out.push(Piece {
                                face: piece.face,
                                k: piece.k,
                                frame,
                                depth,
                                shape: Shape::Cap(Box::new(child)),
                            })
                        }
                    }
                }
            }
        }
    }
}

/// Whether face 0 of a cut-out is a hole (it has no surface).
pub(super) fn is_hole(mesh: &LocalMesh) -> bool {
    mesh.level.face_hole.first().copied().unwrap_or(false)
}
