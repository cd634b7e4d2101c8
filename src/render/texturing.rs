//! Texture maps at a path vertex: the hit's texture coordinates (the exact limit of the mesh's
//! face-varying values at the hit's `(face, k, u, v)`, or that `(u, v)` itself on a mesh
//! without them), the filter width from the path's footprint, and the material with its maps
//! applied.
//!
//! Footprint: a cone around each path, `pixel angle · distance` wide on camera rays (the
//! camera's angle per pixel), widened by 0.1 radian at each non-specular bounce; the width in
//! texture units is the world width times the square root of texture area per world area
//! (`|∂st/∂u × ∂st/∂v|` at the hit times the hit triangle's `(u, v)` area over its world
//! area), the local scale of the texture map on the surface.

use super::material::Material;
use super::scene::{MapDesc, MaterialMaps};
use crate::bvh::Hit;
use crate::error::Result;
use crate::patch::uv::UvSurface;
use crate::texture::image::ColorSpace;
use crate::texture::Texture;
use glam::{Affine3A, Vec3};
use std::sync::Arc;

/// Radians a cone widens by at a non-specular bounce.
pub const BOUNCE_SPREAD: f32 = 0.1;

/// A material's opened texture maps.
#[derive(Clone, Debug, Default)]
pub struct MaterialTextures {
    /// Multiplies a diffuse albedo.
    pub albedo: Option<Texture>,
    /// Replaces a conductor's or dielectric's roughness.
    pub roughness: Option<Texture>,
    /// Multiplies an emissive radiance.
    pub emission: Option<Texture>,
}

impl MaterialTextures {
    /// Opens the maps `maps` names (colour maps as sRGB, roughness as linear data).
    pub fn open(maps: &MaterialMaps, scene: &str) -> Result<MaterialTextures> {
        let open = |m: &Option<MapDesc>, space: ColorSpace, key: &str| -> Result<Option<Texture>> {
            m.as_ref()
                .map(|d| {
                    Texture::open(&d.spec, space).map_err(|e| {
                        let e = if e.file.is_none() {
                            e.in_file(scene.to_string())
                        } else {
                            e
                        };
                        e.at_line(d.line).element(format!("key '{key}'"))
                    })
                })
                .transpose()
        };
        Ok(MaterialTextures {
            albedo: open(&maps.albedo, ColorSpace::Srgb, "albedo_map")?,
            roughness: open(&maps.roughness, ColorSpace::Linear, "roughness_map")?,
            emission: open(&maps.emission, ColorSpace::Srgb, "emission_map")?,
        })
    }

    /// Whether the material has no maps.
    pub fn is_empty(&self) -> bool {
        self.albedo.is_none() && self.roughness.is_none() && self.emission.is_none()
    }

    /// Whether some map reads texture coordinates (an image).
    pub fn uses_uv(&self) -> bool {
        [&self.albedo, &self.roughness, &self.emission]
            .iter()
            .any(|t| t.as_ref().is_some_and(Texture::uses_uv))
    }

    /// `mat` with the maps applied at `at`.
    pub fn apply(&self, mat: Material, at: &Lookup) -> Material {
        let rgb = |t: &Texture| Vec3::from(t.rgb(at.st, at.p, at.footprint));
        let alpha = |t: &Texture| {
            let r = t.scalar(at.st, at.p, at.footprint).clamp(0.0, 1.0);
            r * r
        };
        match mat {
            Material::Diffuse { albedo } => Material::Diffuse {
                albedo: match &self.albedo {
                    Some(t) => (albedo * rgb(t)).clamp(Vec3::ZERO, Vec3::ONE),
                    None => albedo,
                },
            },
            Material::Conductor { fresnel, alpha: a } => Material::Conductor {
                fresnel,
                alpha: self.roughness.as_ref().map_or(a, alpha),
            },
            Material::Dielectric { ior, alpha: a } => Material::Dielectric {
                ior,
                alpha: self.roughness.as_ref().map_or(a, alpha),
            },
            Material::Emissive { radiance } => Material::Emissive {
                radiance: match &self.emission {
                    Some(t) => radiance * rgb(t).max(Vec3::ZERO),
                    None => radiance,
                },
            },
        }
    }

    /// Bytes held by the images.
    pub fn bytes(&self) -> usize {
        [&self.albedo, &self.roughness, &self.emission]
            .iter()
            .map(|t| t.as_ref().map_or(0, Texture::bytes))
            .sum()
    }
}

/// Where a map is read: texture coordinates, object-space point and filter width.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Lookup {
    /// Texture coordinates.
    pub st: [f32; 2],
    /// The object-space point (procedural maps).
    pub p: [f64; 3],
    /// Filter width in texture units.
    pub footprint: f32,
}

/// What an instance needs to address its maps: its limit texture coordinates (none on a mesh
/// without them) and its transform.
#[derive(Debug)]
pub struct InstanceMaps {
    /// Limit texture coordinates.
    pub uv: Option<Arc<UvSurface>>,
    /// Object to world.
    pub to_world: Affine3A,
    /// World to object.
    pub to_object: Affine3A,
}

impl InstanceMaps {
    /// The lookup at `hit` (world point `p`) for a cone `width` wide there; `corners` and
    /// `uvs` are the hit triangle's object-space corners and their `(u, v)`.
    ///
    /// The texture coordinates are the exact limit values at the hit. The surface's scale
    /// comes from the triangle: `|∂st/∂u × ∂st/∂v|` at the hit times the triangle's area in
    /// `(u, v)` over its world-space area, the texture area per world area the GPU path tracer
    /// measures from its vertices' texture coordinates (`src/gpu/texture.rs`).
    pub fn lookup(
        &self,
        hit: &Hit,
        p: Vec3,
        width: f32,
        corners: [[f32; 3]; 3],
        uvs: [[f32; 2]; 3],
    ) -> Lookup {
        let (at, sample) = UvSurface::at_hit(self.uv.as_deref(), hit.face, hit.k, [hit.u, hit.v]);
        let (st, st_density) = match sample {
            Some(Ok(s)) => (s.st, (s.du[0] * s.dv[1] - s.du[1] * s.dv[0]).abs()),
            Some(Err(_)) => ([at.u, at.v], 0.0),
            None => ([at.u, at.v], 1.0),
        };
        let [a, b, c] = corners.map(Vec3::from);
        let e1 = self.to_world.transform_vector3(b - a);
        let e2 = self.to_world.transform_vector3(c - a);
        let area = e1.cross(e2).length() as f64;
        let d1 = [uvs[1][0] - uvs[0][0], uvs[1][1] - uvs[0][1]];
        let d2 = [uvs[2][0] - uvs[0][0], uvs[2][1] - uvs[0][1]];
        let uv_area = (d1[0] * d2[1] - d1[1] * d2[0]).abs() as f64;
        let footprint = if area > 0.0 && area.is_finite() {
            width * (st_density * uv_area / area).sqrt() as f32
        } else {
            0.0
        };
        let q = self.to_object.transform_point3(p);
        Lookup {
            st: [st[0] as f32, st[1] as f32],
            p: [q.x as f64, q.y as f64, q.z as f64],
            footprint,
        }
    }
}
