//! Limit texture coordinates at `(face, k, u, v)`: the limit surface of the mesh's
//! face-varying values ([`crate::refine::fvar_mesh`]) through a patch table of their own, or,
//! in mode [`FVarMode::All`], the bilinear interpolation of each (sub-)face's corners (the
//! limit of bilinear refinement). A face keeps its corners in the value mesh, so the same
//! `(face, k, u, v)` addresses both surfaces.

use super::table::{PatchOptions, PatchTable};
use crate::coord::FaceCoord;
use crate::error::{Error, ErrorKind, Result};
use crate::mesh::{ControlMesh, FVarMode, Scheme};

/// Texture coordinates of a surface's points (see the module).
#[derive(Clone, Debug)]
pub enum UvSurface {
    /// Bilinear per (sub-)face: the mesh's values and corners.
    Bilinear {
        /// `vt` values.
        values: Vec<[f64; 2]>,
        /// Value of each face corner (parallel to the mesh's `face_verts`).
        corners: Vec<u32>,
        /// The mesh's face offsets.
        offsets: Vec<u32>,
    },
    /// The limit surface of the value mesh.
    Smooth(Box<PatchTable>),
}

/// The `(s, t)` at a point and their derivatives in the (sub-)face's `u` and `v`.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct UvSample {
    /// Texture coordinates.
    pub st: [f64; 2],
    /// `∂(s, t)/∂u`.
    pub du: [f64; 2],
    /// `∂(s, t)/∂v`.
    pub dv: [f64; 2],
}

impl UvSurface {
    /// The texture coordinates of `mesh` in `mode`; `None` for a mesh without texture
    /// coordinates. Loop meshes are refused (their face-varying rules are not built).
    pub fn new(mesh: &ControlMesh, mode: FVarMode) -> Result<Option<UvSurface>> {
        if mesh.face_uvs.is_empty() {
            return Ok(None);
        }
        if mesh.options.scheme != Scheme::Catmark {
            return Err(Error::new(
                ErrorKind::Usage,
                "texture coordinates of Loop meshes are not supported (face-varying Loop \
                 refinement is not built)",
            ));
        }
        if mode == FVarMode::All {
            return Ok(Some(UvSurface::Bilinear {
                values: mesh.uvs.clone(),
                corners: mesh.face_uvs.clone(),
                offsets: mesh.face_offsets.clone(),
            }));
        }
        let values = crate::refine::fvar_mesh::uv_mesh(mesh, mode)?;
        let table = PatchTable::new(&values, PatchOptions::default())?;
        Ok(Some(UvSurface::Smooth(Box::new(table))))
    }

    /// The texture coordinates a hit at `(u, v)` of domain `(face, k)` reads: the domain point
    /// (its parameters clamped to the domain, widened to `f64`) and, where the mesh has
    /// texture coordinates (`uv`), their evaluation there. The CPU's texturing and the GPU's
    /// per-vertex coordinates both read them so.
    pub fn at_hit(
        uv: Option<&UvSurface>,
        face: u32,
        k: u32,
        [u, v]: [f32; 2],
    ) -> (FaceCoord, Option<Result<UvSample>>) {
        let at = FaceCoord::new(
            face,
            k,
            (u as f64).clamp(0.0, 1.0),
            (v as f64).clamp(0.0, 1.0),
        );
        (at, uv.map(|s| s.eval(at)))
    }

