//! A scene of instances: diced meshes (each a [`GridMesh`], shared between instances) placed
//! by affine transforms, under a top-level CWBVH over the instances' world bounds.
//!
//! Rays are carried into each instance's object space (`o' = M⁻¹o`, `d' = M⁻¹d`, so `t` is
//! unchanged); all triangles of an instance see the same transformed ray, so the watertight
//! guarantee holds per instance. Instance boxes are padded by a relative `1e-5` to absorb the
//! rounding of the transform.

use super::mesh::normalize;
use super::ray::{Hit, Ray};
use super::triangle::PreparedRay;
use crate::grid::GridMesh;
use glam::{Affine3A, Mat3A, Vec3A};
use obvhs::cwbvh::builder::build_cwbvh;
use obvhs::cwbvh::CwBvh;
use obvhs::{aabb::Aabb, Boundable, BvhBuildParams};
use std::sync::Arc;

/// A hit in a scene.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SceneHit {
    /// The hit, with `t` along the world ray and `ng`, `ns` in world space (unit length).
    pub hit: Hit,
    /// Instance that was hit.
    pub instance: u32,
}

#[derive(Clone, Debug)]
pub(crate) struct Instance {
    pub(crate) mesh: u32,
    pub(crate) world_to_object: Affine3A,
    pub(crate) normal_matrix: Mat3A,
    bounds: ([f32; 3], [f32; 3]),
}

/// Instances of diced meshes.
#[derive(Clone, Debug, Default)]
pub struct SceneBvh {
    pub(crate) meshes: Vec<Arc<GridMesh>>,
    pub(crate) instances: Vec<Instance>,
    pub(crate) top: CwBvh,
    /// Instance of each top-level leaf slot.
    pub(crate) top_index: Vec<u32>,
    /// Exact child bounds of the top-level nodes.
    pub(crate) top_boxes: Vec<super::mesh::WideBoxes>,
    /// Levels of the top-level hierarchy.
    pub(crate) top_depth: usize,
}

struct InstBox(([f32; 3], [f32; 3]));

impl Boundable for InstBox {
    fn aabb(&self) -> Aabb {
        Aabb::new(Vec3A::from(self.0 .0), Vec3A::from(self.0 .1))
    }
}

impl SceneBvh {
    /// An empty scene.
    pub fn new() -> SceneBvh {
        SceneBvh::default()
    }

    /// Adds a mesh; returns its id.
    pub fn add_mesh(&mut self, mesh: Arc<GridMesh>) -> u32 {
        self.meshes.push(mesh);
        self.meshes.len() as u32 - 1
    }

    /// The mesh with id `id`.
    pub fn mesh(&self, id: u32) -> &Arc<GridMesh> {
        &self.meshes[id as usize]
    }

    /// Mesh id of instance `i`.
    pub fn instance_mesh(&self, i: u32) -> u32 {
        self.instances[i as usize].mesh
    }

    /// Number of instances.
    pub fn num_instances(&self) -> usize {
        self.instances.len()
    }

    /// Places mesh `mesh` with `object_to_world`; returns the instance id. Call [`Self::build`]
    /// after the last instance.
    pub fn add_instance(&mut self, mesh: u32, object_to_world: Affine3A) -> u32 {
        let [lo, hi] = self.meshes[mesh as usize].bounds();
        let mut b = ([f32::INFINITY; 3], [f32::NEG_INFINITY; 3]);
        if lo[0] <= hi[0] {
            for i in 0..8 {
                let c = Vec3A::new(
                    if i & 1 == 0 { lo[0] } else { hi[0] },
                    if i & 2 == 0 { lo[1] } else { hi[1] },
                    if i & 4 == 0 { lo[2] } else { hi[2] },
                );
                let w = object_to_world.transform_point3a(c);
                for a in 0..3 {
                    b.0[a] = b.0[a].min(w[a]);
                    b.1[a] = b.1[a].max(w[a]);
                }
            }
            for a in 0..3 {
                let pad = 1e-5 * (b.0[a].abs().max(b.1[a].abs()) + (b.1[a] - b.0[a]));
                b.0[a] -= pad;
                b.1[a] += pad;
            }
        }
        let m3 = object_to_world.matrix3;
        self.instances.push(Instance {
            mesh,
            world_to_object: object_to_world.inverse(),
            normal_matrix: m3.inverse().transpose(),
            bounds: b,
        });
        self.instances.len() as u32 - 1
    }

