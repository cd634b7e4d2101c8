//! Edge and vertex adjacency of a polygon mesh, with ordered vertex rings.
//!
//! Conventions (shared by every refinement level):
//! - edge `i` of a face runs from its vertex `i` to vertex `i + 1`;
//! - around a manifold vertex, incident faces are ordered counter-clockwise (for
//!   counter-clockwise faces); `vert_edges[i]` is the *leading* edge of `vert_faces[i]`
//!   (the face's edge leaving the vertex) and the *trailing* edge of face `i` is edge `i + 1`;
//! - a boundary vertex starts at the face whose leading edge is a boundary edge and has one
//!   more edge than faces; an interior vertex has as many edges as faces.

use crate::error::{Error, ErrorKind, Result};
use rayon::prelude::*;

/// Per-vertex topological tags.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct VertexTag {
    /// On an open boundary (an incident edge has one face).
    pub boundary: bool,
    /// The faces around the vertex do not form one consistently oriented fan: a bow-tie, an
    /// incident non-manifold edge, or inconsistent winding. Its ring is not ordered.
    pub nonmanifold: bool,
}

/// Adjacency of a polygon mesh (no positions).
#[derive(Clone, Debug, Default)]
pub struct Topology {
    /// Number of vertices (vertices used by no face are allowed).
    pub num_vertices: usize,
    /// Face ranges into `face_verts` / `face_edges`.
    pub face_offsets: Vec<u32>,
    /// Vertex indices of each face.
    pub face_verts: Vec<u32>,
    /// Edge `i` of each face (from vertex `i` to `i + 1`), parallel to `face_verts`.
    pub face_edges: Vec<u32>,
    /// The two vertices of each edge.
    pub edge_verts: Vec<[u32; 2]>,
    /// Ranges into `edge_faces`.
    pub edge_face_offsets: Vec<u32>,
    /// Faces incident to each edge.
    pub edge_faces: Vec<u32>,
    /// Edge has more than two faces or two faces that traverse it the same way.
    pub edge_nonmanifold: Vec<bool>,
    /// Ranges into `vert_faces` / `vert_face_corner`.
    pub vert_face_offsets: Vec<u32>,
    /// Faces around each vertex (ordered for manifold vertices).
    pub vert_faces: Vec<u32>,
    /// Position of the vertex within each face of `vert_faces`.
    pub vert_face_corner: Vec<u32>,
    /// Ranges into `vert_edges`.
    pub vert_edge_offsets: Vec<u32>,
    /// Edges around each vertex (ordered for manifold vertices, see module docs).
    pub vert_edges: Vec<u32>,
    /// Tags per vertex.
    pub vert_tags: Vec<VertexTag>,
}

/// The vertex rings of a [`Topology`], as [`Topology::rings`] finds them.
pub(crate) struct Rings {
    vert_faces: Vec<u32>,
    vert_face_corner: Vec<u32>,
    vert_edge_offsets: Vec<u32>,
    vert_edges: Vec<u32>,
    vert_tags: Vec<VertexTag>,
}

fn ranges(counts: &[u32]) -> Vec<u32> {
    let mut off = Vec::with_capacity(counts.len() + 1);
    let mut acc = 0u32;
    off.push(0);
    for &c in counts {
        acc += c;
        off.push(acc);
    }
    off
}

