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
