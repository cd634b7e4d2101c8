//! Sampling building blocks: orthonormal frames, warps from the unit square, discrete and
//! piecewise-constant 2D distributions, and the power heuristic. Plain `f32` arithmetic, no
//! fused multiply-add, and loops bounded by the size of their input (binary searches), so that
//! WGSL kernels can mirror them.

use glam::Vec3;
use std::f32::consts::PI;

/// An orthonormal frame `(t, b, n)` around a unit normal `n`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Frame {
    /// First tangent.
    pub t: Vec3,
    /// Second tangent.
    pub b: Vec3,
    /// Normal (the local `z` axis).
    pub n: Vec3,
}

impl Frame {
    /// A frame around the unit vector `n` (branch on the sign of `n.z` only; continuous
    /// elsewhere).
    pub fn new(n: Vec3) -> Frame {
        let sign = if n.z >= 0.0 { 1.0f32 } else { -1.0f32 };
        let a = -1.0 / (sign + n.z);
        let b = n.x * n.y * a;
        let t = Vec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x);
        let bt = Vec3::new(b, sign + n.y * n.y * a, -n.y);
        Frame { t, b: bt, n }
    }

    /// World vector to local coordinates.
    #[inline]
    pub fn to_local(&self, v: Vec3) -> Vec3 {
        Vec3::new(v.dot(self.t), v.dot(self.b), v.dot(self.n))
    }

    /// Local coordinates to a world vector.
    #[inline]
    pub fn to_world(&self, v: Vec3) -> Vec3 {
        self.t * v.x + self.b * v.y + self.n * v.z
    }
}

/// Shirley–Chiu concentric map of the unit square onto the unit disk.
pub fn concentric_disk(u1: f32, u2: f32) -> (f32, f32) {
    let a = 2.0 * u1 - 1.0;
    let b = 2.0 * u2 - 1.0;
    if a == 0.0 && b == 0.0 {
        return (0.0, 0.0);
    }
    let (r, phi) = if a.abs() > b.abs() {
        (a, (PI / 4.0) * (b / a))
    } else {
        (b, PI / 2.0 - (PI / 4.0) * (a / b))
    };
    (r * phi.cos(), r * phi.sin())
}

/// Cosine-weighted direction in the local `+z` hemisphere (Malley's method); its pdf is
/// `z / π`.
pub fn cosine_hemisphere(u1: f32, u2: f32) -> Vec3 {
    let (x, y) = concentric_disk(u1, u2);
    let z = (1.0 - x * x - y * y).max(0.0).sqrt();
    Vec3::new(x, y, z)
}

/// Uniform direction on the unit sphere; pdf `1 / (4π)`.
pub fn uniform_sphere(u1: f32, u2: f32) -> Vec3 {
    let z = 1.0 - 2.0 * u1;
    let r = (1.0 - z * z).max(0.0).sqrt();
    let phi = 2.0 * PI * u2;
    Vec3::new(r * phi.cos(), r * phi.sin(), z)
}

/// Uniform point on a triangle as barycentric weights `(b1, b2)` of corners 1 and 2.
pub fn uniform_triangle(u1: f32, u2: f32) -> (f32, f32) {
    let s = u1.sqrt();
    (s * (1.0 - u2), s * u2)
}

/// Veach's power heuristic (β = 2) for the strategy with pdf `a` against one with pdf `b`.
#[inline]
pub fn power_heuristic(a: f32, b: f32) -> f32 {
    let a2 = a * a;
    let b2 = b * b;
    if a2 + b2 > 0.0 && a2.is_finite() {
        a2 / (a2 + b2)
    } else if a2.is_finite() {
        0.0
    } else {
        1.0
    }
}

/// A discrete distribution over `n` items with non-negative weights, sampled by binary search
/// on its cumulative distribution.
#[derive(Clone, Debug, PartialEq)]
pub struct Distribution1D {
    /// Normalised cumulative weights, `cdf[0] = 0`, `cdf[n] = 1`; length `n + 1`.
    pub cdf: Vec<f32>,
    /// Probability of each item.
    pub pmf: Vec<f32>,
    /// Sum of the weights.
    pub total: f32,
}

