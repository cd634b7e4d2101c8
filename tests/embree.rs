//! Cross-checks against Embree 4.4 (feature `embree`; run `bash scripts/setup-embree.sh` first):
//!
//!     cargo test --release --features embree --test embree
//!
//! Tolerances, and the numbers measured on this project's machines that justify them:
//!
//! - `rtcInterpolate` against `PatchTable::eval` (Chaikin mode), relative to the diagonal:
//!   2e-5. Measured maxima on the shapes that agree: ≤ 4e-7 on most shapes, 1.4e-6 (rook),
//!   2.9e-6 (catmark_flap) from Embree's `f32` evaluation, and 5.3e-6 / 1.1e-5 near the ends
//!   of infinitely sharp creases (catmark_inf_crease1 / 0), where Embree approximates.
//!   Shapes whose rules differ from OpenSubdiv's in Embree are listed in `DIFFERENT`, with the
//!   reason and the measured size. Embree's hole faces are removed from its topology (their
//!   edges become boundaries) where OpenSubdiv keeps them as control faces: hole shapes are
//!   compared with the hole faces deleted, and match.
//! - limitray's diced surface against Embree's subdivision geometry at the same rate:
//!   hit/miss agreement > 99.5% (the two tessellations differ at silhouettes; measured
//!   99.89% on a 5-sided prism at rate 8, 99.9995% on catmark_car at rate 16).
//! - Same triangles, same rays: ≥ 99.99% of rays hit the same triangle or both miss
//!   (measured 99.997% of 10^6 rays on catmark_car at rate 16); every other ray is
//!   edge-grazing (hit within `EDGE_TOLERANCE` = 1e-5 of the ray's float scale from an edge;
//!   measured ≤ 3.7e-7). Same-triangle hits agree in `t` within 1e-6 relative, except at
//!   grazing incidence, where `|Δt| cos θ / t` ≤ 1e-6 (measured ≤ 8.7e-8, i.e. about 1 ulp).
//! - limitray leaks nothing on rays through diced vertices and edge points (0 of 10^5,
//!   in place and translated to (148376, 1234, −223423)).
#![cfg(feature = "embree")]
// Parallel arrays indexed by the same element, as in the library.
#![allow(clippy::needless_range_loop)]

mod common;

use limitray::embree::crosscheck::{
    crosscheck, embree_table, interpolation_check, interpolation_check_with, limitray_bvh,
    triangle_check_with, EDGE_TOLERANCE,
};
use limitray::embree::rays;
use limitray::embree::subdiv::{
    embree_uv_to_ptex, ptex_to_embree_uv, subdivision_geometry, subdivision_scene,
};
use limitray::embree::{bench, ffi, triangles, Device, SceneOptions};
use limitray::mesh::{obj::read_obj, BoundaryInterpolation, ControlMesh, MeshBuilder};
use limitray::FaceCoord;
use std::mem::{align_of, offset_of, size_of};

/// Embree's limit surface against limitray's (relative to the diagonal) on shapes whose rules
/// agree.
const SURFACE_TOLERANCE: f64 = 2e-5;

