//! Paper 002's approximations of the Loop surface (PN, Walton–Meek, Gregory triangles):
//! continuity across edges measured on closed meshes with valences 3–12, planes reproduced
//! exactly, corners interpolating the exact limit, and the approximations close to the exact
//! surface.

mod common;

use limitray::mesh::{shapes, ControlMesh, MeshBuilder, Options, Scheme};
use limitray::patch::approx::{Approximation, TriApprox};
use limitray::patch::LoopSurface;
use limitray::vec3::{cross, dot, norm, normalize, sub};
use limitray::FaceCoord;

const CORNER: [[f64; 2]; 3] = [[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]];

fn loop_opts(m: &ControlMesh) -> Options {
    Options {
        scheme: Scheme::Loop,
        ..m.options
    }
}

/// Along every interior edge at 9 points: the largest position gap and tangent-plane angle
/// (degrees) between the two faces' patches, and the number of points where a patch is
/// singular.
fn edge_continuity(m: &ControlMesh, s: &TriApprox) -> (f64, f64, usize) {
    let exact = LoopSurface::new(m, loop_opts(m)).unwrap();
    let topo = &exact.level().topo;
    let diag = m.diagonal();
    let (mut gap, mut angle, mut singular) = (0.0f64, 0.0f64, 0);
    for e in 0..topo.num_edges() as u32 {
        let faces = topo.edge_face_list(e);
        if faces.len() != 2 {
            continue;
        }
        let [a, b] = topo.edge_verts[e as usize];
        let at = |f: u32, t: f64| {
            let fv = topo.face_vertices(f as usize);
            let ca = CORNER[fv.iter().position(|&x| x == a).unwrap()];
            let cb = CORNER[fv.iter().position(|&x| x == b).unwrap()];
            let uv = [0, 1].map(|i| ca[i] + t * (cb[i] - ca[i]));
            s.eval(FaceCoord::new(f, 0, uv[0], uv[1])).unwrap()
        };
        for k in 1..10 {
            let t = k as f64 / 10.0;
            let (p, q) = (at(faces[0], t), at(faces[1], t));
            gap = gap.max(norm(sub(p.p, q.p)));
            let (np, nq) = (normalize(cross(p.du, p.dv)), normalize(cross(q.du, q.dv)));
            // The angle between the two tangent planes (a fold, normals reversed, is the
            // same plane: G¹ still holds there).
            // Where a patch is singular (its boundary curve stops, as PN curves can between
            // vertices whose normals differ by ~120°) it has no tangent plane to compare.
            if norm(cross(p.du, p.dv)).min(norm(cross(q.du, q.dv))) < 1e-9 * diag * diag {
                singular += 1;
                continue;
            }
            angle = angle.max(norm(cross(np, nq)).atan2(dot(np, nq).abs()).to_degrees());
        }
    }
    (gap, angle, singular)
}

/// Meshes with smooth vertices of valence 3 to 12 (the blob's 5 and 6; a bipyramid's apexes of
/// valence n and equator of valence 4).
fn closed_meshes() -> Vec<(String, ControlMesh)> {
    let mut out = vec![("blob".to_string(), shapes::blob())];
    for n in [3usize, 7, 9, 12] {
        let mut p = vec![[0.0, 0.0, 1.3], [0.0, 0.0, -0.8]];
        for k in 0..n {
            let a = 2.0 * std::f64::consts::PI * k as f64 / n as f64;
            p.push([
                a.cos() * (1.0 + 0.2 * (3.0 * a).sin()),
                a.sin(),
                0.1 * (2.0 * a).cos(),
            ]);
        }
        let mut f = Vec::new();
        for k in 0..n as u32 {
            let (c, d) = (2 + k, 2 + (k + 1) % n as u32);
            f.extend([0, c, d, 1, d, c]);
        }
        let mesh = MeshBuilder::new()
            .positions(p)
            .faces(&vec![3; 2 * n], &f)
            .build()
            .unwrap();
        out.push((format!("bipyramid{n}"), mesh));
    }
    out
}

/// Adjacent patches meet: their common boundary curve is computed once per edge, so the gap
/// is rounding alone (≤ 1e-14 of the diagonal; measured ≤ 4e-16). Walton–Meek and Gregory
/// are tangent-plane continuous by construction: the normal jump across an edge is rounding
/// (≤ 1e-6 degrees; measured ≤ 9.1e-10). PN triangles are only C⁰: their jump is reported,
/// and must be visible (> 0.1°) on these coarse meshes, or the measurement has no teeth.
#[test]
fn approximations_are_watertight_and_wm_and_gregory_are_g1() {
    for (name, m) in closed_meshes() {
        let exact = LoopSurface::new(&m, loop_opts(&m)).unwrap();
        let diag = m.diagonal();
        for kind in [Approximation::Pn, Approximation::Wm, Approximation::Gregory] {
            let s = TriApprox::new(&exact, kind).unwrap();
            let (gap, angle, singular) = edge_continuity(&m, &s);
            println!(
                "{name} {kind}: gap {:.2e} of the diagonal, tangent planes {angle:.3e} deg apart \
                 ({singular} singular points skipped)",
                gap / diag
            );
            assert!(gap <= 1e-14 * diag, "{name} {kind}: gap {gap}");
            match kind {
                Approximation::Pn => assert!(angle > 0.1, "{name}: PN jump {angle}"),
                _ => assert!(angle < 1e-6, "{name} {kind}: normal jump {angle} degrees"),
            }
        }
    }
}

