//! Side-by-side benchmark: limitray (patch table + dicing + CWBVH), Embree on the same
//! triangles, and Embree's own subdivision geometry at the same rate, on the same rays (plus
//! Embree's triangles with `RTC_SCENE_FLAG_ROBUST`, for the leak counts).
//!
//! Every engine is timed inside one rayon pool of `threads` threads (Embree's build threads
//! limited to the same number through its device configuration); timings are medians of
//! `reps` repetitions, taken in rounds: each round builds every engine once, then traces each
//! set of rays with every engine in turn, with a pause after each build for its threads to go
//! idle. A slow stretch of a shared machine then falls on all engines of a round alike, and
//! [`EngineResult::samples`] keeps every repetition for ratios of the same round. Leak counts
//! use [`rays::towards_points`]: rays from just behind the surface through diced vertices and
//! points on diced edges, away from the mesh boundary, so every one of them must hit; each
//! miss is a leak. They are counted with the mesh where it is
//! and translated to [`FAR_OFFSET`] (large coordinates stress float precision).

use super::crosscheck::embree_table;
use super::rays::{self, LeakTarget, TestRay};
use super::subdiv::{check_rate, subdivision_scene_noise};
use super::triangles::triangle_scene;
use super::{Device, Scene, SceneOptions};
use crate::bvh::{MeshBvh, Ray, Ray64};
use crate::dice::{dice, DiceOptions, DiceRate, Displacement};
use crate::error::{Error, ErrorKind, Result};
use crate::exact::ExactTracer;
use crate::grid::GridMesh;
use crate::mesh::ControlMesh;
use rayon::prelude::*;
use std::collections::HashMap;
use std::time::Instant;

/// Where the translated copy for the second leak count goes (as in `../shared/DESIGN.md`).
pub const FAR_OFFSET: [f64; 3] = [148376.0, 1234.0, -223423.0];

/// Settings of [`bench()`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BenchOptions {
    /// Uniform rate: limitray's dicing rate and Embree's tessellation rate.
    pub rate: u32,
    /// Rays per measurement (coherent and incoherent each).
    pub rays: usize,
    /// Threads (0: all available).
    pub threads: usize,
    /// Repetitions of every measurement (medians are reported).
    pub reps: usize,
    /// Rays per leak count.
    pub leak_rays: usize,
    /// Seed of the random rays.
    pub seed: u64,
    /// Noise displacement `(amplitude, frequency)` of both engines' surfaces: limitray's
    /// dicing ([`crate::dice::Displacement::Noise`]) and Embree's displacement callback
    /// ([`super::subdiv::subdivision_geometry_noise`]); the triangle scenes take limitray's
    /// displaced triangles, and the reference intersector (undisplaced surfaces only) is left
    /// out.
    pub displace: Option<(f64, f64)>,
    /// Whether limitray's grid core stores shading normals ([`GridMesh::dice`]) or is built
    /// for tracing alone ([`GridMesh::dice_geometry`], as Embree's engines here: their hits
    /// carry the geometric normal only).
    pub shading_normals: bool,
}

impl Default for BenchOptions {
    fn default() -> Self {
        BenchOptions {
            rate: 16,
            rays: 1_000_000,
            threads: 0,
            reps: 3,
            leak_rays: 100_000,
            seed: 1,
            displace: None,
            shading_normals: true,
        }
    }
}

