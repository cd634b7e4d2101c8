//! Face-varying refinement of texture coordinates (Catmull-Clark): OpenSubdiv's six linear
//! interpolation modes. Each face corner carries a value index; a vertex has one value per
//! group of faces that share it (its siblings), and an edge whose two faces disagree at either
//! end is a seam, a boundary in the values' own topology.
//!
//! A child face's corners take, in the ptex order of [`super::step`]: the vertex point of
//! the value its parent face has at the corner, the edge points of the value pairs its parent
//! face has along the two edges, and the face point (the average of the face's values).
//! Where the values are continuous, vertex and edge points are the vertex data's own stencils
//! (sharpness included) applied to the values around; on a seam, edges are linear and values
//! follow the crease rule along their two seam edges, or stay where they are at the corners
//! the mode sharpens.

use super::crease;
use super::level::Level;
use super::stencil::StencilTable;
use std::collections::HashMap;

pub use crate::mesh::FVarMode;

/// The face-varying values of one level: `values` and, parallel to the level's
/// `topo.face_verts`, each face corner's value index.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct FVarLevel {
    /// The values.
    pub values: Vec<[f64; 2]>,
    /// Value index of each face corner.
    pub corners: Vec<u32>,
}

/// The child key of a value: which rule makes it.
#[derive(Clone, Copy, PartialEq, Eq, Hash)]
enum Key {
    Vertex(u32, u32),
    Edge(u32, u32, u32),
    Face(u32),
}

/// Child values by the rule (and parent element) that makes them, each made once.
#[derive(Default)]
struct Builder {
    index: HashMap<Key, u32>,
    out: FVarLevel,
}

impl Builder {
    fn get(&mut self, key: Key, make: impl FnOnce() -> [f64; 2]) -> u32 {
        if let Some(&i) = self.index.get(&key) {
            return i;
        }
        self.out.values.push(make());
        let i = (self.out.values.len() - 1) as u32;
        self.index.insert(key, i);
        i
    }
}

/// Refines `parent`'s values one level, with `table` the vertex data's stencils from
/// `parent` (vertex children, then face points, then edge points: [`super::step`]).
pub fn refine(
    parent: &Level,
    values: &FVarLevel,
    table: &StencilTable,
    mode: FVarMode,
) -> FVarLevel {
    let topo = &parent.topo;
    let first_edge_row = parent.num_vertices() + parent.num_faces();
    let val = |f: usize, k: usize| values.corners[topo.face_offsets[f] as usize + k];
    let mut b = Builder::default();
    for f in 0..parent.num_faces() {
        let fv = topo.face_vertices(f);
        let fe = topo.face_edge_list(f);
        let n = fv.len();
        let face_value = b.get(Key::Face(f as u32), || {
            let mut s = [0.0; 2];
            for k in 0..n {
                let x = values.values[val(f, k) as usize];
                s[0] += x[0] / n as f64;
                s[1] += x[1] / n as f64;
            }
            s
        });
        let edge = |b: &mut Builder, m: usize| {
            let (x, y) = (val(f, m), val(f, (m + 1) % n));
            let e = fe[m];
            let pair = if topo.edge_verts[e as usize][0] == fv[m] {
                (x, y)
            } else {
                (y, x)
            };
            b.get(Key::Edge(e, pair.0, pair.1), || {
                edge_value(
                    parent,
                    values,
                    table,
                    mode,
                    e as usize,
                    first_edge_row,
                    pair,
                )
            })
        };
        let edges: Vec<u32> = (0..n).map(|m| edge(&mut b, m)).collect();
        for k in 0..n {
            let x = val(f, k);
            let vertex = b.get(Key::Vertex(fv[k], x), || {
                vertex_value(parent, values, table, mode, fv[k] as usize, x)
            });
            b.out.corners.extend_from_slice(&[
                vertex,
                edges[k],
                face_value,
                edges[(k + n - 1) % n],
            ]);
        }
    }
    b.out
}

