//! The control mesh: positions, faces, RenderMan tags and subdivision options, as read from an
//! OBJ file ([`obj`]) or built in code ([`MeshBuilder`]), and its validated topology ([`topology`]).

mod builder;
pub mod edit;
pub mod generate;
pub mod obj;
pub mod shapes;
pub mod topology;

pub use builder::MeshBuilder;
pub use edit::{EditKind, EditOp, HierarchicalEdit};
pub use topology::Topology;

use crate::error::{Error, ErrorKind, Result};

/// Sharpness at or above which an edge or vertex is infinitely sharp (RenderMan, OpenSubdiv).
pub const SHARPNESS_INFINITE: f32 = 10.0;

/// How boundary edges and corners are interpolated (OpenSubdiv's `VtxBoundaryInterpolation`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum BoundaryInterpolation {
    /// No boundary interpolation: faces on the boundary are not part of the limit surface.
    None,
    /// Boundary edges are infinitely sharp creases; corners of one face stay smooth.
    EdgeOnly,
    /// Boundary edges are infinitely sharp and vertices of one face are infinitely sharp corners.
    #[default]
    EdgeAndCorner,
}

/// How semi-sharp crease sharpness decreases from level to level.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum CreaseMethod {
    /// RenderMan's "normal" rule: every level subtracts one.
    #[default]
    Uniform,
    /// Chaikin's rule: child edges average their sharpness with adjacent creases first.
    Chaikin,
}

/// The subdivision scheme (OpenSubdiv's `Sdc::SchemeType`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Scheme {
    /// Catmull-Clark: any polygons, quads after one step (paper 001).
    #[default]
    Catmark,
    /// Loop: triangles only, each split into four (paper 002). A mesh with other faces is an
    /// error, as in OpenSubdiv.
    Loop,
}

impl Scheme {
    /// The scheme's name on the command line and in scenes (`catmark`, `loop`).
    pub fn name(self) -> &'static str {
        match self {
            Scheme::Catmark => "catmark",
            Scheme::Loop => "loop",
        }
    }
}

/// OpenSubdiv's face-varying linear interpolation (`Sdc::Options::FVarLinearInterpolation`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum FVarMode {
    /// Smooth everywhere; seams use the crease rule even at corners.
    None,
    /// Corners of the value topology (a value of one face) are sharp.
    CornersOnly,
    /// Corners and junctions of three or more values are sharp (USD's default).
    #[default]
    CornersPlus1,
    /// As `CornersPlus1`, and darts (a seam ending inside) and concave corners too.
    CornersPlus2,
    /// Every value on a seam or boundary is linear.
    Boundaries,
    /// Bilinear everywhere.
    All,
}

impl FVarMode {
    /// Every mode with its name on the command line.
    pub const NAMES: [(FVarMode, &'static str); 6] = [
        (FVarMode::None, "none"),
        (FVarMode::CornersOnly, "corners-only"),
        (FVarMode::CornersPlus1, "corners-plus1"),
        (FVarMode::CornersPlus2, "corners-plus2"),
        (FVarMode::Boundaries, "boundaries"),
        (FVarMode::All, "all"),
    ];

    /// The mode's name on the command line and in scenes.
    pub fn name(self) -> &'static str {
        Self::NAMES
            .iter()
            .find(|(m, _)| *m == self)
            .map(|(_, n)| *n)
            .unwrap_or("corners-plus1")
    }

    /// The mode named `name` (`none`, `corners-only`, …).
    pub fn from_name(name: &str) -> Option<FVarMode> {
        Self::NAMES
            .iter()
            .find(|(_, n)| *n == name)
            .map(|(m, _)| *m)
    }
}

/// Subdivision options that apply to a whole mesh.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Options {
    /// Subdivision scheme; Catmull-Clark unless the caller says otherwise (an OBJ file does not
    /// name its scheme).
    pub scheme: Scheme,
    /// Boundary interpolation; edge-and-corner unless a tag or the caller says otherwise.
    pub boundary: BoundaryInterpolation,
    /// Crease sharpness rule; uniform unless a tag or the caller says otherwise.
    pub crease_method: CreaseMethod,
    /// OpenSubdiv's `TRI_SUB_SMOOTH` (tag `t smoothtriangles 0/0/1 smooth`): edge points of
    /// edges next to triangles of the control mesh give the triangles' face points more
    /// weight (0.47 instead of 0.25), which rounds triangles out like Loop's scheme would.
    /// Off by default (`TRI_SUB_CATMARK`, the plain Catmull-Clark rule).
    pub smooth_triangles: bool,
    /// Face-varying linear interpolation of the texture coordinates (`--fvar`, scene key
    /// `fvar`); corners-plus1 (USD's default) unless the caller says otherwise. OpenSubdiv's
    /// own `Sdc::Options` default is `FVAR_LINEAR_ALL` ([`FVarMode::All`]).
    pub fvar: FVarMode,
}

