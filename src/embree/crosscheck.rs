//! Cross-checks against Embree 4: the limit surface ([`interpolation_check`],
//! [`surface_check_with`]) and the triangle intersector / BVH ([`triangle_check_with`]).
//!
//! Distances are reported relative to the bounding-box diagonal of the control mesh.
//! Embree's subdivision geometry always uses Chaikin's crease rule, so limitray is run in
//! Chaikin mode here (identical results on meshes without semi-sharp creases of varying
//! sharpness).

use super::rays::{self, SplitMix64, TestRay};
use super::subdiv::{embree_uv_to_ptex, ptex_to_embree_uv, subdivision_scene};
use super::{Device, EmbreeHit, Scene, SceneOptions};
use crate::bvh::{MeshBvh, Ray};
use crate::coord::FaceCoord;
use crate::dice::{dice, DiceOptions, DiceRate};
use crate::error::Result;
use crate::mesh::{ControlMesh, CreaseMethod, Options};
use crate::patch::{PatchOptions, PatchTable};
use rayon::prelude::*;

/// Where a sample was taken: `(face, k, u, v)`.
pub type At = (u32, u32, f64, f64);

/// A distance and where it was measured.
type Sample = (f64, At);

/// Largest and mean of a set of distances, with where the largest occurred.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct DistanceStats {
    /// Number of samples.
    pub count: usize,
    /// Largest distance (relative to the diagonal).
    pub max: f64,
    /// Mean distance (relative to the diagonal).
    pub mean: f64,
    /// `(face, k, u, v)` of the largest.
    pub worst: At,
}

impl DistanceStats {
    fn from_samples(samples: &[Sample]) -> DistanceStats {
        let mut s = DistanceStats {
            count: samples.len(),
            ..DistanceStats::default()
        };
        let mut sum = 0.0;
        for &(d, at) in samples {
            sum += d;
            if d > s.max || s.max.is_nan() {
                s.max = d;
                s.worst = at;
            }
        }
        if !samples.is_empty() {
            s.mean = sum / samples.len() as f64;
        }
        s
    }

    /// JSON object.
    pub fn json(&self) -> serde_json::Value {
        serde_json::json!({
            "count": self.count,
            "max": self.max,
            "mean": self.mean,
            "worst": {"face": self.worst.0, "k": self.worst.1, "u": self.worst.2, "v": self.worst.3},
        })
    }
}

/// Embree's limit surface (`rtcInterpolate`) against limitray's exact evaluation.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct InterpolationReport {
    /// Bounding-box diagonal of the control mesh.
    pub diagonal: f64,
    /// Random parameters `(face, k, u, v)`: `rtcInterpolate` at the corresponding Embree
    /// `(u, v)` against `PatchTable::eval`.
    pub params: DistanceStats,
    /// Rays shot at Embree's subdivision geometry.
    pub rays: usize,
    /// How many of them hit.
    pub embree_hits: usize,
    /// At each hit's `(primID, u, v)`: `rtcInterpolate` against `PatchTable::eval` at the
    /// mapped ptex parameters.
    pub hits: DistanceStats,
    /// At each hit: the hit point `origin + t dir` against the exact limit point at the mapped
    /// parameters (Embree's tessellation error plus any parameter drift).
    pub hit_points: DistanceStats,
}

impl InterpolationReport {
    /// JSON object.
    pub fn json(&self) -> serde_json::Value {
        serde_json::json!({
            "diagonal": self.diagonal,
            "params": self.params.json(),
            "rays": self.rays,
            "embree_hits": self.embree_hits,
            "hits": self.hits.json(),
            "hit_points": self.hit_points.json(),
        })
    }
}

fn dist(a: [f64; 3], b: [f64; 3]) -> f64 {
    ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
}

fn f64x3(p: [f32; 3]) -> [f64; 3] {
    p.map(|c| c as f64)
}

/// limitray's options for comparing with Embree: the mesh's boundary rule, Chaikin creases.
pub fn embree_options(mesh: &ControlMesh) -> Options {
    Options {
        crease_method: CreaseMethod::Chaikin,
        ..mesh.options
    }
}

