//! Lights for next-event estimation: quad (parallelogram) area lights, emissive meshes and the
//! environment, with a light-selection distribution proportional to each light's estimated
//! irradiance at a point of interest (see [`Lights::new`]).
//!
//! Quad lights emit on one side, the side of `edge1 × edge2`; emissive meshes emit on both
//! sides of every triangle. All densities returned here are w.r.t. solid angle at the shaded
//! point and include the probability of selecting the light.

use super::env::Environment;
use super::sampling::{uniform_triangle, Distribution1D};
use glam::Vec3;

/// A parallelogram area light `corner + s·edge1 + t·edge2`, `s, t ∈ [0, 1]`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct QuadLight {
    /// One corner.
    pub corner: Vec3,
    /// First edge.
    pub edge1: Vec3,
    /// Second edge.
    pub edge2: Vec3,
    /// Unit normal `normalize(edge1 × edge2)`: the emitting side.
    pub normal: Vec3,
    /// Area.
    pub area: f32,
    /// Emitted radiance.
    pub radiance: Vec3,
}

impl QuadLight {
    /// A quad light; `None` when the edges are degenerate.
    pub fn new(corner: Vec3, edge1: Vec3, edge2: Vec3, radiance: Vec3) -> Option<QuadLight> {
        let n = edge1.cross(edge2);
        let area = n.length();
        if !(area > 0.0 && area.is_finite()) {
            return None;
        }
        Some(QuadLight {
            corner,
            edge1,
            edge2,
            normal: n / area,
            area,
            radiance,
        })
    }

    /// Ray parameter of the hit with the ray `o + t·d`, `t ∈ (0, tmax)`, either side.
    pub fn intersect(&self, o: Vec3, d: Vec3, tmax: f32) -> Option<f32> {
        let n = self.edge1.cross(self.edge2);
        let denom = d.dot(n);
        if denom == 0.0 {
            return None;
        }
        let t = (self.corner - o).dot(n) / denom;
        if !(t > 0.0 && t < tmax) {
            return None;
        }
        let w = o + d * t - self.corner;
        let nn = n.dot(n);
        let a = w.cross(self.edge2).dot(n) / nn;
        let b = self.edge1.cross(w).dot(n) / nn;
        if (0.0..=1.0).contains(&a) && (0.0..=1.0).contains(&b) {
            Some(t)
        } else {
            None
        }
    }
}

/// An emissive mesh instance as world-space triangles.
#[derive(Clone, Debug, PartialEq)]
pub struct MeshLight {
    /// Scene instance the triangles belong to.
    pub instance: u32,
    /// World-space triangles.
    pub triangles: Vec<[Vec3; 3]>,
    /// Triangle choice by area.
    pub dist: Distribution1D,
    /// Total area.
    pub area: f32,
    /// Emitted radiance.
    pub radiance: Vec3,
}

impl MeshLight {
    /// From world-space triangles; `None` when the total area is zero.
    pub fn new(instance: u32, triangles: Vec<[Vec3; 3]>, radiance: Vec3) -> Option<MeshLight> {
        let areas: Vec<f32> = triangles
            .iter()
            .map(|t| 0.5 * (t[1] - t[0]).cross(t[2] - t[0]).length())
            .collect();
        let area: f64 = areas
            .iter()
            .filter(|a| a.is_finite())
            .map(|&a| a as f64)
            .sum();
        if area <= 0.0 {
            return None;
        }
        Some(MeshLight {
            instance,
            dist: Distribution1D::new(&areas),
            triangles,
            area: area as f32,
            radiance,
        })
    }
}

/// A light sample seen from a shading point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LightSample {
    /// Unit direction from the shading point to the light.
    pub wi: Vec3,
    /// Point on the light (unused for the environment).
    pub point: Vec3,
    /// Unit normal of the light at `point`, facing the shading point (zero for the environment).
    pub normal: Vec3,
    /// Distance to `point` (infinite for the environment).
    pub dist: f32,
    /// Radiance arriving from the light.
    pub li: Vec3,
    /// Solid-angle density, including the selection probability.
    pub pdf: f32,
}

