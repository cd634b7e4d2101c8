//! The reference intersector (issue 17) on the corpus's closed Catmull-Clark shapes and on
//! randomly generated creased meshes (tests/oracle/gen.rs): every hit is on the limit surface
//! at its reported `(face, k, u, v)` (the project's `eval`, itself checked against OpenSubdiv
//! Far) within 1e-12 of the bounding-box diagonal, every non-grazing hit reports `err ≤ 1e-12`,
//! a ray aimed at a surface point hits at or before it, and Newton's method started from the
//! diced surface's hit (rate 16) finds no crossing in front of the exact first hit.
//!
//! The same checks run on the corpus's closed Loop shapes and random Loop meshes
//! (`generate_loop`): there hits report the triangle's own `(u, v)` (`k = 0`), checked with
//! `eval_triangle`, while the diced surface's hits are in its sub-quad parameters.
//!
//! Ray counts scale with `LIMITRAY_EXACT_RAYS` (rays per corpus shape, default 3000; the
//! random meshes get a sixth of it each). `scripts/soak-exact.sh` runs more than 10^6 rays.

mod common;
mod oracle;

use limitray::bvh::{MeshBvh, Ray, Ray64};
use limitray::dice::{dice, DiceOptions, DiceRate};
use limitray::harness::rng::SplitMix64;
use limitray::mesh::obj::{parse_obj, read_obj};
use limitray::mesh::ControlMesh;
use limitray::patch::{PatchOptions, PatchTable};
use limitray::{ExactTracer, FaceCoord};
use oracle::gen::{generate, Features};
use rayon::prelude::*;
use std::sync::Arc;

/// `|o + t d − P(face, k, u, v)|` bound for every hit, relative to the diagonal (issue 17).
const ON_SURFACE: f64 = 1e-12;

/// Newton's method on `P(u, v) = o + t d` in one (sub-)face from a start point: the crossing
/// (`t`) if it converges to within 1e-13 of the diagonal inside the face's domain (two
/// crossings 1e-9 of the diagonal apart along a ray are told apart). An
/// independent way (no bounds, no search) to find crossings near a diced hit.
fn newton_from(table: &PatchTable, ray: &Ray64, at: FaceCoord, t0: f64, diag: f64) -> Option<f64> {
    use limitray::vec3::{cross, dot, norm};
    let (o, d) = (ray.origin, ray.dir);
    let (mut u, mut v, mut t) = (at.u, at.v, t0);
    for _ in 0..30 {
        let s = table.eval(FaceCoord::new(at.face, at.k, u, v)).ok()?;
        let f: [f64; 3] = std::array::from_fn(|c| s.p[c] - o[c] - t * d[c]);
        if norm(f) <= 1e-13 * diag {
            return Some(t);
        }
        let nd = d.map(|x| -x);
        let det = dot(s.du, cross(s.dv, nd));
        if det == 0.0 || !det.is_finite() {
            return None;
        }
        let mf = f.map(|x| -x);
        u += dot(mf, cross(s.dv, nd)) / det;
        v += dot(s.du, cross(mf, nd)) / det;
        t += dot(s.du, cross(s.dv, mf)) / det;
        if !(0.0..=1.0).contains(&u) || !(0.0..=1.0).contains(&v) {
            return None;
        }
    }
    None
}

fn rays_per_shape() -> usize {
    std::env::var("LIMITRAY_EXACT_RAYS")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(3000)
}

#[derive(Debug, Default)]
struct Stats {
    rays: usize,
    hits: usize,
    grazing: usize,
    worst_off: f64,
    worst_err: f64,
}

/// Half the rays aimed from outside-ish at random limit points (`t = 1` there), half through
/// the bounding box between random points.
fn rays(table: &PatchTable, mesh: &ControlMesh, n: usize, seed: u64) -> Vec<(Ray64, bool)> {
    let diag = mesh.diagonal();
    let [lo, hi] = mesh.bounds();
    let mut rng = SplitMix64::new(seed);
    let mut out = Vec::with_capacity(n);
    let mut tries = 0;
    while out.len() < n && tries < 20 * n {
        tries += 1;
        if out.len() % 2 == 0 {
            let f = rng.below(mesh.num_faces()) as u32;
            let k = rng.below(table.sub_faces(f as usize).max(1)) as u32;
            let Ok(s) = table.eval(FaceCoord::new(f, k, rng.next_f64(), rng.next_f64())) else {
                continue;
            };
            let dir: [f64; 3] = std::array::from_fn(|_| 2.0 * rng.next_f64() - 1.0);
            let o: [f64; 3] = std::array::from_fn(|c| s.p[c] + 0.8 * diag * dir[c]);
            let d: [f64; 3] = std::array::from_fn(|c| s.p[c] - o[c]);
            if d == [0.0; 3] {
                continue;
            }
            out.push((Ray64::new(o, d), true));
        } else {
            let pick = |rng: &mut SplitMix64, grow: f64| -> [f64; 3] {
                std::array::from_fn(|c| {
                    let m = 0.5 * (lo[c] + hi[c]);
                    m + (rng.next_f64() - 0.5) * ((hi[c] - lo[c]) + grow * diag)
                })
            };
            let o = pick(&mut rng, 2.0);
            let t = pick(&mut rng, 0.0);
            let d: [f64; 3] = std::array::from_fn(|c| t[c] - o[c]);
            if d == [0.0; 3] {
                continue;
            }
            out.push((Ray64::new(o, d), false));
        }
    }
    out
}