impl Distribution1D {
    /// Builds the distribution. Negative or non-finite weights count as zero; all-zero weights
    /// give the uniform distribution. An empty list gives an empty distribution.
    pub fn new(weights: &[f32]) -> Distribution1D {
        let n = weights.len();
        let clean: Vec<f64> = weights
            .iter()
            .map(|&w| {
                if w.is_finite() && w > 0.0 {
                    w as f64
                } else {
                    0.0
                }
            })
            .collect();
        let mut total: f64 = clean.iter().sum();
        let uniform = total <= 0.0;
        if uniform {
            total = n as f64;
        }
        let mut cdf = Vec::with_capacity(n + 1);
        let mut pmf = Vec::with_capacity(n);
        let mut acc = 0.0f64;
        cdf.push(0.0f32);
        for &w in &clean {
            let w = if uniform { 1.0 } else { w };
            acc += w;
            cdf.push((acc / total) as f32);
            pmf.push((w / total) as f32);
        }
        if let Some(last) = cdf.last_mut() {
            *last = 1.0;
        }
        Distribution1D {
            cdf,
            pmf,
            total: if uniform { 0.0 } else { total as f32 },
        }
    }

    /// Number of items.
    pub fn len(&self) -> usize {
        self.pmf.len()
    }

    /// Whether there are no items.
    pub fn is_empty(&self) -> bool {
        self.pmf.is_empty()
    }

