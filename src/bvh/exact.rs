//! Where a ray meets the exact limit surface: a hit on the diced mesh refined by Newton's
//! method on `P(u, v) = o + t·d` in `f64`, with `P` from the exact patch table.
//!
//! The diced hit is within the dicing error of the surface, so it is a good start; Newton then
//! converges quadratically unless the ray grazes the surface (singular Jacobian) or the exact
//! intersection lies in a neighbouring face (the iteration leaves the unit square). Both are
//! reported as `None` rather than as a wrong answer.

use super::ray::{Hit, Ray64};
use crate::coord::FaceCoord;
use crate::patch::PatchTable;
use crate::vec3::{cross, dot, norm};

/// An intersection with the exact limit surface.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ExactHit {
    /// Ray parameter.
    pub t: f64,
    /// Base face.
    pub face: u32,
    /// Sub-face.
    pub k: u32,
    /// Parameters in the (sub-)face.
    pub u: f64,
    /// See `u`.
    pub v: f64,
    /// Point on the limit surface.
    pub p: [f64; 3],
    /// Unit limit normal `Pu × Pv`.
    pub n: [f64; 3],
    /// `|P(u,v) − (o + t d)|` at the solution.
    pub residual: f64,
    /// Newton steps taken.
    pub iterations: u32,
}

/// Largest number of Newton steps.
const MAX_STEPS: u32 = 40;

/// Refines `hit` (found for `ray`'s `f32` rounding on the diced mesh) onto the exact limit
/// surface of `table`, for `ray` itself in `f64`.
pub fn refine_hit(table: &PatchTable, ray: &Ray64, hit: &Hit) -> Option<ExactHit> {
    let (o, d) = (ray.origin, ray.dir);
    let (face, k) = (hit.face as usize, hit.k as usize);
    let (mut u, mut v, mut t) = (hit.u as f64, hit.v as f64, hit.t as f64);
    let scale = norm(o) + norm(d) * t.abs() + 1.0;
    let mut best: Option<ExactHit> = None;
    for it in 0..=MAX_STEPS {
        let s = table
            .eval(FaceCoord::new(
                face as u32,
                k as u32,
                u.clamp(0.0, 1.0),
                v.clamp(0.0, 1.0),
            ))
            .ok()?;
        let f = [
            s.p[0] - o[0] - t * d[0],
            s.p[1] - o[1] - t * d[1],
            s.p[2] - o[2] - t * d[2],
        ];
        let res = norm(f);
        if best.is_none_or(|b| res < b.residual) {
            let n = cross(s.du, s.dv);
            let l = norm(n);
            best = Some(ExactHit {
                t,
                face: hit.face,
                k: hit.k,
                u,
                v,
                p: s.p,
                n: if l > 0.0 { n.map(|x| x / l) } else { n },
                residual: res,
                iterations: it,
            });
        }
        if res <= 4.0 * f64::EPSILON * scale || it == MAX_STEPS {
            break;
        }
        // Solve [Pu Pv −d] (du, dv, dt) = −f by Cramer's rule.
        let nd = d.map(|x| -x);
        let det = dot(s.du, cross(s.dv, nd));
        if det == 0.0 || !det.is_finite() {
            break;
        }
        let mf = f.map(|x| -x);
        let du = dot(mf, cross(s.dv, nd)) / det;
        let dv = dot(s.du, cross(mf, nd)) / det;
        let dt = dot(s.du, cross(s.dv, mf)) / det;
        u += du;
        v += dv;
        t += dt;
        let margin = 1e-9;
        if !(-margin..=1.0 + margin).contains(&u) || !(-margin..=1.0 + margin).contains(&v) {
            return None;
        }
    }
    let b = best?;
    (b.residual <= 1e-9 * scale).then_some(b)
}
