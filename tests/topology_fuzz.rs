//! Random and mutated topology: whatever `MeshBuilder::build` accepts must refine to level 3
//! without panicking, with finite positions and finite limit frames; whatever it rejects must
//! be a `Topology` error. Plus deterministic checks of the non-manifold configurations the
//! library keeps (edges of three faces, bow-ties, inconsistent winding, high-valence poles,
//! isolated vertices).
// Levels index several parallel arrays (levels, positions); range loops say so.
#![allow(clippy::needless_range_loop)]

use limitray::mesh::{
    BoundaryInterpolation, ControlMesh, CreaseMethod, MeshBuilder, Options, Scheme,
    SHARPNESS_INFINITE,
};
use limitray::refine::limit::LimitStencils;
use limitray::refine::Refiner;
use limitray::ErrorKind;
use proptest::prelude::*;
use proptest::sample::{select, Index};
use proptest::test_runner::TestRunner;
use std::sync::mpsc;
use std::time::Duration;

/// Sharpness values the fuzzer draws from: smooth, fractional, one level, several levels,
/// exactly infinite and above infinite.
const SHARPNESS: [f32; 6] = [0.0, 0.3, 1.0, 2.5, 10.0, 11.0];

/// Refinement depth checked for every accepted mesh.
const LEVELS: usize = 3;

/// Longest one case may run before it is reported as a hang.
const CASE_TIMEOUT: Duration = Duration::from_secs(20);

/// A mesh description as drawn by the strategies (kept as plain data so that proptest can
/// print and shrink it).
#[derive(Clone, Debug)]
struct Spec {
    positions: Vec<[f64; 3]>,
    faces: Vec<Vec<u32>>,
    creases: Vec<(u32, u32, f32)>,
    corners: Vec<(u32, f32)>,
    holes: Vec<u32>,
    options: Options,
}

impl Spec {
    fn builder(&self) -> MeshBuilder {
        let sizes: Vec<usize> = self.faces.iter().map(|f| f.len()).collect();
        let indices: Vec<u32> = self.faces.concat();
        let mut b = MeshBuilder::new()
            .positions(self.positions.clone())
            .faces(&sizes, &indices)
            .options(self.options);
        for &(a, c, s) in &self.creases {
            b = b.crease(a, c, s);
        }
        for &(v, s) in &self.corners {
            b = b.corner(v, s);
        }
        for &h in &self.holes {
            b = b.hole(h);
        }
        b
    }
}

fn finite(p: &[f64; 3]) -> bool {
    p.iter().all(|c| c.is_finite())
}

/// Runs `f` on a worker thread and fails if it does not finish within [`CASE_TIMEOUT`]
/// (a hang would otherwise stall the whole test run). Panics in `f` are propagated.
fn with_timeout<T: Send + 'static>(what: String, f: impl FnOnce() -> T + Send + 'static) -> T {
    let (tx, rx) = mpsc::channel();
    let handle = std::thread::spawn(move || {
        let out = f();
        let _ = tx.send(());
        out
    });
    match rx.recv_timeout(CASE_TIMEOUT) {
        Ok(()) | Err(mpsc::RecvTimeoutError::Disconnected) => match handle.join() {
            Ok(out) => out,
            Err(panic) => std::panic::resume_unwind(panic),
        },
        Err(mpsc::RecvTimeoutError::Timeout) => {
            panic!("no result after {CASE_TIMEOUT:?} (hang?) for {what}")
        }
    }
}

/// What happened to one mesh, for the statistics printed at the end of a property.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Outcome {
    Rejected,
    Refined,
}

/// The checks every mesh goes through. Returns whether it was accepted.
fn check_mesh(spec: &Spec) -> Outcome {
    let mesh = match spec.builder().build() {
        Ok(m) => m,
        Err(e) => {
            assert_eq!(
                e.kind,
                ErrorKind::Topology,
                "build rejected {spec:?} with a non-topology error: {e}"
            );
            assert!(!e.message.is_empty(), "empty error message for {spec:?}");
            return Outcome::Rejected;
        }
    };
    check_refinement(&mesh, spec.options, &format!("{spec:?}"));
    Outcome::Refined
}