/// The patch table of `mesh` in the rules Embree implements ([`embree_options`]).
pub fn embree_table(mesh: &ControlMesh) -> Result<PatchTable> {
    PatchTable::with_options(mesh, embree_options(mesh), PatchOptions::default())
}

/// Compares Embree's limit surface with limitray's exact one on `mesh`: `samples` random
/// parameters and `nrays` random rays (seeded), Embree tessellation `rate`.
pub fn interpolation_check(
    mesh: &ControlMesh,
    rate: f32,
    samples: usize,
    nrays: usize,
    seed: u64,
) -> Result<InterpolationReport> {
    let table = embree_table(mesh)?;
    let device = Device::new("")?;
    let scene = subdivision_scene(
        &device,
        mesh,
        mesh.options.boundary,
        rate,
        SceneOptions::default(),
    )?;
    interpolation_check_with(mesh, &table, &scene, samples, nrays, seed)
}

/// [`interpolation_check`] with a prepared table (in Embree's rules) and subdivision scene.
pub fn interpolation_check_with(
    mesh: &ControlMesh,
    table: &PatchTable,
    scene: &Scene,
    samples: usize,
    nrays: usize,
    seed: u64,
) -> Result<InterpolationReport> {
    let diag = mesh.diagonal().max(f64::MIN_POSITIVE);
    let mut holes = vec![false; mesh.num_faces()];
    for &h in &mesh.holes {
        holes[h as usize] = true;
    }
    let faces: Vec<u32> = (0..mesh.num_faces() as u32)
        .filter(|&f| !holes[f as usize])
        .collect();

    // Random parameters.
    let mut rng = SplitMix64::new(seed);
    let params: Vec<At> = if faces.is_empty() {
        Vec::new()
    } else {
        (0..samples)
            .map(|_| {
                let f = faces[rng.below(faces.len())];
                let k = rng.below(table.sub_faces(f as usize)) as u32;
                (f, k, rng.next_f64(), rng.next_f64())
            })
            .collect()
    };
    let param_d: Vec<Sample> = params
        .par_iter()
        .filter_map(|&(f, k, u, v)| {
            let exact = table.eval(FaceCoord::new(f, k, u, v)).ok()?;
            let n = mesh.face(f as usize).len();
            let (eu, ev) = ptex_to_embree_uv(n, k as usize, u, v);
            let e = scene.interpolate(0, f, eu, ev).ok()?;
            Some((dist(f64x3(e.p), exact.p) / diag, (f, k, u, v)))
        })
        .collect();

    // Random rays.
    let rays = rays::incoherent(mesh.bounds(), nrays, seed ^ 0x5EED);
    let hits: Vec<(TestRay, EmbreeHit)> = rays
        .par_iter()
        .filter_map(|r| {
            scene
                .intersect(r.origin, r.dir, 0.0, f32::INFINITY)
                .map(|h| (*r, h))
        })
        .collect();
    let hit_d: Vec<(Sample, Sample)> = hits
        .par_iter()
        .filter_map(|(r, h)| {
            let f = h.prim_id;
            let n = mesh.face(f as usize).len();
            let (k, u, v) = embree_uv_to_ptex(n, h.u, h.v);
            let exact = table.eval(FaceCoord::new(f, k as u32, u, v)).ok()?;
            let e = scene.interpolate(0, f, h.u, h.v).ok()?;
            let at = (f, k as u32, u, v);
            let p: [f64; 3] =
                std::array::from_fn(|i| r.origin[i] as f64 + h.t as f64 * r.dir[i] as f64);
            Some((
                (dist(f64x3(e.p), exact.p) / diag, at),
                (dist(p, exact.p) / diag, at),
            ))
        })
        .collect();
    let (hd, pd): (Vec<_>, Vec<_>) = hit_d.into_iter().unzip();
    Ok(InterpolationReport {
        diagonal: diag,
        params: DistanceStats::from_samples(&param_d),
        rays: nrays,
        embree_hits: hits.len(),
        hits: DistanceStats::from_samples(&hd),
        hit_points: DistanceStats::from_samples(&pd),
    })
}

/// Relative `|Δt|` (to the larger `t`) within which two hits count as the same.
pub const T_TOLERANCE: f64 = 1e-6;

