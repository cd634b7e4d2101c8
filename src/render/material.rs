//! Materials and their BSDFs, evaluated in a local shading frame whose `+z` axis is the shading
//! normal turned towards the outgoing direction `wo` (so `wo.z > 0` always).
//!
//! - diffuse: Lambert;
//! - conductor: GGX microfacets (Trowbridge–Reitz, α = roughness²), Smith height-correlated
//!   masking-shadowing, visible-normal sampling (Heitz 2018), Fresnel from complex `eta + i k`
//!   per RGB channel or Schlick's approximation from a base colour; α below [`DELTA_ALPHA`] is a
//!   perfect mirror;
//! - dielectric: smooth (Fresnel-weighted choice of mirror reflection or refraction) or rough
//!   (Walter et al. 2007 microfacet reflection + transmission with the same GGX machinery);
//! - emissive: emits, does not scatter.
//!
//! Directions are unit vectors pointing away from the surface. `etap` is the relative index of
//! refraction across the surface, seen from `wo`: (index on the far side) / (index on `wo`'s
//! side). Transmitted throughput is scaled by `1 / etap²` (radiance, not importance).

use glam::Vec3;
use std::f32::consts::PI;

/// Below this GGX α a surface is treated as perfectly smooth (a delta BSDF).
pub const DELTA_ALPHA: f32 = 1e-3;

/// Fresnel reflectance model of a conductor.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Fresnel {
    /// Complex index of refraction `eta + i k` per RGB channel (the outside medium has index 1).
    Conductor {
        /// Real part.
        eta: Vec3,
        /// Imaginary part (absorption).
        k: Vec3,
    },
    /// Schlick's approximation from the reflectance at normal incidence.
    Schlick {
        /// Reflectance at normal incidence (the base colour).
        f0: Vec3,
    },
}

/// A surface material.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Material {
    /// Lambertian reflector.
    Diffuse {
        /// Reflectance in `[0, 1]` per channel.
        albedo: Vec3,
    },
    /// Rough (or mirror) metal.
    Conductor {
        /// Fresnel model.
        fresnel: Fresnel,
        /// GGX α (roughness²).
        alpha: f32,
    },
    /// Glass-like interface between the outside (index 1) and the inside (index `ior`).
    Dielectric {
        /// Index of refraction of the inside.
        ior: f32,
        /// GGX α (roughness²); below [`DELTA_ALPHA`] the interface is smooth.
        alpha: f32,
    },
    /// Emitter on both sides; does not scatter light.
    Emissive {
        /// Emitted radiance.
        radiance: Vec3,
    },
}

/// A sampled incident direction.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BsdfSample {
    /// Incident direction (local frame).
    pub wi: Vec3,
    /// `f · |cos θi| / pdf`: what the path throughput is multiplied by.
    pub weight: Vec3,
    /// Solid-angle density of `wi` (0 for delta lobes).
    pub pdf: f32,
    /// Whether the lobe is a delta distribution (no light sampling can produce it).
    pub delta: bool,
}

impl Material {
    /// Whether every lobe is a delta distribution (next-event estimation is pointless).
    pub fn is_delta(&self) -> bool {
        match *self {
            Material::Conductor { alpha, .. } | Material::Dielectric { alpha, .. } => {
                alpha < DELTA_ALPHA
            }
            _ => false,
        }
    }

    /// Whether light can pass through the surface (the shading frame must then not be flipped
    /// to the viewer's side without changing `etap`).
    pub fn is_transmissive(&self) -> bool {
        matches!(self, Material::Dielectric { .. })
    }

    /// Emitted radiance (zero except for emissive materials).
    pub fn emission(&self) -> Vec3 {
        match *self {
            Material::Emissive { radiance } => radiance,
            _ => Vec3::ZERO,
        }
    }

    /// The colour written to the `albedo` AOV: diffuse albedo, a conductor's reflectance at
    /// normal incidence, 1 for dielectrics, 0 for emitters.
    pub fn albedo(&self) -> Vec3 {
        match *self {
            Material::Diffuse { albedo } => albedo,
            Material::Conductor { fresnel, .. } => fresnel_eval(fresnel, 1.0),
            Material::Dielectric { .. } => Vec3::ONE,
            Material::Emissive { .. } => Vec3::ZERO,
        }
    }