/// Shapes on which Embree's subdivision rules differ from OpenSubdiv's (which limitray
/// follows), with the reason and the largest difference measured (relative to the diagonal).
const DIFFERENT: &[(&str, &str)] = &[
    ("catmark_chaikin0", "semi-sharp creases of varying sharpness (2.4e-2)"),
    ("catmark_chaikin1", "semi-sharp creases of varying sharpness (2.4e-2)"),
    ("catmark_chaikin2", "semi-sharp creases of varying sharpness (2.3e-2)"),
    ("catmark_cube_creases1", "creases of different sharpness meet (4.0e-2)"),
    ("catmark_cube_creases2", "creases of different sharpness meet (4.7e-2)"),
    ("catmark_cubes_semisharp", "creases of different sharpness meet (2.4e-2)"),
    ("catmark_cubes_infsharp", "a 0.1 crease meets infinitely sharp ones (2.8e-2)"),
    ("catmark_fvar_bound2", "semi-sharp corners 0.1 to 2.1 (2.2e-2)"),
    ("catmark_edgeonly", "edge-only boundary vs SMOOTH_BOUNDARY at corners (2.2e-3)"),
    ("catmark_dart_edgeonly", "edge-only boundary vs SMOOTH_BOUNDARY (9.4e-4)"),
    ("catmark_gregory_test6", "edge-only boundary vs SMOOTH_BOUNDARY (1.6e-3)"),
    ("catmark_gregory_test7", "edge-only boundary vs SMOOTH_BOUNDARY (1.6e-3)"),
    ("catmark_edgenone", "NO_BOUNDARY drops more patches than boundary 'none' (8e-4 at random parameters; hits agree)"),
    ("catmark_fan", "non-manifold edges (4.3e-2)"),
    ("catmark_nonman_verts", "non-manifold vertices (6.7e-2)"),
    ("catmark_gregory_test8", "interior vertex of valence 2 (2.4e-2)"),
    (
        "catmark_nonman_edges",
        "faces that repeat a vertex: OpenSubdiv's degenerate edges, not Embree's (2.2e-2)",
    ),
    (
        "catmark_smoothtris1",
        "smooth triangles (OpenSubdiv's TRI_SUB_SMOOTH; Embree has only Catmull-Clark's rule) (2.1e-2)",
    ),
    (
        "catmark_nonman_quadpole8",
        "faces that repeat a vertex: OpenSubdiv's degenerate edges, not Embree's (2.6e-3)",
    ),
    ("catmark_val2_back2back", "vertices of valence 2 (4.9e-3)"),
    ("catmark_val2_foldover", "vertices of valence 2 (9.2e-3)"),
    ("catmark_val2_interior", "vertices of valence 2 (1.2e-2)"),
    ("catmark_val2_nonman", "valence 2, non-manifold (9.8e-2)"),
    ("catmark_single_crease", "fractional crease sharpness 2.0 to 5.7 (1.6e-2)"),
    ("catmark_square_hedit0", "hierarchical edits (Embree has none); edge-only boundary"),
    ("catmark_square_hedit1", "hierarchical edits (Embree has none); edge-only boundary"),
    ("catmark_square_hedit2", "hierarchical edits (Embree has none); edge-only boundary"),
    ("catmark_square_hedit3", "hierarchical edits (Embree has none); edge-only boundary"),
    ("catmark_square_hedit4", "hierarchical edits (Embree has none); edge-only boundary"),
    ("catmark_tent", "edge-only boundary vs SMOOTH_BOUNDARY (1.5e-3)"),
];

fn device() -> Device {
    Device::new("").expect("Embree device")
}

#[test]
fn struct_layout_matches_embree_4_4() {
    assert_eq!(size_of::<ffi::RTCRay>(), 48);
    assert_eq!(align_of::<ffi::RTCRay>(), 16);
    assert_eq!(size_of::<ffi::RTCHit>(), 48);
    assert_eq!(align_of::<ffi::RTCHit>(), 16);
    assert_eq!(size_of::<ffi::RTCRayHit>(), 96);
    assert_eq!(offset_of!(ffi::RTCRay, tfar), 32);
    assert_eq!(offset_of!(ffi::RTCRay, flags), 44);
    assert_eq!(offset_of!(ffi::RTCRayHit, hit), 48);
    assert_eq!(offset_of!(ffi::RTCHit, u), 12);
    assert_eq!(offset_of!(ffi::RTCHit, primID), 20);
    assert_eq!(offset_of!(ffi::RTCHit, geomID), 24);
    assert_eq!(offset_of!(ffi::RTCHit, instID), 28);
    assert_eq!(offset_of!(ffi::RTCHit, instPrimID), 32);
    assert_eq!(size_of::<ffi::RTCBounds>(), 32);
    assert_eq!(size_of::<ffi::RTCInterpolateArguments>(), 88);
    assert_eq!(offset_of!(ffi::RTCInterpolateArguments, P), 32);
    assert_eq!(offset_of!(ffi::RTCInterpolateArguments, valueCount), 80);
    assert_eq!(device().version(), 40400);
}

/// One big triangle in the z = 0 plane.
fn one_triangle() -> limitray::dice::DicedMesh {
    limitray::dice::DicedMesh {
        positions: vec![[-1.0, -1.0, 0.0], [3.0, -1.0, 0.0], [-1.0, 3.0, 0.0]],
        normals: vec![[0.0, 0.0, 1.0]; 3],
        params: vec![limitray::FaceCoord::default(); 3],
        triangles: vec![[0, 1, 2]],
        tri_info: vec![limitray::dice::TriInfo {
            face: 0,
            k: 0,
            level: 0,
            uv: [[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]],
        }],
        grids: Vec::new(),
        grid_frames: Vec::new(),
    }
}

