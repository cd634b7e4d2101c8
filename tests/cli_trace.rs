//! End-to-end tests of `limitray dice`, `trace` (with and without `--exact`), `accuracy` and
//! `bench-trace` through the binary.

mod common;

use std::process::Output;

fn scene(name: &str) -> String {
    format!("{}/scenes/{name}", env!("CARGO_MANIFEST_DIR"))
}

fn run(args: &[&str], stdin: &str) -> Output {
    common::run_limitray(args, Some(stdin.as_bytes()))
}

#[test]
fn dice_writes_a_closed_obj() {
    let cube = scene("creased_cube.obj");
    let o = run(&["dice", &cube, "--rate", "3", "-o", "-"], "");
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let text = String::from_utf8(o.stdout).unwrap();
    let faces = text.lines().filter(|l| l.starts_with("f ")).count();
    assert_eq!(faces, 6 * 2 * 9);
    let v = text.lines().filter(|l| l.starts_with("v ")).count();
    let vn = text.lines().filter(|l| l.starts_with("vn ")).count();
    assert_eq!(v, vn);
    // Re-read as a mesh: every index in range.
    for l in text.lines().filter(|l| l.starts_with("f ")) {
        for t in l.split_whitespace().skip(1) {
            let i: usize = t.split('/').next().unwrap().parse().unwrap();
            assert!(i >= 1 && i <= v);
        }
    }
}

#[test]
fn trace_hits_misses_and_bad_lines() {
    let cube = scene("creased_cube.obj");
    let input = "0 0 0 1 1 1\n0 0 5 0 0 -1\n0 0 5 0 0 1\n\n1 2 3\n0 0 0 0 0 0\n";
    let o = run(&["trace", &cube, "--rate", "8"], input);
    assert_eq!(o.status.code(), Some(2));
    let out = String::from_utf8(o.stdout).unwrap();
    let lines: Vec<&str> = out.lines().collect();
    assert_eq!(lines.len(), 6, "{out}");
    assert!(lines[0].starts_with("hit "), "{}", lines[0]);
    let f: Vec<f64> = lines[1]
        .split_whitespace()
        .skip(1)
        .map(|x| x.parse().unwrap())
        .collect();
    // The creased cube's top is flat at z = 1 inside its sharp edges: t = 4 from z = 5.
    assert!((f[0] - 4.0).abs() < 1e-6, "{}", lines[1]);
    assert!((f[7] - 1.0).abs() < 1e-6, "normal {}", lines[1]);
    assert_eq!(lines[2], "miss");
    assert_eq!(lines[3], "");
    assert!(lines[4].starts_with("nan"));
    assert!(lines[5].starts_with("nan"));
    let err = String::from_utf8(o.stderr).unwrap();
    assert!(
        err.contains("stdin:5:") && err.contains("stdin:6:"),
        "{err}"
    );
}

#[test]
fn trace_exact_is_on_the_limit_surface() {
    let cube = scene("creased_cube.obj");
    let input = "0.1 0.2 0 0.3 0.5 0.8\n";
    let diced = run(&["trace", &cube, "--rate", "2"], input);
    let exact = run(&["trace", &cube, "--rate", "2", "--exact"], input);
    let parse = |o: &Output| -> Vec<f64> {
        String::from_utf8(o.stdout.clone())
            .unwrap()
            .split_whitespace()
            .skip(1)
            .map(|x| x.parse().unwrap())
            .collect()
    };
    let (d, x) = (parse(&diced), parse(&exact));
    // Evaluate the exact surface at the refined (face, k, u, v) and compare with o + t d.
    let eval = run(
        &["eval", &cube],
        &format!("{} {} {} {}\n", x[1], x[2], x[3], x[4]),
    );
    let p: Vec<f64> = String::from_utf8(eval.stdout)
        .unwrap()
        .split_whitespace()
        .map(|v| v.parse().unwrap())
        .collect();
    // The exact answer is for the ray as given in f64 (1e-12 of the cube's size; measured
    // about 1e-16), not for its f32 rounding, which is 1e-8 to 1e-9 away.
    let o = [0.1, 0.2, 0.0];
    let dir = [0.3, 0.5, 0.8];
    let (o32, dir32) = (
        o.map(|c: f64| c as f32 as f64),
        dir.map(|c: f64| c as f32 as f64),
    );
    let mut off32 = 0.0f64;
    for k in 0..3 {
        assert!(
            (o[k] + x[0] * dir[k] - p[k]).abs() < 1e-12,
            "axis {k}: {x:?} vs {p:?}"
        );
        off32 = off32.max((o32[k] + x[0] * dir32[k] - p[k]).abs());
    }
    assert!(off32 > 1e-10, "the f32 ray would be {off32:e} off");
    // At rate 2 the diced hit is off the surface by the dicing error; the exact one is not.
    assert!((d[0] - x[0]).abs() > 1e-6);
}

