//! Scene files (TOML): camera, meshes, materials, lights, environment and render settings.
//! The format is documented in the README ("Scene files"). Every error names the file, the
//! line and the key (for example `scene.toml:12: key 'camera.fov': must be in (0, 180)`).

mod convert;
mod locate;
mod raw;

pub use convert::conductor_preset;

use super::light::QuadLight;
use super::material::Material;
use crate::error::{Error, ErrorKind, Result};
use convert::{material, non_negative, positive, positive_f64, radiance, transform};
use glam::{Affine3A, Vec3};
use locate::{finite3, Src};
use raw::RawFile;
use std::path::{Path, PathBuf};
use toml::Spanned;

/// Largest image width and height (scene keys `render.width`/`height`, `render --res`).
pub const MAX_RESOLUTION: u32 = 16384;
/// Largest samples per pixel (`render.spp`, `render --spp`).
pub const MAX_SPP: u32 = 1 << 20;
/// Largest path depth (`render.max_depth`, `render --max-depth`).
pub const MAX_DEPTH: u32 = 1024;

/// Render settings (`[render]`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RenderSettings {
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// Samples per pixel.
    pub spp: u32,
    /// Maximum number of scattering events per path (0: emitters and environment only).
    pub max_depth: u32,
    /// Random seed.
    pub seed: u32,
    /// Default screen-space dicing target (pixels per micro-edge) for meshes without a rate.
    pub pixels_per_edge: f64,
    /// Exposure of the PNG preview, in stops.
    pub exposure: f32,
}

impl Default for RenderSettings {
    fn default() -> Self {
        RenderSettings {
            width: 640,
            height: 360,
            spp: 16,
            max_depth: 6,
            seed: 1,
            pixels_per_edge: 2.0,
            exposure: 0.0,
        }
    }
}

/// Camera settings (`[camera]`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CameraDesc {
    /// Eye position.
    pub position: Vec3,
    /// Point looked at.
    pub look_at: Vec3,
    /// Up direction.
    pub up: Vec3,
    /// Vertical field of view in degrees.
    pub fov: f32,
    /// Lens radius (0: pinhole).
    pub aperture: f32,
    /// Focus distance (default: distance to `look_at`).
    pub focus_distance: Option<f32>,
}

/// How a mesh is diced.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Dicing {
    /// A fixed number of segments per base-face edge.
    Rate(u32),
    /// Screen-space: target micro-edge length in pixels, seen from the camera.
    PixelsPerEdge(f64),
}

/// One `[[mesh]]` entry.
#[derive(Clone, Debug, PartialEq)]
pub struct MeshDesc {
    /// OBJ file, resolved against the scene file's folder.
    pub file: PathBuf,
    /// Index into [`SceneDesc::materials`].
    pub material: usize,
    /// Object-to-world transform.
    pub transform: Affine3A,
    /// Dicing rate.
    pub dicing: Dicing,
    /// Maximum isolation level of the patch table.
    pub max_level: usize,
    /// Upper bound on the segments of one edge.
    pub max_rate: u32,
    /// Subdivision scheme (`scheme = "catmark"` or `"loop"`; Catmull-Clark by default).
    pub scheme: crate::mesh::Scheme,
    /// The surface of the mesh (`surface = "exact"`, or `"pn"`, `"wm"`, `"gregory"`: paper
    /// 002's approximations of a Loop mesh; `"gregory"` on a Catmull-Clark mesh is paper 004's
    /// Gregory patches).
    pub surface: crate::patch::approx::Approximation,
    /// Displacement along the limit normal (`displace = "noise:AMPLITUDE:FREQUENCY"`, in the
    /// mesh's object space), applied at dicing.
    pub displace: Option<crate::dice::Displacement>,
    /// Face-varying interpolation of the mesh's texture coordinates (`fvar = "corners-plus1"`,
    /// the default, or any `--fvar` mode).
    pub fvar: crate::mesh::FVarMode,
    /// Line of the entry in the scene file, for messages.
    pub line: usize,
}

/// A texture map of a material: what it names and the scene line, for messages.
#[derive(Clone, Debug, PartialEq)]
pub struct MapDesc {
    /// `noise:FREQUENCY` or an image file (resolved against the scene file's folder).
    pub spec: crate::texture::TextureSpec,
    /// Line of the key in the scene file.
    pub line: usize,
}