/// The library writes the 4.4 record: `instPrimID[0]` is set on a hit and nothing beyond the
/// 96 bytes is touched (embree4-sys's 80-byte record would be overrun by 16 bytes).
#[test]
fn intersect_writes_exactly_the_4_4_record() {
    #[repr(C, align(16))]
    struct Guarded {
        rh: ffi::RTCRayHit,
        canary: [u32; 8],
    }
    let dev = device();
    let scene = triangles::triangle_scene(&dev, &one_triangle(), SceneOptions::default()).unwrap();
    let mut g = Guarded {
        rh: ffi::RTCRayHit::default(),
        canary: [0xDEAD_BEEF; 8],
    };
    g.rh.ray = ffi::RTCRay {
        org_x: 0.25,
        org_y: 0.5,
        org_z: 2.0,
        dir_z: -1.0,
        tfar: f32::INFINITY,
        mask: u32::MAX,
        ..Default::default()
    };
    g.rh.hit.geomID = ffi::RTC_INVALID_GEOMETRY_ID;
    g.rh.hit.instID = [0x1234_5678];
    g.rh.hit.instPrimID = [0x1234_5678];
    scene.intersect_raw(&mut g.rh);
    assert_eq!(g.rh.hit.geomID, 0);
    assert_eq!(g.rh.hit.primID, 0);
    assert!((g.rh.ray.tfar - 2.0).abs() < 1e-6);
    assert_eq!(g.rh.hit.instID[0], ffi::RTC_INVALID_GEOMETRY_ID);
    assert_eq!(g.rh.hit.instPrimID[0], ffi::RTC_INVALID_GEOMETRY_ID);
    assert_eq!(g.canary, [0xDEAD_BEEF; 8]);
    // The safe wrapper: barycentrics of corners 1 and 2 (u = (0.25+1)/4, v = (0.5+1)/4).
    let h = scene
        .intersect([0.25, 0.5, 2.0], [0.0, 0.0, -1.0], 0.0, f32::INFINITY)
        .unwrap();
    assert!(
        (h.u - 0.3125).abs() < 1e-6 && (h.v - 0.375).abs() < 1e-6,
        "{h:?}"
    );
    assert!(scene.occluded([0.25, 0.5, 2.0], [0.0, 0.0, -1.0], 0.0, 10.0));
    assert!(!scene.occluded([0.25, 0.5, 2.0], [0.0, 0.0, -1.0], 0.0, 1.0));
    assert!(scene
        .intersect([5.0, 5.0, 2.0], [0.0, 0.0, -1.0], 0.0, f32::INFINITY)
        .is_none());
}

#[test]
fn bad_input_gives_errors_not_crashes() {
    let dev = device();
    let cube = common::cube_builder().build().unwrap();
    for rate in [0.0, -1.0, f32::NAN, 1e6] {
        let e = subdivision_geometry(&dev, &cube, BoundaryInterpolation::EdgeAndCorner, rate);
        assert!(e.is_err(), "rate {rate}");
    }
    // A 16-gon (Embree takes 3 to 15 vertices per face).
    let n = 16;
    let pos: Vec<[f64; 3]> = (0..n)
        .map(|i| {
            let a = i as f64 / n as f64 * std::f64::consts::TAU;
            [a.cos(), a.sin(), 0.0]
        })
        .collect();
    let big = MeshBuilder::new()
        .positions(pos)
        .faces(&[n], &(0..n as u32).collect::<Vec<_>>())
        .build()
        .unwrap();
    let e = subdivision_geometry(&dev, &big, BoundaryInterpolation::EdgeAndCorner, 4.0)
        .err()
        .unwrap();
    assert!(e.message.contains("at most 15"), "{e}");
    if let Some(models) = common::shared_models() {
        let pole = read_obj(&models.join("opensubdiv/catmark_pole360.obj")).unwrap();
        let e = subdivision_geometry(&dev, &pole, BoundaryInterpolation::EdgeAndCorner, 4.0)
            .err()
            .unwrap();
        assert!(
            e.message.contains("at most 64 faces around a vertex"),
            "{e}"
        );
    }
    // An invalid mesh is reported by validation.
    let mut broken = cube.clone();
    broken.face_verts[0] = 99;
    assert!(subdivision_geometry(&dev, &broken, BoundaryInterpolation::None, 4.0).is_err());
    assert!(Device::new("bad\0config").is_err());
}