    /// Samples an item for `u ∈ [0, 1)`: returns `(index, pmf, u remapped to [0, 1) within the
    /// item)`. Items of zero probability are never returned. Must not be called when empty.
    pub fn sample(&self, u: f32) -> (usize, f32, f32) {
        let n = self.pmf.len();
        // Largest i in [0, n) with cdf[i] <= u and pmf[i] > 0.
        let (mut lo, mut hi) = (0usize, n);
        while hi - lo > 1 {
            let mid = (lo + hi) / 2;
            if self.cdf[mid] <= u {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        let mut i = lo;
        // Skip zero-probability items that share a cdf value (bounded by n).
        while i + 1 < n && self.pmf[i] <= 0.0 {
            i += 1;
        }
        let p = self.pmf[i];
        let rem = if p > 0.0 {
            ((u - self.cdf[i]) / p).clamp(0.0, 1.0 - f32::EPSILON / 2.0)
        } else {
            0.0
        };
        (i, p, rem)
    }
}

/// A piecewise-constant density on `[0, 1)²` over a `width × height` grid: a marginal
/// distribution over rows and a conditional distribution over columns of each row.
#[derive(Clone, Debug, PartialEq)]
pub struct Distribution2D {
    /// Grid width (columns).
    pub width: usize,
    /// Grid height (rows).
    pub height: usize,
    /// Marginal over rows.
    pub rows: Distribution1D,
    /// Conditional over columns, one per row.
    pub cols: Vec<Distribution1D>,
}

impl Distribution2D {
    /// From row-major weights (`weights[y * width + x]`).
    pub fn new(weights: &[f32], width: usize, height: usize) -> Distribution2D {
        let cols: Vec<Distribution1D> = (0..height)
            .map(|y| Distribution1D::new(&weights[y * width..(y + 1) * width]))
            .collect();
        let row_w: Vec<f32> = cols.iter().map(|c| c.total).collect();
        Distribution2D {
            width,
            height,
            rows: Distribution1D::new(&row_w),
            cols,
        }
    }

    /// Samples a point: `((x, y) in [0,1)², density w.r.t. area of the unit square)`.
    pub fn sample(&self, u1: f32, u2: f32) -> ([f32; 2], f32) {
        let (y, py, ry) = self.rows.sample(u1);
        let (x, px, rx) = self.cols[y].sample(u2);
        let pdf = py * px * (self.width * self.height) as f32;
        (
            [
                (x as f32 + rx) / self.width as f32,
                (y as f32 + ry) / self.height as f32,
            ],
            pdf,
        )
    }

    /// Density at cell `(x, y)` w.r.t. area of the unit square.
    pub fn pdf_cell(&self, x: usize, y: usize) -> f32 {
        self.rows.pmf[y] * self.cols[y].pmf[x] * (self.width * self.height) as f32
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frame_is_orthonormal() {
        for n in [
            Vec3::Z,
            -Vec3::Z,
            Vec3::X,
            Vec3::new(0.3, -0.5, 0.8).normalize(),
            Vec3::new(0.0, 1e-8, -1.0).normalize(),
        ] {
            let f = Frame::new(n);
            assert!((f.t.length() - 1.0).abs() < 1e-5);
            assert!((f.b.length() - 1.0).abs() < 1e-5);
            assert!(f.t.dot(f.b).abs() < 1e-5 && f.t.dot(n).abs() < 1e-5);
            assert!((f.t.cross(f.b) - n).length() < 1e-5);
            let v = Vec3::new(0.1, 0.7, -0.2);
            assert!((f.to_world(f.to_local(v)) - v).length() < 1e-6);
        }
    }

    #[test]
    fn warps_stay_on_their_domains() {
        for i in 0..64 {
            for j in 0..64 {
                let (u1, u2) = (i as f32 / 64.0, j as f32 / 64.0);
                let (x, y) = concentric_disk(u1, u2);
                assert!(x * x + y * y <= 1.0 + 1e-6);
                let d = cosine_hemisphere(u1, u2);
                assert!(d.z >= 0.0 && (d.length() - 1.0).abs() < 1e-5);
                let s = uniform_sphere(u1, u2);
                assert!((s.length() - 1.0).abs() < 1e-5);
                let (b1, b2) = uniform_triangle(u1, u2);
                assert!(b1 >= 0.0 && b2 >= 0.0 && b1 + b2 <= 1.0 + 1e-6);
            }
        }
    }

    #[test]
    fn distribution_1d() {
        let d = Distribution1D::new(&[1.0, 0.0, 3.0, 0.0]);
        assert_eq!(d.pmf, vec![0.25, 0.0, 0.75, 0.0]);
        assert_eq!(d.sample(0.1).0, 0);
        assert_eq!(d.sample(0.25).0, 2);
        assert_eq!(d.sample(0.9999).0, 2);
        let (_, _, r) = d.sample(0.625);
        assert!((r - 0.5).abs() < 1e-6);
        let z = Distribution1D::new(&[0.0, 0.0]);
        assert_eq!(z.pmf, vec![0.5, 0.5]);
        let bad = Distribution1D::new(&[f32::NAN, -1.0, 2.0]);
        assert_eq!(bad.sample(0.0).0, 2);
    }

    #[test]
    fn distribution_2d_pdf_matches_sampling() {
        let w = [1.0, 2.0, 3.0, 4.0, 0.0, 6.0];
        let d = Distribution2D::new(&w, 3, 2);
        let (p, pdf) = d.sample(0.9, 0.5);
        let (x, y) = ((p[0] * 3.0) as usize, (p[1] * 2.0) as usize);
        assert_eq!(y, 1);
        assert!((pdf - d.pdf_cell(x, y)).abs() < 1e-5);
        // Density integrates to one.
        let mut s = 0.0;
        for y in 0..2 {
            for x in 0..3 {
                s += d.pdf_cell(x, y) / 6.0;
            }
        }
        assert!((s - 1.0).abs() < 1e-5);
        assert_eq!(d.pdf_cell(1, 1), 0.0);
    }

    #[test]
    fn power_heuristic_limits() {
        assert_eq!(power_heuristic(1.0, 0.0), 1.0);
        assert_eq!(power_heuristic(0.0, 1.0), 0.0);
        assert_eq!(power_heuristic(0.0, 0.0), 0.0);
        assert_eq!(power_heuristic(f32::INFINITY, 1.0), 1.0);
        assert!((power_heuristic(1.0, 1.0) - 0.5).abs() < 1e-7);
    }
}