/// The texture maps of a material (`albedo_map`, `roughness_map`, `emission_map`).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct MaterialMaps {
    /// Multiplies a diffuse material's albedo (colour: sRGB images).
    pub albedo: Option<MapDesc>,
    /// Replaces a conductor's or dielectric's roughness (data: linear images, channel mean).
    pub roughness: Option<MapDesc>,
    /// Multiplies an emissive material's radiance (colour: sRGB images).
    pub emission: Option<MapDesc>,
}

/// The environment (`[environment]`).
#[derive(Clone, Debug, PartialEq)]
pub enum EnvDesc {
    /// Constant radiance.
    Constant(Vec3),
    /// A lat-long EXR map.
    Map {
        /// Map file, resolved against the scene file's folder.
        file: PathBuf,
        /// Multiplier of the map's values.
        intensity: f32,
        /// Rotation about +y, in degrees.
        rotate: f32,
        /// Line of the `map` key, for messages.
        line: usize,
    },
}

/// A parsed and checked scene file.
#[derive(Clone, Debug, PartialEq)]
pub struct SceneDesc {
    /// The scene file.
    pub path: PathBuf,
    /// Render settings.
    pub render: RenderSettings,
    /// Camera.
    pub camera: CameraDesc,
    /// Materials by name, sorted by name.
    pub materials: Vec<(String, Material)>,
    /// The texture maps of each material (parallel to `materials`).
    pub material_maps: Vec<MaterialMaps>,
    /// Meshes.
    pub meshes: Vec<MeshDesc>,
    /// Quad area lights.
    pub quads: Vec<QuadLight>,
    /// Environment (black when absent).
    pub environment: Option<EnvDesc>,
}

/// Reads and checks a scene file.
pub fn read_scene(path: &Path) -> Result<SceneDesc> {
    let text = std::fs::read_to_string(path).map_err(|e| {
        Error::new(ErrorKind::Io, e.to_string()).in_file(path.display().to_string())
    })?;
    parse_scene(&text, path)
}

