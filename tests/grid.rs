//! The grid core ([`GridMesh`]) against the triangle BVH ([`MeshBvh`]) on the same diced
//! triangles: hit or miss equal on every ray (random rays through the box, rays aimed exactly
//! at diced vertices and edge points), `t` equal bit for bit on all but a few, the reported
//! triangle giving that `t` on its own, its parameters and normals those of the diced
//! triangle. (`t` may differ by an ulp: a box is skipped when its entry distance exceeds the
//! best `t` so far, and a box's entry distance and a triangle's `t` round differently, so
//! which of two triangles within an ulp is tested depends on the order of the traversal.) Uniform
//! rates (pure grids), length-based rates (zippers between different rates: loose triangles)
//! and n-gons, on the closed corpus shapes and on random creased generator meshes.

mod common;
mod oracle;

use limitray::bvh::{intersect_triangle, Hit, MeshBvh, Ray};
use limitray::dice::{dice, DiceOptions, DiceRate, DicedMesh, Displacement};
use limitray::grid::GridMesh;
use limitray::harness::probe::aimed_rays;
use limitray::harness::rays::random_rays;
use limitray::mesh::obj::{parse_obj, read_obj};
use limitray::mesh::ControlMesh;
use limitray::patch::{PatchOptions, PatchTable};
use oracle::gen::{generate, Features};

/// Counts of a comparison.
#[derive(Clone, Copy, Debug, Default)]
struct Counts {
    hits: usize,
    /// Hits on different triangles (equal or ulp-close `t`).
    other_triangle: usize,
    /// Hits whose `t` differs.
    other_t: usize,
    /// Largest relative difference of `t`.
    worst_t: f64,
}

/// Compares the two structures on `rays`.
fn compare(name: &str, d: &DicedMesh, rays: &[Ray]) -> Counts {
    let grid = GridMesh::build(d).unwrap();
    let bvh = MeshBvh::build(d.clone());
    assert_eq!(grid.triangles, d.triangles.len());
    let mut c = Counts::default();
    let alone = |h: &Hit, ray: &Ray| {
        let p = d.triangles[h.triangle as usize].map(|v| d.positions[v as usize]);
        intersect_triangle(ray, p[0], p[1], p[2]).map(|x| x.0.to_bits())
    };
    for (i, ray) in rays.iter().enumerate() {
        let a = grid.intersect(ray);
        let b = bvh.intersect(ray);
        assert_eq!(
            a.is_some(),
            b.is_some(),
            "{name}: ray {i} {ray:?}: grid {a:?}, triangle BVH {b:?}"
        );
        assert_eq!(grid.occluded(ray), a.is_some(), "{name}: ray {i}");
        let (Some(a), Some(b)) = (a, b) else { continue };
        c.hits += 1;
        // The hit's location gives back its record and the diced triangle's corners.
        assert_eq!(grid.hit_at(a.leaf, a.t, a.b1, a.b2), a, "{name}: ray {i}");
        let corners = d.triangles[a.triangle as usize].map(|v| d.positions[v as usize]);
        assert_eq!(grid.corners(a.leaf), corners, "{name}: ray {i}");
        let normals = grid.corner_normals(a.leaf);
        for (n, v) in normals.iter().zip(d.triangles[a.triangle as usize]) {
            let m = d.normals[v as usize];
            // The angle, from |n × m| in f64: octahedral normals are within 5e-5 rad of what
            // they encode (block.rs's bound, 4.3e-5 plus the f32 rounding of the decode).
            let (n, m) = (n.map(f64::from), m.map(f64::from));
            let c = [
                n[1] * m[2] - n[2] * m[1],
                n[2] * m[0] - n[0] * m[2],
                n[0] * m[1] - n[1] * m[0],
            ];
            let sin = (c.iter().map(|x| x * x).sum::<f64>()).sqrt();
            let dot: f64 = (0..3).map(|k| n[k] * m[k]).sum();
            assert!(sin <= 5e-5 && dot > 0.0, "{name}: ray {i}: {n:?} vs {m:?}");
        }
        // Each reported triangle, alone, gives the reported t.
        assert_eq!(alone(&a, ray), Some(a.t.to_bits()), "{name}: ray {i}");
        assert_eq!(alone(&b, ray), Some(b.t.to_bits()), "{name}: ray {i}");
        if a.t != b.t {
            c.other_t += 1;
            let rel = (a.t as f64 - b.t as f64).abs() / (a.t.abs().max(b.t.abs()) as f64);
            c.worst_t = c.worst_t.max(rel);
        }
        if a.triangle != b.triangle {
            c.other_triangle += 1;
            continue;
        }
        check_record(name, i, d, &a, &b);
    }
    // An ulp or two of `t`, on rays through shared vertices and edges and on coincident
    // sheets, where two triangles' `t` are within rounding of each other.
    assert!(c.worst_t <= 4.0 * f32::EPSILON as f64, "{name}: {c:?}");
    c
}

