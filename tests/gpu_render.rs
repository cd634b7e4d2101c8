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

/// The scene at `path` at 64 × 48 pixels, `spp` samples, `seed`; its materials' texture maps
/// are left out (the GPU path tracer does not read them yet: `texture_maps_are_refused`),
/// its displacement and hierarchical edits kept.
fn world(path: &std::path::Path, spp: u32, seed: u32) -> World {
    let mut desc = read_scene(path).unwrap();
    for m in &mut desc.material_maps {
        *m = Default::default();
    }
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

/// A world whose materials have texture maps is refused by the GPU path tracer with a message
/// that says why and what to do, not rendered without them.
#[test]
fn texture_maps_are_refused() {
    let Some(ctx) = context_for_tests().expect("a Vulkan adapter is required under CI=true") else {
        return;
    };
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("scenes/detail.toml");
    let desc = read_scene(&path).unwrap();
    assert!(desc.material_maps.iter().any(|m| m.albedo.is_some()));
    let mut s = desc.render;
    s.width = 16;
    s.height = 16;
    let w = World::build(&desc, s).unwrap();
    let err = GpuRenderer::new(&ctx, &w, None)
        .err()
        .expect("refused")
        .to_string();
    assert!(err.contains("texture maps") && err.contains("CPU"), "{err}");
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
