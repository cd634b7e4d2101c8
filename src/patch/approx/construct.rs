//! The control points of paper 002's three approximations of a Loop surface, built from the
//! exact limit surface ([`LoopSurface`]) in three passes that share what neighbours share:
//! per vertex (limit position, unit normal), per edge (the cubic boundary curve and the
//! transversal field of its tangent planes), per face (the interior points). A boundary
//! curve is computed once per edge and copied into both of its faces, so adjacent patches
//! meet bit for bit.
//!
//! **PN triangles** (Vlachos et al. 2001): each edge point is the edge's third point
//! `(2 p_a + p_b)/3` projected into the tangent plane of its corner `a`; the centre is
//! `E + (E − V)/2` (`E` the mean of the six edge points, `V` of the corners). Only `C⁰`
//! across edges. (Paper 002's prose says `(E + V)/2`; Vlachos's own rule, which keeps
//! quadratic precision, is used.)
//!
//! **Walton–Meek** and **Gregory**: the cross-boundary derivative along each edge is built
//! in the plane of two fields that both faces of the edge compute alike,
//!
//! ```text
//! D(t) = α(t) T(t) + β(t) R(t),
//! ```
//!
//! `T` the boundary curve's derivative (quadratic), `R` a transversal field, `α`, `β` linear
//! and fitted at the ends to the derivatives the neighbouring edges impose there. `D` is cubic,
//! and its two middle Bézier coefficients give the edge's two interior points. Since `D` of
//! either face lies in `span{T(t), R(t)}`, the two faces share a tangent plane all along the
//! edge: the patches are `G¹` by construction (measured in the tests).
//! - Walton–Meek uses boundary data only: the PN boundary curves and `R` linear between
//!   `n_a × T(0)` and `n_b × T(1)`.
//! - Gregory (paper 002 §3.3) takes more from the Loop surface: edge points from the exact
//!   limit tangents, `e = p + (2/3) λ t` with `λ = 3/8 + cos(2π/n)/4` (Eq. 2–3; `t` the Loop
//!   tangent mask `(2/n) Σ_k cos(2π(k − j)/n) P_k`, which is the exact derivative at a
//!   regular vertex), and `R` quadratic through the exact limit tangent plane at the edge's
//!   midpoint as well as at its ends. Paper 002 prints Eq. 4 with `c = 2π/n`, garbled, and
//!   with an unspecified scale for its cross-tangent vector `r`; the construction above is
//!   ours, with the paper's inputs (Loop limit points, tangents and cross tangents).
//!
//! Vertices where the tangent mask does not apply (boundaries, creases, corners,
//! non-manifold) take their tangents from the exact surface where its parametric derivative
//! along the edge means something over the whole edge (a regular vertex, or an infinitely
//! sharp edge: a cubic B-spline crease curve), else PN's edge point. (At an irregular
//! vertex with semi-sharp creases the exact derivative's direction holds only in a vanishing
//! neighbourhood: used along a whole edge it rounds a creased box into a ball.)

use super::gregory_tri::GregoryTri;
use super::Approximation;
use crate::coord::FaceCoord;
use crate::error::Result;
use crate::patch::loop_box::regular_vertex;
use crate::patch::LoopSurface;
use crate::refine::crease;
use crate::vec3::{add, cross, dot, normalize, scale, sub};
use rayon::prelude::*;

const CORNER_UV: [[f64; 2]; 3] = [[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]];

/// The patches of `surface` under `kind` (not [`Approximation::Exact`]), one per face,
/// `None` for holes.
pub fn build(surface: &LoopSurface, kind: Approximation) -> Result<Vec<Option<GregoryTri>>> {
    let level = surface.level();
    let topo = &level.topo;
    let control: Vec<[f64; 3]> = (0..level.num_vertices())
        .map(|v| surface.control_point(v))
        .collect();
    let limit = surface.limit_positions(level, 0, &control)?;
    // Per vertex: the ring in face order where the tangent mask applies, and the unit normal.
    let rings: Vec<Option<Vec<u32>>> = (0..level.num_vertices())
        .map(|v| smooth_ring(surface, v))
        .collect();
    let normals: Vec<[f64; 3]> = (0..level.num_vertices())
        .into_par_iter()
        .map(|v| match &rings[v] {
            Some(ring) => {
                let (tu, tv) = mask_tangents(&control, ring);
                normalize(cross(tu, tv))
            }
            None => exact_normal(surface, v).unwrap_or([0.0; 3]),
        })
        .collect();
    // Per edge: the boundary curve from edge_verts[0] to edge_verts[1] and its transversal.
    let edges: Vec<Option<EdgeData>> = (0..topo.num_edges())
        .into_par_iter()
        .map(|e| edge_data(surface, kind, e as u32, &control, &limit, &normals, &rings))
        .collect::<Result<_>>()?;
    Ok((0..level.num_faces())
        .map(|f| {
            if level.face_hole[f] {
                return None;
            }
            Some(face_patch(surface, kind, f, &edges))
        })
        .collect())
}

