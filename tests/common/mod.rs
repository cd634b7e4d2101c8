//! Helpers shared by the integration tests: locating ../shared and comparing point sets.
#![allow(dead_code)]

use std::path::PathBuf;

/// `../shared/models` beside the repository, or `None` (with a printed note) when absent.
pub fn shared_models() -> Option<PathBuf> {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../shared/models");
    if dir.is_dir() {
        Some(dir)
    } else {
        eprintln!("note: skipping: ../shared/models is not present beside the repository");
        None
    }
}

/// Reads the `v` lines of an OBJ file (used for reference files only).
pub fn read_points(path: &std::path::Path) -> Vec<[f64; 3]> {
    let text = std::fs::read_to_string(path).unwrap();
    text.lines()
        .filter_map(|l| l.strip_prefix("v "))
        .map(|l| {
            let c: Vec<f64> = l.split_whitespace().map(|x| x.parse().unwrap()).collect();
            [c[0], c[1], c[2]]
        })
        .collect()
}

/// Counts the `f` lines of an OBJ file.
pub fn count_faces(path: &std::path::Path) -> usize {
    std::fs::read_to_string(path)
        .unwrap()
        .lines()
        .filter(|l| l.starts_with("f "))
        .count()
}

/// Largest distance from a point of `a` to its nearest point in `b` (brute force with an
/// x-sorted window; fine for the few thousand points of the baselines).
pub fn max_nearest_distance(a: &[[f64; 3]], b: &[[f64; 3]]) -> f64 {
    let mut sorted: Vec<[f64; 3]> = b.to_vec();
    sorted.sort_by(|p, q| p[0].total_cmp(&q[0]));
    let mut worst = 0.0f64;
    for p in a {
        let mut best = f64::INFINITY;
        let start = sorted.partition_point(|q| q[0] < p[0]);
        for q in sorted[start..].iter() {
            if q[0] - p[0] > best {
                break;
            }
            best = best.min(dist(p, q));
        }
        for q in sorted[..start].iter().rev() {
            if p[0] - q[0] > best {
                break;
            }
            best = best.min(dist(p, q));
        }
        worst = worst.max(best);
    }
    worst
}

/// Euclidean distance.
pub fn dist(p: &[f64; 3], q: &[f64; 3]) -> f64 {
    ((p[0] - q[0]).powi(2) + (p[1] - q[1]).powi(2) + (p[2] - q[2]).powi(2)).sqrt()
}

/// The Catmull-Clark shapes of the OpenSubdiv corpus (`catmark_*.obj`), sorted by name.
pub fn catmark_files(models: &std::path::Path) -> Vec<PathBuf> {
    corpus_files(models, "catmark_")
}

/// The corpus shapes whose names start with `prefix` (`catmark_`, `loop_`), sorted.
#[allow(dead_code)]
pub fn corpus_files(models: &std::path::Path, prefix: &str) -> Vec<PathBuf> {
    let mut files: Vec<PathBuf> = std::fs::read_dir(models.join("opensubdiv"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| {
            let name = p.file_name().unwrap().to_str().unwrap();
            name.starts_with(prefix) && name.ends_with(".obj")
        })
        .collect();
    files.sort();
    files
}

/// Faces of the test cube (side 2, centred at the origin), counter-clockwise from outside.
pub const CUBE_FACES: [u32; 24] = [
    0, 1, 3, 2, 2, 3, 5, 4, 4, 5, 7, 6, 6, 7, 1, 0, 1, 7, 5, 3, 6, 0, 2, 4,
];

/// The twelve edges of the test cube.
pub const CUBE_EDGES: [(u32, u32); 12] = [
    (0, 1),
    (1, 3),
    (3, 2),
    (2, 0),
    (4, 5),
    (5, 7),
    (7, 6),
    (6, 4),
    (0, 6),
    (1, 7),
    (2, 4),
    (3, 5),
];

/// A builder holding the test cube, to add tags to.
pub fn cube_builder() -> limitray::mesh::MeshBuilder {
    // The same vertices as the library's rounded box, here without tags.
    let p = limitray::mesh::shapes::rounded_box(0.0).positions;
    limitray::mesh::MeshBuilder::new()
        .positions(p)
        .faces(&[4; 6], &CUBE_FACES)
}

/// True if the control mesh is closed and manifold: no holes, every edge has two faces, no
/// non-manifold vertex.
pub fn closed(mesh: &limitray::mesh::ControlMesh) -> bool {
    let topo =
        limitray::mesh::Topology::new(mesh.num_vertices(), &mesh.face_offsets, &mesh.face_verts)
            .unwrap();
    mesh.holes.is_empty()
        && (0..topo.num_edges())
            .all(|e| topo.edge_face_count(e as u32) == 2 && !topo.edge_nonmanifold[e])
        && topo.vert_tags.iter().all(|t| !t.nonmanifold)
}

/// The `limitray` binary as a command, ready for arguments.
pub fn limitray_command() -> std::process::Command {
    std::process::Command::new(env!("CARGO_BIN_EXE_limitray"))
}

/// Runs the `limitray` binary with `args`, feeding `stdin` when given: the one way the tests run
/// the command line.
pub fn run_limitray<S: AsRef<std::ffi::OsStr>>(
    args: &[S],
    stdin: Option<&[u8]>,
) -> std::process::Output {
    use std::io::Write;
    use std::process::Stdio;
    let mut cmd = limitray_command();
    cmd.args(args).stdout(Stdio::piped()).stderr(Stdio::piped());
    cmd.stdin(if stdin.is_some() {
        Stdio::piped()
    } else {
        Stdio::null()
    });
    let mut child = cmd.spawn().expect("failed to run limitray");
    if let Some(input) = stdin {
        let mut pipe = child.stdin.take().expect("piped stdin");
        // The tool may exit before reading everything (bad arguments): ignore a broken pipe.
        let _ = pipe.write_all(input);
    }
    child
        .wait_with_output()
        .expect("failed to wait for limitray")
}

/// One of the OpenSubdiv reference programs built by `scripts/setup-osd.sh` (`osd_oracle`,
/// `osd_refine_bench`) under `target/osd/`; `None` (with a note) when it is not built, except
/// under CI (`CI` set), where a missing reference is a failure.
pub fn osd_binary(name: &str) -> Option<std::path::PathBuf> {
    let bin = std::path::PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("target/osd")
        .join(name);
    if bin.is_file() {
        return Some(bin);
    }
    if std::env::var_os("CI").is_some() {
        panic!(
            "CI: {} is missing; .ci/run must run scripts/setup-osd.sh",
            bin.display()
        );
    }
    eprintln!("note: skipping: OpenSubdiv reference {name} not built (bash scripts/setup-osd.sh)");
    None
}
