//! One uniform refinement step: the child level's topology and tags, and the stencil table
//! that computes child vertices from parent vertices.
//!
//! Child vertex order (OpenSubdiv's default): children of vertices first (vertex `v` keeps
//! index `v`), then face points, then edge points. Parent face `f` with `n` vertices becomes
//! `n` quads; quad `k` is (child of vertex `k`, edge point of edge `k`, face point, edge point
//! of edge `k-1`), which is the ptex sub-face convention.

use super::child_topology::{child_topology, prefix_topology};
use super::crease;
use super::level::Level;
use super::rules::{edge_mask, face_mask, vertex_mask, VertexRing};
use super::stencil::{Accumulator, StencilTable};
use crate::mesh::{CreaseMethod, Topology};
use rayon::prelude::*;

const CHUNK: usize = 2048;

/// Index of the child of parent vertex `v`.
#[inline]
pub fn child_of_vertex(_parent: &Level, v: usize) -> u32 {
    v as u32
}

/// Index of the face point of parent face `f`.
#[inline]
pub fn child_of_face(parent: &Level, f: usize) -> u32 {
    (parent.num_vertices() + f) as u32
}

/// Index of the edge point of parent edge `e`.
#[inline]
pub fn child_of_edge(parent: &Level, e: usize) -> u32 {
    (parent.num_vertices() + parent.num_faces() + e) as u32
}

/// Index of sub-face `k` of face `f` of `parent` in the child level: the children of a face
/// are consecutive, one per corner, in corner order (see [`refine`]).
#[inline]
pub fn child_face(parent: &Level, f: usize, k: usize) -> usize {
    parent.topo.face_offsets[f] as usize + k
}

/// Child sharpness of every edge at vertex `v`, in ring order, into `out`; `inc` is scratch
/// for the parent's sharpness (reused from vertex to vertex: a vector per vertex was 1% of
/// the car's build at rate 16).
fn child_sharpness_at(
    parent: &Level,
    method: CreaseMethod,
    v: usize,
    inc: &mut Vec<f32>,
    out: &mut Vec<f32>,
) {
    parent.incident_sharpness(v, inc);
    let inc = &*inc;
    out.clear();
    out.extend(
        inc.iter()
            .map(|&s| crease::child_edge_sharpness(method, s, inc)),
    );
}

/// Builds table rows for `range` in parallel chunks, with `row` filling one row.
pub(super) fn parallel_rows<F>(count: usize, num_inputs: usize, row: F) -> StencilTable
where
    F: Fn(usize, &mut Accumulator) + Sync,
{
    parallel_rows_with(count, num_inputs, |i, acc, _: &mut ()| row(i, acc))
}

/// [`parallel_rows`] with scratch space `S` per chunk, handed to every row of the chunk (so a
/// row's gathered neighbourhood reuses one buffer instead of allocating its own).
pub(super) fn parallel_rows_with<S, F>(count: usize, num_inputs: usize, row: F) -> StencilTable
where
    S: Default,
    F: Fn(usize, &mut Accumulator, &mut S) + Sync,
{
    let parts: Vec<StencilTable> = (0..count.div_ceil(CHUNK))
        .into_par_iter()
        .with_min_len(crate::threads::min_len())
        .map(|c| {
            let mut t = StencilTable::new(num_inputs);
            let mut acc = Accumulator::new();
            let mut scratch = S::default();
            for i in c * CHUNK..((c + 1) * CHUNK).min(count) {
                row(i, &mut acc, &mut scratch);
                t.push_row(&mut acc);
            }
            t
        })
        .collect();
    StencilTable::concat(num_inputs, &parts)
}

/// The child edge (numbered `2e`, `2e + 1` as in [`refine`]) of parent edge `e` that touches
/// parent vertex `v`: `lead` for the face's edge leaving `v`, otherwise the one arriving at it.
/// A degenerate edge (both ends `v`, used by one face) leaves `v` by its first half and arrives
/// by its second.
pub(super) fn half_edge(topo: &Topology, e: u32, v: u32, lead: bool) -> u32 {
    let [a, b] = topo.edge_verts[e as usize];
    2 * e + if a == b { !lead } else { a != v } as u32
}