/// The same triangle's hit records agree: barycentrics and face bit for bit, `(u, v)` within
/// 2 ulps (the grid computes corner parameters as `i / n`, the pattern as `1 − j / n` on some
/// sides), the shading normal within what octahedral corner normals allow.
fn check_record(name: &str, i: usize, d: &DicedMesh, a: &Hit, b: &Hit) {
    assert_eq!(
        (a.b1.to_bits(), a.b2.to_bits(), a.face, a.k, a.level),
        (b.b1.to_bits(), b.b2.to_bits(), b.face, b.k, b.level),
        "{name}: ray {i}"
    );
    assert_eq!(a.ng, b.ng, "{name}: ray {i}");
    assert!(
        (a.u - b.u).abs() <= 2.0 * f32::EPSILON && (a.v - b.v).abs() <= 2.0 * f32::EPSILON,
        "{name}: ray {i}: uv {} {} vs {} {}",
        a.u,
        a.v,
        b.u,
        b.v
    );
    // Each corner normal is within 4.3e-5 of the exact one; normalising the interpolated
    // sum divides that by its length (short where the corner normals nearly cancel).
    let n = d.triangles[a.triangle as usize].map(|v| d.normals[v as usize]);
    let w = [1.0 - a.b1 - a.b2, a.b1, a.b2];
    let sum: [f32; 3] = std::array::from_fn(|k| w[0] * n[0][k] + w[1] * n[1][k] + w[2] * n[2][k]);
    let len = (sum[0] * sum[0] + sum[1] * sum[1] + sum[2] * sum[2]).sqrt();
    let tol = 1e-6 + 5e-5 * (w[0].abs() + w[1].abs() + w[2].abs()) / len;
    let dn: f32 = (0..3)
        .map(|k| (a.ns[k] - b.ns[k]).abs())
        .fold(0.0, f32::max);
    assert!(
        dn <= 2.0 * tol,
        "{name}: ray {i}: shading normals {:?} vs {:?}",
        a.ns,
        b.ns
    );
}

fn diced(mesh: &ControlMesh, rate: DiceRate) -> DicedMesh {
    let table = PatchTable::new(mesh, PatchOptions::default()).unwrap();
    dice(
        &table,
        mesh,
        &DiceOptions {
            rate,
            max_rate: 64,
            displace: None,
        },
    )
    .unwrap()
}

fn rays_for(d: &DicedMesh, n: usize, seed: u64) -> Vec<Ray> {
    let b = d.bounds();
    let mut rays = random_rays(b, n, seed);
    let c: [f32; 3] =
        std::array::from_fn(|k| 0.5 * (b[0][k] + b[1][k]) + 0.01 * (b[1][k] - b[0][k]));
    let o: [f32; 3] = std::array::from_fn(|k| b[1][k] + 0.7 * (b[1][k] - b[0][k]));
    rays.extend(aimed_rays(d, c, n));
    rays.extend(aimed_rays(d, o, n));
    rays
}

fn rates(diag: f64) -> Vec<DiceRate> {
    vec![
        DiceRate::Uniform(1),
        DiceRate::Uniform(3),
        DiceRate::Uniform(16),
        DiceRate::EdgeLength(diag / 40.0),
        DiceRate::EdgeLength(diag / 150.0),
    ]
}