/// Refines a valid mesh to [`LEVELS`] and checks counts, finiteness, the convex-hull property
/// of the (non-negative) masks, and the limit frames at levels 1 and 2.
fn check_refinement(mesh: &ControlMesh, options: Options, what: &str) {
    let refiner = match Refiner::with_options(mesh, options, LEVELS) {
        Ok(r) => r,
        Err(e) => panic!("a mesh that build() accepted failed to refine: {e}\nmesh: {what}"),
    };
    assert_eq!(refiner.levels.len(), LEVELS + 1);
    let all = refiner.interpolate_all(mesh.positions.as_flattened(), 3);
    let [lo, hi] = mesh.bounds();
    let tol = 1e-9 * (1.0 + mesh.diagonal());
    let inside = |p: &[f64; 3]| (0..3).all(|k| p[k] >= lo[k] - tol && p[k] <= hi[k] + tol);
    for l in 0..=LEVELS {
        let level = &refiner.levels[l];
        assert_eq!(
            all[l].len(),
            3 * level.num_vertices(),
            "level {l} size: {what}"
        );
        if l > 0 {
            let parent = &refiner.levels[l - 1];
            let face_points = match options.scheme {
                Scheme::Catmark => parent.num_faces(),
                Scheme::Loop => 0,
            };
            assert_eq!(
                level.num_vertices(),
                parent.num_vertices() + face_points + parent.topo.num_edges(),
                "level {l} vertex count: {what}"
            );
            if options.scheme == Scheme::Loop {
                assert_eq!(level.num_faces(), 4 * parent.num_faces());
            }
        }
        for (i, c) in all[l].chunks_exact(3).enumerate() {
            let p = [c[0], c[1], c[2]];
            assert!(finite(&p), "level {l} vertex {i} = {p:?}: {what}");
            // Every rule is a convex combination, except OpenSubdiv's Chaikin edge point of an
            // edge sharper than 1 whose child is smooth at one end: it extrapolates past the
            // midpoint (refine/rules.rs `edge_mask`; Far puts this cube's level-2 point at
            // x = 0.5078125, outside [-0.5, 0.5], as limitray does).
            assert!(
                inside(&p) || options.crease_method == CreaseMethod::Chaikin,
                "level {l} vertex {i} = {p:?} is outside the control bounds {lo:?}..{hi:?}: {what}"
            );
        }
    }
    // Limit frames are Catmull-Clark's only so far.
    let frame_levels: &[usize] = if options.scheme == Scheme::Catmark {
        &[1, 2]
    } else {
        &[]
    };
    for &l in frame_levels {
        let level = &refiner.levels[l];
        let pos: Vec<[f64; 3]> = all[l].chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect();
        let frames = LimitStencils::new(level, options.crease_method).frames(&pos);
        assert_eq!(frames.len(), level.num_vertices());
        for (i, f) in frames.iter().enumerate() {
            assert!(
                finite(&f.position) && finite(&f.du) && finite(&f.dv),
                "level {l} limit frame {i} is not finite: {f:?}: {what}"
            );
            // Chaikin's extrapolating edge points (above) can carry the limit outside too.
            assert!(
                inside(&f.position) || options.crease_method == CreaseMethod::Chaikin,
                "level {l} limit position {i} = {:?} is outside the control bounds: {what}",
                f.position
            );
        }
    }
}

fn options_strategy() -> impl Strategy<Value = Options> {
    (
        select(vec![
            BoundaryInterpolation::None,
            BoundaryInterpolation::EdgeOnly,
            BoundaryInterpolation::EdgeAndCorner,
        ]),
        any::<bool>(),
        any::<bool>(),
    )
        .prop_map(|(boundary, chaikin, smooth_triangles)| Options {
            boundary,
            crease_method: if chaikin {
                CreaseMethod::Chaikin
            } else {
                CreaseMethod::Uniform
            },
            smooth_triangles,
            scheme: Scheme::Catmark,
            ..Options::default()
        })
}

/// One face of 3–6 distinct vertices of `0..nv` in random order, sometimes (3 in 64) spoiled:
/// an index out of range, or a vertex repeated (adjacent or not).
fn face_strategy(nv: usize) -> impl Strategy<Value = Vec<u32>> {
    (
        Just((0..nv as u32).collect::<Vec<u32>>()).prop_shuffle(),
        3usize..=6,
        0u8..64,
        any::<Index>(),
        0u32..3,
    )
        .prop_map(move |(perm, k, spoil, at, extra)| {
            let mut f: Vec<u32> = perm.into_iter().take(k).collect();
            let n = f.len();
            let i = at.index(n);
            match spoil {
                0 => f[i] = nv as u32 + extra,
                1 => f[i] = f[(i + 1) % n],
                2 => f[i] = f[(i + 2) % n],
                _ => {}
            }
            f
        })
}