/// The child level's edge and vertex sharpness, for children numbered as both schemes number
/// them: parent edge `e`'s halves are child edges `2e` and `2e + 1` (sharpness from `halves`,
/// every other child edge smooth), parent vertex `v`'s child is vertex `v` (its sharpness,
/// `parent_vertex_sharpness[v]`, decremented; every other child vertex smooth); the child
/// level has `child_edges` edges and `child_vertices` vertices.
pub(super) fn child_tags(
    parent_vertex_sharpness: &[f32],
    halves: &[[f32; 2]],
    [child_edges, child_vertices]: [usize; 2],
) -> (Vec<f32>, Vec<f32>) {
    let mut edge_sharpness = vec![0.0f32; child_edges];
    for (e, h) in halves.iter().enumerate() {
        edge_sharpness[2 * e] = h[0];
        edge_sharpness[2 * e + 1] = h[1];
    }
    let mut vertex_sharpness = vec![0.0f32; child_vertices];
    for (c, &s) in vertex_sharpness.iter_mut().zip(parent_vertex_sharpness) {
        *c = crease::decrement(s);
    }
    (edge_sharpness, vertex_sharpness)
}

/// Child sharpness of each parent edge at each end: `[at v0, at v1]`.
pub(super) fn edge_halves(parent: &Level, method: CreaseMethod) -> Vec<[f32; 2]> {
    let topo = &parent.topo;
    let mut halves = vec![[0.0f32; 2]; topo.num_edges()];
    if parent.edge_sharpness.iter().any(|&s| s != 0.0) {
        let (mut inc, mut buf) = (Vec::new(), Vec::new());
        for v in 0..parent.num_vertices() {
            child_sharpness_at(parent, method, v, &mut inc, &mut buf);
            for (&e, &s) in topo.vertex_edges(v).iter().zip(&buf) {
                let [a, b] = topo.edge_verts[e as usize];
                if a == b {
                    // A degenerate edge: both halves end at v.
                    halves[e as usize] = [s, s];
                } else {
                    halves[e as usize][(a != v as u32) as usize] = s;
                }
            }
        }
    }
    halves
}

/// The stencil rows of the children of the first `count` parent vertices (child `v` is row
/// `v`), with the scheme's vertex `mask`; `halves` from [`edge_halves`],
/// `child_vertex_sharpness` indexed by parent vertex.
pub(super) fn vertex_rows(
    parent: &Level,
    count: usize,
    halves: &[[f32; 2]],
    child_vertex_sharpness: &[f32],
    mask: fn(&mut Accumulator, &VertexRing),
) -> StencilTable {
    let topo = &parent.topo;
    let nv = parent.num_vertices();
    type Scratch<'a> = (Vec<u32>, Vec<f32>, Vec<f32>, Vec<&'a [u32]>);
    parallel_rows_with(count, nv, |v, acc, (ends, es, cs, faces): &mut Scratch| {
        let edges = topo.vertex_edges(v);
        ends.clear();
        ends.extend(edges.iter().map(|&e| topo.other_vertex(e, v as u32)));
        es.clear();
        es.extend(edges.iter().map(|&e| parent.edge_sharpness[e as usize]));
        cs.clear();
        cs.extend(edges.iter().map(|&e| {
            let end = if topo.edge_verts[e as usize][0] == v as u32 {
                0
            } else {
                1
            };
            halves[e as usize][end]
        }));
        faces.clear();
        faces.extend(
            topo.vertex_faces(v)
                .iter()
                .map(|&f| topo.face_vertices(f as usize)),
        );
        mask(
            acc,
            &VertexRing {
                center: v as u32,
                edge_ends: ends,
                edge_sharpness: es,
                child_edge_sharpness: cs,
                faces,
                sharpness: parent.vertex_sharpness[v],
                child_sharpness: child_vertex_sharpness[v],
            },
        );
    })
}

/// Refines `parent` once under the crease `method`.
pub fn refine(parent: &Level, method: CreaseMethod) -> (Level, StencilTable) {
    refine_inner(parent, parent.num_faces(), method)
}