impl Topology {
    /// Builds the adjacency of `num_vertices` vertices and the faces given as ranges of
    /// `face_verts`. Face sizes ≥ 3 and indices in range are the caller's to check
    /// ([`crate::mesh::ControlMesh::validate`]); they are checked again here and reported.
    pub fn new(num_vertices: usize, face_offsets: &[u32], face_verts: &[u32]) -> Result<Self> {
        let nf = face_offsets.len().saturating_sub(1);
        for f in 0..nf {
            let (a, b) = (face_offsets[f] as usize, face_offsets[f + 1] as usize);
            if b < a + 3 || b > face_verts.len() {
                return Err(
                    Error::new(ErrorKind::Topology, "face has fewer than 3 vertices")
                        .element(format!("face {}", f + 1)),
                );
            }
            if let Some(&v) = face_verts[a..b]
                .iter()
                .find(|&&v| v as usize >= num_vertices)
            {
                return Err(Error::new(
                    ErrorKind::Topology,
                    format!("vertex index {} out of range", v + 1),
                )
                .element(format!("face {}", f + 1)));
            }
        }
        let nfv = face_verts.len();
        // Edges: the face-edges in the order of their unordered vertex pair `(lo, hi)`, then
        // of their slot, by a counting sort on `lo` and a sort of each vertex's few entries
        // by `(hi, slot)` (linear time; a comparison sort of every face-edge took 8 of the
        // 37 ms of a 316² grid's level 0). `face_of` keeps each slot's face.
        let mut face_of = vec![0u32; nfv];
        let mut start = vec![0u32; num_vertices + 1];
        let pair = |a: usize, n: usize, i: usize| {
            let v0 = face_verts[a + i];
            let v1 = face_verts[a + (i + 1) % n];
            if v0 < v1 {
                (v0, v1)
            } else {
                (v1, v0)
            }
        };
        for f in 0..nf {
            let (a, b) = (face_offsets[f] as usize, face_offsets[f + 1] as usize);
            face_of[a..b].fill(f as u32);
            for i in 0..b - a {
                start[pair(a, b - a, i).0 as usize + 1] += 1;
            }
        }
        for v in 0..num_vertices {
            start[v + 1] += start[v];
        }
        let mut by_lo: Vec<(u32, u32)> = vec![(0, 0); nfv];
        {
            let mut fill = start.clone();
            for f in 0..nf {
                let (a, b) = (face_offsets[f] as usize, face_offsets[f + 1] as usize);
                for i in 0..b - a {
                    let (lo, hi) = pair(a, b - a, i);
                    let slot = &mut fill[lo as usize];
                    by_lo[*slot as usize] = (hi, (a + i) as u32);
                    *slot += 1;
                }
            }
        }
        for v in 0..num_vertices {
            by_lo[start[v] as usize..start[v + 1] as usize].sort_unstable();
        }
        let mut face_edges = vec![0u32; nfv];
        let mut edge_verts: Vec<[u32; 2]> = Vec::new();
        // Edges that are non-manifold whatever their face count (OpenSubdiv's rules for faces
        // that repeat a vertex): a degenerate pair (v, v) is a new edge at each use; an edge
        // met again in the face that used it last is a new instance, and both are non-manifold.
        let mut forced = Vec::new();
        for lo in 0..num_vertices as u32 {
            let entries = &by_lo[start[lo as usize] as usize..start[lo as usize + 1] as usize];
            let mut i = 0;
            while i < entries.len() {
                let hi = entries[i].0;
                let mut j = i;
                // The first instance of the pair, and the face that used it last.
                let mut first: Option<(u32, u32)> = None;
                while j < entries.len() && entries[j].0 == hi {
                    let fv = entries[j].1 as usize;
                    let f = face_of[fv];
                    let v0 = face_verts[fv];
                    let new_edge = |edge_verts: &mut Vec<[u32; 2]>| {
                        edge_verts.push(if v0 == lo { [lo, hi] } else { [hi, lo] });
                        (edge_verts.len() - 1) as u32
                    };
                    let e = if lo == hi {
                        let e = new_edge(&mut edge_verts);
                        forced.push(e);
                        e
                    } else {
                        match first {
                            None => {
                                let e = new_edge(&mut edge_verts);
                                first = Some((e, f));
                                e
                            }
                            Some((e0, last)) if last == f => {
                                let e = new_edge(&mut edge_verts);
                                forced.extend([e0, e]);
                                e
                            }
                            Some((e0, _)) => {
                                first = Some((e0, f));
                                e0
                            }
                        }
                    };
                    face_edges[fv] = e;
                    j += 1;
                }
                i = j;
            }
        }
        Ok(Self::without_rings(
            num_vertices,
            face_offsets.to_vec(),
            face_verts.to_vec(),
            face_edges,
            edge_verts,
            &forced,
        )
        .with_ordered_rings())
    }