/// A crease either on an edge of a face (`on_face`) or between two random vertices (which may
/// be equal, out of range, or not joined by an edge).
type CreaseSeed = (bool, Index, Index, u32, u32, f32);

fn random_mesh_strategy() -> impl Strategy<Value = Spec> {
    (3usize..=12).prop_flat_map(|nv| {
        (
            prop::collection::vec(prop::array::uniform3(-10.0f64..10.0), nv),
            prop::collection::vec(face_strategy(nv), 1..=8),
            prop::collection::vec(
                (
                    prop::bool::weighted(0.85),
                    any::<Index>(),
                    any::<Index>(),
                    0..=nv as u32,
                    0..=nv as u32,
                    select(SHARPNESS.to_vec()),
                ),
                0..=5,
            ),
            prop::collection::vec(
                (
                    prop::bool::weighted(0.95),
                    0..nv as u32,
                    select(SHARPNESS.to_vec()),
                ),
                0..=3,
            ),
            prop::collection::vec((prop::bool::weighted(0.95), any::<Index>()), 0..=2),
            options_strategy(),
            prop::bool::weighted(0.3),
        )
            .prop_map(
                move |(positions, faces, crease_seeds, corner_seeds, hole_seeds, options, tri)| {
                    // About a third of the meshes are triangle meshes under the Loop scheme:
                    // every face cut to its first three vertices (spoiled ones may stay so).
                    let (faces, options) = if tri {
                        let faces = faces.into_iter().map(|f| f[..3].to_vec()).collect();
                        (
                            faces,
                            Options {
                                scheme: Scheme::Loop,
                                ..options
                            },
                        )
                    } else {
                        (faces, options)
                    };
                    let creases = creases_from(&faces, &crease_seeds);
                    // Mostly valid corner and hole indices; sometimes one past the end.
                    let corners = corner_seeds
                        .iter()
                        .map(|&(ok, v, s)| (if ok { v } else { nv as u32 }, s))
                        .collect();
                    let holes = hole_seeds
                        .iter()
                        .map(|&(ok, i)| {
                            if ok {
                                i.index(faces.len()) as u32
                            } else {
                                faces.len() as u32
                            }
                        })
                        .collect();
                    Spec {
                        positions,
                        faces,
                        creases,
                        corners,
                        holes,
                        options,
                    }
                },
            )
    })
}

fn creases_from(faces: &[Vec<u32>], seeds: &[CreaseSeed]) -> Vec<(u32, u32, f32)> {
    seeds
        .iter()
        .map(|&(on_face, fi, ei, a, b, s)| {
            if on_face && !faces.is_empty() {
                let f = &faces[fi.index(faces.len())];
                let i = ei.index(f.len());
                (f[i], f[(i + 1) % f.len()], s)
            } else {
                (a, b, s)
            }
        })
        .collect()
}

/// The cube of OpenSubdiv's `catmark_cube.obj`.
fn cube_positions() -> Vec<[f64; 3]> {
    vec![
        [-0.5, -0.5, 0.5],
        [0.5, -0.5, 0.5],
        [-0.5, 0.5, 0.5],
        [0.5, 0.5, 0.5],
        [-0.5, 0.5, -0.5],
        [0.5, 0.5, -0.5],
        [-0.5, -0.5, -0.5],
        [0.5, -0.5, -0.5],
    ]
}

fn cube_faces() -> Vec<Vec<u32>> {
    vec![
        vec![0, 1, 3, 2],
        vec![2, 3, 5, 4],
        vec![4, 5, 7, 6],
        vec![6, 7, 1, 0],
        vec![1, 7, 5, 3],
        vec![6, 0, 2, 4],
    ]
}

/// Edits applied to a valid cube.
#[derive(Clone, Debug)]
enum Mutation {
    Remove(Index),
    Duplicate(Index),
    Reverse(Index),
    /// Rotate the face's vertex list (keeps the face the same).
    Rotate(Index, usize),
    /// Apply a random permutation to the face's vertices.
    Shuffle(Index, Vec<usize>),
    /// Replace one corner of a face by another vertex of the cube.
    Replace(Index, Index, u32),
    /// Drop one corner of a face (a quad becomes a triangle).
    DropCorner(Index, Index),
}