/// A planar mesh's approximations are the plane itself (every construction is an affine
/// combination plus vectors in the tangent plane): z stays 0 to rounding, everywhere.
#[test]
fn planes_are_reproduced() {
    let mut p = Vec::new();
    let n = 5;
    for j in 0..=n {
        for i in 0..=n {
            let (x, y) = (
                i as f64 + 0.3 * ((i * j) as f64).sin(),
                j as f64 + 0.2 * (i as f64).cos(),
            );
            p.push([x, y, 0.0]);
        }
    }
    let mut f = Vec::new();
    for j in 0..n as u32 {
        for i in 0..n as u32 {
            let a = j * (n as u32 + 1) + i;
            let (b, c, d) = (a + 1, a + n as u32 + 1, a + n as u32 + 2);
            f.extend([a, b, d, a, d, c]);
        }
    }
    let m = MeshBuilder::new()
        .positions(p)
        .faces(&vec![3; 2 * n * n], &f)
        .build()
        .unwrap();
    let exact = LoopSurface::new(&m, loop_opts(&m)).unwrap();
    for kind in [Approximation::Pn, Approximation::Wm, Approximation::Gregory] {
        let s = TriApprox::new(&exact, kind).unwrap();
        for face in 0..s.num_faces() as u32 {
            for (u, v) in [(0.2, 0.3), (0.7, 0.1), (0.1, 0.1), (0.4, 0.4)] {
                let r = s.eval(FaceCoord::new(face, 0, u, v)).unwrap();
                assert!(r.p[2].abs() < 1e-13, "{kind} face {face}: z = {}", r.p[2]);
                assert!(
                    r.du[2].abs() < 1e-12 && r.dv[2].abs() < 1e-12,
                    "{kind}: slope"
                );
            }
        }
    }
}

/// Corners interpolate the exact limit positions; inside, every approximation stays close to
/// the exact surface at the same parameter (within 5% of the diagonal on these coarse meshes;
/// the measured table is `limitray approx-error`'s).
#[test]
fn approximations_interpolate_corners_and_stay_close() {
    for (name, m) in closed_meshes() {
        let exact = LoopSurface::new(&m, loop_opts(&m)).unwrap();
        let diag = m.diagonal();
        for kind in [Approximation::Pn, Approximation::Wm, Approximation::Gregory] {
            let s = TriApprox::new(&exact, kind).unwrap();
            let mut worst = 0.0f64;
            for face in 0..s.num_faces() as u32 {
                for (c, uv) in CORNER.iter().enumerate() {
                    let a = s.eval(FaceCoord::new(face, 0, uv[0], uv[1])).unwrap();
                    let b = exact.eval(FaceCoord::new(face, 0, uv[0], uv[1])).unwrap();
                    assert!(
                        norm(sub(a.p, b.p)) < 1e-12 * diag,
                        "{name} {kind} corner {c}"
                    );
                }
                for (u, v) in [(0.2, 0.3), (0.5, 0.25), (1.0 / 3.0, 1.0 / 3.0), (0.5, 0.0)] {
                    let a = s.eval(FaceCoord::new(face, 0, u, v)).unwrap();
                    let b = exact.eval(FaceCoord::new(face, 0, u, v)).unwrap();
                    worst = worst.max(norm(sub(a.p, b.p)) / diag);
                }
            }
            println!("{name} {kind}: worst same-parameter distance {worst:.3e} of the diagonal");
            assert!(worst < 5e-2, "{name} {kind}: {worst}");
        }
    }
}

/// Every corpus Loop shape (creases, corners, boundaries, non-manifold, poles): each
/// approximation stays near the exact surface at the same parameter, at 7 points per face:
/// within half the control mesh's diagonal. This is a sanity bound, not an accuracy one.
/// Sharp corners have no tangent plane, so their edge points can coincide with their vertex.
/// When the construction divided by such a vanishing tangent, loop_cubes_infsharp's Gregory
/// points landed 8e6 diagonals away.
#[test]
fn corpus_approximations_stay_near_the_surface() {
    let Some(models) = common::shared_models() else {
        return;
    };
    let mut shapes = 0;
    for path in common::corpus_files(&models, "loop_") {
        let Ok(m) = limitray::mesh::obj::read_obj(&path) else {
            continue;
        };
        let Ok(exact) = LoopSurface::new(&m, loop_opts(&m)) else {
            continue;
        };
        let name = path.file_stem().unwrap().to_string_lossy().to_string();
        let diag = m.diagonal();
        shapes += 1;
        for kind in [Approximation::Pn, Approximation::Wm, Approximation::Gregory] {
            let s = TriApprox::new(&exact, kind).unwrap();
            let mut worst = 0.0f64;
            for face in 0..s.num_faces() as u32 {
                for (u, v) in [
                    (0.0, 0.0),
                    (0.5, 0.0),
                    (0.0, 0.5),
                    (0.5, 0.5),
                    (1.0 / 3.0, 1.0 / 3.0),
                    (0.1, 0.8),
                    (0.8, 0.1),
                ] {
                    let at = FaceCoord::new(face, 0, u, v);
                    let (Ok(a), Ok(b)) = (s.eval(at), exact.eval(at)) else {
                        continue;
                    };
                    worst = worst.max(norm(sub(a.p, b.p)) / diag);
                }
            }
            println!("{name} {kind}: worst same-parameter distance {worst:.3e} of the diagonal");
            assert!(
                worst < 0.5,
                "{name} {kind}: {worst} diagonals from the surface"
            );
        }
    }
    println!("{shapes} corpus shapes");
}
