//! Exactness of limit-surface evaluation: at every (face, k, u, v) where a vertex of a uniform
//! refinement lies, `PatchTable::eval` equals that vertex's exact limit position
//! (`refine::limit`, derived independently from the subdivision rules by eigen-analysis).

mod common;

use limitray::mesh::obj::read_obj;
use limitray::mesh::ControlMesh;
use limitray::patch::{PatchOptions, PatchTable};
use limitray::refine::limit::LimitStencils;
use limitray::refine::Refiner;
use limitray::FaceCoord;

/// (vertex at `level`, base face, sub-face, u, v) for every corner of every level-`level`
/// descendant of every base face.
pub fn dyadic_samples(r: &Refiner, level: usize) -> Vec<(u32, usize, usize, f64, f64)> {
    const CORNER: [[f64; 2]; 4] = [[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]];
    const UAX: [[f64; 2]; 4] = [[1.0, 0.0], [0.0, 1.0], [-1.0, 0.0], [0.0, -1.0]];
    const VAX: [[f64; 2]; 4] = [[0.0, 1.0], [-1.0, 0.0], [0.0, -1.0], [1.0, 0.0]];
    let mut out = Vec::new();
    // stack of (level, face, o, a, b)
    for f in 0..r.levels[0].num_faces() {
        let n = r.levels[0].topo.face_size(f);
        let mut stack = Vec::new();
        if n == 4 {
            stack.push((0usize, f, 0usize, [0.0, 0.0], [1.0, 0.0], [0.0, 1.0]));
        } else {
            for k in 0..n {
                let c = r.levels[0].topo.face_offsets[f] as usize + k;
                stack.push((1usize, c, k, [0.0, 0.0], [1.0, 0.0], [0.0, 1.0]));
            }
        }
        while let Some((l, g, k, o, a, b)) = stack.pop() {
            if l == level {
                for (j, c) in CORNER.iter().enumerate() {
                    let v = r.levels[l].topo.face_vertices(g)[j];
                    let u = o[0] + a[0] * c[0] + b[0] * c[1];
                    let w = o[1] + a[1] * c[0] + b[1] * c[1];
                    out.push((v, f, k, u, w));
                }
                continue;
            }
            for q in 0..4 {
                let map = |p: [f64; 2]| [a[0] * p[0] + b[0] * p[1], a[1] * p[0] + b[1] * p[1]];
                let c = map(CORNER[q]);
                let ua = map(UAX[q]);
                let va = map(VAX[q]);
                let child = r.levels[l].topo.face_offsets[g] as usize + q;
                stack.push((
                    l + 1,
                    child,
                    k,
                    [o[0] + c[0], o[1] + c[1]],
                    [ua[0] / 2.0, ua[1] / 2.0],
                    [va[0] / 2.0, va[1] / 2.0],
                ));
            }
        }
    }
    out
}

/// Largest distance (relative to the diagonal) between eval and the exact limit position at
/// the dyadic points of `level`.
fn max_error(mesh: &ControlMesh, level: usize, opts: PatchOptions) -> f64 {
    let table = PatchTable::new(mesh, opts).unwrap();
    let r = Refiner::new(mesh, level).unwrap();
    let pos = r.refine_positions(&mesh.positions, level);
    let limit = LimitStencils::new(&r.levels[level], mesh.options.crease_method)
        .position
        .apply_points(&pos);
    let diag = mesh.diagonal();
    let mut worst = 0.0f64;
    let lvl = &r.levels[level];
    for (v, f, k, u, w) in dyadic_samples(&r, level) {
        if r.levels[0].face_hole[f] {
            continue;
        }
        let s = match table.eval(FaceCoord::new(f as u32, k as u32, u, w)) {
            Ok(s) => s,
            // A point on the closure of a hole made by a hierarchical edit.
            Err(_)
                if lvl
                    .topo
                    .vertex_faces(v as usize)
                    .iter()
                    .any(|&g| lvl.face_hole[g as usize]) =>
            {
                continue
            }
            Err(e) => panic!("({f}, {k}, {u}, {w}): {e}"),
        };
        let d = common::dist(&s.p, &limit[v as usize]) / diag;
        worst = worst.max(d);
    }
    worst
}

