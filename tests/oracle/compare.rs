//! limitray against Far on one mesh: uniform refinement face by face, and evaluation at
//! `(face, k, u, v)` samples.
//!
//! Tolerances (issue 12):
//! - refinement: 1e-6 of the bounding-box diagonal per face corner, levels 1..4. Both sides
//!   compute in double precision; the differences measured on agreeing meshes are ≤ 1e-8.
//! - evaluation on Far's exact patches (REGULAR: B-spline, boundary and corner patches after
//!   isolation, infinitely sharp creases as boundaries): position 1e-6 of the diagonal, first
//!   and second derivatives 1e-5 relative to the largest derivative of the sample (at least 1e-2
//!   of the diagonal, so that a vanishing derivative does not turn rounding into failures).
//! - Where Far approximates — its end caps (GREGORY_BASIS), every patch of a Chaikin mesh with
//!   holes or boundary interpolation `none` (see `compare`), and every patch at its maximum
//!   isolation level (10, where it also puts REGULAR patches over irregular boundary vertices)
//!   — our evaluation is compared with the exact limit instead: at dyadic samples, with the
//!   limit mask of the vertex that the point becomes after local refinement ([`super::exact`]),
//!   within 1e-8 of the diagonal (the vertex is refined at least 11 levels first, so that no
//!   semi-sharp feature is left at it; sharpness is f32, as in OpenSubdiv, and under Chaikin
//!   the averages are summed in ring order, which differs between the cut-outs: rounding of
//!   the sharpness moves points by up to 4.3e-9 of the diagonal, measured over 24,000 meshes). Far's position there is
//!   only checked to be near (1e-2 of the diagonal: its end caps on these random, jittered
//!   meshes are measured up to 1.0e-3 away from the exact limit over 20,000 meshes) and its
//!   worst difference is reported; derivatives are not compared there.

use super::far::{FarResult, FarSample};
use super::gen::GenMesh;
use limitray::mesh::obj::parse_obj;
use limitray::patch::{PatchOptions, PatchTable, Sample};
use limitray::refine::Refiner;
use limitray::FaceCoord;

pub const REFINE_TOL: f64 = 1e-6;
pub const EVAL_TOL: f64 = 1e-6;
pub const FAR_APPROX_TOL: f64 = 1e-2;
pub const EXACT_TOL: f64 = 1e-8;
/// Far's isolation level (benches/osd/osd_oracle.cpp's default).
pub const ISOLATION: u32 = 10;
pub const DERIV_TOL: f64 = 1e-5;

/// Worst differences seen (relative to the diagonal, or relative for derivatives).
#[derive(Clone, Debug, Default)]
pub struct Worst {
    pub refine: f64,
    pub eval: f64,
    pub end_cap: f64,
    pub d1: f64,
    pub d2: f64,
    pub samples: usize,
    pub end_cap_samples: usize,
    /// Worst difference from the exact limit (refined limit masks) where Far approximates.
    pub exact: f64,
    pub exact_samples: usize,
}

impl Worst {
    pub fn merge(&mut self, o: &Worst) {
        self.refine = self.refine.max(o.refine);
        self.eval = self.eval.max(o.eval);
        self.end_cap = self.end_cap.max(o.end_cap);
        self.d1 = self.d1.max(o.d1);
        self.d2 = self.d2.max(o.d2);
        self.samples += o.samples;
        self.end_cap_samples += o.end_cap_samples;
        self.exact = self.exact.max(o.exact);
        self.exact_samples += o.exact_samples;
    }
}

/// A difference: its category (kept while shrinking) and a description.
#[derive(Clone, Debug)]
pub struct Failure {
    pub category: &'static str,
    pub detail: String,
    /// The failing sample, when it is one.
    pub sample: Option<(usize, usize, f64, f64)>,
}

fn dist(a: [f64; 3], b: [f64; 3]) -> f64 {
    ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
}

fn norm(a: [f64; 3]) -> f64 {
    dist(a, [0.0; 3])
}

