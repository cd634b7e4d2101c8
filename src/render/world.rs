//! Everything a render needs, built from a [`SceneDesc`]: the diced meshes under one
//! [`SceneBvh`], materials per instance, lights (quads, emissive meshes, environment) and the
//! camera, with the time each stage took (time to first pixel).

use super::camera::Camera;
use super::env::{EnvMap, Environment};
use super::light::{Lights, MeshLight};
use super::material::Material;
use super::scene::{Dicing, EnvDesc, RenderSettings, SceneDesc};
use crate::bvh::{MeshBvh, SceneBvh};
use crate::dice::{dice, DiceOptions, DiceRate, ScreenRate};
use crate::error::{Error, ErrorKind, Result};
use crate::mesh::obj::read_obj;
use crate::patch::{PatchOptions, PatchTable};
use glam::{Affine3A, Vec3};
use rayon::prelude::*;
use std::sync::Arc;
use std::time::Instant;

/// How long building the world took, stage by stage (wall-clock seconds), and its size.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct BuildStats {
    /// Reading the OBJ files and the environment map.
    pub load_s: f64,
    /// Building the patch tables.
    pub patch_s: f64,
    /// Dicing.
    pub dice_s: f64,
    /// Building the BVHs (per mesh and top level) and the light tables.
    pub bvh_s: f64,
    /// Diced triangles in the scene.
    pub triangles: usize,
    /// Bytes of diced meshes and BVHs.
    pub bytes: usize,
}

impl BuildStats {
    /// Load + patch + dice + BVH: the time to the first pixel.
    pub fn total_s(&self) -> f64 {
        self.load_s + self.patch_s + self.dice_s + self.bvh_s
    }
}

/// A scene ready to render.
pub struct World {
    /// Geometry.
    pub scene: SceneBvh,
    /// Object-to-world transform of each instance.
    pub transforms: Vec<Affine3A>,
    /// Material index of each instance.
    pub instance_material: Vec<u32>,
    /// Materials.
    pub materials: Vec<Material>,
    /// Lights.
    pub lights: Lights,
    /// Camera.
    pub camera: Camera,
    /// Render settings.
    pub settings: RenderSettings,
    /// Build timings.
    pub stats: BuildStats,
    /// Warnings of the build (mesh files' warnings, meshes without a surface): returned, not
    /// printed; the command line prints them.
    pub warnings: Vec<String>,
}

fn largest_scale(m: &Affine3A) -> f64 {
    let c = m.matrix3;
    [c.x_axis, c.y_axis, c.z_axis]
        .iter()
        .map(|a| a.length() as f64)
        .fold(0.0, f64::max)
}

