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
use crate::patch::approx::Approximation;
use crate::patch::{PatchTable, Sample};
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
    /// Where on the approximation `max` was found.
    pub max_at: FaceCoord,
    /// Where on the approximation `normal_max_deg` was found.
    pub normal_max_at: FaceCoord,
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
             \"normal_mean_deg\":{:e},\"max_at\":[{},{},{},{}],\"normal_max_at\":[{},{},{},{}],\
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
            self.max_at.face,
            self.max_at.k,
            self.max_at.u,
            self.max_at.v,
            self.normal_max_at.face,
            self.normal_max_at.k,
            self.normal_max_at.u,
            self.normal_max_at.v,
            self.samples,
            self.diagonal
        )
    }
}

/// A surface as a function of its domains' parameters (`None` in holes).
type Eval<'a> = &'a (dyn Fn(FaceCoord) -> Option<Sample> + Sync);

/// A surface's positions alone.
type Pos<'a> = &'a (dyn Fn(FaceCoord) -> Option<[f64; 3]> + Sync);

/// The shape of every parameter domain of a surface.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DomainShape {
    /// OpenSubdiv's triangle parameter: `u, v ≥ 0`, `u + v ≤ 1` (Loop faces).
    Triangle,
    /// The unit square (Catmull-Clark faces and n-gon sub-faces).
    Square,
}

impl DomainShape {
    /// Keeps `(u, v)` in the domain.
    fn clamp(self, mut u: f64, mut v: f64) -> (f64, f64) {
        match self {
            DomainShape::Square => (u.clamp(0.0, 1.0), v.clamp(0.0, 1.0)),
            DomainShape::Triangle => {
                if u + v > 1.0 {
                    let e = 0.5 * (u + v - 1.0);
                    u -= e;
                    v -= e;
                }
                u = u.clamp(0.0, 1.0);
                v = v.clamp(0.0, 1.0 - u);
                (u, v)
            }
        }
    }
}

/// A tessellation of a surface with each point's parameter.
struct Tess {
    mesh: ClosestMesh,
    params: Vec<FaceCoord>,
    shape: DomainShape,
    /// Cumulative triangle areas.
    cdf: Vec<f64>,
}