    /// Completes the adjacency from faces whose edges are already known: `face_edges[i]` is
    /// the edge from `face_verts[i]` to the face's next vertex, and `edge_verts` gives each
    /// edge's ends. Refinement uses this to skip edge discovery; the caller guarantees
    /// consistency (faces of ≥ 3 vertices, indices in range).
    pub fn from_edges(
        num_vertices: usize,
        face_offsets: Vec<u32>,
        face_verts: Vec<u32>,
        face_edges: Vec<u32>,
        edge_verts: Vec<[u32; 2]>,
    ) -> Self {
        Self::without_rings(
            num_vertices,
            face_offsets,
            face_verts,
            face_edges,
            edge_verts,
            &[],
        )
        .with_ordered_rings()
    }

    /// The vertex rings of a topology [`Self::without_rings`] gave, each ordered by walking its
    /// faces around the vertex, from face to face across their shared edges.
    pub fn with_ordered_rings(mut self) -> Self {
        // Vertex -> face corners, unordered (by face, then corner), then ordered.
        let nf = self.num_faces();
        let mut unordered = vec![(0u32, 0u32); self.face_verts.len()];
        {
            let mut fill = self.vert_face_offsets.clone();
            for f in 0..nf {
                for (k, &v) in self.face_vertices(f).iter().enumerate() {
                    let slot = &mut fill[v as usize];
                    unordered[*slot as usize] = (f as u32, k as u32);
                    *slot += 1;
                }
            }
        }
        let offsets = &self.vert_face_offsets;
        let rings = self.rings(|v, fan, edges| {
            let (a, b) = (offsets[v] as usize, offsets[v + 1] as usize);
            self.order_ring(&unordered[a..b], fan, edges)
        });
        self.set_rings(rings);
        self
    }

    /// The adjacency of faces whose edges are known, as [`Self::from_edges`] takes them, with
    /// the edges in `forced` non-manifold whatever their faces (cut-outs of a level keep the
    /// level's non-manifold edges so), up to the vertex rings: edges' faces and tags, and how
    /// many faces each vertex has ([`Self::vert_face_offsets`]). The rings are left empty, for
    /// [`Self::with_ordered_rings`] (or for rings the caller finds otherwise).
    pub fn without_rings(
        num_vertices: usize,
        face_offsets: Vec<u32>,
        face_verts: Vec<u32>,
        face_edges: Vec<u32>,
        edge_verts: Vec<[u32; 2]>,
        forced: &[u32],
    ) -> Self {
        let nf = face_offsets.len().saturating_sub(1);
        let nfv = face_verts.len();
        let ne = edge_verts.len();
        // Uses of each edge, and how many run from its first vertex to its second.
        let mut edge_face_counts = vec![0u32; ne];
        let mut forward = vec![0u32; ne];
        for (fe, &e) in face_edges.iter().enumerate() {
            edge_face_counts[e as usize] += 1;
            if face_verts[fe] == edge_verts[e as usize][0] {
                forward[e as usize] += 1;
            }
        }
        // Non-manifold: more than two uses, two uses in the same direction, or `forced` (the
        // degenerate and repeated edges of faces that repeat a vertex, see `new`).
        let mut edge_nonmanifold: Vec<bool> = (0..ne)
            .map(|e| edge_face_counts[e] > 2 || (edge_face_counts[e] == 2 && forward[e] != 1))
            .collect();
        let edge_face_offsets = ranges(&edge_face_counts);
        let mut edge_faces = vec![0u32; nfv];
        {
            let mut fill = edge_face_offsets.clone();
            for f in 0..nf {
                let (a, b) = (face_offsets[f] as usize, face_offsets[f + 1] as usize);
                for &e in &face_edges[a..b] {
                    let slot = &mut fill[e as usize];
                    edge_faces[*slot as usize] = f as u32;
                    *slot += 1;
                }
            }
        }
        for &e in forced {
            edge_nonmanifold[e as usize] = true;
        }
        let mut vcount = vec![0u32; num_vertices];
        for &v in &face_verts {
            vcount[v as usize] += 1;
        }
        Topology {
            num_vertices,
            face_offsets,
            face_verts,
            face_edges,
            edge_verts,
            edge_face_offsets,
            edge_faces,
            edge_nonmanifold,
            vert_face_offsets: ranges(&vcount),
            vert_faces: Vec::new(),
            vert_face_corner: Vec::new(),
            vert_edge_offsets: Vec::new(),
            vert_edges: Vec::new(),
            vert_tags: Vec::new(),
        }
    }