#[test]
fn accuracy_and_bench_print_json() {
    let cube = scene("creased_cube.obj");
    let o = run(&["accuracy", &cube, "--rates", "2,8", "--rays", "500"], "");
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let out = String::from_utf8(o.stdout).unwrap();
    assert_eq!(out.lines().count(), 2);
    for l in out.lines() {
        let v: serde_json::Value = serde_json::from_str(l).unwrap();
        assert!(v["max_bound_ratio"].as_f64().unwrap() <= 1.0, "{l}");
    }
    let bench = |extra: &[&str]| -> serde_json::Value {
        let mut args = vec![
            "bench-trace",
            &cube,
            "--rate",
            "4",
            "--rays",
            "2000",
            "--reps",
            "1",
        ];
        args.extend_from_slice(extra);
        let o = run(&args, "");
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        serde_json::from_slice(&o.stdout).unwrap()
    };
    let v = bench(&[]);
    assert_eq!(v["triangles"], 6 * 2 * 16);
    // One 4×4-quad block per face, all six under the 8-wide root: one level, and a walk that
    // holds at most the root's six children.
    assert_eq!(
        (v["blocks"].as_u64(), v["loose_triangles"].as_u64()),
        (Some(6), Some(0))
    );
    assert_eq!(
        (v["top_depth"].as_u64(), v["top_stack"].as_u64()),
        (Some(1), Some(6))
    );
    // The leaf test the traversal ran: the one this processor gets.
    assert_eq!(v["leaf_test"], limitray::grid::window::leaf_isa());
    // Built for tracing alone (no shading normals): the same blocks, tree and hits, and 4
    // bytes less per block vertex (6 blocks of 5 × 5 vertices over 192 triangles: 3.125
    // bytes per triangle; the JSON rounds each figure to 0.1).
    assert_eq!(v["shading_normals"], true);
    let g = bench(&["--no-shading-normals"]);
    assert_eq!(g["shading_normals"], false);
    for key in [
        "triangles",
        "blocks",
        "top_nodes",
        "coherent_hits",
        "incoherent_hits",
    ] {
        assert_eq!(g[key], v[key], "{key}");
    }
    let bytes = |v: &serde_json::Value| v["bytes_per_triangle"].as_f64().unwrap();
    assert!(
        (bytes(&v) - bytes(&g) - 3.125).abs() < 0.11,
        "{} vs {}",
        bytes(&v),
        bytes(&g)
    );
    assert!(v.get("stages_ms").is_none());
    assert_eq!(v["warm"], 0);
    // With --stages (after two warm builds): the measured build's stages in order, table,
    // dicing, then grid, adding up to no more than the three parts' times (the JSON rounds
    // those to 0.1 ms and the stages to 0.01: 0.15 + 0.10 ms at most for the cube's 19
    // stages, its refinement's three among them); the warm builds' stages are not among
    // them.
    let v = bench(&["--stages", "--warm", "2"]);
    assert_eq!(v["warm"], 2);
    assert_eq!(v["triangles"], 6 * 2 * 16);
    let stages = v["stages_ms"].as_array().expect("stages_ms");
    let names: Vec<&str> = stages.iter().map(|s| s[0].as_str().unwrap()).collect();
    let first = |prefix: &str| names.iter().position(|n| n.starts_with(prefix)).unwrap();
    assert!(
        first("table:") < first("dice:") && first("dice:") < first("grid:"),
        "{names:?}"
    );
    for name in [
        "table: level 0",
        "table: refinement: cut-outs",
        "table: refinement: steps",
        "table: refinement: patches",
        "dice: shared points",
        "dice: domains and their stores",
        "grid: block plans",
        "grid: top-level binning",
        "grid: top-level boxes",
    ] {
        assert!(names.contains(&name), "{name} missing from {names:?}");
    }
    let sum: f64 = stages.iter().map(|s| s[1].as_f64().unwrap()).sum();
    let total: f64 = ["table_ms", "dice_ms", "grid_ms"]
        .iter()
        .map(|k| v[k].as_f64().unwrap())
        .sum();
    assert!(sum <= total + 0.3, "stages {sum} ms, build {total} ms");
    let bad = run(&["bench-trace", &cube, "--exact", "--stages"], "");
    assert_eq!(bad.status.code(), Some(2));
    let bad = run(&["dice", "/nonexistent.obj", "-o", "-"], "");
    assert_eq!(bad.status.code(), Some(2));
    let bad = run(&["dice", &cube, "--rate", "0", "-o", "-"], "");
    assert_eq!(bad.status.code(), Some(2));
}