    /// BSDF value `f(wo, wi)` (without the cosine) and the density with which
    /// [`Material::sample`] produces `wi`. Delta lobes contribute nothing here.
    pub fn eval(&self, wo: Vec3, wi: Vec3, etap: f32) -> (Vec3, f32) {
        if wo.z <= 0.0 {
            return (Vec3::ZERO, 0.0);
        }
        match *self {
            Material::Diffuse { albedo } => {
                if wi.z <= 0.0 {
                    (Vec3::ZERO, 0.0)
                } else {
                    (albedo * (1.0 / PI), wi.z * (1.0 / PI))
                }
            }
            Material::Conductor { fresnel, alpha } => {
                if alpha < DELTA_ALPHA || wi.z <= 0.0 {
                    return (Vec3::ZERO, 0.0);
                }
                let h = wo + wi;
                if h.length_squared() <= 0.0 {
                    return (Vec3::ZERO, 0.0);
                }
                let m = h.normalize();
                let wom = wo.dot(m).max(0.0);
                let d = ggx_d(m, alpha);
                let g = ggx_g2(wo, wi, alpha);
                let f = fresnel_eval(fresnel, wom) * (d * g / (4.0 * wo.z * wi.z));
                let pdf = if wom > 0.0 {
                    vndf_pdf(wo, m, alpha) / (4.0 * wom)
                } else {
                    0.0
                };
                (f, pdf)
            }
            Material::Dielectric { alpha, .. } => {
                if alpha < DELTA_ALPHA {
                    return (Vec3::ZERO, 0.0);
                }
                let (f, pdf) = rough_dielectric_eval(wo, wi, etap, alpha);
                (Vec3::splat(f), pdf)
            }
            Material::Emissive { .. } => (Vec3::ZERO, 0.0),
        }
    }

    /// Samples an incident direction for `wo` from lobe choice `u_lobe` and direction sample
    /// `(u1, u2)`. `None` when the sample carries no energy.
    pub fn sample(&self, wo: Vec3, etap: f32, u_lobe: f32, u1: f32, u2: f32) -> Option<BsdfSample> {
        if wo.z <= 0.0 {
            return None;
        }
        match *self {
            Material::Diffuse { albedo } => {
                let wi = super::sampling::cosine_hemisphere(u1, u2);
                if wi.z <= 0.0 {
                    return None;
                }
                Some(BsdfSample {
                    wi,
                    weight: albedo,
                    pdf: wi.z * (1.0 / PI),
                    delta: false,
                })
            }
            Material::Conductor { fresnel, alpha } => {
                if alpha < DELTA_ALPHA {
                    return Some(BsdfSample {
                        wi: Vec3::new(-wo.x, -wo.y, wo.z),
                        weight: fresnel_eval(fresnel, wo.z),
                        pdf: 0.0,
                        delta: true,
                    });
                }
                let m = vndf_sample(wo, alpha, u1, u2);
                let wom = wo.dot(m);
                if wom <= 0.0 {
                    return None;
                }
                let wi = reflect(wo, m);
                if wi.z <= 0.0 {
                    return None;
                }
                let g1 = ggx_g1(wo, alpha);
                let weight = fresnel_eval(fresnel, wom) * (ggx_g2(wo, wi, alpha) / g1);
                Some(BsdfSample {
                    wi,
                    weight,
                    pdf: vndf_pdf(wo, m, alpha) / (4.0 * wom),
                    delta: false,
                })
            }
            Material::Dielectric { alpha, .. } => {
                if alpha < DELTA_ALPHA {
                    let f = fresnel_dielectric(wo.z, etap);
                    if u_lobe < f {
                        return Some(BsdfSample {
                            wi: Vec3::new(-wo.x, -wo.y, wo.z),
                            weight: Vec3::ONE,
                            pdf: 0.0,
                            delta: true,
                        });
                    }
                    let wi = refract(wo, Vec3::Z, etap)?;
                    return Some(BsdfSample {
                        wi,
                        weight: Vec3::splat(1.0 / (etap * etap)),
                        pdf: 0.0,
                        delta: true,
                    });
                }
                rough_dielectric_sample(wo, etap, alpha, u_lobe, u1, u2)
            }
            Material::Emissive { .. } => None,
        }
    }
}

/// Mirror reflection of `w` about the unit normal `m`.
#[inline]
pub fn reflect(w: Vec3, m: Vec3) -> Vec3 {
    m * (2.0 * w.dot(m)) - w
}