    /// Every vertex's ring from `ring(v, fan, edges)`, which leaves vertex `v`'s ordered face
    /// corners in `fan` (as many as [`Self::vert_face_offsets`] gives it) and its edges in
    /// `edges`, and returns its tags; in parallel blocks of vertices.
    pub(crate) fn rings<F>(&self, ring: F) -> Rings
    where
        F: Fn(usize, &mut Vec<(u32, u32)>, &mut Vec<u32>) -> VertexTag + Sync,
    {
        const BLOCK: usize = 4096;
        struct Block {
            tags: Vec<VertexTag>,
            edges: Vec<u32>,
            counts: Vec<u32>,
        }
        let nv = self.num_vertices;
        let nfv = self.face_verts.len();
        let mut vert_faces = vec![0u32; nfv];
        let mut vert_face_corner = vec![0u32; nfv];
        // Each block writes its vertices' corners in place; edges are gathered per block.
        let mut jobs = Vec::with_capacity(nv.div_ceil(BLOCK));
        {
            let (mut faces, mut corners) = (&mut vert_faces[..], &mut vert_face_corner[..]);
            for blk in 0..nv.div_ceil(BLOCK) {
                let range = blk * BLOCK..((blk + 1) * BLOCK).min(nv);
                let n = (self.vert_face_offsets[range.end] - self.vert_face_offsets[range.start])
                    as usize;
                let (f, rest) = std::mem::take(&mut faces).split_at_mut(n);
                faces = rest;
                let (c, rest) = std::mem::take(&mut corners).split_at_mut(n);
                corners = rest;
                jobs.push((range, f, c));
            }
        }
        let blocks: Vec<Block> = jobs
            .into_par_iter()
            .with_min_len(crate::threads::min_len())
            .map(|(range, faces, corners)| {
                let mut out = Block {
                    tags: Vec::with_capacity(range.len()),
                    edges: Vec::new(),
                    counts: Vec::with_capacity(range.len()),
                };
                let base = self.vert_face_offsets[range.start] as usize;
                let mut fan = Vec::new();
                let mut edges = Vec::new();
                for v in range {
                    out.tags.push(ring(v, &mut fan, &mut edges));
                    let at = self.vert_face_offsets[v] as usize - base;
                    debug_assert_eq!(
                        fan.len(),
                        (self.vert_face_offsets[v + 1] - self.vert_face_offsets[v]) as usize
                    );
                    for (k, &(f, c)) in fan.iter().enumerate() {
                        faces[at + k] = f;
                        corners[at + k] = c;
                    }
                    out.edges.extend_from_slice(&edges);
                    out.counts.push(edges.len() as u32);
                }
                out
            })
            .collect();
        let mut vert_edges = Vec::with_capacity(blocks.iter().map(|b| b.edges.len()).sum());
        let mut vert_edge_offsets = Vec::with_capacity(nv + 1);
        let mut vert_tags = Vec::with_capacity(nv);
        vert_edge_offsets.push(0);
        for blk in blocks {
            vert_edges.extend_from_slice(&blk.edges);
            for c in blk.counts {
                let last = *vert_edge_offsets.last().unwrap();
                vert_edge_offsets.push(last + c);
            }
            vert_tags.extend(blk.tags);
        }
        Rings {
            vert_faces,
            vert_face_corner,
            vert_edge_offsets,
            vert_edges,
            vert_tags,
        }
    }