/// A boundary curve and its transversal field, from `edge_verts[0]` to `edge_verts[1]`.
#[derive(Clone, Copy, Debug)]
struct EdgeData {
    curve: [[f64; 3]; 4],
    /// Bézier coefficients of `R` (quadratic).
    r: [[f64; 3]; 3],
}

/// The one-ring of `v` in the order of its faces' winding when `v` is smooth, interior and
/// manifold with nothing sharp (where the Loop tangent masks hold); `None` otherwise.
fn smooth_ring(surface: &LoopSurface, v: usize) -> Option<Vec<u32>> {
    let level = surface.level();
    let topo = &level.topo;
    let tag = topo.vert_tags[v];
    if tag.boundary || tag.nonmanifold || level.vertex_sharpness[v] != 0.0 {
        return None;
    }
    let edges = topo.vertex_edges(v);
    let faces = topo.vertex_faces(v);
    if edges.len() != faces.len() || edges.len() < 3 {
        return None;
    }
    if edges
        .iter()
        .any(|&e| level.edge_sharpness[e as usize] != 0.0)
    {
        return None;
    }
    // Face (v, a, b) is followed by the face holding (v, b, ·).
    let corners = topo.vertex_face_corners(v);
    let next_of = |f: usize, c: usize| -> (u32, u32) {
        let fv = topo.face_vertices(f);
        (fv[(c + 1) % 3], fv[(c + 2) % 3])
    };
    let mut ring = Vec::with_capacity(faces.len());
    let (first, _) = next_of(faces[0] as usize, corners[0] as usize);
    let mut cur = first;
    for _ in 0..faces.len() {
        ring.push(cur);
        let k = faces.iter().zip(corners).position(|(&f, &c)| {
            let (a, _) = next_of(f as usize, c as usize);
            a == cur
        })?;
        let (_, b) = next_of(faces[k] as usize, corners[k] as usize);
        cur = b;
    }
    (cur == first && {
        let mut sorted = ring.clone();
        sorted.sort_unstable();
        sorted.dedup();
        sorted.len() == ring.len()
    })
    .then_some(ring)
}

/// Loop's limit tangent masks `Σ cos(2πk/n) P_k`, `Σ sin(2πk/n) P_k` over a ring.
fn mask_tangents(control: &[[f64; 3]], ring: &[u32]) -> ([f64; 3], [f64; 3]) {
    let n = ring.len() as f64;
    let mut tu = [0.0; 3];
    let mut tv = [0.0; 3];
    for (k, &r) in ring.iter().enumerate() {
        let a = 2.0 * std::f64::consts::PI * k as f64 / n;
        tu = add(tu, scale(control[r as usize], a.cos()));
        tv = add(tv, scale(control[r as usize], a.sin()));
    }
    (tu, tv)
}

/// The exact unit normal at vertex `v` from its first face that is not a hole (oriented by
/// that face's winding).
fn exact_normal(surface: &LoopSurface, v: usize) -> Option<[f64; 3]> {
    let level = surface.level();
    let topo = &level.topo;
    let (f, c) = topo
        .vertex_faces(v)
        .iter()
        .zip(topo.vertex_face_corners(v))
        .find(|(&f, _)| !level.face_hole[f as usize])?;
    let [u, w] = CORNER_UV[*c as usize];
    let s = surface.eval(FaceCoord::new(*f, 0, u, w)).ok()?;
    Some(normalize(cross(s.du, s.dv)))
}

/// `x` with its component along the unit vector `n` removed.
pub(super) fn in_plane(x: [f64; 3], n: [f64; 3]) -> [f64; 3] {
    sub(x, scale(n, dot(x, n)))
}

/// The derivative of the exact surface at vertex `a` along the edge toward `b`, both corners
/// of face `f`, where it is the derivative of a curve that keeps its parameter (`a` regular
/// for the box spline, or the edge infinitely sharp: a cubic B-spline crease); `None`
/// elsewhere (at an irregular vertex the parametric derivative is 0 or ∞, and its direction
/// holds only in a vanishing neighbourhood).
fn exact_tangent(surface: &LoopSurface, f: usize, a: u32, b: u32) -> Option<[f64; 3]> {
    let level = surface.level();
    let e = level.topo.find_edge(a, b);
    let sharp_edge = e.is_some_and(|e| crease::is_infinite(level.edge_sharpness[e as usize]));
    if !(regular_vertex(level, a, f) || sharp_edge) {
        return None;
    }
    let fv = level.topo.face_vertices(f);
    let ca = fv.iter().position(|&x| x == a)?;
    let cb = fv.iter().position(|&x| x == b)?;
    let [u, v] = CORNER_UV[ca];
    let d = [CORNER_UV[cb][0] - u, CORNER_UV[cb][1] - v];
    let s = surface.eval(FaceCoord::new(f as u32, 0, u, v)).ok()?;
    Some(add(scale(s.du, d[0]), scale(s.dv, d[1])))
}

