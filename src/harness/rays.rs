//! Ray sets of the benchmarks and tests: coherent camera rays and incoherent random rays
//! around a bounding box.

use super::rng::SplitMix64;
use crate::bvh::Ray;

/// A ray as plain arrays: `origin + t dir`, `t ≥ 0`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TestRay {
    /// Origin.
    pub origin: [f32; 3],
    /// Direction (unit length for incoherent and camera rays).
    pub dir: [f32; 3],
}

pub(crate) fn centre_and_diagonal(bounds: [[f64; 3]; 2]) -> ([f64; 3], f64) {
    let [lo, hi] = bounds;
    let c = [
        0.5 * (lo[0] + hi[0]),
        0.5 * (lo[1] + hi[1]),
        0.5 * (lo[2] + hi[2]),
    ];
    let d = ((hi[0] - lo[0]).powi(2) + (hi[1] - lo[1]).powi(2) + (hi[2] - lo[2]).powi(2)).sqrt();
    (c, d)
}

pub(crate) fn normalise(v: [f64; 3]) -> [f64; 3] {
    let l = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
    if l > 0.0 {
        [v[0] / l, v[1] / l, v[2] / l]
    } else {
        [0.0, 0.0, 1.0]
    }
}

/// `n` incoherent rays: origins uniform on the sphere of radius one diagonal around the
/// centre of `bounds`, unit directions towards points uniform in the box. Most of them hit.
pub fn incoherent(bounds: [[f64; 3]; 2], n: usize, seed: u64) -> Vec<TestRay> {
    let (c, diag) = centre_and_diagonal(bounds);
    let [lo, hi] = bounds;
    let mut rng = SplitMix64::new(seed);
    (0..n)
        .map(|_| {
            let s = rng.unit_vector();
            let o = [c[0] + diag * s[0], c[1] + diag * s[1], c[2] + diag * s[2]];
            let target: [f64; 3] =
                std::array::from_fn(|k| lo[k] + (hi[k] - lo[k]) * rng.next_f64());
            let d = normalise([target[0] - o[0], target[1] - o[1], target[2] - o[2]]);
            TestRay {
                origin: o.map(|x| x as f32),
                dir: d.map(|x| x as f32),
            }
        })
        .collect()
}

/// Primary rays of a pinhole camera, row by row (coherent): `width × height` pixels, 40° vertical
/// field of view, looking at the centre of `bounds` from direction `(1, 0.6, 1.4)` (normalised)
/// at one diagonal, so the object fills most of the frame.
pub fn camera(bounds: [[f64; 3]; 2], width: usize, height: usize) -> Vec<TestRay> {
    let (c, diag) = centre_and_diagonal(bounds);
    let back = normalise([1.0, 0.6, 1.4]);
    let eye = [
        c[0] + diag * back[0],
        c[1] + diag * back[1],
        c[2] + diag * back[2],
    ];
    let fwd = [-back[0], -back[1], -back[2]];
    let up0 = [0.0, 1.0, 0.0];
    let right = normalise([
        fwd[1] * up0[2] - fwd[2] * up0[1],
        fwd[2] * up0[0] - fwd[0] * up0[2],
        fwd[0] * up0[1] - fwd[1] * up0[0],
    ]);
    let up = [
        right[1] * fwd[2] - right[2] * fwd[1],
        right[2] * fwd[0] - right[0] * fwd[2],
        right[0] * fwd[1] - right[1] * fwd[0],
    ];
    let half_h = (20.0f64).to_radians().tan();
    let half_w = half_h * width as f64 / height.max(1) as f64;
    let mut rays = Vec::with_capacity(width * height);
    for y in 0..height {
        for x in 0..width {
            let sx = (2.0 * (x as f64 + 0.5) / width as f64 - 1.0) * half_w;
            let sy = (1.0 - 2.0 * (y as f64 + 0.5) / height as f64) * half_h;
            let d = normalise(std::array::from_fn(|k| fwd[k] + sx * right[k] + sy * up[k]));
            rays.push(TestRay {
                origin: eye.map(|x| x as f32),
                dir: d.map(|x| x as f32),
            });
        }
    }
    rays
}

/// A square-ish camera image of about `n` pixels: `(width, height)`.
pub fn camera_size(n: usize) -> (usize, usize) {
    let w = (n as f64).sqrt().round().max(1.0) as usize;
    (w, n.div_ceil(w))
}

fn to_f64(b: [[f32; 3]; 2]) -> [[f64; 3]; 2] {
    b.map(|c| c.map(f64::from))
}

/// About `n` coherent camera rays ([`camera`] at [`camera_size`]`(n)`) looking at `bounds`.
pub fn camera_rays(bounds: [[f32; 3]; 2], n: usize) -> Vec<Ray> {
    let (w, h) = camera_size(n);
    camera(to_f64(bounds), w, h)
        .into_iter()
        .take(n)
        .map(|r| Ray::new(r.origin, r.dir))
        .collect()
}

/// `n` incoherent rays ([`incoherent`]) around `bounds`, deterministic in `seed`.
pub fn random_rays(bounds: [[f32; 3]; 2], n: usize, seed: u64) -> Vec<Ray> {
    incoherent(to_f64(bounds), n, seed)
        .into_iter()
        .map(|r| Ray::new(r.origin, r.dir))
        .collect()
}