    /// Stores the vertex rings of [`Self::rings`].
    pub(crate) fn set_rings(&mut self, rings: Rings) {
        self.vert_faces = rings.vert_faces;
        self.vert_face_corner = rings.vert_face_corner;
        self.vert_edge_offsets = rings.vert_edge_offsets;
        self.vert_edges = rings.vert_edges;
        self.vert_tags = rings.vert_tags;
    }

    /// Orders the face corners around one vertex, given by face and then corner (as
    /// [`Self::from_edges`] lists them); returns its tags and leaves the ordered corners in
    /// `fan` and its edges in `edges`.
    pub(crate) fn order_ring(
        &self,
        corners: &[(u32, u32)],
        fan: &mut Vec<(u32, u32)>,
        edges: &mut Vec<u32>,
    ) -> VertexTag {
        fan.clear();
        edges.clear();
        let mut tag = VertexTag::default();
        if corners.is_empty() {
            return tag;
        }
        let lead = |&(f, c): &(u32, u32)| self.face_edge(f as usize, c as usize);
        let trail = |&(f, c): &(u32, u32)| {
            let n = self.face_size(f as usize);
            self.face_edge(f as usize, (c as usize + n - 1) % n)
        };
        let mut nonman = false;
        for c in corners {
            for e in [lead(c), trail(c)] {
                let nfe = self.edge_face_count(e);
                if self.edge_nonmanifold[e as usize] {
                    nonman = true;
                }
                if nfe == 1 {
                    tag.boundary = true;
                }
            }
        }
        if !nonman {
            // Start at a corner whose leading edge is a boundary edge, if any.
            let start = corners
                .iter()
                .position(|c| self.edge_face_count(lead(c)) == 1)
                .unwrap_or(0);
            let mut cur = corners[start];
            edges.push(lead(&cur));
            loop {
                fan.push(cur);
                let t = trail(&cur);
                edges.push(t);
                if self.edge_face_count(t) == 1 {
                    break; // reached the other boundary
                }
                // The other face of the trailing edge.
                let fs = self.edge_face_list(t);
                let other = if fs[0] == cur.0 { fs[1] } else { fs[0] };
                let Some(next) = corners.iter().find(|c| c.0 == other) else {
                    nonman = true;
                    break;
                };
                if *next == corners[start] {
                    edges.pop(); // closed fan: the trailing edge is the first leading edge
                    break;
                }
                if fan.len() > corners.len() {
                    nonman = true;
                    break;
                }
                cur = *next;
            }
            if !nonman && fan.len() == corners.len() {
                return tag;
            }
        }
        // Non-manifold: keep faces in input order, edges unique.
        tag.nonmanifold = true;
        fan.clear();
        fan.extend_from_slice(corners);
        edges.clear();
        for c in corners {
            for e in [lead(c), trail(c)] {
                if !edges.contains(&e) {
                    edges.push(e);
                }
            }
        }
        tag
    }