/// Loop's subdominant eigenvalue `3/8 + cos(2π/n)/4` (paper 002, Eq. 3).
fn loop_lambda(n: usize) -> f64 {
    0.375 + 0.25 * (2.0 * std::f64::consts::PI / n as f64).cos()
}

/// The Gregory edge point of vertex `a` toward its ring neighbour `b`: `p + (2/3) λ t`.
fn mask_edge_point(
    p: [f64; 3],
    control: &[[f64; 3]],
    ring: &[u32],
    b: u32,
    n: [f64; 3],
) -> [f64; 3] {
    let m = ring.len();
    let j = ring.iter().position(|&x| x == b).unwrap_or(0);
    let mut t = [0.0; 3];
    for (k, &r) in ring.iter().enumerate() {
        let a = 2.0 * std::f64::consts::PI * (k as f64 - j as f64) / m as f64;
        t = add(t, scale(control[r as usize], a.cos()));
    }
    let t = scale(in_plane(t, n), 2.0 / m as f64);
    add(p, scale(t, 2.0 / 3.0 * loop_lambda(m)))
}

fn edge_data(
    surface: &LoopSurface,
    kind: Approximation,
    e: u32,
    control: &[[f64; 3]],
    limit: &[[f64; 3]],
    normals: &[[f64; 3]],
    rings: &[Option<Vec<u32>>],
) -> Result<Option<EdgeData>> {
    let level = surface.level();
    let topo = &level.topo;
    let Some(&f) = topo
        .edge_face_list(e)
        .iter()
        .find(|&&f| !level.face_hole[f as usize])
    else {
        return Ok(None);
    };
    let f = f as usize;
    let [a, b] = topo.edge_verts[e as usize];
    let (pa, pb) = (limit[a as usize], limit[b as usize]);
    let na = normals[a as usize];
    let mut nb = normals[b as usize];
    if dot(na, nb) < 0.0 {
        nb = scale(nb, -1.0);
    }
    // PN's edge point: the chord's third projected into the corner's tangent plane.
    let pn_point =
        |p: [f64; 3], q: [f64; 3], n: [f64; 3]| add(p, scale(in_plane(sub(q, p), n), 1.0 / 3.0));
    let (ea, eb) = match kind {
        Approximation::Gregory => {
            let point =
                |v: u32, w: u32, p: [f64; 3], q: [f64; 3], n: [f64; 3]| match &rings[v as usize] {
                    Some(ring) => mask_edge_point(p, control, ring, w, n),
                    None => match exact_tangent(surface, f, v, w) {
                        Some(t) => add(p, scale(in_plane(t, n), 1.0 / 3.0)),
                        None => pn_point(p, q, n),
                    },
                };
            (point(a, b, pa, pb, na), point(b, a, pb, pa, nb))
        }
        _ => (pn_point(pa, pb, na), pn_point(pb, pa, nb)),
    };
    let curve = [pa, ea, eb, pb];
    let t0 = scale(sub(ea, pa), 3.0);
    let t1 = scale(sub(pb, eb), 3.0);
    let r0 = cross(na, t0);
    let r1 = cross(nb, t1);
    let rm = match kind {
        Approximation::Gregory => {
            // Through the exact tangent plane at the midpoint: R(1/2) = n(½) × T(½).
            let fv = topo.face_vertices(f);
            let ca = fv.iter().position(|&x| x == a).unwrap_or(0);
            let cb = fv.iter().position(|&x| x == b).unwrap_or(1);
            let mid = [0, 1].map(|i| 0.5 * (CORNER_UV[ca][i] + CORNER_UV[cb][i]));
            let s = surface.eval(FaceCoord::new(f as u32, 0, mid[0], mid[1]))?;
            let mut nm = normalize(cross(s.du, s.dv));
            if dot(nm, add(na, nb)) < 0.0 {
                nm = scale(nm, -1.0);
            }
            let th = [0, 1, 2].map(|x| 0.75 * (eb[x] + pb[x] - pa[x] - ea[x]));
            let rh = cross(nm, th);
            // Bézier middle coefficient of the quadratic through r0, rh, r1.
            sub(scale(rh, 2.0), scale(add(r0, r1), 0.5))
        }
        _ => scale(add(r0, r1), 0.5),
    };
    Ok(Some(EdgeData {
        curve,
        r: [r0, rm, r1],
    }))
}

