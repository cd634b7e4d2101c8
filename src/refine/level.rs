//! One level of a subdivided mesh: topology plus the sharpness of every edge and vertex and
//! the hole flag of every face. Level 0 comes from the control mesh and its tags.

use super::crease::{self, Rule};
use crate::error::{ErrorKind, Result};
use crate::mesh::{
    BoundaryInterpolation, ControlMesh, Element, Options, Scheme, Topology, SHARPNESS_INFINITE,
};

/// Topology and tags of one refinement level.
#[derive(Clone, Debug)]
pub struct Level {
    /// Adjacency.
    pub topo: Topology,
    /// Sharpness per edge (boundary and non-manifold edges are infinitely sharp).
    pub edge_sharpness: Vec<f32>,
    /// Sharpness per vertex (corners of one face are infinitely sharp with edge-and-corner
    /// boundaries; non-manifold vertices are infinitely sharp unless on a non-manifold crease).
    pub vertex_sharpness: Vec<f32>,
    /// Faces that are not part of the surface (hole tags; boundary faces when boundary
    /// interpolation is `None`).
    pub face_hole: Vec<bool>,
    /// The smooth-triangle edge rule applies ([`crate::mesh::Options::smooth_triangles`]);
    /// it only changes anything where triangles are, i.e. at level 0.
    pub smooth_triangles: bool,
    /// The scheme that refines this level.
    pub scheme: Scheme,
}

