//! The environment: light arriving from infinitely far away, constant or from a lat-long map.
//!
//! Lat-long convention (`y` is up): a direction `d` maps to the map point
//! `u = 0.5 + atan2(d.x, -d.z) / 2π` (columns, left to right; the centre column looks along
//! `-z`), `v = acos(d.y) / π` (rows, top row = zenith). A rotation of the map about `+y` by
//! `rotate` radians turns the whole sky counter-clockwise seen from above. Texels are looked up
//! without filtering (nearest), which keeps the importance-sampling density exactly
//! proportional to what is returned: the sampling density is proportional to
//! `max(r, g, b) · sin θ` per texel, plus a small floor so that no texel with radiance has
//! zero density.

use super::sampling::{uniform_sphere, Distribution2D};
use glam::Vec3;
use std::f32::consts::PI;

/// A lat-long radiance map with its sampling distribution.
#[derive(Clone, Debug, PartialEq)]
pub struct EnvMap {
    /// Width in texels.
    pub width: usize,
    /// Height in texels.
    pub height: usize,
    /// Row-major radiance, already multiplied by the intensity.
    pub texels: Vec<Vec3>,
    /// Importance-sampling distribution over texels.
    pub dist: Distribution2D,
    /// Mean radiance over the sphere (solid-angle weighted).
    pub mean: Vec3,
}

/// Light from infinitely far away.
#[derive(Clone, Debug, PartialEq)]
pub enum Environment {
    /// The same radiance from every direction.
    Constant(Vec3),
    /// A lat-long map, rotated about `+y` by `rotate` radians.
    Map {
        /// The map.
        map: Box<EnvMap>,
        /// Rotation about `+y` in radians.
        rotate: f32,
    },
}

/// Bad texels of a map, counted before it is used (the scene loader makes non-finite ones an
/// error and warns about negative ones, which [`EnvMap::new`] reads as 0).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct TexelReport {
    /// Texels with a NaN or infinite component once scaled by the intensity.
    pub non_finite: usize,
    /// Index of the first of them (meaningful when `non_finite > 0`).
    pub first_non_finite: usize,
    /// Finite texels with a negative component.
    pub negative: usize,
}

impl TexelReport {
    /// Counts the bad texels of `texels` scaled by `intensity`.
    pub fn new(texels: &[Vec3], intensity: f32) -> TexelReport {
        let mut r = TexelReport::default();
        for (i, &t) in texels.iter().enumerate() {
            let s = t * intensity;
            if !t.is_finite() || !s.is_finite() {
                if r.non_finite == 0 {
                    r.first_non_finite = i;
                }
                r.non_finite += 1;
            } else if t.min_element() < 0.0 {
                r.negative += 1;
            }
        }
        r
    }
}

impl EnvMap {
    /// A map from row-major texels, scaled by `intensity`. `None` when empty or with a size
    /// that does not match.
    pub fn new(width: usize, height: usize, texels: Vec<Vec3>, intensity: f32) -> Option<EnvMap> {
        if width == 0 || height == 0 || texels.len() != width * height {
            return None;
        }
        let texels: Vec<Vec3> = texels
            .into_iter()
            .map(|t| {
                let t = t * intensity;
                if t.is_finite() {
                    t.max(Vec3::ZERO)
                } else {
                    Vec3::ZERO
                }
            })
            .collect();
        let mut weights = Vec::with_capacity(width * height);
        let mut sum = Vec3::ZERO.as_dvec3();
        let mut wsum = 0.0f64;
        for y in 0..height {
            let sin_t = (PI * (y as f32 + 0.5) / height as f32).sin();
            for x in 0..width {
                let t = texels[y * width + x];
                let m = t.max_element();
                weights.push((m + 1e-3 * m.max(1e-6)) * sin_t);
                sum += t.as_dvec3() * sin_t as f64;
                wsum += sin_t as f64;
            }
        }
        let mean = (sum / wsum.max(1e-30)).as_vec3();
        Some(EnvMap {
            width,
            height,
            dist: Distribution2D::new(&weights, width, height),
            texels,
            mean,
        })
    }

    fn texel_of(&self, u: f32, v: f32) -> (usize, usize) {
        let x = ((u * self.width as f32) as usize).min(self.width - 1);
        let y = ((v * self.height as f32) as usize).min(self.height - 1);
        (x, y)
    }
}

/// Map coordinates `(u, v) ∈ [0,1)²` of a unit direction (no rotation).
pub fn dir_to_uv(d: Vec3) -> (f32, f32) {
    let mut u = 0.5 + d.x.atan2(-d.z) * (0.5 / PI);
    if u >= 1.0 {
        u -= 1.0;
    }
    if u < 0.0 {
        u += 1.0;
    }
    let v = d.y.clamp(-1.0, 1.0).acos() * (1.0 / PI);
    (u, v)
}

/// Unit direction of map coordinates `(u, v)` and `sin θ` there.
pub fn uv_to_dir(u: f32, v: f32) -> (Vec3, f32) {
    let theta = PI * v;
    let phi = 2.0 * PI * (u - 0.5);
    let st = theta.sin();
    (Vec3::new(st * phi.sin(), theta.cos(), -st * phi.cos()), st)
}

