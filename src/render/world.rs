//! Everything a render needs, built from a [`SceneDesc`]: the diced meshes under one
//! [`SceneBvh`], materials per instance, lights (quads, emissive meshes, environment) and the
//! camera, with the time each stage took (time to first pixel).

use super::camera::Camera;
use super::env::{EnvMap, Environment};
use super::light::{Lights, MeshLight};
use super::material::Material;
use super::scene::{Dicing, EnvDesc, MeshDesc, RenderSettings, SceneDesc};
use super::texturing::{InstanceMaps, MaterialTextures};
use crate::bvh::SceneBvh;
use crate::dice::{DiceOptions, DiceRate, ScreenRate};
use crate::error::{Error, ErrorKind, Result};
use crate::grid::GridMesh;
use crate::mesh::obj::read_obj;
use crate::mesh::ControlMesh;
use crate::patch::uv::UvSurface;
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
    /// Dicing, straight into each mesh's grid blocks and their top level
    /// ([`GridMesh::dice`]).
    pub dice_s: f64,
    /// Building the scene's top level and the light tables.
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
    /// Texture maps of each material (parallel to `materials`).
    pub textures: Vec<MaterialTextures>,
    /// What each instance's maps are addressed by (`None` when its material has none).
    pub instance_maps: Vec<Option<Arc<InstanceMaps>>>,
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

/// The index of `x` in `list`, appending it when new.
fn index_of<T: PartialEq>(list: &mut Vec<T>, x: T) -> usize {
    match list.iter().position(|y| *y == x) {
        Some(i) => i,
        None => {
            list.push(x);
            list.len() - 1
        }
    }
}

/// What makes two dicings of one patch table the same: the options, compared by their bits
/// (a screen-space rate includes the eye in object space, so only instances with the same
/// transform share it).
#[derive(Clone, PartialEq, Eq)]
struct DiceKey([u64; 6], Option<String>);

impl DiceKey {
    fn of(o: &DiceOptions) -> DiceKey {
        let m = o.max_rate as u64;
        let [a, b, c, d, e, f] = match o.rate {
            DiceRate::Uniform(r) => [0, r as u64, m, 0, 0, 0],
            DiceRate::EdgeLength(l) => [1, l.to_bits(), m, 0, 0, 0],
            DiceRate::Screen(s) => [
                2 | m << 8,
                s.eye[0].to_bits(),
                s.eye[1].to_bits(),
                s.eye[2].to_bits(),
                s.pixels_per_radian.to_bits(),
                s.pixels_per_edge.to_bits(),
            ],
        };
        DiceKey([a, b, c, d, e, f], o.displace.as_ref().map(|d| d.key()))
    }
}