/// The values at the ends of edge `e` (in `edge_verts` order) on each of its faces.
fn edge_pairs(parent: &Level, values: &FVarLevel, e: usize) -> Vec<(u32, u32)> {
    let topo = &parent.topo;
    let [a, _] = topo.edge_verts[e];
    topo.edge_face_list(e as u32)
        .iter()
        .map(|&f| {
            let f = f as usize;
            let fv = topo.face_vertices(f);
            let n = fv.len();
            let m = (0..n)
                .find(|&m| topo.face_edge(f, m) == e as u32)
                .expect("edge of its face");
            let o = topo.face_offsets[f] as usize;
            let (x, y) = (values.corners[o + m], values.corners[o + (m + 1) % n]);
            if fv[m] == a {
                (x, y)
            } else {
                (y, x)
            }
        })
        .collect()
}

/// True when edge `e` is interior, manifold and its two faces agree at both ends.
fn continuous(parent: &Level, values: &FVarLevel, e: usize) -> bool {
    let p = edge_pairs(parent, values, e);
    p.len() == 2 && p[0] == p[1]
}

/// Applies row `row` of `table` to the values, each parent vertex read in `faces` (which
/// must hold it with one value).
fn apply_row(
    parent: &Level,
    values: &FVarLevel,
    table: &StencilTable,
    row: usize,
    faces: &[u32],
) -> [f64; 2] {
    let topo = &parent.topo;
    let mut value_of: HashMap<u32, u32> = HashMap::new();
    for &f in faces {
        let f = f as usize;
        let o = topo.face_offsets[f] as usize;
        for (k, &u) in topo.face_vertices(f).iter().enumerate() {
            value_of.entry(u).or_insert(values.corners[o + k]);
        }
    }
    let (idx, w) = table.row(row);
    let mut s = [0.0; 2];
    for (&u, &w) in idx.iter().zip(w) {
        let x = values.values[value_of[&u] as usize];
        s[0] += w * x[0];
        s[1] += w * x[1];
    }
    s
}

fn edge_value(
    parent: &Level,
    values: &FVarLevel,
    table: &StencilTable,
    mode: FVarMode,
    e: usize,
    first_edge_row: usize,
    (a, b): (u32, u32),
) -> [f64; 2] {
    if mode != FVarMode::All && continuous(parent, values, e) {
        let topo = &parent.topo;
        let faces = topo.edge_face_list(e as u32);
        let corner_values: Vec<&[u32]> = faces
            .iter()
            .map(|&f| {
                let o = topo.face_offsets[f as usize] as usize;
                &values.corners[o..o + topo.face_size(f as usize)]
            })
            .collect();
        // Faces that share a vertex besides the edge's (a valence-2 vertex) may hold it with
        // different values: then the edge rule runs on the values themselves (uniform rule).
        let shared_twice = {
            let [va, vb] = topo.edge_verts[e];
            let f0 = topo.face_vertices(faces[0] as usize);
            let f1 = topo.face_vertices(faces[1] as usize);
            f0.iter().any(|u| *u != va && *u != vb && f1.contains(u))
        };
        if !shared_twice {
            return apply_row(parent, values, table, first_edge_row + e, faces);
        }
        let s = parent.edge_sharpness[e];
        let mut acc = super::stencil::Accumulator::new();
        super::rules::edge_mask(
            &mut acc,
            a,
            b,
            &corner_values,
            s,
            crease::is_sharp(if crease::is_infinite(s) { s } else { s - 1.0 }),
            parent.smooth_triangles,
        );
        let mut out = [0.0; 2];
        for &(i, w) in acc.terms() {
            let x = values.values[i as usize];
            out[0] += w * x[0];
            out[1] += w * x[1];
        }
        return out;
    }
    let (x, y) = (values.values[a as usize], values.values[b as usize]);
    [0.5 * (x[0] + y[0]), 0.5 * (x[1] + y[1])]
}

/// How one value sits at its vertex: what decides whether a [`FVarMode`] pins it.
pub(super) struct ValueShape<'a> {
    /// Faces around the vertex that carry the value.
    pub sector: usize,
    /// Seam (or boundary) edge sides bounding the value's faces.
    pub seams: usize,
    /// Faces carrying each of the vertex's values (its siblings), this one included.
    pub sector_sizes: &'a [usize],
    /// Faces around the vertex.
    pub faces: usize,
    /// Whether the vertex is on the mesh's boundary.
    pub on_boundary: bool,
}