#[test]
fn uv_mapping_round_trips() {
    for n in [3usize, 4, 5, 7, 9] {
        for k in 0..if n == 4 { 1 } else { n } {
            for &(u, v) in &[(0.0, 0.0), (1.0, 0.0), (0.0, 1.0), (0.3, 0.7), (1.0, 1.0)] {
                let (eu, ev) = ptex_to_embree_uv(n, k, u, v);
                let (k2, u2, v2) = embree_uv_to_ptex(n, eu, ev);
                assert_eq!(k2, k, "n {n} k {k}");
                assert!((u2 - u).abs() < 1e-6 && (v2 - v).abs() < 1e-6);
            }
        }
    }
}

/// A closed prism with two `n`-gon caps (`n` = 7 puts sub-faces 4..6 in Embree's second row
/// of the packed (u, v)) and `n` quads around, slightly irregular.
fn prism(n: usize, tagged: bool) -> ControlMesh {
    let mut pos = Vec::new();
    for z in [-1.0, 1.0] {
        for i in 0..n {
            let a = i as f64 / n as f64 * std::f64::consts::TAU;
            let r = 1.0 + 0.15 * (i % 3) as f64;
            pos.push([r * a.cos(), r * a.sin(), z * (1.0 + 0.05 * i as f64)]);
        }
    }
    let n32 = n as u32;
    let mut idx: Vec<u32> = (0..n32).rev().collect();
    idx.extend(n32..2 * n32);
    let mut sizes = vec![n, n];
    for i in 0..n32 {
        let j = (i + 1) % n32;
        idx.extend([i, j, n32 + j, n32 + i]);
        sizes.push(4);
    }
    let b = MeshBuilder::new().positions(pos).faces(&sizes, &idx);
    let b = if tagged {
        b.crease(n32, n32 + 1, 2.5)
            .crease(2, 3, 10.0)
            .corner(n32 + 2, 0.5)
    } else {
        b
    };
    b.build().unwrap()
}

#[test]
fn quad_orientation_and_ngon_packing_on_generated_meshes() {
    // Quads: Embree's (u, v) at the corners of a quad of the grid are the ptex corners.
    let grid = limitray::mesh::generate::grid(6);
    let table = embree_table(&grid).unwrap();
    let dev = device();
    let scene = subdivision_scene(
        &dev,
        &grid,
        grid.options.boundary,
        4.0,
        SceneOptions::default(),
    )
    .unwrap();
    for f in [7u32, 14, 20] {
        for &(u, v) in &[(0.0, 0.0), (1.0, 0.0), (1.0, 1.0), (0.0, 1.0), (0.2, 0.6)] {
            let e = scene.interpolate(0, f, u as f32, v as f32).unwrap().p;
            let x = table.eval(FaceCoord::quad(f, u, v)).unwrap().p;
            let d = (0..3)
                .map(|i| (e[i] as f64 - x[i]).powi(2))
                .sum::<f64>()
                .sqrt();
            assert!(d < 1e-5, "face {f} ({u}, {v}): {d}");
        }
    }
    for n in [3, 5, 7] {
        let m = prism(n, false);
        let r = interpolation_check(&m, 8.0, 4000, 4000, 3).unwrap();
        eprintln!(
            "prism {n}: params max {:.2e}, hits {} max {:.2e}",
            r.params.max, r.embree_hits, r.hits.max
        );
        assert!(
            r.params.max < SURFACE_TOLERANCE,
            "prism {n}: {:?}",
            r.params
        );
        assert!(r.embree_hits > 1000);
        assert!(r.hits.max < SURFACE_TOLERANCE, "prism {n}: {:?}", r.hits);
        // Embree's hit points lie on its tessellation of the same surface.
        assert!(r.hit_points.max < 1e-2, "prism {n}: {:?}", r.hit_points);
    }
}