/// Results of one engine.
#[derive(Clone, Debug, PartialEq)]
pub struct EngineResult {
    /// `limitray` (the grid core), `limitray-triangles` (the diced triangles under one
    /// CWBVH, the core before grids), `embree-triangles`, `embree-subdiv`,
    /// `embree-tri-robust` (the same triangles with `RTC_SCENE_FLAG_ROBUST`) or
    /// `limitray-exact` (the reference intersector on the exact limit surface, in f64,
    /// whatever the rate).
    pub name: &'static str,
    /// Median build time in seconds (for limitray: patch table + dicing + grid blocks and
    /// top level, from the control mesh; for Embree triangles: scene from the already diced
    /// triangles; for Embree subdivision: geometry and scene commit from the control mesh).
    pub build_s: f64,
    /// Bytes the queries use: limitray's structures as they count them, Embree's as its
    /// memory monitor saw its allocations grow during the build (buffers included).
    pub bytes: Option<usize>,
    /// Any-hit (occlusion) queries per second on the incoherent rays, median.
    pub anyhit_rays_per_s: f64,
    /// Parts of the build (median seconds), where there are several.
    pub build_parts: Vec<(&'static str, f64)>,
    /// Coherent (camera) rays per second, median.
    pub coherent_rays_per_s: f64,
    /// Incoherent rays per second, median.
    pub incoherent_rays_per_s: f64,
    /// Camera rays that hit.
    pub coherent_hits: usize,
    /// Incoherent rays that hit.
    pub incoherent_hits: usize,
    /// Leaks of the leak rays, mesh in place.
    pub leaks: usize,
    /// Leaks of the leak rays, mesh translated to [`FAR_OFFSET`].
    pub leaks_far: usize,
    /// For `limitray-exact` alone: of its far leaks, the rays that miss the limit surface
    /// itself ([`far_misses_off_surface`]). The leak rays aim at points of the diced
    /// triangles, which far from the origin are `f32` points up to half an `f32` step
    /// (0.0078 at [`FAR_OFFSET`]) off the surface, so some rays pass beside it. What is left,
    /// `leaks_far` minus these, is what the distance from the origin cost the intersector.
    pub far_misses_off_surface: Option<usize>,
    /// Every repetition's measurement, in the order they were taken (the figures above are
    /// their medians): build seconds, and coherent, incoherent and any-hit rays per second.
    /// Repetition `r` of every engine was taken in the same round `r` of the interleaved
    /// schedule ([`bench()`]), so ratios of the same repetition pair measurements taken
    /// seconds apart.
    pub samples: Samples,
}

/// Per-repetition measurements of one engine ([`EngineResult::samples`]).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Samples {
    /// Build seconds.
    pub build_s: Vec<f64>,
    /// Coherent rays per second.
    pub coherent: Vec<f64>,
    /// Incoherent rays per second.
    pub incoherent: Vec<f64>,
    /// Any-hit queries per second.
    pub anyhit: Vec<f64>,
}

/// Everything [`bench()`] measures.
#[derive(Clone, Debug, PartialEq)]
pub struct BenchReport {
    /// Control faces.
    pub faces: usize,
    /// Diced triangles (limitray and Embree triangles).
    pub triangles: usize,
    /// Settings used (threads resolved).
    pub options: BenchOptions,
    /// Camera image size for the coherent rays.
    pub camera: (usize, usize),
    /// Leak rays in each count.
    pub leak_rays: usize,
    /// Embree version.
    pub embree_version: u32,
    /// limitray, Embree triangles, Embree subdivision, Embree robust triangles.
    pub engines: Vec<EngineResult>,
}

impl BenchReport {
    /// One JSON object per engine: `engine`, `build_ms`, `coherent_mrays_s`,
    /// `incoherent_mrays_s`, `anyhit_mrays_s`, `bytes_per_triangle`, `leaks`, `leaks_far`
    /// (and `far_misses_off_surface`, [`EngineResult::far_misses_off_surface`]), with the
    /// run's settings (`mesh` is added by the CLI) and the build's parts.
    pub fn json_lines(&self) -> Vec<serde_json::Value> {
        self.engines
            .iter()
            .map(|e| {
                let parts: serde_json::Map<String, serde_json::Value> = e
                    .build_parts
                    .iter()
                    .map(|(k, v)| (format!("{k}_ms"), serde_json::json!(v * 1e3)))
                    .collect();
                serde_json::json!({
                    "engine": e.name,
                    "build_ms": e.build_s * 1e3,
                    "build_parts": parts,
                    "coherent_mrays_s": e.coherent_rays_per_s * 1e-6,
                    "incoherent_mrays_s": e.incoherent_rays_per_s * 1e-6,
                    "anyhit_mrays_s": e.anyhit_rays_per_s * 1e-6,
                    "bytes": e.bytes,
                    "bytes_per_triangle": e.bytes.map(|b| b as f64 / self.triangles.max(1) as f64),
                    "coherent_hits": e.coherent_hits,
                    "incoherent_hits": e.incoherent_hits,
                    "leaks": e.leaks,
                    "leaks_far": e.leaks_far,
                    "far_misses_off_surface": e.far_misses_off_surface,
                    "leak_rays": self.leak_rays,
                    "faces": self.faces,
                    "triangles": self.triangles,
                    "rate": self.options.rate,
                    "rays": self.options.rays,
                    "threads": self.options.threads,
                    "reps": self.options.reps,
                    "displace": self.options.displace.map(|(a, f)| [a, f]),
                    "shading_normals": self.options.shading_normals,
                    "camera": [self.camera.0, self.camera.1],
                    "samples": {
                        "build_ms": scaled(&e.samples.build_s, 1e3),
                        "coherent_mrays_s": scaled(&e.samples.coherent, 1e-6),
                        "incoherent_mrays_s": scaled(&e.samples.incoherent, 1e-6),
                        "anyhit_mrays_s": scaled(&e.samples.anyhit, 1e-6),
                    },
                    "far_offset": FAR_OFFSET,
                    "embree_version": self.embree_version,
                })
            })
            .collect()
    }