    /// Texture coordinates and their derivatives at `at`.
    pub fn eval(&self, at: FaceCoord) -> Result<UvSample> {
        match self {
            UvSurface::Smooth(t) => {
                let s = t.eval(at)?;
                Ok(UvSample {
                    st: [s.p[0], s.p[1]],
                    du: [s.du[0], s.du[1]],
                    dv: [s.dv[0], s.dv[1]],
                })
            }
            UvSurface::Bilinear {
                values,
                corners,
                offsets,
            } => {
                let f = at.face as usize;
                if f + 1 >= offsets.len() {
                    return Err(Error::new(
                        ErrorKind::Usage,
                        format!("face {f} out of range"),
                    ));
                }
                let (a, b) = (offsets[f] as usize, offsets[f + 1] as usize);
                let n = b - a;
                let k = at.k as usize;
                if (n == 4 && k != 0) || k >= n {
                    return Err(Error::new(
                        ErrorKind::Usage,
                        format!("face {f} has no sub-face {k}"),
                    ));
                }
                let x = |i: usize| values[corners[a + i % n] as usize];
                let mid = |p: [f64; 2], q: [f64; 2]| [0.5 * (p[0] + q[0]), 0.5 * (p[1] + q[1])];
                // The (sub-)face's corners at (0,0), (1,0), (1,1), (0,1).
                let c = if n == 4 {
                    [x(0), x(1), x(2), x(3)]
                } else {
                    let mut centre = [0.0; 2];
                    for i in 0..n {
                        centre[0] += x(i)[0] / n as f64;
                        centre[1] += x(i)[1] / n as f64;
                    }
                    [x(k), mid(x(k), x(k + 1)), centre, mid(x(k + n - 1), x(k))]
                };
                let (u, v) = (at.u, at.v);
                let mut out = UvSample::default();
                for j in 0..2 {
                    out.st[j] = (1.0 - u) * (1.0 - v) * c[0][j]
                        + u * (1.0 - v) * c[1][j]
                        + u * v * c[2][j]
                        + (1.0 - u) * v * c[3][j];
                    out.du[j] = (1.0 - v) * (c[1][j] - c[0][j]) + v * (c[2][j] - c[3][j]);
                    out.dv[j] = (1.0 - u) * (c[3][j] - c[0][j]) + u * (c[2][j] - c[1][j]);
                }
                Ok(out)
            }
        }
    }

    /// Bytes held.
    pub fn bytes(&self) -> usize {
        match self {
            UvSurface::Smooth(t) => t.bytes(),
            UvSurface::Bilinear {
                values,
                corners,
                offsets,
            } => values.len() * 16 + (corners.len() + offsets.len()) * 4,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::shapes;

    /// A hit's texture coordinates are the surface's at its `(face, k, u, v)`, widened and
    /// clamped to the domain (in that order: `u` then `v`); without texture coordinates the
    /// domain point alone. On the atlas box, whose tiles make `s` and `t` differ from `u` and
    /// `v` and from each other.
    #[test]
    fn a_hit_reads_the_texture_coordinates_at_its_domain_point() {
        let mut mesh = shapes::rounded_box(0.0);
        shapes::atlas_uvs(&mut mesh);
        let uv = UvSurface::new(&mesh, FVarMode::default()).unwrap().unwrap();
        for (face, at) in [(0, [0.25f32, 0.75]), (4, [0.6, 0.1]), (2, [-0.5, 1.5])] {
            let (c, sample) = UvSurface::at_hit(Some(&uv), face, 0, at);
            let want = FaceCoord::new(
                face,
                0,
                (at[0] as f64).clamp(0.0, 1.0),
                (at[1] as f64).clamp(0.0, 1.0),
            );
            assert_eq!(c, want);
            let got = sample.unwrap().unwrap();
            let direct = uv.eval(want).unwrap();
            assert_eq!((got.st, got.du, got.dv), (direct.st, direct.du, direct.dv));
            // The transposed point reads other coordinates (so a swap would be seen).
            let swapped = uv.eval(FaceCoord::new(face, 0, want.v, want.u)).unwrap();
            assert_ne!(got.st, swapped.st, "face {face} at {at:?}");
        }
        let (c, none) = UvSurface::at_hit(None, 3, 0, [1.25, 0.5]);
        assert_eq!((c, none.is_none()), (FaceCoord::new(3, 0, 1.0, 0.5), true));
    }
}
