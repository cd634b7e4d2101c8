//! Output files are never lost: a write that fails on a full file system (here a file-size
//! limit, `RLIMIT_FSIZE`, in a child process: the same `EFBIG`/`ENOSPC` path as a full disk,
//! without needing a mount), a run killed mid-write, and two processes writing the same path
//! at once all leave a complete, readable file.
//!
//! The children are this test binary run again with `LIMITRAY_OUTPUT_CHILD` set, which makes
//! [`child`] do the child's part instead of returning at once.

use limitray::io::exr::{read_channels, write_planes};
use std::path::{Path, PathBuf};
use std::process::Command;

const CHILD: &str = "LIMITRAY_OUTPUT_CHILD";

fn temp_dir(tag: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("limitray-output-{tag}-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// A `w × w` single-channel EXR whose samples are `value` plus incompressible noise below
/// 1e-3, so that files are large and a truncated one cannot pass for whole.
fn write_image(path: &Path, w: usize, value: f32, seed: u64) -> limitray::Result<()> {
    let mut rng = limitray::harness::rng::SplitMix64(seed);
    let r: Vec<f32> = (0..w * w)
        .map(|_| value + (rng.next_f64() as f32) * 1e-3)
        .collect();
    write_planes(path, w, w, vec![("R", r)])
}

/// Reads the image and returns its value (every sample's integer part), or why it is not a
/// complete image of one value.
fn image_value(path: &Path) -> Result<f32, String> {
    let ch = read_channels(path).map_err(|e| e.to_string())?;
    let r = ch.get("R").ok_or("no R channel")?;
    let v = r[0].floor();
    if r.iter().any(|x| x.floor() != v) {
        return Err("mixed values".into());
    }
    Ok(v)
}

fn spawn_child(mode: &str, path: &Path) -> Command {
    let mut c = Command::new(std::env::current_exe().unwrap());
    c.args(["--exact", "child", "--nocapture", "--test-threads", "1"])
        .env(CHILD, format!("{mode}:{}", path.display()));
    c
}

fn others(dir: &Path, keep: &str) -> Vec<String> {
    std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n != keep)
        .collect()
}

/// The children's side; an ordinary test run returns at once (the parent tests below check
/// what the children did).
#[test]
fn child() {
    let Ok(spec) = std::env::var(CHILD) else {
        return;
    };
    let (mode, path) = spec.split_once(':').unwrap();
    let path = Path::new(path);
    match mode {
        // A 64 KiB file-size limit; SIGXFSZ ignored, so writes fail with EFBIG.
        "full" | "killed" => {
            let lim = libc::rlimit {
                rlim_cur: 64 << 10,
                rlim_max: 64 << 10,
            };
            // SAFETY: plain system calls on this process.
            unsafe {
                assert_eq!(libc::setrlimit(libc::RLIMIT_FSIZE, &lim), 0);
                if mode == "full" {
                    libc::signal(libc::SIGXFSZ, libc::SIG_IGN);
                }
            }
            match write_image(path, 512, 7.0, 2) {
                Ok(()) => println!("child: unexpectedly written"),
                Err(e) => println!("child: error: {e}"),
            }
        }
        w @ ("writer1" | "writer2") => {
            let v = if w == "writer1" { 1.0 } else { 2.0 };
            for i in 0..15 {
                write_image(path, 256, v, i).unwrap();
            }
        }
        _ => panic!("unknown child mode {mode}"),
    }
}

#[test]
fn a_full_file_system_leaves_the_previous_file_intact() {
    let d = temp_dir("full");
    let p = d.join("out.exr");
    write_image(&p, 32, 3.0, 1).unwrap();
    let before = std::fs::read(&p).unwrap();
    let out = spawn_child("full", &p).output().unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "{stdout}");
    assert!(stdout.contains("child: error: "), "{stdout}");
    assert!(stdout.contains("File too large"), "{stdout}");
    assert_eq!(std::fs::read(&p).unwrap(), before);
    assert_eq!(image_value(&p), Ok(3.0));
    // The failed run removed its temporary file.
    assert!(
        others(&d, "out.exr").is_empty(),
        "{:?}",
        others(&d, "out.exr")
    );

    // Killed by SIGXFSZ mid-write: the target is untouched (a temporary file may remain).
    let out = spawn_child("killed", &p).output().unwrap();
    assert!(!out.status.success());
    assert_eq!(std::fs::read(&p).unwrap(), before);
    std::fs::remove_dir_all(&d).ok();
}

#[test]
fn concurrent_writers_always_leave_a_complete_file() {
    let d = temp_dir("concurrent");
    let p = d.join("out.exr");
    write_image(&p, 256, 5.0, 0).unwrap();
    let mut a = spawn_child("writer1", &p).spawn().unwrap();
    let mut b = spawn_child("writer2", &p).spawn().unwrap();
    let mut reads = 0;
    let mut seen = std::collections::BTreeSet::new();
    loop {
        // Every read while both write is a whole image of one writer (or the original).
        let v = image_value(&p).unwrap_or_else(|e| panic!("read {reads}: {e}"));
        seen.insert(v as i32);
        reads += 1;
        let done_a = a.try_wait().unwrap().is_some();
        let done_b = b.try_wait().unwrap().is_some();
        if done_a && done_b {
            break;
        }
    }
    assert!(a.wait().unwrap().success() && b.wait().unwrap().success());
    let last = image_value(&p).unwrap();
    assert!(last == 1.0 || last == 2.0, "{last}");
    assert!(seen.iter().all(|v| [1, 2, 5].contains(v)), "{seen:?}");
    assert!(
        others(&d, "out.exr").is_empty(),
        "{:?}",
        others(&d, "out.exr")
    );
    eprintln!("{reads} reads, values seen {seen:?}");
    std::fs::remove_dir_all(&d).ok();
}

#[test]
fn a_device_or_directory_is_never_replaced() {
    // `render` used to unlink whatever the output path was when writing failed.
    let e = write_image(Path::new("/dev/null"), 4, 1.0, 0).unwrap_err();
    assert!(e.to_string().contains("not a regular file"), "{e}");
    assert!(Path::new("/dev/null").exists());
    let d = temp_dir("dir");
    let e = write_image(&d, 4, 1.0, 0).unwrap_err();
    assert!(e.to_string().contains("is a directory"), "{e}");
    assert!(d.is_dir());
    std::fs::remove_dir_all(&d).ok();
}