fn mutation_strategy() -> impl Strategy<Value = Mutation> {
    prop_oneof![
        any::<Index>().prop_map(Mutation::Remove),
        any::<Index>().prop_map(Mutation::Duplicate),
        any::<Index>().prop_map(Mutation::Reverse),
        (any::<Index>(), 1usize..4).prop_map(|(f, k)| Mutation::Rotate(f, k)),
        (any::<Index>(), Just(vec![0usize, 1, 2, 3]).prop_shuffle())
            .prop_map(|(f, p)| Mutation::Shuffle(f, p)),
        (any::<Index>(), any::<Index>(), 0u32..8).prop_map(|(f, c, v)| Mutation::Replace(f, c, v)),
        (any::<Index>(), any::<Index>()).prop_map(|(f, c)| Mutation::DropCorner(f, c)),
    ]
}

fn mutate(faces: &mut Vec<Vec<u32>>, m: &Mutation) {
    if faces.is_empty() {
        return;
    }
    match m {
        Mutation::Remove(f) => {
            faces.remove(f.index(faces.len()));
        }
        Mutation::Duplicate(f) => {
            let dup = faces[f.index(faces.len())].clone();
            faces.push(dup);
        }
        Mutation::Reverse(f) => {
            let i = f.index(faces.len());
            faces[i].reverse();
        }
        Mutation::Rotate(f, k) => {
            let i = f.index(faces.len());
            let n = faces[i].len();
            faces[i].rotate_left(k % n);
        }
        Mutation::Shuffle(f, p) => {
            let i = f.index(faces.len());
            let old = faces[i].clone();
            faces[i] = p
                .iter()
                .filter(|&&k| k < old.len())
                .map(|&k| old[k])
                .collect();
        }
        Mutation::Replace(f, c, v) => {
            let i = f.index(faces.len());
            let j = c.index(faces[i].len());
            faces[i][j] = *v;
        }
        Mutation::DropCorner(f, c) => {
            let i = f.index(faces.len());
            let j = c.index(faces[i].len());
            if faces[i].len() > 3 {
                faces[i].remove(j);
            }
        }
    }
}

fn mutated_cube_strategy() -> impl Strategy<Value = Spec> {
    (
        prop::collection::vec(mutation_strategy(), 1..=4),
        prop::collection::vec(
            (
                prop::bool::weighted(0.9),
                any::<Index>(),
                any::<Index>(),
                0u32..8,
                0u32..8,
                select(SHARPNESS.to_vec()),
            ),
            0..=4,
        ),
        prop::collection::vec((0u32..8, select(SHARPNESS.to_vec())), 0..=2),
        prop::collection::vec((prop::bool::weighted(0.9), any::<Index>()), 0..=1),
        options_strategy(),
    )
        .prop_map(|(mutations, crease_seeds, corners, hole_seeds, options)| {
            let mut faces = cube_faces();
            for m in &mutations {
                mutate(&mut faces, m);
            }
            let creases = creases_from(&faces, &crease_seeds);
            let holes = hole_seeds
                .iter()
                .map(|&(ok, i)| {
                    if ok && !faces.is_empty() {
                        i.index(faces.len()) as u32
                    } else {
                        faces.len() as u32
                    }
                })
                .collect();
            Spec {
                positions: cube_positions(),
                faces,
                creases,
                corners,
                holes,
                options,
            }
        })
}

fn config() -> ProptestConfig {
    ProptestConfig {
        // PROPTEST_CASES=N runs a longer search.
        cases: std::env::var("PROPTEST_CASES")
            .ok()
            .and_then(|n| n.parse().ok())
            .unwrap_or(500),
        max_shrink_time: 60_000,
        max_shrink_iters: 2_000,
        // No regression files: this crate keeps its test inputs in the test sources.
        failure_persistence: None,
        ..ProptestConfig::default()
    }
}

fn run_case(spec: Spec) -> Outcome {
    let what = format!("{spec:?}");
    with_timeout(what, move || check_mesh(&spec))
}