/// A semi-sharp (or infinitely sharp) edge between two control vertices.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EdgeCrease {
    /// First end (0-based vertex index).
    pub v0: u32,
    /// Second end (0-based vertex index).
    pub v1: u32,
    /// Sharpness; `>= SHARPNESS_INFINITE` is infinitely sharp.
    pub sharpness: f32,
}

/// A semi-sharp (or infinitely sharp) corner vertex.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct VertexCorner {
    /// The vertex (0-based).
    pub vertex: u32,
    /// Sharpness; `>= SHARPNESS_INFINITE` is infinitely sharp.
    pub sharpness: f32,
}

/// Where each element of a mesh came from, so that errors found after parsing can still name
/// the file and line. Empty vectors mean "unknown" (a mesh built in code).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Provenance {
    /// Source file name.
    pub file: Option<String>,
    /// 1-based line of each vertex.
    pub vertex_lines: Vec<u32>,
    /// 1-based line of each face.
    pub face_lines: Vec<u32>,
    /// 1-based line of each entry of `creases`.
    pub crease_lines: Vec<u32>,
    /// 1-based line of each entry of `corners`.
    pub corner_lines: Vec<u32>,
    /// 1-based line of each entry of `holes`.
    pub hole_lines: Vec<u32>,
    /// 1-based line of each entry of `edits`.
    pub edit_lines: Vec<u32>,
}

/// A control mesh with its tags. Faces have any number (≥ 3) of vertices, counter-clockwise.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ControlMesh {
    /// Vertex positions.
    pub positions: Vec<[f64; 3]>,
    /// `face_offsets[f]..face_offsets[f+1]` indexes `face_verts` for face `f`; length faces + 1.
    pub face_offsets: Vec<u32>,
    /// Vertex indices of all faces, concatenated.
    pub face_verts: Vec<u32>,
    /// Texture coordinates (`vt`), kept for face-varying use.
    pub uvs: Vec<[f64; 2]>,
    /// Per face-vertex index into `uvs`, parallel to `face_verts`; empty when the mesh has none.
    pub face_uvs: Vec<u32>,
    /// Sharp edges.
    pub creases: Vec<EdgeCrease>,
    /// Sharp vertices.
    pub corners: Vec<VertexCorner>,
    /// Faces that are holes (not part of the surface).
    pub holes: Vec<u32>,
    /// Hierarchical edits, in the order they apply ([`edit`]).
    pub edits: Vec<HierarchicalEdit>,
    /// Boundary and crease options.
    pub options: Options,
    /// Where elements came from, for error messages.
    pub provenance: Provenance,
    /// Non-fatal remarks from reading (unknown tags, unsupported features that were ignored).
    pub warnings: Vec<String>,
}

impl ControlMesh {
    /// Number of faces.
    pub fn num_faces(&self) -> usize {
        self.face_offsets.len().saturating_sub(1)
    }

    /// Number of vertices of face `f`.
    pub fn face_size(&self, f: usize) -> usize {
        (self.face_offsets[f + 1] - self.face_offsets[f]) as usize
    }

    /// Number of vertices.
    pub fn num_vertices(&self) -> usize {
        self.positions.len()
    }

    /// The vertex indices of face `f`.
    pub fn face(&self, f: usize) -> &[u32] {
        &self.face_verts[self.face_offsets[f] as usize..self.face_offsets[f + 1] as usize]
    }

    /// Axis-aligned bounding box of the positions (`[min, max]`); zeros for an empty mesh.
    pub fn bounds(&self) -> [[f64; 3]; 2] {
        bounds_of(&self.positions)
    }

    /// Length of the bounding-box diagonal.
    pub fn diagonal(&self) -> f64 {
        let [lo, hi] = self.bounds();
        ((hi[0] - lo[0]).powi(2) + (hi[1] - lo[1]).powi(2) + (hi[2] - lo[2]).powi(2)).sqrt()
    }

