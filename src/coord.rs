//! [`FaceCoord`]: a point of a control mesh's parameter domain, the one spelling of "where on
//! the surface" used by evaluation, dicing, hits and the front end.

/// A point of the limit surface's parameter domain: `(u, v)` in sub-face `k` of base face
/// `face`, in OpenSubdiv's ptex convention (DESIGN.md): a quad is one unit square (`k = 0`), an
/// n-gon has `n` sub-faces, sub-face `k` having `(0, 0)` at the face's vertex `k` and `(1, 1)`
/// at the face's centre.
///
/// ```
/// use limitray::FaceCoord;
/// let at = FaceCoord::quad(3, 0.25, 0.5);
/// assert_eq!((at.face, at.k, at.u, at.v), (3, 0, 0.25, 0.5));
/// ```
#[derive(Clone, Copy, Debug, Default, PartialEq, bytemuck::Zeroable)]
pub struct FaceCoord {
    /// Base (control-mesh) face, 0-based.
    pub face: u32,
    /// Sub-face of an n-gon (0 for quads).
    pub k: u32,
    /// First parameter in `[0, 1]`.
    pub u: f64,
    /// Second parameter in `[0, 1]`.
    pub v: f64,
}

impl FaceCoord {
    /// `(u, v)` in sub-face `k` of face `face`.
    pub const fn new(face: u32, k: u32, u: f64, v: f64) -> FaceCoord {
        FaceCoord { face, k, u, v }
    }

    /// `(u, v)` in the quad `face` (sub-face 0).
    pub const fn quad(face: u32, u: f64, v: f64) -> FaceCoord {
        FaceCoord { face, k: 0, u, v }
    }
}