/// `n` segments per domain edge over every domain `(face, k)` of `domains`.
fn tessellate(domains: &[(u32, u32)], shape: DomainShape, n: usize, eval: Pos) -> Result<Tess> {
    type Block = (Vec<[f64; 3]>, Vec<FaceCoord>);
    let per_domain: Vec<Option<Block>> = domains
        .par_iter()
        .map(|&(f, k)| {
            let mut pts = Vec::new();
            let mut params = Vec::new();
            for j in 0..=n {
                let row = match shape {
                    DomainShape::Triangle => n - j,
                    DomainShape::Square => n,
                };
                for i in 0..=row {
                    let at = FaceCoord::new(f, k, i as f64 / n as f64, j as f64 / n as f64);
                    pts.push(eval(at)?);
                    params.push(at);
                }
            }
            Some((pts, params))
        })
        .collect();
    // Index of (i, j) within a domain's block: rows of n + 1, n, ... points (triangle) or of
    // n + 1 (square).
    let idx = |i: usize, j: usize| match shape {
        DomainShape::Triangle => (j * (2 * n + 3 - j) / 2 + i) as u32,
        DomainShape::Square => (j * (n + 1) + i) as u32,
    };
    let mut points = Vec::new();
    let mut params = Vec::new();
    let mut tris = Vec::new();
    for (pts, ps) in per_domain.into_iter().flatten() {
        let base = points.len() as u32;
        points.extend(pts);
        params.extend(ps);
        for j in 0..n {
            let row = match shape {
                DomainShape::Triangle => n - j,
                DomainShape::Square => n,
            };
            for i in 0..row {
                tris.push([base + idx(i, j), base + idx(i + 1, j), base + idx(i, j + 1)]);
                if shape == DomainShape::Square || i + j + 2 <= n {
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
        shape,
        cdf,
    })
}

impl Tess {
    /// The parameter of barycentric point `w` of triangle `t`.
    fn param(&self, t: u32, w: [f64; 3]) -> FaceCoord {
        let tri = self.mesh.triangle(t);
        let ps = tri.map(|v| self.params[v as usize]);
        let u = w[0] * ps[0].u + w[1] * ps[1].u + w[2] * ps[2].u;
        let v = w[0] * ps[0].v + w[1] * ps[1].v + w[2] * ps[2].v;
        let (u, v) = self.shape.clamp(u, v);
        FaceCoord::new(ps[0].face, ps[0].k, u, v)
    }

    /// An area-uniform random parameter.
    fn draw(&self, rng: &mut SplitMix64) -> FaceCoord {
        let total = *self.cdf.last().expect("a tessellation has triangles");
        let x = rng.next_f64() * total;
        let t = self.cdf.partition_point(|&c| c < x).min(self.cdf.len() - 1);
        let (r1, r2) = (rng.next_f64().sqrt(), rng.next_f64());
        self.param(t as u32, [1.0 - r1, r1 * (1.0 - r2), r1 * r2])
    }
}

/// The distance from `x` to the surface and the surface's unit normal there.
fn project(tess: &Tess, eval: Eval, x: [f64; 3]) -> Option<(f64, [f64; 3])> {
    let c = tess.mesh.closest(x)?;
    let at = tess.param(c.tri, c.bary);
    let (mut u, mut v) = (at.u, at.v);
    let mut best: Option<(f64, [f64; 3])> = None;
    for _ in 0..16 {
        let s = eval(FaceCoord { u, v, ..at })?;
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
        let (nu, nv) = tess.shape.clamp(u + du, v + dv);
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
    max_at: FaceCoord,
    sum: f64,
    sq: f64,
    nmax: f64,
    nmax_at: FaceCoord,
    nsum: f64,
    count: usize,
}

impl OneWay {
    fn add(&mut self, at: FaceCoord, d: f64, ang: f64) {
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
fn one_way(src: (&Tess, Eval), dst: (&Tess, Eval), samples: usize, seed: u64) -> Result<OneWay> {
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
                let Some(s) = (src.1)(at) else {
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
    exact: &'a PatchTable,
    shape: DomainShape,
    domains: Vec<(u32, u32)>,
    tess: Tess,
    diagonal: f64,
    opts: ErrorOptions,
}

/// `table`'s surface at a domain point: the triangle parameter under Loop, the (sub-)face's
/// square under Catmull-Clark.
fn eval_in(table: &PatchTable, shape: DomainShape, at: FaceCoord) -> Option<Sample> {
    match shape {
        DomainShape::Triangle => table.eval_triangle(at).ok(),
        DomainShape::Square => table.eval(at).ok(),
    }
}

impl<'a> Reference<'a> {
    /// Tessellates the exact surface of `exact` (a table built with the exact surface; a Loop
    /// surface's positions without the secants at its vertices).
    pub fn new(exact: &'a PatchTable, opts: ErrorOptions) -> Result<Self> {
        if opts.samples == 0 || opts.tess == 0 {
            return Err(Error::new(
                ErrorKind::Usage,
                "samples and tessellation rate must be at least 1",
            ));
        }
        if exact.is_approximate() {
            return Err(Error::new(
                ErrorKind::Usage,
                "the reference must be the exact surface",
            ));
        }
        let (shape, domains): (DomainShape, Vec<(u32, u32)>) = match exact.loop_surface() {
            Some(_) => (
                DomainShape::Triangle,
                (0..exact.num_faces() as u32).map(|f| (f, 0)).collect(),
            ),
            None => (
                DomainShape::Square,
                (0..exact.num_faces())
                    .flat_map(|f| (0..exact.sub_faces(f) as u32).map(move |k| (f as u32, k)))
                    .collect(),
            ),
        };
        let pos = |at: FaceCoord| match exact.loop_surface() {
            Some(ls) => ls.position(at).ok(),
            None => exact.eval(at).ok().map(|s| s.p),
        };
        let tess = tessellate(&domains, shape, opts.tess, &pos)?;
        let diagonal = tess.mesh.diagonal();
        Ok(Reference {
            exact,
            shape,
            domains,
            tess,
            diagonal,
            opts,
        })
    }

    /// The distance between `approx` (a table of the same mesh and scheme built with an
    /// approximate surface) and the exact surface.
    pub fn measure(&self, approx: &PatchTable) -> Result<ApproxError> {
        if approx.loop_surface().is_some() != (self.shape == DomainShape::Triangle)
            || approx.num_faces() != self.exact.num_faces()
        {
            return Err(Error::new(
                ErrorKind::Usage,
                "the approximation is not of the reference's mesh and scheme",
            ));
        }
        let (opts, shape, exact) = (self.opts, self.shape, self.exact);
        let ex = |at: FaceCoord| eval_in(exact, shape, at);
        let ap = |at: FaceCoord| eval_in(approx, shape, at);
        let ap_p = |at: FaceCoord| ap(at).map(|s| s.p);
        let ta = tessellate(&self.domains, shape, opts.tess, &ap_p)?;
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
            surface: approx.options.surface,
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

/// The distance between the approximation `approx` and the exact surface `exact` (two tables
/// of one mesh; [`Reference`] prepares the exact side once for several approximations).
pub fn measure(exact: &PatchTable, approx: &PatchTable, opts: ErrorOptions) -> Result<ApproxError> {
    Reference::new(exact, opts)?.measure(approx)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A surface's distance to itself is zero (the projection finds the drawn point again)
    /// and a copy moved by `δ` along z measures `δ` wherever its normal is vertical: checked
    /// on a flat sheet, where the closed form is exact, over both domain shapes.
    #[test]
    fn distances_of_a_known_offset() {
        let plane = |dz: f64| {
            move |at: FaceCoord| {
                Some(Sample {
                    p: [at.u, at.v, dz],
                    du: [1.0, 0.0, 0.0],
                    dv: [0.0, 1.0, 0.0],
                    ..Sample::default()
                })
            }
        };
        for shape in [DomainShape::Triangle, DomainShape::Square] {
            let (a, b) = (plane(0.0), plane(0.01));
            let pa = |at: FaceCoord| a(at).map(|s| s.p);
            let pb = |at: FaceCoord| b(at).map(|s| s.p);
            let (ta, tb) = (
                tessellate(&[(0, 0)], shape, 4, &pa).unwrap(),
                tessellate(&[(0, 0)], shape, 4, &pb).unwrap(),
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
}