/// Runs a property over `config().cases` meshes of `strategy` and prints how many were
/// rejected by `build()` and how many were refined.
fn run_property(name: &str, strategy: impl Strategy<Value = Spec>) {
    let counts = std::cell::Cell::new([0usize; 2]);
    let start = std::time::Instant::now();
    let mut runner = TestRunner::new(config());
    let result = runner.run(&strategy, |spec| {
        let o = run_case(spec);
        let mut c = counts.get();
        c[(o == Outcome::Refined) as usize] += 1;
        counts.set(c);
        Ok(())
    });
    let [rejected, refined] = counts.get();
    println!(
        "{name}: {rejected} meshes rejected by build(), {refined} refined to level {LEVELS} \
         (with limit frames at levels 1 and 2), {:.2} s",
        start.elapsed().as_secs_f64()
    );
    if let Err(e) = result {
        panic!("{name}: {e}");
    }
    assert!(refined > 0, "{name}: no mesh was accepted");
}

#[test]
fn random_meshes_refine_or_are_rejected() {
    run_property("random meshes", random_mesh_strategy());
}

#[test]
fn mutated_cubes_refine_or_are_rejected() {
    run_property("mutated cubes", mutated_cube_strategy());
}

/// The strategies produce a useful mix: many meshes accepted, some rejected, and many of the
/// accepted ones non-manifold.
#[test]
fn strategies_produce_accepted_and_rejected_meshes() {
    use proptest::strategy::ValueTree;
    let mut runner = TestRunner::deterministic();
    for (name, strategy) in [
        ("random", random_mesh_strategy().boxed()),
        ("cube", mutated_cube_strategy().boxed()),
    ] {
        let mut accepted = 0;
        let mut nonmanifold = 0;
        for _ in 0..400 {
            let spec = strategy.new_tree(&mut runner).unwrap().current();
            if let Ok(mesh) = spec.builder().build() {
                accepted += 1;
                let r = Refiner::with_options(&mesh, spec.options, 0).unwrap();
                if r.levels[0].topo.vert_tags.iter().any(|t| t.nonmanifold) {
                    nonmanifold += 1;
                }
            }
        }
        println!("{name}: {accepted}/400 accepted, {nonmanifold} with non-manifold vertices");
        assert!(
            accepted >= 100,
            "{name}: only {accepted}/400 meshes accepted"
        );
        assert!(
            accepted <= 390,
            "{name}: almost nothing rejected ({accepted}/400 accepted)"
        );
        assert!(
            nonmanifold >= 20,
            "{name}: only {nonmanifold} non-manifold meshes"
        );
    }
}

// ---------------------------------------------------------------------------------------------
// Deterministic non-manifold cases.

fn refine_all(mesh: &ControlMesh, levels: usize) -> (Refiner, Vec<Vec<[f64; 3]>>) {
    let r = Refiner::new(mesh, levels).expect("refiner");
    let pos = (0..=levels)
        .map(|l| r.refine_positions(&mesh.positions, l))
        .collect();
    (r, pos)
}

#[test]
fn edge_shared_by_three_faces_is_infinitely_sharp() {
    // Three quads around the edge 0-1, like pages of a book.
    let mesh = MeshBuilder::new()
        .positions(vec![
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [1.0, 1.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.0, -1.0, 0.2],
            [1.0, -1.0, 0.2],
            [0.0, 0.1, 1.0],
            [1.0, 0.1, 1.0],
        ])
        .faces(&[4, 4, 4], &[0, 1, 2, 3, 1, 0, 4, 5, 0, 1, 7, 6])
        .build()
        .expect("a non-manifold edge is accepted");
    let (r, pos) = refine_all(&mesh, 3);
    let base = &r.levels[0];
    let e = base.topo.find_edge(0, 1).expect("edge 0-1") as usize;
    assert_eq!(base.topo.edge_face_count(e as u32), 3);
    assert!(base.topo.edge_nonmanifold[e]);
    assert!(base.edge_sharpness[e] >= SHARPNESS_INFINITE);
    assert!(base.topo.vert_tags[0].nonmanifold && base.topo.vert_tags[1].nonmanifold);
    // The child edges of the non-manifold edge stay sharp and non-manifold.
    let l1 = &r.levels[1];
    let mid = (base.num_vertices() + base.num_faces() + e) as u32;
    for end in [0u32, 1] {
        let ce = l1.topo.find_edge(mid, end).expect("child edge") as usize;
        assert!(l1.topo.edge_nonmanifold[ce]);
        assert!(l1.edge_sharpness[ce] >= SHARPNESS_INFINITE);
    }
    // The edge point of a sharp edge is its midpoint.
    let m = pos[1][mid as usize];
    assert!(dist(&m, &[0.5, 0.0, 0.0]) < 1e-12, "edge point {m:?}");
    for p in pos.iter().flatten() {
        assert!(finite(p));
    }
    for l in 0..=2 {
        let frames = LimitStencils::new(&r.levels[l], mesh.options.crease_method).frames(&pos[l]);
        assert!(frames
            .iter()
            .all(|f| finite(&f.position) && finite(&f.du) && finite(&f.dv)));
    }
}

