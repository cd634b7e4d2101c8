//! Regular patches with one semi-sharp crease (paper 000) against the exact limit positions of
//! uniformly refined meshes, and the paper's matrices against their definitions.
#![allow(clippy::needless_range_loop)]

mod common;

use limitray::mesh::{generate, ControlMesh, CreaseMethod, MeshBuilder};
use limitray::patch::bspline::{self, ControlGrid, Mat4, PatchPoint, IDENTITY};
use limitray::patch::single_crease::{
    self, mat_mul, transform_grid, transition_matrix, transition_matrix_by_powers, CreaseCurve,
    SingleCreasePatch, M_INF, R_INV, R_P,
};
use limitray::refine::limit::LimitStencils;
use limitray::refine::Refiner;

/// Faces per side of the test grid.
const N: usize = 8;

/// Sharpness values checked against refinement (10 is infinitely sharp).
const SHARPNESS: [f32; 11] = [0.0, 0.3, 1.0, 1.7, 2.0, 3.5, 4.25, 6.0, 9.0, 9.6, 10.0];

fn vid(n: usize, i: usize, j: usize) -> u32 {
    (i * (n + 1) + j) as u32
}

/// A non-planar, sheared grid: every coordinate varies with both indices.
fn position(i: usize, j: usize) -> [f64; 3] {
    let (x, y) = (i as f64, j as f64);
    [
        x + 0.2 * (1.1 * y + 0.4 * x).sin(),
        y + 0.15 * (0.9 * x - 0.3 * y).cos() + 0.05 * x,
        0.8 * (0.7 * x).sin() * (0.5 * y).cos() + 0.03 * x * y,
    ]
}

/// The line of edges that carries the crease, across the whole grid.
#[derive(Clone, Copy, Debug)]
enum Line {
    /// Edges `(i, j)`–`(i + 1, j)` for all `i`.
    Row(usize),
    /// Edges `(i, j)`–`(i, j + 1)` for all `j`.
    Col(usize),
}

/// The `n` × `n` grid of [`position`] with a crease of sharpness `s` along `line`.
fn mesh(n: usize, line: Line, s: f32, positions: Vec<[f64; 3]>) -> ControlMesh {
    let g = generate::grid(n);
    let mut b = MeshBuilder::new()
        .positions(positions)
        .faces(&vec![4; n * n], &g.face_verts);
    if s > 0.0 {
        for k in 0..n {
            b = match line {
                Line::Row(j) => b.crease(vid(n, k, j), vid(n, k + 1, j), s),
                Line::Col(i) => b.crease(vid(n, i, k), vid(n, i, k + 1), s),
            };
        }
    }
    b.build().unwrap()
}

/// The 4 × 4 control grid of face `(i0, j0)`: `u` along `i`, `v` along `j`, `(0, 0)` at
/// vertex `(i0, j0)`.
fn control_grid(i0: usize, j0: usize) -> ControlGrid {
    let mut cp = [[0.0; 3]; 16];
    for b in 0..4 {
        for a in 0..4 {
            cp[4 * b + a] = position(i0 + a - 1, j0 + b - 1);
        }
    }
    cp
}

/// (crease line, face, expected crease edge of that face).
const CASES: [(Line, (usize, usize), usize); 4] = [
    (Line::Row(4), (2, 3), 2),
    (Line::Row(4), (5, 4), 0),
    (Line::Col(4), (3, 2), 1),
    (Line::Col(4), (4, 5), 3),
];

fn dist(a: &[f64; 3], b: &[f64; 3]) -> f64 {
    ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
}

fn norm(a: &[f64; 3]) -> f64 {
    dist(a, &[0.0; 3])
}