#[test]
fn corpus_shapes_trace_as_the_triangle_bvh() {
    let Some(models) = common::shared_models() else {
        return;
    };
    let (mut shapes, mut total, mut loose) = (0, Counts::default(), 0usize);
    for path in common::catmark_files(&models) {
        let Ok(mesh) = read_obj(&path) else { continue };
        if !common::closed(&mesh) || mesh.num_faces() > 2000 {
            continue;
        }
        let name = path.file_stem().unwrap().to_string_lossy().to_string();
        for (r, rate) in rates(mesh.diagonal()).into_iter().enumerate() {
            let d = diced(&mesh, rate);
            let c = compare(
                &format!("{name} {rate:?}"),
                &d,
                &rays_for(&d, 1500, r as u64),
            );
            total.hits += c.hits;
            total.other_triangle += c.other_triangle;
            total.other_t += c.other_t;
            total.worst_t = total.worst_t.max(c.worst_t);
            loose += GridMesh::build(&d).unwrap().loose.len();
        }
        shapes += 1;
    }
    eprintln!("{shapes} shapes: {total:?}, {loose} loose triangles");
    assert!(shapes >= 25 && total.hits > 100_000 && loose > 1000);
}

#[test]
fn random_creased_meshes_trace_as_the_triangle_bvh() {
    let features = Features {
        smooth_triangles: true,
        skip_chaikin_boundary_none: false,
        nonmanifold: true,
    };
    let mut hits = 0;
    for seed in 0..60u64 {
        let g = generate(seed, features);
        let mesh = parse_obj(&g.to_obj(), Some("generated")).unwrap();
        let rate = rates(mesh.diagonal())[(seed % 5) as usize];
        let d = diced(&mesh, rate);
        hits += compare(
            &format!("seed {seed} ({}) {rate:?}", g.recipe),
            &d,
            &rays_for(&d, 400, seed),
        )
        .hits;
    }
    assert!(hits > 10_000, "{hits} hits");
}

/// At uniform rates every triangle is in a grid block; blocks hold at most 8×8 quads.
#[test]
fn uniform_rates_are_all_grid() {
    let mesh = limitray::mesh::shapes::rounded_box(2.0);
    for rate in [1, 4, 8, 16, 24] {
        let d = diced(&mesh, DiceRate::Uniform(rate));
        let g = GridMesh::build(&d).unwrap();
        assert!(g.loose.is_empty(), "rate {rate}: {} loose", g.loose.len());
        let quads: usize = g
            .blocks
            .iter()
            .map(|b| b.cols as usize * b.rows as usize)
            .sum();
        assert_eq!(2 * quads, d.triangles.len());
        assert!(g.blocks.iter().all(|b| b.cols <= 8 && b.rows <= 8));
    }
}