#[test]
fn trace_exact_does_not_depend_on_the_dicing() {
    // The reference intersector never looks at the diced mesh: rays near the silhouette (which
    // a coarse dicing misses or hits wrongly) get the same answer at every rate, bit for bit.
    let cube = scene("creased_cube.obj");
    let mut input = String::new();
    for i in 0..200 {
        let y = -1.2 + 0.012 * i as f64;
        input.push_str(&format!("-5 {y} 0.05 1 0.001 0.002\n"));
    }
    let answers: Vec<String> = ["1", "4", "64"]
        .iter()
        .map(|r| {
            let o = run(&["trace", &cube, "--rate", r, "--exact"], &input);
            assert!(o.status.success());
            String::from_utf8(o.stdout).unwrap()
        })
        .collect();
    assert_eq!(answers[0], answers[1]);
    assert_eq!(answers[0], answers[2]);
    let hits = answers[0].lines().filter(|l| l.starts_with("hit")).count();
    assert!(hits > 20 && hits < 200, "{hits}");
    // A diced trace at rate 1 answers some of these rays differently.
    let diced = run(&["trace", &cube, "--rate", "1"], &input);
    let diced_hits = String::from_utf8(diced.stdout)
        .unwrap()
        .lines()
        .filter(|l| l.starts_with("hit"))
        .count();
    assert_ne!(diced_hits, hits);
}

/// `trace --exact --scheme loop` and `accuracy --scheme loop` on the bundled Loop scene's
/// meshes (semi-sharp creases, irregular vertices): hits in the triangle's own `(u, v)` with
/// `k = 0`, on the surface `eval --scheme loop` gives there (1e-12 of the diagonal); the diced
/// surface agrees with the reference on every ray and stays within its error bound.
#[test]
fn loop_meshes_trace_exactly() {
    for name in ["meshes/gear8_tri.obj", "meshes/rounded_box_s2_tri.obj"] {
        let mesh = scene(name);
        let rays = "0.6 0.1 5 0.01 0.02 -1\n4 0.3 0.1 -1 0.05 0.01\n0.2 -3 0.1 0 1 0.03\n";
        let o = run(&["trace", &mesh, "--scheme", "loop", "--exact"], rays);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let out = String::from_utf8(o.stdout).unwrap();
        let mut queries = String::new();
        let mut hits = Vec::new();
        for (line, ray) in out.lines().zip(rays.lines()) {
            let tok: Vec<&str> = line.split_whitespace().collect();
            assert_eq!(tok[0], "hit", "{name}: {line}");
            assert_eq!(tok[3], "0", "{name}: k of a triangle: {line}");
            let x: Vec<f64> = tok[1..].iter().map(|v| v.parse().unwrap()).collect();
            assert!(
                x[3] >= 0.0 && x[4] >= 0.0 && x[3] + x[4] <= 1.0 + 1e-12,
                "{line}"
            );
            queries += &format!("{} {:?} {:?}\n", tok[2], x[3], x[4]);
            let r: Vec<f64> = ray.split_whitespace().map(|v| v.parse().unwrap()).collect();
            hits.push(std::array::from_fn::<f64, 3, _>(|c| r[c] + x[0] * r[3 + c]));
        }
        let e = run(&["eval", &mesh, "--scheme", "loop"], &queries);
        assert!(e.status.success(), "{}", String::from_utf8_lossy(&e.stderr));
        for (line, q) in String::from_utf8(e.stdout).unwrap().lines().zip(&hits) {
            let p: Vec<f64> = line
                .split_whitespace()
                .map(|v| v.parse().unwrap())
                .collect();
            for c in 0..3 {
                // The meshes are about 3 across.
                assert!((p[c] - q[c]).abs() < 3e-12, "{name}: {p:?} vs {q:?}");
            }
        }
        let a = run(
            &[
                "accuracy", &mesh, "--scheme", "loop", "--rates", "4,16", "--rays", "500",
            ],
            "",
        );
        assert!(a.status.success(), "{}", String::from_utf8_lossy(&a.stderr));
        for l in String::from_utf8(a.stdout).unwrap().lines() {
            let v: serde_json::Value = serde_json::from_str(l).unwrap();
            assert_eq!(v["disagree"], 0, "{name}: {l}");
            assert_eq!(v["grazing"], 0, "{name}: {l}");
            assert!(v["max_bound_ratio"].as_f64().unwrap() <= 1.0, "{name}: {l}");
        }
    }
}

