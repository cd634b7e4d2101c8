//! The reference intersector: where a ray first meets the exact limit surface, in `f64`,
//! certified, and independent of any dicing.
//!
//! The surface is cut into pieces with certain bounds ([`crate::patch::table::pieces`]):
//! Bézier pieces (exactly bicubic there) and hull pieces (at irregular vertices, inside the
//! convex hull of their control points). A hierarchy over the pieces' boxes ([`tree`]) and a
//! priority queue ordered by where the ray enters each bound visit them front to back. A
//! piece the ray's line misses is dropped; otherwise, projected onto the plane perpendicular
//! to the ray, a Bézier piece goes through the Krawczyk test ([`mod@krawczyk`]), which proves
//! that it holds no crossing or exactly one; the one crossing is then polished by Newton's
//! method on the table's own evaluation (`P(u, v) = o + t d`, in `f64`). Undecided pieces are
//! split (de Casteljau for Bézier pieces, one more subdivision step for hull pieces) until
//! they are decided, or so thin along the ray that any crossing in them is within
//! [`ExactTracer::tolerance`] of the one Newton finds from their centre. What is left
//! undecided after that (a ray touching the surface tangentially, within rounding) is
//! reported: the hit or miss carries `grazing` and an error bound that covers it.
//!
//! So the first hit is certain up to the reported `err`, and hit, miss and `t` are the same
//! whatever the dicing rate (the diced mesh is not used at all).

pub mod krawczyk;
pub mod tree;

use crate::bvh::Ray64;
use crate::coord::FaceCoord;
use crate::error::Result;
use crate::mesh::{ControlMesh, SHARPNESS_INFINITE};
use crate::patch::bezier::max_abs;
use crate::patch::table::pieces::{Piece, Shape};
use crate::patch::PatchTable;
use crate::refine::Level;
use crate::vec3::{cross, dot, norm};
use krawczyk::{krawczyk, Verdict};
use std::cmp::Ordering;
use std::collections::BinaryHeap;
use std::sync::Arc;
use tree::{slab, Aabb, PieceTree};

/// An intersection with the exact limit surface.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ExactHit {
    /// Ray parameter.
    pub t: f64,
    /// Base face.
    pub face: u32,
    /// Sub-face.
    pub k: u32,
    /// Parameters in the (sub-)face.
    pub u: f64,
    /// See `u`.
    pub v: f64,
    /// Point on the limit surface at `(face, k, u, v)`.
    pub p: [f64; 3],
    /// Unit limit normal `Pu × Pv` (zero where it does not exist).
    pub n: [f64; 3],
    /// `|P(u,v) − (o + t d)|` at the solution (absolute).
    pub residual: f64,
    /// A bound on the distance from `o + t d` to the exact surface, relative to the control
    /// mesh's bounding-box diagonal: the residual, the evaluation's rounding and, for
    /// `grazing` hits, the size of the undecided pieces before the hit.
    pub err: f64,
    /// The hit lies on an infinitely sharp edge or vertex (the normal jumps there).
    pub sharp: bool,
    /// Pieces in front of the hit stayed undecided (the ray grazes the surface there, within
    /// `err`): an earlier tangential touch cannot be ruled out.
    pub grazing: bool,
    /// Newton steps of the final polish.
    pub iterations: u32,
}

/// The answer for one ray.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ExactTrace {
    /// The first hit.
    pub hit: Option<ExactHit>,
    /// For misses: the ray comes within this distance (relative to the diagonal) of the
    /// surface without a decided crossing (a grazing miss); `None` for a certain miss.
    pub graze: Option<f64>,
    /// Pieces visited (the work done).
    pub pieces: u32,
}

/// Pieces visited per ray before the search gives up and reports the ray as grazing (only
/// tangential rays come near it).
const MAX_VISITS: u32 = 200_000;

