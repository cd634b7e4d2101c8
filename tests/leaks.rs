//! Zero leaks: rays from inside a closed diced limit surface always hit it — random
//! directions (≥ 10^6 per shape and rate), rays aimed exactly at diced vertices and edge
//! midpoints, rays through extraordinary vertices and along a cube's diagonals — at rates 1, 2,
//! 4, 16 and 64, at the origin and translated to (148376, 1234, −223423). The count of misses
//! must be 0, for closest-hit and for any-hit queries, in the grid tracing core
//! ([`GridMesh`]; `tests/grid.rs` checks that the triangle BVH the GPU mirrors answers
//! hit or miss alike).

mod common;

use limitray::bvh::Ray;
use limitray::dice::DicedMesh;
use limitray::dice::{dice, DiceOptions, DiceRate};
use limitray::grid::GridMesh;
use limitray::harness::probe::{aimed_rays, count_leaks, inside_origins, sphere_dirs};
use limitray::mesh::obj::read_obj;
use limitray::mesh::ControlMesh;
use limitray::patch::approx::Approximation;
use limitray::patch::{PatchOptions, PatchTable};

const RATES: [u32; 5] = [1, 2, 4, 16, 64];
const FAR: [f64; 3] = [148376.0, 1234.0, -223423.0];
/// Triangle budget per case: shapes whose dicing at a rate exceeds it skip that rate (printed).
const MAX_TRIANGLES: usize = 4_000_000;

/// A diced mesh and its grid core.
struct Built {
    diced: DicedMesh,
    grid: GridMesh,
}

fn build(mesh: &ControlMesh, rate: u32) -> (PatchTable, Built) {
    let table = PatchTable::new(mesh, PatchOptions::default()).unwrap();
    build_from(table, mesh, rate)
}

fn build_from(table: PatchTable, mesh: &ControlMesh, rate: u32) -> (PatchTable, Built) {
    let d = dice(
        &table,
        mesh,
        &DiceOptions {
            rate: DiceRate::Uniform(rate),
            max_rate: 256,
            displace: None,
        },
    )
    .unwrap();
    let grid = GridMesh::build(&d).unwrap();
    (table, Built { diced: d, grid })
}

/// `(thinnest extent, largest coordinate)` of a mesh thinner than 8 float steps where it
/// lies: no point strictly inside exists, and the dicing collapses onto a few planes (a
/// degenerate, slow BVH build).
fn too_thin(m: &ControlMesh) -> Option<(f64, f64)> {
    let [lo, hi] = m.bounds();
    let thinnest = (0..3).map(|a| hi[a] - lo[a]).fold(f64::INFINITY, f64::min);
    let magnitude = lo.iter().chain(&hi).fold(0.0f64, |a, x| a.max(x.abs()));
    (thinnest < 8.0 * magnitude * f32::EPSILON as f64).then_some((thinnest, magnitude))
}

/// `LIMITRAY_LEAKS_ONLY=name` (a substring) restricts the corpus tests to matching shapes,
/// to reproduce one case quickly (and waives the case-count checks); unset, every shape runs.
fn selected(name: &str) -> bool {
    std::env::var("LIMITRAY_LEAKS_ONLY")
        .map_or(true, |only| !only.is_empty() && name.contains(&only))
}

fn translated(mesh: &ControlMesh, by: [f64; 3]) -> ControlMesh {
    let mut m = mesh.clone();
    for p in &mut m.positions {
        for k in 0..3 {
            p[k] += by[k];
        }
    }
    m
}

