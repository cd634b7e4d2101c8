//! The watertight ray/triangle test of Woop, Benthin and Wald (JCGT 2013), and the
//! conservative ray/box test that goes with it.
//!
//! The ray is transformed once so that it runs along +z through the origin (a permutation of
//! axes and a shear); each triangle vertex is transformed by the same operations, so a vertex
//! shared by two triangles gets the same transformed coordinates in both. The 2-D edge
//! functions of a shared edge are then exact negatives of each other, and a ray that lands
//! exactly on an edge or a vertex gives a zero, which is re-evaluated in `f64` (products of
//! two `f32` are exact there). No ray passes between two triangles that share an edge.
//!
//! No fused multiply-add is used anywhere: results are the same on every IEEE machine and in
//! the WGSL port.

use super::ray::Ray;

/// Unit roundoff of `f32`.
const EPS: f32 = f32::EPSILON * 0.5;
/// `γ(3) = 3ε / (1 − 3ε)` (Higham), the relative error bound of a slab distance.
pub const GAMMA3: f32 = 3.0 * EPS / (1.0 - 3.0 * EPS);

/// A ray prepared for the watertight test and the box test.
#[derive(Clone, Copy, Debug)]
pub struct PreparedRay {
    /// Origin.
    pub o: [f32; 3],
    /// Direction.
    pub d: [f32; 3],
    /// `1 / d` per axis (±∞ for a zero component).
    pub inv: [f32; 3],
    /// Axis permutation: `kz` is the dominant axis of `d`.
    pub k: [usize; 3],
    /// Shear constants `d[kx]/d[kz]`, `d[ky]/d[kz]`, `1/d[kz]`.
    pub s: [f32; 3],
    /// Accepted range of `t`.
    pub tmin: f32,
    /// See `tmin`.
    pub tmax: f32,
}

impl PreparedRay {
    /// Prepares `ray`; `None` if its direction is zero or not finite. Inlined: the
    /// traversals copy the prepared ray out of a returned value with wide loads that would
    /// stall on the narrow stores of an out-of-line call.
    #[inline]
    pub fn new(ray: &Ray) -> Option<PreparedRay> {
        let d = ray.dir;
        if !d.iter().all(|x| x.is_finite()) || d.iter().all(|&x| x == 0.0) {
            return None;
        }
        if !ray.origin.iter().all(|x| x.is_finite()) {
            return None;
        }
        let a = d.map(f32::abs);
        let kz = if a[0] > a[1] {
            if a[0] > a[2] {
                0
            } else {
                2
            }
        } else if a[1] > a[2] {
            1
        } else {
            2
        };
        let mut kx = (kz + 1) % 3;
        let mut ky = (kx + 1) % 3;
        if d[kz] < 0.0 {
            std::mem::swap(&mut kx, &mut ky);
        }
        Some(PreparedRay {
            o: ray.origin,
            d,
            inv: d.map(|x| 1.0 / x),
            k: [kx, ky, kz],
            s: [d[kx] / d[kz], d[ky] / d[kz], 1.0 / d[kz]],
            tmin: ray.tmin,
            tmax: ray.tmax,
        })
    }

    /// Conservative slab test against the box `[lo, hi]` for `t ∈ [tmin, tmax]`: never
    /// rejects a box that the exact ray meets (the far distance is enlarged by `2γ(3)`, as
    /// Woop et al. require; NaNs from `0 · ∞` leave the bound open).
    #[inline(always)]
    pub fn hits_box(&self, lo: [f32; 3], hi: [f32; 3], tmax: f32) -> bool {
        let mut near = self.tmin;
        let mut far = tmax;
        for a in 0..3 {
            let (n, f) = if self.inv[a].is_sign_negative() {
                (hi[a], lo[a])
            } else {
                (lo[a], hi[a])
            };
            let tn = (n - self.o[a]) * self.inv[a];
            let tf = (f - self.o[a]) * self.inv[a] * (1.0 + 2.0 * GAMMA3);
            near = near.max(tn);
            far = far.min(tf);
        }
        near <= far
    }
}

