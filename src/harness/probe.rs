//! Rays that probe a diced surface: origins certified inside a closed mesh by their winding
//! number, random and aimed directions, and the accuracy of hits against the exact limit
//! surface. Used by the leak and accuracy tests, the benchmarks and `limitray accuracy`.

use super::rng::SplitMix64;
use crate::bvh::{Intersect, MeshBvh, Ray};
use crate::coord::FaceCoord;
use crate::dice::DicedMesh;
use crate::exact::ExactTracer;
use crate::patch::PatchTable;
use crate::vec3::{cross, dot, norm, sub};
use rayon::prelude::*;

/// Generalised winding number of the closed triangle mesh `d` around `p`, in `f64`
/// (sum of signed solid angles, Van Oosterom and Strackee 1983, over 4π): 1 inside a closed
/// counter-clockwise mesh (−1 for a clockwise one), 0 outside.
pub fn winding_number(d: &DicedMesh, p: [f64; 3]) -> f64 {
    let total: f64 = d
        .triangles
        .par_iter()
        .with_min_len(4096)
        .map(|t| {
            let [a, b, c] = t.map(|i| {
                let q = d.positions[i as usize];
                [q[0] as f64 - p[0], q[1] as f64 - p[1], q[2] as f64 - p[2]]
            });
            let (la, lb, lc) = (norm(a), norm(b), norm(c));
            let num = dot(a, cross(b, c));
            if num == 0.0 {
                // p in the triangle's plane (or a degenerate triangle): no solid angle;
                // atan2(±0, negative) would give a spurious ±π.
                return 0.0;
            }
            let den = la * lb * lc + dot(a, b) * lc + dot(a, c) * lb + dot(b, c) * la;
            2.0 * num.atan2(den)
        })
        .sum();
    total / (4.0 * std::f64::consts::PI)
}

/// Up to `n` points inside the closed diced mesh `d`: centroids of random triangles moved
/// inwards along the triangle normal by `depth` (at least 8 ulps of the coordinates), kept
/// only if their winding number is ±1 within 1e-6 (−1: a mesh wound clockwise). Off the
/// surface the winding number of a closed mesh is an integer to ~1e-12; a fractional value
/// means the point lies on the surface (possible far from the origin, where the mesh is only
/// a few float steps thick), and such a point is rejected.
/// Deterministic in `seed`.
pub fn inside_origins(d: &DicedMesh, n: usize, depth: f64, seed: u64) -> Vec<[f32; 3]> {
    let mut rng = SplitMix64(seed);
    let mut out = Vec::new();
    if d.triangles.is_empty() {
        return out;
    }
    for _ in 0..n * 4 {
        if out.len() == n {
            break;
        }
        let t = d.triangles[rng.below(d.triangles.len())];
        let [a, b, c] = t.map(|i| d.positions[i as usize].map(|x| x as f64));
        let centroid: [f64; 3] = std::array::from_fn(|k| (a[k] + b[k] + c[k]) / 3.0);
        let ng = cross(sub(b, a), sub(c, a));
        let l = norm(ng);
        if l == 0.0 {
            continue;
        }
        let ulp = centroid.iter().fold(0.0f64, |m, x| m.max(x.abs())) * f32::EPSILON as f64;
        // Inwards is against the normal of a counter-clockwise mesh, along it otherwise; a
        // shape only a few float steps thick (far from the origin) needs a shorter step.
        'found: for step in [depth.max(8.0 * ulp), depth.max(2.0 * ulp), ulp] {
            for sign in [-1.0, 1.0] {
                let p: [f64; 3] = std::array::from_fn(|k| centroid[k] + sign * ng[k] / l * step);
                let p32 = p.map(|x| x as f32);
                let w = winding_number(d, p32.map(|x| x as f64));
                if (w.abs() - 1.0).abs() < 1e-6 {
                    out.push(p32);
                    break 'found;
                }
            }
        }
    }
    out
}

/// `n` directions uniform on the sphere, deterministic in `seed`.
pub fn sphere_dirs(n: usize, seed: u64) -> Vec<[f32; 3]> {
    let mut rng = SplitMix64(seed);
    (0..n)
        .map(|_| {
            let z = 2.0 * rng.next_f64() - 1.0;
            let phi = 2.0 * std::f64::consts::PI * rng.next_f64();
            let r = (1.0 - z * z).max(0.0).sqrt();
            [(r * phi.cos()) as f32, (r * phi.sin()) as f32, z as f32]
        })
        .collect()
}

