//! The texture coordinates of a mesh as a control mesh of their own, whose limit surface is
//! the face-varying limit: one control point `(s, t, 0)` per distinct (vertex, value) pair,
//! the mesh's faces over them (so seams are boundaries and faces keep their corners, hence
//! their ptex parameterisation), the vertex data's creases and corners carried over, and
//! the vertices a [`FVarMode`] pins made infinitely sharp corners.
//!
//! Its uniform refinement equals [`super::fvar::refine`], hence Far's face-varying
//! refinement, on every case `tests/fvar.rs` compares (the fvar corpus at levels 1–3 and
//! random seams on 69 corpus shapes at levels 1–2, every mode, 3e-16), so its limit is the
//! limit of Far's values (Far's own face-varying patches approximate it at irregular values).
//! One configuration would not carry over: a value bounded by a single seam edge side (not
//! met in a manifold mesh), which `fvar::refine` smooths with the vertex data's rule.
//! Mode [`FVarMode::All`] (bilinear) is not a subdivision surface; [`crate::patch::uv`]
//! interpolates it directly.

use crate::error::Result;
use crate::mesh::topology::Topology;
use crate::mesh::{
    BoundaryInterpolation, ControlMesh, EdgeCrease, FVarMode, Options, Scheme, VertexCorner,
};
use std::collections::HashMap;

/// Sharpness of a pinned value (infinitely sharp).
const PINNED: f32 = crate::mesh::SHARPNESS_INFINITE;

/// The control mesh of `mesh`'s texture coordinates under `mode` (see the module). `mesh`
/// must have texture coordinates on every face corner.
pub fn uv_mesh(mesh: &ControlMesh, mode: FVarMode) -> Result<ControlMesh> {
    let refiner = super::Refiner::new(mesh, 0)?;
    let base = &refiner.levels[0];
    let topo = &base.topo;
    // One control point per (vertex, value).
    let mut index: HashMap<(u32, u32), u32> = HashMap::new();
    let mut positions = Vec::new();
    let mut owner = Vec::new();
    let face_verts: Vec<u32> = mesh
        .face_verts
        .iter()
        .zip(&mesh.face_uvs)
        .map(|(&v, &t)| {
            *index.entry((v, t)).or_insert_with(|| {
                let [s, t] = mesh.uvs[t as usize];
                positions.push([s, t, 0.0]);
                owner.push(v);
                (positions.len() - 1) as u32
            })
        })
        .collect();
    let point = |f: usize, k: usize| face_verts[mesh.face_offsets[f] as usize + k];
    // The vertex data's edge and vertex sharpness as level 0 has them (tags, and the
    // boundary's sharp edges and corners), on every copy of the edge or vertex.
    let creases = crease_copies(mesh, base, &point);
    let mut corner_sharpness: HashMap<u32, f32> = HashMap::new();
    for (i, &o) in owner.iter().enumerate() {
        let s = base.vertex_sharpness[o as usize];
        if s > 0.0 {
            corner_sharpness.insert(i as u32, s);
        }
    }
    // The values the mode pins, judged as `fvar::refine` judges them.
    if mode != FVarMode::None && mode != FVarMode::All {
        for v in 0..mesh.num_vertices() {
            for x in pinned_values(mesh, topo, &face_verts, v, mode) {
                corner_sharpness.insert(x, PINNED);
            }
        }
    }
    let mut corners: Vec<VertexCorner> = corner_sharpness
        .into_iter()
        .map(|(vertex, sharpness)| VertexCorner { vertex, sharpness })
        .collect();
    corners.sort_by_key(|c| c.vertex);
    Ok(ControlMesh {
        positions,
        face_offsets: mesh.face_offsets.clone(),
        face_verts,
        creases,
        corners,
        holes: mesh.holes.clone(),
        options: Options {
            scheme: Scheme::Catmark,
            boundary: BoundaryInterpolation::EdgeOnly,
            crease_method: mesh.options.crease_method,
            smooth_triangles: mesh.options.smooth_triangles,
            fvar: mode,
        },
        ..ControlMesh::default()
    })
}

