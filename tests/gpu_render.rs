//! The GPU path tracer against the CPU one, on every bundled scene (`scenes/*.toml`) at 64×48:
//!
//! (a) primary hits: each pixel's centre ray (the AOV ray, generated on the GPU by the same
//!     camera arithmetic) hits the same instance and triangle with bitwise the same `t` as
//!     `SceneBvh::intersect` on the CPU, for 100% of pixels, and a quad light in front is seen
//!     by both or neither;
//! (b) radiance: at the same spp and seed, (1) the whole-image mean of every channel agrees
//!     within 0.5%, and (2) the per-pixel differences are consistent with Monte Carlo noise:
//!     their mean square is at most half the mean square difference between two CPU renders
//!     with different seeds (which estimates 2σ², so the bound is σ², the variance of one
//!     render; an independent unbiased renderer would give 2σ², and a biased one more).
//!     With the same counter-based RNG most paths are identical; they part only where
//!     sin/cos/atan2/acos round differently on the device.
//!
//! The first scene's primary test runs with its geometry split over 5–8 storage bindings.
//!
//! Without an adapter these tests print a note and pass, except under `CI=true`.

use limitray::gpu::context_for_tests;
use limitray::gpu::render::GpuRenderer;
use limitray::render::{read_scene, World};
use std::path::PathBuf;

fn scenes() -> Vec<PathBuf> {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("scenes");
    let mut v: Vec<PathBuf> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "toml"))
        .collect();
    v.sort();
    assert!(!v.is_empty(), "no bundled scenes");
    v
}

/// The scene at `path` at 64 × 48 pixels, `spp` samples, `seed`, as it is: texture maps,
/// displacement and hierarchical edits included.
fn world(path: &std::path::Path, spp: u32, seed: u32) -> World {
    let desc = read_scene(path).unwrap();
    let mut s = desc.render;
    s.width = 64;
    s.height = 48;
    s.spp = spp;
    s.seed = seed;
    World::build(&desc, s).unwrap()
}

#[test]
fn primary_hits_are_bitwise_the_cpu_hits_on_every_bundled_scene() {
    let Some(ctx) = context_for_tests().expect("a Vulkan adapter is required under CI=true") else {
        return;
    };
    for (k, path) in scenes().into_iter().enumerate() {
        let w = world(&path, 1, 1);
        // The first scene also with its geometry split over several storage bindings.
        let chunk = (k == 0).then(|| {
            let words = limitray::gpu::render::pack_world(&w).unwrap().0.words.len() as u64;
            (words / 8 + 1).next_power_of_two()
        });
        let gpu = GpuRenderer::new(&ctx, &w, chunk)
            .unwrap()
            .primary()
            .unwrap();
        let (width, height) = (w.camera.width, w.camera.height);
        assert_eq!(gpu.len(), (width * height) as usize);
        let mut differ = 0;
        let mut hits = 0;
        for y in 0..height {
            for x in 0..width {
                let g = gpu[(y * width + x) as usize];
                let (o, d) = w.camera.ray(x as f32 + 0.5, y as f32 + 0.5, 0.5, 0.5);
                let ray = limitray::bvh::Ray::new(o.to_array(), d.to_array());
                let c = w.scene.intersect(&ray);
                let tmax = c.map_or(f32::INFINITY, |h| h.hit.t);
                let quad = w.lights.intersect_quads(o, d, tmax).is_some();
                let same = match c {
                    None => g.status == 0 || (quad && g.status == 3),
                    Some(h) => {
                        (g.status == 1 || (quad && g.status == 3))
                            && g.instance == h.instance
                            && g.leaf == h.hit.leaf
                            && g.t.to_bits() == h.hit.t.to_bits()
                    }
                } && (g.status == 3) == quad;
                hits += c.is_some() as usize;
                if !same && differ < 5 {
                    eprintln!("{}: pixel ({x}, {y}): cpu {c:?} gpu {g:?}", path.display());
                }
                differ += !same as usize;
            }
        }
        assert_eq!(differ, 0, "{}: {differ} pixels differ", path.display());
        assert!(hits > 100, "{}: only {hits} hits", path.display());
        eprintln!(
            "{}: {} pixels, {hits} hits: all equal",
            path.display(),
            width * height
        );
    }
}