/// Rays from `origin` aimed exactly at every vertex of `d` and at the midpoint of every
/// triangle edge, at most `limit` of them (evenly strided).
pub fn aimed_rays(d: &DicedMesh, origin: [f32; 3], limit: usize) -> Vec<Ray> {
    let mut targets: Vec<[f32; 3]> = d.positions.clone();
    for t in &d.triangles {
        for k in 0..3 {
            let (a, b) = (
                d.positions[t[k] as usize],
                d.positions[t[(k + 1) % 3] as usize],
            );
            targets.push(std::array::from_fn(|i| a[i] + 0.5 * (b[i] - a[i])));
        }
    }
    let stride = targets.len().div_ceil(limit.max(1)).max(1);
    targets
        .iter()
        .step_by(stride)
        .filter_map(|p| {
            let dir = [p[0] - origin[0], p[1] - origin[1], p[2] - origin[2]];
            (dir != [0.0; 3]).then_some(Ray::new(origin, dir))
        })
        .collect()
}

/// Misses among rays from inside: closest-hit and any-hit queries that find nothing.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct LeakCount {
    /// Rays cast.
    pub rays: usize,
    /// Closest-hit queries that missed.
    pub missed: usize,
    /// Any-hit queries that missed.
    pub missed_any: usize,
}

/// Casts `rays` (all from inside a closed mesh) with both query kinds and counts misses.
pub fn count_leaks<T: Intersect + ?Sized>(bvh: &T, rays: &[Ray]) -> LeakCount {
    let (missed, missed_any) = rays
        .par_iter()
        .with_min_len(1024)
        .map(|r| {
            (
                bvh.intersect(r).is_none() as usize,
                (!bvh.occluded(r)) as usize,
            )
        })
        .reduce(|| (0, 0), |a, b| (a.0 + b.0, a.1 + b.1));
    LeakCount {
        rays: rays.len(),
        missed,
        missed_any,
    }
}

/// Accuracy of diced hits against the exact limit surface.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Accuracy {
    /// Rays that hit both the diced surface and the exact one (the reference intersector's
    /// first hit).
    pub samples: usize,
    /// Rays that hit one of the two and miss the other (near silhouettes at coarse rates).
    pub disagree: usize,
    /// Rays whose exact answer is grazing (undecided pieces within `err` of the ray).
    pub grazing: usize,
    /// Largest `|hit point − P(face,k,u,v)|` (the reported parameters' surface point).
    pub max_param: f64,
    /// Mean of the same.
    pub mean_param: f64,
    /// Largest distance along the ray between the diced hit and the exact intersection.
    pub max_surface: f64,
    /// Mean of the same.
    pub mean_surface: f64,
    /// Largest ratio of the distance between the hit point and the surface point at its
    /// reported parameters (which bounds its distance to the surface) over the hit
    /// triangle's dicing error bound (see [`triangle_error_bound`]).
    pub max_bound_ratio: f64,
}

/// Order of the barycentric lattice on which [`triangle_error_bound`] samples a triangle.
const LATTICE: usize = 16;

/// The dicing error bound of diced triangle `tri`: the largest distance between the exact
/// surface at a parameter point and the triangle's linear interpolant there, sampled on the
/// order-16 barycentric lattice (153 points), times 1.1. Between lattice points (spacing
/// 1/16 of the triangle) a smooth error function, which vanishes at the corners, rises by at
/// most ~1/256 of its curvature term above its sampled maximum; 10% covers that.
pub fn triangle_error_bound(table: &PatchTable, d: &DicedMesh, tri: usize) -> f64 {
    triangle_error_bound_with(&|at| table.eval(at).ok().map(|s| s.p), d, tri)
}

/// [`triangle_error_bound`] against any surface `point(at)` over the triangle's parameters
/// that is smooth at 1/16 of the triangle.
pub fn triangle_error_bound_with(
    point: &dyn Fn(FaceCoord) -> Option<[f64; 3]>,
    d: &DicedMesh,
    tri: usize,
) -> f64 {
    triangle_error_bound_order(point, d, tri, LATTICE)
}

/// Most samples per triangle edge of [`displaced_triangle_error_bound`] (8,385 points).
const MAX_LATTICE: usize = 128;

