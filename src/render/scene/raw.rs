//! The scene file as serde reads it: every value with its span, for located errors.

use glam::Vec3;
use serde::Deserialize;
use std::collections::BTreeMap;
use toml::Spanned;

/// A colour or scale: one number (grey) or three. Deserialised by hand so that a wrong value
/// is reported as what the key expects, not as an internal type.
pub(super) enum RawRgb {
    Grey(f32),
    Rgb([f32; 3]),
}

impl<'de> Deserialize<'de> for RawRgb {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl<'de> serde::de::Visitor<'de> for V {
            type Value = RawRgb;
            fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                f.write_str("a number or an array of 3 numbers")
            }
            fn visit_f64<E: serde::de::Error>(self, x: f64) -> Result<RawRgb, E> {
                Ok(RawRgb::Grey(x as f32))
            }
            fn visit_i64<E: serde::de::Error>(self, x: i64) -> Result<RawRgb, E> {
                Ok(RawRgb::Grey(x as f32))
            }
            fn visit_u64<E: serde::de::Error>(self, x: u64) -> Result<RawRgb, E> {
                Ok(RawRgb::Grey(x as f32))
            }
            fn visit_seq<A: serde::de::SeqAccess<'de>>(
                self,
                mut seq: A,
            ) -> Result<RawRgb, A::Error> {
                let mut c = [0.0f32; 3];
                for (i, x) in c.iter_mut().enumerate() {
                    *x = seq
                        .next_element::<f64>()?
                        .ok_or_else(|| serde::de::Error::invalid_length(i, &self))?
                        as f32;
                }
                if seq.next_element::<serde::de::IgnoredAny>()?.is_some() {
                    return Err(serde::de::Error::invalid_length(4, &self));
                }
                Ok(RawRgb::Rgb(c))
            }
        }
        d.deserialize_any(V)
    }
}

impl RawRgb {
    pub(super) fn vec(&self) -> Vec3 {
        match *self {
            RawRgb::Grey(g) => Vec3::splat(g),
            RawRgb::Rgb(c) => Vec3::from(c),
        }
    }
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawFile {
    pub(super) render: Option<RawRender>,
    pub(super) camera: Spanned<RawCamera>,
    #[serde(default)]
    pub(super) materials: BTreeMap<String, Spanned<RawMaterial>>,
    #[serde(default)]
    pub(super) mesh: Vec<Spanned<RawMesh>>,
    #[serde(default)]
    pub(super) light: Vec<Spanned<RawLight>>,
    pub(super) environment: Option<Spanned<RawEnv>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawRender {
    pub(super) width: Option<Spanned<i64>>,
    pub(super) height: Option<Spanned<i64>>,
    pub(super) spp: Option<Spanned<i64>>,
    pub(super) max_depth: Option<Spanned<i64>>,
    pub(super) seed: Option<Spanned<i64>>,
    pub(super) pixels_per_edge: Option<Spanned<f64>>,
    pub(super) exposure: Option<Spanned<f32>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawCamera {
    pub(super) position: Spanned<[f32; 3]>,
    pub(super) look_at: Spanned<[f32; 3]>,
    pub(super) up: Option<Spanned<[f32; 3]>>,
    pub(super) fov: Spanned<f32>,
    pub(super) aperture: Option<Spanned<f32>>,
    pub(super) focus_distance: Option<Spanned<f32>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawMaterial {
    #[serde(rename = "type")]
    pub(super) kind: Spanned<String>,
    pub(super) albedo: Option<Spanned<RawRgb>>,
    pub(super) eta: Option<Spanned<RawRgb>>,
    pub(super) k: Option<Spanned<RawRgb>>,
    pub(super) base_color: Option<Spanned<RawRgb>>,
    pub(super) preset: Option<Spanned<String>>,
    pub(super) roughness: Option<Spanned<f32>>,
    pub(super) ior: Option<Spanned<f32>>,
    pub(super) radiance: Option<Spanned<RawRgb>>,
    pub(super) albedo_map: Option<Spanned<String>>,
    pub(super) roughness_map: Option<Spanned<String>>,
    pub(super) emission_map: Option<Spanned<String>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawMesh {
    pub(super) file: Spanned<String>,
    pub(super) material: Spanned<String>,
    pub(super) translate: Option<Spanned<[f32; 3]>>,
    pub(super) rotate: Option<Spanned<[f32; 3]>>,
    pub(super) scale: Option<Spanned<RawRgb>>,
    pub(super) matrix: Option<Spanned<Vec<f32>>>,
    pub(super) rate: Option<Spanned<i64>>,
    pub(super) pixels_per_edge: Option<Spanned<f64>>,
    pub(super) max_level: Option<Spanned<i64>>,
    pub(super) max_rate: Option<Spanned<i64>>,
    pub(super) scheme: Option<Spanned<String>>,
    pub(super) surface: Option<Spanned<String>>,
    pub(super) displace: Option<Spanned<String>>,
    pub(super) fvar: Option<Spanned<String>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawLight {
    #[serde(rename = "type")]
    pub(super) kind: Spanned<String>,
    pub(super) corner: Spanned<[f32; 3]>,
    pub(super) edge1: Spanned<[f32; 3]>,
    pub(super) edge2: Spanned<[f32; 3]>,
    pub(super) radiance: Spanned<RawRgb>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawEnv {
    pub(super) radiance: Option<Spanned<RawRgb>>,
    pub(super) map: Option<Spanned<String>>,
    pub(super) intensity: Option<Spanned<f32>>,
    pub(super) rotate: Option<Spanned<f32>>,
}