fn rgb(f: &limitray::render::Film) -> Vec<[f64; 3]> {
    f.pixels
        .iter()
        .map(|p| [p.rgba[0] as f64, p.rgba[1] as f64, p.rgba[2] as f64])
        .collect()
}

fn msd(a: &[[f64; 3]], b: &[[f64; 3]]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(x, y)| (0..3).map(|c| (x[c] - y[c]).powi(2)).sum::<f64>())
        .sum::<f64>()
        / (3 * a.len()) as f64
}

#[test]
fn radiance_agrees_statistically_on_every_bundled_scene() {
    let Some(ctx) = context_for_tests().expect("a Vulkan adapter is required under CI=true") else {
        return;
    };
    let spp = 8;
    for path in scenes() {
        let w = world(&path, spp, 1);
        let cpu = w.render(&|_| {});
        let gpu = GpuRenderer::new(&ctx, &w, None)
            .unwrap()
            .render(&w, &|_| {})
            .unwrap();
        let other = world(&path, spp, 2).render(&|_| {});
        let (c, g, o) = (rgb(&cpu), rgb(&gpu), rgb(&other));
        for ch in 0..3 {
            let mc: f64 = c.iter().map(|p| p[ch]).sum::<f64>() / c.len() as f64;
            let mg: f64 = g.iter().map(|p| p[ch]).sum::<f64>() / g.len() as f64;
            let rel = (mg - mc).abs() / mc.abs().max(1e-12);
            assert!(
                rel <= 0.005,
                "{}: channel {ch}: mean gpu {mg} cpu {mc} ({:.3}%)",
                path.display(),
                rel * 100.0
            );
        }
        let d_gc = msd(&g, &c);
        let d_seeds = msd(&c, &o);
        let exact = c.iter().zip(&g).filter(|(a, b)| a == b).count();
        eprintln!(
            "{}: msd gpu-cpu {d_gc:.3e}, cpu seed 1-2 {d_seeds:.3e}; {exact} of {} pixels bitwise equal",
            path.display(),
            c.len()
        );
        assert!(
            d_gc <= 0.5 * d_seeds,
            "{}: per-pixel differences {d_gc:e} exceed the noise of one render {:e}",
            path.display(),
            0.5 * d_seeds
        );
        // Alpha and the AOVs of the centre ray agree too.
        for (a, b) in cpu.pixels.iter().zip(&gpu.pixels) {
            assert_eq!(a.z.to_bits(), b.z.to_bits());
            assert_eq!(a.face, b.face);
            assert_eq!(a.level, b.level);
        }
    }
}

/// White furnace on the GPU: a closed diffuse rounded box (convex) of albedo 1 in a uniform
/// environment of radiance 1 renders 1 within 1%, albedo 0.5 renders 0.5 within 1%, and the
/// background is exactly 1.
#[test]
fn white_furnace_on_the_gpu() {
    let Some(ctx) = context_for_tests().expect("a Vulkan adapter is required under CI=true") else {
        return;
    };
    let mesh =
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/meshes/rounded_box_s0.obj");
    for (albedo, want) in [(1.0f32, 1.0f64), (0.5, 0.5)] {
        let text = format!(
            "[render]\nwidth = 40\nheight = 40\nspp = 16\nmax_depth = 16\nseed = 7\n\n\
             [camera]\nposition = [0.4, 0.9, 3.2]\nlook_at = [0, 0, 0]\nfov = 38\n\n\
             [materials.white]\ntype = \"diffuse\"\nalbedo = {albedo}\n\n\
             [[mesh]]\nfile = \"{}\"\nmaterial = \"white\"\nrate = 16\n\n\
             [environment]\nradiance = 1.0\n",
            mesh.display()
        );
        let desc =
            limitray::render::scene::parse_scene(&text, &mesh.with_file_name("furnace.toml"))
                .unwrap();
        let w = World::build(&desc, desc.render).unwrap();
        let f = GpuRenderer::new(&ctx, &w, None)
            .unwrap()
            .render(&w, &|_| {})
            .unwrap();
        let (mut obj, mut n, mut bg) = (0.0f64, 0usize, Vec::new());
        for p in &f.pixels {
            if p.rgba[3] == 1.0 {
                obj += p.rgba[0] as f64;
                n += 1;
            } else if p.rgba[3] == 0.0 {
                bg.push(p.rgba[0]);
            }
        }
        let obj = obj / n.max(1) as f64;
        eprintln!("gpu furnace albedo {albedo}: {obj:.5} over {n} pixels");
        assert!(n > 300, "object covers {n} pixels");
        assert!(
            (obj - want).abs() < 0.01 * want,
            "albedo {albedo}: mean {obj}"
        );
        assert!(!bg.is_empty() && bg.iter().all(|&x| x == 1.0));
    }
}

