//! The child level's adjacency after a Catmull-Clark step, its vertex rings derived from the
//! parent's ordered rings instead of searched for.
//!
//! Every child vertex's ring is the one [`Topology::from_edges`] would order (the same faces,
//! corners and edges, starting where it starts), found without walking the child level:
//! - the child of a parent vertex has the parent's ring, each face `f` at corner `c` replaced
//!   by quad `c` of `f` (at its corner 0) and each edge by its half at the vertex;
//! - a face point is corner 2 of the face's quads in order, its edges the face's interior
//!   edges, starting from the last;
//! - an edge point is corner 1 of the quad of the edge and corner 3 of the next quad, in each
//!   face of the edge, its edges the edge's halves and the faces' interior edges.
//!
//! A non-manifold parent vertex or edge (and a degenerate edge, or one a face uses twice)
//! has its child's ring ordered as [`Topology::order_ring`] orders any ring.

use super::step::half_edge;
use crate::mesh::topology::VertexTag;
use crate::mesh::Topology;

/// The topology of the child level of `parent` whose faces are `face_offsets`,
/// `face_verts` with edges `face_edges` (numbered as [`super::step::refine`] numbers them:
/// parent vertex `v`'s child is vertex `v`, then face points, then edge points; parent face
/// `f`'s quad `k` is child face `parent.face_offsets[f] + k`; parent edge `e`'s halves are
/// child edges `2e` (at its first vertex) and `2e + 1`, then the interior edge of each face
/// corner), joining `edge_verts`. The same as [`Topology::from_edges`] of these faces.
pub(super) fn child_topology(
    parent: &Topology,
    face_offsets: Vec<u32>,
    face_verts: Vec<u32>,
    face_edges: Vec<u32>,
    edge_verts: Vec<[u32; 2]>,
) -> Topology {
    let (nv, nf) = (parent.num_vertices, parent.num_faces());
    let mut topo = Topology::without_rings(
        nv + nf + parent.num_edges(),
        face_offsets,
        face_verts,
        face_edges,
        edge_verts,
        &[],
    );
    let rings = topo.rings(|v, fan, edges| {
        fan.clear();
        edges.clear();
        if v < nv {
            vertex_child_ring(parent, &topo, v, fan, edges)
        } else if v < nv + nf {
            face_point_ring(parent, v - nv, fan, edges)
        } else {
            edge_point_ring(parent, &topo, v - nv - nf, fan, edges)
        }
    });
    topo.set_rings(rings);
    topo
}

/// The topology of the first `faces` faces of `topo`, whose vertices and edges are the first
/// ones of `topo` (as a cut-out lists the faces within fewer rings first,
/// [`crate::patch::local::extract_faces_within`]). Edges non-manifold in `topo` stay so.
pub(super) fn prefix_topology(topo: &Topology, faces: usize) -> Topology {
    let end = topo.face_offsets[faces] as usize;
    let face_verts = topo.face_verts[..end].to_vec();
    let face_edges = topo.face_edges[..end].to_vec();
    let nv = face_verts.iter().max().map_or(0, |&v| v as usize + 1);
    let ne = face_edges.iter().max().map_or(0, |&e| e as usize + 1);
    debug_assert!(
        {
            let mut used = (vec![false; nv], vec![false; ne]);
            face_verts.iter().for_each(|&v| used.0[v as usize] = true);
            face_edges.iter().for_each(|&e| used.1[e as usize] = true);
            used.0.iter().chain(&used.1).all(|&u| u)
        },
        "the first {faces} faces' vertices and edges are not a prefix of the numbering"
    );
    let forced: Vec<u32> = (0..ne as u32)
        .filter(|&e| topo.edge_nonmanifold[e as usize])
        .collect();
    Topology::without_rings(
        nv,
        topo.face_offsets[..=faces].to_vec(),
        face_verts,
        face_edges,
        topo.edge_verts[..ne].to_vec(),
        &forced,
    )
    .with_ordered_rings()
}