/// Runs every probe on one diced mesh; returns the rays cast. Panics on any miss.
fn probe(name: &str, built: &Built, diag: f64, random_rays: usize) -> usize {
    let d = &built.diced;
    let bvh = &built.grid;
    // Far from the origin a thin shape is only a few float steps thick and few candidate
    // points are certainly inside: one is enough, it then casts all the rays.
    let origins = inside_origins(d, 8, 2e-3 * diag, 7);
    // A shape thinner than 8 float steps where it lies (catmark_lefthanded is 0.03 thick; at
    // z = −223423 a step is 0.016) has no representable point strictly inside: the rays from
    // inside are undefined there, so the case is skipped, and only then.
    let [lo, hi] = bvh.bounds();
    let thinnest = (0..3).map(|a| hi[a] - lo[a]).fold(f32::INFINITY, f32::min);
    let magnitude = lo.iter().chain(&hi).fold(0.0f32, |m, x| m.max(x.abs()));
    if origins.is_empty() && thinnest < 8.0 * magnitude * f32::EPSILON {
        eprintln!("note: {name}: {thinnest} thick at magnitude {magnitude}: no point strictly inside; skipped");
        return 0;
    }
    assert!(
        !origins.is_empty(),
        "{name}: only {} inside origins",
        origins.len()
    );
    let per = random_rays.div_ceil(origins.len());
    let mut total = 0;
    for (i, &o) in origins.iter().enumerate() {
        let rays: Vec<Ray> = sphere_dirs(per, 1000 + i as u64)
            .into_iter()
            .map(|dir| Ray::new(o, dir))
            .collect();
        let c = count_leaks(bvh, &rays);
        assert_eq!(
            (c.missed, c.missed_any),
            (0, 0),
            "{name}: origin {o:?}: {c:?}"
        );
        total += c.rays;
    }
    // Aimed exactly at vertices (extraordinary vertices included) and edge midpoints.
    for &o in origins.iter().take(4) {
        let rays = aimed_rays(d, o, 200_000);
        let c = count_leaks(bvh, &rays);
        assert_eq!(
            (c.missed, c.missed_any),
            (0, 0),
            "{name}: aimed from {o:?}: {c:?}"
        );
        total += c.rays;
    }
    total
}

#[test]
fn cube_diagonals_and_grid_vertices() {
    let cube = common::cube_builder().build().unwrap();
    for by in [[0.0; 3], FAR] {
        let mesh = translated(&cube, by);
        for rate in RATES {
            let (_, bvh) = build(&mesh, rate);
            let c: [f32; 3] = by.map(|x| x as f32);
            // The eight diagonals through the corners (extraordinary vertices of valence 3).
            let rays: Vec<Ray> = (0..8)
                .map(|i| {
                    let s = |b: usize| if i & b == 0 { 1.0 } else { -1.0 };
                    Ray::new(c, [s(1), s(2), s(4)])
                })
                .collect();
            let l = count_leaks(&bvh.grid, &rays);
            assert_eq!((l.missed, l.missed_any), (0, 0), "rate {rate}, at {by:?}");
            // From the centre to every diced vertex and edge midpoint.
            let l = count_leaks(&bvh.grid, &aimed_rays(&bvh.diced, c, usize::MAX));
            assert_eq!((l.missed, l.missed_any), (0, 0), "rate {rate}, at {by:?}");
            let total = probe(&format!("cube rate {rate} at {by:?}"), &bvh, 3.5, 1_000_000);
            assert!(total >= 1_000_000);
        }
    }
}

#[test]
fn corpus_closed_shapes_do_not_leak() {
    let Some(models) = common::shared_models() else {
        return;
    };
    let mut cases = 0;
    let mut rays = 0usize;
    for path in common::catmark_files(&models) {
        let Ok(mesh) = read_obj(&path) else { continue };
        if !common::closed(&mesh) {
            continue;
        }
        let name = path.file_stem().unwrap().to_string_lossy().to_string();
        if !selected(&name) {
            continue;
        }
        for rate in RATES {
            // Uniform rate r gives 2 r² triangles per quad (n-gon sub-faces: ~r²/2).
            let estimate = 2 * (rate as usize).pow(2) * mesh.num_faces();
            if estimate > MAX_TRIANGLES {
                eprintln!(
                    "note: {name} rate {rate}: ~{estimate} triangles, over the budget; skipped"
                );
                continue;
            }
            for by in [[0.0; 3], FAR] {
                let t0 = std::time::Instant::now();
                let m = translated(&mesh, by);
                if let Some((thinnest, magnitude)) = too_thin(&m) {
                    eprintln!(
                        "note: {name} rate {rate} at {by:?}: {thinnest} thick at magnitude \
                         {magnitude}: no point strictly inside; skipped"
                    );
                    continue;
                }
                let (_, bvh) = build(&m, rate);
                let t1 = t0.elapsed().as_secs_f64();
                let cast = probe(
                    &format!("{name} rate {rate} at {by:?}"),
                    &bvh,
                    mesh.diagonal(),
                    1_000_000,
                );
                rays += cast;
                cases += (cast > 0) as usize;
                eprintln!(
                    "{name} rate {rate} at {by:?}: {} triangles, build {t1:.2} s, all {:.2} s",
                    bvh.diced.triangles.len(),
                    t0.elapsed().as_secs_f64()
                );
            }
        }
    }
    eprintln!("{cases} cases, {rays} rays, 0 misses");
    assert!(cases >= 200 || !selected(""), "only {cases} cases");
}