/// A disagreement counts as edge-grazing when a hit lies within this distance of an edge of
/// its triangle, relative to the ray's float scale `max(t, |origin|)` (about 100 ulp).
pub const EDGE_TOLERANCE: f64 = 1e-5;

/// Distance from the point with barycentrics `(1 - b1 - b2, b1, b2)` to the nearest edge of
/// triangle `[a, b, c]`, and the smallest barycentric coordinate.
pub fn edge_distance(tri: [[f32; 3]; 3], b1: f32, b2: f32) -> (f64, f64) {
    let p = tri.map(f64x3);
    let bary = [1.0 - b1 as f64 - b2 as f64, b1 as f64, b2 as f64];
    let sub = |x: [f64; 3], y: [f64; 3]| [x[0] - y[0], x[1] - y[1], x[2] - y[2]];
    let e1 = sub(p[1], p[0]);
    let e2 = sub(p[2], p[0]);
    let cr = [
        e1[1] * e2[2] - e1[2] * e2[1],
        e1[2] * e2[0] - e1[0] * e2[2],
        e1[0] * e2[1] - e1[1] * e2[0],
    ];
    let twice_area = (cr[0] * cr[0] + cr[1] * cr[1] + cr[2] * cr[2]).sqrt();
    let mut d = f64::INFINITY;
    for i in 0..3 {
        // Altitude onto the edge opposite corner i.
        let len = dist(p[(i + 1) % 3], p[(i + 2) % 3]);
        if len > 0.0 {
            d = d.min(bary[i].abs() * twice_area / len);
        }
    }
    let min_b = bary.iter().fold(f64::INFINITY, |m, &b| m.min(b));
    (d, min_b)
}

/// `|cos θ|` between `dir` and the normal of triangle `tri`.
pub fn cos_incidence(tri: [[f32; 3]; 3], dir: [f32; 3]) -> f64 {
    let p = tri.map(f64x3);
    let d = f64x3(dir);
    let e1 = [p[1][0] - p[0][0], p[1][1] - p[0][1], p[1][2] - p[0][2]];
    let e2 = [p[2][0] - p[0][0], p[2][1] - p[0][1], p[2][2] - p[0][2]];
    let n = [
        e1[1] * e2[2] - e1[2] * e2[1],
        e1[2] * e2[0] - e1[0] * e2[2],
        e1[0] * e2[1] - e1[1] * e2[0],
    ];
    let nn = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
    let dd = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
    if nn == 0.0 || dd == 0.0 {
        return 0.0;
    }
    ((n[0] * d[0] + n[1] * d[1] + n[2] * d[2]) / (nn * dd)).abs()
}

/// One disagreement between limitray and Embree on the same triangles.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TriangleDisagreement {
    /// The ray.
    pub ray: TestRay,
    /// limitray's hit: `(triangle, t, b1, b2)`.
    pub limitray: Option<(u32, f32, f32, f32)>,
    /// Embree's hit: `(primID, t, u, v)`.
    pub embree: Option<(u32, f32, f32, f32)>,
    /// Smallest distance of a hit to an edge of its triangle, relative to `max(t, |origin|)`.
    pub edge_distance: f64,
    /// Smallest barycentric coordinate of the hit(s).
    pub min_barycentric: f64,
}

/// limitray's BVH against Embree on the same triangles and rays.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct TriangleReport {
    /// Triangles.
    pub triangles: usize,
    /// Rays.
    pub rays: usize,
    /// Both miss.
    pub both_miss: usize,
    /// Both hit the same triangle with `|Δt| ≤ T_TOLERANCE · t`.
    pub same_hit: usize,
    /// Both hit the same triangle, `|Δt|` beyond `T_TOLERANCE · t` at grazing incidence:
    /// a triangle test's relative error in `t` grows like `ε / |cos θ|`
    /// (`θ` between the ray and the triangle normal).
    pub same_oblique: usize,
    /// Largest `|Δt| · |cos θ| / t` among `same_oblique` (float precision when ≲ 1e-6).
    pub max_dt_cos_oblique: f64,
    /// Largest `|cos θ|` among `same_oblique`.
    pub max_cos_oblique: f64,
    /// Disagreements whose hit(s) lie within [`EDGE_TOLERANCE`] of a triangle edge.
    pub edge_grazing: usize,
    /// Disagreements that are not edge-grazing.
    pub other: usize,
    /// Largest relative `|Δt|` among same-triangle hits.
    pub max_dt_same: f64,
    /// Largest edge distance (relative) among the edge-grazing disagreements.
    pub max_edge_distance_grazing: f64,
    /// Largest |smallest barycentric| among the edge-grazing disagreements.
    pub max_min_barycentric_grazing: f64,
    /// Up to 20 disagreements, the non-grazing ones first.
    pub examples: Vec<TriangleDisagreement>,
}