fn rot_y(d: Vec3, angle: f32) -> Vec3 {
    let (s, c) = angle.sin_cos();
    Vec3::new(c * d.x + s * d.z, d.y, c * d.z - s * d.x)
}

impl Environment {
    /// Radiance arriving along `-dir` (i.e. seen when looking in unit direction `dir`).
    pub fn eval(&self, dir: Vec3) -> Vec3 {
        match self {
            Environment::Constant(c) => *c,
            Environment::Map { map, rotate } => {
                let (u, v) = dir_to_uv(rot_y(dir, -*rotate));
                let (x, y) = map.texel_of(u, v);
                map.texels[y * map.width + x]
            }
        }
    }

    /// Samples a direction: `(unit direction, radiance, solid-angle pdf)`.
    pub fn sample(&self, u1: f32, u2: f32) -> (Vec3, Vec3, f32) {
        match self {
            Environment::Constant(c) => (uniform_sphere(u1, u2), *c, 1.0 / (4.0 * PI)),
            Environment::Map { map, rotate } => {
                let ([u, v], _) = map.dist.sample(u1, u2);
                let (d, _) = uv_to_dir(u, v);
                let d = rot_y(d, *rotate);
                // Radiance and density of the texel the direction looks up, so that sampling,
                // `eval` and `pdf` agree exactly even where rounding moves a sample across a
                // texel border.
                (d, self.eval(d), self.pdf(d))
            }
        }
    }

    /// Solid-angle density with which [`Environment::sample`] returns `dir`.
    pub fn pdf(&self, dir: Vec3) -> f32 {
        match self {
            Environment::Constant(_) => 1.0 / (4.0 * PI),
            Environment::Map { map, rotate } => {
                let (u, v) = dir_to_uv(rot_y(dir, -*rotate));
                let (x, y) = map.texel_of(u, v);
                let st = (PI * v).sin();
                if st <= 0.0 {
                    return 0.0;
                }
                map.dist.pdf_cell(x, y) / (2.0 * PI * PI * st)
            }
        }
    }

    /// Mean radiance over all directions (for light selection).
    pub fn mean(&self) -> Vec3 {
        match self {
            Environment::Constant(c) => *c,
            Environment::Map { map, .. } => map.mean,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::render::rng::PathRng;

    fn test_map() -> Environment {
        let (w, h) = (32, 16);
        let mut t = vec![Vec3::splat(0.1); w * h];
        t[4 * w + 20] = Vec3::new(50.0, 40.0, 30.0);
        Environment::Map {
            map: Box::new(EnvMap::new(w, h, t, 2.0).unwrap()),
            rotate: 0.7,
        }
    }

    #[test]
    fn uv_round_trip() {
        for d in [
            Vec3::new(0.3, 0.4, -0.5),
            Vec3::new(-0.7, -0.2, 0.1),
            Vec3::new(0.0, 0.0, -1.0),
        ] {
            let d = d.normalize();
            let (u, v) = dir_to_uv(d);
            let (e, _) = uv_to_dir(u, v);
            assert!((d - e).length() < 1e-5, "{d} {e}");
        }
        assert_eq!(dir_to_uv(Vec3::new(0.0, 0.0, -1.0)), (0.5, 0.5));
    }

    #[test]
    fn sampling_is_unbiased() {
        // E[L / pdf] over sampled directions = ∫ L dω = 4π · mean.
        let env = test_map();
        let n = 100_000u32;
        let mut est = 0.0f64;
        let mut zero = 0;
        for i in 0..n {
            let r = PathRng::new(1, i, 0);
            let (d, l, pdf) = env.sample(r.get(0), r.get(1));
            if pdf == 0.0 {
                // Only exactly at a pole (sin θ = 0); the integrator drops such samples.
                zero += 1;
                continue;
            }
            let p2 = env.pdf(d);
            // Equal up to the rounding of the direction ↔ (u, v) round trip (sin θ near the poles).
            assert!((pdf - p2).abs() < 1e-2 * pdf, "{pdf} {p2}");
            assert!((env.eval(d) - l).length() < 1e-4 * l.length().max(1.0));
            est += (l.x / pdf) as f64;
        }
        assert!(zero < 10, "{zero} samples at a pole");
        let want = 4.0 * std::f64::consts::PI * env.mean().x as f64;
        assert!(
            ((est / n as f64) - want).abs() < 0.01 * want,
            "{} {want}",
            est / n as f64
        );
    }

    #[test]
    fn bad_maps() {
        assert!(EnvMap::new(0, 1, vec![], 1.0).is_none());
        assert!(EnvMap::new(2, 2, vec![Vec3::ONE; 3], 1.0).is_none());
        let m = EnvMap::new(1, 1, vec![Vec3::splat(f32::NAN)], 1.0).unwrap();
        assert_eq!(m.texels[0], Vec3::ZERO);
    }
}