/// The dicing error bound of diced triangle `tri` against the displaced surface `s`: as
/// [`triangle_error_bound`], on a lattice fine enough for the displacement's detail, four
/// samples per noise cell or texel the triangle's longest edge crosses
/// ([`crate::dice::DisplacedSurface::detail_across`]), at least 16 and at most 128 per edge.
/// A displacement whose detail is finer than the triangle (an image of random texels at a low
/// rate) is then sampled where it varies, not assumed smooth at 1/16 of the triangle.
pub fn displaced_triangle_error_bound(
    s: &crate::dice::DisplacedSurface,
    d: &DicedMesh,
    tri: usize,
) -> f64 {
    let info = &d.tri_info[tri];
    let uv = info.uv.map(|p| [p[0] as f64, p[1] as f64]);
    let detail = s.detail_across(info.face, info.k, uv).unwrap_or(0.0);
    let order = (4.0 * detail)
        .ceil()
        .clamp(LATTICE as f64, MAX_LATTICE as f64) as usize;
    triangle_error_bound_order(&|at| s.point(at).ok(), d, tri, order)
}

/// [`triangle_error_bound_with`] on the barycentric lattice of order `order`.
pub fn triangle_error_bound_order(
    point: &dyn Fn(FaceCoord) -> Option<[f64; 3]>,
    d: &DicedMesh,
    tri: usize,
    order: usize,
) -> f64 {
    let info = &d.tri_info[tri];
    let [a, b, c] = d.triangles[tri].map(|i| d.positions[i as usize].map(|x| x as f64));
    let uv = info.uv.map(|p| [p[0] as f64, p[1] as f64]);
    let mut worst = 0.0f64;
    for i in 0..=order {
        for j in 0..=order - i {
            let (l1, l2) = (i as f64 / order as f64, j as f64 / order as f64);
            let l0 = 1.0 - l1 - l2;
            let u = l0 * uv[0][0] + l1 * uv[1][0] + l2 * uv[2][0];
            let v = l0 * uv[0][1] + l1 * uv[1][1] + l2 * uv[2][1];
            let Some(p) = point(FaceCoord::new(info.face, info.k, u, v)) else {
                continue;
            };
            let lin: [f64; 3] = std::array::from_fn(|k| l0 * a[k] + l1 * b[k] + l2 * c[k]);
            worst = worst.max(norm(sub(p, lin)));
        }
    }
    worst * 1.1
}

/// Measures [`Accuracy`] over `n` random rays aimed from outside at random diced triangles
/// (deterministic in `seed`), against the reference intersector `exact`'s first hits on the
/// same rays. The control mesh's diagonal scales the distance of the ray origins.
pub fn accuracy(exact: &ExactTracer, bvh: &MeshBvh, n: usize, seed: u64) -> Accuracy {
    let table = exact.table();
    let diag = exact.diagonal();
    let d = &bvh.diced;
    if d.triangles.is_empty() {
        return Accuracy::default();
    }
    let rays = rays_from_above(d, n, seed, diag);
    // Per ray: (diced hit's parameter error, distance along the ray to the exact first hit,
    // bound ratio) when both hit; otherwise whether they disagree; and whether it grazes.
    type Row = (Option<(f64, Option<(f64, f64)>)>, bool, bool);
    let per: Vec<Row> = rays
        .par_iter()
        .map(|ray| {
            // The reference answers for the very ray the diced mesh traced (f32, widened).
            let x = exact.trace(&ray.into());
            let grazing = x.graze.is_some() || x.hit.is_some_and(|h| h.grazing);
            let Some(h) = bvh.intersect(ray) else {
                return (None, x.hit.is_some(), grazing);
            };
            let o = ray.origin.map(|x| x as f64);
            let dir = ray.dir.map(|x| x as f64);
            let hp: [f64; 3] = std::array::from_fn(|k| o[k] + h.t as f64 * dir[k]);
            let Ok(s) = table.eval(FaceCoord::new(h.face, h.k, h.u as f64, h.v as f64)) else {
                return (None, false, grazing);
            };
            let param_err = norm(sub(hp, s.p));
            match x.hit {
                Some(e) => {
                    let along = (e.t - h.t as f64).abs() * norm(dir);
                    let bound = triangle_error_bound(table, d, h.triangle as usize);
                    // Rounding: f32 vertices, f32 t along a ray from an f32 origin.
                    let mag = hp.iter().chain(&o).fold(0.0f64, |m, v| m.max(v.abs()));
                    let slack = 8.0 * mag * f32::EPSILON as f64;
                    let ratio = param_err / (bound + slack);
                    (Some((param_err, Some((along, ratio)))), false, grazing)
                }
                None => (Some((param_err, None)), true, grazing),
            }
        })
        .collect();
    let mut acc = Accuracy::default();
    let mut count_param = 0usize;
    for (both, disagree, grazing) in per {
        acc.disagree += disagree as usize;
        acc.grazing += grazing as usize;
        let Some((p, exact_hit)) = both else { continue };
        count_param += 1;
        acc.max_param = acc.max_param.max(p);
        acc.mean_param += p;
        if let Some((along, ratio)) = exact_hit {
            acc.samples += 1;
            acc.max_surface = acc.max_surface.max(along);
            acc.mean_surface += along;
            acc.max_bound_ratio = acc.max_bound_ratio.max(ratio);
        }
    }
    acc.mean_param /= count_param.max(1) as f64;
    acc.mean_surface /= acc.samples.max(1) as f64;
    acc
}