fn without_holes(m: &ControlMesh) -> (ControlMesh, Vec<u32>) {
    let mut r = m.clone();
    r.face_offsets = vec![0];
    r.face_verts.clear();
    r.face_uvs.clear();
    r.holes.clear();
    r.provenance = Default::default();
    let mut map = vec![u32::MAX; m.num_faces()];
    for f in 0..m.num_faces() {
        if !m.holes.contains(&(f as u32)) {
            map[f] = r.num_faces() as u32;
            r.face_verts.extend_from_slice(m.face(f));
            r.face_offsets.push(r.face_verts.len() as u32);
        }
    }
    (r, map)
}

#[test]
fn limit_surface_matches_on_the_corpus() {
    let Some(models) = common::shared_models() else {
        return;
    };
    let dev = device();
    let mut failures = Vec::new();
    let mut compared = 0;
    for path in common::catmark_files(&models) {
        let name = path.file_stem().unwrap().to_str().unwrap().to_string();
        let Ok(mesh) = read_obj(&path) else {
            panic!("{name}: does not load");
        };
        let scene = match subdivision_scene(
            &dev,
            &mesh,
            mesh.options.boundary,
            8.0,
            SceneOptions::default(),
        ) {
            Ok(s) => s,
            Err(e) => {
                // catmark_pole360 (valence 360) and catmark_nonman_edge100 (100 faces at a
                // vertex) exceed Embree's 64-face rings: refused with an error.
                eprintln!("{name}: {e}");
                assert!(e.message.contains("at most 64 faces"), "{name}: {e}");
                continue;
            }
        };
        // Embree removes hole faces from the topology (their edges become boundaries),
        // where OpenSubdiv keeps them as control faces: compare with the holes deleted.
        let r = if mesh.holes.is_empty() {
            let t = embree_table(&mesh).unwrap();
            interpolation_check_with(&mesh, &t, &scene, 2000, 2000, 5).unwrap()
        } else {
            let (cut, map) = without_holes(&mesh);
            let cut_scene = subdivision_scene(
                &dev,
                &cut,
                cut.options.boundary,
                8.0,
                SceneOptions::default(),
            )
            .unwrap();
            // Embree with the holes tagged is Embree with the faces deleted, bit for bit.
            for f in 0..mesh.num_faces() {
                if map[f] == u32::MAX {
                    continue;
                }
                let n = mesh.face(f).len();
                let (u, v) = ptex_to_embree_uv(n, 0, 0.3, 0.6);
                let a = scene.interpolate(0, f as u32, u, v).unwrap();
                let b = cut_scene.interpolate(0, map[f], u, v).unwrap();
                assert_eq!(a.p, b.p, "{name}: face {f}");
            }
            let t = embree_table(&cut).unwrap();
            interpolation_check_with(&cut, &t, &cut_scene, 2000, 2000, 5).unwrap()
        };
        let worst = r.params.max.max(r.hits.max);
        let known = DIFFERENT.iter().find(|(n, _)| *n == name);
        eprintln!(
            "{name:32} params max {:.2e} hits {:4} max {:.2e} hit points max {:.2e}{}",
            r.params.max,
            r.embree_hits,
            r.hits.max,
            r.hit_points.max,
            known.map_or(String::new(), |(_, why)| format!("  [differs: {why}]"))
        );
        if known.is_none() {
            compared += 1;
            if worst >= SURFACE_TOLERANCE || r.embree_hits == 0 {
                failures.push(format!("{name}: {worst:.2e}"));
            }
        }
    }
    assert!(compared >= 40, "only {compared} shapes compared");
    assert!(
        failures.is_empty(),
        "beyond {SURFACE_TOLERANCE}: {failures:?}"
    );
}

#[test]
fn same_triangles_agree_on_catmark_car() {
    let Some(models) = common::shared_models() else {
        return;
    };
    let mesh = read_obj(&models.join("opensubdiv/catmark_car.obj")).unwrap();
    let table = embree_table(&mesh).unwrap();
    let bvh = limitray_bvh(&mesh, &table, 16).unwrap();
    let dev = device();
    let scene = triangles::triangle_scene(&dev, &bvh.diced, SceneOptions::default()).unwrap();
    let rs = rays::incoherent(mesh.bounds(), 1_000_000, 11);
    let r = triangle_check_with(&bvh, &scene, &rs);
    eprintln!("{}", r.json());
    assert_eq!(r.rays, 1_000_000);
    assert!(r.agreement() >= 0.9999, "{}", r.agreement());
    assert_eq!(r.other, 0, "non-grazing disagreements: {:?}", r.examples);
    assert!(r.max_edge_distance_grazing <= EDGE_TOLERANCE);
    assert!(r.max_dt_same <= 1e-6);
    assert!(r.max_dt_cos_oblique <= 1e-6, "{}", r.max_dt_cos_oblique);
    assert!(r.max_cos_oblique < 0.2, "{}", r.max_cos_oblique);
}