impl World {
    /// Builds the world: reads, dices and indexes every mesh (in parallel), loads the
    /// environment and collects the lights. `settings` overrides the scene file's.
    pub fn build(desc: &SceneDesc, settings: RenderSettings) -> Result<World> {
        let c = &desc.camera;
        let camera = Camera::look_at(
            c.position,
            c.look_at,
            c.up,
            c.fov,
            settings.width,
            settings.height,
            c.aperture,
            c.focus_distance,
        )
        .ok_or_else(|| {
            Error::new(ErrorKind::Usage, "degenerate camera")
                .in_file(desc.path.display().to_string())
        })?;
        let mut stats = BuildStats::default();
        let scene_name = desc.path.display().to_string();

        let t0 = Instant::now();
        let controls: Vec<_> = desc
            .meshes
            .par_iter()
            .map(|m| read_obj(&m.file))
            .collect::<Result<Vec<_>>>()?;
        let mut warnings: Vec<String> = controls
            .iter()
            .flat_map(|m| m.warnings.iter().map(|w| w.to_string()))
            .collect();
        let environment = match &desc.environment {
            None => None,
            Some(EnvDesc::Constant(c)) => Some(Environment::Constant(*c)),
            Some(EnvDesc::Map {
                file,
                intensity,
                rotate,
                line,
            }) => {
                let (w, h, texels) = crate::io::exr::read_rgb(file)?;
                let texels = texels.into_iter().map(Vec3::from).collect();
                let map = EnvMap::new(w, h, texels, *intensity).ok_or_else(|| {
                    Error::new(ErrorKind::Parse, "environment map is empty")
                        .in_file(scene_name.clone())
                        .at_line(*line)
                        .element("key 'environment.map'")
                })?;
                Some(Environment::Map {
                    map: Box::new(map),
                    rotate: rotate.to_radians(),
                })
            }
        };
        stats.load_s = t0.elapsed().as_secs_f64();

        let t0 = Instant::now();
        let tables = desc
            .meshes
            .par_iter()
            .zip(controls.par_iter())
            .map(|(m, mesh)| {
                PatchTable::new(
                    mesh,
                    PatchOptions {
                        max_level: m.max_level,
                        ..PatchOptions::default()
                    },
                )
            })
            .collect::<Result<Vec<_>>>()?;
        stats.patch_s = t0.elapsed().as_secs_f64();

        let t0 = Instant::now();
        let diced = desc
            .meshes
            .par_iter()
            .zip(controls.par_iter().zip(tables.par_iter()))
            .map(|(m, (mesh, table))| {
                let rate = match m.dicing {
                    Dicing::Rate(r) => DiceRate::Uniform(r),
                    Dicing::PixelsPerEdge(p) => {
                        let eye = m.transform.inverse().transform_point3(camera.position);
                        DiceRate::Screen(ScreenRate {
                            eye: [eye.x as f64, eye.y as f64, eye.z as f64],
                            pixels_per_radian: camera.pixels_per_radian() as f64
                                * largest_scale(&m.transform),
                            pixels_per_edge: p,
                        })
                    }
                };
                dice(
                    table,
                    mesh,
                    &DiceOptions {
                        rate,
                        max_rate: m.max_rate,
                    },
                )
                .map_err(|e| e.in_file(m.file.display().to_string()))
            })
            .collect::<Result<Vec<_>>>()?;
        drop(tables);
        drop(controls);
        stats.dice_s = t0.elapsed().as_secs_f64();

        let t0 = Instant::now();
        let bvhs: Vec<Arc<MeshBvh>> = diced
            .into_par_iter()
            .map(|d| Arc::new(MeshBvh::build(d)))
            .collect();
        let mut scene = SceneBvh::new();
        let mut transforms = Vec::new();
        let mut instance_material = Vec::new();
        let mut mesh_lights = Vec::new();
        for (m, bvh) in desc.meshes.iter().zip(&bvhs) {
            if bvh.diced.triangles.is_empty() {
                warnings.push(format!(
                    "{}:{}: mesh {} has no surface (every face a hole?); skipped",
                    scene_name,
                    m.line,
                    m.file.display()
                ));
                continue;
            }
            stats.triangles += bvh.diced.triangles.len();
            stats.bytes += bvh.bytes();
            let id = scene.add_mesh(bvh.clone());
            let inst = scene.add_instance(id, m.transform);
            transforms.push(m.transform);
            instance_material.push(m.material as u32);
            let mat = desc.materials[m.material].1;
            if let Material::Emissive { radiance } = mat {
                if radiance.max_element() > 0.0 {
                    let d = &bvh.diced;
                    let tris = d
                        .triangles
                        .iter()
                        .map(|t| {
                            t.map(|i| {
                                m.transform
                                    .transform_point3(Vec3::from(d.positions[i as usize]))
                            })
                        })
                        .collect();
                    if let Some(l) = MeshLight::new(inst, tris, radiance) {
                        mesh_lights.push(l);
                    }
                }
            }
        }
        scene.build();
        let lights = Lights::new(
            desc.quads.clone(),
            mesh_lights,
            environment,
            scene.num_instances(),
            desc.camera.look_at,
        );
        stats.bvh_s = t0.elapsed().as_secs_f64();

        Ok(World {
            scene,
            transforms,
            instance_material,
            materials: desc.materials.iter().map(|(_, m)| *m).collect(),
            lights,
            camera,
            settings,
            stats,
            warnings,
        })
    }
}