/// Splits of a Bézier piece below its leaf (2^-48 of the leaf's size).
const MAX_BEZIER_DEPTH: u8 = 48;

/// The reference intersector of one patch table.
#[derive(Debug)]
pub struct ExactTracer {
    table: Arc<PatchTable>,
    roots: Vec<Piece>,
    tree: PieceTree,
    diag: f64,
    /// The largest absolute coordinate of the pieces' bounds.
    extent: f64,
    /// Per (face, sub-face) slot: bits 0–3 the infinitely sharp sub-face edges
    /// (`v = 0`, `u = 1`, `v = 1`, `u = 0`), bits 4–7 the infinitely sharp corners
    /// (`(0,0)`, `(1,0)`, `(1,1)`, `(0,1)`).
    sharp: Vec<u8>,
    slot_offsets: Vec<u32>,
    /// A Loop surface: pieces and hits in each triangle's own `(u, v)` (`k = 0`).
    triangles: bool,
}

/// One entry of the search's queue: something whose bound the ray enters at `w` (distance
/// along the unit direction).
struct Entry {
    w: f64,
    item: Item,
}

enum Item {
    Node(u32),
    Root(u32),
    Piece(Box<Piece>),
}

impl PartialEq for Entry {
    fn eq(&self, o: &Self) -> bool {
        self.w == o.w
    }
}
impl Eq for Entry {}
impl PartialOrd for Entry {
    fn partial_cmp(&self, o: &Self) -> Option<Ordering> {
        Some(self.cmp(o))
    }
}
impl Ord for Entry {
    fn cmp(&self, o: &Self) -> Ordering {
        // Min-heap on w.
        o.w.total_cmp(&self.w)
    }
}

/// The ray in the frame of its unit direction.
struct RayFrame {
    o: [f64; 3],
    d: [f64; 3],
    len: f64,
    dn: [f64; 3],
    e1: [f64; 3],
    e2: [f64; 3],
    inv: [f64; 3],
    omax: f64,
}

impl RayFrame {
    fn new(ray: &Ray64) -> RayFrame {
        let len = norm(ray.dir);
        let dn = ray.dir.map(|x| x / len);
        // An orthonormal basis around dn (Duff et al. 2017).
        let sign = 1f64.copysign(dn[2]);
        let a = -1.0 / (sign + dn[2]);
        let b = dn[0] * dn[1] * a;
        let e1 = [1.0 + sign * dn[0] * dn[0] * a, sign * b, -sign * dn[0]];
        let e2 = [b, sign + dn[1] * dn[1] * a, -dn[1]];
        RayFrame {
            o: ray.origin,
            d: ray.dir,
            len,
            dn,
            e1,
            e2,
            inv: dn.map(|x| 1.0 / x),
            omax: ray.origin.iter().fold(0.0f64, |m, x| m.max(x.abs())),
        }
    }
}

/// A piece projected on the ray's frame: the 2-D points, the range along the ray and the
/// rounding pad.
struct Projected {
    q: Vec<[f64; 2]>,
    w: (f64, f64),
    pad: f64,
}

fn project(r: &RayFrame, piece: &Piece) -> Projected {
    let pts = piece.hull();
    let pts = &pts[..];
    // Rounding of the points themselves (conversion and splits, a few ulps per level) and of
    // the projection.
    let pad = f64::EPSILON
        * ((16.0 + 4.0 * piece.depth as f64) * max_abs(pts) + 8.0 * (r.omax + max_abs(pts)))
        + piece.pad();
    let mut q = Vec::with_capacity(pts.len());
    let (mut w0, mut w1) = (f64::INFINITY, f64::NEG_INFINITY);
    for p in pts {
        let x = [p[0] - r.o[0], p[1] - r.o[1], p[2] - r.o[2]];
        q.push([dot(x, r.e1), dot(x, r.e2)]);
        let w = dot(x, r.dn);
        w0 = w0.min(w);
        w1 = w1.max(w);
    }
    Projected {
        q,
        w: (w0 - pad, w1 + pad),
        pad,
    }
}