/// Refines the first `inner` faces of `parent` once under the crease `method`: the child level
/// is the refinement of those faces as a mesh of their own (its rim a boundary), while its
/// stencils read the whole of `parent`, so that the children of vertices and edges whose
/// neighbourhood lies in `parent` are exact even on that rim. The first `inner` faces' vertices
/// and edges must be the parent's first ones (as [`crate::patch::local::extract_faces_within`]
/// numbers a cut-out); the stencil rows read the parent's vertices.
///
/// Adaptive refinement cuts two rings of faces out around the faces it isolates, which keeps
/// every point of the next level exact, but refines only the first ring: the next level's
/// two rings around the isolated faces' children lie within it.
///
/// The child topology and the child's tags and stencils read only the parent, not each other:
/// they are built side by side (`rayon::join`; a cut-out's level is too small for its rows'
/// chunks to keep two threads busy, so serially each waited on the other).
pub fn refine_inner(parent: &Level, inner: usize, method: CreaseMethod) -> (Level, StencilTable) {
    let own;
    let topo = if inner >= parent.num_faces() {
        &parent.topo
    } else {
        own = prefix_topology(&parent.topo, inner);
        &own
    };
    let nv = topo.num_vertices;
    let nf = topo.num_faces();
    let ne = topo.num_edges();
    let child_of_vertex = |v: usize| v as u32;
    let child_of_face = |f: usize| (nv + f) as u32;
    let child_of_edge = |e: usize| (nv + nf + e) as u32;

    // The child topology from the cut-out's first faces, and beside it the child's tags and
    // the stencils, which read the parent alone.
    let nfv = topo.face_verts.len();
    let ((child_topo, face_hole), (edge_sharpness, vertex_sharpness, table)) = rayon::join(
        || {
            // Child edges, numbered structurally: parent edge e gives 2e (at its first vertex) and
            // 2e + 1 (at its second); corner k of parent face f (face-vertex slot o + k) gives the
            // interior edge 2·ne + o + k from the edge point of edge k to the face point.
            let mut edge_verts = Vec::with_capacity(2 * ne + nfv);
            for e in 0..ne {
                let [a, b] = topo.edge_verts[e];
                let m = child_of_edge(e);
                edge_verts.push([child_of_vertex(a as usize), m]);
                edge_verts.push([m, child_of_vertex(b as usize)]);
            }
            for f in 0..nf {
                let cf = child_of_face(f);
                for &e in topo.face_edge_list(f) {
                    edge_verts.push([child_of_edge(e as usize), cf]);
                }
            }
            let half = |e: u32, v: u32, lead: bool| half_edge(topo, e, v, lead);

            // Child faces: quad k of face f is (v_k, edge point k, face point, edge point k-1).
            let mut face_offsets = Vec::with_capacity(nfv + 1);
            let mut face_verts = Vec::with_capacity(nfv * 4);
            let mut face_edges = Vec::with_capacity(nfv * 4);
            let mut face_hole = Vec::with_capacity(nfv);
            face_offsets.push(0u32);
            for f in 0..nf {
                let fv = topo.face_vertices(f);
                let fe = topo.face_edge_list(f);
                let o = topo.face_offsets[f];
                let n = fv.len();
                for k in 0..n {
                    let prev = (k + n - 1) % n;
                    face_verts.extend_from_slice(&[
                        child_of_vertex(fv[k] as usize),
                        child_of_edge(fe[k] as usize),
                        child_of_face(f),
                        child_of_edge(fe[prev] as usize),
                    ]);
                    face_edges.extend_from_slice(&[
                        half(fe[k], fv[k], true),
                        (2 * ne) as u32 + o + k as u32,
                        (2 * ne) as u32 + o + prev as u32,
                        half(fe[prev], fv[k], false),
                    ]);
                    face_offsets.push(face_verts.len() as u32);
                    face_hole.push(parent.face_hole[f]);
                }
            }
            let child = child_topology(topo, face_offsets, face_verts, face_edges, edge_verts);
            (child, face_hole)
        },
        || {
            // Sharpness and stencils from the whole parent (its vertices are the stencils' inputs).
            let halves = edge_halves(parent, method);
            let (edge_sharpness, vertex_sharpness) = child_tags(
                &parent.vertex_sharpness[..nv],
                &halves[..ne],
                [2 * ne + nfv, nv + nf + ne],
            );
            let topo = &parent.topo;
            let inputs = parent.num_vertices();

            // Stencils: vertex children, face points, edge points.
            let vertex_rows = vertex_rows(parent, nv, &halves, &vertex_sharpness, vertex_mask);
            let face_rows = parallel_rows(nf, inputs, |f, acc| {
                face_mask(acc, topo.face_vertices(f), 1.0)
            });
            let edge_rows = parallel_rows_with(ne, inputs, |e, acc, faces: &mut Vec<&[u32]>| {
                let [a, b] = topo.edge_verts[e];
                faces.clear();
                faces.extend(
                    topo.edge_face_list(e as u32)
                        .iter()
                        .map(|&f| topo.face_vertices(f as usize)),
                );
                let [h0, h1] = halves[e];
                edge_mask(
                    acc,
                    a,
                    b,
                    faces,
                    parent.edge_sharpness[e],
                    crease::is_sharp(h0) && crease::is_sharp(h1),
                    parent.smooth_triangles,
                );
            });
            let table = StencilTable::concat(inputs, [&vertex_rows, &face_rows, &edge_rows]);
            (edge_sharpness, vertex_sharpness, table)
        },
    );
    assert_eq!(
        (child_topo.num_edges(), child_topo.num_vertices),
        (edge_sharpness.len(), vertex_sharpness.len()),
        "the child's tags are sized as its topology"
    );
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
