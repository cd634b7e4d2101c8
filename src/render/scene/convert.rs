//! Checked conversions of scene-file values: numbers in range, colours, materials, transforms.

use super::locate::{finite3, Src};
use super::raw::{RawMaterial, RawMesh, RawRgb};
use crate::error::Result;
use crate::render::material::{Fresnel, Material};
use glam::{Affine3A, Mat3, Mat4, Vec3};
use std::ops::Range;
use toml::Spanned;

pub(super) fn positive(src: &Src, v: &Spanned<f32>) -> Result<f32> {
    let x = *v.get_ref();
    if !(x > 0.0 && x.is_finite()) {
        return Err(src.err(v.span(), format!("must be a positive number, not {x}")));
    }
    Ok(x)
}

pub(super) fn positive_f64(src: &Src, v: &Spanned<f64>) -> Result<f64> {
    let x = *v.get_ref();
    if !(x > 0.0 && x.is_finite()) {
        return Err(src.err(v.span(), format!("must be a positive number, not {x}")));
    }
    Ok(x)
}

pub(super) fn non_negative(src: &Src, v: &Spanned<f32>) -> Result<f32> {
    let x = *v.get_ref();
    if !(x >= 0.0 && x.is_finite()) {
        return Err(src.err(v.span(), format!("must be a number ≥ 0, not {x}")));
    }
    Ok(x)
}

pub(super) fn radiance(src: &Src, v: &Spanned<RawRgb>) -> Result<Vec3> {
    let x = v.get_ref().vec();
    if !(finite3(x) && x.min_element() >= 0.0) {
        return Err(src.err(v.span(), "radiance components must be finite and ≥ 0"));
    }
    Ok(x)
}

pub(super) fn unit_rgb(src: &Src, v: &Spanned<RawRgb>) -> Result<Vec3> {
    let x = v.get_ref().vec();
    if !(finite3(x) && x.min_element() >= 0.0 && x.max_element() <= 1.0) {
        return Err(src.err(v.span(), "colour components must be in [0, 1]"));
    }
    Ok(x)
}

/// Complex indices of refraction at RGB (approximately 650, 550, 450 nm) of common metals.
pub fn conductor_preset(name: &str) -> Option<(Vec3, Vec3)> {
    Some(match name {
        "gold" => (
            Vec3::new(0.143, 0.374, 1.442),
            Vec3::new(3.983, 2.385, 1.603),
        ),
        "copper" => (
            Vec3::new(0.200, 0.924, 1.102),
            Vec3::new(3.912, 2.452, 2.142),
        ),
        "silver" => (
            Vec3::new(0.155, 0.117, 0.138),
            Vec3::new(4.828, 3.122, 2.147),
        ),
        "aluminium" | "aluminum" => (
            Vec3::new(1.657, 0.880, 0.521),
            Vec3::new(9.224, 6.270, 4.837),
        ),
        _ => return None,
    })
}

pub(super) fn material(src: &Src, m: &Spanned<RawMaterial>) -> Result<Material> {
    let r = m.get_ref();
    let kind = r.kind.get_ref().as_str();
    // Which keys each type accepts.
    let present: [(&str, Option<Range<usize>>); 11] = [
        ("albedo", r.albedo.as_ref().map(|v| v.span())),
        ("eta", r.eta.as_ref().map(|v| v.span())),
        ("k", r.k.as_ref().map(|v| v.span())),
        ("base_color", r.base_color.as_ref().map(|v| v.span())),
        ("preset", r.preset.as_ref().map(|v| v.span())),
        ("roughness", r.roughness.as_ref().map(|v| v.span())),
        ("ior", r.ior.as_ref().map(|v| v.span())),
        ("radiance", r.radiance.as_ref().map(|v| v.span())),
        ("albedo_map", r.albedo_map.as_ref().map(|v| v.span())),
        ("roughness_map", r.roughness_map.as_ref().map(|v| v.span())),
        ("emission_map", r.emission_map.as_ref().map(|v| v.span())),
    ];
    let allowed: &[&str] = match kind {
        "diffuse" => &["albedo", "albedo_map"],
        "conductor" => &[
            "eta",
            "k",
            "base_color",
            "preset",
            "roughness",
            "roughness_map",
        ],
        "dielectric" => &["ior", "roughness", "roughness_map"],
        "emissive" => &["radiance", "emission_map"],
        _ => {
            return Err(src.err(
                r.kind.span(),
                format!(
                    "unknown material type '{kind}' (expected diffuse, conductor, dielectric or \
                     emissive)"
                ),
            ))
        }
    };
    for (key, span) in &present {
        if let Some(span) = span {
            if !allowed.contains(key) {
                return Err(src.err(
                    span.clone(),
                    format!("'{key}' does not apply to a {kind} material"),
                ));
            }
        }
    }
    let roughness = match &r.roughness {
        Some(v) => {
            let x = *v.get_ref();
            if !(0.0..=1.0).contains(&x) {
                return Err(src.err(v.span(), "roughness must be in [0, 1]"));
            }
            x
        }
        None => 0.0,
    };
    let alpha = roughness * roughness;
    Ok(match kind {
        "diffuse" => Material::Diffuse {
            albedo: match &r.albedo {
                Some(a) => unit_rgb(src, a)?,
                None => Vec3::splat(0.8),
            },
        },
        "conductor" => {
            let fresnel = match (&r.eta, &r.k, &r.base_color, &r.preset) {
                (Some(e), Some(k), None, None) => {
                    let (e, k) = (e.get_ref().vec(), k.get_ref().vec());
                    if !(finite3(e)
                        && finite3(k)
                        && e.min_element() > 0.0
                        && k.min_element() >= 0.0)
                    {
                        return Err(src.err(
                            r.eta.as_ref().map_or(0..0, |v| v.span()),
                            "eta must be > 0 and k ≥ 0",
                        ));
                    }
                    Fresnel::Conductor { eta: e, k }
                }
                (None, None, Some(b), None) => Fresnel::Schlick {
                    f0: unit_rgb(src, b)?,
                },
                (None, None, None, Some(p)) => {
                    let (eta, k) = conductor_preset(p.get_ref()).ok_or_else(|| {
                        src.err(
                            p.span(),
                            format!(
                                "unknown preset '{}' (expected gold, copper, silver or aluminium)",
                                p.get_ref()
                            ),
                        )
                    })?;
                    Fresnel::Conductor { eta, k }
                }
                _ => {
                    return Err(src.err(
                        m.span(),
                        "a conductor needs exactly one of: eta and k, base_color, preset",
                    ))
                }
            };
            Material::Conductor { fresnel, alpha }
        }
        "dielectric" => {
            let ior = match &r.ior {
                Some(v) => positive(src, v)?,
                None => 1.5,
            };
            Material::Dielectric { ior, alpha }
        }
        _ => Material::Emissive {
            radiance: match &r.radiance {
                Some(v) => radiance(src, v)?,
                None => return Err(src.err(m.span(), "an emissive material needs radiance")),
            },
        },
    })
}