impl ValueShape<'_> {
    /// Whether `mode` makes the value a corner: a corner of the values (one face), a junction
    /// of three or more values, a concave corner (a sector wider than a half-plane: more than
    /// half the faces around an interior vertex, more than two at a boundary vertex, or the
    /// other of two values is a corner), or any seam value in modes `boundaries` and `all`.
    pub fn pinned_by(&self, mode: FVarMode) -> bool {
        let corner = self.sector == 1;
        let junction = self.sector_sizes.len() >= 3;
        let other_is_corner = self.sector_sizes.len() == 2
            && self.sector_sizes.iter().filter(|&&n| n == 1).count() > usize::from(corner);
        let concave = other_is_corner
            || self.seams == 2
                && if self.on_boundary {
                    // A boundary vertex with one value is the mesh's own boundary, not a
                    // corner of the values.
                    self.sector_sizes.len() >= 2 && self.sector > 2
                } else {
                    2 * self.sector > self.faces
                };
        match mode {
            FVarMode::None => false,
            FVarMode::CornersOnly => corner,
            FVarMode::CornersPlus1 => corner || junction,
            FVarMode::CornersPlus2 => corner || junction || concave,
            FVarMode::Boundaries | FVarMode::All => true,
        }
    }
}

fn vertex_value(
    parent: &Level,
    values: &FVarLevel,
    table: &StencilTable,
    mode: FVarMode,
    v: usize,
    x: u32,
) -> [f64; 2] {
    let topo = &parent.topo;
    let xv = values.values[x as usize];
    if mode == FVarMode::All {
        return xv;
    }
    let faces = topo.vertex_faces(v);
    let corners = topo.vertex_face_corners(v);
    let value_at = |i: usize| {
        values.corners[topo.face_offsets[faces[i] as usize] as usize + corners[i] as usize]
    };
    let sector: Vec<u32> = (0..faces.len())
        .filter(|&i| value_at(i) == x)
        .map(|i| faces[i])
        .collect();
    let mut siblings: Vec<u32> = (0..faces.len()).map(value_at).collect();
    siblings.sort_unstable();
    siblings.dedup();
    // The seam (or boundary) edges at v bounding this value's faces, with the value at their
    // other end on the sector's side.
    let mut seams = Vec::new();
    for &e in topo.vertex_edges(v) {
        let e = e as usize;
        if continuous(parent, values, e) {
            continue;
        }
        let [a, _] = topo.edge_verts[e];
        for (&f, (p, q)) in topo
            .edge_face_list(e as u32)
            .iter()
            .zip(edge_pairs(parent, values, e))
        {
            if !sector.contains(&f) {
                continue;
            }
            let (here, there) = if a as usize == v { (p, q) } else { (q, p) };
            if here == x {
                seams.push(there);
            }
        }
    }
    if seams.is_empty() {
        // Continuous around v: the vertex data's own rule, from its stencil row unless a
        // vertex of the ring has two values in it (faces sharing more than an edge, at
        // valence-2 vertices): then the rule runs on the values themselves (uniform rule).
        let mut seen: HashMap<u32, u32> = HashMap::new();
        let ambiguous = faces.iter().any(|&f| {
            let o = topo.face_offsets[f as usize] as usize;
            topo.face_vertices(f as usize)
                .iter()
                .enumerate()
                .any(|(k, &u)| {
                    *seen.entry(u).or_insert(values.corners[o + k]) != values.corners[o + k]
                })
        });
        if !ambiguous {
            return apply_row(parent, values, table, v, faces);
        }
        let edges = topo.vertex_edges(v);
        let ends: Vec<u32> = edges
            .iter()
            .map(|&e| {
                let [a, _] = topo.edge_verts[e as usize];
                let (p, q) = edge_pairs(parent, values, e as usize)[0];
                if a as usize == v {
                    q
                } else {
                    p
                }
            })
            .collect();
        let es: Vec<f32> = edges
            .iter()
            .map(|&e| parent.edge_sharpness[e as usize])
            .collect();
        let next = |x: f32| {
            if crease::is_infinite(x) {
                x
            } else {
                (x - 1.0).max(0.0)
            }
        };
        let cs: Vec<f32> = es.iter().map(|&x| next(x)).collect();
        let face_values: Vec<&[u32]> = faces
            .iter()
            .map(|&f| {
                let o = topo.face_offsets[f as usize] as usize;
                &values.corners[o..o + topo.face_size(f as usize)]
            })
            .collect();
        let mut acc = super::stencil::Accumulator::new();
        super::rules::vertex_mask(
            &mut acc,
            &super::rules::VertexRing {
                center: x,
                edge_ends: &ends,
                edge_sharpness: &es,
                child_edge_sharpness: &cs,
                faces: &face_values,
                sharpness: parent.vertex_sharpness[v],
                child_sharpness: next(parent.vertex_sharpness[v]),
            },
        );
        let mut out = [0.0; 2];
        for &(i, w) in acc.terms() {
            let y = values.values[i as usize];
            out[0] += w * y[0];
            out[1] += w * y[1];
        }
        return out;
    }
    // The value's own rule counts its seams as infinitely sharp edges, with the vertex data's
    // sharp edges inside its sector and the vertex's sharpness: three or more sharp edges, or
    // a sharp vertex, pin it (a corner). Where that rule turns from corner to crease in the
    // next level (semi-sharp edges and vertex, uniform rule), the two blend by the average
    // sharpness of what turns smooth, as the vertex rule of the positions does.
    let sv = parent.vertex_sharpness[v];
    let inner: Vec<f32> = topo
        .vertex_edges(v)
        .iter()
        .filter(|&&e| {
            let e = e as usize;
            parent.edge_sharpness[e] > 0.0
                && continuous(parent, values, e)
                && topo
                    .edge_face_list(e as u32)
                    .iter()
                    .any(|f| sector.contains(f))
        })
        .map(|&e| parent.edge_sharpness[e as usize])
        .collect();
    let next = |x: f32| if crease::is_infinite(x) { x } else { x - 1.0 };
    let pinned = |sv: f32, inner: &[f32]| {
        sv > 0.0 || seams.len() + inner.iter().filter(|&&x| x > 0.0).count() > 2
    };
    let inner_next: Vec<f32> = inner.iter().map(|&x| next(x)).collect();
    if pinned(next(sv), &inner_next) {
        return xv;
    }
    let mut s = 0.0f64;
    if pinned(sv, &inner) {
        let turning: Vec<f32> = std::iter::once(sv)
            .chain(inner.iter().copied())
            .filter(|&x| x > 0.0 && x <= 1.0)
            .collect();
        s = turning.iter().map(|&x| x as f64).sum::<f64>() / turning.len().max(1) as f64;
    }
    let dart = seams.len() == 1;
    // A sector wider than a half-plane: more than half the faces around an interior vertex,
    // more than two at a boundary vertex.
    let on_boundary = topo
        .vertex_edges(v)
        .iter()
        .any(|&e| topo.edge_is_boundary(e));
    let sizes: Vec<usize> = siblings
        .iter()
        .map(|&y| (0..faces.len()).filter(|&i| value_at(i) == y).count())
        .collect();
    let own = ValueShape {
        sector: sector.len(),
        seams: seams.len(),
        sector_sizes: &sizes,
        faces: faces.len(),
        on_boundary,
    };
    let sharp = own.pinned_by(mode);
    if sharp || seams.len() != 2 {
        if dart && !sharp {
            return apply_row(parent, values, table, v, &sector);
        }
        return xv;
    }
    let (p, q) = (
        values.values[seams[0] as usize],
        values.values[seams[1] as usize],
    );
    let c = [
        0.75 * xv[0] + 0.125 * (p[0] + q[0]),
        0.75 * xv[1] + 0.125 * (p[1] + q[1]),
    ];
    [(1.0 - s) * c[0] + s * xv[0], (1.0 - s) * c[1] + s * xv[1]]
}
