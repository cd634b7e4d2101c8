//! Limit masks: closed-form cases, consistency across levels, and convergence of refinement.
#![allow(clippy::needless_range_loop)]

mod common;

use limitray::mesh::obj::read_obj;
use limitray::mesh::{ControlMesh, CreaseMethod, MeshBuilder};
use limitray::refine::limit::{limit_positions, LimitStencils};
use limitray::refine::Refiner;

fn check_consistency(mesh: &ControlMesh, name: &str, tol_rel: f64) -> f64 {
    // The limit point of a vertex at level L equals the limit point of its child at L+1.
    // Hierarchical edits change the surface below their level, which the limit masks of a
    // coarser level cannot know: they are left out here (tests/eval.rs checks them).
    let mut mesh = mesh.clone();
    mesh.edits.clear();
    let mesh = &mesh;
    let r = Refiner::new(mesh, 2).unwrap();
    let m = mesh.options.crease_method;
    let p0 = mesh.positions.clone();
    let p1 = r.refine_positions(&p0, 1);
    let p2 = r.refine_positions(&p0, 2);
    let l0 = limit_positions(&r.levels[0], &p0, m);
    let l1 = limit_positions(&r.levels[1], &p1, m);
    let l2 = limit_positions(&r.levels[2], &p2, m);
    let diag = mesh.diagonal();
    let mut worst = 0.0f64;
    for v in 0..p0.len() {
        worst = worst.max(common::dist(&l0[v], &l1[v]) / diag);
    }
    for v in 0..p1.len() {
        worst = worst.max(common::dist(&l1[v], &l2[v]) / diag);
    }
    assert!(
        worst <= tol_rel,
        "{name}: limit changes between levels by {worst:e} of the diagonal"
    );
    worst
}

#[test]
fn limit_is_invariant_under_refinement_on_corpus() {
    let Some(models) = common::shared_models() else {
        return;
    };
    let mut n = 0;
    for p in common::catmark_files(&models) {
        let name = p.file_name().unwrap().to_str().unwrap().to_string();
        let Ok(mesh) = read_obj(&p) else { continue };
        if mesh.num_faces() > 2000 {
            continue;
        }
        // 1e-12 of the diagonal: both sides are exact; only rounding differs.
        let w = check_consistency(&mesh, &name, 1e-12);
        println!("{name}: {w:.1e}");
        n += 1;
    }
    assert!(n > 60);
}

fn cube(sharp: Option<f32>) -> ControlMesh {
    let mut b = common::cube_builder();
    if let Some(s) = sharp {
        for (a, c) in common::CUBE_EDGES {
            b = b.crease(a, c, s);
        }
    }
    b.build().unwrap()
}

#[test]
fn smooth_limit_matches_deep_refinement() {
    // Vertex positions converge to the limit like (1/4)^k for a valence-3 vertex's
    // sub-dominant modes... after 8 levels the refined vertex is within ~1e-5 of its limit.
    let mesh = cube(None);
    let r = Refiner::new(&mesh, 8).unwrap();
    let l0 = limit_positions(&r.levels[0], &mesh.positions, CreaseMethod::Uniform);
    let p8 = r.refine_positions(&mesh.positions, 8);
    for v in 0..8 {
        let d = common::dist(&l0[v], &p8[v]);
        assert!(d < 1e-4, "vertex {v}: {d}");
    }
    // The cube corner of a unit cube (side 2) has limit radius known in closed form:
    // valence 3: (n^2 V + 4 ΣE + ΣF)/(n(n+5)) = (9V + 4·(3 edges) + 3 diagonals)/24.
    let v = mesh.positions[3];
    let e = [mesh.positions[1], mesh.positions[2], mesh.positions[5]];
    let f = [mesh.positions[0], mesh.positions[4], mesh.positions[7]];
    for k in 0..3 {
        let expect =
            (9.0 * v[k] + 4.0 * (e[0][k] + e[1][k] + e[2][k]) + (f[0][k] + f[1][k] + f[2][k]))
                / 24.0;
        assert!((l0[3][k] - expect).abs() < 1e-14);
    }
}

