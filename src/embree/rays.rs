//! Reproducible ray sets for cross-checks and benchmarks: incoherent random rays, coherent
//! camera rays and "rays from inside" for leak counts.

/// A ray as plain arrays: `origin + t dir`, `t ≥ 0`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TestRay {
    /// Origin.
    pub origin: [f32; 3],
    /// Direction (unit length for incoherent and camera rays).
    pub dir: [f32; 3],
}

/// SplitMix64: a small, fast, reproducible generator (Steele, Lea, Flood 2014).
#[derive(Clone, Debug)]
pub struct SplitMix64(u64);

impl SplitMix64 {
    /// A generator from a seed.
    pub fn new(seed: u64) -> Self {
        SplitMix64(seed)
    }

    /// The next 64 random bits.
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Uniform in `[0, 1)`.
    pub fn next_f64(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
    }

    /// Uniform in `0..n` (`n > 0`).
    pub fn below(&mut self, n: usize) -> usize {
        (((self.next_u64() >> 32) * n as u64) >> 32) as usize
    }

    /// Uniform on the unit sphere.
    pub fn unit_vector(&mut self) -> [f64; 3] {
        let z = 2.0 * self.next_f64() - 1.0;
        let phi = std::f64::consts::TAU * self.next_f64();
        let r = (1.0 - z * z).max(0.0).sqrt();
        [r * phi.cos(), r * phi.sin(), z]
    }
}

fn centre_and_diagonal(bounds: [[f64; 3]; 2]) -> ([f64; 3], f64) {
    let [lo, hi] = bounds;
    let c = [
        0.5 * (lo[0] + hi[0]),
        0.5 * (lo[1] + hi[1]),
        0.5 * (lo[2] + hi[2]),
    ];
    let d = ((hi[0] - lo[0]).powi(2) + (hi[1] - lo[1]).powi(2) + (hi[2] - lo[2]).powi(2)).sqrt();
    (c, d)
}

fn normalise(v: [f64; 3]) -> [f64; 3] {
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

/// A point of a diced surface for a leak ray: the ray goes through `point` along a direction
/// within `max_tilt` radians of `normal`, chosen so that every triangle around the point faces
/// it (the triangles' normals make an angle below 90° with it).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LeakTarget {
    /// A diced vertex or a point on a diced edge.
    pub point: [f32; 3],
    /// Unit normal of the cone of allowed directions.
    pub normal: [f64; 3],
    /// Half-angle of that cone, radians.
    pub max_tilt: f64,
}

/// Leak rays: for each ray a random target, a direction `m` uniform in its cone, the origin
/// `point - depth m` (behind the surface) and the direction `point - origin`, so the ray passes
/// through the point at `t ≈ 1` (to float rounding). Every triangle around the point faces `m`,
/// so the fan projects one-to-one along the ray: a watertight intersector must report a hit
/// (at the point, or before it). Every miss is a leak.
pub fn towards_points(targets: &[LeakTarget], depth: f64, n: usize, seed: u64) -> Vec<TestRay> {
    let mut rng = SplitMix64::new(seed);
    if targets.is_empty() {
        return Vec::new();
    }
    (0..n)
        .map(|_| {
            let t = targets[rng.below(targets.len())];
            let nrm = normalise(t.normal);
            // Uniform on the spherical cap of half-angle max_tilt around the normal.
            let cos_max = t.max_tilt.clamp(0.0, std::f64::consts::FRAC_PI_2).cos();
            let c = 1.0 - rng.next_f64() * (1.0 - cos_max);
            let s = (1.0 - c * c).max(0.0).sqrt();
            let phi = std::f64::consts::TAU * rng.next_f64();
            let helper = if nrm[0].abs() < 0.9 {
                [1.0, 0.0, 0.0]
            } else {
                [0.0, 1.0, 0.0]
            };
            let a = normalise(cross(nrm, helper));
            let b = cross(nrm, a);
            let m: [f64; 3] =
                std::array::from_fn(|k| c * nrm[k] + s * (phi.cos() * a[k] + phi.sin() * b[k]));
            let p = t.point;
            let o: [f32; 3] = std::array::from_fn(|k| (p[k] as f64 - depth * m[k]) as f32);
            let dir: [f32; 3] = std::array::from_fn(|k| p[k] - o[k]);
            TestRay { origin: o, dir }
        })
        .collect()
}

/// Cross product.
pub fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}