impl TriangleReport {
    /// Fraction of rays on which both agree: both miss, or both hit the same triangle.
    pub fn agreement(&self) -> f64 {
        if self.rays == 0 {
            1.0
        } else {
            (self.both_miss + self.same_hit + self.same_oblique) as f64 / self.rays as f64
        }
    }

    /// Fraction of rays that both miss or that hit the same triangle with
    /// `|Δt| ≤ T_TOLERANCE · t`.
    pub fn strict_agreement(&self) -> f64 {
        if self.rays == 0 {
            1.0
        } else {
            (self.both_miss + self.same_hit) as f64 / self.rays as f64
        }
    }

    /// JSON object.
    pub fn json(&self) -> serde_json::Value {
        let ex: Vec<serde_json::Value> = self
            .examples
            .iter()
            .map(|d| {
                serde_json::json!({
                    "origin": d.ray.origin, "dir": d.ray.dir,
                    "limitray": d.limitray.map(|h| serde_json::json!({"triangle": h.0, "t": h.1, "b1": h.2, "b2": h.3})),
                    "embree": d.embree.map(|h| serde_json::json!({"triangle": h.0, "t": h.1, "u": h.2, "v": h.3})),
                    "edge_distance": d.edge_distance,
                    "min_barycentric": d.min_barycentric,
                })
            })
            .collect();
        serde_json::json!({
            "triangles": self.triangles,
            "rays": self.rays,
            "agreement": self.agreement(),
            "strict_agreement": self.strict_agreement(),
            "both_miss": self.both_miss,
            "same_hit": self.same_hit,
            "same_oblique": self.same_oblique,
            "max_dt_cos_oblique": self.max_dt_cos_oblique,
            "max_cos_oblique": self.max_cos_oblique,
            "edge_grazing": self.edge_grazing,
            "other": self.other,
            "max_dt_same": self.max_dt_same,
            "max_edge_distance_grazing": self.max_edge_distance_grazing,
            "max_min_barycentric_grazing": self.max_min_barycentric_grazing,
            "examples": ex,
        })
    }
}

enum TriOutcome {
    Miss,
    Same(f64),
    Oblique(f64, f64),
    Grazing(TriangleDisagreement),
    Other(TriangleDisagreement),
}