#[test]
fn crosscheck_on_a_generated_mesh() {
    // Semi-sharp creases of one sharpness each and a semi-sharp corner: rules Embree shares.
    let m = prism(5, true);
    let r = crosscheck(&m, 8, 50_000, 2).unwrap();
    eprintln!("{}", r.json());
    let s = &r.surface;
    assert!(s.agreement() > 0.995, "{}", s.agreement());
    assert!(
        s.interpolation.hits.max < 1e-3,
        "{:?}",
        s.interpolation.hits
    );
    assert!(s.dt.mean < 1e-3, "{:?}", s.dt);
    let t = &r.triangles;
    assert!(t.agreement() >= 0.9999 && t.other == 0, "{}", t.json());
    // The grid: open, smooth, many faces.
    let g = limitray::mesh::generate::grid(30);
    let r = crosscheck(&g, 4, 50_000, 3).unwrap();
    assert!(r.surface.interpolation.params.max < SURFACE_TOLERANCE);
    assert!(r.triangles.agreement() >= 0.9999 && r.triangles.other == 0);
}

#[test]
fn limitray_does_not_leak() {
    let mut meshes = vec![("prism7".to_string(), prism(7, true))];
    if let Some(models) = common::shared_models() {
        meshes.push((
            "catmark_car".into(),
            read_obj(&models.join("opensubdiv/catmark_car.obj")).unwrap(),
        ));
    }
    meshes.push(("cube".into(), common::cube_builder().build().unwrap()));
    for (name, mesh) in meshes {
        for far in [false, true] {
            let mut m = mesh.clone();
            if far {
                for p in &mut m.positions {
                    for k in 0..3 {
                        p[k] += bench::FAR_OFFSET[k];
                    }
                }
            }
            let table = embree_table(&m).unwrap();
            let bvh = limitray_bvh(&m, &table, 8).unwrap();
            let targets = bench::leak_targets(&m, &bvh, 4);
            assert!(targets.len() > 100, "{name}: {} targets", targets.len());
            let rs = rays::towards_points(&targets, 0.05 * m.diagonal(), 100_000, 9);
            let leaks = rs
                .iter()
                .filter(|r| {
                    bvh.intersect(&limitray::bvh::Ray::new(r.origin, r.dir))
                        .is_none()
                })
                .count();
            let dev = device();
            let tris =
                triangles::triangle_scene(&dev, &bvh.diced, SceneOptions::default()).unwrap();
            let embree_leaks = rs
                .iter()
                .filter(|r| {
                    tris.intersect(r.origin, r.dir, 0.0, f32::INFINITY)
                        .is_none()
                })
                .count();
            eprintln!(
                "{name} far={far}: limitray leaks {leaks}, Embree (same triangles) {embree_leaks} of {}",
                rs.len()
            );
            assert_eq!(leaks, 0, "{name} far={far}");
        }
    }
}

/// The JSON object on each line of a successful command's standard output.
fn json_rows(out: std::process::Output) -> Vec<serde_json::Value> {
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8(out.stdout)
        .unwrap()
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect()
}