/// The sharp edges of `base` on each of their copies in the value mesh (`point(f, k)`: the
/// control point of face `f`'s corner `k`).
fn crease_copies(
    mesh: &ControlMesh,
    base: &super::level::Level,
    point: &dyn Fn(usize, usize) -> u32,
) -> Vec<EdgeCrease> {
    let mut creases = Vec::new();
    let mut seen = std::collections::HashSet::new();
    for f in 0..mesh.num_faces() {
        let n = mesh.face_size(f);
        for m in 0..n {
            let s = base.edge_sharpness[base.topo.face_edge(f, m) as usize];
            if s <= 0.0 {
                continue;
            }
            let (a, b) = (point(f, m), point(f, (m + 1) % n));
            // A degenerate edge (a face repeating a vertex) has no crease tag to carry.
            if a != b && seen.insert((a.min(b), a.max(b))) {
                creases.push(EdgeCrease {
                    v0: a.min(b),
                    v1: a.max(b),
                    sharpness: s,
                });
            }
        }
    }
    creases
}

/// The control points (values) of vertex `v` that `mode` makes corners: on a seam or the
/// boundary and a corner of the values (one face), a junction of three or more values, a
/// concave corner (corners-plus2), any seam value (boundaries), or one where more than two
/// seams meet.
fn pinned_values(
    mesh: &ControlMesh,
    topo: &Topology,
    points: &[u32],
    v: usize,
    mode: FVarMode,
) -> Vec<u32> {
    let faces = topo.vertex_faces(v);
    let corners = topo.vertex_face_corners(v);
    let value_at =
        |i: usize| points[mesh.face_offsets[faces[i] as usize] as usize + corners[i] as usize];
    let mut siblings: Vec<u32> = (0..faces.len()).map(value_at).collect();
    siblings.sort_unstable();
    siblings.dedup();
    // Edge `e`'s (value here, value there) on each of its faces.
    let ends = |e: u32| -> Vec<(u32, u32)> {
        topo.edge_face_list(e)
            .iter()
            .map(|&f| {
                let f = f as usize;
                let o = mesh.face_offsets[f] as usize;
                let fv = &mesh.face_verts[o..mesh.face_offsets[f + 1] as usize];
                let n = fv.len();
                let [a, b] = topo.edge_verts[e as usize];
                let m = (0..n)
                    .find(|&m| {
                        (fv[m], fv[(m + 1) % n]) == (a, b) || (fv[m], fv[(m + 1) % n]) == (b, a)
                    })
                    .expect("edge of its face");
                let (p, q) = (points[o + m], points[o + (m + 1) % n]);
                if fv[m] as usize == v {
                    (p, q)
                } else {
                    (q, p)
                }
            })
            .collect()
    };
    let on_boundary = topo
        .vertex_edges(v)
        .iter()
        .any(|&e| topo.edge_is_boundary(e));
    let mut out = Vec::new();
    for &x in &siblings {
        let sector = (0..faces.len()).filter(|&i| value_at(i) == x).count();
        let mut seams = 0;
        for &e in topo.vertex_edges(v) {
            let pairs = ends(e);
            let continuous = pairs.len() == 2 && pairs[0] == pairs[1];
            if !continuous {
                seams += pairs.iter().filter(|(here, _)| *here == x).count();
            }
        }
        if seams == 0 {
            continue;
        }
        let sizes: Vec<usize> = siblings
            .iter()
            .map(|&y| (0..faces.len()).filter(|&i| value_at(i) == y).count())
            .collect();
        let sharp = super::fvar::ValueShape {
            sector,
            seams,
            sector_sizes: &sizes,
            faces: faces.len(),
            on_boundary,
        }
        .pinned_by(mode);
        if sharp || seams > 2 {
            out.push(x);
        }
    }
    out
}