    /// A plain-text table: one row per engine, ratios against limitray.
    pub fn table(&self) -> String {
        let mut s = format!(
            "faces {}  triangles {}  rate {}  threads {}  rays {} (camera {}x{})  reps {} (medians)  Embree {}\n",
            self.faces,
            self.triangles,
            self.options.rate,
            self.options.threads,
            self.options.rays,
            self.camera.0,
            self.camera.1,
            self.options.reps,
            self.embree_version
        );
        if let Some((a, f)) = self.options.displace {
            s.push_str(&format!(
                "displaced by noise: amplitude {a}, frequency {f} (both engines)\n"
            ));
        }
        s.push_str(&format!(
            "{:<18} {:>10} {:>14} {:>14} {:>12} {:>8} {:>9} {:>9} {:>9} {:>9} {:>11}\n",
            "engine",
            "build ms",
            "coherent Mr/s",
            "incoher. Mr/s",
            "any-hit Mr/s",
            "B/tri",
            "build x",
            "coh. x",
            "incoh. x",
            "any x",
            "leaks/far"
        ));
        let base = &self.engines[0];
        for e in &self.engines {
            let per_tri = e.bytes.map_or("-".to_string(), |b| {
                format!("{:.1}", b as f64 / self.triangles.max(1) as f64)
            });
            s.push_str(&format!(
                "{:<18} {:>10.1} {:>14.3} {:>14.3} {:>12.3} {:>8} {:>9.2} {:>9.2} {:>9.2} {:>9.2} {:>5}/{:<5}\n",
                e.name,
                e.build_s * 1e3,
                e.coherent_rays_per_s * 1e-6,
                e.incoherent_rays_per_s * 1e-6,
                e.anyhit_rays_per_s * 1e-6,
                per_tri,
                e.build_s / base.build_s,
                e.coherent_rays_per_s / base.coherent_rays_per_s,
                e.incoherent_rays_per_s / base.incoherent_rays_per_s,
                e.anyhit_rays_per_s / base.anyhit_rays_per_s,
                e.leaks,
                e.leaks_far
            ));
        }
        s.push_str(&format!(
            "ratios are engine / limitray (build: lower is faster; rays: higher is faster); leaks of {} rays each\n",
            self.leak_rays
        ));
        for e in &self.engines {
            if let Some(off) = e.far_misses_off_surface {
                s.push_str(&format!(
                    "{}: {off} of its {} far leaks miss the limit surface itself (aimed at f32 points off it)\n",
                    e.name, e.leaks_far
                ));
            }
        }
        s
    }
}

/// `v`'s values times `k` (seconds to milliseconds, rays per second to millions).
fn scaled(v: &[f64], k: f64) -> Vec<f64> {
    v.iter().map(|x| x * k).collect()
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    if v.is_empty() {
        f64::NAN
    } else {
        v[v.len() / 2]
    }
}

/// Whether the rounded point `p` lies on segment `ab` within 1e-3 of its length (far from the
/// origin, rounding moves points on edges by a good part of a micro-triangle).
fn on_segment(p: [f32; 3], a: [f32; 3], b: [f32; 3]) -> bool {
    let (p, a, b) = (p.map(f64::from), a.map(f64::from), b.map(f64::from));
    let ab: [f64; 3] = std::array::from_fn(|k| b[k] - a[k]);
    let ap: [f64; 3] = std::array::from_fn(|k| p[k] - a[k]);
    let len2 = ab[0] * ab[0] + ab[1] * ab[1] + ab[2] * ab[2];
    if len2 == 0.0 {
        return false;
    }
    let c = rays::cross(ab, ap);
    let dist2 = (c[0] * c[0] + c[1] * c[1] + c[2] * c[2]) / len2;
    dist2 <= 1e-6 * len2
}