fn check(name: &str, mesh: &ControlMesh, n: usize, seed: u64) -> Stats {
    let table = Arc::new(PatchTable::new(mesh, PatchOptions::default()).unwrap());
    let triangles = table.loop_surface().is_some();
    let tracer = ExactTracer::new(table.clone(), mesh).unwrap();
    let diag = tracer.diagonal();
    let diced = dice(
        &table,
        mesh,
        &DiceOptions {
            rate: DiceRate::Uniform(16),
            max_rate: 256,
            displace: None,
        },
    )
    .unwrap();
    let bvh = MeshBvh::build(diced);
    let rays = rays(&table, mesh, n, seed);
    let rows: Vec<(bool, bool, f64, f64)> = rays
        .par_iter()
        .map(|(ray, aimed)| {
            let x = tracer.trace(ray);
            let len = limitray::vec3::norm(ray.dir);
            let Some(h) = x.hit else {
                // A certain miss of a ray aimed at a surface point is a bug.
                assert!(
                    !aimed || x.graze.is_some(),
                    "{name}: aimed ray {ray:?} missed"
                );
                return (false, x.graze.is_some(), 0.0, 0.0);
            };
            let at = FaceCoord::new(h.face, h.k, h.u, h.v);
            let s = if triangles {
                table.eval_triangle(at)
            } else {
                table.eval(at)
            }
            .unwrap_or_else(|e| panic!("{name}: hit off the domain {h:?}: {e}"));
            let q: [f64; 3] = std::array::from_fn(|c| ray.origin[c] + h.t * ray.dir[c]);
            let off = common::dist(&q, &s.p) / diag;
            assert!(
                off <= ON_SURFACE,
                "{name}: {off:e} off the surface: {ray:?} {h:?}"
            );
            if !h.grazing {
                assert!(
                    h.err <= ON_SURFACE,
                    "{name}: err {:e}: {ray:?} {h:?}",
                    h.err
                );
                assert!(off <= h.err, "{name}: off {off:e} > err {:e}", h.err);
                if *aimed {
                    // At the aimed point itself t = 1 only to rounding / sin θ on shallow
                    // rays (1e-12 seen); a different crossing beyond it would be farther.
                    assert!(
                        (h.t - 1.0) * len / diag <= 1e-9,
                        "{name}: hit beyond the aimed point {h:?}"
                    );
                }
                // Newton from the diced hit finds no crossing in front of it.
                if let Some(d) = bvh.intersect(&Ray::new(
                    ray.origin.map(|x| x as f32),
                    ray.dir.map(|x| x as f32),
                )) {
                    let at = FaceCoord::new(d.face, d.k, d.u as f64, d.v as f64);
                    if let Some(t) = newton_from(&table, ray, at, d.t as f64, diag) {
                        // Another crossing in front, not the same one reached less precisely
                        // (on shallow rays a residual of 1e-13 moves t by 1e-13 / sin θ).
                        let ahead = (h.t - t) * len / diag;
                        assert!(
                            t < 0.0 || ahead <= 1e-9,
                            "{name}: a crossing {ahead:e} of the diagonal in front: {ray:?} {h:?}"
                        );
                    }
                }
            }
            (true, h.grazing, off, h.err)
        })
        .collect();
    let mut st = Stats {
        rays: rows.len(),
        ..Stats::default()
    };
    for (hit, graze, off, err) in rows {
        st.hits += hit as usize;
        st.grazing += graze as usize;
        st.worst_off = st.worst_off.max(off);
        if !graze {
            st.worst_err = st.worst_err.max(err);
        }
    }
    st
}