/// Whether the projected bound contains the ray's line (the origin of the plane).
fn straddles(p: &Projected) -> bool {
    (0..2).all(|c| {
        let (lo, hi) =
            p.q.iter()
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), x| {
                    (l.min(x[c]), h.max(x[c]))
                });
        lo - p.pad <= 0.0 && hi + p.pad >= 0.0
    })
}

/// The box of a piece's hull, padded like [`project`]'s bounds.
fn piece_box(piece: &Piece) -> Aabb {
    let pts = piece.hull();
    let pts = &pts[..];
    let pad = f64::EPSILON * (16.0 + 8.0) * max_abs(pts) + f64::MIN_POSITIVE + piece.pad();
    let mut b: Aabb = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
    for p in pts {
        for a in 0..3 {
            b.0[a] = b.0[a].min(p[a] - pad);
            b.1[a] = b.1[a].max(p[a] + pad);
        }
    }
    b
}

/// The search state of one ray.
struct Search<'a> {
    tracer: &'a ExactTracer,
    r: RayFrame,
    heap: BinaryHeap<Entry>,
    best: Option<ExactHit>,
    best_w: f64,
    /// Undecided pieces: the smallest `w` where one starts, and the largest size.
    graze_w: f64,
    graze_size: f64,
    tol: f64,
    visits: u32,
}

impl ExactTracer {
    /// Builds the intersector of `table` (the pieces of every leaf and their hierarchy).
    /// `mesh` and `options` are the control mesh and rules the table was built from (for the
    /// diagonal and the infinitely sharp features).
    pub fn new(table: Arc<PatchTable>, mesh: &ControlMesh) -> Result<ExactTracer> {
        if table.is_approximate() {
            return Err(crate::error::Error::new(
                crate::error::ErrorKind::Usage,
                "the reference intersector (--exact) traces the exact limit surface, not an \
                 approximation (--surface)",
            ));
        }
        use rayon::prelude::*;
        let triangles = table.loop_surface().is_some();
        let roots: Vec<Piece> = if triangles {
            (0..table.num_faces())
                .into_par_iter()
                .flat_map_iter(|f| {
                    let mut v = Vec::new();
                    table.loop_pieces(f, &mut v);
                    v
                })
                .collect()
        } else {
            (0..table.patches.len())
                .into_par_iter()
                .flat_map_iter(|p| {
                    let mut v = Vec::new();
                    table.patch_pieces(p, &mut v);
                    v
                })
                .collect()
        };
        let boxes: Vec<Aabb> = roots.par_iter().map(piece_box).collect();
        let tree = PieceTree::build(&boxes);
        let extent = boxes.iter().fold(0.0f64, |m, b| {
            (0..3).fold(m, |m, a| m.max(b.0[a].abs()).max(b.1[a].abs()))
        });
        let (level, _) = Level::base(mesh, &table.mesh_options)?;
        let topo = &level.topo;
        let inf = |s: f32| s >= SHARPNESS_INFINITE;
        let sharp_edge =
            |e: u32| inf(level.edge_sharpness[e as usize]) && topo.edge_face_count(e) != 1;
        let interior_vertex = |v: u32| {
            topo.vert_edges[topo.vert_edge_offsets[v as usize] as usize
                ..topo.vert_edge_offsets[v as usize + 1] as usize]
                .iter()
                .all(|&e| topo.edge_face_count(e) != 1)
        };
        let sharp_vertex = |v: u32| inf(level.vertex_sharpness[v as usize]) && interior_vertex(v);
        let mut sharp = Vec::new();
        let mut slot_offsets = vec![0u32];
        for f in 0..table.num_faces() {
            let verts = topo.face_vertices(f);
            let n = verts.len();
            let edge = |i: usize| topo.face_edge(f, i % n);
            if triangles {
                // One slot per triangle: edges v = 0, u + v = 1, u = 0 (bits 0–2) and corners
                // (0,0), (1,0), (0,1) (bits 4–6).
                let mut bits = 0u8;
                for i in 0..3 {
                    bits |= (sharp_edge(edge(i)) as u8) << i;
                    bits |= (sharp_vertex(verts[i]) as u8) << (4 + i);
                }
                sharp.push(bits);
                slot_offsets.push(sharp.len() as u32);
                continue;
            }
            for k in 0..table.sub_faces(f) {
                let mut bits = 0u8;
                if n == 4 {
                    for i in 0..4 {
                        bits |= (sharp_edge(edge(i)) as u8) << i;
                        bits |= (sharp_vertex(verts[i]) as u8) << (4 + i);
                    }
                } else if k < n {
                    // Sub-face k: (0,0) at vertex k, v = 0 along edge k, u = 0 along edge k − 1.
                    bits |= sharp_edge(edge(k)) as u8;
                    bits |= (sharp_edge(edge(k + n - 1)) as u8) << 3;
                    bits |= (sharp_vertex(verts[k]) as u8) << 4;
                }
                sharp.push(bits);
            }
            slot_offsets.push(sharp.len() as u32);
        }
        Ok(ExactTracer {
            table,
            roots,
            tree,
            diag: mesh.diagonal().max(f64::MIN_POSITIVE),
            extent,
            sharp,
            slot_offsets,
            triangles,
        })
    }

