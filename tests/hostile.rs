//! The hostile cases of issue 13 at library level, each generated here: the numeric contract
//! (every stage safe up to it, refused beyond), the memory budget (estimated before
//! allocating), instancing of identical scene meshes, bad environment-map texels and a hostile
//! EXR header.
//!
//! Every test of this binary sets the same process-wide memory limit (8 GiB) first, so the
//! outcome does not depend on the machine's memory: the hostile cases need tens of GiB to
//! terabytes, the legitimate ones a few MiB.

use limitray::bvh::{MeshBvh, Ray};
use limitray::dice::{dice, DiceOptions, DiceRate};
use limitray::mesh::shapes;
use limitray::patch::{PatchOptions, PatchTable};
use limitray::refine::Refiner;
use limitray::render::scene::parse_scene;
use limitray::render::world::World;
use limitray::ErrorKind;
use std::path::{Path, PathBuf};

const LIMIT: u64 = 8 << 30;

fn budget() {
    limitray::memory::set_limit(LIMIT);
}

fn temp_dir(tag: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("limitray-hostile-{tag}-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

const CUBE_OBJ: &str = "v -1 -1 1\nv 1 -1 1\nv -1 1 1\nv 1 1 1\nv -1 1 -1\nv 1 1 -1\n\
v -1 -1 -1\nv 1 -1 -1\nf 1 2 4 3\nf 3 4 6 5\nf 5 6 8 7\nf 7 8 2 1\nf 2 8 6 4\nf 7 1 3 5\n";

/// A scene with a camera and one material, then `meshes`.
fn scene_text(render: &str, meshes: &str) -> String {
    format!(
        "[render]\n{render}\n[camera]\nposition = [0, 1, 8]\nlook_at = [0, 0, 0]\nfov = 40\n\n\
         [materials.clay]\ntype = \"diffuse\"\n\n{meshes}"
    )
}

#[test]
fn every_stage_is_safe_at_the_edge_of_the_numeric_contract() {
    budget();
    // A box reaching 0.999 · 2^32 on every axis: patch table, dicing, BVH (obvhs panicked at
    // ±1e20) and the watertight test (which returned t = inf at ±3e13) all stay finite.
    let big = 0.999 * limitray::numeric::MAX_COORD;
    let mut mesh = shapes::rounded_box(2.0);
    for p in &mut mesh.positions {
        *p = p.map(|c| c * big);
    }
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
    assert!(d.positions.iter().flatten().all(|c| c.is_finite()));
    let bvh = MeshBvh::build(d);
    let mut rng = limitray::harness::rng::SplitMix64(13);
    for _ in 0..2000 {
        // From the centre outwards: every ray hits the closed box.
        let dir = [
            rng.next_f64() as f32 - 0.5,
            rng.next_f64() as f32 - 0.5,
            rng.next_f64() as f32 - 0.5,
        ];
        let h = bvh
            .intersect(&Ray::new([0.0; 3], dir))
            .expect("a ray from inside a closed box hits it");
        assert!(h.t.is_finite() && h.t > 0.0, "t = {}", h.t);
        let n = h.ng;
        let len = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
        // Unit normal to f32 rounding of the normalisation (a few ulps).
        assert!((len - 1.0).abs() < 1e-6, "|ng| = {len}");
        // The hit point lies on the hit triangle: its distance from the triangle's plane is
        // within f32 rounding of the coordinates (2^-22 of 2^32, times a few operations).
        let p = [dir[0] * h.t, dir[1] * h.t, dir[2] * h.t];
        let tri = bvh.diced.triangles[h.triangle as usize];
        let a = bvh.diced.positions[tri[0] as usize];
        let dist: f64 = (0..3).map(|i| (p[i] - a[i]) as f64 * n[i] as f64).sum();
        assert!(dist.abs() < 1e-5 * big, "off the plane by {dist}");
    }
}

#[test]
fn coordinates_beyond_the_contract_are_refused_in_code_built_meshes() {
    budget();
    for x in [1e39, -1e20, 3e13] {
        let mut mesh = shapes::rounded_box(0.0);
        mesh.positions[5][1] = x;
        let e = PatchTable::new(&mesh, PatchOptions::default()).unwrap_err();
        assert_eq!(e.element.as_deref(), Some("vertex 5"), "{e}");
        assert!(e.message.contains("out of range"), "{e}");
    }
}

#[test]
fn scene_transforms_are_checked_against_the_contract() {
    budget();
    let d = temp_dir("transform");
    std::fs::write(d.join("cube.obj"), CUBE_OBJ).unwrap();
    // Inside the range after scaling by 2e9 (|x| = 2e9); outside after 1e13.
    for (scale, ok) in [("2e9", true), ("1e13", false)] {
        let text = scene_text(
            "width = 8\nheight = 8",
            &format!(
                "[[mesh]]\nfile = \"cube.obj\"\nmaterial = \"clay\"\nscale = {scale}\nrate = 1\n"
            ),
        );
        let path = d.join("s.toml");
        let desc = parse_scene(&text, &path).unwrap();
        let r = World::build(&desc, desc.render);
        if ok {
            r.unwrap();
        } else {
            let e = r.err().unwrap();
            assert_eq!(e.line, Some(12), "{e}");
            assert_eq!(e.element.as_deref(), Some("key 'mesh[0]'"), "{e}");
            assert!(e.message.contains("reaches |coordinate| = 1.000e13"), "{e}");
        }
    }
    std::fs::remove_dir_all(&d).ok();
}

#[test]
fn ten_thousand_entries_of_one_file_share_one_mesh() {
    budget();
    let d = temp_dir("instances");
    std::fs::write(d.join("cube.obj"), CUBE_OBJ).unwrap();
    let mut meshes = String::new();
    for i in 0..10_000 {
        let (x, z) = ((i % 100) as f32 * 3.0, (i / 100) as f32 * 3.0);
        meshes.push_str(&format!(
            "[[mesh]]\nfile = \"cube.obj\"\nmaterial = \"clay\"\ntranslate = [{x}, 0, {z}]\n\
             rate = 4\n"
        ));
    }
    let text = scene_text("width = 8\nheight = 8", &meshes);
    let desc = parse_scene(&text, &d.join("s.toml")).unwrap();
    let w = World::build(&desc, desc.render).unwrap();
    assert_eq!(w.scene.num_instances(), 10_000);
    // One diced mesh and BVH for all of them.
    let first = w.scene.instance_mesh(0);
    assert!((0..10_000).all(|i| w.scene.instance_mesh(i) == first));
    let one = w.scene.mesh(first).bytes();
    assert_eq!(w.stats.bytes, one);
    assert_eq!(w.stats.triangles, 10_000 * w.scene.mesh(first).triangles);
    std::fs::remove_dir_all(&d).ok();
}

#[test]
fn huge_refinement_dicing_and_films_are_refused_before_allocating() {
    budget();
    let cube = shapes::rounded_box(0.0);
    // refine --level 12 on a cube: about 50 GiB of levels and stencils.
    let e = Refiner::new(&cube, 12).unwrap_err();
    assert_eq!(e.kind, ErrorKind::Usage);
    assert!(
        e.message
            .starts_with("uniform refinement to level 12 would need about"),
        "{e}"
    );
    assert!(e.message.contains("lower the level (--level)"), "{e}");
    assert!(e.message.contains("above the limit of 8.0 GiB"), "{e}");
    // Level 8 (about 200 MiB; 194 MiB of peak RSS measured for `refine --level 8`) is fine.
    assert_eq!(Refiner::new(&cube, 8).unwrap().max_level(), 8);

    // dice --rate 100000: 1.2e11 triangles.
    let table = PatchTable::new(&cube, PatchOptions::default()).unwrap();
    let opts = DiceOptions {
        rate: DiceRate::Uniform(100_000),
        max_rate: 100_000,
        displace: None,
    };
    let e = dice(&table, &cube, &opts).unwrap_err();
    assert!(e.message.starts_with("dicing would need about"), "{e}");
    assert!(e.message.contains("lower the dicing rate"), "{e}");

    // A 16384² render: its film alone is beyond 8 GiB.
    let d = temp_dir("film");
    std::fs::write(d.join("cube.obj"), CUBE_OBJ).unwrap();
    let text = scene_text(
        "width = 16384\nheight = 16384",
        "[[mesh]]\nfile = \"cube.obj\"\nmaterial = \"clay\"\nrate = 2\n",
    );
    let desc = parse_scene(&text, &d.join("s.toml")).unwrap();
    let e = World::build(&desc, desc.render).err().unwrap();
    assert!(
        e.message
            .starts_with("a 16384 × 16384 render would need about"),
        "{e}"
    );
    assert!(e.message.contains("lower the resolution"), "{e}");
    // A scene whose meshes together dice to more than the budget.
    let text = scene_text(
        "width = 8\nheight = 8",
        "[[mesh]]\nfile = \"cube.obj\"\nmaterial = \"clay\"\nrate = 4096\nmax_rate = 4096\n",
    );
    let desc = parse_scene(&text, &d.join("s.toml")).unwrap();
    let e = World::build(&desc, desc.render).err().unwrap();
    assert!(
        e.message
            .starts_with("dicing and indexing the scene's 1 distinct meshes would need about"),
        "{e}"
    );
    std::fs::remove_dir_all(&d).ok();
}

/// Writes a `w × h` RGB EXR whose texels come from `f`.
fn write_map(path: &Path, w: usize, h: usize, f: impl Fn(usize) -> [f32; 3]) {
    let px: Vec<[f32; 3]> = (0..w * h).map(f).collect();
    let planes = (0..3)
        .map(|c| (["R", "G", "B"][c], px.iter().map(|p| p[c]).collect()))
        .collect();
    limitray::io::exr::write_planes(path, w, h, planes).unwrap();
}

#[test]
fn environment_maps_with_bad_texels() {
    budget();
    let d = temp_dir("env");
    std::fs::write(d.join("cube.obj"), CUBE_OBJ).unwrap();
    let build = |map: &str, intensity: f32| {
        let text = scene_text(
            "width = 8\nheight = 8",
            &format!(
                "[[mesh]]\nfile = \"cube.obj\"\nmaterial = \"clay\"\nrate = 1\n\n\
                 [environment]\nmap = \"{map}\"\nintensity = {intensity:?}\n"
            ),
        );
        let desc = parse_scene(&text, &d.join("s.toml")).unwrap();
        World::build(&desc, desc.render)
    };
    // NaN and infinite texels: an error with the count and the first one.
    write_map(&d.join("nan.exr"), 8, 4, |i| match i {
        9 => [f32::NAN, 0.0, 0.0],
        20 | 21 => [0.0, f32::INFINITY, 0.0],
        _ => [0.5; 3],
    });
    let e = build("nan.exr", 1.0).err().unwrap();
    assert_eq!(e.element.as_deref(), Some("key 'environment.map'"), "{e}");
    assert!(
        e.message.ends_with(
            "nan.exr: 3 of 32 texels are NaN or infinite (the first at column 1, row 1); an \
             environment map must be finite"
        ),
        "{e}"
    );
    // Finite texels that overflow once scaled by the intensity.
    write_map(&d.join("bright.exr"), 4, 2, |_| [3e38, 1.0, 1.0]);
    let e = build("bright.exr", 10.0).err().unwrap();
    assert!(
        e.message
            .contains("8 of 8 texels are NaN or infinite after the intensity"),
        "{e}"
    );
    // Negative texels: a warning (counted by `TexelReport`), read as 0; the scene renders.
    write_map(&d.join("neg.exr"), 4, 2, |i| {
        if i < 3 {
            [-0.1, 0.2, 0.3]
        } else {
            [0.2; 3]
        }
    });
    let w = build("neg.exr", 1.0).unwrap();
    assert!(w.lights.env.is_some());
    let texels: Vec<glam::Vec3> = (0..8)
        .map(|i| {
            if i < 3 {
                glam::Vec3::new(-0.1, 0.2, 0.3)
            } else {
                glam::Vec3::splat(0.2)
            }
        })
        .collect();
    let r = limitray::render::env::TexelReport::new(&texels, 1.0);
    assert_eq!((r.non_finite, r.negative), (0, 3));
    std::fs::remove_dir_all(&d).ok();
}

/// Sets the `box2i` attribute `name` of an EXR header to `(0, 0, x_max, y_max)`.
fn patch_box(bytes: &mut [u8], name: &str, x_max: i32, y_max: i32) {
    let key = format!("{name}\0box2i\0");
    let at = bytes
        .windows(key.len())
        .position(|w| w == key.as_bytes())
        .unwrap_or_else(|| panic!("{name} attribute"))
        + key.len()
        + 4; // the attribute size
    bytes[at + 8..at + 12].copy_from_slice(&x_max.to_le_bytes());
    bytes[at + 12..at + 16].copy_from_slice(&y_max.to_le_bytes());
}

#[test]
fn an_exr_header_claiming_a_huge_window_is_refused() {
    budget();
    let d = temp_dir("exr");
    let p = d.join("huge.exr");
    write_map(&p, 2, 2, |_| [1.0; 3]);
    let mut bytes = std::fs::read(&p).unwrap();
    patch_box(&mut bytes, "dataWindow", 999_999, 999_999);
    patch_box(&mut bytes, "displayWindow", 999_999, 999_999);
    std::fs::write(&p, &bytes).unwrap();
    let e = limitray::io::exr::read_channels(&p).unwrap_err();
    assert!(
        e.message
            .starts_with("reading the 1000000 × 1000000 EXR image"),
        "{e}"
    );
    assert!(e.message.contains("use a smaller image"), "{e}");
    let e = limitray::io::exr::read_rgb(&p).unwrap_err();
    assert!(e.message.contains("above the limit"), "{e}");
    std::fs::remove_dir_all(&d).ok();
}

#[test]
fn isolation_levels_outside_the_supported_range_are_refused() {
    budget();
    // `stats --max-level 300` used to wrap at 256; 0 was silently 1.
    let cube = shapes::rounded_box(0.0);
    for bad in [0, 17, 256, 300] {
        let e = PatchTable::new(
            &cube,
            PatchOptions {
                max_level: bad,
                ..PatchOptions::default()
            },
        )
        .err()
        .unwrap();
        assert_eq!(e.kind, ErrorKind::Usage);
        assert_eq!(
            e.message,
            format!("maximum isolation level {bad} is outside 1..=16")
        );
    }
    let ok = PatchOptions {
        max_level: limitray::patch::table::MAX_LEVEL,
        ..PatchOptions::default()
    };
    assert!(PatchTable::new(&cube, ok).is_ok());
}