#[test]
fn eval_equals_exact_limit_at_dyadic_points_on_corpus() {
    let Some(models) = common::shared_models() else {
        return;
    };
    let files = common::catmark_files(&models);
    let mut failures = Vec::new();
    let mut n = 0;
    for p in &files {
        let name = p.file_stem().unwrap().to_str().unwrap();
        let Ok(mesh) = read_obj(p) else { continue };
        // Below the deepest hierarchical edit (catmark_square_hedit*), whose effect on the
        // limit a coarser level's limit masks cannot see.
        let deepest = mesh.edits.iter().map(|e| e.level() + 1).max().unwrap_or(0);
        let level = if mesh.num_faces() > 1000 { 1 } else { 2 }.max(deepest);
        let e = max_error(&mesh, level, PatchOptions::default());
        println!("{name}: level {level} max error {e:.2e}");
        // 1e-6 of the diagonal is the bound; both sides are exact, so the measured
        // differences are rounding (≤ 1e-12).
        if e > 1e-6 {
            failures.push(format!("{name}: {e:e}"));
        }
        n += 1;
    }
    assert!(n >= 83);
    assert!(failures.is_empty(), "{failures:?}");
}

#[test]
fn derivatives_match_central_differences() {
    let Some(models) = common::shared_models() else {
        return;
    };
    // Shapes with extraordinary vertices, n-gons, semi-sharp creases, corners and boundaries.
    let names = [
        "catmark_car",
        "catmark_cube_creases1",
        "catmark_nonquads",
        "catmark_pyramid_creases1",
        "catmark_tent_creases1",
        "catmark_xord_interior",
        "catmark_single_crease",
        "catmark_chaikin0",
        "catmark_dart_edgeonly",
    ];
    let mut state = 0x9e3779b97f4a7c15u64;
    let mut rnd = move || {
        state = state.wrapping_add(0x9e3779b97f4a7c15);
        let mut z = state;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58476d1ce4e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d049bb133111eb);
        ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
    };
    for name in names {
        let mesh = read_obj(&models.join(format!("opensubdiv/{name}.obj"))).unwrap();
        let table = PatchTable::new(&mesh, PatchOptions::default()).unwrap();
        let diag = mesh.diagonal();
        let h = 1e-6;
        let mut worst = 0.0f64;
        for _ in 0..300 {
            let f = (rnd() * table.num_faces() as f64) as usize;
            let k = (rnd() * table.sub_faces(f) as f64) as usize;
            // away from the (sub-)face border, where infinitely sharp creases and
            // extraordinary vertices live
            let u = 0.05 + 0.9 * rnd();
            let v = 0.05 + 0.9 * rnd();
            let Ok(s) = table.eval(FaceCoord::new(f as u32, k as u32, u, v)) else {
                continue;
            };
            let e = |a: f64, b: f64| {
                table
                    .eval(FaceCoord::new(f as u32, k as u32, a, b))
                    .unwrap()
                    .p
            };
            let (pu, mu, pv, mv) = (e(u + h, v), e(u - h, v), e(u, v + h), e(u, v - h));
            for c in 0..3 {
                let fu = (pu[c] - mu[c]) / (2.0 * h);
                let fv = (pv[c] - mv[c]) / (2.0 * h);
                let scale = diag.max(s.du[c].abs()).max(s.dv[c].abs());
                worst = worst.max((fu - s.du[c]).abs() / scale);
                worst = worst.max((fv - s.dv[c]).abs() / scale);
            }
        }
        println!("{name}: worst relative derivative error {worst:.2e}");
        // Central differences with h = 1e-6 carry ~1e-16/h ≈ 1e-10 rounding and h² ≈ 1e-12
        // truncation (measured ≤ 1.6e-10); 1e-7 is far inside the 1e-4 and still three
        // orders above the noise. A wrong derivative chain (rotation, scale) is off by O(1).
        assert!(worst < 1e-7, "{name}: {worst:e}");
    }
}