/// Parses scene text; `path` names it in messages and anchors relative file names.
pub fn parse_scene(text: &str, path: &Path) -> Result<SceneDesc> {
    let src = Src {
        name: path.display().to_string(),
        text,
    };
    let raw: RawFile = toml::from_str(text).map_err(|e| {
        let span = e.span().unwrap_or(0..0);
        let message = e.message().trim().to_string();
        let mut err = src.err(span.clone(), message.clone());
        // A missing key is reported at its table: name the key itself.
        if let Some(field) = message
            .strip_prefix("missing field `")
            .and_then(|r| r.split('`').next())
        {
            // An empty span is the whole document (a top-level key).
            let table = if span.is_empty() {
                String::new()
            } else {
                src.key_at(span.start)
            };
            err.element = Some(if table.is_empty() {
                format!("key '{field}'")
            } else {
                format!("key '{table}.{field}'")
            });
        }
        err
    })?;
    let base = path.parent().map(Path::to_path_buf).unwrap_or_default();

    // [render]
    let mut render = RenderSettings::default();
    if let Some(r) = &raw.render {
        let int = |v: &Spanned<i64>, lo: i64, hi: i64| -> Result<u32> {
            let x = *v.get_ref();
            if x < lo || x > hi {
                return Err(src.err(v.span(), format!("must be in {lo}..={hi}, not {x}")));
            }
            Ok(x as u32)
        };
        if let Some(v) = &r.width {
            render.width = int(v, 1, MAX_RESOLUTION as i64)?;
        }
        if let Some(v) = &r.height {
            render.height = int(v, 1, MAX_RESOLUTION as i64)?;
        }
        if let Some(v) = &r.spp {
            render.spp = int(v, 1, MAX_SPP as i64)?;
        }
        if let Some(v) = &r.max_depth {
            render.max_depth = int(v, 0, MAX_DEPTH as i64)?;
        }
        if let Some(v) = &r.seed {
            render.seed = int(v, 0, u32::MAX as i64)?;
        }
        if let Some(v) = &r.pixels_per_edge {
            render.pixels_per_edge = positive_f64(&src, v)?;
        }
        if let Some(v) = &r.exposure {
            if !v.get_ref().is_finite() {
                return Err(src.err(v.span(), "must be a finite number"));
            }
            render.exposure = *v.get_ref();
        }
    }

    // [camera]
    let c = raw.camera.get_ref();
    let vec3 = |v: &Spanned<[f32; 3]>| -> Result<Vec3> {
        let x = Vec3::from(*v.get_ref());
        if !finite3(x) {
            return Err(src.err(v.span(), "components must be finite"));
        }
        if !crate::numeric::in_range(x.as_dvec3().into()) {
            return Err(src.err(
                v.span(),
                format!("out of range ({})", crate::numeric::contract()),
            ));
        }
        Ok(x)
    };
    let camera = CameraDesc {
        position: vec3(&c.position)?,
        look_at: vec3(&c.look_at)?,
        up: match &c.up {
            Some(u) => vec3(u)?,
            None => Vec3::Y,
        },
        fov: *c.fov.get_ref(),
        aperture: match &c.aperture {
            Some(a) => non_negative(&src, a)?,
            None => 0.0,
        },
        focus_distance: match &c.focus_distance {
            Some(f) => Some(positive(&src, f)?),
            None => None,
        },
    };
    if !(camera.fov > 0.0 && camera.fov < 180.0) {
        return Err(src.err(c.fov.span(), "field of view must be in (0, 180) degrees"));
    }
    if (camera.look_at - camera.position).length() <= 0.0 {
        return Err(src.err(c.look_at.span(), "look_at equals position"));
    }
    let fwd = (camera.look_at - camera.position).normalize();
    if fwd.cross(camera.up).length() <= 1e-6 * camera.up.length() {
        return Err(src.err(
            c.up.as_ref().map_or(c.look_at.span(), |u| u.span()),
            "up is parallel to the viewing direction (or zero)",
        ));
    }

    // [materials.*]
    let mut materials = Vec::new();
    let mut material_maps = Vec::new();
    for (name, m) in &raw.materials {
        materials.push((name.clone(), material(&src, m)?));
        material_maps.push(convert::material_maps(&src, m, &base)?);
    }

    // [[mesh]]
    let mut meshes = Vec::new();
    for m in &raw.mesh {
        let r = m.get_ref();
        let material = materials
            .iter()
            .position(|(n, _)| n == r.material.get_ref())
            .ok_or_else(|| {
                src.err(
                    r.material.span(),
                    format!(
                        "no material named '{}' (defined: {})",
                        r.material.get_ref(),
                        if materials.is_empty() {
                            "none".to_string()
                        } else {
                            materials
                                .iter()
                                .map(|(n, _)| n.as_str())
                                .collect::<Vec<_>>()
                                .join(", ")
                        }
                    ),
                )
            })?;
        let transform = transform(&src, r)?;
        let dicing = match (&r.rate, &r.pixels_per_edge) {
            (Some(a), Some(_)) => {
                return Err(src.err(a.span(), "give either rate or pixels_per_edge, not both"))
            }
            (Some(a), None) => {
                let x = *a.get_ref();
                if !(1..=4096).contains(&x) {
                    return Err(src.err(a.span(), "rate must be in 1..=4096"));
                }
                Dicing::Rate(x as u32)
            }
            (None, Some(p)) => Dicing::PixelsPerEdge(positive_f64(&src, p)?),
            (None, None) => Dicing::PixelsPerEdge(render.pixels_per_edge),
        };
        let max_level = match &r.max_level {
            Some(v) => {
                let x = *v.get_ref();
                let max = crate::patch::table::MAX_LEVEL as i64;
                if !(1..=max).contains(&x) {
                    return Err(src.err(v.span(), format!("max_level must be in 1..={max}")));
                }
                x as usize
            }
            None => crate::patch::table::DEFAULT_MAX_LEVEL,
        };
        let max_rate = match &r.max_rate {
            Some(v) => {
                let x = *v.get_ref();
                if !(1..=4096).contains(&x) {
                    return Err(src.err(v.span(), "max_rate must be in 1..=4096"));
                }
                x as u32
            }
            None => 128,
        };
        let scheme = match &r.scheme {
            None => crate::mesh::Scheme::Catmark,
            Some(s) => match s.get_ref().as_str() {
                "catmark" => crate::mesh::Scheme::Catmark,
                "loop" => crate::mesh::Scheme::Loop,
                other => {
                    return Err(src.err(
                        s.span(),
                        format!("unknown scheme '{other}' (catmark or loop)"),
                    ))
                }
            },
        };
        let surface = match &r.surface {
            None => crate::patch::approx::Approximation::Exact,
            Some(s) => {
                let a: crate::patch::approx::Approximation = s
                    .get_ref()
                    .parse()
                    .map_err(|e: Error| src.err(s.span(), e.message))?;
                if matches!(
                    a,
                    crate::patch::approx::Approximation::Pn
                        | crate::patch::approx::Approximation::Wm
                ) && scheme != crate::mesh::Scheme::Loop
                {
                    return Err(src.err(
                        s.span(),
                        format!(
                            "surface '{a}' approximates Loop meshes; add scheme = \"loop\" \
                             (a Catmull-Clark mesh takes \"exact\" or \"gregory\")"
                        ),
                    ));
                }
                a
            }
        };
        let displace = match &r.displace {
            None => None,
            Some(s) => Some(
                crate::dice::Displacement::parse_in(s.get_ref(), &base)
                    .map_err(|e: Error| src.err(s.span(), e.message))?,
            ),
        };
        let fvar = match &r.fvar {
            None => crate::mesh::FVarMode::default(),
            Some(s) => crate::mesh::FVarMode::from_name(s.get_ref()).ok_or_else(|| {
                let names: Vec<&str> = crate::mesh::FVarMode::NAMES
                    .iter()
                    .map(|(_, n)| *n)
                    .collect();
                src.err(
                    s.span(),
                    format!(
                        "unknown fvar mode '{}' (one of {})",
                        s.get_ref(),
                        names.join(", ")
                    ),
                )
            })?,
        };
        meshes.push(MeshDesc {
            file: base.join(r.file.get_ref()),
            material,
            transform,
            dicing,
            max_level,
            max_rate,
            scheme,
            surface,
            displace,
            fvar,
            line: src.line_of(m.span().start),
        });
    }

    // [[light]]
    let mut quads = Vec::new();
    for l in &raw.light {
        let r = l.get_ref();
        if r.kind.get_ref() != "quad" {
            return Err(src.err(
                r.kind.span(),
                format!(
                    "unknown light type '{}' (expected quad; emissive meshes use an emissive \
                     material)",
                    r.kind.get_ref()
                ),
            ));
        }
        let radiance = radiance(&src, &r.radiance)?;
        let q = QuadLight::new(vec3(&r.corner)?, vec3(&r.edge1)?, vec3(&r.edge2)?, radiance)
            .ok_or_else(|| src.err(r.edge2.span(), "edges are parallel or zero"))?;
        quads.push(q);
    }

    // [environment]
    let environment = match &raw.environment {
        None => None,
        Some(e) => {
            let r = e.get_ref();
            match (&r.radiance, &r.map) {
                (Some(a), Some(_)) => {
                    return Err(src.err(a.span(), "give either radiance or map, not both"))
                }
                (Some(a), None) => {
                    if let Some(i) = r.intensity.as_ref().or(r.rotate.as_ref()) {
                        return Err(src.err(i.span(), "intensity and rotate apply to maps only"));
                    }
                    Some(EnvDesc::Constant(radiance(&src, a)?))
                }
                (None, Some(m)) => Some(EnvDesc::Map {
                    file: base.join(m.get_ref()),
                    intensity: match &r.intensity {
                        Some(i) => non_negative(&src, i)?,
                        None => 1.0,
                    },
                    rotate: match &r.rotate {
                        Some(a) if a.get_ref().is_finite() => *a.get_ref(),
                        Some(a) => return Err(src.err(a.span(), "must be finite")),
                        None => 0.0,
                    },
                    line: src.line_of(m.span().start),
                }),
                (None, None) => return Err(src.err(e.span(), "environment needs radiance or map")),
            }
        }
    };

    Ok(SceneDesc {
        path: path.to_path_buf(),
        render,
        camera,
        materials,
        material_maps,
        meshes,
        quads,
        environment,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    const GOOD: &str = r#"
[render]
width = 64
height = 32
spp = 4

[camera]
position = [0, 1, 5]
look_at = [0, 0, 0]
fov = 40

[materials.clay]
type = "diffuse"
albedo = 0.5

[materials.gold]
type = "conductor"
preset = "gold"
roughness = 0.3

[[mesh]]
file = "box.obj"
material = "clay"
translate = [1, 0, 0]
rotate = [0, 90, 0]
scale = 2
rate = 4

[[mesh]]
file = "sub/other.obj"
material = "gold"

[[light]]
type = "quad"
corner = [-1, 3, -1]
edge1 = [2, 0, 0]
edge2 = [0, 0, 2]
radiance = [5, 5, 5]

[environment]
radiance = 0.2
"#;

    #[test]
    fn parses_a_full_scene() {
        let s = parse_scene(GOOD, Path::new("dir/scene.toml")).unwrap();
        assert_eq!((s.render.width, s.render.height, s.render.spp), (64, 32, 4));
        assert_eq!(s.materials.len(), 2);
        assert_eq!(s.meshes[0].file, Path::new("dir/box.obj"));
        assert_eq!(s.meshes[0].dicing, Dicing::Rate(4));
        assert_eq!(s.meshes[1].dicing, Dicing::PixelsPerEdge(2.0));
        // Materials are sorted: clay = 0.
        assert_eq!(s.meshes[0].material, 0);
        let p = s.meshes[0]
            .transform
            .transform_point3(Vec3::new(1.0, 0.0, 0.0));
        // Scale 2, rotate +90° about y: x → -z; then translate.
        assert!((p - Vec3::new(1.0, 0.0, -2.0)).length() < 1e-5, "{p}");
        assert_eq!(s.quads.len(), 1);
        assert_eq!(s.environment, Some(EnvDesc::Constant(Vec3::splat(0.2))));
    }

    fn err(text: &str) -> String {
        parse_scene(text, Path::new("s.toml"))
            .unwrap_err()
            .to_string()
    }

    #[test]
    fn errors_name_file_key_and_line() {
        let bad = GOOD.replace("fov = 40", "fov = 400");
        assert_eq!(
            err(&bad),
            "s.toml:10: key 'camera.fov': field of view must be in (0, 180) degrees"
        );
        let bad = GOOD.replace("material = \"gold\"", "material = \"gould\"");
        let e = err(&bad);
        assert!(
            e.starts_with("s.toml:31: key 'mesh[1].material': no material named 'gould'"),
            "{e}"
        );
        let bad = GOOD.replace("fov = 40", "fovv = 40");
        let e = err(&bad);
        assert!(
            e.starts_with("s.toml:10: key 'camera.fovv': unknown field"),
            "{e}"
        );
        let bad = GOOD.replace("spp = 4", "spp = \"many\"");
        let e = err(&bad);
        assert!(
            e.starts_with("s.toml:5: key 'render.spp': invalid type"),
            "{e}"
        );
        let bad = GOOD.replace("albedo = 0.5", "albedo = 1.5");
        assert!(err(&bad).starts_with("s.toml:14: key 'materials.clay.albedo':"));
        let bad = GOOD.replace("preset = \"gold\"", "preset = \"gold\"\nior = 1.5");
        assert!(err(&bad).contains("'ior' does not apply to a conductor"));
        let bad = GOOD.replace("edge2 = [0, 0, 2]", "edge2 = [4, 0, 0]");
        assert!(err(&bad).starts_with("s.toml:37: key 'light[0].edge2':"));
        let bad = GOOD.replace("rate = 4", "rate = 4\npixels_per_edge = 1");
        assert!(err(&bad).contains("either rate or pixels_per_edge"));
        let e = err("[camera\n");
        assert!(e.starts_with("s.toml:1:"), "{e}");
        let e = err("[render]\nwidth = 3\n");
        assert!(e.contains("key 'camera': missing field `camera`"), "{e}");
        let e = err(&GOOD.replace("fov = 40\n", ""));
        assert!(e.contains("key 'camera.fov': missing field `fov`"), "{e}");
        // Values of colour keys are described, not named by an internal type.
        let e = err(&GOOD.replace("albedo = 0.5", "albedo = \"grey\""));
        assert_eq!(
            e,
            "s.toml:14: key 'materials.clay.albedo': invalid type: string \"grey\", expected a \
             number or an array of 3 numbers"
        );
        let e = err(&GOOD.replace("radiance = [5, 5, 5]", "radiance = [5, 5]"));
        assert!(
            e.starts_with(
                "s.toml:38: key 'light[0].radiance': invalid length 2, expected a number"
            ),
            "{e}"
        );
        assert!(!e.contains("RawRgb") && !e.contains("untagged"), "{e}");
        // The numeric contract applies to the camera and lights too.
        let e = err(&GOOD.replace("position = [0, 1, 5]", "position = [0, 1, 1e20]"));
        assert!(
            e.starts_with("s.toml:8: key 'camera.position': out of range (the supported range"),
            "{e}"
        );
    }

    #[test]
    fn matrix_transform() {
        let text = GOOD.replace(
            "translate = [1, 0, 0]\nrotate = [0, 90, 0]\nscale = 2\n",
            "matrix = [2,0,0,1, 0,2,0,2, 0,0,2,3, 0,0,0,1]\n",
        );
        let s = parse_scene(&text, Path::new("s.toml")).unwrap();
        let p = s.meshes[0].transform.transform_point3(Vec3::ONE);
        assert_eq!(p, Vec3::new(3.0, 4.0, 5.0));
        let bad = text.replace("0,0,0,1]", "0,0,1,1]");
        assert!(err(&bad).contains("affine"));
    }
}