/// Dicing straight into the grid core (`GridMesh::dice`: each domain's blocks and loose
/// triangles stored from its worker's buffers, no diced mesh made) builds exactly the grid
/// mesh of the diced mesh (`GridMesh::build` of `dice`): every block, vertex bit, normal
/// code, box, level, loose triangle and top-level node equal, and the triangles' corners
/// those of the diced mesh. Closed and open corpus shapes and random creased meshes (n-gons,
/// non-manifold, holes), uniform and length-based rates, with and without displacement.
#[test]
fn dicing_into_the_grid_builds_the_same_grid() {
    let check = |name: &str, mesh: &ControlMesh, rate: DiceRate, displace: bool| {
        let table = PatchTable::new(mesh, PatchOptions::default()).unwrap();
        let diag = mesh.diagonal();
        let opts = DiceOptions {
            rate,
            max_rate: 64,
            displace: displace.then(|| Displacement::Noise {
                amplitude: 0.02 * diag,
                frequency: 3.0 / diag,
            }),
        };
        let (full, fused) = match (
            dice(&table, mesh, &opts),
            GridMesh::dice(&table, mesh, &opts),
        ) {
            (Ok(f), Ok(l)) => (f, l),
            // A mesh dicing refuses (catmark_square_hedit4's hole below the base level): the
            // same error both ways.
            (Err(e), Err(e2)) => {
                assert_eq!(e.to_string(), e2.to_string(), "{name}");
                return 0;
            }
            (f, l) => panic!("{name} {rate:?}: {:?} vs {:?}", f.err(), l.err()),
        };
        let corners: Vec<[[f32; 3]; 3]> = full
            .triangles
            .iter()
            .map(|t| t.map(|v| full.positions[v as usize]))
            .collect();
        assert!(fused.triangle_corners() == corners, "{name} {rate:?}");
        // Every grid vertex read from a region's frame or interior is the corner the region's
        // triangles name.
        for g in &full.grids {
            let [qc, qr] = g.part.quads;
            for y in 0..qr {
                for x in 0..qc {
                    let t = g.first_triangle as usize + 2 * (y * qc + x) as usize;
                    let v = |dx, dy| g.vertex(&full.grid_frames, x + dx, y + dy);
                    assert_eq!(
                        [full.triangles[t], full.triangles[t + 1]],
                        [[v(0, 0), v(1, 0), v(1, 1)], [v(0, 0), v(1, 1), v(0, 1)]],
                        "{name} {rate:?}: quad ({x}, {y}) of face {} sub-face {}",
                        g.face,
                        g.k
                    );
                }
            }
        }
        let a = GridMesh::build(&full).unwrap();
        let b = fused;
        assert!(
            a == b,
            "{name} {rate:?} displaced {displace}: the grid meshes differ"
        );
        assert!(b.shading_normals && b.normals.len() == (b.coords.len() - 4) / 3);
        // Built for tracing alone: the same mesh but for the normals, the same hits but for
        // the shading normal, which is the geometric one.
        let g = GridMesh::dice_geometry(&table, mesh, &opts).unwrap();
        let mut stripped = b.clone();
        stripped.normals.clear();
        stripped.shading_normals = false;
        for l in &mut stripped.loose {
            l.n = [0; 3];
        }
        assert!(
            stripped == g,
            "{name} {rate:?} displaced {displace}: the geometry-only grid mesh differs"
        );
        let bounds = b.bounds();
        for (i, ray) in random_rays(bounds, 300, 7).iter().enumerate() {
            let want = b.intersect(ray).map(|h| Hit { ns: h.ng, ..h });
            assert_eq!(g.intersect(ray), want, "{name}: ray {i}");
            assert_eq!(g.occluded(ray), b.occluded(ray), "{name}: ray {i}");
        }
        a.blocks.len()
    };
    let mut blocks = 0;
    if let Some(models) = common::shared_models() {
        for (i, path) in common::catmark_files(&models).into_iter().enumerate() {
            let Ok(mesh) = read_obj(&path) else { continue };
            if mesh.num_faces() > 2000 {
                continue;
            }
            let name = path.file_stem().unwrap().to_string_lossy().to_string();
            let rates = rates(mesh.diagonal());
            blocks += check(&name, &mesh, rates[i % 5], i % 3 == 0);
        }
    }
    let features = Features {
        smooth_triangles: true,
        skip_chaikin_boundary_none: false,
        nonmanifold: true,
    };
    for seed in 0..30u64 {
        let g = generate(seed, features);
        let mesh = parse_obj(&g.to_obj(), Some("generated")).unwrap();
        let rate = rates(mesh.diagonal())[(seed % 5) as usize];
        blocks += check(
            &format!("seed {seed} ({})", g.recipe),
            &mesh,
            rate,
            seed % 4 == 1,
        );
    }
    assert!(blocks > 1000, "{blocks} blocks");
}

