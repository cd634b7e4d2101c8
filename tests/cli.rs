//! End-to-end tests of the `limitray` binary: `info`, `refine` and its options, output to a
//! file and to standard output, and the exit code and `file:line:` messages of bad input.

mod common;

use std::path::{Path, PathBuf};
use std::process::Output;
use std::sync::atomic::{AtomicUsize, Ordering};

/// A scratch directory under the system temporary directory, removed when dropped.
struct TempDir(PathBuf);

impl TempDir {
    fn new(tag: &str) -> Self {
        static COUNTER: AtomicUsize = AtomicUsize::new(0);
        let n = COUNTER.fetch_add(1, Ordering::SeqCst);
        let nanos = std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map(|d| d.subsec_nanos())
            .unwrap_or(0);
        let dir = std::env::temp_dir().join(format!(
            "limitray-cli-{tag}-{}-{n}-{nanos}",
            std::process::id()
        ));
        std::fs::create_dir_all(&dir).unwrap();
        TempDir(dir)
    }

    /// Writes `text` to `name` in the directory and returns its path.
    fn file(&self, name: &str, text: &str) -> PathBuf {
        let p = self.0.join(name);
        std::fs::write(&p, text).unwrap();
        p
    }

    fn path(&self, name: &str) -> PathBuf {
        self.0.join(name)
    }
}

impl Drop for TempDir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

/// The cube of OpenSubdiv's `catmark_cube.obj` (8 vertices, 6 quads).
const CUBE: &str = "\
# unit cube
v -0.5 -0.5 0.5
v 0.5 -0.5 0.5
v -0.5 0.5 0.5
v 0.5 0.5 0.5
v -0.5 0.5 -0.5
v 0.5 0.5 -0.5
v -0.5 -0.5 -0.5
v 0.5 -0.5 -0.5
f 1 2 4 3
f 3 4 6 5
f 5 6 8 7
f 7 8 2 1
f 2 8 6 4
f 7 1 3 5
";

fn limitray(args: &[&dyn AsRef<std::ffi::OsStr>]) -> Output {
    let args: Vec<&std::ffi::OsStr> = args.iter().map(|a| a.as_ref()).collect();
    common::run_limitray(&args, None)
}