    /// Builds an error located at an element of this mesh: file and line come from the
    /// provenance when known.
    pub fn error_at(&self, kind: ErrorKind, element: Element, message: impl Into<String>) -> Error {
        let p = &self.provenance;
        let (line, name) = match element {
            Element::Vertex(i) => (p.vertex_lines.get(i).copied(), format!("vertex {}", i)),
            Element::Face(i) => (p.face_lines.get(i).copied(), format!("face {}", i + 1)),
            Element::Crease(i) => (p.crease_lines.get(i).copied(), "tag crease".to_string()),
            Element::Corner(i) => (p.corner_lines.get(i).copied(), "tag corner".to_string()),
            Element::Hole(i) => (p.hole_lines.get(i).copied(), "tag hole".to_string()),
            Element::Edit(i) => (
                p.edit_lines.get(i).copied(),
                format!("hierarchical edit {}", i + 1),
            ),
        };
        let mut e = Error::new(kind, message).element(name);
        if let Some(file) = &p.file {
            e = e.in_file(file.clone());
        }
        if let Some(l) = line {
            e = e.at_line(l as usize);
        }
        e
    }

    /// Checks everything that does not need edge topology: face sizes, index ranges,
    /// coordinates (finite and within [`crate::numeric::MAX_COORD`]), tag
    /// indices and sharpness values.
    /// Topology-level checks (non-manifold configurations) are made by [`Topology::new`].
    pub fn validate(&self) -> Result<()> {
        let nv = self.positions.len();
        for (i, p) in self.positions.iter().enumerate() {
            if !p.iter().all(|c| c.is_finite()) {
                return Err(self.error_at(
                    ErrorKind::Topology,
                    Element::Vertex(i),
                    format!("coordinate is not finite: {} {} {}", p[0], p[1], p[2]),
                ));
            }
            if !crate::numeric::in_range(*p) {
                return Err(self.error_at(
                    ErrorKind::Topology,
                    Element::Vertex(i),
                    format!(
                        "coordinate {:e} {:e} {:e} is out of range ({})",
                        p[0],
                        p[1],
                        p[2],
                        crate::numeric::contract()
                    ),
                ));
            }
        }
        if self.face_offsets.is_empty() || self.face_offsets[0] != 0 {
            return Err(Error::new(
                ErrorKind::Topology,
                "face offsets must start at 0",
            ));
        }
        if *self.face_offsets.last().unwrap() as usize != self.face_verts.len() {
            return Err(Error::new(
                ErrorKind::Topology,
                "face offsets do not cover the face-vertex list",
            ));
        }
        if !self.face_uvs.is_empty() && self.face_uvs.len() != self.face_verts.len() {
            return Err(Error::new(
                ErrorKind::Topology,
                "face texture indices must be given for every face-vertex or none",
            ));
        }
        for f in 0..self.num_faces() {
            if self.face_offsets[f + 1] < self.face_offsets[f] {
                return Err(Error::new(ErrorKind::Topology, "face offsets decrease"));
            }
            let fv = self.face(f);
            if fv.len() < 3 {
                return Err(self.error_at(
                    ErrorKind::Topology,
                    Element::Face(f),
                    format!("face has {} vertices; at least 3 are needed", fv.len()),
                ));
            }
            for &v in fv {
                if v as usize >= nv {
                    return Err(self.error_at(
                        ErrorKind::Topology,
                        Element::Face(f),
                        format!(
                            "vertex index {} is out of range (mesh has {} vertices)",
                            v + 1,
                            nv
                        ),
                    ));
                }
            }
        }
        let nu = self.uvs.len();
        if let Some(&bad) = self.face_uvs.iter().find(|&&t| t as usize >= nu) {
            let pos = self.face_uvs.iter().position(|&t| t == bad).unwrap();
            let f = self.face_offsets.partition_point(|&o| o as usize <= pos) - 1;
            return Err(self.error_at(
                ErrorKind::Topology,
                Element::Face(f),
                format!("texture index {} is out of range ({} vt)", bad + 1, nu),
            ));
        }
        let check_sharpness = |s: f32| s.is_finite() && s >= 0.0 || s == f32::INFINITY;
        for (i, c) in self.creases.iter().enumerate() {
            if c.v0 as usize >= nv || c.v1 as usize >= nv {
                return Err(self.error_at(
                    ErrorKind::Topology,
                    Element::Crease(i),
                    format!(
                        "crease vertex {} or {} is out of range (0-based, mesh has {nv} vertices)",
                        c.v0, c.v1
                    ),
                ));
            }
            if c.v0 == c.v1 {
                return Err(self.error_at(
                    ErrorKind::Topology,
                    Element::Crease(i),
                    format!("crease joins vertex {} to itself", c.v0),
                ));
            }
            if !check_sharpness(c.sharpness) {
                return Err(self.error_at(
                    ErrorKind::Topology,
                    Element::Crease(i),
                    format!("sharpness {} is invalid (must be ≥ 0)", c.sharpness),
                ));
            }
        }
        for (i, c) in self.corners.iter().enumerate() {
            if c.vertex as usize >= nv {
                return Err(self.error_at(
                    ErrorKind::Topology,
                    Element::Corner(i),
                    format!(
                        "corner vertex {} is out of range (0-based, mesh has {nv} vertices)",
                        c.vertex
                    ),
                ));
            }
            if !check_sharpness(c.sharpness) {
                return Err(self.error_at(
                    ErrorKind::Topology,
                    Element::Corner(i),
                    format!("sharpness {} is invalid (must be ≥ 0)", c.sharpness),
                ));
            }
        }
        for (i, &h) in self.holes.iter().enumerate() {
            if h as usize >= self.num_faces() {
                return Err(self.error_at(
                    ErrorKind::Topology,
                    Element::Hole(i),
                    format!(
                        "hole face {h} is out of range (0-based, mesh has {} faces)",
                        self.num_faces()
                    ),
                ));
            }
        }
        for i in 0..self.edits.len() {
            self.validate_edit(i)?;
        }
        Ok(())
    }