#[test]
fn cli_crosscheck_and_bench() {
    let exe = env!("CARGO_BIN_EXE_limitray");
    let cube = std::env::temp_dir().join(format!("limitray_embree_{}.obj", std::process::id()));
    std::fs::write(
        &cube,
        "v -1 -1 1\nv 1 -1 1\nv -1 1 1\nv 1 1 1\nv -1 1 -1\nv 1 1 -1\nv -1 -1 -1\nv 1 -1 -1\n\
         f 1 2 4 3\nf 3 4 6 5\nf 5 6 8 7\nf 7 8 2 1\nf 2 8 6 4\nf 7 1 3 5\nt crease 2/1/0 0 1 2.5\n",
    )
    .unwrap();
    let out = std::process::Command::new(exe)
        .args([
            "crosscheck",
            cube.to_str().unwrap(),
            "--rate",
            "8",
            "--rays",
            "20000",
            "--json",
        ])
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert!(
        v["triangles"]["agreement"].as_f64().unwrap() >= 0.9999,
        "{v}"
    );
    assert_eq!(v["embree_version"], 40400);
    let out = std::process::Command::new(exe)
        .args([
            "bench",
            cube.to_str().unwrap(),
            "--rate",
            "4",
            "--rays",
            "20000",
            "--reps",
            "1",
            "--threads",
            "2",
            "--leak-rays",
            "5000",
        ])
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let text = String::from_utf8(out.stdout).unwrap();
    for engine in [
        "limitray",
        "limitray-triangles",
        "embree-triangles",
        "embree-subdiv",
        "limitray-exact",
    ] {
        assert!(text.contains(engine), "{text}");
    }
    // `--json`: one object per engine per line, with the keys.
    let out = std::process::Command::new(exe)
        .args([
            "bench",
            cube.to_str().unwrap(),
            "--rate",
            "8",
            "--rays",
            "20000",
            "--reps",
            "3",
            "--threads",
            "2",
            "--leak-rays",
            "5000",
            "--json",
        ])
        .output()
        .unwrap();
    let rows = json_rows(out);
    let names: Vec<&str> = rows.iter().map(|r| r["engine"].as_str().unwrap()).collect();
    assert_eq!(
        names,
        [
            "limitray",
            "limitray-triangles",
            "embree-triangles",
            "embree-subdiv",
            "embree-tri-robust",
            "limitray-exact"
        ]
    );
    for r in &rows {
        for key in [
            "build_ms",
            "coherent_mrays_s",
            "incoherent_mrays_s",
            "anyhit_mrays_s",
            "leaks",
            "leaks_far",
        ] {
            assert!(r[key].as_f64().is_some_and(|x| x >= 0.0), "{key}: {r}");
        }
        assert!(r.get("bytes_per_triangle").is_some(), "{r}");
        // Every repetition is kept (three rounds here), and each figure is their median.
        for (key, figure) in [
            ("build_ms", "build_ms"),
            ("coherent_mrays_s", "coherent_mrays_s"),
            ("incoherent_mrays_s", "incoherent_mrays_s"),
            ("anyhit_mrays_s", "anyhit_mrays_s"),
        ] {
            let mut v: Vec<f64> = r["samples"][key]
                .as_array()
                .unwrap_or_else(|| panic!("samples.{key}: {r}"))
                .iter()
                .map(|x| x.as_f64().unwrap())
                .collect();
            assert_eq!(v.len(), 3, "samples.{key}: {r}");
            assert!(v.iter().all(|x| x.is_finite() && *x > 0.0), "{r}");
            v.sort_by(f64::total_cmp);
            assert_eq!(
                r[figure].as_f64(),
                Some(v[1]),
                "{figure} is the median: {r}"
            );
        }
        // limitray's grid core stores shading normals unless `--no-shading-normals`.
        assert_eq!(r["shading_normals"], true, "{r}");
    }
    // The grid core: no leaks, and its bytes per triangle include every level. A closed
    // cube at rate 8 is 768 triangles in 6 blocks of 8×8 quads, about 15.5 bytes each.
    let grid = &rows[0];
    assert_eq!(
        (grid["leaks"].as_u64(), grid["leaks_far"].as_u64()),
        (Some(0), Some(0))
    );
    let bpt = grid["bytes_per_triangle"].as_f64().unwrap();
    assert!(bpt > 8.0 && bpt <= 20.0, "{grid}");
    // The reference intersector reports how many of its far leaks miss the limit surface
    // itself (all of them: rays aimed at f32 points of the far diced mesh); the other
    // engines report no such count. (The count itself is tested in `embree::bench`.)
    let exact = &rows[5];
    assert_eq!(
        exact["far_misses_off_surface"].as_u64(),
        exact["leaks_far"].as_u64(),
        "{exact}"
    );
    assert!(rows[..5]
        .iter()
        .all(|r| r["far_misses_off_surface"].is_null()));
    // Embree's memory is seen through its monitor.
    assert!(
        rows[3]["bytes_per_triangle"].as_f64().unwrap() > 0.0,
        "{}",
        rows[3]
    );
    // Bad input: exit code 2 with a message naming the problem.
    let out = std::process::Command::new(exe)
        .args(["crosscheck", cube.to_str().unwrap(), "--rate", "0"])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("rate"));
    let out = std::process::Command::new(exe)
        .args(["bench", "/nonexistent.obj"])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    // `--displace noise:…`: both engines displaced, the reference intersector left out,
    // limitray still leak-free; a map is refused (Embree's side evaluates noise only).
    let displaced = |spec: &str| {
        std::process::Command::new(exe)
            .args([
                "bench",
                cube.to_str().unwrap(),
                "--rate",
                "8",
                "--rays",
                "5000",
            ])
            .args([
                "--reps",
                "1",
                "--threads",
                "2",
                "--leak-rays",
                "5000",
                "--json",
            ])
            .args(["--displace", spec])
            .output()
            .unwrap()
    };
    let out = displaced("noise:0.05:3");
    let rows = json_rows(out);
    assert_eq!(rows.len(), 5, "{rows:?}");
    assert_eq!(rows[3]["engine"], "embree-subdiv");
    assert_eq!(rows[0]["displace"], serde_json::json!([0.05, 3.0]));
    assert_eq!(
        (rows[0]["leaks"].as_u64(), rows[0]["leaks_far"].as_u64()),
        (Some(0), Some(0))
    );
    let out = displaced("map:height.png:0.1");
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("noise"));
    std::fs::remove_file(&cube).ok();
}