#[test]
fn infinitely_sharp_cube_limit_is_the_cube() {
    let mesh = cube(Some(10.0));
    let l = limit_positions(
        &Refiner::new(&mesh, 0).unwrap().levels[0],
        &mesh.positions,
        CreaseMethod::Uniform,
    );
    for v in 0..8 {
        assert_eq!(l[v], mesh.positions[v]);
    }
}

#[test]
fn semi_sharp_limit_matches_deep_refinement() {
    for s in [0.5f32, 1.0, 2.5, 3.0] {
        let mesh = cube(Some(s));
        // After the sharpness has run out, a vertex approaches its limit by a factor ~1/4
        // per level (its component on the sub-dominant modes vanishes by symmetry): after 7
        // levels the refined corner is within a few 1e-5 of the limit (measured ≤ 5.6e-5 on
        // this side-2 cube); a wrong fractional blend or decrement moves the limit by > 1e-2.
        let r = Refiner::new(&mesh, 7).unwrap();
        let l0 = limit_positions(&r.levels[0], &mesh.positions, CreaseMethod::Uniform);
        let p = r.refine_positions(&mesh.positions, 7);
        let l7 = limit_positions(&r.levels[7], &p, CreaseMethod::Uniform);
        for v in 0..8 {
            let d = common::dist(&l0[v], &p[v]);
            println!("s={s} vertex {v}: {d:e}");
            assert!(d < 2e-4, "s={s} vertex {v}: {d}");
            assert!(common::dist(&l0[v], &l7[v]) < 1e-13);
        }
    }
}

#[test]
fn regular_tangents_are_parametric_derivatives() {
    // A flat regular grid z=0 with x = i, y = j: at interior vertices du = (1,0,0) and
    // dv = (0,1,0) in face-0 orientation (up to the ring's rotation), and |du| = 1.
    let n = 4u32;
    let mut pos = vec![];
    for i in 0..=n {
        for j in 0..=n {
            pos.push([i as f64, j as f64, 0.0]);
        }
    }
    let mut fv = vec![];
    for i in 0..n {
        for j in 0..n {
            let a = i * (n + 1) + j;
            fv.extend_from_slice(&[a, a + n + 1, a + n + 2, a + 1]);
        }
    }
    let mesh = MeshBuilder::new()
        .positions(pos)
        .faces(&vec![4; (n * n) as usize], &fv)
        .build()
        .unwrap();
    let r = Refiner::new(&mesh, 0).unwrap();
    let frames = LimitStencils::new(&r.levels[0], CreaseMethod::Uniform).frames(&mesh.positions);
    for (v, fr) in frames.iter().enumerate() {
        let len = |t: [f64; 3]| (t[0] * t[0] + t[1] * t[1] + t[2] * t[2]).sqrt();
        // every vertex of a planar grid: tangents in the plane, unit length (boundary and
        // corner included: the B-spline with end conditions is linear on a uniform grid)
        assert!(
            (len(fr.du) - 1.0).abs() < 1e-12,
            "vertex {v} du {:?}",
            fr.du
        );
        assert!(
            (len(fr.dv) - 1.0).abs() < 1e-12,
            "vertex {v} dv {:?}",
            fr.dv
        );
        assert!(fr.du[2].abs() < 1e-14 && fr.dv[2].abs() < 1e-14);
        let dot = fr.du[0] * fr.dv[0] + fr.du[1] * fr.dv[1];
        assert!(dot.abs() < 1e-12, "vertex {v}: tangents not perpendicular");
        // limit of a planar linear grid is the grid itself
        assert!(common::dist(&fr.position, &mesh.positions[v]) < 1e-12);
    }
}