/// Paper 004's Gregory patches of every closed Catmull-Clark corpus shape (`--surface
/// gregory`), diced like the exact surface, at rates 1, 4 and 16, at the origin and far from
/// it: 100k random rays per case plus the aimed ones.
#[test]
fn catmark_gregory_patches_do_not_leak() {
    let Some(models) = common::shared_models() else {
        return;
    };
    let mut cases = 0;
    let mut rays = 0usize;
    for path in common::catmark_files(&models) {
        let Ok(mesh) = read_obj(&path) else { continue };
        if !common::closed(&mesh) {
            continue;
        }
        let name = path.file_stem().unwrap().to_string_lossy().to_string();
        if !selected(&name) {
            continue;
        }
        for rate in [1u32, 4, 16] {
            let estimate = 2 * (rate as usize).pow(2) * mesh.num_faces();
            if estimate > MAX_TRIANGLES {
                continue;
            }
            for by in [[0.0; 3], FAR] {
                let m = translated(&mesh, by);
                if too_thin(&m).is_some() {
                    continue;
                }
                let opts = PatchOptions {
                    surface: Approximation::Gregory,
                    ..PatchOptions::default()
                };
                let table = PatchTable::new(&m, opts).unwrap();
                let (_, bvh) = build_from(table, &m, rate);
                let cast = probe(
                    &format!("{name} (Gregory patches) rate {rate} at {by:?}"),
                    &bvh,
                    mesh.diagonal(),
                    100_000,
                );
                rays += cast;
                cases += (cast > 0) as usize;
            }
        }
    }
    eprintln!("Catmull-Clark Gregory patches: {cases} cases, {rays} rays, 0 misses");
    assert!(cases >= 100 || !selected(""), "only {cases} cases");
}

/// The Loop scheme (issue 15): every closed loop shape of the corpus and the meshes of the
/// bundled Loop scene under `Scheme::Loop`,
/// each triangle diced as three sub-quads sharing its edges and spokes, at rates 1–64, at the
/// origin and far from it, 300k random rays per case plus the aimed ones.
#[test]
fn corpus_closed_loop_shapes_do_not_leak() {
    if let Some((cases, rays)) = loop_cases(Approximation::Exact, 300_000) {
        eprintln!("Loop: {cases} cases, {rays} rays, 0 misses");
        assert!(cases >= 100 || !selected(""), "only {cases} cases");
    }
}

/// Paper 002's approximations of the same Loop surfaces (PN, Walton–Meek, Gregory
/// triangles) diced the same way: the same cases, 100k random rays each plus the aimed ones.
#[test]
fn loop_approximations_do_not_leak() {
    for surface in [Approximation::Pn, Approximation::Wm, Approximation::Gregory] {
        if let Some((cases, rays)) = loop_cases(surface, 100_000) {
            eprintln!("Loop {surface}: {cases} cases, {rays} rays, 0 misses");
            assert!(cases >= 100 || !selected(""), "only {cases} cases");
        }
    }
}

