//! Small local meshes for feature-adaptive refinement: the neighbourhood of one face cut out
//! of a level, refined on its own, with per-point data (stencil weights or positions) carried
//! along.
//!
//! The limit surface over a face depends only on its one-ring; one level of refinement of a
//! neighbourhood is exact wherever the rules only read points of the neighbourhood. Cutting
//! out two rings of faces keeps every point that the face's descendants need exact: the wrong
//! values at the cut (rules applied to incomplete rings) move inwards by one edge of the
//! current level per level, ½ + ¼ + … < 1 face, while the descendants' one-rings reach only
//! their own size beyond the face. Chaikin's rule reads the edges at both ends of an edge, so
//! the second ring also keeps the vertices of the first ring complete.

use crate::mesh::{CreaseMethod, Topology};
use crate::refine::Level;
use rustc_hash::FxHashMap as HashMap;

/// A level (usually a small neighbourhood) and `width` numbers of data per vertex.
#[derive(Clone, Debug)]
pub struct LocalMesh {
    /// Topology and tags.
    pub level: Level,
    /// Per-vertex data, `width` values per vertex.
    pub data: Vec<f64>,
    /// Values per vertex.
    pub width: usize,
}

impl LocalMesh {
    /// One uniform refinement step of the whole local mesh, under its level's scheme.
    pub fn refine(&self, method: CreaseMethod) -> LocalMesh {
        let (level, table) = crate::refine::refine_once(&self.level, method);
        let data = table.apply(&self.data, self.width);
        LocalMesh {
            level,
            data,
            width: self.width,
        }
    }

    /// The data of vertex `v`.
    pub fn point(&self, v: usize) -> &[f64] {
        &self.data[v * self.width..(v + 1) * self.width]
    }

    /// Cuts out the faces within `rings` vertex-rings of `face` (which becomes face 0 of the
    /// result, with the same vertex order), copying sharpness, holes and data.
    pub fn extract(
        level: &Level,
        data: &[f64],
        width: usize,
        face: usize,
        rings: usize,
    ) -> LocalMesh {
        Self::extract_with_map(level, data, width, face, rings).0
    }

    /// Like [`Self::extract`], also returning the original index of each local vertex.
    pub fn extract_with_map(
        level: &Level,
        data: &[f64],
        width: usize,
        face: usize,
        rings: usize,
    ) -> (LocalMesh, Vec<u32>) {
        let (lvl, verts_old, _) = extract_faces(level, &[face as u32], rings);
        let mut out = Vec::with_capacity(verts_old.len() * width);
        for &v in &verts_old {
            out.extend_from_slice(&data[v as usize * width..(v as usize + 1) * width]);
        }
        let mesh = LocalMesh {
            level: lvl,
            data: out,
            width,
        };
        (mesh, verts_old)
    }
}

/// A renumbering of some of `0..n` as `0, 1, 2, …` in the order first met: a dense table
/// where many are renumbered (a level's cut-out around many seeds), a hash map where few are
/// (a small neighbourhood of a large level, where clearing a table of `n` would dominate).
enum Renumber {
    Dense(Vec<u32>),
    Sparse(HashMap<u32, u32>),
}

impl Renumber {
    /// A renumbering of `0..n` expecting about `expected` numbers.
    fn new(n: usize, expected: usize) -> Self {
        if expected.saturating_mul(16) >= n {
            Renumber::Dense(vec![u32::MAX; n])
        } else {
            Renumber::Sparse(HashMap::default())
        }
    }

    /// The new number of `x`, given by `add` (called once, on first sight).
    #[inline]
    fn get_or_add(&mut self, x: u32, add: impl FnOnce() -> u32) -> u32 {
        match self {
            Renumber::Dense(table) => {
                let slot = &mut table[x as usize];
                if *slot == u32::MAX {
                    *slot = add();
                }
                *slot
            }
            Renumber::Sparse(map) => *map.entry(x).or_insert_with(add),
        }
    }

    /// The new number of `x`, which has one.
    #[inline]
    fn get(&self, x: u32) -> u32 {
        match self {
            Renumber::Dense(table) => table[x as usize],
            Renumber::Sparse(map) => map[&x],
        }
    }
}