/// Refraction of `w` (on the side `m` points to) through a surface with normal `m` and
/// relative index `etap`; `None` for total internal reflection.
pub fn refract(w: Vec3, m: Vec3, etap: f32) -> Option<Vec3> {
    let cos_i = w.dot(m);
    let sin2_i = (1.0 - cos_i * cos_i).max(0.0);
    let sin2_t = sin2_i / (etap * etap);
    if sin2_t >= 1.0 {
        return None;
    }
    let cos_t = (1.0 - sin2_t).sqrt();
    Some(-w / etap + m * (cos_i / etap - cos_t))
}

/// Unpolarised Fresnel reflectance of a dielectric interface for `cos_i ≥ 0` on the incident
/// side and relative index `etap` (far side over near side); 1 under total internal reflection.
pub fn fresnel_dielectric(cos_i: f32, etap: f32) -> f32 {
    let c = cos_i.clamp(0.0, 1.0);
    let sin2_t = (1.0 - c * c) / (etap * etap);
    if sin2_t >= 1.0 {
        return 1.0;
    }
    let cos_t = (1.0 - sin2_t).sqrt();
    let r_par = (etap * c - cos_t) / (etap * c + cos_t);
    let r_perp = (c - etap * cos_t) / (c + etap * cos_t);
    0.5 * (r_par * r_par + r_perp * r_perp)
}

/// Unpolarised Fresnel reflectance of a conductor with complex index `eta + i k` (one channel).
pub fn fresnel_conductor(cos_i: f32, eta: f32, k: f32) -> f32 {
    let c = cos_i.clamp(0.0, 1.0);
    let c2 = c * c;
    let s2 = 1.0 - c2;
    let eta2 = eta * eta;
    let k2 = k * k;
    let t0 = eta2 - k2 - s2;
    let a2b2 = (t0 * t0 + 4.0 * eta2 * k2).max(0.0).sqrt();
    let t1 = a2b2 + c2;
    let a = (0.5 * (a2b2 + t0)).max(0.0).sqrt();
    let t2 = 2.0 * c * a;
    let rs = (t1 - t2) / (t1 + t2);
    let t3 = c2 * a2b2 + s2 * s2;
    let t4 = t2 * s2;
    let rp = rs * (t3 - t4) / (t3 + t4);
    (0.5 * (rp + rs)).clamp(0.0, 1.0)
}

/// Conductor reflectance per channel.
pub fn fresnel_eval(f: Fresnel, cos_i: f32) -> Vec3 {
    match f {
        Fresnel::Conductor { eta, k } => Vec3::new(
            fresnel_conductor(cos_i, eta.x, k.x),
            fresnel_conductor(cos_i, eta.y, k.y),
            fresnel_conductor(cos_i, eta.z, k.z),
        ),
        Fresnel::Schlick { f0 } => {
            let m = (1.0 - cos_i).clamp(0.0, 1.0);
            let m2 = m * m;
            let m5 = m2 * m2 * m;
            f0 + (Vec3::ONE - f0) * m5
        }
    }
}

/// GGX normal distribution `D(m)` for a local microfacet normal `m`.
pub fn ggx_d(m: Vec3, alpha: f32) -> f32 {
    if m.z <= 0.0 {
        return 0.0;
    }
    let a2 = alpha * alpha;
    let t = m.z * m.z * (a2 - 1.0) + 1.0;
    a2 / (PI * t * t)
}

/// Smith's Λ for GGX.
pub fn ggx_lambda(w: Vec3, alpha: f32) -> f32 {
    let c2 = w.z * w.z;
    if c2 <= 0.0 {
        return f32::INFINITY;
    }
    let s2 = (1.0 - c2).max(0.0);
    let tan2 = s2 / c2;
    0.5 * ((1.0 + alpha * alpha * tan2).sqrt() - 1.0)
}

/// Smith masking for one direction.
pub fn ggx_g1(w: Vec3, alpha: f32) -> f32 {
    1.0 / (1.0 + ggx_lambda(w, alpha))
}

/// Height-correlated Smith masking-shadowing.
pub fn ggx_g2(wo: Vec3, wi: Vec3, alpha: f32) -> f32 {
    1.0 / (1.0 + ggx_lambda(wo, alpha) + ggx_lambda(wi, alpha))
}

/// Density of the visible normal `m` seen from `wo` (w.r.t. solid angle of `m`).
pub fn vndf_pdf(wo: Vec3, m: Vec3, alpha: f32) -> f32 {
    if wo.z <= 0.0 {
        return 0.0;
    }
    ggx_g1(wo, alpha) * wo.dot(m).max(0.0) * ggx_d(m, alpha) / wo.z
}

