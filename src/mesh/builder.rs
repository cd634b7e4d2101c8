//! Building a control mesh in code.

use super::{ControlMesh, EdgeCrease, Options, VertexCorner};
use crate::error::Result;

/// Builds a [`ControlMesh`] from arrays, for library users who do not read OBJ files.
///
/// ```
/// use limitray::mesh::MeshBuilder;
/// let mesh = MeshBuilder::new()
///     .positions(vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 1.0, 0.0], [0.0, 1.0, 0.0]])
///     .faces(&[4], &[0, 1, 2, 3])
///     .crease(0, 1, 2.5)
///     .build()
///     .unwrap();
/// assert_eq!(mesh.num_faces(), 1);
/// ```
#[derive(Clone, Debug, Default)]
pub struct MeshBuilder {
    mesh: ControlMesh,
}

impl MeshBuilder {
    /// An empty builder with default options (edge-and-corner boundaries, uniform creases).
    pub fn new() -> Self {
        let mut b = Self::default();
        b.mesh.face_offsets = vec![0];
        b
    }

    /// Sets the vertex positions.
    pub fn positions(mut self, positions: Vec<[f64; 3]>) -> Self {
        self.mesh.positions = positions;
        self
    }

    /// Appends faces given by their sizes and concatenated 0-based vertex indices.
    pub fn faces(mut self, sizes: &[usize], indices: &[u32]) -> Self {
        let mut at = *self.mesh.face_offsets.last().unwrap_or(&0) as usize;
        for &n in sizes {
            at += n;
            self.mesh.face_offsets.push(at as u32);
        }
        self.mesh.face_verts.extend_from_slice(indices);
        self
    }

    /// Adds a sharp edge between vertices `a` and `b` (0-based).
    pub fn crease(mut self, a: u32, b: u32, sharpness: f32) -> Self {
        self.mesh.creases.push(EdgeCrease {
            v0: a,
            v1: b,
            sharpness,
        });
        self
    }

    /// Adds a sharp vertex (0-based).
    pub fn corner(mut self, vertex: u32, sharpness: f32) -> Self {
        self.mesh.corners.push(VertexCorner { vertex, sharpness });
        self
    }

    /// Marks a face (0-based) as a hole.
    pub fn hole(mut self, face: u32) -> Self {
        self.mesh.holes.push(face);
        self
    }

    /// Sets the subdivision options.
    pub fn options(mut self, options: Options) -> Self {
        self.mesh.options = options;
        self
    }

    /// Validates and returns the mesh.
    pub fn build(self) -> Result<ControlMesh> {
        self.mesh.validate()?;
        Ok(self.mesh)
    }
}
