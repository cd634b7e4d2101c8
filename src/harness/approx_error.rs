//! How far an approximate surface is from the exact one: paper 002's Table 3 (measured there
//! with Metro) redone on the surfaces themselves rather than on tessellations of them.
//!
//! Points are drawn area-uniformly on one surface (a triangle of a fine tessellation chosen
//! with probability proportional to its area, a uniform point in it, mapped through the
//! triangle's parameters back onto the surface) and projected onto the other: the closest
//! tessellation triangle seeds a Gauss–Newton projection on the surface itself, within the
//! seed's face. Each distance is therefore realised by a point of the other surface (an upper
//! bound of the true distance that the projection makes tight). Distances are relative to the
//! exact surface's bounding-box diagonal; normals are compared at the projected point.

use super::closest::ClosestMesh;
use super::rng::SplitMix64;
use crate::coord::FaceCoord;
use crate::error::{Error, ErrorKind, Result};
use crate::patch::approx::{Approximation, TriApprox};
use crate::patch::{LoopSurface, Sample};
use crate::vec3::{cross, dot, norm, normalize, sub};
use rayon::prelude::*;

/// Options of [`measure`].
#[derive(Clone, Copy, Debug)]
pub struct ErrorOptions {
    /// Points drawn on each surface.
    pub samples: usize,
    /// Random seed.
    pub seed: u64,
    /// Segments per triangle edge of the tessellations that seed the projections and carry
    /// the area weights.
    pub tess: usize,
}

impl Default for ErrorOptions {
    fn default() -> Self {
        ErrorOptions {
            samples: 100_000,
            seed: 1,
            tess: 8,
        }
    }
}

/// The measured distance between an approximation and the exact surface.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ApproxError {
    /// Which approximation.
    pub surface: Approximation,
    /// Largest distance from the approximation's points to the exact surface (one-sided
    /// Hausdorff), relative to the diagonal.
    pub max: f64,
    /// Mean of those distances.
    pub mean: f64,
    /// Root mean square of those distances.
    pub rms: f64,
    /// Largest distance from the exact surface's points to the approximation.
    pub max_reverse: f64,
    /// Mean of the reverse distances.
    pub mean_reverse: f64,
    /// Root mean square of the reverse distances.
    pub rms_reverse: f64,
    /// Largest angle (degrees) between the approximation's normal and the exact normal at
    /// the projected point.
    pub normal_max_deg: f64,
    /// Mean of those angles.
    pub normal_mean_deg: f64,
    /// Where on the approximation `max` was found: `(face, u, v)`.
    pub max_at: (u32, f64, f64),
    /// Where on the approximation `normal_max_deg` was found.
    pub normal_max_at: (u32, f64, f64),
    /// Points drawn on each surface.
    pub samples: usize,
    /// The exact surface's bounding-box diagonal (the unit of the distances).
    pub diagonal: f64,
}

impl ApproxError {
    /// One JSON object (no newline).
    pub fn json(&self) -> String {
        format!(
            "{{\"surface\":\"{}\",\"max\":{:e},\"mean\":{:e},\"rms\":{:e},\"max_reverse\":{:e},\
             \"mean_reverse\":{:e},\"rms_reverse\":{:e},\"normal_max_deg\":{:e},\
             \"normal_mean_deg\":{:e},\"max_at\":[{},{},{}],\"normal_max_at\":[{},{},{}],\
             \"samples\":{},\"diagonal\":{:e}}}",
            self.surface,
            self.max,
            self.mean,
            self.rms,
            self.max_reverse,
            self.mean_reverse,
            self.rms_reverse,
            self.normal_max_deg,
            self.normal_mean_deg,
            self.max_at.0,
            self.max_at.1,
            self.max_at.2,
            self.normal_max_at.0,
            self.normal_max_at.1,
            self.normal_max_at.2,
            self.samples,
            self.diagonal
        )
    }
}

/// A surface given face by face in OpenSubdiv's triangle parameter (`None` in holes).
type TriEval<'a> = &'a (dyn Fn(u32, f64, f64) -> Option<Sample> + Sync);

