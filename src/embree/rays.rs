//! "Rays from inside" for the Embree leak counts; the other ray sets are the harness's
//! ([`crate::harness::rays`]).

pub use crate::harness::rng::SplitMix64;

use crate::harness::rays::normalise;
pub use crate::harness::rays::{camera, camera_size, incoherent, TestRay};
/// A point of a diced surface for a leak ray: the ray goes through `point` along a direction
/// within `max_tilt` radians of `normal`, chosen so that every triangle around the point faces
/// it (the triangles' normals make an angle below 90° with it).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LeakTarget {
    /// A diced vertex or a point on a diced edge.
    pub point: [f32; 3],
    /// Unit normal of the cone of allowed directions.
    pub normal: [f64; 3],
    /// Half-angle of that cone, radians.
    pub max_tilt: f64,
}

/// Leak rays: for each ray a random target, a direction `m` uniform in its cone, the origin
/// `point - depth m` (behind the surface) and the direction `point - origin`, so the ray passes
/// through the point at `t ≈ 1` (to float rounding). Every triangle around the point faces `m`,
/// so the fan projects one-to-one along the ray: a watertight intersector must report a hit
/// (at the point, or before it). Every miss is a leak.
pub fn towards_points(targets: &[LeakTarget], depth: f64, n: usize, seed: u64) -> Vec<TestRay> {
    let mut rng = SplitMix64::new(seed);
    if targets.is_empty() {
        return Vec::new();
    }
    (0..n)
        .map(|_| {
            let t = targets[rng.below(targets.len())];
            let nrm = normalise(t.normal);
            // Uniform on the spherical cap of half-angle max_tilt around the normal.
            let cos_max = t.max_tilt.clamp(0.0, std::f64::consts::FRAC_PI_2).cos();
            let c = 1.0 - rng.next_f64() * (1.0 - cos_max);
            let s = (1.0 - c * c).max(0.0).sqrt();
            let phi = std::f64::consts::TAU * rng.next_f64();
            let helper = if nrm[0].abs() < 0.9 {
                [1.0, 0.0, 0.0]
            } else {
                [0.0, 1.0, 0.0]
            };
            let a = normalise(cross(nrm, helper));
            let b = cross(nrm, a);
            let m: [f64; 3] =
                std::array::from_fn(|k| c * nrm[k] + s * (phi.cos() * a[k] + phi.sin() * b[k]));
            let p = t.point;
            let o: [f32; 3] = std::array::from_fn(|k| (p[k] as f64 - depth * m[k]) as f32);
            let dir: [f32; 3] = std::array::from_fn(|k| p[k] - o[k]);
            TestRay { origin: o, dir }
        })
        .collect()
}

/// Cross product.
pub fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}