/// Checks that `mesh` placed by the entry's transform stays inside the numeric contract
/// ([`crate::numeric`]). The limit surface lies in the convex hull of the control points, so
/// the eight corners of the transformed control box bound it.
fn check_transformed(mesh: &ControlMesh, m: &MeshDesc, index: usize, scene: &str) -> Result<()> {
    let [lo, hi] = mesh.bounds();
    let t = &m.transform;
    let m3 = t.matrix3;
    let cols = [m3.x_axis, m3.y_axis, m3.z_axis];
    let mut worst = 0.0f64;
    for c in 0..8 {
        let p = [
            if c & 1 == 0 { lo[0] } else { hi[0] },
            if c & 2 == 0 { lo[1] } else { hi[1] },
            if c & 4 == 0 { lo[2] } else { hi[2] },
        ];
        for a in 0..3 {
            // In f64, so that the check itself cannot overflow.
            let w = t.translation[a] as f64
                + cols[0][a] as f64 * p[0]
                + cols[1][a] as f64 * p[1]
                + cols[2][a] as f64 * p[2];
            worst = worst.max(if w.is_nan() { f64::INFINITY } else { w.abs() });
        }
    }
    if worst > crate::numeric::MAX_COORD {
        return Err(Error::new(
            ErrorKind::Parse,
            format!(
                "{} placed by this entry's transform reaches |coordinate| = {worst:.3e}, out of \
                 range ({}); scale it down",
                m.file.display(),
                crate::numeric::contract()
            ),
        )
        .in_file(scene.to_string())
        .at_line(m.line)
        .element(format!("key 'mesh[{index}]'")));
    }
    Ok(())
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

        crate::memory::check(
            &format!("a {} × {} render", settings.width, settings.height),
            super::film::estimate_bytes(settings.width, settings.height),
            "lower the resolution (--width/--height, or the scene's render.width/height)",
        )?;

        // Identical meshes are instances: each file is read once, each (file, max_level)
        // gets one patch table, and each table diced the same way one diced mesh and BVH.
        let t0 = Instant::now();
        let mut files: Vec<&std::path::Path> = Vec::new();
        let file_of: Vec<usize> = desc
            .meshes
            .iter()
            .map(|m| index_of(&mut files, m.file.as_path()))
            .collect();
        let controls: Vec<_> = files
            .par_iter()
            .map(|f| read_obj(f))
            .collect::<Result<Vec<_>>>()?;
        let mut warnings: Vec<String> = controls
            .iter()
            .flat_map(|m| m.warnings.iter().map(|w| w.to_string()))
            .collect();
        for (i, m) in desc.meshes.iter().enumerate() {
            check_transformed(&controls[file_of[i]], m, i, &scene_name)?;
        }
        let environment = match &desc.environment {
            None => None,
            Some(EnvDesc::Constant(c)) => Some(Environment::Constant(*c)),
            Some(EnvDesc::Map {
                file,
                intensity,
                rotate,
                line,
            }) => {
                let at = |e: Error| {
                    e.in_file(scene_name.clone())
                        .at_line(*line)
                        .element("key 'environment.map'")
                };
                let (w, h, texels) = crate::io::exr::read_rgb(file)?;
                let texels: Vec<Vec3> = texels.into_iter().map(Vec3::from).collect();
                let report = super::env::TexelReport::new(&texels, *intensity);
                if report.non_finite > 0 {
                    let (x, y) = (report.first_non_finite % w, report.first_non_finite / w);
                    return Err(at(Error::new(
                        ErrorKind::Parse,
                        format!(
                            "{}: {} of {} texels are NaN or infinite{} (the first at column {x}, \
                             row {y}); an environment map must be finite",
                            file.display(),
                            report.non_finite,
                            texels.len(),
                            if *intensity != 1.0 {
                                " after the intensity is applied"
                            } else {
                                ""
                            },
                        ),
                    )));
                }
                if report.negative > 0 {
                    warnings.push(format!(
                        "{scene_name}:{line}: key 'environment.map': {}: {} of {} texels \
                         have negative components; they are read as 0",
                        file.display(),
                        report.negative,
                        texels.len()
                    ));
                }
                let map = EnvMap::new(w, h, texels, *intensity)
                    .ok_or_else(|| at(Error::new(ErrorKind::Parse, "environment map is empty")))?;
                Some(Environment::Map {
                    map: Box::new(map),
                    rotate: rotate.to_radians(),
                })
            }
        };
        let textures = desc
            .material_maps
            .iter()
            .map(|m| MaterialTextures::open(m, &scene_name))
            .collect::<Result<Vec<_>>>()?;
        stats.load_s = t0.elapsed().as_secs_f64();

        let t0 = Instant::now();
        type TableKey = (
            usize,
            usize,
            crate::mesh::Scheme,
            crate::patch::approx::Approximation,
            crate::mesh::FVarMode,
        );
        let mut table_keys: Vec<TableKey> = Vec::new();
        let table_of: Vec<usize> = desc
            .meshes
            .iter()
            .zip(&file_of)
            .map(|(m, &f)| {
                index_of(
                    &mut table_keys,
                    (f, m.max_level, m.scheme, m.surface, m.fvar),
                )
            })
            .collect();
        let tables = table_keys
            .par_iter()
            .map(|&(f, max_level, scheme, surface, fvar)| {
                PatchTable::with_options(
                    &controls[f],
                    crate::mesh::Options {
                        scheme,
                        fvar,
                        ..controls[f].options
                    },
                    PatchOptions {
                        max_level,
                        surface,
                        ..PatchOptions::default()
                    },
                )
            })
            .map(|t| t.map(Arc::new))
            .collect::<Result<Vec<_>>>()?;
        // Texture coordinates of the tables whose instances' maps read them.
        let mut uv_of_table: Vec<Option<Arc<UvSurface>>> = vec![None; tables.len()];
        for (i, m) in desc.meshes.iter().enumerate() {
            let (ti, f) = (table_of[i], file_of[i]);
            if textures[m.material].uses_uv()
                && uv_of_table[ti].is_none()
                && !controls[f].face_uvs.is_empty()
            {
                let mesh = ControlMesh {
                    options: tables[ti].mesh_options,
                    ..controls[f].clone()
                };
                uv_of_table[ti] = UvSurface::new(&mesh, m.fvar)
                    .map_err(|e| e.in_file(m.file.display().to_string()))?
                    .map(Arc::new);
            }
        }
        stats.patch_s = t0.elapsed().as_secs_f64();

        let t0 = Instant::now();
        let options: Vec<DiceOptions> = desc
            .meshes
            .iter()
            .map(|m| {
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
                DiceOptions {
                    rate,
                    max_rate: m.max_rate,
                    displace: m.displace.clone(),
                }
            })
            .collect();
        let mut jobs: Vec<(usize, DiceKey)> = Vec::new();
        let job_of: Vec<usize> = (0..desc.meshes.len())
            .map(|i| index_of(&mut jobs, (table_of[i], DiceKey::of(&options[i]))))
            .collect();
        let first_user: Vec<usize> = (0..jobs.len())
            .map(|j| job_of.iter().position(|&x| x == j).unwrap_or(0))
            .collect();
        // Every distinct dicing planned (its edge rates measured, once), the whole scene's
        // memory checked, and then each diced by its plan.
        let plans = first_user
            .par_iter()
            .map(|&i| crate::dice::plan(&tables[table_of[i]], &controls[file_of[i]], &options[i]))
            .collect::<Result<Vec<_>>>()?;
        crate::memory::check(
            &format!(
                "dicing and indexing the scene's {} distinct meshes",
                jobs.len()
            ),
            plans.iter().map(|p| p.estimate().bytes_with_bvh()).sum(),
            "lower the dicing rates (the meshes' rate, max_rate or pixels_per_edge)",
        )?;
        let job_grids: Vec<Arc<GridMesh>> = plans
            .into_par_iter()
            .zip(first_user.par_iter())
            .map(|(plan, &i)| {
                let m = &desc.meshes[i];
                let (table, mesh) = (&tables[table_of[i]], &controls[file_of[i]]);
                GridMesh::dice_planned(table, mesh, &options[i], plan)
                    .map(Arc::new)
                    .map_err(|e| e.in_file(m.file.display().to_string()))
            })
            .collect::<Result<Vec<_>>>()?;
        drop(controls);
        stats.dice_s = t0.elapsed().as_secs_f64();

        let t0 = Instant::now();
        // Emissive meshes' triangles, in the diced mesh's order.
        let mut light_tris: Vec<Option<Vec<[[f32; 3]; 3]>>> = vec![None; job_grids.len()];
        for (m, &job) in desc.meshes.iter().zip(&job_of) {
            if emitted(desc.materials[m.material].1).is_some() && light_tris[job].is_none() {
                light_tris[job] = Some(job_grids[job].triangle_corners());
            }
        }
        let grids: Vec<Arc<GridMesh>> = job_of.iter().map(|&j| job_grids[j].clone()).collect();
        let mut scene = SceneBvh::new();
        let mut transforms = Vec::new();
        let mut instance_material = Vec::new();
        let mut instance_maps = Vec::new();
        let mut mesh_lights = Vec::new();
        let mut mesh_id: Vec<Option<u32>> = vec![None; job_grids.len()];
        for (i, ((m, grid), &job)) in desc.meshes.iter().zip(&grids).zip(&job_of).enumerate() {
            if grid.triangles == 0 {
                warnings.push(format!(
                    "{}:{}: mesh {} has no surface (every face a hole?); skipped",
                    scene_name,
                    m.line,
                    m.file.display()
                ));
                continue;
            }
            stats.triangles += grid.triangles;
            let id = match mesh_id[job] {
                Some(id) => id,
                None => {
                    stats.bytes += grid.bytes();
                    let id = scene.add_mesh(grid.clone());
                    mesh_id[job] = Some(id);
                    id
                }
            };
            let inst = scene.add_instance(id, m.transform);
            transforms.push(m.transform);
            instance_material.push(m.material as u32);
            let maps = &textures[m.material];
            instance_maps.push((!maps.is_empty()).then(|| {
                Arc::new(InstanceMaps {
                    uv: uv_of_table[table_of[i]].clone(),
                    to_world: m.transform,
                    to_object: m.transform.inverse(),
                })
            }));
            let mat = desc.materials[m.material].1;
            // A textured emitter is not sampled as a light (its radiance varies over it): paths
            // find it by BSDF sampling alone, which stays unbiased.
            let lit = if maps.emission.is_some() {
                None
            } else {
                emitted(mat)
            };
            if let (Some(radiance), Some(tris)) = (lit, &light_tris[job]) {
                let tris = tris
                    .iter()
                    .map(|t| t.map(|p| m.transform.transform_point3(Vec3::from(p))))
                    .collect();
                if let Some(l) = MeshLight::new(inst, tris, radiance) {
                    mesh_lights.push(l);
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
            textures,
            instance_maps,
            lights,
            camera,
            settings,
            stats,
            warnings,
        })
    }
}

/// The radiance of a material that lights the scene: emissive and not black.
fn emitted(mat: Material) -> Option<Vec3> {
    match mat {
        Material::Emissive { radiance } if radiance.max_element() > 0.0 => Some(radiance),
        _ => None,
    }
}