fn cross(a: &[f64; 3], b: &[f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

/// Compares the direct evaluation with the exact limit of every vertex of `levels` that lies in
/// the face `(i0, j0)` of the `n` × `n` grid; returns (max position error / `n`, max sine of
/// the angle between normals).
fn check_against_refinement(
    n: usize,
    line: Line,
    face: (usize, usize),
    edge: usize,
    s: f32,
    levels: &[usize],
) -> (f64, f64) {
    let (i0, j0) = face;
    let side = n + 1;
    let geometry: Vec<[f64; 3]> = (0..side * side)
        .map(|k| position(k / side, k % side))
        .collect();
    // The grid parameter as a primvar: every rule reproduces linear functions on a uniform
    // grid, so each refined vertex carries its own dyadic (i, j).
    let params: Vec<[f64; 3]> = (0..side * side)
        .map(|k| [(k / side) as f64, (k % side) as f64, 0.0])
        .collect();
    let m = mesh(n, line, s, geometry.clone());
    let r = Refiner::new(&m, *levels.iter().max().unwrap()).unwrap();
    let cp = control_grid(i0, j0);
    let sharp = s as f64;
    let patch = SingleCreasePatch::new(&cp, edge, sharp);
    let mut worst = 0.0f64;
    let mut worst_angle = 0.0f64;
    for &level in levels {
        let pos = r.refine_positions(&geometry, level);
        let par = r.refine_positions(&params, level);
        let frames = LimitStencils::new(&r.levels[level], CreaseMethod::Uniform).frames(&pos);
        let scale = (1u64 << level) as f64;
        let mut found = 0;
        for v in 0..pos.len() {
            let (x, y) = (par[v][0] * scale, par[v][1] * scale);
            let (xi, yi) = (x.round(), y.round());
            assert!((x - xi).abs() < 1e-9 && (y - yi).abs() < 1e-9);
            let (u, w) = (xi / scale - i0 as f64, yi / scale - j0 as f64);
            if !(0.0..=1.0).contains(&u) || !(0.0..=1.0).contains(&w) {
                continue;
            }
            found += 1;
            let direct = single_crease::eval(&cp, edge, sharp, u, w);
            let pre = patch.eval(u, w);
            assert!(dist(&direct.p, &pre.p) <= 1e-13 * n as f64);
            let e = dist(&direct.p, &frames[v].position) / n as f64;
            assert!(
                e <= 1e-12,
                "s = {s}, edge {edge}, level {level}, (u, v) = ({u}, {w}): error {e:e}"
            );
            worst = worst.max(e);
            // Normals (tangent magnitudes are conventions of the limit masks; planes are not).
            // An infinitely sharp crease has no tangent plane: the patch gives its own side.
            if sharp >= 10.0 && single_crease::crease_parameter(edge, u, w) == 1.0 {
                continue;
            }
            let n1 = cross(&direct.du, &direct.dv);
            let n2 = cross(&frames[v].du, &frames[v].dv);
            let sin = norm(&cross(&n1, &n2)) / (norm(&n1) * norm(&n2));
            worst_angle = worst_angle.max(sin);
        }
        let k = (1usize << level) + 1;
        assert_eq!(found, k * k, "level {level}: vertices found in the face");
    }
    (worst, worst_angle)
}

#[test]
fn matches_exact_limits_of_refinement() {
    for &s in &SHARPNESS {
        let mut worst = 0.0f64;
        let mut worst_angle = 0.0f64;
        for &(line, face, edge) in &CASES {
            let (e, a) = check_against_refinement(N, line, face, edge, s, &[0, 1, 2, 3, 4]);
            worst = worst.max(e);
            worst_angle = worst_angle.max(a);
        }
        println!(
            "s = {s:>4}: max position error {worst:.2e} of the grid size, \
             max normal sin {worst_angle:.2e}"
        );
        assert!(
            worst_angle <= 1e-9,
            "s = {s}: normals differ by sin {worst_angle:e}"
        );
    }
}

#[test]
fn deep_levels_sample_inside_the_transition_pieces() {
    // Level 7 puts vertices inside the last pieces (1 − 2^−k, 1] for k ≤ 6; a 3 × 3 grid is the
    // face's whole 4 × 4 neighbourhood, which is all its limit depends on.
    for &s in &[4.25f32, 5.5, 6.0] {
        let mut worst = 0.0f64;
        for (line, edge) in [(Line::Row(2), 2), (Line::Col(1), 3)] {
            let (e, a) = check_against_refinement(3, line, (1, 1), edge, s, &[7]);
            assert!(a <= 1e-9, "s = {s}: normals differ by sin {a:e}");
            worst = worst.max(e);
        }
        println!("s = {s:>4}: level 7, max position error {worst:.2e} of the grid size");
    }
}

fn test_grid() -> ControlGrid {
    control_grid(3, 3)
}

/// Parameters on a lattice plus a cluster next to the crease.
fn samples() -> Vec<f64> {
    let mut t: Vec<f64> = (0..=20).map(|k| 0.013 + 0.97 * k as f64 / 20.0).collect();
    for k in 1..=12 {
        let d = 0.5f64.powi(k);
        t.push(1.0 - 0.37 * d);
        t.push(1.0 - 0.81 * d);
    }
    t.push(1.0);
    t.push(0.0);
    t
}

fn rel(a: &[f64; 3], b: &[f64; 3]) -> f64 {
    dist(a, b) / norm(b).max(1.0)
}

#[test]
fn derivatives_match_central_differences() {
    let cp = test_grid();
    let h = 1e-6;
    for &s in &[0.0, 0.3, 1.0, 1.7, 2.0, 3.5, 6.0, 9.0, 9.6, 10.0] {
        let curve = CreaseCurve::new(s);
        let breaks: Vec<f64> = curve.segments().iter().map(|g| g.end).collect();
        let mut worst1 = 0.0f64;
        let mut worst2 = 0.0f64;
        for edge in 0..4 {
            let f = |u: f64, v: f64| single_crease::eval(&cp, edge, s, u, v);
            for &a in &samples() {
                for &b in &samples() {
                    let t = single_crease::crease_parameter(edge, a, b);
                    if breaks.iter().any(|&x| (t - x).abs() < 1e-5 && x < 1.0) {
                        continue;
                    }
                    let p = f(a, b);
                    let (up, um, vp, vm) = (f(a + h, b), f(a - h, b), f(a, b + h), f(a, b - h));
                    let fd = |p: &PatchPoint, m: &PatchPoint, g: fn(&PatchPoint) -> [f64; 3]| {
                        let (x, y) = (g(p), g(m));
                        [
                            (x[0] - y[0]) / (2.0 * h),
                            (x[1] - y[1]) / (2.0 * h),
                            (x[2] - y[2]) / (2.0 * h),
                        ]
                    };
                    worst1 = worst1.max(rel(&fd(&up, &um, |q| q.p), &p.du));
                    worst1 = worst1.max(rel(&fd(&vp, &vm, |q| q.p), &p.dv));
                    worst2 = worst2.max(rel(&fd(&up, &um, |q| q.du), &p.duu));
                    worst2 = worst2.max(rel(&fd(&vp, &vm, |q| q.dv), &p.dvv));
                    worst2 = worst2.max(rel(&fd(&vp, &vm, |q| q.du), &p.duv));
                    worst2 = worst2.max(rel(&fd(&up, &um, |q| q.dv), &p.duv));
                }
            }
        }
        println!("s = {s:>4}: first derivatives {worst1:.1e}, second {worst2:.1e} (relative)");
        assert!(
            worst1 <= 1e-4,
            "s = {s}: first derivatives off by {worst1:e}"
        );
        assert!(
            worst2 <= 1e-4,
            "s = {s}: second derivatives off by {worst2:e}"
        );
    }
}

#[test]
fn pieces_join_with_continuous_second_derivatives() {
    // For finite sharpness every rule is smooth from level ⌈s⌉ on, so the limit is a uniform
    // B-spline of that level: C² across the breakpoints 1 − 2^−k.
    let cp = test_grid();
    let p = [cp[1], cp[5], cp[9], cp[13]];
    for &s in &[0.3, 1.0, 1.7, 2.0, 3.5, 6.0, 9.0, 9.6] {
        let curve = CreaseCurve::new(s);
        let segs = curve.segments();
        for k in 0..segs.len() - 1 {
            let t = segs[k].end;
            let side = |m: &Mat4| {
                let b = bspline::Basis::at(t).transformed(m);
                let mut out = [[0.0; 3]; 3];
                for i in 0..4 {
                    for c in 0..3 {
                        out[0][c] += b.w[i] * p[i][c];
                        out[1][c] += b.d1[i] * p[i][c];
                        out[2][c] += b.d2[i] * p[i][c];
                    }
                }
                out
            };
            let (l, r) = (side(&segs[k].matrix), side(&segs[k + 1].matrix));
            for d in 0..3 {
                let e = dist(&l[d], &r[d]) / norm(&r[d]).max(1.0);
                assert!(e < 1e-11, "s = {s}, t = {t}, derivative {d}: jump {e:e}");
            }
        }
    }
}

#[test]
fn zero_sharpness_is_the_plain_patch() {
    let cp = test_grid();
    for edge in 0..4 {
        let patch = SingleCreasePatch::new(&cp, edge, 0.0);
        for &u in &samples() {
            for &v in &samples() {
                let plain = bspline::eval(&cp, u, v);
                assert_eq!(single_crease::eval(&cp, edge, 0.0, u, v), plain);
                assert_eq!(patch.eval(u, v), plain);
            }
        }
    }
}

#[test]
fn sharpness_ten_and_above_is_infinitely_sharp() {
    let cp = test_grid();
    for edge in 0..4 {
        let sharp = transform_grid(&cp, edge, &M_INF);
        for &s in &[10.0, 12.5, 1e9, f64::INFINITY] {
            let patch = SingleCreasePatch::new(&cp, edge, s);
            assert_eq!(patch.curve().segments().len(), 1);
            for &u in &samples() {
                for &v in &samples() {
                    let a = bspline::eval(&sharp, u, v);
                    assert_eq!(patch.eval(u, v), a);
                    let b = single_crease::eval(&cp, edge, s, u, v);
                    for (x, y) in [(a.p, b.p), (a.du, b.du), (a.dv, b.dv)] {
                        assert!(dist(&x, &y) <= 1e-13 * N as f64);
                    }
                }
            }
        }
        // The crease passes through the crease row/column of the control grid at the edge.
        let on_edge = match edge {
            0 => (0.5, 0.0, [5, 6]),
            1 => (1.0, 0.5, [6, 10]),
            2 => (0.5, 1.0, [9, 10]),
            _ => (0.0, 0.5, [5, 9]),
        };
        let (u, v, [a, b]) = on_edge;
        let p = single_crease::eval(&cp, edge, 10.0, u, v).p;
        // Midpoint of the crease edge: the cubic B-spline of the crease polyline at t = 1/2.
        let line: Vec<[f64; 3]> = match edge {
            0 | 2 => (0..4).map(|i| cp[4 * (a / 4) + i]).collect(),
            _ => (0..4).map(|j| cp[4 * j + (a % 4)]).collect(),
        };
        let w = bspline::basis(0.5);
        let mut q = [0.0; 3];
        for k in 0..4 {
            for c in 0..3 {
                q[c] += w[k] * line[k][c];
            }
        }
        assert!(dist(&p, &q) < 1e-14 * N as f64, "edge {edge} ({a}, {b})");
    }
}

/// The paper's closed form as printed (σ = 2^s, with the factor (1 − σ)/6σ outside).
fn paper_closed_form(s: u32) -> Mat4 {
    let g = 2f64.powi(s as i32);
    let k = (1.0 - g) / (6.0 * g);
    let m = [
        [
            6.0 * g / (1.0 - g),
            6.0 * g * g - 5.0 * g + 1.0,
            -12.0 * g * g + 10.0 * g - 2.0,
            6.0 * g * g - 5.0 * g + 1.0,
        ],
        [
            0.0,
            (2.0 * g * g + 3.0 * g + 1.0) / (1.0 - g),
            4.0 * g - 2.0,
            1.0 - 2.0 * g,
        ],
        [
            0.0,
            g + 1.0,
            (2.0 * g * g + 6.0 * g - 2.0) / (1.0 - g),
            g + 1.0,
        ],
        [
            0.0,
            1.0 - 2.0 * g,
            4.0 * g - 2.0,
            (2.0 * g * g + 3.0 * g + 1.0) / (1.0 - g),
        ],
    ];
    m.map(|row| row.map(|x| k * x))
}

fn mat_pow(m: &Mat4, n: u32) -> Mat4 {
    (0..n).fold(IDENTITY, |acc, _| mat_mul(&acc, m))
}

fn max_rel_diff(a: &Mat4, b: &Mat4) -> f64 {
    let mut worst = 0.0f64;
    for r in 0..4 {
        for c in 0..4 {
            worst = worst.max((a[r][c] - b[r][c]).abs() / b[r][c].abs().max(1.0));
        }
    }
    worst
}

#[test]
fn paper_closed_form_equals_powers() {
    for s in 1..=8 {
        // (R⁻¹)^s R_p^s literally, the recursion R⁻¹ M R_p, the paper's printed closed form and
        // the exact closed form used by the crate.
        let literal = mat_mul(&mat_pow(&R_INV, s), &mat_pow(&R_P, s));
        let exact = transition_matrix(s);
        assert_eq!(transition_matrix_by_powers(s), exact, "s = {s}");
        let d_lit = max_rel_diff(&literal, &exact);
        let d_paper = max_rel_diff(&paper_closed_form(s), &exact);
        println!("s = {s}: literal powers {d_lit:.1e}, paper's closed form {d_paper:.1e}");
        assert!(d_lit < 1e-12 && d_paper < 1e-13, "s = {s}");
    }
}

#[test]
fn transition_piece_is_the_sharply_refined_curve() {
    // Independent of R⁻¹: on [1 − 2^−s, 1] the curve is the B-spline of R_p^s P in the local
    // parameter τ = 2^s (t − 1) + 1.
    let cp = test_grid();
    let p = [cp[2], cp[6], cp[10], cp[14]];
    for s in 1..=9u32 {
        let q = mat_pow(&R_P, s);
        let curve = CreaseCurve::new(s as f64);
        let scale = 2f64.powi(s as i32);
        for k in 0..=16 {
            let tau = k as f64 / 16.0;
            let t = 1.0 + (tau - 1.0) / scale;
            let direct = curve.eval(&p, t);
            let b = bspline::Basis::at(tau).transformed(&q);
            let mut local = [0.0; 3];
            let mut local_d = [0.0; 3];
            for i in 0..4 {
                for c in 0..3 {
                    local[c] += b.w[i] * p[i][c];
                    local_d[c] += b.d1[i] * p[i][c] * scale;
                }
            }
            assert!(
                dist(&direct[0], &local) < 1e-12 * N as f64,
                "s = {s}, τ = {tau}"
            );
            assert!(rel(&direct[1], &local_d) < 1e-10, "s = {s}, τ = {tau}");
        }
    }
}

/// Under Chaikin's crease rule, single-crease patches (made only where the crease continues
/// with the same sharpness at both ends, where Chaikin's decrement is the uniform one) give the
/// surface that isolating the creases by Chaikin refinement gives (that path is checked
/// against OpenSubdiv Far in `tests/osd_oracle.rs`). Corpus shapes with constant and varying
/// sharpness along their creases; positions agree within 1e-12 of the bounding-box diagonal
/// (both are exact: B-spline and single-crease weights over the same control points, rounding
/// ~1e-16 per level over at most 10 levels).
#[test]
fn chaikin_single_crease_patches_equal_isolation_by_subdivision() {
    use limitray::coord::FaceCoord;
    use limitray::mesh::obj::read_obj;
    use limitray::patch::table::PatchKind;
    use limitray::patch::{PatchOptions, PatchTable};
    let Some(models) = common::shared_models() else {
        eprintln!("skipped: ../shared/models is absent");
        return;
    };
    let mut single_crease_patches = 0;
    for name in [
        "catmark_car",
        "catmark_chaikin0",
        "catmark_chaikin1",
        "catmark_chaikin2",
        "catmark_cube_creases1",
        "catmark_torus_creases1",
        "catmark_pyramid_creases1",
    ] {
        let mesh = read_obj(&models.join(format!("opensubdiv/{name}.obj"))).unwrap();
        let options = limitray::mesh::Options {
            crease_method: CreaseMethod::Chaikin,
            ..mesh.options
        };
        let table = |single_crease| {
            let opts = PatchOptions {
                single_crease,
                ..PatchOptions::default()
            };
            PatchTable::with_options(&mesh, options, opts).unwrap()
        };
        let (fast, refined) = (table(true), table(false));
        let count = fast
            .patches
            .iter()
            .filter(|p| matches!(p.kind, PatchKind::SingleCrease { .. }))
            .count();
        single_crease_patches += count;
        let diag = mesh.diagonal();
        let mut rng = limitray::harness::rng::SplitMix64::new(17);
        let mut worst = 0f64;
        for _ in 0..3000 {
            let f = rng.below(fast.num_faces());
            let k = rng.below(fast.sub_faces(f));
            let at = FaceCoord::new(f as u32, k as u32, rng.next_f64(), rng.next_f64());
            let (Ok(a), Ok(b)) = (fast.eval(at), refined.eval(at)) else {
                assert!(
                    fast.eval(at).is_err() && refined.eval(at).is_err(),
                    "{at:?}"
                );
                continue;
            };
            worst = worst.max(dist(&a.p, &b.p) / diag);
        }
        println!(
            "{name}: {count} single-crease patches, {} against {} leaves, worst {worst:.2e}",
            fast.patches.len(),
            refined.patches.len()
        );
        assert!(
            worst <= 1e-12,
            "{name}: positions differ by {worst:e} of the diagonal"
        );
    }
    assert!(single_crease_patches > 0, "no single-crease patch was made");
}
