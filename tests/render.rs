//! Renderer tests: white furnace (albedo 1 and 0.5, constant and map environments), energy
//! never growing with depth, bitwise-identical output on 1 and 2 threads, the EXR read back by
//! the exr crate's reader with the documented channels, and the `render` command end to end
//! (including located scene-file errors with exit code 2).

mod common;

use limitray::io::exr::{read_channels, write_planes};
use limitray::render::output::{write_film, CHANNELS};
use limitray::render::scene::parse_scene;
use limitray::render::{Film, World};
use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::atomic::{AtomicUsize, Ordering};

struct TempDir(PathBuf);

impl TempDir {
    fn new(tag: &str) -> Self {
        static COUNTER: AtomicUsize = AtomicUsize::new(0);
        let n = COUNTER.fetch_add(1, Ordering::SeqCst);
        let dir =
            std::env::temp_dir().join(format!("limitray-render-{tag}-{}-{n}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        TempDir(dir)
    }
    fn path(&self, name: &str) -> PathBuf {
        self.0.join(name)
    }
    fn file(&self, name: &str, text: &str) -> PathBuf {
        let p = self.path(name);
        std::fs::write(&p, text).unwrap();
        p
    }
}

impl Drop for TempDir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

fn mesh_path(name: &str) -> String {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("scenes/meshes")
        .join(name)
        .display()
        .to_string()
}

fn world(text: &str, dir: &Path) -> World {
    let desc = parse_scene(text, &dir.join("scene.toml")).unwrap();
    World::build(&desc, desc.render).unwrap()
}

fn render_one_thread(w: &World) -> Film {
    rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap()
        .install(|| w.render(&|_| {}))
}

/// A furnace scene: the rounded box of sharpness 0 (Catmull-Clark limit of a cube: a closed,
/// convex surface) with a diffuse albedo, seen in full from outside, inside `env`.
fn furnace(albedo: f32, max_depth: u32, env: &str, mesh: &str) -> String {
    format!(
        r#"
[render]
width = 48
height = 48
spp = 64
max_depth = {max_depth}
seed = 7

[camera]
position = [0.4, 0.9, 3.2]
look_at = [0, 0, 0]
fov = 38

[materials.white]
type = "diffuse"
albedo = {albedo}

[[mesh]]
file = "{}"
material = "white"
rate = 24

[environment]
{env}
"#,
        mesh_path(mesh)
    )
}

/// Mean beauty (R) over pixels whose every sample hit the object, and over background pixels.
fn means(f: &Film) -> (f64, f64, usize) {
    let (mut s_obj, mut n_obj, mut s_bg, mut n_bg) = (0.0f64, 0usize, 0.0f64, 0usize);
    for p in &f.pixels {
        if p.rgba[3] == 1.0 {
            s_obj += p.rgba[0] as f64;
            n_obj += 1;
        } else if p.rgba[3] == 0.0 {
            s_bg += p.rgba[0] as f64;
            n_bg += 1;
        }
    }
    (
        s_obj / n_obj.max(1) as f64,
        s_bg / n_bg.max(1) as f64,
        n_obj,
    )
}

/// White furnace. In a uniform environment of radiance 1 a closed object of albedo ρ seen from
/// outside returns, for each camera ray that hits it, L = Σ_k (light after k bounces). For
/// ρ = 1 no energy is lost at any bounce, so L = 1 whatever the shape. For a *convex* object
/// every ray leaving the surface escapes to the environment without hitting the object again,
/// so the path ends after exactly one bounce: L = ρ · (∫ cos/π dω) · 1 = ρ. With ρ = 0.5, L = 0.5.
/// (The diced mesh is convex up to the flatness of its triangles; the tolerance covers that
/// and the Monte Carlo noise, whose standard error here is about 0.2 %.)
#[test]
fn white_furnace_constant_environment() {
    let dir = TempDir::new("furnace");
    for (albedo, want) in [(1.0f32, 1.0f64), (0.5, 0.5)] {
        let w = world(
            &furnace(albedo, 16, "radiance = 1.0", "rounded_box_s0.obj"),
            &dir.0,
        );
        let f = render_one_thread(&w);
        let (obj, bg, n) = means(&f);
        eprintln!("furnace albedo {albedo}: object mean {obj:.5} over {n} pixels, background {bg}");
        assert!(n > 500, "object covers {n} pixels");
        assert!(
            (obj - want).abs() < 0.01 * want,
            "albedo {albedo}: mean {obj}, want {want}"
        );
        assert_eq!(bg, 1.0);
    }
}

/// The same furnace with a constant lat-long map: exercises map importance sampling, whose
/// density then varies with sin θ only.
#[test]
fn white_furnace_map_environment() {
    let dir = TempDir::new("furnace-map");
    let (w, h) = (32, 16);
    write_planes(
        &dir.path("ones.exr"),
        w,
        h,
        vec![
            ("R", vec![1.0; w * h]),
            ("G", vec![1.0; w * h]),
            ("B", vec![1.0; w * h]),
        ],
    )
    .unwrap();
    let world = world(
        &furnace(
            1.0,
            16,
            "map = \"ones.exr\"\nrotate = 30",
            "rounded_box_s0.obj",
        ),
        &dir.0,
    );
    let f = render_one_thread(&world);
    let (obj, _, _) = means(&f);
    eprintln!("furnace with map: {obj:.5}");
    assert!((obj - 1.0).abs() < 0.01, "mean {obj}");
}

/// Energy never grows with depth: for albedo ≤ 1 in a furnace of radiance 1, raising
/// `max_depth` only adds light (the random stream of a path does not depend on `max_depth`, so
/// each pixel is non-decreasing, bit for bit), and the whole-image mean stays at or below the
/// furnace value 1. A gear (concave, genus one) makes the higher bounces matter.
#[test]
fn energy_never_grows_with_depth() {
    let dir = TempDir::new("depth");
    let mut prev: Option<Film> = None;
    let mut means_by_depth = Vec::new();
    for depth in [0u32, 1, 2, 3, 5, 8] {
        let w = world(
            &furnace(0.9, depth, "radiance = 1.0", "gear8.obj").replace("rate = 24", "rate = 6"),
            &dir.0,
        );
        let f = render_one_thread(&w);
        let m = f.mean_rgb()[0];
        means_by_depth.push(m);
        assert!(
            m <= 1.0 + 0.01,
            "depth {depth}: mean {m} above the furnace value"
        );
        if let Some(p) = &prev {
            for (a, b) in p.pixels.iter().zip(&f.pixels) {
                assert!(b.rgba[0] >= a.rgba[0], "depth {depth}: a pixel lost energy");
            }
        }
        prev = Some(f);
    }
    eprintln!("mean by depth 0,1,2,3,5,8: {means_by_depth:?}");
    assert!(means_by_depth.windows(2).all(|w| w[1] >= w[0]));
    // Higher bounces add light inside the gear's concavities.
    assert!(means_by_depth[5] > means_by_depth[1]);
}

fn rich_scene() -> String {
    format!(
        r#"
[render]
width = 40
height = 30
spp = 6
max_depth = 6
seed = 3

[camera]
position = [0, 1.5, 5]
look_at = [0, 0.2, 0]
fov = 45
aperture = 0.05

[materials.floor]
type = "diffuse"
albedo = [0.6, 0.5, 0.4]
[materials.metal]
type = "conductor"
preset = "gold"
roughness = 0.3
[materials.mirror]
type = "conductor"
base_color = 0.9
[materials.glass]
type = "dielectric"
ior = 1.5
[materials.frosted]
type = "dielectric"
ior = 1.4
roughness = 0.4
[materials.lamp]
type = "emissive"
radiance = [4, 3, 2]

[[mesh]]
file = "{cyc}"
material = "floor"
rate = 4
translate = [0, -0.5, 0]
scale = 0.3
[[mesh]]
file = "{gear}"
material = "metal"
rotate = [-60, 0, 0]
translate = [-1.2, 0, 0]
pixels_per_edge = 3
[[mesh]]
file = "{blob}"
material = "glass"
scale = 0.4
translate = [0.3, 0, 0]
[[mesh]]
file = "{box0}"
material = "frosted"
scale = 0.3
translate = [1.3, 0, 0.3]
[[mesh]]
file = "{box2}"
material = "mirror"
scale = 0.3
translate = [1.3, 0, -0.8]
[[mesh]]
file = "{box1}"
material = "lamp"
scale = 0.2
translate = [0, 1.5, 0.5]

[[light]]
type = "quad"
corner = [-1, 3, -1]
edge1 = [2, 0, 0]
edge2 = [0, 0, 2]
radiance = 5

[environment]
map = "{sky}"
intensity = 0.5
"#,
        cyc = mesh_path("cyclorama.obj"),
        gear = mesh_path("gear8.obj"),
        blob = mesh_path("blob.obj"),
        box0 = mesh_path("rounded_box_s0.obj"),
        box1 = mesh_path("rounded_box_s1.obj"),
        box2 = mesh_path("rounded_box_s2.obj"),
        sky = Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("scenes/studio.exr")
            .display(),
    )
}

/// Same seed → bitwise-identical EXR on 1 and 2 threads, with every material and light type.
#[test]
fn identical_on_one_and_two_threads() {
    let dir = TempDir::new("threads");
    let w = world(&rich_scene(), &dir.0);
    let mut files = Vec::new();
    for threads in [1usize, 2] {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        let film = pool.install(|| w.render(&|_| {}));
        let p = dir.path(&format!("t{threads}.exr"));
        write_film(&p, &film).unwrap();
        files.push(std::fs::read(&p).unwrap());
        assert!(film
            .pixels
            .iter()
            .all(|p| p.rgba.iter().all(|c| c.is_finite())));
        assert!(film.mean_rgb()[0] > 0.0);
    }
    assert!(
        files[0] == files[1],
        "EXR bytes differ between 1 and 2 threads"
    );
}

/// The EXR is read back by an independent reader (the exr crate's generic reader) with the
/// documented channel names, and its AOVs hold what they should.
#[test]
fn exr_reads_back_with_documented_channels() {
    let dir = TempDir::new("exr");
    let w = world(
        &furnace(0.5, 2, "radiance = 1.0", "rounded_box_s0.obj").replace("spp = 64", "spp = 2"),
        &dir.0,
    );
    let film = render_one_thread(&w);
    let p = dir.path("out.exr");
    write_film(&p, &film).unwrap();
    let back = read_channels(&p).unwrap();
    assert_eq!((back.width, back.height), (48, 48));
    let mut names: Vec<&str> = back.channels.iter().map(|(n, _)| n.as_str()).collect();
    names.sort_unstable();
    let mut want: Vec<&str> = CHANNELS.to_vec();
    want.sort_unstable();
    assert_eq!(names, want);
    let face = back.get("faceid").unwrap();
    let z = back.get("Z").unwrap();
    let level = back.get("level").unwrap();
    let a = back.get("A").unwrap();
    let nz = back.get("N.Z").unwrap();
    let alb = back.get("albedo.G").unwrap();
    // Corner pixel: background.
    assert_eq!(
        (face[0], z[0], level[0], a[0]),
        (-1.0, f32::INFINITY, -1.0, 0.0)
    );
    // Centre pixel: the box, ~3.3 away, one of its 6 faces, facing the camera (+z-ish).
    let c = 24 * 48 + 24;
    assert!((0.0..6.0).contains(&face[c]) && face[c].fract() == 0.0);
    assert!(z[c] > 2.0 && z[c] < 3.4, "{}", z[c]);
    assert!(level[c] >= 0.0);
    assert!(nz[c] > 0.5);
    assert_eq!(alb[c], 0.5);
    assert_eq!(a[c], 1.0);
    for (name, v) in &back.channels {
        let i = film.pixels.len() / 3;
        let orig = match name.as_str() {
            "R" => film.pixels[i].rgba[0],
            "Z" => film.pixels[i].z,
            _ => continue,
        };
        assert_eq!(v[i].to_bits(), orig.to_bits());
    }
}

fn limitray() -> Command {
    common::limitray_command()
}

#[test]
fn cli_renders_a_tiny_scene() {
    let dir = TempDir::new("cli");
    let scene = dir.file("tiny.toml", &rich_scene());
    let exr = dir.path("tiny.exr");
    let png = dir.path("tiny.png");
    let out = limitray()
        .arg("render")
        .arg(&scene)
        .arg("-o")
        .arg(&exr)
        .arg("--png")
        .arg(&png)
        .args(["--spp", "2", "--res", "24x16", "--threads", "2", "--quiet"])
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(
        out.stderr.is_empty(),
        "--quiet printed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    let back = read_channels(&exr).unwrap();
    assert_eq!((back.width, back.height), (24, 16));
    let img = image::open(&png).unwrap();
    assert_eq!((img.width(), img.height()), (24, 16));

    // The whole command (dicing and BVH included) is deterministic across thread counts.
    let exr1 = dir.path("tiny1.exr");
    let out = limitray()
        .arg("render")
        .arg(&scene)
        .arg("-o")
        .arg(&exr1)
        .args(["--spp", "2", "--res", "24x16", "--threads", "1", "--quiet"])
        .output()
        .unwrap();
    assert!(out.status.success());
    assert!(std::fs::read(&exr).unwrap() == std::fs::read(&exr1).unwrap());

    // Without --quiet: a summary naming the time to first pixel.
    let out = limitray()
        .arg("render")
        .arg(&scene)
        .arg("-o")
        .arg(&exr)
        .args(["--spp", "1", "--res", "8x8"])
        .output()
        .unwrap();
    assert!(out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("first pixel after"), "{err}");
}

#[test]
fn cli_reports_scene_errors_with_key_and_line() {
    let dir = TempDir::new("cli-err");
    let bad = rich_scene().replace("fov = 45", "fov = -45");
    let line = bad.lines().position(|l| l.starts_with("fov")).unwrap() + 1;
    let scene = dir.file("bad.toml", &bad);
    let out = limitray()
        .arg("render")
        .arg(&scene)
        .arg("-o")
        .arg(dir.path("x.exr"))
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains(&format!("bad.toml:{line}: key 'camera.fov':")),
        "{err}"
    );
    // A missing mesh file names the file.
    let bad = rich_scene().replace("blob.obj", "no_such_mesh.obj");
    let scene = dir.file("bad2.toml", &bad);
    let out = limitray()
        .arg("render")
        .arg(&scene)
        .arg("-o")
        .arg(dir.path("x.exr"))
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("no_such_mesh.obj"));
    // The GPU backend reads the scene the same way: the same located error.
    let out = limitray()
        .arg("render")
        .arg(dir.path("bad2.toml"))
        .arg("-o")
        .arg(dir.path("x.exr"))
        .args(["--backend", "gpu"])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("no_such_mesh.obj"));
}