/// `trace --uv` appends the hit's limit texture coordinates: on a cube whose faces each carry
/// the whole unit square (one island per face), mode `all` gives `(s, t) = (u, v)` of the hit
/// (bilinear corners (0,0), (1,0), (1,1), (0,1); 1e-15 for the interpolation's rounding), and
/// every mode, diced or exact, gives what `Surface::uv` gives at the printed `(face, k, u, v)`,
/// bit for bit. A mesh without texture coordinates is refused.
#[test]
fn trace_reports_texture_coordinates() {
    use limitray::{FaceCoord, Surface, SurfaceOptions};
    let dir = std::env::temp_dir().join(format!("limitray-uv-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let mut obj = String::new();
    for i in 0..8 {
        let c = |b: usize| if i >> b & 1 == 1 { 1 } else { -1 };
        obj += &format!("v {} {} {}\n", c(0), c(1), c(2));
    }
    obj += "vt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n";
    for f in [
        [0, 2, 3, 1],
        [4, 5, 7, 6],
        [0, 1, 5, 4],
        [2, 6, 7, 3],
        [0, 4, 6, 2],
        [1, 3, 7, 5],
    ] {
        obj += &format!(
            "f {}/1 {}/2 {}/3 {}/4\n",
            f[0] + 1,
            f[1] + 1,
            f[2] + 1,
            f[3] + 1
        );
    }
    let path = dir.join("cube.obj");
    std::fs::write(&path, obj).unwrap();
    let p = path.to_str().unwrap();
    let rays = "0 0 0 0.3 0.2 1\n0 0 0 -1 0.4 0.1\n0 0 0 0.2 -1 -0.3\n5 5 5 1 0 0\n";
    for mode in ["all", "corners-plus1", "none"] {
        let s = Surface::from_obj(
            &path,
            SurfaceOptions {
                fvar: limitray::mesh::FVarMode::from_name(mode),
                ..SurfaceOptions::default()
            },
        )
        .unwrap();
        for exact in [false, true] {
            let mut args = vec!["trace", p, "--uv", "--fvar", mode, "--rate", "8"];
            if exact {
                args.push("--exact");
            }
            let o = run(&args, rays);
            assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
            let out = String::from_utf8(o.stdout).unwrap();
            let lines: Vec<&str> = out.lines().collect();
            assert_eq!(lines.len(), 4);
            assert_eq!(lines[3], "miss");
            for l in &lines[..3] {
                let f: Vec<&str> = l.split_whitespace().collect();
                let x = |i: usize| f[i].parse::<f64>().unwrap();
                let at = FaceCoord::new(f[2].parse().unwrap(), f[3].parse().unwrap(), x(4), x(5));
                let n = f.len();
                let (st_s, st_t) = (x(n - 2), x(n - 1));
                let want = s.uv(at).unwrap().unwrap().st;
                assert_eq!([st_s, st_t], want, "{mode} {l}");
                if mode == "all" {
                    assert!(
                        (st_s - at.u).abs() < 1e-15 && (st_t - at.v).abs() < 1e-15,
                        "{l}"
                    );
                }
            }
        }
    }
    let plain = scene("creased_cube.obj");
    let o = run(&["trace", &plain, "--uv"], rays);
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("creased_cube.obj") && err.contains("no texture coordinates"),
        "{err}"
    );
    std::fs::remove_dir_all(&dir).ok();
}
