//! The hostile command lines of issue 13 through the binary, each input generated here: every
//! one ends with exit code 0 or 2 and a clear message, never a panic, an abort or a lost file.

use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};

fn run(args: &[&str], stdin: &[u8]) -> Output {
    let mut child = Command::new(env!("CARGO_BIN_EXE_limitray"))
        .args(args)
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    child.stdin.take().unwrap().write_all(stdin).unwrap();
    child.wait_with_output().unwrap()
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// Exit code 2 with `message` in the error output.
fn refused(o: &Output, message: &str) {
    assert_eq!(o.status.code(), Some(2), "{}", stderr(o));
    let e = stderr(o);
    assert!(e.contains(message), "expected '{message}' in: {e}");
    assert!(!e.contains("panicked"), "{e}");
}

fn temp_dir(tag: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("limitray-clih-{tag}-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

const CUBE: &str = "v -1 -1 1\nv 1 -1 1\nv -1 1 1\nv 1 1 1\nv -1 1 -1\nv 1 1 -1\n\
v -1 -1 -1\nv 1 -1 -1\nf 1 2 4 3\nf 3 4 6 5\nf 5 6 8 7\nf 7 8 2 1\nf 2 8 6 4\nf 7 1 3 5\n";

fn cube(d: &Path) -> String {
    let p = d.join("cube.obj");
    std::fs::write(&p, CUBE).unwrap();
    p.display().to_string()
}

#[test]
fn memory_hungry_requests_are_errors_and_keep_the_previous_output() {
    let d = temp_dir("mem");
    let c = cube(&d);
    let out = d.join("out.obj");
    std::fs::write(&out, "previous good output\n").unwrap();
    let o_ = out.display().to_string();
    let o = run(
        &[
            "refine",
            &c,
            "--level",
            "12",
            "-o",
            &o_,
            "--memory-limit",
            "8G",
        ],
        b"",
    );
    refused(&o, "uniform refinement to level 12 would need about");
    refused(&o, "lower the level (--level), or raise --memory-limit");
    let o = run(
        &[
            "dice",
            &c,
            "--rate",
            "100000",
            "--max-rate",
            "100000",
            "-o",
            &o_,
            "--memory-limit",
            "8G",
        ],
        b"",
    );
    refused(&o, "dicing would need about");
    assert_eq!(
        std::fs::read_to_string(&out).unwrap(),
        "previous good output\n"
    );
    assert_eq!(
        std::fs::read_dir(&d).unwrap().count(),
        2,
        "no temporary files left"
    );
    let o = run(&["bench-trace", "--grid", "100000"], b"");
    refused(&o, "--grid 100000 is above the maximum of 32767");
    let o = run(
        &["bench-trace", "--grid", "30000", "--memory-limit", "1G"],
        b"",
    );
    refused(&o, "the 30000 × 30000 grid mesh would need about");
    let o = run(
        &[
            "refine",
            &c,
            "--level",
            "1",
            "-o",
            "-",
            "--memory-limit",
            "lots",
        ],
        b"",
    );
    refused(&o, "invalid size 'lots'");
    std::fs::remove_dir_all(&d).ok();
}

#[test]
fn bad_numbers_and_caps_are_errors() {
    let d = temp_dir("nums");
    let c = cube(&d);
    let big = d.join("big.obj");
    std::fs::write(&big, CUBE.replacen("v 1 1 1", "v 1e39 1 1", 1)).unwrap();
    let o = run(&["dice", &big.display().to_string(), "-o", "-"], b"");
    refused(
        &o,
        "big.obj:4: vertex 3: coordinate 1e39 1e0 1e0 is out of range",
    );
    assert!(o.stdout.is_empty());
    let o = run(&["stats", &c, "--max-level", "300"], b"");
    refused(&o, "maximum isolation level 300 is outside 1..=16");
    let o = run(
        &["bench-trace", &c, "--threads", "5000", "--reps", "1"],
        b"",
    );
    refused(&o, "--threads 5000 is above the maximum of 1024");
    // A rate above --max-rate is a warning that says what was used, and JSON says it too.
    let o = run(
        &["accuracy", &c, "--rates", "2,100000", "--rays", "200"],
        b"",
    );
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stderr(&o).contains("warning: rate 100000 is above --max-rate 256; 256 segments"));
    let text = String::from_utf8(o.stdout).unwrap();
    for line in text.lines() {
        let v: serde_json::Value = serde_json::from_str(line).unwrap();
        assert!(v["rate_used"].as_u64().unwrap() <= 256, "{line}");
        assert!(!line.contains("NaN") && !line.contains("inf"), "{line}");
    }
    std::fs::remove_dir_all(&d).ok();
}

#[test]
fn line_tools_answer_every_line_and_name_bad_ones() {
    let d = temp_dir("lines");
    let c = cube(&d);
    let mut input = b"0.1 0.2 5 0 0 -1\n".to_vec();
    input.extend_from_slice(b"\xff\xfe not text\n");
    input.extend_from_slice(b"0 0 5 0 0 1\n0.3 0.1 5 0 0 -1\n");
    let o = run(&["trace", &c, "--rate", "2", "--exact"], &input);
    refused(&o, "stdin:2: invalid UTF-8 at byte 1");
    let out = String::from_utf8(o.stdout).unwrap();
    let lines: Vec<&str> = out.lines().collect();
    assert_eq!(lines.len(), 4, "{out}");
    // `--exact` hits carry err, sharp and grazing after the normal.
    for i in [0, 3] {
        let f: Vec<&str> = lines[i].split_whitespace().collect();
        assert_eq!((f[0], f.len()), ("hit", 12), "{}", lines[i]);
        assert!(f[9].parse::<f64>().unwrap() <= 1e-12, "{}", lines[i]);
        assert_eq!((f[10], f[11]), ("0", "0"), "{}", lines[i]);
    }
    assert!(lines[1].starts_with("nan"));
    assert_eq!(lines[2], "miss");
    let o = run(&["eval", &c], b"0 0.5 0.5\n\xc3\x28\n2 0.25 0.75\n");
    refused(&o, "stdin:2: invalid UTF-8");
    let out = String::from_utf8(o.stdout).unwrap();
    assert_eq!(out.lines().count(), 3);
    assert!(out.lines().nth(1).unwrap().starts_with("nan"));
    std::fs::remove_dir_all(&d).ok();
}

#[test]
fn render_checks_outputs_first_and_never_replaces_devices() {
    let d = temp_dir("render");
    let c = cube(&d);
    let scene = d.join("s.toml");
    std::fs::write(
        &scene,
        "[render]\nwidth = 16\nheight = 8\nspp = 1\n[camera]\nposition = [0, 1, 6]\n\
         look_at = [0, 0, 0]\nfov = 40\n[materials.m]\ntype = \"diffuse\"\n\
         [[mesh]]\nfile = \"cube.obj\"\nmaterial = \"m\"\nrate = 2\n",
    )
    .unwrap();
    let _ = c;
    let s = scene.display().to_string();
    let o = run(&["render", &s, "-o", "/dev/null", "--quiet"], b"");
    refused(&o, "/dev/null: is not a regular file");
    assert!(Path::new("/dev/null").exists());
    let dd = d.display().to_string();
    let o = run(&["render", &s, "-o", &dd, "--quiet"], b"");
    refused(&o, "is a directory");
    let o = run(
        &["render", &s, "-o", "/nonexistent-dir/x.exr", "--quiet"],
        b"",
    );
    refused(&o, "cannot write into folder /nonexistent-dir");
    let o = run(&["render", &s, "-o", "-", "--quiet"], b"");
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(
        &o.stdout[..4],
        &[0x76, 0x2f, 0x31, 0x01],
        "EXR magic on stdout"
    );
    let o = run(&["render", &s, "-o", "-", "--png", "-", "--quiet"], b"");
    refused(&o, "only one output can be standard output");
    let o = run(&["render", &s, "-o", "x.png", "--quiet"], b"");
    refused(
        &o,
        "x.png: this output is written as EXR, but its extension .png",
    );
    let o = run(
        &["render", &s, "-o", "x.exr", "--png", "p.EXR", "--quiet"],
        b"",
    );
    refused(
        &o,
        "p.EXR: this output is written as PNG, but its extension .exr",
    );
    let o = run(
        &[
            "render",
            &s,
            "-o",
            "x.exr",
            "--levels-png",
            "l.jpg",
            "--quiet",
        ],
        b"",
    );
    refused(
        &o,
        "l.jpg: this output is written as PNG, but its extension .jpg",
    );
    assert!(!Path::new("x.png").exists() && !Path::new("x.exr").exists());
    let o = run(
        &["render", &s, "-o", "x.exr", "--spp", "2000000", "--quiet"],
        b"",
    );
    refused(&o, "--spp 2000000 is outside 1..=1048576");
    let o = run(
        &["render", &s, "-o", "x.exr", "--threads", "5000", "--quiet"],
        b"",
    );
    refused(&o, "--threads 5000 is above the maximum of 1024");
    // A mesh file that is not OBJ at all is an error, not an empty image.
    std::fs::write(d.join("cube.obj"), "[camera]\nfov = 3\n").unwrap();
    let exr = d.join("out.exr").display().to_string();
    let o = run(&["render", &s, "-o", &exr, "--quiet"], b"");
    refused(&o, "not an OBJ mesh");
    assert!(!Path::new(&exr).exists());
    std::fs::remove_dir_all(&d).ok();
}