/// The committed OBJ files of the bundled scenes are what the generators in
/// `limitray::mesh::shapes` produce (regenerate with
/// `cargo run --release --example make_scenes -- scenes`).
#[test]
fn bundled_meshes_match_their_generators() {
    use limitray::mesh::shapes;
    let cases = [
        ("rounded_box_s0.obj", shapes::rounded_box(0.0)),
        ("rounded_box_s1.obj", shapes::rounded_box(1.0)),
        ("rounded_box_s2.obj", shapes::rounded_box(2.0)),
        ("rounded_box_s3.5.obj", shapes::rounded_box(3.5)),
        ("rounded_box_sinf.obj", shapes::rounded_box(f32::INFINITY)),
        ("blob.obj", shapes::blob()),
        ("gear12.obj", shapes::gear(12)),
        ("gear8.obj", shapes::gear(8)),
        ("cyclorama.obj", shapes::cyclorama(24.0, 16.0, 9.0)),
    ];
    for (name, want) in cases {
        let got = limitray::mesh::obj::read_obj(Path::new(&mesh_path(name))).unwrap();
        assert_eq!(got.positions, want.positions, "{name}");
        assert_eq!(got.face_offsets, want.face_offsets, "{name}");
        assert_eq!(got.face_verts, want.face_verts, "{name}");
        assert_eq!(got.creases, want.creases, "{name}");
    }
}