/// The ring of the child of parent vertex `v`.
fn vertex_child_ring(
    parent: &Topology,
    child: &Topology,
    v: usize,
    fan: &mut Vec<(u32, u32)>,
    edges: &mut Vec<u32>,
) -> VertexTag {
    let tag = parent.vert_tags[v];
    let faces = parent.vertex_faces(v);
    let corners = parent.vertex_face_corners(v);
    let quads = faces
        .iter()
        .zip(corners)
        .map(|(&f, &c)| (parent.face_offsets[f as usize] + c, 0));
    if tag.nonmanifold {
        let mut unordered: Vec<(u32, u32)> = quads.collect();
        unordered.sort_unstable();
        return child.order_ring(&unordered, fan, edges);
    }
    // A manifold ring has no degenerate edge (a face repeating `v` makes it non-manifold).
    fan.extend(quads);
    edges.extend(
        parent
            .vertex_edges(v)
            .iter()
            .map(|&e| half_edge(parent, e, v as u32, true)),
    );
    tag
}

/// The ring of the face point of parent face `f`.
fn face_point_ring(
    parent: &Topology,
    f: usize,
    fan: &mut Vec<(u32, u32)>,
    edges: &mut Vec<u32>,
) -> VertexTag {
    let n = parent.face_size(f) as u32;
    let o = parent.face_offsets[f];
    // Quad k's interior edges: 2·ne + o + k leaves the face point for edge point k (its
    // trailing edge there), 2·ne + o + k − 1 arrives (its leading edge).
    let inner = 2 * parent.num_edges() as u32 + o;
    fan.extend((0..n).map(|k| (o + k, 2)));
    edges.push(inner + n - 1);
    edges.extend((0..n - 1).map(|k| inner + k));
    VertexTag::default()
}

/// The ring of the edge point of parent edge `e`.
fn edge_point_ring(
    parent: &Topology,
    child: &Topology,
    e: usize,
    fan: &mut Vec<(u32, u32)>,
    edges: &mut Vec<u32>,
) -> VertexTag {
    let [a, b] = parent.edge_verts[e];
    // The edge's half at an end (`a ≠ b` where this is asked).
    let half = |x: u32| half_edge(parent, e as u32, x, true);
    let faces = parent.edge_face_list(e as u32);
    let e32 = e as u32;
    // Where face `f` uses the edge (slot `m`): the quads holding the edge point are `m`
    // (corner 1) and `m + 1` (corner 3).
    let uses = |f: u32| {
        let list = parent.face_edge_list(f as usize);
        let o = parent.face_offsets[f as usize];
        let n = list.len() as u32;
        list.iter()
            .enumerate()
            .filter(move |(_, &x)| x == e32)
            .map(move |(m, _)| (o, n, m as u32))
    };
    let simple = !parent.edge_nonmanifold[e]
        && a != b
        && match faces {
            [_] => true,
            [f, g] => f != g,
            _ => false,
        };
    if !simple {
        let mut unordered: Vec<(u32, u32)> = Vec::with_capacity(2 * faces.len());
        let mut last = None;
        for &f in faces {
            if last == Some(f) {
                continue;
            }
            last = Some(f);
            for (o, n, m) in uses(f) {
                unordered.extend([(o + m, 1), (o + (m + 1) % n, 3)]);
            }
        }
        unordered.sort_unstable();
        return child.order_ring(&unordered, fan, edges);
    }
    let inner = 2 * parent.num_edges() as u32;
    // Per face: corner 3 of quad m + 1 (its leading edge the half at the face's vertex
    // m + 1), then corner 1 of quad m (its leading edge the interior edge of slot m, its
    // trailing edge the half at vertex m, which the other face's quad leads with, returned).
    let side = |f: u32, fan: &mut Vec<(u32, u32)>, edges: &mut Vec<u32>| {
        let (o, n, m) = uses(f).next().expect("a face of the edge uses it");
        let fv = parent.face_vertices(f as usize);
        fan.extend([(o + (m + 1) % n, 3), (o + m, 1)]);
        edges.extend([half(fv[((m + 1) % n) as usize]), inner + o + m]);
        half(fv[m as usize])
    };
    match *faces {
        [f] => {
            let trailing = side(f, fan, edges);
            edges.push(trailing);
            VertexTag {
                boundary: true,
                nonmanifold: false,
            }
        }
        [f, g] => {
            side(f, fan, edges);
            side(g, fan, edges);
            // An interior ring starts at its face of lowest index.
            let start = (0..4).min_by_key(|&i| fan[i].0).unwrap_or(0);
            fan.rotate_left(start);
            edges.rotate_left(start);
            VertexTag::default()
        }
        _ => unreachable!("a simple edge has one or two faces"),
    }
}

