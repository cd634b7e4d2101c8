//! Cross-checks against Embree 4: the limit surface ([`interpolation_check`],
//! [`surface_check`]) and the triangle intersector / BVH ([`triangle_check`]).
//!
//! Distances are reported relative to the bounding-box diagonal of the control mesh.
//! Embree's subdivision geometry always uses Chaikin's crease rule, so limitray is run in
//! Chaikin mode here (identical results on meshes without semi-sharp creases of varying
//! sharpness).

use super::rays::{self, SplitMix64, TestRay};
use super::subdiv::{embree_uv_to_ptex, ptex_to_embree_uv, subdivision_scene};
use super::{Device, EmbreeHit, Scene, SceneOptions};
// BVH use crate::bvh::{MeshBvh, Ray};
// DICE use crate::dice::{dice, DiceOptions, DiceRate};
use crate::error::Result;
use crate::mesh::{ControlMesh, CreaseMethod, Options};
use crate::patch::{PatchOptions, PatchTable};
use rayon::prelude::*;

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
    pub worst: (u32, u32, f64, f64),
}

impl DistanceStats {
    fn from_samples(samples: &[(f64, (u32, u32, f64, f64))]) -> DistanceStats {
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
    let params: Vec<(u32, u32, f64, f64)> = if faces.is_empty() {
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
    let param_d: Vec<(f64, (u32, u32, f64, f64))> = params
        .par_iter()
        .filter_map(|&(f, k, u, v)| {
            let exact = table.eval(f as usize, k as usize, u, v).ok()?;
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
    let hit_d: Vec<((f64, (u32, u32, f64, f64)), (f64, (u32, u32, f64, f64)))> = hits
        .par_iter()
        .filter_map(|(r, h)| {
            let f = h.prim_id;
            let n = mesh.face(f as usize).len();
            let (k, u, v) = embree_uv_to_ptex(n, h.u, h.v);
            let exact = table.eval(f as usize, k, u, v).ok()?;
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