/// Compares refinement (levels 1..) and samples; the first failure found, and the worst
/// differences.
pub fn compare(
    m: &GenMesh,
    far: &FarResult,
    samples: &[(usize, usize, f64, f64)],
    single_crease: bool,
) -> (Worst, Option<Failure>) {
    let mut worst = Worst::default();
    let obj = m.to_obj();
    let mesh = match parse_obj(&obj, Some("oracle.obj")) {
        Ok(mesh) => mesh,
        Err(e) => {
            let f = Failure {
                category: "rejected",
                detail: format!("limitray rejects a mesh Far accepts: {e}"),
                sample: None,
            };
            return (worst, Some(f));
        }
    };
    let diag = mesh.diagonal();
    let levels = far.levels.len();
    if levels > 0 {
        let r = match Refiner::new(&mesh, levels) {
            Ok(r) => r,
            Err(e) => {
                let f = Failure {
                    category: "rejected",
                    detail: format!("limitray's refiner rejects a mesh Far accepts: {e}"),
                    sample: None,
                };
                return (worst, Some(f));
            }
        };
        let all = r.interpolate_all(mesh.positions.as_flattened(), 3);
        // Far numbers child faces as limitray does (by parent, then by the parent's corner)
        // but rotates the vertices of children of quads, which changes the order of
        // grandchildren: follow the correspondence level by level. `map[f]` = (our face,
        // rotation r) with Far's vertex j = our vertex (j + r) of that face.
        let mut map: Vec<(usize, usize)> = (0..mesh.num_faces()).map(|f| (f, 0)).collect();
        let mut far_sizes: Vec<usize> = m.faces.iter().map(|f| f.len()).collect();
        for (l, fl) in far.levels.iter().enumerate() {
            let parent = &r.levels[l];
            let lvl = &r.levels[l + 1];
            let pos = &all[l + 1];
            let p = |v: u32| {
                let i = v as usize * 3;
                [pos[i], pos[i + 1], pos[i + 2]]
            };
            if lvl.num_faces() != fl.faces.len() {
                let f = Failure {
                    category: "refine",
                    detail: format!(
                        "level {}: {} faces, Far {}",
                        l + 1,
                        lvl.num_faces(),
                        fl.faces.len()
                    ),
                    sample: None,
                };
                return (worst, Some(f));
            }
            let mut next = vec![(usize::MAX, 0); fl.faces.len()];
            let mut far_first = 0;
            for (f, &n) in far_sizes.iter().enumerate() {
                let (g, rot) = map[f];
                let our_first = parent.topo.face_offsets[g] as usize;
                for j in 0..n {
                    next[far_first + j] = (our_first + (j + rot) % n, 0);
                }
                far_first += n;
            }
            let mut level_worst = (0.0f64, 0usize);
            for (i, (hole, fv)) in fl.faces.iter().enumerate() {
                let g = next[i].0;
                let ours = lvl.topo.face_vertices(g);
                let n = fv.len();
                if ours.len() != n {
                    let f = Failure {
                        category: "refine",
                        detail: format!("level {}: face {i} differs in size", l + 1),
                        sample: None,
                    };
                    return (worst, Some(f));
                }
                let (d, rot) = (0..n)
                    .map(|rot| {
                        let d = (0..n)
                            .map(|j| dist(p(ours[(j + rot) % n]), fl.positions[fv[j] as usize]))
                            .fold(0.0, f64::max);
                        (d, rot)
                    })
                    .fold((f64::INFINITY, 0), |a, b| if b.0 < a.0 { b } else { a });
                next[i].1 = rot;
                if lvl.face_hole[g] {
                    continue;
                }
                if *hole {
                    let f = Failure {
                        category: "refine",
                        detail: format!("level {}: face {i} is a hole for Far only", l + 1),
                        sample: None,
                    };
                    return (worst, Some(f));
                }
                let d = d / diag;
                if d > level_worst.0 {
                    level_worst = (d, i);
                }
            }
            map = next;
            far_sizes = fl.faces.iter().map(|f| f.1.len()).collect();
            worst.refine = worst.refine.max(level_worst.0);
            if level_worst.0 > REFINE_TOL {
                let f = Failure {
                    category: "refine",
                    detail: format!(
                        "level {}: face {} off by {:.2e} of the diagonal",
                        l + 1,
                        level_worst.1,
                        level_worst.0
                    ),
                    sample: None,
                };
                return (worst, Some(f));
            }
        }
    }
    let table = match PatchTable::new(
        &mesh,
        PatchOptions {
            single_crease,
            ..PatchOptions::default()
        },
    ) {
        Ok(t) => t,
        Err(e) => {
            let f = Failure {
                category: "rejected",
                detail: format!("limitray's patch table rejects a mesh Far accepts: {e}"),
                sample: None,
            };
            return (worst, Some(f));
        }
    };
    // Far's adaptive patches on Chaikin meshes with faces that its adaptive refinement leaves
    // unrefined (holes, and boundary faces under boundary interpolation `none`) differ from the
    // limit of Far's own uniform refinement (which limitray matches to 1e-16 on them) by up to
    // 1e-3 of the diagonal next to those faces: Chaikin's rule averages the sharpness of the
    // edges around a vertex, and there Far's sparse levels lack some of them. The same meshes
    // without the holes, or with the uniform rule, agree. There the exact limit is the
    // reference (tests/osd_oracle.rs, `chaikin_with_boundary_none_far_is_approximate`,
    // `chaikin_next_to_a_hole_far_is_approximate`).
    let far_exact = !(m.chaikin && (m.boundary == 0 || !m.holes.is_empty()));
    let mut failure = None;
    for (&s, theirs) in samples.iter().zip(&far.samples) {
        let ours = table
            .eval(FaceCoord::new(s.0 as u32, s.1 as u32, s.2, s.3))
            .ok();
        let exact = || super::exact::limit_at(&mesh, s.0, s.1, s.2, s.3);
        if let Some(f) = check_sample(&ours, theirs, diag, far_exact, exact, &mut worst) {
            if failure.is_none() {
                failure = Some(Failure {
                    category: f.0,
                    detail: format!("sample {} {} {:?} {:?}: {}", s.0, s.1, s.2, s.3, f.1),
                    sample: Some(s),
                });
            }
        }
    }
    (worst, failure)
}

