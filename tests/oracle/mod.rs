//! The differential oracle: random meshes ([`gen`]), OpenSubdiv Far's answers ([`far`]),
//! limitray's against them ([`compare`]), and shrinking of a failing mesh to a minimal one.
#![allow(dead_code)]

pub mod compare;
pub mod exact;
pub mod far;
pub mod gen;

use compare::{Failure, Worst};
use gen::{Features, GenMesh, Rng};
use std::path::Path;

/// Samples evaluated per mesh.
pub const SAMPLES: usize = 40;

/// One mesh's case: the mesh, its samples, the refinement depth, the patch option.
#[derive(Clone, Debug)]
pub struct Case {
    pub mesh: GenMesh,
    pub samples: Vec<(usize, usize, f64, f64)>,
    pub levels: usize,
    pub single_crease: bool,
}

impl Case {
    /// The case of `seed`.
    pub fn random(seed: u64, features: Features) -> Case {
        let mesh = gen::generate(seed, features);
        let mut rng = Rng::new(seed.wrapping_mul(31).wrapping_add(7));
        let samples = gen::samples(&mesh, &mut rng, SAMPLES);
        // Level 4 of a 16-face mesh has 4096 faces: enough, and quick.
        let levels = if mesh.faces.len() <= 16 { 4 } else { 3 };
        Case {
            mesh,
            samples,
            levels,
            single_crease: seed.is_multiple_of(2),
        }
    }
}

/// Result of one case: `None` when Far refuses the mesh (the generator's reject).
pub fn run(bin: &Path, dir: &Path, case: &Case) -> Option<(Worst, Option<Failure>)> {
    let path = dir.join(format!(
        "case-{:?}-{}.obj",
        std::thread::current().id(),
        std::process::id()
    ));
    let path = Path::new(&path.to_string_lossy().replace(['(', ')'], "")).to_path_buf();
    let far = far::run(bin, &path, &case.mesh.to_obj(), case.levels, &case.samples).ok()?;
    let _ = std::fs::remove_file(&path);
    Some(compare::compare(
        &case.mesh,
        &far,
        &case.samples,
        case.single_crease,
    ))
}

fn still_fails(bin: &Path, dir: &Path, case: &Case, category: &str) -> Option<Failure> {
    match run(bin, dir, case) {
        Some((_, Some(f))) if f.category == category => Some(f),
        _ => None,
    }
}

fn remove_face(m: &GenMesh, f: usize) -> GenMesh {
    let mut out = m.clone();
    out.faces.remove(f);
    out.holes = m
        .holes
        .iter()
        .filter(|&&h| h as usize != f)
        .map(|&h| if h as usize > f { h - 1 } else { h })
        .collect();
    out.compact();
    out
}

/// Candidate simplifications of `case`, simplest-first.
fn candidates(case: &Case) -> Vec<Case> {
    let m = &case.mesh;
    let mut out = Vec::new();
    let with = |mesh: GenMesh| Case {
        mesh,
        ..case.clone()
    };
    for f in (0..m.faces.len()).rev() {
        if m.faces.len() <= 1 {
            break;
        }
        let mut c = with(remove_face(m, f));
        // Keep the failing sample on its face.
        let ok = c.samples.iter_mut().all(|s| {
            if s.0 == f {
                return false;
            }
            if s.0 > f {
                s.0 -= 1;
            }
            true
        });
        if ok {
            out.push(c);
        }
    }
    for e in m.creases.keys() {
        let mut mm = m.clone();
        mm.creases.remove(e);
        out.push(with(mm));
    }
    for v in m.corners.keys() {
        let mut mm = m.clone();
        mm.corners.remove(v);
        out.push(with(mm));
    }
    for i in 0..m.holes.len() {
        let mut mm = m.clone();
        mm.holes.remove(i);
        out.push(with(mm));
    }
    for (e, &s) in &m.creases {
        for simpler in [10.0f32, s.ceil(), s.floor()] {
            if simpler != s && simpler > 0.0 {
                let mut mm = m.clone();
                mm.creases.insert(*e, simpler);
                out.push(with(mm));
            }
        }
    }
    if m.boundary != 1 {
        let mut mm = m.clone();
        mm.boundary = 1;
        out.push(with(mm));
    }
    if m.chaikin {
        let mut mm = m.clone();
        mm.chaikin = false;
        out.push(with(mm));
    }
    if case.levels > 1 {
        out.push(Case {
            levels: case.levels - 1,
            ..case.clone()
        });
    }
    out
}

/// Shrinks a failing case to one where no single simplification still fails the same way.
pub fn shrink(bin: &Path, dir: &Path, case: &Case, failure: &Failure) -> (Case, Failure) {
    let mut cur = case.clone();
    let mut fail = failure.clone();
    if let Some(s) = failure.sample {
        cur.samples = vec![s];
    }
    // Eval failures do not need the refinement comparison; refine failures need no samples.
    if failure.category == "refine" {
        cur.samples.clear();
    } else {
        cur.levels = 0;
    }
    'outer: for _ in 0..200 {
        for c in candidates(&cur) {
            if let Some(f) = still_fails(bin, dir, &c, fail.category) {
                cur = c;
                fail = f;
                continue 'outer;
            }
        }
        break;
    }
    (cur, fail)
}