#[test]
fn repose_without_reanalysis() {
    let Some(models) = common::shared_models() else {
        return;
    };
    let mesh = read_obj(&models.join("opensubdiv/catmark_cube_creases1.obj")).unwrap();
    let mut table = PatchTable::new(&mesh, PatchOptions::default()).unwrap();
    // Scaling and translating the control points moves the limit surface the same way.
    let moved: Vec<[f64; 3]> = mesh
        .positions
        .iter()
        .map(|p| [2.0 * p[0] + 1.0, 2.0 * p[1], 2.0 * p[2] - 3.0])
        .collect();
    let before = table.eval(FaceCoord::quad(3, 0.3, 0.7)).unwrap().p;
    table.set_positions(&moved);
    let after = table.eval(FaceCoord::quad(3, 0.3, 0.7)).unwrap().p;
    let expect = [
        2.0 * before[0] + 1.0,
        2.0 * before[1],
        2.0 * before[2] - 3.0,
    ];
    assert!(common::dist(&after, &expect) < 1e-12);
}

#[test]
fn patches_tile_their_faces_and_know_their_domain() {
    let Some(models) = common::shared_models() else {
        return;
    };
    for name in [
        "catmark_car",
        "catmark_nonquads",
        "catmark_hole_test1",
        "catmark_pole8",
    ] {
        let mesh = read_obj(&models.join(format!("opensubdiv/{name}.obj"))).unwrap();
        let table = PatchTable::new(&mesh, PatchOptions::default()).unwrap();
        let mut area = std::collections::HashMap::new();
        for p in &table.patches {
            let h2 = p.axis_u[0] * p.axis_u[0] + p.axis_u[1] * p.axis_u[1];
            assert_eq!(h2, p.axis_v[0] * p.axis_v[0] + p.axis_v[1] * p.axis_v[1]);
            assert_eq!(
                h2,
                0.25f64.powi(
                    p.level as i32
                        - if table.sub_faces(p.face as usize) > 1 {
                            1
                        } else {
                            0
                        }
                )
            );
            *area.entry((p.face, p.sub_face)).or_insert(0.0) += h2;
            // the centre of the patch's domain evaluates to a point of that level
            let u = p.origin[0] + 0.5 * (p.axis_u[0] + p.axis_v[0]);
            let v = p.origin[1] + 0.5 * (p.axis_u[1] + p.axis_v[1]);
            let s = table
                .eval(FaceCoord::new(p.face, p.sub_face as u32, u, v))
                .unwrap();
            assert!(s.level >= p.level);
        }
        for ((f, _), a) in area {
            // holes have no patches; every other (sub-)face is covered exactly once
            assert!((a - 1.0f64).abs() < 1e-12, "{name}: face {f} covered {a}");
        }
    }
}

/// Largest distance (relative to the diagonal) between `eval` and the exact limit of the
/// uniform refinement to `level` with every edit applied, at the level's dyadic points, the
/// points on a hole's closure skipped; also the points compared and skipped.
fn edited_error(mesh: &ControlMesh, level: usize, name: &str) -> (f64, usize, usize) {
    let table = PatchTable::new(mesh, PatchOptions::default()).unwrap();
    let r = Refiner::new(mesh, level).unwrap();
    let pos = r.refine_positions(&mesh.positions, level);
    let lvl = &r.levels[level];
    let limit = LimitStencils::new(lvl, mesh.options.crease_method)
        .position
        .apply_points(&pos);
    let diag = mesh.diagonal();
    let (mut worst, mut n, mut skipped) = (0.0f64, 0, 0);
    for (v, f, k, u, w) in dyadic_samples(&r, level) {
        let faces = lvl.topo.vertex_faces(v as usize);
        if faces.iter().any(|&g| lvl.face_hole[g as usize]) {
            skipped += 1;
            continue;
        }
        let s = table
            .eval(FaceCoord::new(f as u32, k as u32, u, w))
            .unwrap_or_else(|e| panic!("{name}: ({f}, {k}, {u}, {w}): {e}"));
        worst = worst.max(common::dist(&s.p, &limit[v as usize]) / diag);
        n += 1;
    }
    (worst, n, skipped)
}