    /// Number of faces.
    pub fn num_faces(&self) -> usize {
        self.face_offsets.len() - 1
    }
    /// Number of edges.
    pub fn num_edges(&self) -> usize {
        self.edge_verts.len()
    }
    /// Number of vertices of face `f`.
    pub fn face_size(&self, f: usize) -> usize {
        (self.face_offsets[f + 1] - self.face_offsets[f]) as usize
    }
    /// Vertices of face `f`.
    pub fn face_vertices(&self, f: usize) -> &[u32] {
        &self.face_verts[self.face_offsets[f] as usize..self.face_offsets[f + 1] as usize]
    }
    /// Edges of face `f` (edge `i` from vertex `i` to `i + 1`).
    pub fn face_edge_list(&self, f: usize) -> &[u32] {
        &self.face_edges[self.face_offsets[f] as usize..self.face_offsets[f + 1] as usize]
    }
    /// Edge `i` of face `f`.
    pub fn face_edge(&self, f: usize, i: usize) -> u32 {
        self.face_edges[self.face_offsets[f] as usize + i]
    }
    /// Faces incident to edge `e`.
    pub fn edge_face_list(&self, e: u32) -> &[u32] {
        let e = e as usize;
        &self.edge_faces[self.edge_face_offsets[e] as usize..self.edge_face_offsets[e + 1] as usize]
    }
    /// Number of faces incident to edge `e`.
    pub fn edge_face_count(&self, e: u32) -> usize {
        let e = e as usize;
        (self.edge_face_offsets[e + 1] - self.edge_face_offsets[e]) as usize
    }
    /// Faces around vertex `v`.
    pub fn vertex_faces(&self, v: usize) -> &[u32] {
        &self.vert_faces[self.vert_face_offsets[v] as usize..self.vert_face_offsets[v + 1] as usize]
    }
    /// Corner index of `v` in each of [`Self::vertex_faces`].
    pub fn vertex_face_corners(&self, v: usize) -> &[u32] {
        &self.vert_face_corner
            [self.vert_face_offsets[v] as usize..self.vert_face_offsets[v + 1] as usize]
    }
    /// Edges around vertex `v`.
    pub fn vertex_edges(&self, v: usize) -> &[u32] {
        &self.vert_edges[self.vert_edge_offsets[v] as usize..self.vert_edge_offsets[v + 1] as usize]
    }
    /// The end of edge `e` that is not `v`.
    pub fn other_vertex(&self, e: u32, v: u32) -> u32 {
        let [a, b] = self.edge_verts[e as usize];
        if a == v {
            b
        } else {
            a
        }
    }
    /// The edge joining `a` and `b`, if any.
    pub fn find_edge(&self, a: u32, b: u32) -> Option<u32> {
        if a as usize >= self.num_vertices {
            return None;
        }
        self.vertex_edges(a as usize)
            .iter()
            .copied()
            .find(|&e| self.other_vertex(e, a) == b)
    }
    /// True if the edge has exactly one face.
    pub fn edge_is_boundary(&self, e: u32) -> bool {
        self.edge_face_count(e) == 1
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn grid(n: u32) -> (Vec<u32>, Vec<u32>) {
        let mut off = vec![0];
        let mut fv = vec![];
        for i in 0..n {
            for j in 0..n {
                let a = i * (n + 1) + j;
                fv.extend_from_slice(&[a, a + n + 1, a + n + 2, a + 1]);
                off.push(fv.len() as u32);
            }
        }
        (off, fv)
    }

    #[test]
    fn grid_rings_are_ordered() {
        let (off, fv) = grid(2);
        let t = Topology::new(9, &off, &fv).unwrap();
        assert_eq!(t.num_edges(), 12);
        // centre vertex 4: interior, 4 faces, 4 edges, ring ordered so that trailing edge of
        // face i is the leading edge of face i+1.
        assert!(!t.vert_tags[4].boundary);
        let faces = t.vertex_faces(4);
        let edges = t.vertex_edges(4);
        assert_eq!(faces.len(), 4);
        assert_eq!(edges.len(), 4);
        for i in 0..4 {
            let f = faces[i] as usize;
            let c = t.vertex_face_corners(4)[i] as usize;
            assert_eq!(t.face_edge(f, c), edges[i]);
            assert_eq!(t.face_edge(f, (c + 3) % 4), edges[(i + 1) % 4]);
        }
        // corner vertex 0: one face, two edges, boundary
        assert!(t.vert_tags[0].boundary);
        assert_eq!(t.vertex_edges(0).len(), 2);
        // boundary edge vertex 1: 2 faces, 3 edges, first leading edge is boundary
        let e1 = t.vertex_edges(1);
        assert_eq!(e1.len(), 3);
        assert!(t.edge_is_boundary(e1[0]) && t.edge_is_boundary(e1[2]));
        assert!(!t.edge_is_boundary(e1[1]));
    }

    #[test]
    fn bowtie_and_nonmanifold_edges_are_tagged() {
        // two triangles sharing only vertex 0
        let t = Topology::new(5, &[0, 3, 6], &[0, 1, 2, 0, 3, 4]).unwrap();
        assert!(t.vert_tags[0].nonmanifold);
        assert!(!t.vert_tags[1].nonmanifold);
        // three quads on one edge
        let t = Topology::new(8, &[0, 4, 8, 12], &[0, 1, 2, 3, 1, 0, 4, 5, 0, 1, 6, 7]).unwrap();
        let e = t.find_edge(0, 1).unwrap();
        assert!(t.edge_nonmanifold[e as usize]);
        assert!(t.vert_tags[0].nonmanifold);
        // inconsistent winding
        let t = Topology::new(6, &[0, 4, 8], &[0, 1, 2, 3, 0, 1, 4, 5]).unwrap();
        assert!(t.edge_nonmanifold[t.find_edge(0, 1).unwrap() as usize]);
    }

    /// Edges of random meshes (faces of 3–6 vertices from a small pool, so pairs repeat,
    /// faces repeat vertices, and edges are shared by one to many faces): each face-edge's edge
    /// joins its two vertices; edges are numbered in the order of their unordered pair; a pair
    /// that no face uses twice and that is not degenerate is one edge, manifold only with one
    /// use or two uses in opposite directions; degenerate pairs and a pair used twice by one
    /// face are non-manifold.
    #[test]
    fn edges_are_numbered_by_pair_and_shared() {
        let mut rng = crate::harness::rng::SplitMix64(17);
        for case in 0..300 {
            let pool = 4 + rng.below(12) as u32;
            let mut off = vec![0u32];
            let mut fv = Vec::new();
            for _ in 0..1 + rng.below(12) {
                for _ in 0..3 + rng.below(4) {
                    fv.push(rng.below(pool as usize) as u32);
                }
                off.push(fv.len() as u32);
            }
            let t = Topology::new(pool as usize, &off, &fv).unwrap();
            let pair = |e: u32| {
                let [a, b] = t.edge_verts[e as usize];
                (a.min(b), a.max(b))
            };
            // Per unordered pair: each use's face, edge, and direction (from the lower vertex).
            type Uses = Vec<(usize, u32, bool)>;
            let mut uses: std::collections::BTreeMap<(u32, u32), Uses> = Default::default();
            for f in 0..t.num_faces() {
                let vs = t.face_vertices(f);
                for (i, &e) in t.face_edge_list(f).iter().enumerate() {
                    let (a, b) = (vs[i], vs[(i + 1) % vs.len()]);
                    assert_eq!(pair(e), (a.min(b), a.max(b)), "case {case}");
                    uses.entry(pair(e)).or_default().push((f, e, a < b));
                }
            }
            for e in 1..t.num_edges() as u32 {
                assert!(pair(e - 1) <= pair(e), "case {case}: edges by pair");
            }
            for ((a, b), used) in &uses {
                let mut faces: Vec<usize> = used.iter().map(|u| u.0).collect();
                faces.dedup();
                let edges: std::collections::BTreeSet<u32> = used.iter().map(|u| u.1).collect();
                if a == b || faces.len() < used.len() {
                    assert!(
                        edges.iter().all(|&e| t.edge_nonmanifold[e as usize]),
                        "case {case}: ({a}, {b})"
                    );
                } else {
                    assert_eq!(edges.len(), 1, "case {case}: ({a}, {b}) is one edge");
                    let e = used[0].1 as usize;
                    let manifold = used.len() == 1 || (used.len() == 2 && used[0].2 != used[1].2);
                    assert_eq!(t.edge_nonmanifold[e], !manifold, "case {case}: ({a}, {b})");
                }
            }
        }
    }
}