/// A surface's positions alone.
type TriPos<'a> = &'a (dyn Fn(u32, f64, f64) -> Option<[f64; 3]> + Sync);

/// A tessellation of a triangle surface with each point's parameter.
struct Tess {
    mesh: ClosestMesh,
    params: Vec<(u32, f64, f64)>,
    /// Cumulative triangle areas.
    cdf: Vec<f64>,
}

fn tessellate(faces: usize, n: usize, eval: TriPos) -> Result<Tess> {
    type FaceBlock = (Vec<[f64; 3]>, Vec<(u32, f64, f64)>);
    let per_face: Vec<Option<FaceBlock>> = (0..faces as u32)
        .into_par_iter()
        .map(|f| {
            let mut pts = Vec::new();
            let mut params = Vec::new();
            for j in 0..=n {
                for i in 0..=n - j {
                    let (u, v) = (i as f64 / n as f64, j as f64 / n as f64);
                    pts.push(eval(f, u, v)?);
                    params.push((f, u, v));
                }
            }
            Some((pts, params))
        })
        .collect();
    // Index of (i, j) within a face's block: rows of n + 1, n, ... points.
    let idx = |i: usize, j: usize| (j * (2 * n + 3 - j) / 2 + i) as u32;
    let mut points = Vec::new();
    let mut params = Vec::new();
    let mut tris = Vec::new();
    for (pts, ps) in per_face.into_iter().flatten() {
        let base = points.len() as u32;
        points.extend(pts);
        params.extend(ps);
        for j in 0..n {
            for i in 0..n - j {
                tris.push([base + idx(i, j), base + idx(i + 1, j), base + idx(i, j + 1)]);
                if i + j + 2 <= n {
                    tris.push([
                        base + idx(i + 1, j),
                        base + idx(i + 1, j + 1),
                        base + idx(i, j + 1),
                    ]);
                }
            }
        }
    }
    if tris.is_empty() {
        return Err(Error::new(
            ErrorKind::Usage,
            "the surface has no faces outside holes",
        ));
    }
    let mut cdf = Vec::with_capacity(tris.len());
    let mut total = 0.0;
    for t in &tris {
        let [a, b, c] = t.map(|v| points[v as usize]);
        total += 0.5 * norm(cross(sub(b, a), sub(c, a)));
        cdf.push(total);
    }
    Ok(Tess {
        mesh: ClosestMesh::new(points, tris),
        params,
        cdf,
    })
}

impl Tess {
    /// The parameter of barycentric point `w` of triangle `t`.
    fn param(&self, t: u32, w: [f64; 3]) -> (u32, f64, f64) {
        let tri = self.mesh.triangle(t);
        let ps = tri.map(|v| self.params[v as usize]);
        let u = w[0] * ps[0].1 + w[1] * ps[1].1 + w[2] * ps[2].1;
        let v = w[0] * ps[0].2 + w[1] * ps[1].2 + w[2] * ps[2].2;
        (ps[0].0, u.max(0.0), v.max(0.0).min(1.0 - u.max(0.0)))
    }

    /// An area-uniform random parameter.
    fn draw(&self, rng: &mut SplitMix64) -> (u32, f64, f64) {
        let total = *self.cdf.last().expect("a tessellation has triangles");
        let x = rng.next_f64() * total;
        let t = self.cdf.partition_point(|&c| c < x).min(self.cdf.len() - 1);
        let (r1, r2) = (rng.next_f64().sqrt(), rng.next_f64());
        self.param(t as u32, [1.0 - r1, r1 * (1.0 - r2), r1 * r2])
    }
}

/// Keeps `(u, v)` in the triangle `u, v ≥ 0`, `u + v ≤ 1`.
fn clamp_tri(mut u: f64, mut v: f64) -> (f64, f64) {
    if u + v > 1.0 {
        let e = 0.5 * (u + v - 1.0);
        u -= e;
        v -= e;
    }
    u = u.clamp(0.0, 1.0);
    v = v.clamp(0.0, 1.0 - u);
    (u, v)
}