impl Level {
    /// Level 0 of `mesh` under `options`. Crease tags on edges that do not exist are ignored
    /// with a warning, as OpenSubdiv does; the warnings are returned. Under the Loop scheme a
    /// face that is not a triangle is an error naming it (OpenSubdiv refuses such meshes too).
    pub fn base(mesh: &ControlMesh, options: &Options) -> Result<(Level, Vec<String>)> {
        mesh.validate()?;
        super::edit::check_scheme(mesh, options.scheme)?;
        if options.scheme == Scheme::Loop {
            if let Some(f) = (0..mesh.num_faces()).find(|&f| mesh.face_size(f) != 3) {
                return Err(mesh.error_at(
                    ErrorKind::Topology,
                    Element::Face(f),
                    format!(
                        "the Loop scheme needs triangles and this face has {} vertices",
                        mesh.face_size(f)
                    ),
                ));
            }
        }
        let topo = Topology::new(mesh.num_vertices(), &mesh.face_offsets, &mesh.face_verts)
            .map_err(|e| {
                let mut e = e;
                if let Some(f) = &mesh.provenance.file {
                    e = e.in_file(f.clone());
                }
                e
            })?;
        let mut warnings = Vec::new();
        let ne = topo.num_edges();
        let nv = topo.num_vertices;
        let mut edge_sharpness = vec![0.0f32; ne];
        for (i, c) in mesh.creases.iter().enumerate() {
            match topo.find_edge(c.v0, c.v1) {
                Some(e) => edge_sharpness[e as usize] = crease::canonical(c.sharpness),
                None => warnings.push(
                    mesh.error_at(
                        ErrorKind::Topology,
                        Element::Crease(i),
                        format!(
                            "no edge joins vertices {} and {}; crease ignored",
                            c.v0, c.v1
                        ),
                    )
                    .to_string(),
                ),
            }
        }
        // Boundary edges the tags made infinitely sharp: with boundary interpolation `None`
        // only these keep their faces (OpenSubdiv's semantics, checked on catmark_edgenone).
        let tagged_sharp_boundary: Vec<bool> = (0..ne)
            .map(|e| topo.edge_is_boundary(e as u32) && crease::is_infinite(edge_sharpness[e]))
            .collect();
        for e in 0..ne {
            if topo.edge_face_count(e as u32) != 2 || topo.edge_nonmanifold[e] {
                edge_sharpness[e] = SHARPNESS_INFINITE;
            }
        }
        let mut vertex_sharpness = vec![0.0f32; nv];
        for c in &mesh.corners {
            vertex_sharpness[c.vertex as usize] = crease::canonical(c.sharpness);
        }
        for v in 0..nv {
            let tag = topo.vert_tags[v];
            let faces = topo.vertex_faces(v).len();
            let edges = topo.vertex_edges(v);
            if tag.nonmanifold {
                // OpenSubdiv sharpens every non-manifold vertex except one inside an interior
                // non-manifold crease: two non-manifold edges, no edge with fewer than two
                // faces, and more faces than edges (a fin adds a face, not an edge). A
                // degenerate edge counts twice (both its ends are here).
                let (mut nonman_edges, mut boundary_edges, mut edge_count) = (0, 0, 0);
                for &e in edges {
                    let [a, b] = topo.edge_verts[e as usize];
                    let uses = if a == b { 2 } else { 1 };
                    edge_count += uses;
                    if topo.edge_nonmanifold[e as usize] {
                        nonman_edges += uses;
                    }
                    if topo.edge_face_count(e) < 2 {
                        boundary_edges += uses;
                    }
                }
                let on_nonmanifold_crease =
                    nonman_edges == 2 && boundary_edges == 0 && faces > edge_count;
                if !on_nonmanifold_crease {
                    vertex_sharpness[v] = SHARPNESS_INFINITE;
                }
            } else if faces == 1
                && edges.len() == 2
                && options.boundary == BoundaryInterpolation::EdgeAndCorner
            {
                vertex_sharpness[v] = SHARPNESS_INFINITE;
            }
        }
        let mut face_hole = vec![false; topo.num_faces()];
        for &h in &mesh.holes {
            face_hole[h as usize] = true;
        }
        if options.boundary == BoundaryInterpolation::None {
            // A face is a hole when one of its vertices has a boundary edge that is not
            // infinitely sharp by tag.
            let open: Vec<bool> = (0..nv)
                .map(|v| {
                    topo.vertex_edges(v)
                        .iter()
                        .any(|&e| topo.edge_is_boundary(e) && !tagged_sharp_boundary[e as usize])
                })
                .collect();
            for (f, hole) in face_hole.iter_mut().enumerate() {
                if topo.face_vertices(f).iter().any(|&v| open[v as usize]) {
                    *hole = true;
                }
            }
        }
        Ok((
            Level {
                topo,
                edge_sharpness,
                vertex_sharpness,
                face_hole,
                smooth_triangles: options.smooth_triangles,
                scheme: options.scheme,
            },
            warnings,
        ))
    }

    /// Number of vertices.
    pub fn num_vertices(&self) -> usize {
        self.topo.num_vertices
    }

    /// Number of faces.
    pub fn num_faces(&self) -> usize {
        self.topo.num_faces()
    }

    /// Sharpness of the edges around `v`, in ring order, into `out`.
    pub fn incident_sharpness(&self, v: usize, out: &mut Vec<f32>) {
        out.clear();
        out.extend(
            self.topo
                .vertex_edges(v)
                .iter()
                .map(|&e| self.edge_sharpness[e as usize]),
        );
    }

    /// The rule of vertex `v` at this level.
    pub fn vertex_rule(&self, v: usize) -> Rule {
        let sharp = self
            .topo
            .vertex_edges(v)
            .iter()
            .filter(|&&e| crease::is_sharp(self.edge_sharpness[e as usize]))
            .count();
        crease::vertex_rule(self.vertex_sharpness[v], sharp)
    }

    /// True if any edge or vertex still has semi-sharp (finite, non-zero) sharpness.
    pub fn has_semi_sharp(&self) -> bool {
        self.edge_sharpness
            .iter()
            .any(|&s| crease::is_semi_sharp(s))
            || self
                .vertex_sharpness
                .iter()
                .any(|&s| crease::is_semi_sharp(s))
    }
}
