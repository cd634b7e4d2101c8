//! One uniform Loop refinement step (paper 002 §2): every triangle becomes four, with the
//! child level's tags and the stencil table from parent to child vertices.
//!
//! Child vertex order: children of vertices first (vertex `v` keeps index `v`), then edge
//! points (`nv + e`), as on the Catmull-Clark side. Triangle `f = (v0, v1, v2)` with edges
//! `e_k = (v_k, v_k+1)` and edge points `m_k` becomes
//! - child `k < 3`, the corner triangle at `v_k`: `(v0, m0, m2)`, `(m0, v1, m1)`, `(m2, m1, v2)`;
//! - child 3, the middle triangle `(m1, m2, m0)`.
//!
//! In the face's triangle parameter (OpenSubdiv's: `(0,0)` at `v0`, `(1,0)` at `v1`, `(0,1)` at
//! `v2`) the corner children are the parent's quarter triangles translated, and the middle one is
//! turned half a turn: child `(s, t)` is parent `(½ − s/2, ½ − t/2)`. This is OpenSubdiv's
//! triangle sub-face convention ([`child_uv`]).

use super::crease;
use super::level::Level;
use super::loop_rules::{edge_mask, vertex_mask};
use super::stencil::StencilTable;
use super::step::{child_tags, edge_halves, half_edge, parallel_rows, vertex_rows};
use crate::mesh::{CreaseMethod, Topology};

/// Index of the child of parent vertex `v`.
#[inline]
pub fn child_of_vertex(v: usize) -> u32 {
    v as u32
}

/// Index of the edge point of parent edge `e`.
#[inline]
pub fn child_of_edge(parent: &Level, e: usize) -> u32 {
    (parent.num_vertices() + e) as u32
}

/// The parent triangle parameter of child `k`'s parameter `(s, t)` (children as in the module
/// documentation).
pub fn child_uv(k: usize, s: f64, t: f64) -> (f64, f64) {
    match k {
        0 => (0.5 * s, 0.5 * t),
        1 => (0.5 + 0.5 * s, 0.5 * t),
        2 => (0.5 * s, 0.5 + 0.5 * t),
        _ => (0.5 - 0.5 * s, 0.5 - 0.5 * t),
    }
}

/// The child triangle holding `(u, v)` and the point's parameter in it (inverse of
/// [`child_uv`]; every operation is exact).
pub fn child_of(u: f64, v: f64) -> (usize, f64, f64) {
    let k = if u >= 0.5 {
        1
    } else if v >= 0.5 {
        2
    } else if u + v <= 0.5 {
        0
    } else {
        3
    };
    let (s, t) = match k {
        0 => (2.0 * u, 2.0 * v),
        1 => (2.0 * u - 1.0, 2.0 * v),
        2 => (2.0 * u, 2.0 * v - 1.0),
        _ => (1.0 - 2.0 * u, 1.0 - 2.0 * v),
    };
    debug_assert!({
        let (pu, pv) = child_uv(k, s, t);
        (pu - u).abs() < 1e-15 && (pv - v).abs() < 1e-15
    });
    (k, s.max(0.0), t.max(0.0))
}

/// The vertex of triangle `f` opposite its edge `e`.
fn opposite(topo: &Topology, f: usize, e: u32) -> u32 {
    let fe = topo.face_edge_list(f);
    let k = fe.iter().position(|&x| x == e).unwrap_or(0);
    topo.face_vertices(f)[(k + 2) % 3]
}