/// Compares `bvh` with an Embree triangle scene built from `bvh.diced` (geometry 0) on `rays`.
pub fn triangle_check_with(bvh: &MeshBvh, scene: &Scene, rays: &[TestRay]) -> TriangleReport {
    let diced = &bvh.diced;
    let tri = |i: u32| diced.triangles[i as usize].map(|v| diced.positions[v as usize]);
    let outcomes: Vec<TriOutcome> = rays
        .par_iter()
        .with_min_len(256)
        .map(|r| {
            let l = bvh.intersect(&Ray::new(r.origin, r.dir));
            let e = scene.intersect(r.origin, r.dir, 0.0, f32::INFINITY);
            match (l, e) {
                (None, None) => return TriOutcome::Miss,
                (Some(l), Some(e)) if l.triangle == e.prim_id => {
                    let dt = (l.t as f64 - e.t as f64).abs() / (l.t.max(e.t) as f64).max(1e-30);
                    if dt <= T_TOLERANCE {
                        return TriOutcome::Same(dt);
                    }
                    let cos = cos_incidence(tri(l.triangle), r.dir);
                    return TriOutcome::Oblique(dt * cos, cos);
                }
                _ => {}
            }
            let scale = f64x3(r.origin).iter().map(|x| x * x).sum::<f64>().sqrt();
            let mut edge = f64::INFINITY;
            let mut min_b = f64::INFINITY;
            if let Some(l) = l {
                let (d, b) = edge_distance(tri(l.triangle), l.b1, l.b2);
                edge = edge.min(d / scale.max(l.t as f64));
                min_b = min_b.min(b.abs());
            }
            if let Some(e) = e {
                if (e.prim_id as usize) < diced.triangles.len() {
                    let (d, b) = edge_distance(tri(e.prim_id), e.u, e.v);
                    edge = edge.min(d / scale.max(e.t as f64));
                    min_b = min_b.min(b.abs());
                }
            }
            let d = TriangleDisagreement {
                ray: *r,
                limitray: l.map(|h| (h.triangle, h.t, h.b1, h.b2)),
                embree: e.map(|h| (h.prim_id, h.t, h.u, h.v)),
                edge_distance: edge,
                min_barycentric: min_b,
            };
            if edge <= EDGE_TOLERANCE {
                TriOutcome::Grazing(d)
            } else {
                TriOutcome::Other(d)
            }
        })
        .collect();
    let mut rep = TriangleReport {
        triangles: diced.triangles.len(),
        rays: rays.len(),
        ..TriangleReport::default()
    };
    let mut grazing = Vec::new();
    for o in outcomes {
        match o {
            TriOutcome::Miss => rep.both_miss += 1,
            TriOutcome::Same(dt) => {
                rep.same_hit += 1;
                rep.max_dt_same = rep.max_dt_same.max(dt);
            }
            TriOutcome::Oblique(dtc, cos) => {
                rep.same_oblique += 1;
                rep.max_dt_cos_oblique = rep.max_dt_cos_oblique.max(dtc);
                rep.max_cos_oblique = rep.max_cos_oblique.max(cos);
            }
            TriOutcome::Grazing(d) => {
                rep.edge_grazing += 1;
                rep.max_edge_distance_grazing = rep.max_edge_distance_grazing.max(d.edge_distance);
                rep.max_min_barycentric_grazing =
                    rep.max_min_barycentric_grazing.max(d.min_barycentric);
                if grazing.len() < 20 {
                    grazing.push(d);
                }
            }
            TriOutcome::Other(d) => {
                rep.other += 1;
                if rep.examples.len() < 20 {
                    rep.examples.push(d);
                }
            }
        }
    }
    let room = 20 - rep.examples.len();
    rep.examples.extend(grazing.into_iter().take(room));
    rep
}

/// The diced mesh and BVH limitray traces for the cross-check: `mesh` in Embree's rules
/// ([`embree_options`]), uniform `rate`.
pub fn limitray_bvh(mesh: &ControlMesh, table: &PatchTable, rate: u32) -> Result<MeshBvh> {
    let diced = dice(
        table,
        mesh,
        &DiceOptions {
            rate: DiceRate::Uniform(rate),
            ..DiceOptions::default()
        },
    )?;
    Ok(MeshBvh::build(diced))
}

/// limitray's diced surface (BVH) against Embree's subdivision geometry at the same rate.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SurfaceReport {
    /// Rays.
    pub rays: usize,
    /// Rays limitray hits.
    pub limitray_hits: usize,
    /// Rays Embree hits.
    pub embree_hits: usize,
    /// Rays on which both hit or both miss.
    pub hit_miss_agree: usize,
    /// Both hit, on the same base face.
    pub same_face: usize,
    /// `|Δt|` of the rays both hit, relative to the diagonal (unit directions).
    pub dt: DistanceStats,
    /// Limit surface: `rtcInterpolate` against exact evaluation.
    pub interpolation: InterpolationReport,
}

impl SurfaceReport {
    /// Fraction of rays on which hit/miss agree.
    pub fn agreement(&self) -> f64 {
        if self.rays == 0 {
            1.0
        } else {
            self.hit_miss_agree as f64 / self.rays as f64
        }
    }

