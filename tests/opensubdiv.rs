//! Uniform refinement against OpenSubdiv 3.5 Far itself, on every catmark shape of the corpus
//! (Catmull-Clark) and every loop shape (Loop, `--loop`).
//!
//! `scripts/setup-osd.sh` (run by `.ci/run`) installs Debian's libosd-dev and builds
//! `target/osd/osd_refine_bench`, a small program of ours that refines a mesh with Far's
//! `TopologyRefiner` + `PrimvarRefiner` and dumps the last level. Without it the test skips
//! with a note, except under CI (`CI` set), where a missing reference is a failure.
//!
//! Tolerance: 1e-6 of the bounding-box diagonal, order-free (Far orders edges differently).
//! Far computes in single precision; the largest difference measured over the corpus at level
//! 2 is 8.7e-7 (catmark_flap), typical 2e-8 to 6e-7. Face counts (holes left out) must match.

mod common;

use limitray::mesh::obj::read_obj;
use limitray::mesh::{CreaseMethod, Options, Scheme};
use limitray::refine::Refiner;
use std::path::{Path, PathBuf};
use std::process::Command;

fn reference_binary() -> Option<PathBuf> {
    common::osd_binary("osd_refine_bench")
}

fn far_refine(
    bin: &Path,
    mesh: &Path,
    level: usize,
    chaikin: bool,
    loop_scheme: bool,
    out: &Path,
) -> (Vec<[f64; 3]>, usize) {
    let mut cmd = Command::new(bin);
    cmd.arg(mesh)
        .arg(level.to_string())
        .args(["--reps", "1", "--dump"])
        .arg(out);
    if chaikin {
        cmd.arg("--chaikin");
    }
    if loop_scheme {
        cmd.arg("--loop");
    }
    let st = cmd.output().unwrap();
    assert!(
        st.status.success(),
        "{}: {}",
        mesh.display(),
        String::from_utf8_lossy(&st.stderr)
    );
    (common::read_points(out), common::count_faces(out))
}

#[test]
fn refinement_matches_opensubdiv_far_on_corpus() {
    let Some(models) = common::shared_models() else {
        return;
    };
    let Some(bin) = reference_binary() else {
        return;
    };
    let tmp = std::env::temp_dir().join(format!("limitray-osd-{}", std::process::id()));
    std::fs::create_dir_all(&tmp).unwrap();
    let files = common::catmark_files(&models);
    let mut failures = Vec::new();
    let mut compared = 0;
    for path in &files {
        let name = path.file_stem().unwrap().to_str().unwrap();
        let mut mesh = read_obj(path).unwrap();
        // Far applies no hierarchical edits (catmark_square_hedit*): compared without them.
        mesh.edits.clear();
        // Every shape with the uniform rule (or its own tag); creased ones with Chaikin too.
        let mut runs = vec![false];
        if !mesh.creases.is_empty() && mesh.options.crease_method == CreaseMethod::Uniform {
            runs.push(true);
        }
        for chaikin in runs {
            let level = if mesh.num_faces() > 5000 { 1 } else { 2 };
            let mut opts: Options = mesh.options;
            if chaikin {
                opts.crease_method = CreaseMethod::Chaikin;
            }
            let r = Refiner::with_options(&mesh, opts, level).unwrap();
            let ours = r.refine_positions(&mesh.positions, level);
            let lvl = &r.levels[level];
            let our_faces = lvl.face_hole.iter().filter(|&&h| !h).count();
            let (theirs, their_faces) = far_refine(
                &bin,
                path,
                level,
                chaikin,
                false,
                &tmp.join(format!("{name}.obj")),
            );
            let diag = mesh.diagonal();
            let d = common::max_nearest_distance(&ours, &theirs)
                .max(common::max_nearest_distance(&theirs, &ours))
                / diag;
            let ok = ours.len() == theirs.len() && our_faces == their_faces && d <= 1e-6;
            println!(
                "{name}{} level {level}: vertices {}/{} faces {our_faces}/{their_faces} max {d:.1e} {}",
                if chaikin { " (chaikin)" } else { "" },
                ours.len(),
                theirs.len(),
                if ok { "ok" } else { "FAIL" }
            );
            if !ok {
                failures.push(format!("{name} chaikin={chaikin}"));
            }
            compared += 1;
        }
    }
    let _ = std::fs::remove_dir_all(&tmp);
    assert!(compared >= 83, "compared only {compared}");
    assert!(failures.is_empty(), "differ from Far: {failures:?}");
}

/// Loop refinement (`Scheme::Loop`) against Far's `SCHEME_LOOP` on every loop shape of the
/// corpus at levels 1–3 (1 for the 360-valence pole), uniform and (where creased) Chaikin, with
/// the same tolerance and reasons as the Catmull-Clark test above: 1e-6 of the diagonal,
/// order-free, equal vertex and face counts.
#[test]
fn loop_refinement_matches_opensubdiv_far_on_corpus() {
    let Some(models) = common::shared_models() else {
        return;
    };
    let Some(bin) = reference_binary() else {
        return;
    };
    let tmp = std::env::temp_dir().join(format!("limitray-osd-loop-{}", std::process::id()));
    std::fs::create_dir_all(&tmp).unwrap();
    let files = common::corpus_files(&models, "loop_");
    let mut failures = Vec::new();
    let mut compared = 0;
    let mut worst = 0.0f64;
    for path in &files {
        let name = path.file_stem().unwrap().to_str().unwrap();
        let mut mesh = read_obj(path).unwrap();
        // Far applies no hierarchical edits (catmark_square_hedit*): compared without them.
        mesh.edits.clear();
        let mut runs = vec![false];
        if !(mesh.creases.is_empty() && mesh.corners.is_empty())
            && mesh.options.crease_method == CreaseMethod::Uniform
        {
            runs.push(true);
        }
        let top = if mesh.num_vertices() > 300 { 2 } else { 3 };
        for chaikin in runs {
            let mut opts: Options = mesh.options;
            opts.scheme = Scheme::Loop;
            if chaikin {
                opts.crease_method = CreaseMethod::Chaikin;
            }
            let r = Refiner::with_options(&mesh, opts, top).unwrap();
            for level in 1..=top {
                let ours = r.refine_positions(&mesh.positions, level);
                let lvl = &r.levels[level];
                let our_faces = lvl.face_hole.iter().filter(|&&h| !h).count();
                let (theirs, their_faces) = far_refine(
                    &bin,
                    path,
                    level,
                    chaikin,
                    true,
                    &tmp.join(format!("{name}.obj")),
                );
                let diag = mesh.diagonal();
                let d = common::max_nearest_distance(&ours, &theirs)
                    .max(common::max_nearest_distance(&theirs, &ours))
                    / diag;
                worst = worst.max(d);
                let ok = ours.len() == theirs.len() && our_faces == their_faces && d <= 1e-6;
                println!(
                    "{name}{} level {level}: vertices {}/{} faces {our_faces}/{their_faces} max {d:.1e} {}",
                    if chaikin { " (chaikin)" } else { "" },
                    ours.len(),
                    theirs.len(),
                    if ok { "ok" } else { "FAIL" }
                );
                if !ok {
                    failures.push(format!("{name} level {level} chaikin={chaikin}"));
                }
                compared += 1;
            }
        }
    }
    let _ = std::fs::remove_dir_all(&tmp);
    println!("worst {worst:.2e} of the diagonal over {compared} comparisons");
    assert!(compared >= 90, "compared only {compared}");
    assert!(failures.is_empty(), "differ from Far: {failures:?}");
}