    /// Builds the top level.
    pub fn build(&mut self) {
        let boxes: Vec<InstBox> = self
            .instances
            .iter()
            .filter(|i| i.bounds.0[0] <= i.bounds.1[0])
            .map(|i| InstBox(i.bounds))
            .collect();
        let live: Vec<u32> = (0..self.instances.len() as u32)
            .filter(|&i| {
                let b = self.instances[i as usize].bounds;
                b.0[0] <= b.1[0]
            })
            .collect();
        if boxes.is_empty() {
            self.top = CwBvh::default();
            self.top_index.clear();
            return;
        }
        let mut params = BvhBuildParams::medium_build();
        params.pre_split = false;
        params.max_prims_per_leaf = 1;
        let mut top = super::mesh::build_deep(|| {
            build_cwbvh(&boxes, params, &mut std::time::Duration::default())
        });
        self.top_index = top
            .primitive_indices
            .iter()
            .map(|&i| live[i as usize])
            .collect();
        let corners: Vec<[[f32; 3]; 3]> = self
            .top_index
            .iter()
            .map(|&i| {
                let b = self.instances[i as usize].bounds;
                [b.0, b.1, b.1]
            })
            .collect();
        let (_, boxes, depth) = super::mesh::make_conservative(&mut top, &corners);
        self.top_boxes = boxes;
        self.top_depth = depth;
        self.top = top;
    }

    /// World bounds of all instances.
    pub fn bounds(&self) -> [[f32; 3]; 2] {
        let mut b = [[f32::INFINITY; 3], [f32::NEG_INFINITY; 3]];
        for i in &self.instances {
            for a in 0..3 {
                b[0][a] = b[0][a].min(i.bounds.0[a]);
                b[1][a] = b[1][a].max(i.bounds.1[a]);
            }
        }
        b
    }

    fn object_ray(&self, inst: &Instance, ray: &Ray, tmax: f32) -> Ray {
        let o = inst
            .world_to_object
            .transform_point3a(Vec3A::from(ray.origin));
        let d = inst
            .world_to_object
            .transform_vector3a(Vec3A::from(ray.dir));
        Ray {
            origin: o.into(),
            dir: d.into(),
            tmin: ray.tmin,
            tmax,
        }
    }

    fn traverse(&self, ray: &Ray, mut leaf: impl FnMut(u32, f32) -> (f32, bool)) {
        let Some(r) = PreparedRay::new(ray) else {
            return;
        };
        let pf = super::mesh::Prefetch::nodes_only(&self.top_boxes, &self.top.nodes);
        super::mesh::walk(&self.top, self.top_depth, pf, &r, |li, tmax| {
            leaf(self.top_index[li], tmax)
        });
    }

    /// Closest hit.
    pub fn intersect(&self, ray: &Ray) -> Option<SceneHit> {
        let mut best: Option<SceneHit> = None;
        self.traverse(ray, |i, tmax| {
            let inst = &self.instances[i as usize];
            let oray = self.object_ray(inst, ray, tmax);
            if let Some(mut h) = self.meshes[inst.mesh as usize].intersect(&oray) {
                // Equal t: the lowest instance wins (independent of traversal order).
                if best.is_none_or(|b| h.t < b.hit.t || (h.t == b.hit.t && i < b.instance)) {
                    h.ng = self.to_world_normal(inst, h.ng);
                    h.ns = self.to_world_normal(inst, h.ns);
                    best = Some(SceneHit {
                        hit: h,
                        instance: i,
                    });
                    return (h.t, false);
                }
            }
            (tmax, false)
        });
        best
    }

    /// True if anything is hit in `[tmin, tmax]`.
    pub fn occluded(&self, ray: &Ray) -> bool {
        let mut hit = false;
        self.traverse(ray, |i, tmax| {
            let inst = &self.instances[i as usize];
            let oray = self.object_ray(inst, ray, tmax);
            if self.meshes[inst.mesh as usize].occluded(&oray) {
                hit = true;
                return (tmax, true);
            }
            (tmax, false)
        });
        hit
    }

    /// The hit record of the triangle at `leaf` ([`Hit::leaf`]) of instance `instance` at `t`
    /// with barycentrics `b1, b2`: what [`Self::intersect`] returns for that triangle (the GPU
    /// backend's hits are completed with it).
    pub fn hit_record(&self, instance: u32, leaf: u32, t: f32, b1: f32, b2: f32) -> SceneHit {
        let inst = &self.instances[instance as usize];
        let mut h = self.meshes[inst.mesh as usize].hit_at(leaf, t, b1, b2);
        h.ng = self.to_world_normal(inst, h.ng);
        h.ns = self.to_world_normal(inst, h.ns);
        SceneHit { hit: h, instance }
    }

    /// The object-space corners of instance `instance`'s triangle at `leaf` and their
    /// `(u, v)`.
    pub fn triangle(&self, instance: u32, leaf: u32) -> ([[f32; 3]; 3], [[f32; 2]; 3]) {
        let m = &self.meshes[self.instances[instance as usize].mesh as usize];
        (m.corners(leaf), m.corner_uvs(leaf))
    }

    fn to_world_normal(&self, inst: &Instance, n: [f32; 3]) -> [f32; 3] {
        normalize(inst.normal_matrix.mul_vec3a(Vec3A::from(n)).into())
    }
}
