//! Paper 002's approximations of the Loop limit surface — PN triangles, Walton–Meek and
//! Gregory triangles — as alternative surfaces of a Loop mesh: one patch per triangle, built
//! from the exact limit surface's positions, normals, tangents and cross tangents
//! ([`construct`]) and evaluated as a triangular Gregory patch ([`gregory_tri`]). For
//! Catmull-Clark meshes, paper 004's Gregory-patch approximation ([`QuadApprox`]): one bicubic
//! Gregory patch ([`gregory_quad`]) per quad after one level of subdivision
//! ([`construct_quad`]).
//!
//! ```
//! use limitray::mesh::{shapes, Options, Scheme};
//! use limitray::patch::approx::{Approximation, TriApprox};
//! use limitray::patch::LoopSurface;
//! use limitray::FaceCoord;
//!
//! let mesh = shapes::blob();
//! let exact = LoopSurface::new(&mesh, Options { scheme: Scheme::Loop, ..mesh.options })?;
//! let pn = TriApprox::new(&exact, Approximation::Pn)?;
//! // Corners interpolate the exact limit positions.
//! let (a, b) = (pn.eval(FaceCoord::new(0, 0, 0.0, 0.0))?, exact.eval(FaceCoord::new(0, 0, 0.0, 0.0))?);
//! assert!((0..3).all(|i| (a.p[i] - b.p[i]).abs() < 1e-12));
//! # Ok::<(), limitray::Error>(())
//! ```

pub mod construct;
pub mod construct_quad;
pub mod gregory_quad;
pub mod gregory_tri;

pub use construct_quad::QuadFrame;
pub use gregory_quad::GregoryQuad;
pub use gregory_tri::GregoryTri;

use crate::coord::FaceCoord;
use crate::error::{Error, ErrorKind, Result};
use crate::mesh::{ControlMesh, Options};
use crate::patch::loop_surface::{check_triangle_coord, eval_sub_quad};
use crate::patch::{LoopSurface, PatchTable, Sample};

/// Which surface a mesh stands for: the exact limit surface or one of the approximations.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum Approximation {
    /// The exact limit surface.
    #[default]
    Exact,
    /// PN triangles (Vlachos et al. 2001) from the limit positions and normals: cubic, `C⁰`.
    Pn,
    /// Walton–Meek: `G¹` Gregory triangles from the PN boundary curves and normals alone.
    Wm,
    /// Paper 002's Gregory triangles (`G¹`, from limit tangents and cross tangents) on a
    /// Loop mesh; paper 004's Gregory patches (Loop, Schaefer, Ni, Castaño) on a
    /// Catmull-Clark mesh.
    Gregory,
}

impl Approximation {
    /// All four, in the order of the command line's list.
    pub const ALL: [Approximation; 4] = [
        Approximation::Exact,
        Approximation::Pn,
        Approximation::Wm,
        Approximation::Gregory,
    ];

    /// The name used on the command line, in scenes and in JSON (`exact`, `pn`, `wm`,
    /// `gregory`).
    pub fn name(self) -> &'static str {
        match self {
            Approximation::Exact => "exact",
            Approximation::Pn => "pn",
            Approximation::Wm => "wm",
            Approximation::Gregory => "gregory",
        }
    }
}

impl std::fmt::Display for Approximation {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

impl std::str::FromStr for Approximation {
    type Err = Error;
    fn from_str(s: &str) -> Result<Self> {
        Approximation::ALL
            .into_iter()
            .find(|a| a.name() == s)
            .ok_or_else(|| {
                Error::new(
                    ErrorKind::Usage,
                    format!("unknown surface `{s}` (expected exact, pn, wm or gregory)"),
                )
            })
    }
}

/// An approximate surface of a Loop mesh: one triangular Gregory patch per face.
#[derive(Clone, Debug)]
pub struct TriApprox {
    kind: Approximation,
    patches: Vec<Option<GregoryTri>>,
}

impl TriApprox {
    /// The approximation `kind` of `exact` (an error for [`Approximation::Exact`]).
    pub fn new(exact: &LoopSurface, kind: Approximation) -> Result<Self> {
        if kind == Approximation::Exact {
            return Err(Error::new(
                ErrorKind::Usage,
                "the exact surface is the LoopSurface itself, not an approximation",
            ));
        }
        Ok(TriApprox {
            kind,
            patches: construct::build(exact, kind)?,
        })
    }

    /// Which approximation this is.
    pub fn kind(&self) -> Approximation {
        self.kind
    }

    /// Number of faces.
    pub fn num_faces(&self) -> usize {
        self.patches.len()
    }