#[test]
fn bowtie_vertex_is_infinitely_sharp() {
    // Two triangles that share only vertex 0.
    let mesh = MeshBuilder::new()
        .positions(vec![
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [1.0, 1.0, 0.0],
            [-1.0, 0.0, 0.0],
            [-1.0, -1.0, 0.5],
        ])
        .faces(&[3, 3], &[0, 1, 2, 0, 3, 4])
        .build()
        .expect("a bow-tie is accepted");
    let (r, pos) = refine_all(&mesh, 3);
    let base = &r.levels[0];
    assert!(base.topo.vert_tags[0].nonmanifold);
    assert!(base.vertex_sharpness[0] >= SHARPNESS_INFINITE);
    assert!(!base.topo.vert_tags[1].nonmanifold);
    // An infinitely sharp vertex does not move, at any level or in the limit.
    for (l, p) in pos.iter().enumerate() {
        assert_eq!(p[0], [0.0, 0.0, 0.0], "level {l}");
        assert!(p.iter().all(finite));
    }
    for l in 0..=2 {
        let frames = LimitStencils::new(&r.levels[l], mesh.options.crease_method).frames(&pos[l]);
        assert_eq!(frames[0].position, [0.0, 0.0, 0.0], "level {l} limit");
        assert!(frames
            .iter()
            .all(|f| finite(&f.position) && finite(&f.du) && finite(&f.dv)));
    }
}

#[test]
fn inconsistent_winding_tags_the_edge_nonmanifold() {
    // Two quads that both run 0 -> 1 along their shared edge.
    let mesh = MeshBuilder::new()
        .positions(vec![
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [1.0, 1.0, 0.0],
            [0.0, 1.0, 0.0],
            [1.0, -1.0, 0.0],
            [0.0, -1.0, 0.0],
        ])
        .faces(&[4, 4], &[0, 1, 2, 3, 0, 1, 4, 5])
        .build()
        .expect("inconsistent winding is accepted");
    let (r, pos) = refine_all(&mesh, 3);
    let base = &r.levels[0];
    let e = base.topo.find_edge(0, 1).unwrap() as usize;
    assert_eq!(base.topo.edge_face_count(e as u32), 2);
    assert!(base.topo.edge_nonmanifold[e]);
    assert!(base.edge_sharpness[e] >= SHARPNESS_INFINITE);
    assert!(base.topo.vert_tags[0].nonmanifold && base.topo.vert_tags[1].nonmanifold);
    assert!(pos.iter().flatten().all(finite));
    for l in 0..=2 {
        let frames = LimitStencils::new(&r.levels[l], mesh.options.crease_method).frames(&pos[l]);
        assert!(frames
            .iter()
            .all(|f| finite(&f.position) && finite(&f.du) && finite(&f.dv)));
    }
}

#[test]
fn valence_360_pole_refines_with_finite_limit() {
    // A fan of 360 triangles around a raised centre, closed by a ring of 360 quads.
    let n = 360u32;
    let mut positions = vec![[0.0, 0.0, 1.0]];
    for r in [1.0, 2.0] {
        for i in 0..n {
            let a = std::f64::consts::TAU * i as f64 / n as f64;
            positions.push([r * a.cos(), r * a.sin(), 0.0]);
        }
    }
    let inner = |i: u32| 1 + i % n;
    let outer = |i: u32| 1 + n + i % n;
    let mut sizes = Vec::new();
    let mut indices = Vec::new();
    for i in 0..n {
        sizes.push(3);
        indices.extend_from_slice(&[0, inner(i), inner(i + 1)]);
    }
    for i in 0..n {
        sizes.push(4);
        indices.extend_from_slice(&[inner(i), outer(i), outer(i + 1), inner(i + 1)]);
    }
    let mesh = MeshBuilder::new()
        .positions(positions)
        .faces(&sizes, &indices)
        .build()
        .expect("pole mesh");
    let (r, pos) = refine_all(&mesh, 2);
    let base = &r.levels[0];
    assert_eq!(base.topo.vertex_edges(0).len(), n as usize);
    assert!(!base.topo.vert_tags[0].nonmanifold && !base.topo.vert_tags[0].boundary);
    assert!(pos.iter().flatten().all(finite));
    for l in 0..=1 {
        let frames = LimitStencils::new(&r.levels[l], mesh.options.crease_method).frames(&pos[l]);
        for (i, f) in frames.iter().enumerate() {
            assert!(
                finite(&f.position) && finite(&f.du) && finite(&f.dv),
                "level {l} frame {i}: {f:?}"
            );
        }
        // By symmetry the pole's limit lies on the axis, below the control point.
        let c = frames[0].position;
        assert!(
            c[0].abs() < 1e-9 && c[1].abs() < 1e-9,
            "level {l} pole {c:?}"
        );
        assert!(c[2] > 0.0 && c[2] < 1.0, "level {l} pole {c:?}");
    }
}