/// Cuts the faces within `rings` vertex-rings of the `seeds` out of `level`. Returns the new
/// level (seeds first, in order, keeping their vertex order), the original index of each new
/// vertex, and the new index of each seed.
pub fn extract_faces(level: &Level, seeds: &[u32], rings: usize) -> (Level, Vec<u32>, Vec<u32>) {
    let (cut, old, seed_new, _) = extract_faces_within(level, seeds, rings);
    (cut, old, seed_new)
}

/// [`extract_faces`], with the number of the cut-out's faces within `rings − 1` rings of the
/// seeds (all of them when `rings` is 0). The cut-out lists its faces ring by ring and
/// numbers vertices and edges in the order its faces first use them, so those faces' vertices
/// and edges come first too: the faces within `rings − 1` rings are a cut-out of their own,
/// numbered as a prefix of this one ([`crate::refine::step::refine_inner`] refines it).
pub fn extract_faces_within(
    level: &Level,
    seeds: &[u32],
    rings: usize,
) -> (Level, Vec<u32>, Vec<u32>, usize) {
    let topo = &level.topo;
    // A cut-out holds about 16 faces per seed (two rings of a regular quad).
    let expected = seeds.len() * if rings == 0 { 1 } else { 16 };
    let mut faces: Vec<u32> = Vec::new();
    let mut seen = Renumber::new(topo.num_faces(), expected);
    let mut seed_new = Vec::with_capacity(seeds.len());
    for &f in seeds {
        let id = seen.get_or_add(f, || {
            faces.push(f);
            (faces.len() - 1) as u32
        });
        seed_new.push(id);
    }
    let mut frontier = faces.clone();
    let mut inner = faces.len();
    for ring in 0..rings {
        if ring + 1 == rings {
            inner = faces.len();
        }
        let mut next = Vec::new();
        for &f in &frontier {
            for &v in topo.face_vertices(f as usize) {
                for &g in topo.vertex_faces(v as usize) {
                    seen.get_or_add(g, || {
                        faces.push(g);
                        next.push(g);
                        (faces.len() - 1) as u32
                    });
                }
            }
        }
        frontier = next;
    }
    let mut vmap = Renumber::new(topo.num_vertices, expected);
    let mut verts_old = Vec::new();
    let mut emap = Renumber::new(topo.num_edges(), 2 * expected);
    let mut edges_old = Vec::new();
    let mut offsets = vec![0u32];
    let mut fverts = Vec::new();
    let mut fedges = Vec::new();
    for &f in &faces {
        for (&v, &e) in topo
            .face_vertices(f as usize)
            .iter()
            .zip(topo.face_edge_list(f as usize))
        {
            let id = vmap.get_or_add(v, || {
                verts_old.push(v);
                (verts_old.len() - 1) as u32
            });
            fverts.push(id);
            let eid = emap.get_or_add(e, || {
                edges_old.push(e);
                (edges_old.len() - 1) as u32
            });
            fedges.push(eid);
        }
        offsets.push(fverts.len() as u32);
    }
    // The cut-out keeps the level's edges as they are (not re-discovered from vertex pairs):
    // below a face that repeats a vertex, two distinct edges can join the same two vertices
    // (the halves of a degenerate edge), and they must stay apart. Edges that are
    // non-manifold in the level stay so in the cut-out.
    let edge_verts = edges_old
        .iter()
        .map(|&e| topo.edge_verts[e as usize].map(|v| vmap.get(v)))
        .collect();
    let nonmanifold: Vec<u32> = edges_old
        .iter()
        .enumerate()
        .filter(|(_, &e)| topo.edge_nonmanifold[e as usize])
        .map(|(i, _)| i as u32)
        .collect();
    let sub = Topology::without_rings(
        verts_old.len(),
        offsets,
        fverts,
        fedges,
        edge_verts,
        &nonmanifold,
    )
    .with_ordered_rings();
    let edge_sharpness = edges_old
        .iter()
        .map(|&e| level.edge_sharpness[e as usize])
        .collect();
    let vertex_sharpness = verts_old
        .iter()
        .map(|&v| level.vertex_sharpness[v as usize])
        .collect();
    let face_hole = faces.iter().map(|&f| level.face_hole[f as usize]).collect();
    (
        Level {
            topo: sub,
            edge_sharpness,
            vertex_sharpness,
            face_hole,
            smooth_triangles: level.smooth_triangles,
            scheme: level.scheme,
        },
        verts_old,
        seed_new,
        inner,
    )
}

pub use crate::refine::step::child_face;