    /// Face `f`'s patch (`None` for a hole).
    pub fn patch(&self, f: usize) -> Option<&GregoryTri> {
        self.patches.get(f).and_then(|p| p.as_ref())
    }

    /// Bytes held: 15 points per face.
    pub fn bytes(&self) -> usize {
        self.patches.len() * std::mem::size_of::<Option<GregoryTri>>()
    }

    /// Position and derivatives at `(face, 0, u, v)` in OpenSubdiv's triangle parameter.
    pub fn eval(&self, at: FaceCoord) -> Result<Sample> {
        check_triangle_coord(at, self.patches.len())?;
        let (f, u, v) = (at.face as usize, at.u, at.v);
        let Some(p) = &self.patches[f] else {
            return Err(Error::new(
                ErrorKind::Usage,
                format!("face {} is a hole", at.face),
            ));
        };
        let r = p.eval(u, v.min(1.0 - u));
        Ok(Sample {
            p: r[0],
            du: r[1],
            dv: r[2],
            duu: r[3],
            duv: r[4],
            dvv: r[5],
            level: 0,
        })
    }

    /// [`Self::eval`] at the sub-quad parameter `(face, k, s, t)` (as
    /// [`LoopSurface::eval_sub_quad`]).
    pub fn eval_sub_quad(&self, at: FaceCoord) -> Result<Sample> {
        eval_sub_quad(at, |u, v| self.eval(FaceCoord::new(at.face, 0, u, v)))
    }
}

/// Paper 004's Gregory-patch approximation of a Catmull-Clark surface: one bicubic Gregory
/// patch per quad of the first subdivision level, addressed by the base mesh's `(face, k, u, v)`
/// (a quad face's domain holds its four children, an n-gon's sub-face `k` is one).
#[derive(Clone, Debug)]
pub struct QuadApprox {
    frames: Vec<QuadFrame>,
    patches: Vec<Option<GregoryQuad>>,
    /// First level-1 face of each base face, and its size.
    first: Vec<(u32, u8)>,
    mesh: ControlMesh,
    options: Options,
}

impl QuadApprox {
    /// The approximation of the surface of `mesh` under `options`, whose exact patch table is
    /// `exact` (the exact surface supplies the limit data).
    pub fn new(mesh: &ControlMesh, options: Options, exact: &PatchTable) -> Result<Self> {
        let (frames, patches) = construct_quad::build(mesh, options, exact)?;
        let mut first = Vec::with_capacity(exact.num_faces());
        let mut at = 0u32;
        for f in 0..exact.num_faces() {
            let n = mesh.face_size(f);
            first.push((at, n.min(255) as u8));
            at += n as u32;
        }
        Ok(QuadApprox {
            frames,
            patches,
            first,
            mesh: mesh.clone(),
            options,
        })
    }

    /// The same approximation re-posed: new base positions, same topology and tags.
    pub fn with_positions(&self, base: &[[f64; 3]], exact: &PatchTable) -> Result<Self> {
        let mut mesh = self.mesh.clone();
        mesh.positions = base.to_vec();
        QuadApprox::new(&mesh, self.options, exact)
    }

    /// Level-1 quads with their frames in the base domains and their patches (`None` for
    /// holes).
    pub fn patches(&self) -> impl Iterator<Item = (&QuadFrame, Option<&GregoryQuad>)> {
        self.frames
            .iter()
            .zip(self.patches.iter().map(|p| p.as_ref()))
    }

    /// Bytes held by the patches and frames.
    pub fn bytes(&self) -> usize {
        self.patches.len() * std::mem::size_of::<Option<GregoryQuad>>()
            + self.frames.len() * std::mem::size_of::<QuadFrame>()
    }

    /// Position and derivatives at `at` in the base mesh's domains (the caller checks the
    /// range, as [`PatchTable::eval`] does).
    pub fn eval(&self, at: FaceCoord) -> Result<Sample> {
        let Some(&(first, n)) = self.first.get(at.face as usize) else {
            return Err(Error::new(
                ErrorKind::Usage,
                format!("face {} out of range", at.face),
            ));
        };
        let c = if n == 4 {
            match (at.u < 0.5, at.v < 0.5) {
                (true, true) => 0,
                (false, true) => 1,
                (false, false) => 2,
                (true, false) => 3,
            }
        } else {
            at.k
        };
        let q = (first + c) as usize;
        let frame = &self.frames[q];
        let Some(p) = &self.patches[q] else {
            return Err(Error::new(
                ErrorKind::Usage,
                format!("face {} is a hole", at.face),
            ));
        };
        let (s, t) = frame.local(at.u, at.v);
        Ok(frame.to_domain(p.eval(s, t)))
    }
}