/// Refines the all-triangle level `parent` once under the crease `method`.
pub fn refine(parent: &Level, method: CreaseMethod) -> (Level, StencilTable) {
    let topo = &parent.topo;
    let nv = parent.num_vertices();
    let nf = parent.num_faces();
    let ne = topo.num_edges();
    debug_assert!((0..nf).all(|f| topo.face_vertices(f).len() == 3));

    // Child edges: parent edge e gives 2e (at its first vertex) and 2e + 1 (at its second);
    // triangle f gives the middle triangle's edges 2·ne + 3f + k, edge k joining m_k and
    // m_(k-1) (the corner child at v_k cuts it off).
    let mut edge_verts = Vec::with_capacity(2 * ne + 3 * nf);
    for e in 0..ne {
        let [a, b] = topo.edge_verts[e];
        let m = child_of_edge(parent, e);
        edge_verts.push([child_of_vertex(a as usize), m]);
        edge_verts.push([m, child_of_vertex(b as usize)]);
    }
    for f in 0..nf {
        let fe = topo.face_edge_list(f);
        for k in 0..3 {
            edge_verts.push([
                child_of_edge(parent, fe[k] as usize),
                child_of_edge(parent, fe[(k + 2) % 3] as usize),
            ]);
        }
    }

    let mut face_offsets = Vec::with_capacity(4 * nf + 1);
    let mut face_verts = Vec::with_capacity(12 * nf);
    let mut face_edges = Vec::with_capacity(12 * nf);
    let mut face_hole = Vec::with_capacity(4 * nf);
    face_offsets.push(0u32);
    for f in 0..nf {
        let v = topo.face_vertices(f);
        let e = topo.face_edge_list(f);
        let m = |k: usize| child_of_edge(parent, e[k] as usize);
        let inner = |k: usize| (2 * ne + 3 * f + k) as u32;
        let half = |k: usize, at: usize, lead: bool| half_edge(topo, e[k], v[at], lead);
        let (v0, v1, v2) = (v[0] as usize, v[1] as usize, v[2] as usize);
        face_verts.extend_from_slice(&[child_of_vertex(v0), m(0), m(2)]);
        face_edges.extend_from_slice(&[half(0, 0, true), inner(0), half(2, 0, false)]);
        face_verts.extend_from_slice(&[m(0), child_of_vertex(v1), m(1)]);
        face_edges.extend_from_slice(&[half(0, 1, false), half(1, 1, true), inner(1)]);
        face_verts.extend_from_slice(&[m(2), m(1), child_of_vertex(v2)]);
        face_edges.extend_from_slice(&[inner(2), half(1, 2, false), half(2, 2, true)]);
        face_verts.extend_from_slice(&[m(1), m(2), m(0)]);
        face_edges.extend_from_slice(&[inner(2), inner(0), inner(1)]);
        for _ in 0..4 {
            face_offsets.push(face_offsets.len() as u32 * 3);
            face_hole.push(parent.face_hole[f]);
        }
    }
    let child_topo =
        Topology::from_edges(nv + ne, face_offsets, face_verts, face_edges, edge_verts);

    let halves = edge_halves(parent, method);
    let (edge_sharpness, vertex_sharpness) = child_tags(
        &parent.vertex_sharpness,
        &halves,
        [child_topo.num_edges(), child_topo.num_vertices],
    );

    let vertex_rows = vertex_rows(
        parent,
        parent.num_vertices(),
        &halves,
        &vertex_sharpness,
        vertex_mask,
    );
    let edge_rows = parallel_rows(ne, nv, |e, acc| {
        let [a, b] = topo.edge_verts[e];
        let opp: Vec<u32> = topo
            .edge_face_list(e as u32)
            .iter()
            .map(|&f| opposite(topo, f as usize, e as u32))
            .collect();
        let [h0, h1] = halves[e];
        edge_mask(
            acc,
            a,
            b,
            &opp,
            parent.edge_sharpness[e],
            crease::is_sharp(h0) && crease::is_sharp(h1),
        );
    });
    let table = StencilTable::concat(vertex_rows.num_inputs, [&vertex_rows, &edge_rows]);

    (
        Level {
            topo: child_topo,
            edge_sharpness,
            vertex_sharpness,
            face_hole,
            smooth_triangles: parent.smooth_triangles,
            scheme: parent.scheme,
        },
        table,
    )
}
