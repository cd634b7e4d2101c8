//! Rays and hits.

/// A ray `origin + t·dir`, `t ∈ [tmin, tmax]`. `dir` need not be unit length; `t` is in units
/// of `dir`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ray {
    /// Origin.
    pub origin: [f32; 3],
    /// Direction (not necessarily normalised; must not be zero).
    pub dir: [f32; 3],
    /// Smallest accepted `t`.
    pub tmin: f32,
    /// Largest accepted `t`.
    pub tmax: f32,
}

impl Ray {
    /// A ray over `[0, ∞)`.
    pub fn new(origin: [f32; 3], dir: [f32; 3]) -> Ray {
        Ray {
            origin,
            dir,
            tmin: 0.0,
            tmax: f32::INFINITY,
        }
    }
}

/// A ray in double precision, as the exact intersector takes it ([`crate::exact`]): the
/// answer is for this ray, not for its `f32` rounding (which only seeds the search through the
/// diced mesh's BVH, [`Ray64::to_f32`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ray64 {
    /// Origin.
    pub origin: [f64; 3],
    /// Direction (not necessarily normalised; must not be zero).
    pub dir: [f64; 3],
}

impl Ray64 {
    /// A ray over `[0, ∞)`.
    pub fn new(origin: [f64; 3], dir: [f64; 3]) -> Ray64 {
        Ray64 { origin, dir }
    }

    /// The nearest `f32` ray, for the BVH traversal.
    pub fn to_f32(&self) -> Ray {
        Ray::new(self.origin.map(|x| x as f32), self.dir.map(|x| x as f32))
    }
}

impl From<&Ray> for Ray64 {
    /// The same ray, widened exactly.
    fn from(r: &Ray) -> Ray64 {
        Ray64::new(r.origin.map(f64::from), r.dir.map(f64::from))
    }
}

/// Where a ray meets a diced mesh.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    /// Ray parameter of the hit.
    pub t: f32,
    /// Triangle of the diced mesh ([`crate::dice::DicedMesh::triangles`] index).
    pub triangle: u32,
    /// Base (control-mesh) face.
    pub face: u32,
    /// Sub-face of an n-gon (0 for quads).
    pub k: u32,
    /// `(u, v)` in the (sub-)face's parameterisation, interpolated from the diced vertices.
    pub u: f32,
    /// See `u`.
    pub v: f32,
    /// Barycentric coordinates of the hit in the triangle: weight of corner 1 and corner 2
    /// (corner 0 has `1 - b1 - b2`).
    pub b1: f32,
    /// See `b1`.
    pub b2: f32,
    /// Unit geometric normal of the triangle (winding order of the control faces, outward for
    /// counter-clockwise faces), in the space of the ray.
    pub ng: [f32; 3],
    /// Unit shading normal: the limit-surface normal interpolated across the triangle.
    pub ns: [f32; 3],
    /// Subdivision level of the patch at the hit (0 = a base-face B-spline patch).
    pub level: u8,
    /// Where the structure that was traced holds the triangle: a location in a
    /// [`crate::grid::GridMesh`] ([`crate::grid::GridMesh::corners`]), or the leaf-ordered
    /// index of a [`crate::bvh::MeshBvh`].
    pub leaf: u32,
}

/// Ray queries against one diced mesh in its own space: the grid core
/// ([`crate::grid::GridMesh`]) and the triangle BVH ([`crate::bvh::MeshBvh`]) answer them
/// alike (the same `t`, bit for bit).
pub trait Intersect: Sync {
    /// Closest hit of `ray` in `[tmin, tmax]`.
    fn intersect(&self, ray: &Ray) -> Option<Hit>;
    /// True if anything is hit in `[tmin, tmax]`.
    fn occluded(&self, ray: &Ray) -> bool;
}