    /// Checks edit `i`'s path against the faces it walks (Catmull-Clark children: a face of
    /// `n` corners has `n` sub-faces, every sub-face is a quad) and its values.
    fn validate_edit(&self, i: usize) -> Result<()> {
        let e = &self.edits[i];
        let bad = |m: String| Err(self.error_at(ErrorKind::Topology, Element::Edit(i), m));
        if e.face as usize >= self.num_faces() {
            return bad(format!(
                "face {} is out of range (0-based, mesh has {} faces)",
                e.face,
                self.num_faces()
            ));
        }
        if e.path.len() > crate::refine::MAX_LEVEL {
            return bad(format!(
                "path of {} sub-faces is deeper than the maximum level {}",
                e.path.len(),
                crate::refine::MAX_LEVEL
            ));
        }
        let mut size = self.face_size(e.face as usize);
        for (depth, &k) in e.path.iter().enumerate() {
            if k as usize >= size {
                return bad(format!(
                    "sub-face {k} at depth {} does not exist (the face there has {size} corners)",
                    depth + 1
                ));
            }
            size = 4;
        }
        if let Some(x) = e.element() {
            if x as usize >= size {
                let what = if matches!(e.kind, EditKind::EdgeSharpness { .. }) {
                    "edge"
                } else {
                    "corner"
                };
                return bad(format!("{what} {x} does not exist (the face has {size})"));
            }
        }
        let finite = match e.kind {
            EditKind::Position { value, .. } => value
                .iter()
                .all(|x| x.is_finite() && x.abs() <= crate::numeric::MAX_COORD),
            EditKind::VertexSharpness { value, .. } | EditKind::EdgeSharpness { value, .. } => {
                !value.is_nan()
            }
            EditKind::Hole => true,
        };
        if !finite {
            return bad("value is not finite or out of range".to_string());
        }
        Ok(())
    }
}

/// An element of a control mesh, for error messages.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Element {
    /// Vertex (0-based).
    Vertex(usize),
    /// Face (0-based; printed 1-based like OBJ).
    Face(usize),
    /// Entry of `creases`.
    Crease(usize),
    /// Entry of `corners`.
    Corner(usize),
    /// Entry of `holes`.
    Hole(usize),
    /// Entry of `edits`.
    Edit(usize),
}

/// Axis-aligned bounds of a point set; zeros when empty.
pub fn bounds_of(points: &[[f64; 3]]) -> [[f64; 3]; 2] {
    if points.is_empty() {
        return [[0.0; 3]; 2];
    }
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    for p in points {
        for k in 0..3 {
            lo[k] = lo[k].min(p[k]);
            hi[k] = hi[k].max(p[k]);
        }
    }
    [lo, hi]
}