/// Lossless interfaces in the furnace: a smooth glass object (ior 1.5; refraction scales
/// radiance by 1/η² going in and η² coming out, Fresnel splits but loses nothing) and a perfect
/// mirror (Schlick with F0 = 1) return the environment's radiance 1 along every path that
/// escapes; `max_depth` 64 leaves a negligible tail of internally reflected paths. Rough
/// (single-scattering GGX) variants lose energy to masking but must never exceed 1.
#[test]
fn furnace_lossless_and_rough_interfaces() {
    let dir = TempDir::new("furnace-glass");
    let cases = [
        ("type = \"dielectric\"\nior = 1.5", true),
        ("type = \"conductor\"\nbase_color = 1.0", true),
        ("type = \"dielectric\"\nior = 1.5\nroughness = 0.5", false),
        (
            "type = \"conductor\"\nbase_color = 1.0\nroughness = 0.5",
            false,
        ),
    ];
    for (mat, lossless) in cases {
        let text = furnace(1.0, 64, "radiance = 1.0", "rounded_box_s0.obj")
            .replace("type = \"diffuse\"\nalbedo = 1", mat);
        let w = world(&text, &dir.0);
        let f = render_one_thread(&w);
        let (obj, _, n) = means(&f);
        eprintln!(
            "furnace {}: {obj:.5} over {n} pixels",
            mat.replace('\n', " ")
        );
        assert!(n > 500);
        if lossless {
            assert!((obj - 1.0).abs() < 0.01, "{mat}: {obj}");
        } else {
            assert!(obj <= 1.01 && obj > 0.7, "{mat}: {obj}");
        }
    }
}