/// Watertight intersection of a prepared ray with triangle `(a, b, c)`, both sides.
/// Returns `(t, b1, b2)` with `t ∈ [tmin, tmax]` and barycentric weights of `b` and `c`.
#[inline(always)]
pub fn intersect_prepared(
    r: &PreparedRay,
    a: [f32; 3],
    b: [f32; 3],
    c: [f32; 3],
    tmax: f32,
) -> Option<(f32, f32, f32)> {
    let [kx, ky, kz] = r.k;
    let [sx, sy, sz] = r.s;
    let at = [a[0] - r.o[0], a[1] - r.o[1], a[2] - r.o[2]];
    let bt = [b[0] - r.o[0], b[1] - r.o[1], b[2] - r.o[2]];
    let ct = [c[0] - r.o[0], c[1] - r.o[1], c[2] - r.o[2]];
    let ax = at[kx] - sx * at[kz];
    let ay = at[ky] - sy * at[kz];
    let bx = bt[kx] - sx * bt[kz];
    let by = bt[ky] - sy * bt[kz];
    let cx = ct[kx] - sx * ct[kz];
    let cy = ct[ky] - sy * ct[kz];
    let mut u = cx * by - cy * bx;
    let mut v = ax * cy - ay * cx;
    let mut w = bx * ay - by * ax;
    if u == 0.0 || v == 0.0 || w == 0.0 {
        let (ax, ay, bx, by, cx, cy) = (
            ax as f64, ay as f64, bx as f64, by as f64, cx as f64, cy as f64,
        );
        u = (cx * by - cy * bx) as f32;
        v = (ax * cy - ay * cx) as f32;
        w = (bx * ay - by * ax) as f32;
    }
    if (u < 0.0 || v < 0.0 || w < 0.0) && (u > 0.0 || v > 0.0 || w > 0.0) {
        return None;
    }
    let det = u + v + w;
    if det == 0.0 {
        return None;
    }
    let az = sz * at[kz];
    let bz = sz * bt[kz];
    let cz = sz * ct[kz];
    let t_scaled = u * az + v * bz + w * cz;
    let (ts, ad) = if det < 0.0 {
        (-t_scaled, -det)
    } else {
        (t_scaled, det)
    };
    if ts < r.tmin * ad || ts > tmax * ad {
        return None;
    }
    let rcp = 1.0 / det;
    let t = t_scaled * rcp;
    if t < r.tmin || t > tmax {
        return None;
    }
    Some((t, v * rcp, w * rcp))
}

/// Watertight intersection of `ray` with triangle `(a, b, c)`: `(t, b1, b2)`.
pub fn intersect_triangle(
    ray: &Ray,
    a: [f32; 3],
    b: [f32; 3],
    c: [f32; 3],
) -> Option<(f32, f32, f32)> {
    let r = PreparedRay::new(ray)?;
    intersect_prepared(&r, a, b, c, ray.tmax)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A ray through a shared edge or vertex of a fan hits at least one triangle, for rays
    /// aimed exactly at points on the shared edges.
    #[test]
    fn shared_edges_and_vertices_do_not_leak() {
        // A fan of triangles around a centre, with awkward coordinates.
        let c = [0.1f32, 0.2, 0.3];
        let ring: Vec<[f32; 3]> = (0..7)
            .map(|i| {
                let a = i as f32 * 0.897;
                [
                    c[0] + a.cos() * 1.3,
                    c[1] + a.sin() * 0.7,
                    c[2] + 0.01 * i as f32,
                ]
            })
            .collect();
        let tris: Vec<[[f32; 3]; 3]> = (0..7).map(|i| [c, ring[i], ring[(i + 1) % 7]]).collect();
        let o = [0.05f32, 0.15, 5.0];
        for i in 0..7 {
            for t in [0.0f32, 0.25, 0.5, 0.999, 1.0] {
                let p = [
                    c[0] + (ring[i][0] - c[0]) * t,
                    c[1] + (ring[i][1] - c[1]) * t,
                    c[2] + (ring[i][2] - c[2]) * t,
                ];
                let ray = Ray::new(o, [p[0] - o[0], p[1] - o[1], p[2] - o[2]]);
                let hits = tris
                    .iter()
                    .filter(|tr| intersect_triangle(&ray, tr[0], tr[1], tr[2]).is_some())
                    .count();
                assert!(hits >= 1, "ray at edge {i}, t {t} leaked");
            }
        }
    }

    #[test]
    fn closed_form_hit() {
        let ray = Ray::new([0.25, 0.25, -1.0], [0.0, 0.0, 2.0]);
        let (t, b1, b2) =
            intersect_triangle(&ray, [0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]).unwrap();
        assert_eq!((t, b1, b2), (0.5, 0.25, 0.25));
        // Back side too.
        let (t, ..) =
            intersect_triangle(&ray, [0.0, 0.0, 0.0], [0.0, 1.0, 0.0], [1.0, 0.0, 0.0]).unwrap();
        assert_eq!(t, 0.5);
        let miss = Ray::new([1.25, 0.25, -1.0], [0.0, 0.0, 1.0]);
        assert!(
            intersect_triangle(&miss, [0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]).is_none()
        );
    }

    #[test]
    fn box_test_is_conservative_on_faces() {
        // Rays lying exactly in a box face plane, axis-parallel (0 · ∞ = NaN case).
        let r = PreparedRay::new(&Ray::new([0.0, 1.0, -5.0], [0.0, 0.0, 1.0])).unwrap();
        assert!(r.hits_box([0.0, 0.0, 0.0], [1.0, 1.0, 1.0], f32::INFINITY));
        let r = PreparedRay::new(&Ray::new([2.0, 0.5, 0.5], [-1.0, 0.0, 0.0])).unwrap();
        assert!(r.hits_box([0.0, 0.0, 0.0], [1.0, 1.0, 1.0], f32::INFINITY));
        assert!(!r.hits_box([0.0, 0.0, 0.0], [1.0, 1.0, 1.0], 0.5));
    }
}