/// Coefficients `(α, β)` of `d = α t + β r` for `t ⟂ r`; zero for a vector that vanishes
/// against `d` (shorter than 1e-6 |d|: rounding, e.g. an edge point that the tangent plane
/// at a sharp corner puts on its vertex, whose α would otherwise be ~1e8 and throw the
/// interior points millions of diagonals away).
pub(super) fn decompose(d: [f64; 3], t: [f64; 3], r: [f64; 3]) -> (f64, f64) {
    let floor = 1e-12 * dot(d, d);
    let (tt, rr) = (dot(t, t), dot(r, r));
    let a = if tt > floor && tt > 0.0 {
        dot(d, t) / tt
    } else {
        0.0
    };
    let b = if rr > floor && rr > 0.0 {
        dot(d, r) / rr
    } else {
        0.0
    };
    (a, b)
}

fn face_patch(
    surface: &LoopSurface,
    kind: Approximation,
    f: usize,
    edges: &[Option<EdgeData>],
) -> GregoryTri {
    let topo = &surface.level().topo;
    let fv = topo.face_vertices(f);
    let mut g = GregoryTri::default();
    // Each edge's data, oriented from corner i to corner i + 1.
    let mut oriented = [EdgeData {
        curve: [[0.0; 3]; 4],
        r: [[0.0; 3]; 3],
    }; 3];
    for i in 0..3 {
        let e = topo.face_edge(f, i);
        let d = edges[e as usize].expect("an edge of a face that is not a hole has data");
        oriented[i] = if topo.edge_verts[e as usize][0] == fv[i] {
            d
        } else {
            let [c0, c1, c2, c3] = d.curve;
            let [r0, rm, r1] = d.r;
            EdgeData {
                curve: [c3, c2, c1, c0],
                r: [r1, rm, r0],
            }
        };
        g.p[i] = oriented[i].curve[0];
        g.e_plus[i] = oriented[i].curve[1];
        g.e_minus[(i + 1) % 3] = oriented[i].curve[2];
    }
    if kind == Approximation::Pn {
        let e: [f64; 3] = [0, 1, 2].map(|x| {
            (0..3)
                .map(|i| g.e_plus[i][x] + g.e_minus[i][x])
                .sum::<f64>()
                / 6.0
        });
        let v: [f64; 3] = [0, 1, 2].map(|x| (g.p[0][x] + g.p[1][x] + g.p[2][x]) / 3.0);
        let centre = add(e, scale(sub(e, v), 0.5));
        for i in 0..3 {
            // Degree elevation of the cubic: b_211 = (2 c_111 + c_210 + c_201) / 4.
            let q = scale(
                add(scale(centre, 2.0), add(g.e_plus[i], g.e_minus[i])),
                0.25,
            );
            g.f_plus[i] = q;
            g.f_minus[i] = q;
        }
        return g;
    }
    for i in 0..3 {
        let (a, b) = (i, (i + 1) % 3);
        let EdgeData { curve: c, r } = oriented[i];
        let tp = [sub(c[1], c[0]), sub(c[2], c[1]), sub(c[3], c[2])].map(|x| scale(x, 3.0));
        // The derivatives toward the third corner that the other two edges impose at the ends.
        let d0 = scale(sub(g.e_minus[a], g.p[a]), 3.0);
        let d1 = scale(sub(g.e_plus[b], g.e_minus[b]), 3.0);
        let (a0, b0) = decompose(d0, tp[0], r[0]);
        let (a1, b1) = decompose(d1, tp[2], r[2]);
        // Cubic D = α T + β R: its coefficients 1 and 2.
        let dc1 = add(
            scale(add(scale(tp[1], 2.0 * a0), scale(tp[0], a1)), 1.0 / 3.0),
            scale(add(scale(r[1], 2.0 * b0), scale(r[0], b1)), 1.0 / 3.0),
        );
        let dc2 = add(
            scale(add(scale(tp[2], a0), scale(tp[1], 2.0 * a1)), 1.0 / 3.0),
            scale(add(scale(r[2], b0), scale(r[1], 2.0 * b1)), 1.0 / 3.0),
        );
        // D(t) = 4 Σ B³_j (row-1 point j − boundary point j): solve for the two interior ones.
        let b310 = scale(add(c[0], scale(c[1], 3.0)), 0.25);
        let b220 = scale(add(c[1], c[2]), 0.5);
        g.f_plus[a] = add(b310, scale(dc1, 0.25));
        g.f_minus[b] = add(b220, scale(dc2, 0.25));
    }
    g
}