/// The complete scene-file example in the README parses (and uses every material type).
#[test]
fn readme_scene_example_parses() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let readme = std::fs::read_to_string(root.join("README.md")).unwrap();
    let start = readme
        .find("```toml\n[render]")
        .expect("README has the example")
        + 8;
    let end = start + readme[start..].find("```").unwrap();
    let desc = parse_scene(&readme[start..end], &root.join("scenes/example.toml")).unwrap();
    assert_eq!(desc.materials.len(), 4);
    assert_eq!(desc.meshes.len(), 1);
    assert_eq!(desc.quads.len(), 1);
    assert!(desc.meshes[0].file.ends_with("scenes/meshes/blob.obj"));
}

/// Texture maps in the furnace (environment radiance 1, a convex box: one bounce): an albedo
/// map of constant sRGB 128 renders its linear value 0.2158605 within 1% — addressed by the
/// faces' own (u, v) (the mesh has no texture coordinates) and by texture coordinates of a
/// 3 × 2 atlas (edited box, face-varying) — and a procedural `noise:F` map renders its mean
/// over the object, within [0.3, 0.7]; a conductor's roughness map of constant 128/255 (linear
/// data) renders as `roughness = 128/255` (0.1%: the map's channel mean may round differently).
#[test]
fn texture_maps_in_the_furnace() {
    let dir = TempDir::new("furnace-maps");
    limitray::io::png::write_rgb8(&dir.path("grey.png"), 8, 8, vec![128; 8 * 8 * 3]).unwrap();
    let atlas = dir.path("atlas.obj");
    {
        let mut f = std::fs::File::create(&atlas).unwrap();
        limitray::mesh::shapes::write_tagged_obj(
            &mut f,
            &limitray::mesh::shapes::edited_box(),
            "edited box",
        )
        .unwrap();
    }
    let grey = 0.21586050011389926f64;
    for (mesh, map, lo, hi) in [
        ("rounded_box_s0.obj", "grey.png", grey * 0.99, grey * 1.01),
        (
            atlas.to_str().unwrap(),
            "grey.png",
            grey * 0.99,
            grey * 1.01,
        ),
        ("rounded_box_s0.obj", "noise:2", 0.3, 0.7),
    ] {
        let map_value = if map.starts_with("noise") {
            map.to_string()
        } else {
            dir.path(map).display().to_string()
        };
        let scene = furnace(1.0, 16, "radiance = 1.0", mesh).replace(
            "albedo = 1\n",
            &format!("albedo = 1\nalbedo_map = \"{map_value}\"\n"),
        );
        assert!(scene.contains("albedo_map"), "{scene}");
        let w = world(&scene, &dir.0);
        let f = render_one_thread(&w);
        let (obj, bg, n) = means(&f);
        eprintln!("furnace {mesh} {map}: object mean {obj:.5} over {n} pixels");
        assert!(n > 500 && obj >= lo && obj <= hi, "{mesh} {map}: {obj}");
        assert_eq!(bg, 1.0);
    }
    // A roughness map of constant 128/255 (linear data) renders as `roughness = 128/255`.
    let rough = |key: String| {
        let scene = furnace(1.0, 16, "radiance = 1.0", "rounded_box_s0.obj").replace(
            "type = \"diffuse\"\nalbedo = 1\n",
            &format!("type = \"conductor\"\nbase_color = 1.0\n{key}\n"),
        );
        assert!(scene.contains("rough"), "{scene}");
        means(&render_one_thread(&world(&scene, &dir.0))).0
    };
    let mapped = rough(format!(
        "roughness_map = \"{}\"",
        dir.path("grey.png").display()
    ));
    let scalar = rough(format!("roughness = {}", 128.0f32 / 255.0));
    assert!(
        (mapped - scalar).abs() < 1e-3 * scalar,
        "roughness map {mapped} vs scalar {scalar}"
    );
}

