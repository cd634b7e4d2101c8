//! Closed-form checks of each subdivision rule.
#![allow(clippy::needless_range_loop)]

mod common;

use limitray::mesh::{BoundaryInterpolation, ControlMesh, MeshBuilder, Options};
use limitray::refine::{step, Refiner};

use common::{cube_builder, CUBE_EDGES};

/// The loop of the cube's top face (z = +1).
const TOP_LOOP: [u32; 4] = [0, 1, 3, 2];

fn cube_with_top_loop(s: f32) -> ControlMesh {
    let mut b = cube_builder();
    for k in 0..4 {
        b = b.crease(TOP_LOOP[k], TOP_LOOP[(k + 1) % 4], s);
    }
    b.build().unwrap()
}

#[test]
fn infinitely_sharp_cube_stays_a_cube() {
    let mut b = cube_builder();
    for (a, c) in CUBE_EDGES {
        b = b.crease(a, c, 10.0);
    }
    let mesh = b.build().unwrap();
    let r = Refiner::new(&mesh, 4).unwrap();
    for level in 1..=4 {
        let p = r.refine_positions(&mesh.positions, level);
        for q in &p {
            // every refined point lies on the cube's surface: some |coordinate| is 1 and none
            // exceeds it (exact arithmetic on dyadic numbers)
            assert!(q.iter().all(|c| c.abs() <= 1.0));
            assert!(q.iter().any(|c| c.abs() == 1.0), "{q:?} is off the cube");
        }
        // the 8 corners stay put
        assert_eq!(&p[..8], &mesh.positions[..]);
    }
}

/// Closed uniform cubic B-spline subdivision of a polygon: the crease curve rule.
fn bspline_refine(poly: &[[f64; 3]]) -> Vec<[f64; 3]> {
    let n = poly.len();
    let mut out = Vec::with_capacity(2 * n);
    for i in 0..n {
        let (a, b, c) = (poly[(i + n - 1) % n], poly[i], poly[(i + 1) % n]);
        out.push(std::array::from_fn(|k| (a[k] + 6.0 * b[k] + c[k]) / 8.0));
        out.push(std::array::from_fn(|k| (b[k] + c[k]) / 2.0));
    }
    out
}

/// Level-`level` edges that are halves of edges that were sharp at the level above: the
/// edges the crease rule refined (their own sharpness may already be 0).
fn crease_children(r: &Refiner, level: usize) -> Vec<bool> {
    let (pl, l) = (&r.levels[level - 1], &r.levels[level]);
    let mut out = vec![false; l.topo.num_edges()];
    for e in 0..pl.topo.num_edges() {
        if pl.edge_sharpness[e] > 0.0 {
            let m = step::child_of_edge(pl, e);
            for v in pl.topo.edge_verts[e] {
                out[l.topo.find_edge(m, v).unwrap() as usize] = true;
            }
        }
    }
    out
}

/// Follows a closed chain of crease edges through the refined level (vertex children keep
/// their index).
fn crease_chain(r: &Refiner, level: usize, start: u32, second: u32) -> Vec<u32> {
    let l = &r.levels[level];
    let sharp = crease_children(r, level);
    let mut chain = vec![start, second];
    loop {
        let cur = *chain.last().unwrap();
        let prev = chain[chain.len() - 2];
        let next = l
            .topo
            .vertex_edges(cur as usize)
            .iter()
            .filter(|&&e| sharp[e as usize])
            .map(|&e| l.topo.other_vertex(e, cur))
            .find(|&v| v != prev)
            .unwrap();
        if next == start {
            return chain;
        }
        chain.push(next);
    }
}

#[test]
fn semi_sharp_crease_follows_the_crease_curve_for_s_levels() {
    // A crease of sharpness s = 3 refines like a cubic B-spline curve, independent of the
    // faces around it, for 3 levels; at level 4 the smooth rule takes over.
    let mesh = cube_with_top_loop(3.0);
    let r = Refiner::new(&mesh, 4).unwrap();
    let mut poly: Vec<[f64; 3]> = TOP_LOOP
        .iter()
        .map(|&v| mesh.positions[v as usize])
        .collect();
    for level in 1..=4 {
        let p = r.refine_positions(&mesh.positions, level);
        poly = bspline_refine(&poly);
        if level <= 3 {
            // start the walk towards the neighbour that should be the curve's next point
            let l = &r.levels[level];
            let sharp = crease_children(&r, level);
            let first = l
                .topo
                .vertex_edges(0)
                .iter()
                .filter(|&&e| sharp[e as usize])
                .map(|&e| l.topo.other_vertex(e, 0))
                .min_by(|&a, &b| {
                    common::dist(&p[a as usize], &poly[1])
                        .total_cmp(&common::dist(&p[b as usize], &poly[1]))
                })
                .unwrap();
            let chain = crease_chain(&r, level, 0, first);
            assert_eq!(chain.len(), poly.len());
            for (k, &v) in chain.iter().enumerate() {
                let d = common::dist(&p[v as usize], &poly[k]);
                assert!(
                    d < 1e-15,
                    "level {level} crease vertex {k}: off the curve by {d}"
                );
            }
        } else {
            // level 4: vertex 0 no longer follows the curve rule
            assert!(common::dist(&p[0], &poly[0]) > 1e-3);
        }
    }
}