    /// The patch table traced.
    pub fn table(&self) -> &PatchTable {
        &self.table
    }

    /// Number of root pieces.
    pub fn num_pieces(&self) -> usize {
        self.roots.len()
    }

    /// The control mesh's bounding-box diagonal (the unit of `err`).
    pub fn diagonal(&self) -> f64 {
        self.diag
    }

    /// The thickness along a ray below which an undecided piece is settled by Newton's
    /// method: 2^-44 (6e-14) of the diagonal plus 1024 ulps of the larger of the ray origin's
    /// coordinates (`scale`) and the surface's (above the rounding pads of the pieces' bounds,
    /// at most 8 + (16 + 4·48) ulps, so that far from the origin a piece can get thin enough).
    pub fn tolerance(&self, scale: f64) -> f64 {
        self.diag * 2f64.powi(-44) + 1024.0 * f64::EPSILON * scale.max(self.extent)
    }

    /// Traces many rays in parallel.
    pub fn trace_batch(&self, rays: &[Ray64]) -> Vec<ExactTrace> {
        use rayon::prelude::*;
        rays.par_iter().map(|r| self.trace(r)).collect()
    }

    /// The first hit of `ray` (`t ≥ 0`) with the exact limit surface.
    pub fn trace(&self, ray: &Ray64) -> ExactTrace {
        let r = RayFrame::new(ray);
        if !(r.len > 0.0 && r.len.is_finite()) {
            return ExactTrace::default();
        }
        let tol = self.tolerance(r.omax);
        let mut s = Search {
            tracer: self,
            r,
            heap: BinaryHeap::new(),
            best: None,
            best_w: f64::INFINITY,
            graze_w: f64::INFINITY,
            graze_size: 0.0,
            tol,
            visits: 0,
        };
        if !self.tree.nodes.is_empty() {
            s.push_node(0);
        }
        while let Some(e) = s.heap.pop() {
            if e.w >= s.best_w - s.tol {
                break;
            }
            s.visits += 1;
            if s.visits > MAX_VISITS {
                s.graze(e.w, self.diag);
                break;
            }
            match e.item {
                Item::Node(n) => {
                    let node = self.tree.nodes[n as usize];
                    if node.count == 0 {
                        s.push_node(node.first);
                        s.push_node(node.first + 1);
                    } else {
                        for &i in &self.tree.items
                            [node.first as usize..(node.first + node.count) as usize]
                        {
                            s.push_root(i);
                        }
                    }
                }
                Item::Root(i) => s.visit(&self.roots[i as usize]),
                Item::Piece(p) => s.visit(&p),
            }
        }
        s.finish()
    }
}