/// `n` rays aimed from outside at random points of random triangles of `d` (deterministic in
/// `seed`), from half a diagonal `diag` away, 30° to 90° above the triangle.
fn rays_from_above(d: &DicedMesh, n: usize, seed: u64, diag: f64) -> Vec<Ray> {
    let mut rng = SplitMix64(seed);
    (0..n)
        .map(|_| {
            let t = d.triangles[rng.below(d.triangles.len())];
            let (mut w1, mut w2) = (rng.next_f64(), rng.next_f64());
            if w1 + w2 > 1.0 {
                (w1, w2) = (1.0 - w1, 1.0 - w2);
            }
            let [a, b, c] = t.map(|i| d.positions[i as usize].map(|x| x as f64));
            let target: [f64; 3] =
                std::array::from_fn(|k| a[k] + w1 * (b[k] - a[k]) + w2 * (c[k] - a[k]));
            let ng = cross(sub(b, a), sub(c, a));
            let l = norm(ng).max(f64::MIN_POSITIVE);
            // Origin in the hemisphere above the triangle, 30° to 90° elevation.
            let z = 0.5 + 0.5 * rng.next_f64();
            let phi = 2.0 * std::f64::consts::PI * rng.next_f64();
            let r = (1.0 - z * z).sqrt();
            let n = ng.map(|x| x / l);
            let (tu, tv) = basis(n);
            let dir: [f64; 3] =
                std::array::from_fn(|k| n[k] * z + tu[k] * r * phi.cos() + tv[k] * r * phi.sin());
            let o: [f64; 3] = std::array::from_fn(|k| target[k] + dir[k] * 0.5 * diag);
            Ray::new(
                o.map(|x| x as f32),
                std::array::from_fn(|k| (target[k] - o[k]) as f32),
            )
        })
        .collect()
}

/// The largest ratio, over `n` rays aimed at random diced triangles (as [`accuracy`] aims
/// them), of a hit's distance from `point` at the hit's reported parameters over its
/// triangle's error bound `bound(triangle)` (against `point`: [`triangle_error_bound_with`],
/// [`displaced_triangle_error_bound`]) plus the rounding of an `f32` hit; and how many rays
/// hit. For surfaces without a reference intersector (displaced ones): the hit parameters are
/// as good as the dicing's own bound says.
pub fn bound_ratio(
    point: &(dyn Fn(FaceCoord) -> Option<[f64; 3]> + Sync),
    bound: &(dyn Fn(usize) -> f64 + Sync),
    bvh: &MeshBvh,
    n: usize,
    seed: u64,
    diag: f64,
) -> (f64, usize) {
    let d = &bvh.diced;
    if d.triangles.is_empty() {
        return (0.0, 0);
    }
    let rays = rays_from_above(d, n, seed, diag);
    let per: Vec<Option<f64>> = rays
        .par_iter()
        .map(|ray| {
            let h = bvh.intersect(ray)?;
            let o = ray.origin.map(|x| x as f64);
            let dir = ray.dir.map(|x| x as f64);
            let hp: [f64; 3] = std::array::from_fn(|k| o[k] + h.t as f64 * dir[k]);
            let p = point(FaceCoord::new(h.face, h.k, h.u as f64, h.v as f64))?;
            let bound = bound(h.triangle as usize);
            let mag = hp.iter().chain(&o).fold(0.0f64, |m, v| m.max(v.abs()));
            let slack = 8.0 * mag * f32::EPSILON as f64;
            Some(norm(sub(hp, p)) / (bound + slack))
        })
        .collect();
    let hits = per.iter().flatten().count();
    (per.into_iter().flatten().fold(0.0, f64::max), hits)
}

fn basis(n: [f64; 3]) -> ([f64; 3], [f64; 3]) {
    let a = if n[0].abs() > 0.9 {
        [0.0, 1.0, 0.0]
    } else {
        [1.0, 0.0, 0.0]
    };
    let u = cross(n, a);
    let l = norm(u);
    let u = u.map(|x| x / l);
    (u, cross(n, u))
}