fn check_sample(
    ours: &Option<Sample>,
    theirs: &Option<FarSample>,
    diag: f64,
    far_exact: bool,
    exact: impl FnOnce() -> Option<[f64; 3]>,
    worst: &mut Worst,
) -> Option<(&'static str, String)> {
    let (o, t) = match (ours, theirs) {
        (None, None) => return None,
        (Some(_), None) => return Some(("coverage", "limitray has a patch, Far none".into())),
        (None, Some(_)) => return Some(("coverage", "Far has a patch, limitray none".into())),
        (Some(o), Some(t)) => (o, t),
    };
    worst.samples += 1;
    let e = dist(o.p, t.d[0]) / diag;
    if t.kind != "REGULAR" || t.depth >= ISOLATION || !far_exact {
        worst.end_cap_samples += 1;
        worst.end_cap = worst.end_cap.max(e);
        if let Some(x) = exact() {
            worst.exact_samples += 1;
            let ex = dist(o.p, x) / diag;
            worst.exact = worst.exact.max(ex);
            if ex > EXACT_TOL {
                return Some((
                    "exact",
                    format!(
                        "position off the exact limit by {ex:.2e} of the diagonal (Far {} level {} off by {e:.2e})",
                        t.kind, t.depth
                    ),
                ));
            }
        }
        return (e > FAR_APPROX_TOL).then(|| {
            (
                "eval",
                format!(
                    "position off by {e:.2e} of the diagonal in Far's {} patch at level {}",
                    t.kind, t.depth
                ),
            )
        });
    }
    worst.eval = worst.eval.max(e);
    if e > EVAL_TOL {
        return Some((
            "eval",
            format!(
                "position off by {e:.2e} of the diagonal (Far {} level {}): ours {:?}, Far {:?}",
                t.kind, t.depth, o.p, t.d[0]
            ),
        ));
    }
    let s1 = norm(t.d[1]).max(norm(t.d[2])).max(1e-2 * diag);
    let e1 = dist(o.du, t.d[1]).max(dist(o.dv, t.d[2])) / s1;
    worst.d1 = worst.d1.max(e1);
    if e1 > DERIV_TOL {
        return Some((
            "d1",
            format!(
                "first derivatives off by {e1:.2e} relative (Far level {}): ours {:?} {:?}, Far {:?} {:?}",
                t.depth, o.du, o.dv, t.d[1], t.d[2]
            ),
        ));
    }
    let s2 = norm(t.d[3])
        .max(norm(t.d[4]))
        .max(norm(t.d[5]))
        .max(1e-2 * diag);
    let e2 = dist(o.duu, t.d[3])
        .max(dist(o.duv, t.d[4]))
        .max(dist(o.dvv, t.d[5]))
        / s2;
    worst.d2 = worst.d2.max(e2);
    if e2 > DERIV_TOL {
        return Some((
            "d2",
            format!(
                "second derivatives off by {e2:.2e} relative (Far level {}): ours {:?} {:?} {:?}, Far {:?} {:?} {:?}",
                t.depth, o.duu, o.duv, o.dvv, t.d[3], t.d[4], t.d[5]
            ),
        ));
    }
    None
}