#[test]
fn corpus_closed_shapes() {
    let Some(models) = common::shared_models() else {
        return;
    };
    let n = rays_per_shape();
    let mut total = Stats::default();
    let mut shapes = 0;
    for path in common::catmark_files(&models) {
        let mesh = read_obj(&path).unwrap();
        if !common::closed(&mesh) {
            continue;
        }
        let name = path.file_stem().unwrap().to_string_lossy().to_string();
        let st = check(&name, &mesh, n, 17);
        eprintln!("{name}: {st:?}");
        // Grazing answers are for rays within rounding of tangency: a handful at most.
        assert!(st.grazing * 1000 <= st.rays.max(1000), "{name}: {st:?}");
        assert!(st.hits * 4 >= st.rays, "{name}: {st:?}");
        shapes += 1;
        total.rays += st.rays;
        total.hits += st.hits;
        total.grazing += st.grazing;
        total.worst_off = total.worst_off.max(st.worst_off);
        total.worst_err = total.worst_err.max(st.worst_err);
    }
    eprintln!("{shapes} closed corpus shapes: {total:?}");
    assert!(shapes >= 25, "{shapes} closed shapes");
}

fn add(total: &mut Stats, st: &Stats) {
    total.rays += st.rays;
    total.hits += st.hits;
    total.grazing += st.grazing;
    total.worst_off = total.worst_off.max(st.worst_off);
    total.worst_err = total.worst_err.max(st.worst_err);
}

/// The closed Loop corpus shapes (valence 3 to 360, creases, Chaikin, semi-sharp).
#[test]
fn corpus_closed_loop_shapes() {
    let Some(models) = common::shared_models() else {
        return;
    };
    let n = rays_per_shape();
    let mut total = Stats::default();
    let mut shapes = 0;
    for path in common::corpus_files(&models, "loop_") {
        let mut mesh = read_obj(&path).unwrap();
        mesh.options.scheme = limitray::mesh::Scheme::Loop;
        if !common::closed(&mesh) {
            continue;
        }
        let name = path.file_stem().unwrap().to_string_lossy().to_string();
        let st = check(&name, &mesh, n, 23);
        eprintln!("{name}: {st:?}");
        assert!(st.grazing * 1000 <= st.rays.max(1000), "{name}: {st:?}");
        assert!(st.hits * 4 >= st.rays, "{name}: {st:?}");
        shapes += 1;
        add(&mut total, &st);
    }
    eprintln!("{shapes} closed Loop corpus shapes: {total:?}");
    assert!(shapes >= 10, "{shapes} closed Loop shapes");
}

/// Random Loop meshes: creases (uniform and Chaikin), corners, boundaries, holes,
/// non-manifold vertices.
#[test]
fn random_loop_meshes() {
    let features = Features {
        smooth_triangles: false,
        skip_chaikin_boundary_none: false,
        nonmanifold: true,
    };
    let per = (rays_per_shape() / 6).max(50);
    let (mut total, mut degenerate) = (Stats::default(), Stats::default());
    for seed in 0..100u64 {
        let g = oracle::gen::generate_loop(seed, features);
        let mut mesh = parse_obj(&g.to_obj(), Some("generated")).unwrap();
        mesh.options.scheme = limitray::mesh::Scheme::Loop;
        if (0..mesh.num_faces()).all(|f| mesh.holes.contains(&(f as u32))) {
            continue;
        }
        let st = check(
            &format!("loop seed {seed} ({})", g.recipe),
            &mesh,
            per,
            seed,
        );
        if g.recipe.contains("degenerate") {
            // A triangle with a repeated vertex (`a b c c` split for Loop) has a zero-length
            // edge: the surface folds flat there, and rays through the fold graze it (seen:
            // up to 26 of 500 rays on such meshes, none elsewhere). Every hit is still
            // checked above; only the share of grazing answers is allowed to be larger.
            assert!(st.grazing * 10 <= st.rays, "loop seed {seed}: {st:?}");
            add(&mut degenerate, &st);
        } else {
            add(&mut total, &st);
        }
    }
    eprintln!("random Loop meshes: {total:?}; with a degenerate triangle: {degenerate:?}");
    assert!(total.grazing * 1000 <= total.rays, "{total:?}");
}

#[test]
fn random_creased_meshes() {
    let features = Features {
        smooth_triangles: true,
        skip_chaikin_boundary_none: false,
        nonmanifold: true,
    };
    let per = (rays_per_shape() / 6).max(50);
    let mut total = Stats::default();
    for seed in 0..150u64 {
        let g = generate(seed, features);
        let mesh = parse_obj(&g.to_obj(), Some("generated")).unwrap();
        let st = check(&format!("seed {seed} ({})", g.recipe), &mesh, per, seed);
        total.rays += st.rays;
        total.hits += st.hits;
        total.grazing += st.grazing;
        total.worst_off = total.worst_off.max(st.worst_off);
        total.worst_err = total.worst_err.max(st.worst_err);
    }
    eprintln!("150 random meshes: {total:?}");
    assert!(total.grazing * 1000 <= total.rays, "{total:?}");
}