/// Samples a visible GGX normal for `wo.z > 0` (Heitz 2018: stretch, sample the projected
/// hemisphere, unstretch).
pub fn vndf_sample(wo: Vec3, alpha: f32, u1: f32, u2: f32) -> Vec3 {
    let vh = Vec3::new(alpha * wo.x, alpha * wo.y, wo.z).normalize();
    let lensq = vh.x * vh.x + vh.y * vh.y;
    let t1 = if lensq > 0.0 {
        Vec3::new(-vh.y, vh.x, 0.0) * (1.0 / lensq.sqrt())
    } else {
        Vec3::X
    };
    let t2 = vh.cross(t1);
    let r = u1.sqrt();
    let phi = 2.0 * PI * u2;
    let p1 = r * phi.cos();
    let p2a = r * phi.sin();
    let s = 0.5 * (1.0 + vh.z);
    let p2 = (1.0 - s) * (1.0 - p1 * p1).max(0.0).sqrt() + s * p2a;
    let pz = (1.0 - p1 * p1 - p2 * p2).max(0.0).sqrt();
    let nh = t1 * p1 + t2 * p2 + vh * pz;
    Vec3::new(alpha * nh.x, alpha * nh.y, nh.z.max(1e-7)).normalize()
}

fn rough_dielectric_eval(wo: Vec3, wi: Vec3, etap: f32, alpha: f32) -> (f32, f32) {
    if wi.z > 0.0 {
        let m = (wo + wi).normalize();
        let wom = wo.dot(m);
        if wom <= 0.0 {
            return (0.0, 0.0);
        }
        let f = fresnel_dielectric(wom, etap);
        let val = ggx_d(m, alpha) * ggx_g2(wo, wi, alpha) * f / (4.0 * wo.z * wi.z);
        let pdf = vndf_pdf(wo, m, alpha) / (4.0 * wom) * f;
        return (val, pdf);
    }
    if wi.z == 0.0 {
        return (0.0, 0.0);
    }
    let h = wi * etap + wo;
    if h.length_squared() <= 0.0 {
        return (0.0, 0.0);
    }
    let mut m = h.normalize();
    if m.z < 0.0 {
        m = -m;
    }
    let wom = wo.dot(m);
    let wim = wi.dot(m);
    if wom <= 0.0 || wim >= 0.0 {
        return (0.0, 0.0);
    }
    let f = fresnel_dielectric(wom, etap);
    let s = wim + wom / etap;
    let denom = s * s;
    if denom <= 0.0 {
        return (0.0, 0.0);
    }
    let val = ggx_d(m, alpha)
        * ggx_g2(wo, wi, alpha)
        * (1.0 - f)
        * (wim * wom / (wi.z * wo.z * denom)).abs()
        / (etap * etap);
    let pdf = vndf_pdf(wo, m, alpha) * (1.0 - f) * wim.abs() / denom;
    (val, pdf)
}