/// Loop refinement of `m` (`Scheme::Loop`) against Far's `SCHEME_LOOP` levels, face by face in
/// Far's order (both number a level's faces by parent, then by child: corners at the parent's
/// vertices 0, 1, 2, then the middle), each face's corners matched up to rotation; vertex and
/// face counts and hole flags must agree. Tolerance [`REFINE_TOL`] of the diagonal.
pub fn compare_loop_refinement(m: &GenMesh, far: &FarResult) -> (Worst, Option<Failure>) {
    let mut worst = Worst::default();
    let fail = |detail: String| Failure {
        category: "refine",
        detail,
        sample: None,
    };
    let mut mesh = match parse_obj(&m.to_obj(), Some("oracle.obj")) {
        Ok(mesh) => mesh,
        Err(e) => {
            return (
                worst,
                Some(Failure {
                    category: "rejected",
                    detail: format!("limitray rejects a mesh Far accepts: {e}"),
                    sample: None,
                }),
            )
        }
    };
    mesh.options.scheme = limitray::mesh::Scheme::Loop;
    let diag = mesh.diagonal();
    let r = match Refiner::new(&mesh, far.levels.len()) {
        Ok(r) => r,
        Err(e) => {
            return (
                worst,
                Some(Failure {
                    category: "rejected",
                    detail: format!("limitray's Loop refiner rejects a mesh Far accepts: {e}"),
                    sample: None,
                }),
            )
        }
    };
    let all = r.interpolate_all(mesh.positions.as_flattened(), 3);
    for (l, fl) in far.levels.iter().enumerate() {
        let lvl = &r.levels[l + 1];
        let pos = &all[l + 1];
        let p = |v: u32| {
            let i = v as usize * 3;
            [pos[i], pos[i + 1], pos[i + 2]]
        };
        if lvl.num_vertices() != fl.positions.len() || lvl.num_faces() != fl.faces.len() {
            let d = format!(
                "level {}: {} vertices and {} faces, Far {} and {}",
                l + 1,
                lvl.num_vertices(),
                lvl.num_faces(),
                fl.positions.len(),
                fl.faces.len()
            );
            return (worst, Some(fail(d)));
        }
        for (i, (hole, fv)) in fl.faces.iter().enumerate() {
            let ours = lvl.topo.face_vertices(i);
            if ours.len() != fv.len() || lvl.face_hole[i] != *hole {
                let d = format!("level {}: face {i} differs in size or hole flag", l + 1);
                return (worst, Some(fail(d)));
            }
            let n = fv.len();
            let d = (0..n)
                .map(|rot| {
                    (0..n)
                        .map(|j| {
                            dist(
                                p(ours[(j + rot) % n]),
                                far.levels[l].positions[fv[j] as usize],
                            )
                        })
                        .fold(0.0, f64::max)
                })
                .fold(f64::INFINITY, f64::min)
                / diag;
            worst.refine = worst.refine.max(d);
            if d > REFINE_TOL {
                let d = format!(
                    "level {}: face {i} is {d:.2e} of the diagonal from Far's",
                    l + 1
                );
                return (worst, Some(fail(d)));
            }
        }
    }
    (worst, None)
}
