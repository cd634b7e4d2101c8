//! Running `target/osd/osd_oracle` (benches/osd/osd_oracle.cpp, OpenSubdiv 3.5 Far in double
//! precision) and reading what it prints.

use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};

/// The oracle binary; `None` (with a note) when it is not built, except under `CI=true`, where
/// a missing reference is a failure.
pub fn binary() -> Option<PathBuf> {
    crate::common::osd_binary("osd_oracle")
}

/// One uniformly refined level as Far orders it.
#[derive(Debug, Default)]
pub struct FarLevel {
    pub positions: Vec<[f64; 3]>,
    /// (hole, vertices) per face.
    pub faces: Vec<(bool, Vec<u32>)>,
}

/// A Far sample: `None` where Far has no patch (holes, unsupported boundary faces).
#[derive(Clone, Debug)]
pub struct FarSample {
    /// Far's patch type (REGULAR, GREGORY_BASIS, ...).
    pub kind: String,
    pub depth: u32,
    /// p, du, dv, duu, duv, dvv.
    pub d: [[f64; 3]; 6],
}

/// What Far made of one mesh.
#[derive(Debug, Default)]
pub struct FarResult {
    pub levels: Vec<FarLevel>,
    pub samples: Vec<Option<FarSample>>,
}

fn nums<T: std::str::FromStr>(line: &str) -> Vec<T>
where
    T::Err: std::fmt::Debug,
{
    line.split_whitespace()
        .map(|x| x.parse().unwrap())
        .collect()
}

/// Runs the oracle on `obj` (written to `path`): uniform refinement to `levels`, evaluation of
/// `samples`. `Err` carries Far's message when it refuses the mesh.
pub fn run(
    bin: &Path,
    path: &Path,
    obj: &str,
    levels: usize,
    samples: &[(usize, usize, f64, f64)],
) -> Result<FarResult, String> {
    run_scheme(bin, path, obj, levels, samples, false)
}

/// [`run`] under the Loop scheme (`loop_scheme`) or Catmull-Clark.
pub fn run_scheme(
    bin: &Path,
    path: &Path,
    obj: &str,
    levels: usize,
    samples: &[(usize, usize, f64, f64)],
    loop_scheme: bool,
) -> Result<FarResult, String> {
    std::fs::write(path, obj).unwrap();
    let mut cmd = Command::new(bin);
    cmd.arg(path);
    if loop_scheme {
        cmd.arg("--loop");
    }
    if levels > 0 {
        cmd.args(["--refine", &levels.to_string()]);
    }
    if !samples.is_empty() || !loop_scheme {
        cmd.arg("--eval");
    }
    let mut child = cmd
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut input = String::new();
    for &(f, k, u, v) in samples {
        input.push_str(&format!("{f} {k} {u:?} {v:?}\n"));
    }
    let mut stdin = child.stdin.take().unwrap();
    let writer = std::thread::spawn(move || stdin.write_all(input.as_bytes()));
    let out = child.wait_with_output().unwrap();
    writer.join().unwrap().unwrap();
    if !out.status.success() {
        return Err(String::from_utf8_lossy(&out.stderr).into_owned());
    }
    let text = String::from_utf8(out.stdout).unwrap();
    let mut lines = text.lines();
    let mut res = FarResult::default();
    while let Some(head) = lines.next() {
        let w: Vec<&str> = head.split_whitespace().collect();
        match w[0] {
            "level" => {
                let (nv, nf): (usize, usize) = (w[2].parse().unwrap(), w[3].parse().unwrap());
                let mut lvl = FarLevel::default();
                for _ in 0..nv {
                    let c: Vec<f64> = nums(lines.next().unwrap());
                    lvl.positions.push([c[0], c[1], c[2]]);
                }
                for _ in 0..nf {
                    let c: Vec<u32> = nums(lines.next().unwrap());
                    lvl.faces.push((c[0] == 1, c[2..].to_vec()));
                }
                res.levels.push(lvl);
            }
            "eval" => {
                let n: usize = w[1].parse().unwrap();
                for _ in 0..n {
                    let l = lines.next().unwrap();
                    let t: Vec<&str> = l.split_whitespace().collect();
                    if t[0] == "none" {
                        res.samples.push(None);
                        continue;
                    }
                    let c: Vec<f64> = t[3..].iter().map(|x| x.parse().unwrap()).collect();
                    res.samples.push(Some(FarSample {
                        kind: t[1].to_string(),
                        depth: t[2].parse().unwrap(),
                        d: std::array::from_fn(|i| [c[3 * i], c[3 * i + 1], c[3 * i + 2]]),
                    }));
                }
            }
            other => panic!("unexpected oracle output line '{other}'"),
        }
    }
    Ok(res)
}