/// The distance from `x` to the surface and the surface's unit normal there.
fn project(tess: &Tess, eval: TriEval, x: [f64; 3]) -> Option<(f64, [f64; 3])> {
    let c = tess.mesh.closest(x)?;
    let (f, mut u, mut v) = tess.param(c.tri, c.bary);
    let mut best: Option<(f64, [f64; 3])> = None;
    for _ in 0..16 {
        let s = eval(f, u, v)?;
        let r = sub(s.p, x);
        let d = norm(r);
        if best.is_none_or(|b| d < b.0) {
            best = Some((d, normalize(cross(s.du, s.dv))));
        }
        let (a11, a12, a22) = (dot(s.du, s.du), dot(s.du, s.dv), dot(s.dv, s.dv));
        let (b1, b2) = (-dot(s.du, r), -dot(s.dv, r));
        let det = a11 * a22 - a12 * a12;
        if det.is_nan() || det <= 0.0 {
            break;
        }
        let (du, dv) = ((a22 * b1 - a12 * b2) / det, (a11 * b2 - a12 * b1) / det);
        let (nu, nv) = clamp_tri(u + du, v + dv);
        if (nu - u).abs() + (nv - v).abs() < 1e-14 {
            break;
        }
        (u, v) = (nu, nv);
    }
    best
}

/// Distances (and normal angles, degrees) from area-uniform points of one surface to another,
/// unscaled, with where the largest of each was found.
#[derive(Clone, Copy, Debug, Default)]
struct OneWay {
    max: f64,
    max_at: (u32, f64, f64),
    sum: f64,
    sq: f64,
    nmax: f64,
    nmax_at: (u32, f64, f64),
    nsum: f64,
    count: usize,
}

impl OneWay {
    fn add(&mut self, at: (u32, f64, f64), d: f64, ang: f64) {
        if d > self.max {
            self.max = d;
            self.max_at = at;
        }
        if ang > self.nmax {
            self.nmax = ang;
            self.nmax_at = at;
        }
        self.sum += d;
        self.sq += d * d;
        self.nsum += ang;
        self.count += 1;
    }

    fn merge(mut self, o: OneWay) -> OneWay {
        if o.max > self.max {
            self.max = o.max;
            self.max_at = o.max_at;
        }
        if o.nmax > self.nmax {
            self.nmax = o.nmax;
            self.nmax_at = o.nmax_at;
        }
        self.sum += o.sum;
        self.sq += o.sq;
        self.nsum += o.nsum;
        self.count += o.count;
        self
    }

    fn mean(&self) -> f64 {
        self.sum / self.count as f64
    }

    fn rms(&self) -> f64 {
        (self.sq / self.count as f64).sqrt()
    }
}

/// [`OneWay`] over `samples` area-uniform points of `src`, projected onto `dst`.
fn one_way(
    src: (&Tess, TriEval),
    dst: (&Tess, TriEval),
    samples: usize,
    seed: u64,
) -> Result<OneWay> {
    const CHUNK: usize = 1024;
    let chunks = samples.div_ceil(CHUNK);
    let total = (0..chunks)
        .into_par_iter()
        .map(|c| {
            let mut rng = SplitMix64::new(seed ^ (c as u64).wrapping_mul(0x9e37_79b9_7f4a_7c15));
            let n = CHUNK.min(samples - c * CHUNK);
            let mut acc = OneWay::default();
            for _ in 0..n {
                let at = src.0.draw(&mut rng);
                let Some(s) = (src.1)(at.0, at.1, at.2) else {
                    continue;
                };
                let Some((d, nd)) = project(dst.0, dst.1, s.p) else {
                    continue;
                };
                let ns = normalize(cross(s.du, s.dv));
                acc.add(at, d, norm(cross(ns, nd)).atan2(dot(ns, nd)).to_degrees());
            }
            acc
        })
        .reduce(OneWay::default, OneWay::merge);
    if total.count == 0 {
        return Err(Error::new(ErrorKind::Usage, "no sample could be measured"));
    }
    Ok(total)
}

/// The exact surface prepared once for measuring several approximations of it: its
/// tessellation and diagonal.
pub struct Reference<'a> {
    exact: &'a LoopSurface,
    tess: Tess,
    diagonal: f64,
    opts: ErrorOptions,
}

