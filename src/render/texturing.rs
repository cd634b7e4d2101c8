//! Texture maps at a path vertex: the hit's texture coordinates (the exact limit of the mesh's
//! face-varying values at the hit's `(face, k, u, v)`, or that `(u, v)` itself on a mesh
//! without them), the filter width from the path's footprint, and the material with its maps
//! applied.
//!
//! Footprint: a cone around each path, `pixel angle · distance` wide on camera rays (the
//! camera's angle per pixel), widened by 0.1 radian at each non-specular bounce; the width in
//! texture units is the world width times `sqrt(|∂st/∂u × ∂st/∂v| / |∂P/∂u × ∂P/∂v|)`, the
//! local scale of the texture map on the limit surface.

use super::material::Material;
use super::scene::{MapDesc, MaterialMaps};
use crate::bvh::Hit;
use crate::coord::FaceCoord;
use crate::error::Result;
use crate::patch::uv::UvSurface;
use crate::patch::PatchTable;
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

/// What an instance needs to address its maps: its limit surface (for the surface's scale),
/// its limit texture coordinates (none on a mesh without them) and its transform.
#[derive(Debug)]
pub struct InstanceMaps {
    /// The mesh's patch table.
    pub table: Arc<PatchTable>,
    /// Limit texture coordinates.
    pub uv: Option<Arc<UvSurface>>,
    /// Object to world.
    pub to_world: Affine3A,
    /// World to object.
    pub to_object: Affine3A,
}

impl InstanceMaps {
    /// The lookup at `hit` (world point `p`) for a cone `width` wide there.
    pub fn lookup(&self, hit: &Hit, p: Vec3, width: f32) -> Lookup {
        let at = FaceCoord::new(
            hit.face,
            hit.k,
            (hit.u as f64).clamp(0.0, 1.0),
            (hit.v as f64).clamp(0.0, 1.0),
        );
        let (st, su, sv) = match self.uv.as_ref().map(|uv| uv.eval(at)) {
            Some(Ok(s)) => (s.st, s.du, s.dv),
            Some(Err(_)) => ([at.u, at.v], [0.0; 2], [0.0; 2]),
            None => ([at.u, at.v], [1.0, 0.0], [0.0, 1.0]),
        };
        let st_area = (su[0] * sv[1] - su[1] * sv[0]).abs();
        let footprint = match self.table.eval(at) {
            Ok(s) => {
                let du = self
                    .to_world
                    .transform_vector3(Vec3::from(s.du.map(|x| x as f32)));
                let dv = self
                    .to_world
                    .transform_vector3(Vec3::from(s.dv.map(|x| x as f32)));
                let area = du.cross(dv).length() as f64;
                if area > 0.0 && area.is_finite() {
                    width * (st_area / area).sqrt() as f32
                } else {
                    0.0
                }
            }
            Err(_) => 0.0,
        };
        let q = self.to_object.transform_point3(p);
        Lookup {
            st: [st[0] as f32, st[1] as f32],
            p: [q.x as f64, q.y as f64, q.z as f64],
            footprint,
        }
    }
}