/// Which light a sample or a hit refers to.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LightId {
    /// Index into [`Lights::quads`].
    Quad(u32),
    /// Index into [`Lights::meshes`].
    Mesh(u32),
    /// The environment.
    Env,
}

/// All lights of a scene.
#[derive(Clone, Debug, PartialEq)]
pub struct Lights {
    /// Quad area lights.
    pub quads: Vec<QuadLight>,
    /// Emissive mesh instances.
    pub meshes: Vec<MeshLight>,
    /// The environment, if any (black otherwise).
    pub env: Option<Environment>,
    /// Selection distribution over quads, then meshes, then the environment.
    pub select: Distribution1D,
    /// For each scene instance, its mesh light (index into `meshes`), if emissive.
    pub instance_light: Vec<Option<u32>>,
}

fn luminance(c: Vec3) -> f32 {
    0.2126 * c.x + 0.7152 * c.y + 0.0722 * c.z
}

impl Lights {
    /// Collects the lights; `num_instances` sizes the instance → light table and `reference`
    /// is a point of interest (the camera's look-at point) for the selection weights.
    ///
    /// Selection weights estimate each light's irradiance at `reference`: `π · luminance` of
    /// the environment's mean; `luminance · area · cos / d²` for a quad light (cos of its normal
    /// towards `reference`, at least 0.1; `d²` at least the area); `luminance · area / d²` for
    /// an emissive mesh (`d` from its area-weighted centroid, `d²` at least the area).
    pub fn new(
        quads: Vec<QuadLight>,
        meshes: Vec<MeshLight>,
        env: Option<Environment>,
        num_instances: usize,
        reference: Vec3,
    ) -> Lights {
        let mut w: Vec<f32> = quads
            .iter()
            .map(|q| {
                let c = q.corner + (q.edge1 + q.edge2) * 0.5;
                let d = reference - c;
                let d2 = d.length_squared().max(q.area);
                let cos = (d.normalize_or_zero().dot(q.normal)).max(0.1);
                luminance(q.radiance).max(0.0) * q.area * cos / d2
            })
            .chain(meshes.iter().map(|m| {
                let mut centroid = Vec3::ZERO;
                for (t, &p) in m.triangles.iter().zip(&m.dist.pmf) {
                    centroid += (t[0] + t[1] + t[2]) * (p / 3.0);
                }
                let d2 = (reference - centroid).length_squared().max(m.area);
                luminance(m.radiance).max(0.0) * m.area / d2
            }))
            .collect();
        if let Some(e) = &env {
            w.push(std::f32::consts::PI * luminance(e.mean()).max(0.0));
        }
        // Every light keeps a floor of 1% of the mean weight, so no light is starved.
        let total: f32 = w.iter().sum();
        if total > 0.0 {
            let floor = 0.01 * total / w.len() as f32;
            for x in &mut w {
                *x = x.max(floor);
            }
        }
        let mut instance_light = vec![None; num_instances];
        for (i, m) in meshes.iter().enumerate() {
            if let Some(slot) = instance_light.get_mut(m.instance as usize) {
                *slot = Some(i as u32);
            }
        }
        Lights {
            select: Distribution1D::new(&w),
            quads,
            meshes,
            env,
            instance_light,
        }
    }

    /// Whether there is nothing to sample.
    pub fn is_empty(&self) -> bool {
        self.select.is_empty()
    }

    fn slot(&self, id: LightId) -> usize {
        match id {
            LightId::Quad(i) => i as usize,
            LightId::Mesh(i) => self.quads.len() + i as usize,
            LightId::Env => self.quads.len() + self.meshes.len(),
        }
    }