    /// JSON object.
    pub fn json(&self) -> serde_json::Value {
        serde_json::json!({
            "rays": self.rays,
            "limitray_hits": self.limitray_hits,
            "embree_hits": self.embree_hits,
            "hit_miss_agreement": self.agreement(),
            "hit_miss_agree": self.hit_miss_agree,
            "same_face": self.same_face,
            "dt": self.dt.json(),
            "interpolation": self.interpolation.json(),
        })
    }
}

/// Compares the limitray BVH of `mesh` (diced in Embree's rules) with an Embree subdivision
/// scene of the same mesh and rate on `rays`; the interpolation part uses `samples`
/// parameters and the same rays.
pub fn surface_check_with(
    mesh: &ControlMesh,
    table: &PatchTable,
    bvh: &MeshBvh,
    scene: &Scene,
    rays: &[TestRay],
    samples: usize,
    seed: u64,
) -> Result<SurfaceReport> {
    let diag = mesh.diagonal().max(f64::MIN_POSITIVE);
    let pairs: Vec<(bool, bool, Option<Sample>, bool)> = rays
        .par_iter()
        .with_min_len(256)
        .map(|r| {
            let l = bvh.intersect(&Ray::new(r.origin, r.dir));
            let e = scene.intersect(r.origin, r.dir, 0.0, f32::INFINITY);
            let (dt, same) = match (l, e) {
                (Some(l), Some(e)) => (
                    Some((
                        (l.t as f64 - e.t as f64).abs() / diag,
                        (l.face, l.k, l.u as f64, l.v as f64),
                    )),
                    l.face == e.prim_id,
                ),
                _ => (None, false),
            };
            (l.is_some(), e.is_some(), dt, same)
        })
        .collect();
    let dts: Vec<_> = pairs.iter().filter_map(|p| p.2).collect();
    let interpolation = interpolation_check_with(mesh, table, scene, samples, rays.len(), seed)?;
    Ok(SurfaceReport {
        rays: rays.len(),
        limitray_hits: pairs.iter().filter(|p| p.0).count(),
        embree_hits: pairs.iter().filter(|p| p.1).count(),
        hit_miss_agree: pairs.iter().filter(|p| p.0 == p.1).count(),
        same_face: pairs.iter().filter(|p| p.3).count(),
        dt: DistanceStats::from_samples(&dts),
        interpolation,
    })
}

/// Everything `limitray crosscheck` reports.
#[derive(Clone, Debug, PartialEq)]
pub struct CrosscheckReport {
    /// Tessellation rate (limitray uniform dicing rate = Embree tessellation rate).
    pub rate: u32,
    /// Embree version (e.g. 40400).
    pub embree_version: u32,
    /// Subdivision surface comparison.
    pub surface: SurfaceReport,
    /// Same triangles, same rays.
    pub triangles: TriangleReport,
}

impl CrosscheckReport {
    /// JSON object.
    pub fn json(&self) -> serde_json::Value {
        serde_json::json!({
            "rate": self.rate,
            "embree_version": self.embree_version,
            "surface": self.surface.json(),
            "triangles": self.triangles.json(),
        })
    }
}

/// The full cross-check of `mesh` at `rate` with `nrays` incoherent rays (and as many
/// parameter samples for the interpolation check), seeded.
pub fn crosscheck(
    mesh: &ControlMesh,
    rate: u32,
    nrays: usize,
    seed: u64,
) -> Result<CrosscheckReport> {
    super::subdiv::check_rate(rate as f32)?;
    let table = embree_table(mesh)?;
    let bvh = limitray_bvh(mesh, &table, rate)?;
    let device = Device::new("")?;
    let sub = subdivision_scene(
        &device,
        mesh,
        mesh.options.boundary,
        rate as f32,
        SceneOptions::default(),
    )?;
    let tris = super::triangles::triangle_scene(&device, &bvh.diced, SceneOptions::default())?;
    let rays = rays::incoherent(mesh.bounds(), nrays, seed);
    let surface = surface_check_with(mesh, &table, &bvh, &sub, &rays, nrays, seed)?;
    let triangles = triangle_check_with(&bvh, &tris, &rays);
    Ok(CrosscheckReport {
        rate,
        embree_version: device.version(),
        surface,
        triangles,
    })
}