impl Search<'_> {
    fn push_node(&mut self, n: u32) {
        let node = &self.tracer.tree.nodes[n as usize];
        if let Some((t0, _)) = slab(&node.bounds, &self.r.o, &self.r.inv) {
            if t0 < self.best_w {
                self.heap.push(Entry {
                    w: t0,
                    item: Item::Node(n),
                });
            }
        }
    }

    /// The piece's range along the ray if its bound can hold a crossing at `t ≥ 0` before the
    /// best hit so far.
    fn admit(&self, piece: &Piece) -> Option<Projected> {
        let p = project(&self.r, piece);
        (p.w.1 >= -self.tol && p.w.0 < self.best_w - self.tol && straddles(&p)).then_some(p)
    }

    fn push_root(&mut self, i: u32) {
        if let Some(p) = self.admit(&self.tracer.roots[i as usize]) {
            self.heap.push(Entry {
                w: p.w.0,
                item: Item::Root(i),
            });
        }
    }

    fn push_piece(&mut self, piece: Piece) {
        if let Some(p) = self.admit(&piece) {
            self.heap.push(Entry {
                w: p.w.0,
                item: Item::Piece(Box::new(piece)),
            });
        }
    }

    fn graze(&mut self, w: f64, size: f64) {
        self.graze_w = self.graze_w.min(w);
        self.graze_size = self.graze_size.max(size);
    }

    /// Decides, splits or settles one piece.
    fn visit(&mut self, piece: &Piece) {
        let Some(proj) = self.admit(piece) else {
            return;
        };
        let size = {
            let b = piece_box(piece);
            norm(std::array::from_fn(|a| b.1[a] - b.0[a]))
        };
        if proj.w.1 - proj.w.0 <= self.tol {
            // Thin along the ray: any crossing here is within tol of Newton's.
            let (s, t) = piece.centre();
            if !self.newton(piece, s, t, proj.w, None) {
                self.graze(proj.w.0, size);
            }
            return;
        }
        match &piece.shape {
            Shape::Quartic { .. } => match krawczyk::<5>(&proj.q, proj.pad) {
                Verdict::Exclude => {}
                Verdict::Unique { lo, hi } => {
                    // The one zero of the polynomial in the square: settled without a hit
                    // when its enclosure lies beyond the triangle; otherwise Newton must find
                    // it on the triangle, or the piece is split.
                    if !piece.holds(lo[0], lo[1]) {
                        return;
                    }
                    let (s, t) = (0.5 * (lo[0] + hi[0]), 0.5 * (lo[1] + hi[1]));
                    if !self.newton(piece, s, t, proj.w, Some((lo, hi))) {
                        self.split_quartic(piece, proj.w.0, size);
                    }
                }
                Verdict::Unknown => self.split_quartic(piece, proj.w.0, size),
            },
            Shape::Bezier(g) => {
                match krawczyk::<4>(&proj.q, proj.pad) {
                    Verdict::Exclude => {}
                    Verdict::Unique { lo, hi } => {
                        let (s, t) = (0.5 * (lo[0] + hi[0]), 0.5 * (lo[1] + hi[1]));
                        if !self.newton(piece, s, t, proj.w, Some((lo, hi))) {
                            // Newton left the enclosure (or did not converge): split, so that
                            // smaller pieces start it closer to the one crossing.
                            if piece.depth >= MAX_BEZIER_DEPTH || size <= self.tol {
                                self.graze(proj.w.0, size);
                            } else {
                                for kid in piece.split_bezier(g) {
                                    self.push_piece(kid);
                                }
                            }
                        }
                    }
                    Verdict::Unknown => {
                        if piece.depth >= MAX_BEZIER_DEPTH || size <= self.tol {
                            self.graze(proj.w.0, size);
                        } else {
                            for kid in piece.split_bezier(g) {
                                self.push_piece(kid);
                            }
                        }
                    }
                }
            }
            _ => {
                let mut kids = Vec::new();
                self.tracer.table.split_hull(piece, &mut kids);
                if kids.is_empty() || size <= self.tol {
                    // At an irregular vertex, below any depth evaluation uses.
                    let (s, t) = piece.centre();
                    if !self.newton(piece, s, t, proj.w, None) {
                        self.graze(proj.w.0, size);
                    }
                    return;
                }
                for kid in kids {
                    self.push_piece(kid);
                }
            }
        }
    }

    /// Splits a quartic piece, or records it as undecided below the splits' depth.
    fn split_quartic(&mut self, piece: &Piece, w: f64, size: f64) {
        if piece.depth >= MAX_BEZIER_DEPTH || size <= self.tol {
            self.graze(w, size);
        } else {
            let mut kids = Vec::with_capacity(4);
            piece.split_quartic(&mut kids);
            for kid in kids {
                self.push_piece(kid);
            }
        }
    }

    /// Newton's method on `P(u, v) = o + t d` from the piece's `(s, t)`, on the table's own
    /// evaluation. With `within` (Krawczyk's enclosure of the piece's one crossing) the
    /// solution must lie in it (up to 2^-20 of the piece); without, it must lie within `tol`
    /// of the piece's range `w` along the ray. Records the hit if so and `t ≥ 0`; returns
    /// whether the piece is settled (its crossing found, or behind the origin).
    fn newton(
        &mut self,
        piece: &Piece,
        s0: f64,
        t0: f64,
        w: (f64, f64),
        within: Option<([f64; 2], [f64; 2])>,
    ) -> bool {
        let table = &self.tracer.table;
        let r = &self.r;
        let triangles = self.tracer.triangles;
        // Parameters kept in the domain: the unit square, or the triangle u, v ≥ 0, u + v ≤ 1.
        let clamp = |u: f64, v: f64| -> (f64, f64) {
            let (u, v) = (u.clamp(0.0, 1.0), v.clamp(0.0, 1.0));
            if triangles && u + v > 1.0 {
                let s = u + v;
                (u / s, v / s)
            } else {
                (u, v)
            }
        };
        let eval = |u: f64, v: f64| {
            let at = FaceCoord::new(piece.face, piece.k, u, v);
            if triangles {
                table.eval_triangle(at)
            } else {
                table.eval(at)
            }
        };
        let [u0, v0] = piece.face_uv(s0, t0);
        let (mut u, mut v) = clamp(u0, v0);
        // Start t: the ray's closest point to the surface point.
        let Ok(first) = eval(u, v) else {
            return false;
        };
        let x: [f64; 3] = std::array::from_fn(|c| first.p[c] - r.o[c]);
        let mut t = dot(x, r.d) / (r.len * r.len);
        // (residual, point, Pu × Pv, t, u, v, step) of the best iterate.
        type Iterate = (f64, [f64; 3], [f64; 3], f64, f64, f64, u32);
        let mut best: Option<Iterate> = None;
        let mut sample = first;
        for it in 0..12u32 {
            let f: [f64; 3] = std::array::from_fn(|c| sample.p[c] - r.o[c] - t * r.d[c]);
            let res = norm(f);
            if best.is_none_or(|b| res < b.0) {
                best = Some((res, sample.p, cross(sample.du, sample.dv), t, u, v, it));
            }
            let scale = sample.p.iter().fold(r.omax, |m, x| m.max(x.abs()));
            if res <= 2.0 * f64::EPSILON * scale {
                break;
            }
            let nd = r.d.map(|x| -x);
            let det = dot(sample.du, cross(sample.dv, nd));
            if det == 0.0 || !det.is_finite() {
                break;
            }
            let mf = f.map(|x| -x);
            (u, v) = clamp(
                u + dot(mf, cross(sample.dv, nd)) / det,
                v + dot(sample.du, cross(mf, nd)) / det,
            );
            t += dot(sample.du, cross(sample.dv, mf)) / det;
            match eval(u, v) {
                Ok(x) => sample = x,
                Err(_) => break,
            }
        }
        let Some((res, p, n, t, u, v, it)) = best else {
            return false;
        };
        let scale = p.iter().fold(r.omax, |m, x| m.max(x.abs()));
        if res > self.tol.max(16.0 * f64::EPSILON * scale) {
            return false;
        }
        let w_hit = t * r.len;
        match within {
            Some((lo, hi)) => {
                let st = piece.local_st(u, v);
                let m = 2f64.powi(-20);
                if (0..2).any(|i| !(st[i] >= lo[i] - m && st[i] <= hi[i] + m)) {
                    return false;
                }
                // A quartic piece's zero counts only on its triangle.
                if !piece.holds(st[0], st[1]) {
                    return false;
                }
            }
            None => {
                if w_hit < w.0 - self.tol || w_hit > w.1 + self.tol {
                    return false;
                }
            }
        }
        if t < 0.0 {
            // Behind the origin: no hit here (the piece is settled).
            return true;
        }
        if w_hit < self.best_w {
            let l = norm(n);
            let diag = self.tracer.diag;
            self.best_w = w_hit;
            self.best = Some(ExactHit {
                t,
                face: piece.face,
                k: piece.k,
                u,
                v,
                p,
                n: if l > 0.0 { n.map(|x| x / l) } else { n },
                residual: res,
                err: (res + 16.0 * f64::EPSILON * scale) / diag,
                sharp: self.tracer.is_sharp(piece.face, piece.k, u, v),
                grazing: false,
                iterations: it,
            });
        }
        true
    }

    fn finish(self) -> ExactTrace {
        let diag = self.tracer.diag;
        let mut hit = self.best;
        let mut graze = None;
        if self.graze_size > 0.0 || self.graze_w.is_finite() {
            match &mut hit {
                Some(h) if self.graze_w < self.best_w => {
                    h.grazing = true;
                    h.err = h.err.max(self.graze_size / diag);
                }
                Some(_) => {}
                None => graze = Some(self.graze_size / diag),
            }
        }
        ExactTrace {
            hit,
            graze,
            pieces: self.visits,
        }
    }
}