impl<'a> Reference<'a> {
    /// Tessellates `exact` (positions only: no secants at its vertices).
    pub fn new(exact: &'a LoopSurface, opts: ErrorOptions) -> Result<Self> {
        if opts.samples == 0 || opts.tess == 0 {
            return Err(Error::new(
                ErrorKind::Usage,
                "samples and tessellation rate must be at least 1",
            ));
        }
        let pos = |f: u32, u: f64, v: f64| exact.position(FaceCoord::new(f, 0, u, v)).ok();
        let tess = tessellate(exact.num_faces(), opts.tess, &pos)?;
        let diagonal = tess.mesh.diagonal();
        Ok(Reference {
            exact,
            tess,
            diagonal,
            opts,
        })
    }

    /// The distance between `approx` and the exact surface.
    pub fn measure(&self, approx: &TriApprox) -> Result<ApproxError> {
        let opts = self.opts;
        let exact = self.exact;
        let ex = |f: u32, u: f64, v: f64| exact.eval(FaceCoord::new(f, 0, u, v)).ok();
        let ap = |f: u32, u: f64, v: f64| approx.eval(FaceCoord::new(f, 0, u, v)).ok();
        let ap_p = |f: u32, u: f64, v: f64| ap(f, u, v).map(|s| s.p);
        let ta = tessellate(approx.num_faces(), opts.tess, &ap_p)?;
        let te = &self.tess;
        let fwd = one_way((&ta, &ap), (te, &ex), opts.samples, opts.seed)?;
        let rev = one_way(
            (te, &ex),
            (&ta, &ap),
            opts.samples,
            opts.seed.wrapping_add(1),
        )?;
        let diagonal = self.diagonal;
        let rel = |x: f64| if diagonal > 0.0 { x / diagonal } else { x };
        Ok(ApproxError {
            surface: approx.kind(),
            max: rel(fwd.max),
            mean: rel(fwd.mean()),
            rms: rel(fwd.rms()),
            max_reverse: rel(rev.max),
            mean_reverse: rel(rev.mean()),
            rms_reverse: rel(rev.rms()),
            normal_max_deg: fwd.nmax,
            normal_mean_deg: fwd.nsum / fwd.count as f64,
            max_at: fwd.max_at,
            normal_max_at: fwd.nmax_at,
            samples: opts.samples,
            diagonal,
        })
    }
}

/// The distance between `approx` and the exact surface `exact` it approximates (one
/// approximation: [`Reference`] prepares the exact side once for several).
pub fn measure(exact: &LoopSurface, approx: &TriApprox, opts: ErrorOptions) -> Result<ApproxError> {
    Reference::new(exact, opts)?.measure(approx)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A surface's distance to itself is zero (the projection finds the drawn point again)
    /// and a copy moved by `δ` along z measures `δ` wherever its normal is vertical: checked
    /// on a flat sheet, where the closed form is exact.
    #[test]
    fn distances_of_a_known_offset() {
        let plane = |dz: f64| {
            move |_f: u32, u: f64, v: f64| {
                Some(Sample {
                    p: [u, v, dz],
                    du: [1.0, 0.0, 0.0],
                    dv: [0.0, 1.0, 0.0],
                    ..Sample::default()
                })
            }
        };
        let (a, b) = (plane(0.0), plane(0.01));
        let pa = |f: u32, u: f64, v: f64| a(f, u, v).map(|s| s.p);
        let pb = |f: u32, u: f64, v: f64| b(f, u, v).map(|s| s.p);
        let (ta, tb) = (
            tessellate(1, 4, &pa).unwrap(),
            tessellate(1, 4, &pb).unwrap(),
        );
        let same = one_way((&ta, &a), (&ta, &a), 2000, 3).unwrap();
        assert!(same.max < 1e-15 && same.nmax < 1e-9, "{same:?}");
        let off = one_way((&ta, &a), (&tb, &b), 2000, 3).unwrap();
        assert!(
            (off.max - 0.01).abs() < 1e-15 && (off.mean() - 0.01).abs() < 1e-15,
            "{off:?}"
        );
        assert_eq!(off.count, 2000);
    }
}