/// Probes every closed Loop case (see [`corpus_closed_loop_shapes_do_not_leak`]) on
/// `surface` with `per_case` random rays; `(cases, rays)`, or `None` without the corpus.
fn loop_cases(surface: Approximation, per_case: usize) -> Option<(usize, usize)> {
    let models = common::shared_models()?;
    let mut cases = 0;
    let mut rays = 0usize;
    // The corpus's loop shapes and the bundled Loop scene's meshes (scenes/loop.toml).
    let scene = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/meshes");
    let mut files = common::corpus_files(&models, "loop_");
    files.extend(["blob.obj", "gear8_tri.obj", "rounded_box_s2_tri.obj"].map(|f| scene.join(f)));
    for path in files {
        let Ok(mut mesh) = read_obj(&path) else {
            continue;
        };
        if !common::closed(&mesh) {
            continue;
        }
        mesh.options.scheme = limitray::mesh::Scheme::Loop;
        let name = path.file_stem().unwrap().to_string_lossy().to_string();
        if !selected(&name) {
            continue;
        }
        for rate in RATES {
            // Three sub-quads of (r/2)² quads per triangle: ~1.5 r² triangles.
            let estimate = 3 * (rate as usize).pow(2) * mesh.num_faces() / 2;
            if estimate > MAX_TRIANGLES {
                eprintln!("note: {name} rate {rate}: ~{estimate} triangles; skipped");
                continue;
            }
            for by in [[0.0; 3], FAR] {
                let m = translated(&mesh, by);
                let opts = PatchOptions {
                    surface,
                    ..PatchOptions::default()
                };
                let table = PatchTable::new(&m, opts).unwrap();
                let (_, bvh) = build_from(table, &m, rate);
                let cast = probe(
                    &format!("{name} (Loop, {surface}) rate {rate} at {by:?}"),
                    &bvh,
                    mesh.diagonal(),
                    per_case,
                );
                rays += cast;
                cases += (cast > 0) as usize;
            }
        }
    }
    Some((cases, rays))
}

/// Hierarchically edited closed surfaces (a cube and the blob with bumps added at levels 1–3
/// on single corners, vertex and edge sharpness set below the base level) leak nothing at
/// rates 1–64, in place and far from the origin: the edits change the patches, not how the
/// dicing shares edge samples.
#[test]
fn hierarchical_edits_do_not_leak() {
    use limitray::mesh::{shapes, EditKind, EditOp, HierarchicalEdit};
    let edit = HierarchicalEdit::new;
    let bump = |corner: u32, z: f64| EditKind::Position {
        corner,
        op: EditOp::Add,
        value: [0.1 * z, -0.05 * z, z],
    };
    let mut cube = common::cube_builder().build().unwrap();
    cube.edits = vec![
        edit(0, &[1], bump(2, 0.4)),
        edit(2, &[0, 3], bump(0, -0.3)),
        edit(3, &[2, 2, 1], bump(3, 0.25)),
        edit(
            4,
            &[1],
            EditKind::EdgeSharpness {
                edge: 1,
                op: EditOp::Set,
                value: 3.0,
            },
        ),
        edit(
            5,
            &[3, 0],
            EditKind::VertexSharpness {
                corner: 2,
                op: EditOp::Set,
                value: 10.0,
            },
        ),
    ];
    let mut blob = shapes::blob();
    blob.edits = vec![
        edit(3, &[0, 1], bump(1, 0.3)),
        edit(
            7,
            &[2],
            EditKind::EdgeSharpness {
                edge: 0,
                op: EditOp::Add,
                value: 2.5,
            },
        ),
        edit(11, &[1, 1, 1], bump(0, -0.2)),
    ];
    let mut cases = 0;
    // And the detail scene's edited box (scenes/meshes/edited_box.obj).
    let meshes = [
        ("cube", cube),
        ("blob", blob),
        ("edited_box", shapes::edited_box()),
    ];
    for (name, mesh) in meshes {
        for rate in RATES {
            for by in [[0.0; 3], FAR] {
                let m = translated(&mesh, by);
                let table = PatchTable::new(&m, PatchOptions::default()).unwrap();
                let (_, built) = build_from(table, &m, rate);
                let label = format!("{name} (edited) rate {rate} at {by:?}");
                cases += (probe(&label, &built, mesh.diagonal(), 100_000) > 0) as usize;
            }
        }
    }
    assert_eq!(cases, 3 * 2 * RATES.len());
}

