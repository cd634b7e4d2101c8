//! Instances: one diced mesh placed several times by affine transforms shares its BVH; a world
//! ray meets an instance where the object-space ray meets the mesh (same t), normals are
//! transformed as normals, and the nearest instance wins.

mod common;

use glam::{Affine3A, Quat, Vec3};
use limitray::bvh::{MeshBvh, Ray, SceneBvh};
use limitray::dice::{dice, DiceOptions, DiceRate};
use limitray::grid::GridMesh;
use limitray::patch::{PatchOptions, PatchTable};
use std::sync::Arc;

fn cube_bvh() -> Arc<GridMesh> {
    let mesh = common::cube_builder().build().unwrap();
    let table = PatchTable::new(&mesh, PatchOptions::default()).unwrap();
    let d = dice(
        &table,
        &mesh,
        &DiceOptions {
            rate: DiceRate::Uniform(8),
            max_rate: 64,
            displace: None,
        },
    )
    .unwrap();
    Arc::new(GridMesh::build(&d).unwrap())
}

#[test]
fn instances_share_a_mesh_and_transform_hits() {
    let mesh = cube_bvh();
    let mut scene = SceneBvh::new();
    let id = scene.add_mesh(mesh.clone());
    let xf = [
        Affine3A::from_translation(Vec3::new(10.0, 0.0, 0.0)),
        Affine3A::from_scale_rotation_translation(
            Vec3::new(2.0, 0.5, 1.0),
            Quat::from_rotation_y(0.7),
            Vec3::new(-10.0, 3.0, 1.0),
        ),
        Affine3A::from_translation(Vec3::new(0.0, 0.0, 20.0)),
    ];
    for x in xf {
        scene.add_instance(id, x);
    }
    scene.build();
    assert_eq!(scene.num_instances(), 3);
    let mut rng = limitray::harness::rng::SplitMix64(9);
    let mut hits = 0;
    for _ in 0..5000 {
        let i = rng.below(3);
        let target = xf[i].transform_point3(Vec3::new(
            (rng.next_f64() - 0.5) as f32,
            (rng.next_f64() - 0.5) as f32,
            (rng.next_f64() - 0.5) as f32,
        ));
        let o = Vec3::new(0.0, 40.0, 5.0);
        let ray = Ray::new(o.into(), (target - o).into());
        let h = scene
            .intersect(&ray)
            .expect("aimed at a point inside an instance");
        assert!(scene.occluded(&ray));
        // The same query in the hit instance's object space.
        let inv = xf[h.instance as usize].inverse();
        let oray = Ray::new(
            inv.transform_point3(o).into(),
            inv.transform_vector3(target - o).into(),
        );
        let oh = mesh.intersect(&oray).unwrap();
        assert_eq!(oh.triangle, h.hit.triangle);
        assert!(
            (oh.t - h.hit.t).abs() <= 1e-5 * oh.t,
            "{} vs {}",
            oh.t,
            h.hit.t
        );
        // Normals: world normal ∝ M^-T n.
        let m = xf[h.instance as usize].matrix3;
        let expect = (m.inverse().transpose() * Vec3::from(oh.ng)).normalize();
        assert!(expect.dot(Vec3::from(h.hit.ng)) > 0.9999);
        // Nearest instance: nothing closer along the ray.
        let mut shorter = ray;
        shorter.tmax = h.hit.t * 0.999;
        assert!(scene
            .intersect(&shorter)
            .is_none_or(|s| s.hit.t <= shorter.tmax));
        hits += 1;
    }
    assert_eq!(hits, 5000);
    // A ray between the instances misses; bounds cover all three.
    assert!(scene
        .intersect(&Ray::new([0.0, 40.0, 0.0], [0.0, 1.0, 0.0]))
        .is_none());
    let b = scene.bounds();
    assert!(b[0][0] < -10.0 && b[1][0] > 10.0 && b[1][2] > 20.0);
}

/// A degenerate mesh (tens of thousands of coincident triangles, as a thin shape far from the
/// origin dices into) makes a triangle hierarchy deeper than the fixed traversal stack: the
/// growable stack takes over and every triangle is still reachable; the grid core's top level
/// stays shallow.
#[test]
fn deep_hierarchies_are_traversed_completely() {
    use limitray::dice::{DicedMesh, TriInfo};
    let n = 12_000u32;
    let mut d = DicedMesh::default();
    for i in 0..n {
        // All triangles on top of each other, but for one far corner that differs.
        let x = if i % 1000 == 0 {
            1.0 + i as f32 * 1e-3
        } else {
            1.0
        };
        for p in [[0.0, 0.0, 0.0], [x, 0.0, 0.0], [0.0, 1.0, 0.0]] {
            d.positions.push(p);
            d.normals.push([0.0, 0.0, 1.0]);
            d.params.push(limitray::FaceCoord::default());
        }
        d.triangles.push([3 * i, 3 * i + 1, 3 * i + 2]);
        d.tri_info.push(TriInfo {
            face: i,
            k: 0,
            level: 0,
            uv: [[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]],
        });
    }
    let grid = GridMesh::build(&d).unwrap();
    // The grid's top level halves coincident boxes by their order: its walk fits the GPU's
    // stack.
    limitray::gpu::PackedScene::from_mesh(&grid).unwrap();
    // A top level whose walk could need more than the GPU's stack holds is refused when
    // packed, with the reason (the bound is what the packer checks).
    let mut deep = grid.clone();
    deep.top.stack = 100_000;
    let e = limitray::gpu::PackedScene::from_mesh(&deep).unwrap_err();
    assert!(e.to_string().contains("nodes deep"), "{e}");
    let bvh = MeshBvh::build(d);
    eprintln!("depth {}, grid top level {}", bvh.depth, grid.top.depth);
    assert!(
        bvh.depth >= 64,
        "depth {} does not exercise the growable stack",
        bvh.depth
    );
    // The far corners of every 1000th triangle are each hit by their own ray.
    for i in (1000..n).step_by(1000) {
        let x = 1.0 + i as f32 * 1e-3;
        let ray = Ray::new([x - 0.25, 0.001, 1.0], [0.0, 0.0, -1.0]);
        let h = bvh
            .intersect(&ray)
            .expect("a triangle of the deep hierarchy");
        assert!(
            h.face >= i && bvh.occluded(&ray),
            "ray {i}: face {}",
            h.face
        );
        // The grid core (all loose triangles here) gives the same t; of the coplanar
        // triangles the ray meets (every 1000th from `i` on) it reports the lowest id, where
        // the triangle BVH reports the lowest leaf.
        let g = grid.intersect(&ray).expect("the grid core's hit");
        assert_eq!((g.triangle, g.t.to_bits()), (i, h.t.to_bits()));
        assert!(grid.occluded(&ray));
    }
}