/// A fresh temporary folder for one test.
fn temp_dir(tag: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("limitray-gpu-{tag}-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// A smooth 64 × 32 sRGB image (sines and a ramp): neighbouring texels differ by at most
/// ~0.05 in sRGB units.
fn smooth_png(path: &std::path::Path) {
    let (w, h) = (64u32, 32u32);
    let mut rgb = Vec::with_capacity((w * h * 3) as usize);
    for y in 0..h {
        for x in 0..w {
            let a = std::f64::consts::TAU * x as f64 / w as f64;
            let b = std::f64::consts::TAU * y as f64 / h as f64;
            rgb.push((127.5 + 120.0 * a.sin()) as u8);
            rgb.push((255.0 * y as f64 / (h - 1) as f64) as u8);
            rgb.push((127.5 + 120.0 * (a + b).cos()) as u8);
        }
    }
    limitray::io::png::write_rgb8(path, w, h, rgb).unwrap();
}

/// Texture maps on the GPU, against the CPU, in one scene: an image albedo map read through a
/// face-varying UV atlas (the edited box, seams on every edge), a noise albedo map, a noise
/// roughness map on a conductor and an image emission map on a mesh without texture
/// coordinates (read at each face's own (u, v)).
///
/// (1) Per pixel, the albedo AOV (the textured albedo at each sample's first hit: primary hits
///     are bitwise the CPU's) and the radiance of directly seen emitter pixels agree within
///     1e-5 (measured ≤ 2e-7). What may differ: the GPU interpolates its vertices' exact
///     texture coordinates where the CPU evaluates them at the hit (they part by the
///     coordinates' curvature over one triangle, times an image whose texels step by ≤ 0.05),
///     noise is blended in f32 on the GPU and in f64 on the CPU, and log2 and sqrt may round
///     differently on the device. The footprint is the same quantity on both (texture area
///     per world area over the hit triangle); with the CPU's former exact-derivative scale
///     the mip blend alone moved colours by up to 1e-2.
/// (2) The radiance agrees statistically, as for the bundled scenes: the image means within
///     0.5% and per-pixel differences within the noise of one render.
#[test]
fn texture_maps_match_the_cpu() {
    let Some(ctx) = context_for_tests().expect("a Vulkan adapter is required under CI=true") else {
        return;
    };
    let dir = temp_dir("maps");
    smooth_png(&dir.join("smooth.png"));
    {
        let mut f = std::fs::File::create(dir.join("atlas.obj")).unwrap();
        let m = limitray::mesh::shapes::edited_box();
        limitray::mesh::shapes::write_tagged_obj(&mut f, &m, "edited box, UV atlas").unwrap();
    }
    let rounded =
        PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("scenes/meshes/rounded_box_s0.obj");
    let scene = |seed: u32| {
        let text = format!(
            "[render]\nwidth = 64\nheight = 48\nspp = 8\nmax_depth = 4\nseed = {seed}\n\n\
             [camera]\nposition = [0, 1.0, 2.9]\nlook_at = [0, 0, 0]\nfov = 50\n\n\
             [materials.atlas]\ntype = \"diffuse\"\nalbedo = 1\nalbedo_map = \"smooth.png\"\n\n\
             [materials.speckle]\ntype = \"diffuse\"\nalbedo = [0.9, 0.8, 0.7]\nalbedo_map = \"noise:3\"\n\n\
             [materials.brushed]\ntype = \"conductor\"\nbase_color = 0.9\nroughness_map = \"noise:2\"\n\n\
             [materials.glow]\ntype = \"emissive\"\nradiance = 2\nemission_map = \"smooth.png\"\n\n\
             [[mesh]]\nfile = \"atlas.obj\"\nmaterial = \"atlas\"\nrate = 12\ntranslate = [-1.5, 0, 0]\nscale = 0.5\nrotate = [20, 30, 0]\n\n\
             [[mesh]]\nfile = \"{r}\"\nmaterial = \"speckle\"\nrate = 12\ntranslate = [-0.5, 0, 0]\nscale = 0.6\n\n\
             [[mesh]]\nfile = \"{r}\"\nmaterial = \"brushed\"\nrate = 12\ntranslate = [0.5, 0, 0]\nscale = 0.6\n\n\
             [[mesh]]\nfile = \"{r}\"\nmaterial = \"glow\"\nrate = 12\ntranslate = [1.5, 0, 0]\nscale = 0.6\nrotate = [0, 40, 0]\n\n\
             [environment]\nradiance = 0.6\n",
            r = rounded.display()
        );
        let desc = limitray::render::scene::parse_scene(&text, &dir.join("maps.toml")).unwrap();
        World::build(&desc, desc.render).unwrap()
    };
    let w = scene(1);
    let cpu = w.render(&|_| {});
    let gpu = GpuRenderer::new(&ctx, &w, None)
        .unwrap()
        .render(&w, &|_| {})
        .unwrap();
    let (mut albedo_max, mut glow_max, mut seen, mut glow) = (0.0f32, 0.0f32, 0, 0);
    for (c, g) in cpu.pixels.iter().zip(&gpu.pixels) {
        assert_eq!(c.rgba[3], g.rgba[3]);
        if c.rgba[3] != 1.0 {
            continue;
        }
        seen += 1;
        for k in 0..3 {
            albedo_max = albedo_max.max((c.albedo[k] - g.albedo[k]).abs());
        }
        if c.albedo == [0.0; 3] {
            glow += 1;
            for k in 0..3 {
                glow_max = glow_max.max((c.rgba[k] - g.rgba[k]).abs() / 2.0);
            }
        }
    }
    eprintln!(
        "maps: {seen} object pixels ({glow} on the emitter): albedo differs by <= {albedo_max:.2e}, \
         emission (/ radiance) by <= {glow_max:.2e}"
    );
    assert!(seen > 800 && glow > 150, "{seen} {glow}");
    assert!(albedo_max <= 1e-5, "albedo AOV differs by {albedo_max}");
    assert!(glow_max <= 1e-5, "emission differs by {glow_max}");
    let (c, g, o) = (rgb(&cpu), rgb(&gpu), rgb(&scene(2).render(&|_| {})));
    for ch in 0..3 {
        let mc: f64 = c.iter().map(|p| p[ch]).sum::<f64>() / c.len() as f64;
        let mg: f64 = g.iter().map(|p| p[ch]).sum::<f64>() / g.len() as f64;
        assert!(
            (mg - mc).abs() <= 0.005 * mc,
            "channel {ch}: gpu {mg} cpu {mc}"
        );
    }
    let (d_gc, d_seeds) = (msd(&g, &c), msd(&c, &o));
    eprintln!("maps: msd gpu-cpu {d_gc:.3e}, cpu seed 1-2 {d_seeds:.3e}");
    assert!(d_gc <= 0.5 * d_seeds, "{d_gc:e} vs {d_seeds:e}");
    let _ = std::fs::remove_dir_all(&dir);
}