    /// Probability of selecting light `id`.
    pub fn select_pmf(&self, id: LightId) -> f32 {
        self.select.pmf.get(self.slot(id)).copied().unwrap_or(0.0)
    }

    /// Samples a light as seen from `p` with selection number `u_sel` and position sample
    /// `(u1, u2)`. `None` when nothing can be sampled or the sample faces away.
    pub fn sample(&self, p: Vec3, u_sel: f32, u1: f32, u2: f32) -> Option<LightSample> {
        if self.is_empty() {
            return None;
        }
        let (slot, pmf, _) = self.select.sample(u_sel);
        if pmf <= 0.0 {
            return None;
        }
        let nq = self.quads.len();
        let nm = self.meshes.len();
        if slot < nq {
            let q = &self.quads[slot];
            let point = q.corner + q.edge1 * u1 + q.edge2 * u2;
            let (wi, dist, cos_l) = towards(p, point, q.normal)?;
            // One-sided: the shading point must be on the emitting side.
            if cos_l <= 0.0 {
                return None;
            }
            let pdf = pmf * dist * dist / (cos_l * q.area);
            return Some(LightSample {
                wi,
                point,
                normal: q.normal,
                dist,
                li: q.radiance,
                pdf,
            });
        }
        if slot < nq + nm {
            let m = &self.meshes[slot - nq];
            let (ti, _, rem) = m.dist.sample(u1);
            let t = m.triangles[ti];
            let (b1, b2) = uniform_triangle(rem, u2);
            let point = t[0] * (1.0 - b1 - b2) + t[1] * b1 + t[2] * b2;
            let ng = (t[1] - t[0]).cross(t[2] - t[0]).normalize_or_zero();
            let (wi, dist, cos_l) = towards(p, point, ng)?;
            let cos_l = cos_l.abs();
            if cos_l <= 0.0 {
                return None;
            }
            let normal = if ng.dot(wi) < 0.0 { ng } else { -ng };
            let pdf = pmf * dist * dist / (cos_l * m.area);
            return Some(LightSample {
                wi,
                point,
                normal,
                dist,
                li: m.radiance,
                pdf,
            });
        }
        let env = self.env.as_ref()?;
        let (wi, li, pdf) = env.sample(u1, u2);
        if pdf <= 0.0 {
            return None;
        }
        Some(LightSample {
            wi,
            point: Vec3::ZERO,
            normal: Vec3::ZERO,
            dist: f32::INFINITY,
            li,
            pdf: pdf * pmf,
        })
    }

    /// Density (solid angle at the shading point, with selection) with which
    /// [`Lights::sample`] would produce a point at distance `dist` in unit direction `wi` on a
    /// surface light, `cos_l` the cosine between `wi` and the light's normal there.
    pub fn pdf_area_light(&self, id: LightId, dist: f32, cos_l: f32) -> f32 {
        let area = match id {
            LightId::Quad(i) => self.quads[i as usize].area,
            LightId::Mesh(i) => self.meshes[i as usize].area,
            LightId::Env => return 0.0,
        };
        let c = cos_l.abs();
        if c <= 0.0 {
            return 0.0;
        }
        self.select_pmf(id) * dist * dist / (c * area)
    }

    /// Density with which [`Lights::sample`] produces environment direction `wi`.
    pub fn pdf_env(&self, wi: Vec3) -> f32 {
        match &self.env {
            Some(e) => self.select_pmf(LightId::Env) * e.pdf(wi),
            None => 0.0,
        }
    }

    /// Nearest quad light hit by `o + t·d` with `t < tmax`: `(t, index)`.
    pub fn intersect_quads(&self, o: Vec3, d: Vec3, tmax: f32) -> Option<(f32, u32)> {
        let mut best: Option<(f32, u32)> = None;
        let mut tm = tmax;
        for (i, q) in self.quads.iter().enumerate() {
            if let Some(t) = q.intersect(o, d, tm) {
                tm = t;
                best = Some((t, i as u32));
            }
        }
        best
    }
}