/// A dicing by a plan (`dice::plan`, the renderer's way: every mesh planned, the scene's
/// memory checked, then each diced by its plan without measuring its edges again) builds the
/// grid mesh `GridMesh::dice` builds, bit for bit, and the plan's estimate bounds its
/// triangles. Screen-space rates (as the renderer's), uniform and length-based rates,
/// with and without displacement, on corpus shapes and random creased meshes. A plan made for
/// another mesh is refused, not diced by.
#[test]
fn dicing_by_a_plan_builds_the_same_grid() {
    use limitray::dice::{plan, ScreenRate};
    let check = |name: &str, mesh: &ControlMesh, i: usize| {
        let table = PatchTable::new(mesh, PatchOptions::default()).unwrap();
        let diag = mesh.diagonal();
        let [lo, hi] = mesh.bounds();
        let eye = std::array::from_fn(|k| hi[k] + 0.8 * (hi[k] - lo[k]) + 0.1 * diag);
        let mut all = rates(diag);
        all.push(DiceRate::Screen(ScreenRate {
            eye,
            pixels_per_radian: 600.0,
            pixels_per_edge: 1.5,
        }));
        let rate = all[i % all.len()];
        let opts = DiceOptions {
            rate,
            max_rate: 64,
            displace: (i % 3 == 1).then(|| Displacement::Noise {
                amplitude: 0.02 * diag,
                frequency: 3.0 / diag,
            }),
        };
        let (planned, direct) = match (
            plan(&table, mesh, &opts),
            GridMesh::dice(&table, mesh, &opts),
        ) {
            (Ok(p), Ok(d)) => (p, d),
            (Err(e), Err(e2)) => {
                assert_eq!(e.to_string(), e2.to_string(), "{name}");
                return false;
            }
            (Ok(p), Err(e)) => {
                // Refused after planning (catmark_square_hedit4's hole below the base level):
                // refused the same way by the plan.
                let e2 = GridMesh::dice_planned(&table, mesh, &opts, p).unwrap_err();
                assert_eq!(e.to_string(), e2.to_string(), "{name}");
                return false;
            }
            (p, d) => panic!("{name} {rate:?}: {:?} vs {:?}", p.err(), d.err()),
        };
        // The plan's estimate bounds the mesh (as `estimate_size`'s, which is the plan's).
        let est = planned.estimate();
        assert!(
            direct.triangles as f64 <= est.triangles,
            "{name} {rate:?}: {} triangles, {} estimated",
            direct.triangles,
            est.triangles
        );
        let by_plan = GridMesh::dice_planned(&table, mesh, &opts, planned).unwrap();
        assert!(by_plan == direct, "{name} {rate:?}: the grid meshes differ");
        true
    };
    let mut checked = 0;
    if let Some(models) = common::shared_models() {
        for (i, path) in common::catmark_files(&models).into_iter().enumerate() {
            // Every other shape (its neighbours in the listing are variants of it).
            let Ok(mesh) = read_obj(&path) else { continue };
            if mesh.num_faces() > 2000 || i % 2 == 1 {
                continue;
            }
            let name = path.file_stem().unwrap().to_string_lossy().to_string();
            // Not the poles of valence 360 (half a minute each at the screen rate here; the
            // grid test above dices them).
            if name.contains("360") {
                continue;
            }
            checked += check(&name, &mesh, i / 2) as usize;
        }
    }
    let features = Features {
        smooth_triangles: true,
        skip_chaikin_boundary_none: false,
        nonmanifold: true,
    };
    for seed in 0..14u64 {
        let g = generate(seed, features);
        let mesh = parse_obj(&g.to_obj(), Some("generated")).unwrap();
        checked += check(&format!("seed {seed} ({})", g.recipe), &mesh, seed as usize) as usize;
    }
    assert!(checked > 30, "{checked} meshes diced");
    // A plan of another mesh (another edge count) is an error naming what went wrong.
    let small = parse_obj(&generate(1, features).to_obj(), Some("a")).unwrap();
    let big = limitray::mesh::generate::grid(5);
    let opts = DiceOptions {
        rate: DiceRate::Uniform(2),
        max_rate: 64,
        displace: None,
    };
    let small_table = PatchTable::new(&small, PatchOptions::default()).unwrap();
    let big_table = PatchTable::new(&big, PatchOptions::default()).unwrap();
    let p = plan(&small_table, &small, &opts).unwrap();
    let e = GridMesh::dice_planned(&big_table, &big, &opts, p).unwrap_err();
    assert!(e.to_string().contains("another mesh"), "{e}");
}