/// Embree's displacement callback (`subdivision_scene_noise`, the peer in `limitray bench
/// --displace`) displaces by the same noise along the same normal as limitray's dicing: on the
/// tests' cube at rate 16, displaced by `noise:0.1:3`, rays from a sphere around it aimed at
/// random points of its inside hit both engines' displaced surfaces at `t` within 0.05 × the
/// amplitude of each other (median; measured 7e-3 × amplitude: two tessellations of the same
/// displaced limit surface), while Embree's displaced and
/// undisplaced surfaces part by more than 0.2 × the amplitude (a flipped normal would give
/// about twice the displacement).
#[test]
fn embree_noise_displacement_matches_limitray() {
    use limitray::dice::{dice, DiceOptions, DiceRate, Displacement};
    let m = common::cube_builder().build().unwrap();
    let (amplitude, frequency) = (0.1, 3.0);
    let table = embree_table(&m).unwrap();
    let diced = dice(
        &table,
        &m,
        &DiceOptions {
            rate: DiceRate::Uniform(16),
            displace: Some(Displacement::Noise {
                amplitude,
                frequency,
            }),
            ..DiceOptions::default()
        },
    )
    .unwrap();
    let ours = limitray::bvh::MeshBvh::build(diced);
    let dev = device();
    let scene = |noise| {
        limitray::embree::subdiv::subdivision_scene_noise(
            &dev,
            &m,
            m.options.boundary,
            16.0,
            SceneOptions::default(),
            noise,
        )
        .unwrap()
    };
    let (displaced, plain) = (scene(Some((amplitude, frequency))), scene(None));
    let mut rng = limitray::harness::rng::SplitMix64(7);
    let (mut same, mut moved) = (Vec::new(), Vec::new());
    for _ in 0..4000 {
        let d = rng.unit_vector();
        let target: [f64; 3] = std::array::from_fn(|_| rng.next_f64() - 0.5);
        let origin: [f32; 3] = std::array::from_fn(|k| (target[k] - 6.0 * d[k]) as f32);
        let dir = d.map(|c| c as f32);
        let (Some(a), Some(b), Some(c)) = (
            ours.intersect(&limitray::bvh::Ray::new(origin, dir)),
            displaced.intersect(origin, dir, 0.0, f32::INFINITY),
            plain.intersect(origin, dir, 0.0, f32::INFINITY),
        ) else {
            panic!("a ray aimed inside the cube missed");
        };
        same.push((a.t - b.t).abs() as f64);
        moved.push((b.t - c.t).abs() as f64);
    }
    let median = |mut v: Vec<f64>| {
        v.sort_by(f64::total_cmp);
        v[v.len() / 2]
    };
    let (same, moved) = (median(same), median(moved));
    eprintln!(
        "noise displacement: median |t_limitray - t_embree| {same:.2e}, Embree displaced vs plain {moved:.2e} (amplitude {amplitude})"
    );
    assert!(same < 0.05 * amplitude, "{same}");
    assert!(moved > 0.2 * amplitude, "{moved}");
}