#[test]
fn isolated_vertex_is_kept_and_does_not_move() {
    let mut positions = cube_positions();
    positions.push([3.0, 4.0, 5.0]);
    let faces = cube_faces();
    let sizes = vec![4; faces.len()];
    let mesh = MeshBuilder::new()
        .positions(positions)
        .faces(&sizes, &faces.concat())
        .build()
        .expect("isolated vertices are allowed");
    let (r, pos) = refine_all(&mesh, 3);
    let iso = 8;
    assert!(r.levels[0].topo.vertex_edges(iso).is_empty());
    for (l, p) in pos.iter().enumerate() {
        assert_eq!(p[iso], [3.0, 4.0, 5.0], "level {l}");
        assert!(r.levels[l].topo.vertex_edges(iso).is_empty(), "level {l}");
        assert!(p.iter().all(finite));
    }
    for l in 0..=3 {
        let frames = LimitStencils::new(&r.levels[l], mesh.options.crease_method).frames(&pos[l]);
        assert_eq!(frames[iso].position, [3.0, 4.0, 5.0], "level {l} limit");
        assert!(frames
            .iter()
            .all(|f| finite(&f.position) && finite(&f.du) && finite(&f.dv)));
    }
}

#[test]
fn repeated_vertex_in_a_face_is_a_degenerate_edge() {
    // OpenSubdiv keeps a face that repeats a vertex: the repeated pair is a degenerate edge,
    // tagged non-manifold and so infinitely sharp, and the vertex is a non-manifold corner.
    let mesh = MeshBuilder::new()
        .positions(cube_positions())
        .faces(&[4, 4], &[0, 1, 3, 3, 1, 0, 4, 5])
        .build()
        .unwrap();
    let r = Refiner::new(&mesh, 3).unwrap();
    let t = &r.levels[0].topo;
    let e = t.find_edge(3, 3).expect("the degenerate edge exists");
    assert!(t.edge_nonmanifold[e as usize]);
    assert!(t.vert_tags[3].nonmanifold);
    assert!(crease_is_infinite(r.levels[0].edge_sharpness[e as usize]));
    for l in 0..=3 {
        let p = r.refine_positions(&mesh.positions, l);
        assert!(p.iter().all(finite), "level {l}");
    }
    // The corner stays where it is; the degenerate edge's edge point sits on it.
    let p1 = r.refine_positions(&mesh.positions, 1);
    assert_eq!(p1[3], mesh.positions[3]);
    // A face using the same edge twice (a vertex repeated apart) is non-manifold too.
    let mesh = MeshBuilder::new()
        .positions(cube_positions())
        .faces(&[4], &[0, 1, 0, 2])
        .build()
        .unwrap();
    let r = Refiner::new(&mesh, 2).unwrap();
    let t = &r.levels[0].topo;
    assert!(t.edge_nonmanifold[t.find_edge(0, 1).unwrap() as usize]);
    assert!(r.refine_positions(&mesh.positions, 2).iter().all(finite));
}

fn crease_is_infinite(s: f32) -> bool {
    s >= limitray::mesh::SHARPNESS_INFINITE
}

fn dist(p: &[f64; 3], q: &[f64; 3]) -> f64 {
    ((p[0] - q[0]).powi(2) + (p[1] - q[1]).powi(2) + (p[2] - q[2]).powi(2)).sqrt()
}