/// The texture maps of a material entry (`albedo_map`, `roughness_map`, `emission_map`), each
/// `noise:FREQUENCY` or an image file relative to the scene's folder; which keys a type takes is
/// checked by [`material`].
pub(super) fn material_maps(
    src: &Src,
    m: &Spanned<RawMaterial>,
    base: &std::path::Path,
) -> Result<super::MaterialMaps> {
    let r = m.get_ref();
    let spec = |v: &Option<Spanned<String>>| -> Result<Option<super::MapDesc>> {
        v.as_ref()
            .map(|s| {
                crate::texture::TextureSpec::parse(s.get_ref(), base)
                    .map(|spec| super::MapDesc {
                        spec,
                        line: src.line_of(s.span().start),
                    })
                    .map_err(|e| src.err(s.span(), e.message))
            })
            .transpose()
    };
    Ok(super::MaterialMaps {
        albedo: spec(&r.albedo_map)?,
        roughness: spec(&r.roughness_map)?,
        emission: spec(&r.emission_map)?,
    })
}

pub(super) fn transform(src: &Src, r: &RawMesh) -> Result<Affine3A> {
    if let Some(m) = &r.matrix {
        if let Some(other) = [
            r.translate.as_ref().map(|v| v.span()),
            r.rotate.as_ref().map(|v| v.span()),
            r.scale.as_ref().map(|v| v.span()),
        ]
        .into_iter()
        .flatten()
        .next()
        {
            return Err(src.err(
                other,
                "give either matrix or translate/rotate/scale, not both",
            ));
        }
        let v = m.get_ref();
        if v.len() != 16 || !v.iter().all(|x| x.is_finite()) {
            return Err(src.err(m.span(), "matrix must be 16 finite numbers (row-major 4×4)"));
        }
        if v[12] != 0.0 || v[13] != 0.0 || v[14] != 0.0 || v[15] != 1.0 {
            return Err(src.err(m.span(), "matrix must be affine: last row 0 0 0 1"));
        }
        let mat = Mat4::from_cols_array(&[
            v[0], v[4], v[8], v[12], v[1], v[5], v[9], v[13], v[2], v[6], v[10], v[14], v[3], v[7],
            v[11], v[15],
        ]);
        let a = Affine3A::from_mat4(mat);
        let det = a.matrix3.determinant();
        if det.is_nan() || det.abs() <= 1e-12 {
            return Err(src.err(m.span(), "matrix is singular"));
        }
        return Ok(a);
    }
    let t = match &r.translate {
        Some(v) => Vec3::from(*v.get_ref()),
        None => Vec3::ZERO,
    };
    let rot = match &r.rotate {
        Some(v) => Vec3::from(*v.get_ref()),
        None => Vec3::ZERO,
    };
    let s = match &r.scale {
        Some(v) => {
            let s = v.get_ref().vec();
            if !(finite3(s) && s.abs().min_element() > 0.0) {
                return Err(src.err(v.span(), "scale must be finite and non-zero"));
            }
            s
        }
        None => Vec3::ONE,
    };
    if !finite3(t) || !finite3(rot) {
        let span = r
            .translate
            .as_ref()
            .map(|v| v.span())
            .or(r.rotate.as_ref().map(|v| v.span()))
            .unwrap_or(0..0);
        return Err(src.err(span, "components must be finite"));
    }
    // M = T · Rz · Ry · Rx · S: scale first, then rotate about x, y, z, then translate.
    let m3 = Mat3::from_rotation_z(rot.z.to_radians())
        * Mat3::from_rotation_y(rot.y.to_radians())
        * Mat3::from_rotation_x(rot.x.to_radians())
        * Mat3::from_diagonal(s);
    Ok(Affine3A::from_mat3_translation(m3, t))
}