fn stdout(o: &Output) -> String {
    String::from_utf8_lossy(&o.stdout).into_owned()
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

fn assert_success(o: &Output, what: &str) {
    assert!(
        o.status.success(),
        "{what}: exit {:?}\nstdout:\n{}\nstderr:\n{}",
        o.status.code(),
        stdout(o),
        stderr(o)
    );
}

fn assert_exit_2(o: &Output, what: &str) -> String {
    let err = stderr(o);
    assert_eq!(
        o.status.code(),
        Some(2),
        "{what}: expected exit code 2\nstdout:\n{}\nstderr:\n{err}",
        stdout(o)
    );
    assert!(
        err.contains("error: "),
        "{what}: no `error:` line on stderr: {err}"
    );
    err
}

/// Counts `v` and `f` lines of OBJ text.
fn count_v_f(text: &str) -> (usize, usize) {
    let v = text.lines().filter(|l| l.starts_with("v ")).count();
    let f = text.lines().filter(|l| l.starts_with("f ")).count();
    (v, f)
}

fn points_of(text: &str) -> Vec<[f64; 3]> {
    text.lines()
        .filter_map(|l| l.strip_prefix("v "))
        .map(|l| {
            let c: Vec<f64> = l
                .split_whitespace()
                .map(|x| x.parse().expect("number"))
                .collect();
            assert_eq!(c.len(), 3, "v line with {} numbers: {l}", c.len());
            [c[0], c[1], c[2]]
        })
        .collect()
}

/// Runs `refine` on `mesh` with extra arguments, writing to a file, and returns its text.
fn refine_to_file(dir: &TempDir, mesh: &Path, out_name: &str, extra: &[&str]) -> String {
    refine_to_file_cmd(dir, "refine", mesh, out_name, extra)
}

#[test]
fn info_prints_json_with_counts() {
    let dir = TempDir::new("info");
    let mesh = dir.file("cube.obj", CUBE);
    let o = limitray(&[&"info", &mesh]);
    assert_success(&o, "info");
    let json: serde_json::Value = serde_json::from_str(&stdout(&o)).expect("info prints JSON");
    assert_eq!(json["vertices"], 8, "{json}");
    assert_eq!(json["faces"], 6, "{json}");
    assert_eq!(json["edges"], 12, "{json}");
    assert_eq!(json["max_valence"], 3, "{json}");
    assert_eq!(json["nonmanifold_vertices"], 0, "{json}");
}

#[test]
fn refine_cube_level_2_writes_98_vertices_and_96_faces() {
    let dir = TempDir::new("refine");
    let mesh = dir.file("cube.obj", CUBE);
    let text = refine_to_file(&dir, &mesh, "out.obj", &["--level", "2"]);
    assert_eq!(count_v_f(&text), (98, 96));
    // Every face is a quad of valid 1-based indices.
    for l in text.lines().filter(|l| l.starts_with("f ")) {
        let idx: Vec<usize> = l[2..]
            .split_whitespace()
            .map(|t| t.parse().unwrap())
            .collect();
        assert_eq!(idx.len(), 4, "{l}");
        assert!(idx.iter().all(|&i| (1..=98).contains(&i)), "{l}");
    }
    // The output is itself a valid mesh.
    let again = refine_to_file(&dir, &dir.path("out.obj"), "again.obj", &["--level", "1"]);
    assert_eq!(count_v_f(&again), (386, 384));
}

#[test]
fn smooth_triangles_flag_equals_the_tag() {
    let dir = TempDir::new("smoothtris");
    let tet = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 2 3 4\nf 3 1 4\n";
    let plain = dir.file("tet.obj", tet);
    let tagged = dir.file(
        "tet_tag.obj",
        &format!("{tet}t smoothtriangles 0/0/1 smooth\n"),
    );
    let catmark = refine_to_file(&dir, &plain, "catmark.obj", &["--level", "2"]);
    let flag = refine_to_file(
        &dir,
        &plain,
        "flag.obj",
        &["--level", "2", "--smooth-triangles"],
    );
    let tag = refine_to_file(&dir, &tagged, "tag.obj", &["--level", "2"]);
    assert_eq!(points_of(&flag), points_of(&tag));
    assert_ne!(
        points_of(&flag),
        points_of(&catmark),
        "the smooth-triangle rule moves the edge points of triangles"
    );
}

#[test]
fn chaikin_and_boundary_options_are_accepted() {
    let dir = TempDir::new("options");
    let mesh = dir.file(
        "creased.obj",
        &format!("{CUBE}t crease 2/1/0 0 1 2.5\nt crease 2/1/0 1 3 1.3\n"),
    );
    let uniform = refine_to_file(&dir, &mesh, "uniform.obj", &["--level", "2"]);
    let chaikin = refine_to_file(&dir, &mesh, "chaikin.obj", &["--level", "2", "--chaikin"]);
    assert_eq!(count_v_f(&chaikin), (98, 96));
    assert_ne!(
        points_of(&uniform),
        points_of(&chaikin),
        "Chaikin's rule changes the creases"
    );
    for b in ["none", "edge", "corner"] {
        let text = refine_to_file(
            &dir,
            &mesh,
            &format!("b-{b}.obj"),
            &["--level", "1", "--boundary", b],
        );
        // A closed cube has no boundary: every option gives the same 26 vertices, 24 quads.
        assert_eq!(count_v_f(&text), (26, 24), "--boundary {b}");
    }
    // On an open mesh (one quad) the options matter: `none` drops the boundary faces.
    let quad = dir.file(
        "quad.obj",
        "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\n",
    );
    let edge = refine_to_file(
        &dir,
        &quad,
        "q-edge.obj",
        &["--level", "1", "--boundary", "edge"],
    );
    let corner = refine_to_file(
        &dir,
        &quad,
        "q-corner.obj",
        &["--level", "1", "--boundary", "corner"],
    );
    let none = refine_to_file(
        &dir,
        &quad,
        "q-none.obj",
        &["--level", "1", "--boundary", "none"],
    );
    assert_eq!(count_v_f(&edge), (9, 4));
    assert_eq!(count_v_f(&corner), (9, 4));
    assert_eq!(count_v_f(&none).1, 0);
    assert_ne!(points_of(&edge), points_of(&corner), "smooth corners move");
    // An unknown boundary value is a usage error (exit code 2 as well).
    let o = limitray(&[
        &"refine",
        &quad,
        &"--boundary",
        &"sideways",
        &"-o",
        &dir.path("x.obj"),
    ]);
    let err = assert_exit_2(&o, "--boundary sideways");
    assert!(err.contains("sideways"), "{err}");
}

#[test]
fn limit_positions_differ_from_control_points() {
    let dir = TempDir::new("limit");
    let mesh = dir.file("cube.obj", CUBE);
    let plain = points_of(&refine_to_file(&dir, &mesh, "plain.obj", &["--level", "1"]));
    let limit = points_of(&refine_to_file(
        &dir,
        &mesh,
        "limit.obj",
        &["--level", "1", "--limit"],
    ));
    assert_eq!(plain.len(), limit.len());
    let moved = plain
        .iter()
        .zip(&limit)
        .filter(|(p, q)| common::dist(p, q) > 1e-6)
        .count();
    assert_eq!(
        moved,
        plain.len(),
        "every vertex of a smooth cube moves to the limit"
    );
    // The limit surface of the cube lies inside its control points' hull.
    for q in &limit {
        assert!(q.iter().all(|c| c.abs() < 0.5), "{q:?}");
    }
}

#[test]
fn dash_writes_to_stdout() {
    let dir = TempDir::new("stdout");
    let mesh = dir.file("cube.obj", CUBE);
    let o = limitray(&[&"refine", &mesh, &"--level", &"2", &"-o", &"-"]);
    assert_success(&o, "refine -o -");
    let text = stdout(&o);
    assert_eq!(count_v_f(&text), (98, 96));
    assert!(!dir.path("-").exists(), "`-` must not create a file");
    // Same content as writing to a file.
    let file = refine_to_file(&dir, &mesh, "out.obj", &["--level", "2"]);
    assert_eq!(text, file);
}

/// Runs `info` and `refine` on bad OBJ text and checks exit code 2 and a `FILE:LINE:` prefix.
fn check_bad_obj(dir: &TempDir, name: &str, text: &str, line: usize, needle: &str) {
    let mesh = dir.file(name, text);
    let located = format!("{}:{line}:", mesh.display());
    for args in [
        vec![&"info" as &dyn AsRef<std::ffi::OsStr>, &mesh],
        vec![&"refine", &mesh, &"--level", &"1", &"-o", &"-"],
    ] {
        let o = limitray(&args);
        let err = assert_exit_2(&o, name);
        assert!(
            err.contains(&located),
            "{name}: stderr lacks `{located}`: {err}"
        );
        assert!(
            err.to_lowercase().contains(needle),
            "{name}: stderr lacks `{needle}`: {err}"
        );
        assert!(
            stdout(&o).is_empty(),
            "{name}: nothing may be written on error"
        );
    }
}

#[test]
fn bad_obj_exits_2_with_file_and_line() {
    let dir = TempDir::new("bad");
    check_bad_obj(
        &dir,
        "two_corners.obj",
        "v 0 0 0\nv 1 0 0\nv 1 1 0\n# a face needs three corners\nf 1 2\n",
        5,
        "face",
    );
    check_bad_obj(
        &dir,
        "bad_number.obj",
        "v 0 0 0\nv 1 0 0\nv 1 1.5.2 0\nf 1 2 3\n",
        3,
        "1.5.2",
    );
    check_bad_obj(
        &dir,
        "negative_sharpness.obj",
        &format!("{CUBE}t crease 2/1/0 0 1 -1.0\n"),
        CUBE.lines().count() + 1,
        "sharpness",
    );
    check_bad_obj(
        &dir,
        "out_of_range.obj",
        "v 0 0 0\nv 1 0 0\nv 1 1 0\nf 1 2 3\nf 1 3 9\n",
        5,
        "out of range",
    );
}

#[test]
fn missing_file_exits_2_naming_it() {
    let dir = TempDir::new("missing");
    let mesh = dir.path("does_not_exist.obj");
    for args in [
        vec![&"info" as &dyn AsRef<std::ffi::OsStr>, &mesh],
        vec![&"refine", &mesh, &"-o", &dir.path("out.obj")],
    ] {
        let o = limitray(&args);
        let err = assert_exit_2(&o, "missing file");
        assert!(
            err.contains(&mesh.display().to_string()),
            "stderr does not name the file: {err}"
        );
    }
    assert!(!dir.path("out.obj").exists());
}

#[test]
fn unwritable_output_exits_2_naming_it() {
    let dir = TempDir::new("unwritable");
    let mesh = dir.file("cube.obj", CUBE);
    let out = dir.path("no_such_dir/out.obj");
    let o = limitray(&[&"refine", &mesh, &"-o", &out]);
    let err = assert_exit_2(&o, "output in a missing directory");
    assert!(
        err.contains(&out.display().to_string()),
        "stderr does not name the output: {err}"
    );
}

#[test]
fn level_above_maximum_exits_2() {
    let dir = TempDir::new("level");
    let mesh = dir.file("cube.obj", CUBE);
    let o = limitray(&[
        &"refine",
        &mesh,
        &"--level",
        &"13",
        &"-o",
        &dir.path("out.obj"),
    ]);
    let err = assert_exit_2(&o, "--level 13");
    assert!(
        err.contains("13") && err.contains("12"),
        "message should name the level and the maximum: {err}"
    );
    assert!(!dir.path("out.obj").exists());
}

#[test]
fn crease_on_missing_edge_warns_and_succeeds() {
    let dir = TempDir::new("warn");
    // Vertices 0 and 3 are diagonal on the first face: no edge joins them.
    let mesh = dir.file("diag.obj", &format!("{CUBE}t crease 2/1/0 0 3 2.0\n"));
    let o = limitray(&[&"refine", &mesh, &"--level", &"1", &"-o", &"-"]);
    assert_success(&o, "crease on a missing edge");
    let err = stderr(&o);
    assert!(err.contains("warning"), "no warning: {err}");
    assert!(
        err.contains("no edge joins vertices 0 and 3"),
        "warning should name the vertices: {err}"
    );
    assert!(
        err.contains(&format!("{}:{}:", mesh.display(), CUBE.lines().count() + 1)),
        "warning should name the tag's line: {err}"
    );
    assert_eq!(count_v_f(&stdout(&o)), (26, 24));
    // The ignored crease changes nothing.
    let plain = dir.file("plain.obj", CUBE);
    let p = limitray(&[&"refine", &plain, &"--level", &"1", &"-o", &"-"]);
    assert_success(&p, "plain cube");
    assert_eq!(stdout(&o), stdout(&p));
}

#[test]
fn refined_cube_matches_hbr_baseline() {
    let Some(models) = common::shared_models() else {
        return;
    };
    let dir = TempDir::new("baseline");
    let mesh = models.join("opensubdiv/catmark_cube.obj");
    // `NAME_level1.obj` holds two refinement steps.
    let base = models.join("opensubdiv-hbr-baseline/catmark_cube_level1.obj");
    let text = refine_to_file(&dir, &mesh, "cube2.obj", &["--level", "2"]);
    let ours = points_of(&text);
    let theirs = common::read_points(&base);
    assert_eq!(ours.len(), theirs.len());
    assert_eq!(count_v_f(&text).1, common::count_faces(&base));
    let diag = limitray::mesh::obj::read_obj(&mesh).unwrap().diagonal();
    let d1 = common::max_nearest_distance(&ours, &theirs) / diag;
    let d2 = common::max_nearest_distance(&theirs, &ours) / diag;
    println!("catmark_cube level 2 vs Hbr: {d1:.2e} {d2:.2e} of the diagonal");
    assert!(d1 <= 1e-6 && d2 <= 1e-6, "{d1:e} {d2:e}");
}

#[test]
fn eval_and_stats_through_the_cli() {
    let dir = std::env::temp_dir().join(format!("limitray-cli-eval-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let obj = dir.join("cube.obj");
    std::fs::write(
        &obj,
        "v -1 -1 1\nv 1 -1 1\nv -1 1 1\nv 1 1 1\nv -1 1 -1\nv 1 1 -1\nv -1 -1 -1\nv 1 -1 -1\n\
         f 1 2 4 3\nf 3 4 6 5\nf 5 6 8 7\nf 7 8 2 1\nf 2 8 6 4\nf 7 1 3 5\nt crease 2/1 0 1 3\n",
    )
    .unwrap();
    let out = common::run_limitray(
        &[std::ffi::OsStr::new("eval"), obj.as_os_str()],
        Some(b"0 0.5 0.5\n0 0 0.25 0.75\nbad line\n9 0.5 0.5\n0 1 0.5 0.5\n1 0 0\n"),
    );
    let stdout = String::from_utf8(out.stdout).unwrap();
    let stderr = String::from_utf8(out.stderr).unwrap();
    let lines: Vec<&str> = stdout.lines().collect();
    assert_eq!(lines.len(), 6, "one output line per input line: {stdout}");
    for (i, l) in lines.iter().enumerate() {
        let fields: Vec<&str> = l.split_whitespace().collect();
        assert_eq!(fields.len(), 9);
        let bad = (2..=4).contains(&i);
        assert_eq!(fields.iter().all(|f| *f == "nan"), bad, "line {i}: {l}");
        if !bad {
            assert!(fields.iter().all(|f| f.parse::<f64>().unwrap().is_finite()));
        }
    }
    // messages name the input lines; exit code 2 at the end
    assert!(
        stderr.contains("stdin:3:") && stderr.contains("stdin:4:") && stderr.contains("stdin:5:"),
        "{stderr}"
    );
    assert_eq!(out.status.code(), Some(2));
    // the top face is mirror-symmetric in x (the crease runs along x at y = -1): its centre
    // lies on x = 0, pulled towards the crease (y < 0)
    let c: Vec<f64> = lines[0]
        .split_whitespace()
        .map(|f| f.parse().unwrap())
        .collect();
    assert!(c[0].abs() < 1e-12 && c[1] < 0.0 && c[2] > 0.0, "{c:?}");

    let out = common::run_limitray(&[std::ffi::OsStr::new("stats"), obj.as_os_str()], None);
    assert!(out.status.success());
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert!(v["patches_total"].as_u64().unwrap() > 6);
    assert!(v["bytes_total"].as_u64().unwrap() > 0);
    assert!(
        v["patches_by_type"]["single_crease"].as_u64().is_some()
            || v["patches_by_type"]["regular"].as_u64().is_some()
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// A tetrahedron: four triangles, every vertex of valence 3.
const TETRA: &str = "\
v 1 1 1
v -1 -1 1
v -1 1 -1
v 1 -1 -1
f 1 2 3
f 1 4 2
f 1 3 4
f 2 4 3
";

#[test]
fn refine_with_the_loop_scheme() {
    let dir = TempDir::new("loop");
    let tetra = dir.file("tetra.obj", TETRA);
    let text = refine_to_file(&dir, &tetra, "tetra1.obj", &["--scheme", "loop"]);
    // Loop: 4 + 6 vertices, 4·4 triangles.
    assert_eq!(count_v_f(&text), (10, 16));
    assert!(text
        .lines()
        .filter(|l| l.starts_with("f "))
        .all(|l| l.split_whitespace().count() == 4));
    // Vertex 0's child is first: valence 3, β = 3/16, so 7/16 of itself and 3/16 of each
    // neighbour: (7 - 3)/16 = 1/4 in every coordinate. The first edge point of edge 0–1 is
    // 3/8 (v0 + v1) + 1/8 (v2 + v3) = (0, 0, 3/4 - 1/4) = (0, 0, 1/2).
    let p = points_of(&text);
    for c in p[0] {
        assert!((c - 0.25).abs() < 1e-12, "{:?}", p[0]);
    }
    assert!(p[4..].iter().any(|q| q
        .iter()
        .zip([0.0, 0.0, 0.5])
        .all(|(a, b)| (a - b).abs() < 1e-12)));

    // A quad is refused, naming the file, the line and the face.
    let cube = dir.file("cube.obj", CUBE);
    let out = dir.path("never.obj");
    let o = limitray(&[&"refine", &cube, &"--scheme", &"loop", &"-o", &out]);
    let err = assert_exit_2(&o, "refine --scheme loop on quads");
    assert!(
        err.contains("cube.obj:10") && err.contains("face 1") && err.contains("triangles"),
        "{err}"
    );
    assert!(!out.exists(), "a failed run wrote {}", out.display());

    // `eval`: at vertex 0 the limit position, by Loop's limit mask for valence 3
    // (χ = 1/(3 + 3/(8·3/16)) = 1/5): 2/5 v0 + 1/5 (v1 + v2 + v3) = (1/5, 1/5, 1/5). A point
    // outside the triangle is a bad line: nine `nan`, a message, exit 2.
    let args: Vec<std::ffi::OsString> = vec![
        "eval".into(),
        tetra.clone().into(),
        "--scheme".into(),
        "loop".into(),
    ];
    let o = common::run_limitray(&args, Some(b"0 0 0\n1 0.75 0.5\n"));
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    let text = stdout(&o);
    let lines: Vec<&str> = text.lines().collect();
    let p: Vec<f64> = lines[0]
        .split_whitespace()
        .map(|x| x.parse().unwrap())
        .collect();
    for c in &p[..3] {
        assert!((c - 0.2).abs() < 1e-14, "{}", lines[0]);
    }
    assert!(lines[1].starts_with("nan"), "{text}");
    assert!(stderr(&o).contains("stdin:2:"), "{}", stderr(&o));

    // `refine --limit`: level 1's vertex 0 is the child of control vertex 0, at the same
    // limit (1/5, 1/5, 1/5); every vertex lies on the surface.
    let text = refine_to_file(
        &dir,
        &tetra,
        "tetra_limit.obj",
        &["--scheme", "loop", "--limit"],
    );
    let p = points_of(&text);
    assert_eq!(p.len(), 10);
    for c in p[0] {
        assert!((c - 0.2).abs() < 1e-14, "{:?}", p[0]);
    }

    // `dice`: each triangle as three sub-quads, rate 4 → 3 · (2 · 2²) = 24 triangles per
    // face; every diced vertex is a limit point, so the four corner limits appear.
    let diced = dir.path("tetra_diced.obj");
    let o = limitray(&[
        &"dice",
        &tetra,
        &"--scheme",
        &"loop",
        &"--rate",
        &"4",
        &"-o",
        &diced,
    ]);
    assert_success(&o, "dice --scheme loop");
    let text = std::fs::read_to_string(&diced).unwrap();
    assert_eq!(count_v_f(&text).1, 4 * 24);
    let p = points_of(&text);
    assert!(p.iter().any(|q| q.iter().all(|c| (c - 0.2).abs() < 1e-6)));

    // The reference intersector traces Loop too: a ray from inside the tetrahedron hits,
    // reported in the triangle's own parameter (k = 0).
    let args: Vec<std::ffi::OsString> = vec![
        "trace".into(),
        tetra.clone().into(),
        "--scheme".into(),
        "loop".into(),
        "--exact".into(),
    ];
    let o = common::run_limitray(&args, Some(b"0 0 0 1 0 0\n"));
    assert_success(&o, "trace --exact --scheme loop");
    let out = String::from_utf8(o.stdout.clone()).unwrap();
    let tok: Vec<&str> = out.split_whitespace().collect();
    assert_eq!((tok[0], tok[3]), ("hit", "0"), "{out}");
}

/// Paper 002's approximations through the command line: `approx-error` prints one JSON
/// object per surface with the keys, the paper's ordering holds on the blob
/// (Gregory closer than PN), a Catmull-Clark mesh refuses an approximation without writing
/// anything, `dice --surface` writes the approximate surface, and scenes check the key.
#[test]
fn approximations_through_the_cli() {
    let dir = TempDir::new("approx");
    let blob = dir.path("blob.obj");
    {
        let mut w = std::io::BufWriter::new(std::fs::File::create(&blob).unwrap());
        limitray::mesh::shapes::write_tagged_obj(&mut w, &limitray::mesh::shapes::blob(), "blob")
            .unwrap();
    }
    let o = limitray(&[&"approx-error", &blob, &"--samples", &"3000", &"--json"]);
    assert_success(&o, "approx-error --json");
    let lines: Vec<serde_json::Value> = stdout(&o)
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    assert_eq!(lines.len(), 3);
    let names: Vec<&str> = lines
        .iter()
        .map(|l| l["surface"].as_str().unwrap())
        .collect();
    assert_eq!(names, ["pn", "wm", "gregory"]);
    for l in &lines {
        for key in ["max", "mean", "rms", "max_reverse", "normal_max_deg"] {
            let x = l[key].as_f64().unwrap_or_else(|| panic!("{key} in {l}"));
            assert!(x.is_finite() && x >= 0.0, "{key} = {x}");
        }
        // On the blob every approximation stays within 1% of the diagonal (measured ≤ 3.6e-3)
        // and its mean is far below its maximum.
        assert!(
            l["max"].as_f64().unwrap() < 1e-2 && l["mean"].as_f64().unwrap() < 1e-3,
            "{l}"
        );
    }
    let max = |i: usize| lines[i]["max"].as_f64().unwrap();
    assert!(max(2) < max(0), "Gregory {} vs PN {}", max(2), max(0));

    // Under Catmull-Clark the default is paper 004's Gregory patches alone.
    let cube_mesh = dir.file("cube_ae.obj", CUBE);
    let o = limitray(&[
        &"approx-error",
        &cube_mesh,
        &"--scheme",
        &"catmark",
        &"--samples",
        &"2000",
        &"--json",
    ]);
    assert_success(&o, "approx-error --scheme catmark");
    let l: Vec<serde_json::Value> = stdout(&o)
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    assert_eq!(l.len(), 1);
    assert_eq!(l[0]["surface"], "gregory");
    // The cube's patches stay within 1% of its diagonal (measured 2e-3).
    assert!(l[0]["max"].as_f64().unwrap() < 1e-2, "{}", l[0]);

    // The exact surface is the reference, not an approximation to measure.
    let o = limitray(&[&"approx-error", &blob, &"--surface", &"exact"]);
    assert_exit_2(&o, "approx-error --surface exact");

    // PN and Walton-Meek approximate Loop surfaces only.
    let cube = dir.file("cube.obj", CUBE);
    let out = dir.path("never.obj");
    let o = limitray(&[&"dice", &cube, &"--surface", &"pn", &"-o", &out]);
    let err = assert_exit_2(&o, "dice --surface pn on Catmull-Clark");
    assert!(err.contains("Loop"), "{err}");
    assert!(!out.exists());
    // A Catmull-Clark mesh takes paper 004's Gregory patches: the same triangles, other
    // points; the reference intersector refuses an approximation.
    let dice_cube = |surface: &str| {
        let out = dir.path(&format!("cube_{surface}.obj"));
        let o = limitray(&[
            &"dice",
            &cube,
            &"--surface",
            &surface,
            &"--rate",
            &"4",
            &"-o",
            &out,
        ]);
        assert_success(&o, "dice a Catmull-Clark mesh --surface");
        let text = std::fs::read_to_string(&out).unwrap();
        (count_v_f(&text), points_of(&text))
    };
    let ((ce, pe), (cg, pg)) = (dice_cube("exact"), dice_cube("gregory"));
    assert_eq!(ce, cg);
    assert!(pe.iter().zip(&pg).any(|(a, b)| a != b));
    let o = limitray(&[&"trace", &cube, &"--exact", &"--surface", &"gregory"]);
    let err = assert_exit_2(&o, "trace --exact --surface gregory");
    assert!(err.contains("approximation"), "{err}");

    // Dicing the approximation: same triangle count as the exact surface, different points.
    let count = |surface: &str| {
        let out = dir.path(&format!("blob_{surface}.obj"));
        let o = limitray(&[
            &"dice",
            &blob,
            &"--scheme",
            &"loop",
            &"--surface",
            &surface,
            &"--rate",
            &"2",
            &"-o",
            &out,
        ]);
        assert_success(&o, "dice --surface");
        let text = std::fs::read_to_string(&out).unwrap();
        (count_v_f(&text), points_of(&text))
    };
    let (exact, pe) = count("exact");
    let (greg, pg) = count("gregory");
    assert_eq!(exact, greg);
    assert!(pe.iter().zip(&pg).any(|(a, b)| a != b));

    // The scene key: an approximation needs the Loop scheme, named on its line.
    let scene = dir.file(
        "s.toml",
        &format!(
            "[render]\nwidth = 4\nheight = 4\nspp = 1\n\n[camera]\nposition = [0, 0, 5]\nlook_at = [0, 0, 0]\nfov = 40\n\n[materials.clay]\ntype = \"diffuse\"\nalbedo = [0.5, 0.5, 0.5]\n\n[[mesh]]\nfile = \"{}\"\nmaterial = \"clay\"\nsurface = \"wm\"\n",
            cube.display()
        ),
    );
    let png = dir.path("s.exr");
    let o = limitray(&[&"render", &scene, &"-o", &png]);
    let err = assert_exit_2(&o, "render with surface on a Catmull-Clark mesh");
    assert!(
        err.contains("s.toml:") && err.contains("scheme = \"loop\""),
        "{err}"
    );
}

/// `refine` honours hierarchical edits as Hbr does: catmark_square_hedit0 at 2, 3 and 4 steps
/// equals Hbr's baselines (point sets within 1e-6 of the diagonal; the baselines print 9
/// digits of Hbr's single precision), where a level's own edits show only once it is refined
/// further; `--level-edits` applies them (the level-2 edit raises 4 points by 1).
#[test]
fn refine_honours_hierarchical_edits_like_hbr() {
    let Some(models) = common::shared_models() else {
        return;
    };
    let dir = TempDir::new("hedit");
    let mesh = models.join("opensubdiv/catmark_square_hedit0.obj");
    for steps in 2..=4 {
        let level = steps.to_string();
        let ours = refine_points(&refine_to_file(&dir, &mesh, "r.obj", &["--level", &level]));
        let base = models.join(format!(
            "opensubdiv-hbr-baseline/catmark_square_hedit0_level{}.obj",
            steps - 1
        ));
        let theirs = common::read_points(&base);
        let diag = 2f64.sqrt() * 2.0;
        let d = common::max_nearest_distance(&ours, &theirs)
            .max(common::max_nearest_distance(&theirs, &ours));
        assert!(d <= 1e-6 * diag, "level {steps}: {d}");
        let edited = refine_points(&refine_to_file(
            &dir,
            &mesh,
            "e.obj",
            &["--level", &level, "--level-edits"],
        ));
        let moved = ours
            .iter()
            .zip(&edited)
            .filter(|(a, b)| common::dist(a, b) > 0.5)
            .count();
        // The level-1 edit is already in both; levels 2 and 3 each edit 4 vertices.
        assert_eq!(moved, if steps == 4 { 0 } else { 4 }, "level {steps}");
    }
}

/// `--displace noise:A:F` on dice and trace: the displaced vertices leave the limit surface by
/// at most 1.1 A, a ray down the cube's axis hits the displaced surface (not the limit's),
/// `--exact` refuses it, and a bad spec or an image map is exit code 2 naming the spec.
#[test]
fn displace_on_dice_and_trace() {
    let dir = TempDir::new("displace");
    let mesh = dir.file("cube.obj", CUBE);
    let plain = refine_points(&refine_to_file_cmd(
        &dir,
        "dice",
        &mesh,
        "a.obj",
        &["--rate", "6"],
    ));
    let moved = refine_points(&refine_to_file_cmd(
        &dir,
        "dice",
        &mesh,
        "b.obj",
        &["--rate", "6", "--displace", "noise:0.2:2"],
    ));
    assert_eq!(plain.len(), moved.len());
    let d = plain
        .iter()
        .zip(&moved)
        .map(|(a, b)| common::dist(a, b))
        .fold(0.0f64, f64::max);
    assert!(d > 0.05 && d <= 0.22 + 1e-6, "largest displacement {d}");
    let ray = b"0.1 0.2 5 0 0 -1\n";
    let hit = |extra: &[&str]| first_hit_t(&mesh, extra, ray);
    let (t0, t1) = (
        hit(&["--rate", "16"]),
        hit(&["--rate", "16", "--displace", "noise:0.2:2"]),
    );
    assert!(
        (t0 - t1).abs() > 1e-3 && (t0 - t1).abs() <= 0.22,
        "{t0} {t1}"
    );
    for (extra, msg) in [
        (vec!["--exact", "--displace", "noise:0.2:2"], "--displace"),
        (vec!["--displace", "noise:0.2"], "noise:AMPLITUDE:FREQUENCY"),
        (
            vec!["--displace", "map:no-such-tex.png:1"],
            "no-such-tex.png",
        ),
        (vec!["--displace", "map:tex.png"], "map:FILE:SCALE"),
        (vec!["--displace", "noise:0.1:-3"], "frequency"),
    ] {
        let mut args: Vec<&std::ffi::OsStr> = vec!["trace".as_ref(), mesh.as_os_str()];
        args.extend(extra.iter().map(|a| std::ffi::OsStr::new(*a)));
        let o = common::run_limitray(&args, Some(ray));
        let err = assert_exit_2(&o, &format!("{extra:?}"));
        assert!(err.contains(msg), "{extra:?}: {err}");
    }
}

/// `--displace map:FILE:SCALE`: a white PNG (value 1, linear) moves every diced vertex of the
/// cube out by SCALE along its limit normal (1e-6: the f32 positions), and the ray from above
/// meets the surface SCALE earlier (the top is flat at the centre: 1e-4 for the dicing).
#[test]
fn displace_by_an_image_map() {
    let dir = TempDir::new("displace-map");
    let mesh = dir.file("cube.obj", CUBE);
    let png = dir.path("white.png");
    limitray::io::png::write_rgb8(&png, 16, 16, vec![255; 16 * 16 * 3]).unwrap();
    let spec = format!("map:{}:0.1", png.display());
    let plain = refine_points(&refine_to_file_cmd(
        &dir,
        "dice",
        &mesh,
        "a.obj",
        &["--rate", "6"],
    ));
    let moved = refine_points(&refine_to_file_cmd(
        &dir,
        "dice",
        &mesh,
        "b.obj",
        &["--rate", "6", "--displace", &spec],
    ));
    assert_eq!(plain.len(), moved.len());
    for (a, b) in plain.iter().zip(&moved) {
        let d = common::dist(a, b);
        assert!((d - 0.1).abs() < 1e-6, "{a:?} -> {b:?}: {d}");
    }
    let ray = b"0 0 5 0 0 -1\n";
    let hit = |extra: &[&str]| first_hit_t(&mesh, extra, ray);
    let (t0, t1) = (
        hit(&["--rate", "16"]),
        hit(&["--rate", "16", "--displace", &spec]),
    );
    assert!((t0 - t1 - 0.1).abs() < 1e-4, "{t0} {t1}");
}

/// The `t` of `limitray trace MESH EXTRA…`'s first answer to `ray` (which must hit).
fn first_hit_t(mesh: &Path, extra: &[&str], ray: &[u8]) -> f64 {
    let mut args: Vec<&std::ffi::OsStr> = vec!["trace".as_ref(), mesh.as_os_str()];
    args.extend(extra.iter().map(|a| std::ffi::OsStr::new(*a)));
    let o = common::run_limitray(&args, Some(ray));
    assert_success(&o, "trace");
    stdout(&o)
        .split_whitespace()
        .nth(1)
        .unwrap()
        .parse()
        .unwrap()
}

fn refine_to_file_cmd(
    dir: &TempDir,
    cmd: &str,
    mesh: &Path,
    out_name: &str,
    extra: &[&str],
) -> String {
    let out = dir.path(out_name);
    let mut args: Vec<&dyn AsRef<std::ffi::OsStr>> = vec![&cmd, &mesh];
    for a in extra {
        args.push(a);
    }
    args.push(&"-o");
    args.push(&out);
    let o = limitray(&args);
    assert_success(&o, &format!("{cmd} {extra:?}"));
    std::fs::read_to_string(&out).expect("output file written")
}

fn refine_points(text: &str) -> Vec<[f64; 3]> {
    text.lines()
        .filter(|l| l.starts_with("v "))
        .map(|l| {
            let x: Vec<f64> = l[2..]
                .split_whitespace()
                .map(|t| t.parse().unwrap())
                .collect();
            [x[0], x[1], x[2]]
        })
        .collect()
}

/// `refine --uv` needs texture coordinates and a Catmull-Clark mesh, and `--fvar` takes only
/// OpenSubdiv's six mode names: each mistake is a clear error and no output file.
#[test]
fn refine_uv_refuses_what_it_cannot_do() {
    let dir = TempDir::new("uv");
    let mesh = dir.file("cube.obj", CUBE);
    let out = dir.path("r.obj");
    let o = limitray(&[&"refine", &mesh, &"--uv", &"-o", &out]);
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("cube.obj") && err.contains("no texture coordinates"),
        "{err}"
    );
    assert!(!out.exists());
    let o = limitray(&[
        &"refine",
        &mesh,
        &"--uv",
        &"--fvar",
        &"sometimes",
        &"-o",
        &out,
    ]);
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("unknown mode 'sometimes'") && err.contains("corners-plus1"),
        "{err}"
    );
    // With texture coordinates: one `vt` per refined value, faces as `f v/vt`.
    let textured = dir.file(
        "quad.obj",
        "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nf 1/1 2/2 3/3 4/4\n",
    );
    let o = limitray(&[
        &"refine", &textured, &"--uv", &"--fvar", &"all", &"--level", &"2", &"-o", &out,
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let text = std::fs::read_to_string(&out).unwrap();
    assert_eq!(text.lines().filter(|l| l.starts_with("vt ")).count(), 25);
    assert_eq!(text.lines().filter(|l| l.starts_with("f ")).count(), 16);
    assert!(text
        .lines()
        .filter(|l| l.starts_with("f "))
        .all(|l| l.split_whitespace().skip(1).all(|c| c.contains('/'))));
    // Bilinear (`all`) on one quad: the values are the bilinear lattice of quarters.
    for l in text.lines().filter(|l| l.starts_with("vt ")) {
        for x in l.split_whitespace().skip(1) {
            let x: f64 = x.parse().unwrap();
            assert_eq!((x * 4.0).fract(), 0.0, "{l}");
        }
    }
}