/// Texture map mistakes name the scene, the line and the key: a map on a material type that
/// does not take it, a missing image (the message also names the file), a bad noise frequency.
#[test]
fn texture_map_errors_name_the_key() {
    let dir = TempDir::new("map-errors");
    let base = furnace(1.0, 4, "radiance = 1.0", "rounded_box_s0.obj");
    let cases = [
        (
            base.replace("albedo = 1\n", "albedo = 1\nroughness_map = \"noise:2\"\n"),
            "'roughness_map' does not apply to a diffuse material",
        ),
        (
            base.replace("albedo = 1\n", "albedo = 1\nalbedo_map = \"nowhere.png\"\n"),
            "nowhere.png",
        ),
        (
            base.replace("albedo = 1\n", "albedo = 1\nalbedo_map = \"noise:-1\"\n"),
            "frequency -1",
        ),
    ];
    for (text, want) in cases {
        let path = dir.path("scene.toml");
        let line = text
            .lines()
            .position(|l| l.contains("_map"))
            .map(|i| i + 1)
            .unwrap();
        let err = parse_scene(&text, &path)
            .and_then(|desc| World::build(&desc, desc.render).map(|_| ()))
            .unwrap_err()
            .to_string();
        assert!(err.contains(want), "{err}");
        assert!(err.contains(&format!(":{line}")), "line {line}: {err}");
    }
}