/// `(unit direction p → q, distance, cos between the direction and n)`; `None` when `q = p`.
fn towards(p: Vec3, q: Vec3, n: Vec3) -> Option<(Vec3, f32, f32)> {
    let d = q - p;
    let dist = d.length();
    if !(dist > 0.0 && dist.is_finite()) {
        return None;
    }
    let wi = d / dist;
    Some((wi, dist, -wi.dot(n)))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::render::rng::PathRng;

    #[test]
    fn quad_sampling_matches_pdf_and_solid_angle() {
        // A unit square light at height 1 facing down; the estimate of ∫ dω = E[1/pdf] must
        // match the closed-form solid angle.
        let q = QuadLight::new(
            Vec3::new(-0.5, 1.0, -0.5),
            Vec3::new(1.0, 0.0, 0.0),
            Vec3::new(0.0, 0.0, 1.0),
            Vec3::ONE,
        )
        .unwrap();
        assert!((q.normal - Vec3::new(0.0, -1.0, 0.0)).length() < 1e-6);
        let lights = Lights::new(vec![q], vec![], None, 0, Vec3::ZERO);
        let n = 50_000u32;
        let mut est = 0.0f64;
        for i in 0..n {
            let r = PathRng::new(5, i, 0);
            let s = lights
                .sample(Vec3::ZERO, r.get(0), r.get(1), r.get(2))
                .unwrap();
            let (t, _) = lights
                .intersect_quads(Vec3::ZERO, s.wi, f32::INFINITY)
                .unwrap();
            assert!((t - s.dist).abs() < 1e-4);
            let p2 = lights.pdf_area_light(LightId::Quad(0), s.dist, s.wi.dot(q.normal));
            assert!((p2 - s.pdf).abs() < 1e-4 * s.pdf);
            est += 1.0 / s.pdf as f64;
        }
        // Solid angle of a centred a×b rectangle at distance d: 4 asin(ab / sqrt((a²+4d²)(b²+4d²))).
        let want = 4.0 * (1.0f64 / (5.0f64 * 5.0).sqrt()).asin();
        assert!(((est / n as f64) - want).abs() < 0.01 * want);
        // Back side: nothing.
        assert!(lights
            .sample(Vec3::new(0.0, 2.0, 0.0), 0.5, 0.5, 0.5)
            .is_none());
    }

    #[test]
    fn selection_with_environment() {
        let q = QuadLight::new(Vec3::ZERO, Vec3::X, Vec3::Z, Vec3::ONE).unwrap();
        let m = MeshLight::new(3, vec![[Vec3::ZERO, Vec3::X, Vec3::Y]], Vec3::splat(2.0)).unwrap();
        let l = Lights::new(
            vec![q],
            vec![m],
            Some(Environment::Constant(Vec3::ONE)),
            5,
            Vec3::new(0.5, -2.0, 0.5),
        );
        // Quad: 1 · 1 · cos 1 / 4; mesh: 2 · 0.5 / |(0.5,-2,0.5) - (1/3,1/3,0)|²; env: π.
        let wq = 0.25f32;
        let wm = 1.0
            / (Vec3::new(0.5, -2.0, 0.5) - Vec3::new(1.0 / 3.0, 1.0 / 3.0, 0.0)).length_squared();
        let we = std::f32::consts::PI;
        let sum = wq + wm + we;
        assert!((l.select_pmf(LightId::Env) - we / sum).abs() < 1e-6);
        assert!((l.select_pmf(LightId::Quad(0)) - wq / sum).abs() < 1e-6);
        assert_eq!(l.instance_light[3], Some(0));
        assert!(QuadLight::new(Vec3::ZERO, Vec3::X, Vec3::X, Vec3::ONE).is_none());
        assert!(MeshLight::new(0, vec![], Vec3::ONE).is_none());
    }
}