#[cfg(test)]
mod tests {
    use crate::mesh::generate::{grid, star};
    use crate::mesh::CreaseMethod;
    use crate::mesh::{shapes, ControlMesh, MeshBuilder, Topology};
    use crate::patch::local::{extract_faces, extract_faces_within};
    use crate::refine::level::Level;
    use crate::refine::step::{refine, refine_inner};

    /// Every field of two topologies, named where they differ.
    fn assert_same(got: &Topology, want: &Topology, what: &str) {
        assert_eq!(got.num_vertices, want.num_vertices, "{what}");
        assert_eq!(got.edge_faces, want.edge_faces, "{what}: edge faces");
        assert_eq!(got.edge_face_offsets, want.edge_face_offsets, "{what}");
        assert_eq!(got.edge_nonmanifold, want.edge_nonmanifold, "{what}");
        assert_eq!(got.vert_face_offsets, want.vert_face_offsets, "{what}");
        for v in 0..want.num_vertices {
            assert_eq!(
                (got.vertex_faces(v), got.vertex_face_corners(v)),
                (want.vertex_faces(v), want.vertex_face_corners(v)),
                "{what}: faces around vertex {v}"
            );
            assert_eq!(
                got.vertex_edges(v),
                want.vertex_edges(v),
                "{what}: edges around vertex {v}"
            );
            assert_eq!(got.vert_tags[v], want.vert_tags[v], "{what}: vertex {v}");
        }
        assert_eq!(got.vert_edge_offsets, want.vert_edge_offsets, "{what}");
    }

    /// Meshes with boundaries, n-gons, triangles, creases, poles and non-manifold features:
    /// a bow-tie vertex, an edge of three faces, two faces winding one edge the same way,
    /// and a face that repeats a vertex.
    fn meshes() -> Vec<(String, ControlMesh)> {
        let raw = |n: usize, sizes: &[usize], verts: &[u32]| {
            let positions = (0..n)
                .map(|i| [i as f64, (i * i % 7) as f64, 0.0])
                .collect();
            MeshBuilder::new()
                .positions(positions)
                .faces(sizes, verts)
                .build()
                .unwrap()
        };
        vec![
            ("grid(3)".into(), grid(3)),
            ("star(5, 2)".into(), star(5, 2)),
            ("star(3, 3)".into(), star(3, 3)),
            ("blob".into(), shapes::blob()),
            ("gear".into(), shapes::gear(6)),
            ("spindle".into(), shapes::spindle(5)),
            ("rounded box".into(), shapes::rounded_box(2.0)),
            (
                "triangulated box".into(),
                shapes::triangulated(&shapes::rounded_box(1.0)),
            ),
            ("cyclorama".into(), shapes::cyclorama(2.0, 1.0, 1.0)),
            ("bow-tie".into(), raw(5, &[3, 3], &[0, 1, 2, 0, 3, 4])),
            (
                "three faces on an edge".into(),
                raw(8, &[4, 4, 4], &[0, 1, 2, 3, 1, 0, 4, 5, 0, 1, 6, 7]),
            ),
            (
                "inconsistent winding".into(),
                raw(6, &[4, 4], &[0, 1, 2, 3, 0, 1, 4, 5]),
            ),
            (
                "repeated vertex".into(),
                raw(7, &[5, 4], &[0, 1, 2, 0, 3, 1, 0, 5, 6]),
            ),
        ]
    }

