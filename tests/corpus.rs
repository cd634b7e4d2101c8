//! Every Catmull-Clark model of OpenSubdiv's regression corpus (../shared/models/opensubdiv)
//! loads, refines to level 2 with finite positions, and has finite limit frames at level 1 —
//! the shapes whose faces repeat a vertex (`f 4 3 5 5`, degenerate edges, as OpenSubdiv keeps
//! them) included.

mod common;

use limitray::mesh::obj::read_obj;
use limitray::refine::limit::LimitStencils;
use limitray::refine::Refiner;
use std::time::Instant;

/// Meshes with more level-1 vertices than this are refined but skip the limit frames (none of
/// the corpus does today: the whole test takes well under a second).
const MAX_LIMIT_VERTICES: usize = 50_000;

fn finite(p: &[f64; 3]) -> bool {
    p.iter().all(|c| c.is_finite())
}

#[test]
fn every_catmark_model_loads_refines_and_has_finite_limits() {
    let Some(models) = common::shared_models() else {
        return;
    };
    let files = common::catmark_files(&models);
    assert!(
        files.len() >= 80,
        "expected the 87 catmark models, found {}",
        files.len()
    );

    let start = Instant::now();
    let mut failures: Vec<String> = Vec::new();
    let (mut loaded, mut framed) = (0usize, 0usize);
    println!(
        "{:<34} {:>7} {:>7} {:>9} {:>9} {:>8}  result",
        "model", "verts", "faces", "L2 verts", "L1 frames", "ms"
    );
    for path in &files {
        let name = path.file_stem().unwrap().to_str().unwrap().to_string();
        let t0 = Instant::now();
        let mesh = match read_obj(path) {
            Ok(m) => m,
            Err(e) => {
                failures.push(format!("{name}: failed to load: {e}"));
                continue;
            }
        };
        loaded += 1;
        let refiner = match Refiner::new(&mesh, 2) {
            Ok(r) => r,
            Err(e) => {
                failures.push(format!("{name}: Refiner::new failed: {e}"));
                continue;
            }
        };
        let p2 = refiner.refine_positions(&mesh.positions, 2);
        if let Some(i) = p2.iter().position(|p| !finite(p)) {
            failures.push(format!(
                "{name}: level-2 vertex {i} is not finite: {:?}",
                p2[i]
            ));
            continue;
        }
        let l1 = &refiner.levels[1];
        let frames_note = if l1.num_vertices() <= MAX_LIMIT_VERTICES {
            let p1 = refiner.refine_positions(&mesh.positions, 1);
            let frames = LimitStencils::new(l1, mesh.options.crease_method).frames(&p1);
            assert_eq!(frames.len(), l1.num_vertices(), "{name}: frame count");
            if let Some(i) = frames
                .iter()
                .position(|f| !(finite(&f.position) && finite(&f.du) && finite(&f.dv)))
            {
                failures.push(format!(
                    "{name}: level-1 limit frame {i} is not finite: {:?}",
                    frames[i]
                ));
                continue;
            }
            framed += 1;
            frames.len().to_string()
        } else {
            "skipped".to_string()
        };
        println!(
            "{name:<34} {:>7} {:>7} {:>9} {:>9} {:>8}  ok",
            mesh.num_vertices(),
            mesh.num_faces(),
            p2.len(),
            frames_note,
            t0.elapsed().as_millis()
        );
    }
    println!(
        "{} models: {loaded} loaded, {framed} with limit frames, {:.2} s",
        files.len(),
        start.elapsed().as_secs_f64()
    );
    assert!(
        failures.is_empty(),
        "{} failure(s):\n{}",
        failures.len(),
        failures.join("\n")
    );
}