fn rough_dielectric_sample(
    wo: Vec3,
    etap: f32,
    alpha: f32,
    u_lobe: f32,
    u1: f32,
    u2: f32,
) -> Option<BsdfSample> {
    let m = vndf_sample(wo, alpha, u1, u2);
    let wom = wo.dot(m);
    if wom <= 0.0 {
        return None;
    }
    let f = fresnel_dielectric(wom, etap);
    let g1 = ggx_g1(wo, alpha);
    let pm = vndf_pdf(wo, m, alpha);
    if u_lobe < f {
        let wi = reflect(wo, m);
        if wi.z <= 0.0 {
            return None;
        }
        let w = ggx_g2(wo, wi, alpha) / g1;
        return Some(BsdfSample {
            wi,
            weight: Vec3::splat(w),
            pdf: pm / (4.0 * wom) * f,
            delta: false,
        });
    }
    let wi = refract(wo, m, etap)?;
    if wi.z >= 0.0 {
        return None;
    }
    let wim = wi.dot(m);
    let s = wim + wom / etap;
    let denom = s * s;
    if denom <= 0.0 {
        return None;
    }
    let w = ggx_g2(wo, wi, alpha) / g1 / (etap * etap);
    Some(BsdfSample {
        wi,
        weight: Vec3::splat(w),
        pdf: pm * (1.0 - f) * wim.abs() / denom,
        delta: false,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::render::rng::PathRng;

    /// Estimates ∫ f cos dwi by BSDF sampling and compares eval/pdf against sample weights.
    fn check_consistency(mat: Material, wo: Vec3, etap: f32) -> f32 {
        let n = 200_000u32;
        let mut sum = 0.0f64;
        for i in 0..n {
            let r = PathRng::new(3, i, 0);
            if let Some(s) = mat.sample(wo, etap, r.get(0), r.get(1), r.get(2)) {
                if !s.delta {
                    let (f, pdf) = mat.eval(wo, s.wi, etap);
                    assert!(
                        (pdf - s.pdf).abs() <= 2e-3 * s.pdf.max(1.0),
                        "pdf {pdf} vs {} at {:?}",
                        s.pdf,
                        s.wi
                    );
                    let w = f.x * s.wi.z.abs() / pdf;
                    assert!(
                        (w - s.weight.x).abs() <= 2e-3 * s.weight.x.max(1.0),
                        "weight {w} vs {}",
                        s.weight.x
                    );
                }
                sum += s.weight.x as f64;
            }
        }
        (sum / n as f64) as f32
    }

    #[test]
    fn diffuse_energy() {
        let wo = Vec3::new(0.3, 0.1, 0.9).normalize();
        let e = check_consistency(
            Material::Diffuse {
                albedo: Vec3::splat(0.5),
            },
            wo,
            1.0,
        );
        assert!((e - 0.5).abs() < 1e-6);
    }

    #[test]
    fn conductor_consistent_and_bounded() {
        for alpha in [0.05f32, 0.3, 0.8] {
            let mat = Material::Conductor {
                fresnel: Fresnel::Schlick { f0: Vec3::ONE },
                alpha,
            };
            let wo = Vec3::new(0.5, 0.2, 0.6).normalize();
            let e = check_consistency(mat, wo, 1.0);
            // Independent estimate of the directional albedo ∫ f cos dω by cosine sampling.
            let n = 400_000u32;
            let mut e2 = 0.0f64;
            for i in 0..n {
                let r = PathRng::new(11, i, 0);
                let wi = crate::render::sampling::cosine_hemisphere(r.get(0), r.get(1));
                if wi.z > 0.0 {
                    e2 += (mat.eval(wo, wi, 1.0).0.x * PI) as f64;
                }
            }
            let e2 = (e2 / n as f64) as f32;
            assert!((e - e2).abs() < 0.02 * e2, "alpha {alpha}: {e} vs {e2}");
            // A white single-scattering GGX conductor only loses energy.
            assert!(e <= 1.0 + 1e-3 && e > 0.3, "alpha {alpha}: {e}");
        }
    }

    #[test]
    fn rough_dielectric_consistent() {
        for (alpha, etap) in [(0.2f32, 1.5f32), (0.5, 1.0 / 1.5)] {
            let mat = Material::Dielectric { ior: 1.5, alpha };
            let wo = Vec3::new(0.4, -0.3, 0.7).normalize();
            let e = check_consistency(mat, wo, etap);
            assert!(e > 0.2 && e < 2.5, "{e}");
        }
    }

    #[test]
    fn fresnel_values() {
        // Normal incidence, glass: ((1.5-1)/(1.5+1))² = 0.04.
        assert!((fresnel_dielectric(1.0, 1.5) - 0.04).abs() < 1e-6);
        assert_eq!(fresnel_dielectric(0.1, 1.0 / 1.5), 1.0);
        // A conductor with k = 0 is a dielectric.
        for c in [0.2f32, 0.6, 1.0] {
            assert!((fresnel_conductor(c, 1.5, 0.0) - fresnel_dielectric(c, 1.5)).abs() < 1e-5);
        }
        assert!(
            (fresnel_eval(
                Fresnel::Schlick {
                    f0: Vec3::splat(0.5)
                },
                1.0
            )
            .x - 0.5)
                .abs()
                < 1e-7
        );
    }

    #[test]
    fn smooth_dielectric_refracts_by_snell() {
        let mat = Material::Dielectric {
            ior: 1.5,
            alpha: 0.0,
        };
        let wo = Vec3::new(0.6, 0.0, 0.8);
        let s = mat.sample(wo, 1.5, 0.99, 0.5, 0.5).unwrap();
        assert!(s.delta && s.wi.z < 0.0);
        // sin θt = sin θi / 1.5.
        assert!((s.wi.x.abs() - 0.6 / 1.5).abs() < 1e-6);
        let r = mat.sample(wo, 1.5, 0.0, 0.5, 0.5).unwrap();
        assert_eq!(r.wi, Vec3::new(-0.6, 0.0, 0.8));
    }
}