    /// Two refinement steps of every mesh, and of cut-outs around a few of its faces (whose
    /// rim has bow-ties and boundaries the mesh lacks), give the topology that
    /// `Topology::from_edges` finds from the child faces: every ring the same, in the same
    /// order, from the same start.
    #[test]
    fn child_rings_are_those_from_edges() {
        let mut derived = 0;
        for (name, mesh) in meshes() {
            let (base, _) = Level::base(&mesh, &Default::default()).unwrap();
            let nf = base.num_faces() as u32;
            let mut levels = vec![(name.clone(), base.clone())];
            for seeds in [vec![0], vec![nf / 2, nf - 1], vec![1 % nf]] {
                let (sub, _, _) = extract_faces(&base, &seeds, 1);
                levels.push((format!("{name}, cut out at {seeds:?}"), sub));
            }
            for (what, level) in levels {
                let mut level = level;
                for step in 1..=2 {
                    let (child, _) = refine(&level, Default::default());
                    let t = &child.topo;
                    let want = Topology::from_edges(
                        t.num_vertices,
                        t.face_offsets.clone(),
                        t.face_verts.clone(),
                        t.face_edges.clone(),
                        t.edge_verts.clone(),
                    );
                    assert_same(t, &want, &format!("{what}, step {step}"));
                    derived += t.num_vertices;
                    level = child;
                }
            }
        }
        assert!(derived > 10_000, "{derived} vertices compared");
    }

    /// Refining the first ring of a two-ring cut-out (`refine_inner`, as adaptive refinement
    /// does) gives the topology of the refined one-ring cut-out, and, for every child vertex
    /// and edge, the stencil row and sharpness of the same child in the refinement of the whole
    /// two-ring cut-out, bit for bit: semi-sharp creases under both crease rules, boundaries,
    /// n-gons and non-manifold features.
    #[test]
    fn inner_refinement_is_the_whole_one_inside() {
        let mut checked = 0;
        for (name, mesh) in meshes() {
            let (base, _) = Level::base(&mesh, &Default::default()).unwrap();
            let nf = base.num_faces() as u32;
            for seeds in [vec![0], vec![nf / 2, nf - 1]] {
                let (sub, _, _, inner) = extract_faces_within(&base, &seeds, 2);
                let (one, _, _) = extract_faces(&base, &seeds, 1);
                assert_eq!(inner, one.num_faces(), "{name}");
                for method in [CreaseMethod::Uniform, CreaseMethod::Chaikin] {
                    let what = format!("{name}, seeds {seeds:?}, {method:?}");
                    let (part, pt) = refine_inner(&sub, inner, method);
                    let (whole, wt) = refine(&sub, method);
                    let (of_one, _) = refine(&one, method);
                    assert_same(&part.topo, &of_one.topo, &what);
                    // Child vertex and interior-edge numbers of `part` in `whole`.
                    let (p, w) = (&sub.topo, &part.topo);
                    let (nv, nf1, ne) = (one.num_vertices(), one.num_faces(), one.topo.num_edges());
                    let vertex = |c: usize| {
                        if c < nv {
                            c
                        } else if c < nv + nf1 {
                            p.num_vertices + (c - nv)
                        } else {
                            p.num_vertices + p.num_faces() + (c - nv - nf1)
                        }
                    };
                    assert_eq!(pt.num_inputs, wt.num_inputs, "{what}");
                    for c in 0..w.num_vertices {
                        assert_eq!(pt.row(c), wt.row(vertex(c)), "{what}: child vertex {c}");
                        assert_eq!(
                            part.vertex_sharpness[c].to_bits(),
                            whole.vertex_sharpness[vertex(c)].to_bits(),
                            "{what}: child vertex {c}"
                        );
                    }
                    for e in 0..w.num_edges() {
                        let we = if e < 2 * ne {
                            e
                        } else {
                            e - 2 * ne + 2 * p.num_edges()
                        };
                        assert_eq!(
                            part.edge_sharpness[e].to_bits(),
                            whole.edge_sharpness[we].to_bits(),
                            "{what}: child edge {e}"
                        );
                    }
                    assert_eq!(part.face_hole, whole.face_hole[..w.num_faces()], "{what}");
                    checked += w.num_vertices;
                }
            }
        }
        assert!(checked > 1_500, "{checked} child vertices compared");
    }
}
