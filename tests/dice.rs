//! Dicing: crack-free by construction (every diced edge of a closed surface has its twin, by
//! vertex position bits), vertices exactly on the limit surface, rates as specified.

mod common;

use limitray::dice::{dice, DiceOptions, DiceRate, DicedMesh};
use limitray::mesh::obj::read_obj;
use limitray::mesh::ControlMesh;
use limitray::patch::{PatchOptions, PatchTable};
use std::collections::HashMap;

fn diced(mesh: &ControlMesh, rate: DiceRate) -> (PatchTable, DicedMesh) {
    let table = PatchTable::new(mesh, PatchOptions::default()).unwrap();
    let d = dice(
        &table,
        mesh,
        &DiceOptions {
            rate,
            max_rate: 256,
            displace: None,
        },
    )
    .unwrap();
    (table, d)
}

/// The corpus shapes `names`, read from `../shared` (none, with a printed note, where it is
/// absent).
fn corpus(names: &[&str]) -> Vec<(String, ControlMesh)> {
    let Some(models) = common::shared_models() else {
        return Vec::new();
    };
    names
        .iter()
        .map(|name| {
            let path = models.join(format!("opensubdiv/{name}.obj"));
            (name.to_string(), read_obj(&path).unwrap())
        })
        .collect()
}

/// Directed edges keyed by the bits of their end positions: the count of each edge minus
/// the count of its reverse. Zero everywhere means every edge has a twin with bitwise equal
/// end points — no crack, no T-junction.
fn open_edges(d: &DicedMesh) -> usize {
    let key = |i: u32| d.positions[i as usize].map(f32::to_bits);
    let mut count: HashMap<([u32; 3], [u32; 3]), i64> = HashMap::new();
    for t in &d.triangles {
        for k in 0..3 {
            let (a, b) = (key(t[k]), key(t[(k + 1) % 3]));
            *count.entry((a, b)).or_default() += 1;
            *count.entry((b, a)).or_default() -= 1;
        }
    }
    count.values().filter(|&&c| c != 0).count()
}

#[test]
fn cube_is_closed_at_every_rate() {
    let mesh = common::cube_builder().build().unwrap();
    for r in [1, 2, 3, 4, 7, 16] {
        let (_, d) = diced(&mesh, DiceRate::Uniform(r));
        assert_eq!(d.triangles.len(), 6 * 2 * (r * r) as usize, "rate {r}");
        assert_eq!(open_edges(&d), 0, "rate {r}");
    }
}

/// Every closed shape of the corpus dices into a closed triangle mesh at uniform rates and at
/// an edge-length rate (mixed rates per edge, stitched).
#[test]
fn corpus_closed_shapes_dice_closed() {
    let Some(models) = common::shared_models() else {
        return;
    };
    let mut checked = 0;
    for path in common::catmark_files(&models) {
        let Ok(mesh) = read_obj(&path) else { continue };
        if !common::closed(&mesh) {
            continue;
        }
        let diag = mesh.diagonal();
        let rates = if mesh.num_faces() > 1000 {
            vec![DiceRate::Uniform(1), DiceRate::Uniform(2)]
        } else {
            vec![
                DiceRate::Uniform(1),
                DiceRate::Uniform(3),
                DiceRate::EdgeLength(diag / 40.0),
            ]
        };
        for rate in rates {
            let (_, d) = diced(&mesh, rate);
            assert_eq!(open_edges(&d), 0, "{}: {rate:?}", path.display());
        }
        checked += 1;
    }
    eprintln!("closed shapes checked: {checked}");
    assert!(checked >= 25, "only {checked} closed shapes");
}

/// Every diced vertex is the exact limit point at its recorded parameters, rounded once to
/// f32: |p − eval| ≤ half an ulp of the coordinate (plus nothing: eval is deterministic).
#[test]
fn vertices_lie_on_the_limit_surface() {
    for (name, mesh) in corpus(&[
        "catmark_car",
        "catmark_pyramid_creases2",
        "catmark_fvar_bound1",
        "catmark_tent",
    ]) {
        let (table, d) = diced(&mesh, DiceRate::Uniform(3));
        for (i, &c) in d.params.iter().enumerate() {
            let s = table.eval(c).unwrap();
            for a in 0..3 {
                let x = d.positions[i][a];
                // The parameters are the exact f64 ones the vertex was evaluated at, and the
                // position is the f64 point rounded once to f32: at most half an f32 ulp off.
                let slack = (x.abs() * f32::EPSILON) as f64 * 0.5;
                assert!(
                    (x as f64 - s.p[a]).abs() <= slack,
                    "{name}: vertex {i} axis {a}: {x} vs {}",
                    s.p[a]
                );
            }
        }
    }
}