/// Displaced closed surfaces (`--displace noise:…`: corpus cubes with creases, the tori, and
/// the bundled scenes' blob, gear and boxes) leak nothing at rates 1–64, in place and far from
/// the origin, closest and any hit: a vertex on a shared edge is displaced once and its `f32`
/// position copied into both sides. The amplitude is 4% of the diagonal and the frequency
/// puts several bumps on each face, so the displaced surface folds and self-intersects in
/// places.
#[test]
fn displaced_surfaces_do_not_leak() {
    let Some(models) = common::shared_models() else {
        return;
    };
    let scene = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/meshes");
    let mut files: Vec<std::path::PathBuf> = [
        "catmark_cube",
        "catmark_cube_creases2",
        "catmark_cubes_semisharp",
        "catmark_torus",
        "catmark_torus_creases1",
    ]
    .iter()
    .map(|n| models.join(format!("opensubdiv/{n}.obj")))
    .collect();
    files.extend(["blob.obj", "gear8.obj", "rounded_box_s2.obj"].map(|f| scene.join(f)));
    let mut cases = 0;
    for path in files {
        let mesh = read_obj(&path).unwrap();
        let name = path.file_stem().unwrap().to_string_lossy().to_string();
        if !selected(&name) {
            continue;
        }
        let diag = mesh.diagonal();
        let noise = limitray::dice::Displacement::Noise {
            amplitude: 0.04 * diag,
            frequency: 6.0 / diag,
        };
        // An image map: 64 × 48 texels of noise in [0, 1], addressed by each face's own (u, v)
        // (the mesh has no texture coordinates: the heights jump across every edge) and by
        // texture coordinates with seams (the vertices' x, y with islands of their own).
        let texels: Vec<[f32; 3]> = (0..64 * 48)
            .map(|i| {
                let (x, y) = ((i % 64) as f64 * 0.37, (i / 64) as f64 * 0.41);
                [(0.5 + 0.5 * limitray::texture::noise::noise([x, y, 0.5]).0) as f32; 3]
            })
            .collect();
        let map = limitray::dice::Displacement::Map {
            texture: std::sync::Arc::new(limitray::texture::image::ImageTexture::from_rgb(
                64, 48, texels,
            )),
            scale: 0.04 * diag,
            file: "noise.png".into(),
        };
        let mut with_uvs = mesh.clone();
        with_uvs.uvs = mesh
            .positions
            .iter()
            .map(|p| [p[0] / diag, p[1] / diag])
            .collect();
        with_uvs.face_uvs = mesh.face_verts.clone();
        for f in (0..mesh.num_faces()).step_by(3) {
            for c in mesh.face_offsets[f] as usize..mesh.face_offsets[f + 1] as usize {
                let v = with_uvs.face_uvs[c] as usize;
                with_uvs.uvs.push(with_uvs.uvs[v].map(|x| x + 0.3));
                with_uvs.face_uvs[c] = (with_uvs.uvs.len() - 1) as u32;
            }
        }
        let variants = [
            ("noise", &mesh, &noise, 50_000),
            ("face-uv map", &mesh, &map, 20_000),
            ("seamed-uv map", &with_uvs, &map, 20_000),
        ];
        for (what, mesh, displace, rays) in variants {
            for rate in RATES {
                let estimate = 2 * (rate as usize).pow(2) * mesh.face_verts.len() / 4;
                if estimate > MAX_TRIANGLES {
                    continue;
                }
                for by in [[0.0; 3], FAR] {
                    let m = translated(mesh, by);
                    let table = PatchTable::new(&m, PatchOptions::default()).unwrap();
                    let d = dice(
                        &table,
                        &m,
                        &DiceOptions {
                            rate: DiceRate::Uniform(rate),
                            max_rate: 256,
                            displace: Some(displace.clone()),
                        },
                    )
                    .unwrap();
                    let grid = GridMesh::build(&d).unwrap();
                    let built = Built { diced: d, grid };
                    let label = format!("{name} ({what}) rate {rate} at {by:?}");
                    cases += (probe(&label, &built, diag, rays) > 0) as usize;
                }
            }
        }
    }
    assert!(cases >= 210 || !selected(""), "only {cases} cases");
}