#[test]
fn fractional_sharpness_blends_parent_and_child_rules() {
    // With s = 0.5 every level-1 point is the average of the s = 0 (smooth) and s = 1 (crease
    // for one level) results; later levels are smooth in all three.
    let p = |s: f32| {
        let m = cube_with_top_loop(s);
        Refiner::new(&m, 1)
            .unwrap()
            .refine_positions(&m.positions, 1)
    };
    let (p0, p1, ph) = (p(0.0), p(1.0), p(0.5));
    let (pq, p34) = (p(0.25), p(0.75));
    for i in 0..p0.len() {
        for k in 0..3 {
            assert!((ph[i][k] - 0.5 * (p0[i][k] + p1[i][k])).abs() < 1e-15);
            assert!((pq[i][k] - (0.75 * p0[i][k] + 0.25 * p1[i][k])).abs() < 1e-15);
            assert!((p34[i][k] - (0.25 * p0[i][k] + 0.75 * p1[i][k])).abs() < 1e-15);
        }
    }
}

#[test]
fn corner_vertex_stays_and_semi_sharp_corner_blends() {
    let inf = cube_builder().corner(3, 10.0).build().unwrap();
    let p = Refiner::new(&inf, 3)
        .unwrap()
        .refine_positions(&inf.positions, 3);
    assert_eq!(p[3], inf.positions[3]);
    // sharpness 0.5 at the corner: level-1 vertex is the average of the corner and smooth rules
    let half = cube_builder().corner(3, 0.5).build().unwrap();
    let smooth = cube_builder().build().unwrap();
    let ph = Refiner::new(&half, 1)
        .unwrap()
        .refine_positions(&half.positions, 1);
    let ps = Refiner::new(&smooth, 1)
        .unwrap()
        .refine_positions(&smooth.positions, 1);
    for k in 0..3 {
        assert!((ph[3][k] - 0.5 * (ps[3][k] + smooth.positions[3][k])).abs() < 1e-15);
    }
}

#[test]
fn dart_uses_the_smooth_rule() {
    // One sharp edge at a vertex (a dart): the vertex point is the smooth one; the edge point
    // is the midpoint.
    let dart = cube_builder().crease(0, 1, 10.0).build().unwrap();
    let smooth = cube_builder().build().unwrap();
    let rd = Refiner::new(&dart, 1).unwrap();
    let pd = rd.refine_positions(&dart.positions, 1);
    let ps = Refiner::new(&smooth, 1)
        .unwrap()
        .refine_positions(&smooth.positions, 1);
    assert_eq!(pd[0], ps[0]);
    assert_eq!(pd[1], ps[1]);
    let e = rd.levels[0].topo.find_edge(0, 1).unwrap() as usize;
    let mid = step::child_of_edge(&rd.levels[0], e) as usize;
    assert_eq!(pd[mid], [0.0, -1.0, 1.0]);
}

fn quad(boundary: BoundaryInterpolation) -> ControlMesh {
    MeshBuilder::new()
        .positions(vec![
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [1.0, 1.0, 0.0],
            [0.0, 1.0, 0.0],
        ])
        .faces(&[4], &[0, 1, 2, 3])
        .options(Options {
            boundary,
            ..Options::default()
        })
        .build()
        .unwrap()
}

#[test]
fn boundary_modes() {
    // edge-and-corner: a lone quad's corners stay; edge-only: they follow the crease rule
    // 3/4 V + 1/8 (E_a + E_b); 'none' makes every face touching the boundary a hole.
    let m = quad(BoundaryInterpolation::EdgeAndCorner);
    let p = Refiner::new(&m, 1)
        .unwrap()
        .refine_positions(&m.positions, 1);
    assert_eq!(p[0], [0.0, 0.0, 0.0]);
    let m = quad(BoundaryInterpolation::EdgeOnly);
    let p = Refiner::new(&m, 1)
        .unwrap()
        .refine_positions(&m.positions, 1);
    assert_eq!(p[0], [0.125, 0.125, 0.0]);
    let m = quad(BoundaryInterpolation::None);
    let r = Refiner::new(&m, 2).unwrap();
    assert!(r.levels[2].face_hole.iter().all(|&h| h));
}

#[test]
fn ngon_becomes_quads_in_one_step() {
    let n = 7;
    let pos: Vec<[f64; 3]> = (0..n)
        .map(|i| {
            let a = i as f64 * std::f64::consts::TAU / n as f64;
            [a.cos(), a.sin(), 0.0]
        })
        .collect();
    let idx: Vec<u32> = (0..n as u32).collect();
    let m = MeshBuilder::new()
        .positions(pos)
        .faces(&[n], &idx)
        .build()
        .unwrap();
    let r = Refiner::new(&m, 1).unwrap();
    let l = &r.levels[1];
    assert_eq!(l.num_faces(), n);
    assert!((0..n).all(|f| l.topo.face_size(f) == 4));
    // the face point is the centroid (the origin), shared by all sub-faces as corner 2
    let p = r.refine_positions(&m.positions, 1);
    let c = l.topo.face_vertices(0)[2] as usize;
    assert!(p[c].iter().all(|x| x.abs() < 1e-15));
    assert!((0..n).all(|f| l.topo.face_vertices(f)[2] as usize == c));
}

#[test]
fn holes_are_kept_in_topology_and_tagged() {
    let m = cube_builder().hole(0).build().unwrap();
    let r = Refiner::new(&m, 2).unwrap();
    let holes = r.levels[2].face_hole.iter().filter(|&&h| h).count();
    assert_eq!(holes, 16);
    // the hole does not change the positions (it only removes faces from the surface)
    let s = cube_builder().build().unwrap();
    assert_eq!(
        r.refine_positions(&m.positions, 2),
        Refiner::new(&s, 2)
            .unwrap()
            .refine_positions(&s.positions, 2)
    );
}