/// Every triangle's corners are the limit points at the parameters it records for them in its
/// own domain: a side's shared points stand where the domain's pattern puts them (in order
/// along the side, whichever way the edge runs), in every domain that holds them. The
/// recorded `(u, v)` are `f32` (at most 2⁻²⁵ off in the unit square) and the corners are
/// rounded to `f32`, so a corner may differ from the point at them by a few 10⁻⁸ of the
/// mesh's size (3.3·10⁻⁸ at most on these meshes); the bound is 10⁻⁶. A corner misplaced by
/// one segment along its side is off by a face's size over the rate (1/24 of the grid's
/// size).
#[test]
fn triangle_corners_lie_at_their_recorded_parameters() {
    let mut meshes = vec![("grid 6".to_string(), limitray::mesh::generate::grid(6))];
    meshes.extend(corpus(&[
        "catmark_car",
        "catmark_pyramid_creases2",
        "catmark_tent",
        "catmark_pole8",
    ]));
    for (name, mesh) in &meshes {
        for rate in [1, 3, 4] {
            let (table, d) = diced(mesh, DiceRate::Uniform(rate));
            let (lo, hi) = d.positions.iter().fold(
                ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]),
                |(lo, hi), p| {
                    (
                        std::array::from_fn(|a| lo[a].min(p[a] as f64)),
                        std::array::from_fn(|a| hi[a].max(p[a] as f64)),
                    )
                },
            );
            let size = (0..3).map(|a| hi[a] - lo[a]).fold(0.0, f64::max);
            for (t, (tri, info)) in d.triangles.iter().zip(&d.tri_info).enumerate() {
                for (c, &v) in tri.iter().enumerate() {
                    let [u, w] = info.uv[c].map(f64::from);
                    let at = limitray::coord::FaceCoord::new(info.face, info.k, u, w);
                    let s = table.eval(at).unwrap();
                    let p = d.positions[v as usize];
                    let off = (0..3)
                        .map(|a| (p[a] as f64 - s.p[a]).abs())
                        .fold(0.0, f64::max);
                    assert!(
                        off <= 1e-6 * size,
                        "{name} at rate {rate}: triangle {t} corner {c} is {off} from its \
                         parameters ({}, {}, {u}, {w})",
                        info.face,
                        info.k
                    );
                }
            }
        }
    }
}

/// Sides of n-gons: an edge between a quad and a pentagon gets an even rate on both sides;
/// the mesh stays closed.
#[test]
fn ngon_rates_are_even_and_stitched() {
    let Some(models) = common::shared_models() else {
        return;
    };
    let mesh = read_obj(&models.join("opensubdiv/catmark_pyramid.obj")).unwrap();
    for r in [1, 2, 5] {
        let (_, d) = diced(&mesh, DiceRate::Uniform(r));
        assert_eq!(open_edges(&d), 0, "rate {r}");
    }
}

#[test]
fn bad_rates_are_errors() {
    let mesh = common::cube_builder().build().unwrap();
    let table = PatchTable::new(&mesh, PatchOptions::default()).unwrap();
    for rate in [
        DiceRate::Uniform(0),
        DiceRate::EdgeLength(0.0),
        DiceRate::EdgeLength(f64::NAN),
    ] {
        let opts = DiceOptions {
            rate,
            max_rate: 64,
            displace: None,
        };
        assert!(dice(&table, &mesh, &opts).is_err(), "{rate:?}");
    }
}

/// Screen-space rates: edges near the camera get more segments than far ones, the mesh
/// stays closed, and pixel targets scale the rate.
#[test]
fn screen_rate_follows_distance() {
    use limitray::dice::ScreenRate;
    let mesh = common::cube_builder().build().unwrap();
    let eye = [0.0, 0.0, 2.5];
    let rate = |ppe: f64| {
        DiceRate::Screen(ScreenRate {
            eye,
            pixels_per_radian: 500.0,
            pixels_per_edge: ppe,
        })
    };
    let (_, d) = diced(&mesh, rate(4.0));
    assert_eq!(open_edges(&d), 0);
    // Triangles of the near face (+z, face 0) outnumber those of the far face (−z, face 2).
    let count = |f: u32| d.tri_info.iter().filter(|t| t.face == f).count();
    assert!(
        count(0) > 2 * count(2),
        "near {} far {}",
        count(0),
        count(2)
    );
    let (_, fine) = diced(&mesh, rate(1.0));
    assert!(fine.triangles.len() > 8 * d.triangles.len() / 2);
    assert_eq!(open_edges(&fine), 0);
}

/// Measured rates follow the displacement: on the cube at a target edge length, noise with a
/// higher amplitude or frequency lengthens the displaced edges and raises their rates (more
/// triangles), the dicing stays closed, and `estimate_size` (which measures the same displaced
/// curves) bounds the result. Uniform rates stay the caller's.
#[test]
fn measured_rates_follow_the_displacement() {
    use limitray::dice::{estimate_size, Displacement};
    let mesh = common::cube_builder().build().unwrap();
    let table = PatchTable::new(&mesh, PatchOptions::default()).unwrap();
    let count = |rate: DiceRate, displace: Option<Displacement>| {
        let opts = DiceOptions {
            rate,
            max_rate: 256,
            displace,
        };
        let d = dice(&table, &mesh, &opts).unwrap();
        let est = estimate_size(&table, &mesh, &opts).unwrap();
        assert!(d.triangles.len() as f64 <= est.triangles, "{rate:?}");
        assert_eq!(open_edges(&d), 0, "{rate:?}");
        d.triangles.len()
    };
    let noise = |amplitude: f64, frequency: f64| {
        Some(Displacement::Noise {
            amplitude,
            frequency,
        })
    };
    let by_length = DiceRate::EdgeLength(0.25);
    let plain = count(by_length, None);
    let low = count(by_length, noise(0.05, 2.0));
    let high = count(by_length, noise(0.3, 2.0));
    let fine = count(by_length, noise(0.3, 6.0));
    eprintln!("triangles: plain {plain}, low {low}, high {high}, fine {fine}");
    assert!(
        plain <= low && low < high && high < fine,
        "{plain} {low} {high} {fine}"
    );
    assert_eq!(
        count(DiceRate::Uniform(6), noise(0.3, 6.0)),
        count(DiceRate::Uniform(6), None)
    );
}