/// Hierarchical edits (catmark_square_hedit0–4: position edits at levels 1–3, vertex and edge
/// sharpness set at level 1, a hole at level 2) are honoured by evaluation: at every dyadic
/// point of level 4, below the deepest edit, `eval` equals the exact limit of the uniformly
/// refined, edited level (whose own edits apply: they act before further refinement). Points
/// on a hole's closure are skipped. Both sides are exact, so the differences are rounding:
/// measured ≤ 1e-15 of the diagonal, asserted ≤ 1e-12 (a few hundred ulps of the refinement's
/// rounding at level 4).
#[test]
fn eval_honours_hierarchical_edits() {
    let Some(models) = common::shared_models() else {
        return;
    };
    let level = 4;
    for i in 0..=4 {
        let name = format!("catmark_square_hedit{i}");
        let mesh = read_obj(&models.join("opensubdiv").join(format!("{name}.obj"))).unwrap();
        assert!(!mesh.edits.is_empty(), "{name}: no edits read");
        let (worst, n, skipped) = edited_error(&mesh, level, &name);
        println!("{name}: {n} points ({skipped} by holes), max error {worst:.2e}");
        assert!(worst <= 1e-12, "{name}: {worst:e}");
    }
}

/// Random hierarchical edits (positions added and set, vertex and edge sharpness added and
/// set, holes; paths of 1–3 sub-faces, from quads and n-gons, any corner or edge) on shapes
/// with creases, n-gons and extraordinary vertices: `eval` equals the exact limit of the
/// edited uniform refinement one level below the deepest edit, as above (1e-12 of the
/// diagonal; measured ≤ 1e-15). This exercises the path rotation on single corners and edges,
/// which the corpus's edits (all four corners or edges of a sub-face) cannot see.
#[test]
fn eval_honours_random_hierarchical_edits() {
    use limitray::mesh::{shapes, EditKind, EditOp, HierarchicalEdit};
    let mut state = 0x9e37_79b9_7f4a_7c15u64;
    let mut next = move || {
        state = state.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = state;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    };
    let bases = [
        ("rounded_box", shapes::rounded_box(2.0)),
        ("gear", shapes::gear(6)),
        ("star", limitray::mesh::generate::star(5, 2)),
        ("blob", shapes::blob()),
    ];
    let mut cases = 0;
    for round in 0..6 {
        for (name, base) in &bases {
            let mut mesh = base.clone();
            let diag = mesh.diagonal();
            for _ in 0..4 {
                let face = (next() % mesh.num_faces() as u64) as u32;
                let depth = 1 + (next() % 3) as usize;
                let mut size = mesh.face_size(face as usize) as u64;
                let mut path = Vec::new();
                for _ in 0..depth {
                    path.push((next() % size) as u32);
                    size = 4;
                }
                let x = (next() % 4) as u32;
                let op = [EditOp::Set, EditOp::Add][(next() % 2) as usize];
                let kind = match next() % 7 {
                    0 | 1 => EditKind::Position {
                        corner: x,
                        op: EditOp::Add,
                        value: [0, 1, 2]
                            .map(|_| ((next() % 1000) as f64 / 1000.0 - 0.5) * 0.2 * diag),
                    },
                    2 => EditKind::Position {
                        corner: x,
                        op: EditOp::Set,
                        value: mesh.positions[(next() % mesh.num_vertices() as u64) as usize],
                    },
                    3 => EditKind::VertexSharpness {
                        corner: x,
                        op,
                        value: (next() % 40) as f32 / 10.0,
                    },
                    4 | 5 => EditKind::EdgeSharpness {
                        edge: x,
                        op,
                        value: (next() % 40) as f32 / 10.0,
                    },
                    _ => EditKind::Hole,
                };
                mesh.edits.push(HierarchicalEdit { face, path, kind });
            }
            let level = 1 + mesh.edits.iter().map(|e| e.level()).max().unwrap();
            let (worst, _, _) = edited_error(&mesh, level, &format!("{name} round {round}"));
            println!("{name} round {round} (level {level}): max error {worst:.2e}");
            assert!(
                worst <= 1e-12,
                "{name} round {round}: {worst:e}; edits {:?}",
                mesh.edits
            );
            cases += 1;
        }
    }
    assert_eq!(cases, 24);
}