impl ExactTracer {
    /// Whether `(u, v)` of sub-face `k` of `face` lies on an infinitely sharp edge or vertex
    /// (within 2^-30 in the parameters).
    fn is_sharp(&self, face: u32, k: u32, u: f64, v: f64) -> bool {
        let Some(&bits) = self
            .slot_offsets
            .get(face as usize)
            .and_then(|&o| self.sharp.get(o as usize + k as usize))
        else {
            return false;
        };
        if bits == 0 {
            return false;
        }
        let eps = 2f64.powi(-30);
        if self.triangles {
            let on = [v <= eps, u + v >= 1.0 - eps, u <= eps];
            let corner = [on[2] && on[0], on[0] && on[1], on[1] && on[2]];
            return (0..3)
                .any(|i| (on[i] && bits & (1 << i) != 0) || (corner[i] && bits & (16 << i) != 0));
        }
        let on = [v <= eps, u >= 1.0 - eps, v >= 1.0 - eps, u <= eps];
        let corner = [
            on[3] && on[0],
            on[0] && on[1],
            on[1] && on[2],
            on[2] && on[3],
        ];
        (0..4).any(|i| (on[i] && bits & (1 << i) != 0) || (corner[i] && bits & (16 << i) != 0))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::harness::rng::SplitMix64;
    use crate::mesh::{generate, shapes, EdgeCrease};
    use crate::patch::PatchOptions;

    fn tracer(mesh: &ControlMesh) -> ExactTracer {
        let table = PatchTable::new(mesh, PatchOptions::default()).unwrap();
        ExactTracer::new(Arc::new(table), mesh).unwrap()
    }

    /// Rays aimed at random limit-surface points from outside, 30°–90° from the tangent
    /// plane: the first hit is at or before the aimed point, on the surface at its reported
    /// coordinates, and (for a convex-ish shape seen from outside) is the aimed point.
    fn aimed(mesh: &ControlMesh, seed: u64, rays: usize) -> (usize, f64) {
        let tr = tracer(mesh);
        let diag = tr.diagonal();
        let mut rng = SplitMix64::new(seed);
        let (mut same, mut worst) = (0, 0.0f64);
        for _ in 0..rays {
            let f = rng.below(mesh.num_faces()) as u32;
            let k = rng.below(tr.table().sub_faces(f as usize)) as u32;
            let at = FaceCoord::new(f, k, rng.next_f64(), rng.next_f64());
            let Ok(s) = tr.table().eval(at) else { continue };
            let n = cross(s.du, s.dv);
            let l = norm(n);
            if l == 0.0 {
                continue;
            }
            let n = n.map(|x| x / l);
            let jitter: [f64; 3] = std::array::from_fn(|_| rng.next_f64() - 0.5);
            let dir: [f64; 3] = std::array::from_fn(|c| n[c] + 0.8 * jitter[c]);
            let o: [f64; 3] = std::array::from_fn(|c| s.p[c] + 0.7 * diag * dir[c]);
            let d: [f64; 3] = std::array::from_fn(|c| s.p[c] - o[c]);
            let ray = Ray64::new(o, d);
            let got = tr.trace(&ray);
            let h = got.hit.expect("an aimed ray hits");
            assert!(!h.grazing, "{h:?}");
            assert!(h.t <= 1.0 + 1e-12, "hit beyond the aimed point: {h:?}");
            let e = tr
                .table()
                .eval(FaceCoord::new(h.face, h.k, h.u, h.v))
                .unwrap();
            let hp: [f64; 3] = std::array::from_fn(|c| o[c] + h.t * d[c]);
            let off = norm(std::array::from_fn(|c| hp[c] - e.p[c])) / diag;
            worst = worst.max(off);
            assert!(off <= 1e-12 && h.err <= 1e-12, "{off:e} {h:?}");
            if (h.t - 1.0).abs() < 1e-9 {
                same += 1;
            }
        }
        (same, worst)
    }

    #[test]
    fn rounded_box_hits_are_exact_and_first() {
        // Stam patches at the valence-3 corners, semi-sharp single-crease patches.
        let (same, worst) = aimed(&shapes::rounded_box(2.5), 1, 300);
        assert!(same >= 250, "{same}");
        assert!(worst < 1e-13, "{worst:e}");
    }

    #[test]
    fn end_caps_are_traced() {
        // A dart at a valence-5 vertex: end caps around it.
        let mut mesh = generate::star(5, 3);
        mesh.creases.push(EdgeCrease {
            v0: 0,
            v1: 1,
            sharpness: SHARPNESS_INFINITE,
        });
        let (same, _) = aimed(&mesh, 2, 200);
        assert!(same >= 150, "{same}");
    }

    #[test]
    fn misses_are_certain() {
        let mesh = shapes::rounded_box(0.0);
        let tr = tracer(&mesh);
        let b = mesh.bounds();
        // Rays passing outside the bounding box.
        for i in 0..50 {
            let y = b[1][1] + 0.01 + i as f64 * 0.1;
            let got = tr.trace(&Ray64::new([b[0][0] - 1.0, y, 0.0], [1.0, 0.0, 0.01]));
            assert_eq!(got.hit, None);
            assert_eq!(got.graze, None);
        }
    }
}