/// Leak-ray targets of a diced mesh: one vertex and one random point on one edge of every
/// triangle, except on control faces that touch a boundary vertex (or a hole) of `mesh`.
///
/// Vertices are welded by position bits (infinitely sharp features duplicate vertices with the
/// same position). For each welded vertex the cone of its triangles' unit normals is bounded:
/// axis = normalised sum, half-angle `c` = largest angle of a normal to the axis; the target's
/// directions may tilt `78° - c` (at most 60°) from the axis, so every triangle normal stays
/// within 78° of the ray. Vertices whose cone is wider than 48° are skipped. An edge point
/// uses the sum of both ends' axes and a conservative bound of the combined cone, and is kept
/// only if its `f32` rounding leaves it within 1e-3 of the edge's length from the edge.
pub fn leak_targets(mesh: &ControlMesh, bvh: &MeshBvh, seed: u64) -> Vec<LeakTarget> {
    let mut edge_count: HashMap<(u32, u32), u32> = HashMap::new();
    for f in 0..mesh.num_faces() {
        let fv = mesh.face(f);
        for i in 0..fv.len() {
            let (a, b) = (fv[i], fv[(i + 1) % fv.len()]);
            *edge_count.entry((a.min(b), a.max(b))).or_default() += 1;
        }
    }
    let mut boundary = vec![false; mesh.num_vertices()];
    for (&(a, b), &c) in &edge_count {
        if c != 2 {
            boundary[a as usize] = true;
            boundary[b as usize] = true;
        }
    }
    for &h in &mesh.holes {
        for &v in mesh.face(h as usize) {
            boundary[v as usize] = true;
        }
    }
    let excluded: Vec<bool> = (0..mesh.num_faces())
        .map(|f| mesh.face(f).iter().any(|&v| boundary[v as usize]))
        .collect();

    let d = &bvh.diced;
    // Weld by position bits.
    let key = |i: usize| d.positions[i].map(f32::to_bits);
    let mut order: Vec<u32> = (0..d.positions.len() as u32).collect();
    order.par_sort_unstable_by_key(|&i| key(i as usize));
    let mut weld = vec![0u32; d.positions.len()];
    let mut id = 0u32;
    for (j, &i) in order.iter().enumerate() {
        if j > 0 && key(i as usize) != key(order[j - 1] as usize) {
            id += 1;
        }
        weld[i as usize] = id;
    }
    let nw = if order.is_empty() { 0 } else { id as usize + 1 };
    drop(order);
    let tri_normal = |t: &[u32; 3]| -> Option<[f64; 3]> {
        let p = t.map(|i| d.positions[i as usize].map(|c| c as f64));
        let n = rays::cross(
            std::array::from_fn(|k| p[1][k] - p[0][k]),
            std::array::from_fn(|k| p[2][k] - p[0][k]),
        );
        let l = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
        (l > 0.0).then(|| n.map(|c| c / l))
    };
    let normals: Vec<Option<[f64; 3]>> = d.triangles.par_iter().map(tri_normal).collect();
    let mut axis = vec![[0.0f64; 3]; nw];
    let mut degenerate = vec![false; nw];
    for (t, n) in d.triangles.iter().zip(&normals) {
        for &v in t {
            let w = weld[v as usize] as usize;
            match n {
                Some(n) => {
                    for k in 0..3 {
                        axis[w][k] += n[k];
                    }
                }
                None => degenerate[w] = true,
            }
        }
    }
    for a in &mut axis {
        let l = (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt();
        if l > 0.0 {
            *a = a.map(|c| c / l);
        }
    }
    // Half-angle of each cone.
    let mut cone = vec![0.0f64; nw];
    for (t, n) in d.triangles.iter().zip(&normals) {
        if let Some(n) = n {
            for &v in t {
                let w = weld[v as usize] as usize;
                let dot =
                    (n[0] * axis[w][0] + n[1] * axis[w][1] + n[2] * axis[w][2]).clamp(-1.0, 1.0);
                cone[w] = cone[w].max(dot.acos());
            }
        }
    }
    let limit = 78f64.to_radians();
    let widest = 48f64.to_radians();
    let angle = |a: [f64; 3], b: [f64; 3]| {
        (a[0] * b[0] + a[1] * b[1] + a[2] * b[2])
            .clamp(-1.0, 1.0)
            .acos()
    };
    let mut targets = Vec::new();
    let mut rng = rays::SplitMix64::new(seed);
    for (t, info) in d.triangles.iter().zip(&d.tri_info) {
        if excluded[info.face as usize] {
            continue;
        }
        let i = rng.below(3);
        let (a, b) = (t[i] as usize, t[(i + 1) % 3] as usize);
        let (wa, wb) = (weld[a] as usize, weld[b] as usize);
        let s = rng.next_f64() as f32;
        if degenerate[wa] || degenerate[wb] {
            continue;
        }
        if cone[wa] <= widest {
            targets.push(LeakTarget {
                point: d.positions[a],
                normal: axis[wa],
                max_tilt: (limit - cone[wa]).min(60f64.to_radians()),
            });
        }
        let sum: [f64; 3] = std::array::from_fn(|k| axis[wa][k] + axis[wb][k]);
        let l = (sum[0] * sum[0] + sum[1] * sum[1] + sum[2] * sum[2]).sqrt();
        if l == 0.0 {
            continue;
        }
        let ax = sum.map(|c| c / l);
        let c = (cone[wa] + angle(axis[wa], ax)).max(cone[wb] + angle(axis[wb], ax));
        let p: [f32; 3] = std::array::from_fn(|k| {
            d.positions[a][k] + s * (d.positions[b][k] - d.positions[a][k])
        });
        if c <= widest && on_segment(p, d.positions[a], d.positions[b]) {
            targets.push(LeakTarget {
                point: p,
                normal: ax,
                max_tilt: (limit - c).min(60f64.to_radians()),
            });
        }
    }
    targets
}

trait Engine: Sync {
    fn hit(&self, r: &TestRay) -> bool;
    fn occluded(&self, r: &TestRay) -> bool;
}

impl Engine for MeshBvh {
    fn hit(&self, r: &TestRay) -> bool {
        self.intersect(&Ray::new(r.origin, r.dir)).is_some()
    }
    fn occluded(&self, r: &TestRay) -> bool {
        MeshBvh::occluded(self, &Ray::new(r.origin, r.dir))
    }
}

impl Engine for GridMesh {
    fn hit(&self, r: &TestRay) -> bool {
        self.intersect(&Ray::new(r.origin, r.dir)).is_some()
    }
    fn occluded(&self, r: &TestRay) -> bool {
        GridMesh::occluded(self, &Ray::new(r.origin, r.dir))
    }
}

impl Engine for ExactTracer {
    fn hit(&self, r: &TestRay) -> bool {
        self.trace(&Ray64::new(r.origin.map(f64::from), r.dir.map(f64::from)))
            .hit
            .is_some()
    }
    fn occluded(&self, r: &TestRay) -> bool {
        self.hit(r)
    }
}

/// The reference intersector of `mesh`, built `reps` times: the last one, and the seconds of
/// its patch table and of its pieces and hierarchy, per repetition.
fn build_exact(mesh: &ControlMesh, reps: usize) -> Result<(ExactTracer, [Vec<f64>; 2])> {
    let mut times: [Vec<f64>; 2] = Default::default();
    let mut last = None;
    for _ in 0..reps.max(1) {
        drop(last.take());
        let t0 = Instant::now();
        let table = std::sync::Arc::new(embree_table(mesh)?);
        let t1 = Instant::now();
        let tracer = ExactTracer::new(table, mesh)?;
        let t2 = Instant::now();
        times[0].push((t1 - t0).as_secs_f64());
        times[1].push((t2 - t1).as_secs_f64());
        last = Some(tracer);
    }
    let tracer = last.expect("at least one repetition");
    Ok((tracer, times))
}

impl Engine for Scene {
    fn hit(&self, r: &TestRay) -> bool {
        self.intersect(r.origin, r.dir, 0.0, f32::INFINITY)
            .is_some()
    }
    fn occluded(&self, r: &TestRay) -> bool {
        Scene::occluded(self, r.origin, r.dir, 0.0, f32::INFINITY)
    }
}

fn trace(engine: &dyn Engine, rays: &[TestRay], any: bool) -> (f64, usize) {
    let t0 = Instant::now();
    let hits = rays
        .par_iter()
        .with_min_len(256)
        .filter(|r| {
            if any {
                engine.occluded(r)
            } else {
                engine.hit(r)
            }
        })
        .count();
    (t0.elapsed().as_secs_f64(), hits)
}

fn leaks(engine: &dyn Engine, rays: &[TestRay]) -> usize {
    rays.len() - trace(engine, rays, false).1
}

/// How many of `rays` `far` (the reference intersector of the mesh at [`FAR_OFFSET`]) misses
/// (its far leaks), and how many of those miss the limit surface itself: the ray moved back
/// by [`FAR_OFFSET`] is a certain miss (no hit, no graze) of `near`, the same mesh in place
/// (each ray traced far once, and in place only where it missed). The move is exact (the
/// offset is a whole number, the origin an `f32`: their difference is an `f32` too), and the
/// two surfaces differ only by the rounding of the far control points (about 3e-11 at this
/// offset), far below any tolerance here. A far miss that `near` hits is a leak that distance
/// caused.
pub fn far_misses_off_surface(
    far: &ExactTracer,
    near: &ExactTracer,
    rays: &[TestRay],
) -> (usize, usize) {
    rays.par_iter()
        .with_min_len(64)
        .filter(|r| !far.hit(r))
        .map(|r| {
            let o: [f64; 3] = std::array::from_fn(|k| f64::from(r.origin[k]) - FAR_OFFSET[k]);
            let t = near.trace(&Ray64::new(o, r.dir.map(f64::from)));
            (1, usize::from(t.hit.is_none() && t.graze.is_none()))
        })
        .reduce(|| (0, 0), |a, b| (a.0 + b.0, a.1 + b.1))
}

/// limitray's two diced structures.
struct Limitray {
    grid: GridMesh,
    tris: MeshBvh,
}

/// Builds [`Limitray`] once, with the seconds of each part: patch table, dicing into the grid
/// core's blocks, the grid core's strips and top level (the grid core's build,
/// [`GridMesh::dice`]), full dicing, triangle BVH (the triangle BVH's).
fn build_limitray(
    mesh: &ControlMesh,
    rate: u32,
    displace: Option<(f64, f64)>,
    shading_normals: bool,
) -> Result<(Limitray, [f64; 5])> {
    let options = DiceOptions {
        rate: DiceRate::Uniform(rate),
        displace: displace.map(|(amplitude, frequency)| Displacement::Noise {
            amplitude,
            frequency,
        }),
        ..DiceOptions::default()
    };
    let t0 = Instant::now();
    let table = embree_table(mesh)?;
    let t1 = Instant::now();
    let (grid, t2) = GridMesh::dice_staged(&table, mesh, &options, None, shading_normals)?;
    let t3 = Instant::now();
    // The triangle BVH needs the full diced mesh (every triangle's record).
    let diced = dice(&table, mesh, &options)?;
    drop(table);
    let t4 = Instant::now();
    let tris = MeshBvh::build(diced);
    let t5 = Instant::now();
    let parts =
        [(t0, t1), (t1, t2), (t2, t3), (t3, t4), (t4, t5)].map(|(a, b)| (b - a).as_secs_f64());
    Ok((Limitray { grid, tris }, parts))
}

/// Embree's three scenes, with the bytes each added to the device.
struct Embree {
    tris: Scene,
    sub: Scene,
    robust: Scene,
    bytes: [usize; 3],
}

/// Builds [`Embree`] once (its triangle scenes from limitray's diced triangles `diced`), with
/// the seconds of each scene's build.
fn build_embree(
    mesh: &ControlMesh,
    diced: &crate::dice::DicedMesh,
    rate: u32,
    device: &Device,
    displace: Option<(f64, f64)>,
) -> Result<(Embree, [f64; 3])> {
    let m0 = device.memory_bytes();
    let t0 = Instant::now();
    let tris = triangle_scene(device, diced, SceneOptions::default())?;
    let t1 = Instant::now();
    let m1 = device.memory_bytes();
    let sub = subdivision_scene_noise(
        device,
        mesh,
        mesh.options.boundary,
        rate as f32,
        SceneOptions::default(),
        displace,
    )?;
    let t2 = Instant::now();
    let m2 = device.memory_bytes();
    let robust = triangle_scene(
        device,
        diced,
        SceneOptions {
            robust: true,
            ..SceneOptions::default()
        },
    )?;
    let t3 = Instant::now();
    let m3 = device.memory_bytes();
    let parts = [(t0, t1), (t1, t2), (t2, t3)].map(|(a, b)| (b - a).as_secs_f64());
    let bytes = [m1 - m0, m2 - m1, m3 - m2].map(|b| b.max(0) as usize);
    Ok((
        Embree {
            tris,
            sub,
            robust,
            bytes,
        },
        parts,
    ))
}

/// Lets the threads of the build that just ended go to sleep before anything is timed: Embree's
/// build workers (TBB) and rayon's spin for a moment after their last task, and a spinning
/// worker would take a core from the next engine's measurement.
fn settle() {
    std::thread::sleep(std::time::Duration::from_millis(50));
}

/// Runs the side-by-side benchmark on `mesh`.
pub fn bench(mesh: &ControlMesh, opts: &BenchOptions) -> Result<BenchReport> {
    check_rate(opts.rate as f32)?;
    if opts.rays == 0 || opts.reps == 0 {
        return Err(Error::new(
            ErrorKind::Usage,
            "--rays and --reps must be at least 1",
        ));
    }
    let threads = if opts.threads == 0 {
        std::thread::available_parallelism().map_or(1, |n| n.get())
    } else {
        opts.threads
    };
    let pool = crate::threads::pool(threads)?;
    let opts = BenchOptions { threads, ..*opts };
    pool.install(|| bench_in_pool(mesh, &opts))
}

fn bench_in_pool(mesh: &ControlMesh, opts: &BenchOptions) -> Result<BenchReport> {
    let bounds = mesh.bounds();
    let camera = rays::camera_size(opts.rays);
    let coherent = rays::camera(bounds, camera.0, camera.1);
    let incoherent = rays::incoherent(bounds, opts.rays, opts.seed);
    let diag = mesh.diagonal();
    let depth = 0.05 * diag;
    let reps = opts.reps.max(1);
    let device = Device::with_threads(opts.threads)?;

    // The builds, round by round: limitray's structures, then Embree's scenes (its triangle
    // scenes take limitray's diced triangles); each engine's previous build is freed just
    // before its next one, so that both engines build after a large free, as before.
    let (mut lr, mut em) = (None, None);
    let mut lr_parts: [Vec<f64>; 5] = Default::default();
    let mut em_parts: [Vec<f64>; 3] = Default::default();
    for _ in 0..reps {
        drop(lr.take());
        let (l, p) = build_limitray(mesh, opts.rate, opts.displace, opts.shading_normals)?;
        settle();
        drop(em.take());
        let (e, q) = build_embree(mesh, &l.tris.diced, opts.rate, &device, opts.displace)?;
        settle();
        for (v, x) in lr_parts.iter_mut().zip(p) {
            v.push(x);
        }
        for (v, x) in em_parts.iter_mut().zip(q) {
            v.push(x);
        }
        (lr, em) = (Some(l), Some(e));
    }
    let (lr, em): (Limitray, Embree) = (
        lr.expect("at least one repetition"),
        em.expect("at least one repetition"),
    );
    // The reference intersector (it does not depend on the rate; it traces undisplaced
    // surfaces only).
    let exact = match opts.displace {
        None => Some(build_exact(mesh, reps)?),
        Some(_) => None,
    };
    settle();
    let targets = leak_targets(mesh, &lr.tris, opts.seed);
    let leak_rays = rays::towards_points(&targets, depth, opts.leak_rays, opts.seed ^ 0x1EA4);
    let triangles = lr.tris.diced.triangles.len();

    let p = &lr_parts;
    let sum = |parts: &[usize]| -> Vec<f64> {
        (0..reps)
            .map(|r| parts.iter().map(|&i| p[i][r]).sum())
            .collect()
    };
    let med = |v: &Vec<f64>| median(v.clone());
    struct Entry<'a> {
        name: &'static str,
        engine: &'a dyn Engine,
        build_s: Vec<f64>,
        parts: Vec<(&'static str, f64)>,
        bytes: Option<usize>,
    }
    let mut entries = vec![
        Entry {
            name: "limitray",
            engine: &lr.grid,
            build_s: sum(&[0, 1, 2]),
            parts: vec![
                ("patch_table", med(&p[0])),
                ("dice", med(&p[1])),
                ("grid", med(&p[2])),
            ],
            bytes: Some(lr.grid.bytes()),
        },
        Entry {
            name: "limitray-triangles",
            engine: &lr.tris,
            build_s: sum(&[0, 3, 4]),
            parts: vec![
                ("patch_table", med(&p[0])),
                ("dice", med(&p[3])),
                ("bvh", med(&p[4])),
            ],
            bytes: Some(lr.tris.bytes() - lr.tris.diced.bytes()),
        },
    ];
    let names = ["embree-triangles", "embree-subdiv", "embree-tri-robust"];
    let scenes: [&dyn Engine; 3] = [&em.tris, &em.sub, &em.robust];
    for (i, (name, engine)) in names.into_iter().zip(scenes).enumerate() {
        entries.push(Entry {
            name,
            engine,
            build_s: em_parts[i].clone(),
            parts: vec![],
            bytes: Some(em.bytes[i]),
        });
    }
    if let Some((exact, [table_s, pieces_s])) = &exact {
        entries.push(Entry {
            name: "limitray-exact",
            engine: exact,
            build_s: (0..reps).map(|r| table_s[r] + pieces_s[r]).collect(),
            parts: vec![("patch_table", med(table_s)), ("pieces", med(pieces_s))],
            bytes: None,
        });
    }

    // The rays, interleaved: in each round, each set of rays is traced by every engine in
    // turn (the first engine of a round moves on by one each round), so that each engine's
    // repetition `r` is taken within seconds of the others' and a slow stretch of a shared
    // machine falls on all engines alike, not on whichever ran then.
    let sets: [(&[TestRay], bool); 3] = [
        (&coherent, false),
        (&incoherent, false),
        (&incoherent, true),
    ];
    let n = entries.len();
    let mut speeds = vec![[Vec::new(), Vec::new(), Vec::new()]; n];
    let mut hits = vec![[0usize; 2]; n];
    for round in 0..reps {
        for (k, &(rays, any)) in sets.iter().enumerate() {
            for i in 0..n {
                let e = (i + round) % n;
                let (t, h) = trace(entries[e].engine, rays, any);
                speeds[e][k].push(rays.len() as f64 / t);
                if let Some(slot) = hits[e].get_mut(k) {
                    *slot = h;
                }
            }
        }
    }
    let mut results: Vec<EngineResult> = entries
        .iter()
        .zip(speeds)
        .zip(&hits)
        .map(|((e, [coherent, incoherent, anyhit]), h)| EngineResult {
            name: e.name,
            build_s: med(&e.build_s),
            bytes: e.bytes,
            build_parts: e.parts.clone(),
            coherent_rays_per_s: med(&coherent),
            incoherent_rays_per_s: med(&incoherent),
            anyhit_rays_per_s: med(&anyhit),
            coherent_hits: h[0],
            incoherent_hits: h[1],
            leaks: leaks(e.engine, &leak_rays),
            leaks_far: 0,
            far_misses_off_surface: None,
            samples: Samples {
                build_s: e.build_s.clone(),
                coherent,
                incoherent,
                anyhit,
            },
        })
        .collect();
    drop(entries);
    drop((em, lr, coherent, incoherent));

    // The translated copy, for the far leak count (built after the first is freed).
    let mut far = mesh.clone();
    for p in &mut far.positions {
        for k in 0..3 {
            p[k] += FAR_OFFSET[k];
        }
    }
    let (far_lr, _) = build_limitray(&far, opts.rate, opts.displace, opts.shading_normals)?;
    let far_targets = leak_targets(&far, &far_lr.tris, opts.seed);
    let far_rays = rays::towards_points(&far_targets, depth, opts.leak_rays, opts.seed ^ 0x1EA4);
    results[0].leaks_far = leaks(&far_lr.grid, &far_rays);
    results[1].leaks_far = leaks(&far_lr.tris, &far_rays);
    let (far_em, _) = build_embree(&far, &far_lr.tris.diced, opts.rate, &device, opts.displace)?;
    drop(far_lr);
    let far_engines: [&dyn Engine; 3] = [&far_em.tris, &far_em.sub, &far_em.robust];
    for (r, engine) in results[2..5].iter_mut().zip(far_engines) {
        r.leaks_far = leaks(engine, &far_rays);
    }
    drop(far_em);
    if let (Some(r), Some((near_exact, _))) = (results.get_mut(5), &exact) {
        let (far_exact, _) = build_exact(&far, 1)?;
        let (missed, off) = far_misses_off_surface(&far_exact, near_exact, &far_rays);
        (r.leaks_far, r.far_misses_off_surface) = (missed, Some(off));
    }
    Ok(BenchReport {
        faces: mesh.num_faces(),
        triangles,
        options: *opts,
        camera,
        leak_rays: leak_rays.len(),
        embree_version: device.version(),
        engines: results,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `far_misses_off_surface` counts a far miss only where the same ray, moved back by
    /// `FAR_OFFSET`, misses the mesh in place too: rays along `z` beside a box (at a `y`
    /// beyond its limit surface) miss it far and in place, so all are counted; the same far
    /// misses checked against the box scaled three times, which those rays meet, count none.
    #[test]
    fn far_misses_are_checked_in_place() {
        let mesh = crate::mesh::shapes::rounded_box(2.0);
        let mut far = mesh.clone();
        let mut big = mesh.clone();
        for (p, q) in far.positions.iter_mut().zip(&mut big.positions) {
            for k in 0..3 {
                p[k] += FAR_OFFSET[k];
                q[k] *= 3.0;
            }
        }
        let [lo, hi] = mesh.bounds();
        // Whole and half units: the origins are `f32` far and in place, exactly.
        let y = (hi[1] + 0.5).ceil();
        let z = (lo[2] - 2.0).floor();
        let rays: Vec<TestRay> = (0..16)
            .map(|i| {
                let x = lo[0] + (hi[0] - lo[0]) * (i as f64 + 0.5) / 16.0;
                let x = (x * 8.0).round() / 8.0;
                let o = [x, y, z];
                TestRay {
                    origin: std::array::from_fn(|k| (o[k] + FAR_OFFSET[k]) as f32),
                    dir: [0.0, 0.0, 1.0],
                }
            })
            .collect();
        for r in &rays {
            let o: [f64; 3] = std::array::from_fn(|k| f64::from(r.origin[k]) - FAR_OFFSET[k]);
            assert!(o[1] == y && o[2] == z, "{o:?}");
        }
        let (far_exact, _) = build_exact(&far, 1).unwrap();
        let (near_exact, _) = build_exact(&mesh, 1).unwrap();
        let (big_exact, _) = build_exact(&big, 1).unwrap();
        assert_eq!(
            leaks(&far_exact, &rays),
            rays.len(),
            "the rays miss the far box"
        );
        let n = rays.len();
        assert_eq!(
            far_misses_off_surface(&far_exact, &near_exact, &rays),
            (n, n)
        );
        assert_eq!(
            far_misses_off_surface(&far_exact, &big_exact, &rays),
            (n, 0)
        );
    }
}
