//! The triangular Gregory patch of paper 002, Eq. 1: cubic boundary curves (corners `p_i`,
//! edge points `e_i⁺` toward corner `i + 1` and `e_i⁻` toward corner `i − 1`) degree-elevated to
//! a quartic Bézier net whose three interior points are blended from two points each,
//!
//! ```text
//! F_0 = (b2 f_0⁻ + b1 f_0⁺) / (b1 + b2),  F_1 = (b0 f_1⁻ + b2 f_1⁺) / (b2 + b0),
//! F_2 = (b1 f_2⁻ + b0 f_2⁺) / (b0 + b1),
//! ```
//!
//! with `(b0, b1, b2)` the barycentric weights of the corners. On edge `i → i + 1` the interior
//! row is `f_i⁺, f_{i+1}⁻` alone, so each edge's cross-boundary derivative is set by its own
//! two points: what makes tangent-plane continuity possible (see [`super::construct`]).
//!
//! The parameter is OpenSubdiv's triangle parameter `(u, v)`: corner 0 at `(0, 0)`, corner 1
//! at `(1, 0)`, corner 2 at `(0, 1)`, so `b0 = 1 − u − v`, `b1 = u`, `b2 = v`. A patch whose
//! `f⁺` and `f⁻` coincide is an ordinary quartic Bézier triangle (how PN triangles, cubic, are
//! stored after degree elevation).

use crate::patch::loop_box::{bernstein, bezier_indices};

/// A triangular Gregory patch: 15 control points.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct GregoryTri {
    /// Corners.
    pub p: [[f64; 3]; 3],
    /// Edge point on edge `i → i + 1`, next to corner `i`.
    pub e_plus: [[f64; 3]; 3],
    /// Edge point on edge `i → i − 1`, next to corner `i`.
    pub e_minus: [[f64; 3]; 3],
    /// Interior point next to corner `i` that belongs to edge `i → i + 1`.
    pub f_plus: [[f64; 3]; 3],
    /// Interior point next to corner `i` that belongs to edge `i → i − 1`.
    pub f_minus: [[f64; 3]; 3],
}

fn lerp(a: [f64; 3], b: [f64; 3], t: f64) -> [f64; 3] {
    [0, 1, 2].map(|i| a[i] + t * (b[i] - a[i]))
}

/// A scalar and its derivatives `[value, d/du, d/dv, d²/du², d²/dudv, d²/dv²]`.
type Jet = [f64; 6];

/// The blend weight of `f⁺` in interior point `i`, `num / den`, with derivatives; at the
/// corner where `den` vanishes (where the weight has no limit but `b0 b1 b2` and its first
/// derivatives do), `1/2` with zero derivatives.
fn blend(i: usize, u: f64, v: f64) -> Jet {
    match i {
        0 => {
            // u / (u + v)
            let s = u + v;
            if s <= 0.0 {
                return [0.5, 0.0, 0.0, 0.0, 0.0, 0.0];
            }
            let (s2, s3) = (s * s, s * s * s);
            [
                u / s,
                v / s2,
                -u / s2,
                -2.0 * v / s3,
                (u - v) / s3,
                2.0 * u / s3,
            ]
        }
        1 => {
            // v / (1 − u)
            let d = 1.0 - u;
            if d <= 0.0 {
                return [0.5, 0.0, 0.0, 0.0, 0.0, 0.0];
            }
            let (d2, d3) = (d * d, d * d * d);
            [v / d, v / d2, 1.0 / d, 2.0 * v / d3, 1.0 / d2, 0.0]
        }
        _ => {
            // (1 − u − v) / (1 − v) = 1 − u / (1 − v)
            let d = 1.0 - v;
            if d <= 0.0 {
                return [0.5, 0.0, 0.0, 0.0, 0.0, 0.0];
            }
            let (d2, d3) = (d * d, d * d * d);
            [
                1.0 - u / d,
                -1.0 / d,
                -u / d2,
                0.0,
                -1.0 / d2,
                -2.0 * u / d3,
            ]
        }
    }
}

impl GregoryTri {
    /// The quartic net in [`bezier_indices`] order (the three interior points left zero: they
    /// are blended at evaluation).
    fn net(&self) -> [[f64; 3]; 15] {
        let (p, ep, em) = (&self.p, &self.e_plus, &self.e_minus);
        let q =
            |a: [f64; 3], b: [f64; 3], wa: f64| [0, 1, 2].map(|x| wa * a[x] + (1.0 - wa) * b[x]);
        let mut net = [[0.0; 3]; 15];
        for (n, &(i, j, k)) in bezier_indices().iter().enumerate() {
            net[n] = match (i, j, k) {
                (4, 0, 0) => p[0],
                (0, 4, 0) => p[1],
                (0, 0, 4) => p[2],
                // Edge 0 → 1 (k = 0).
                (3, 1, 0) => q(p[0], ep[0], 0.25),
                (2, 2, 0) => q(ep[0], em[1], 0.5),
                (1, 3, 0) => q(em[1], p[1], 0.75),
                // Edge 1 → 2 (i = 0).
                (0, 3, 1) => q(p[1], ep[1], 0.25),
                (0, 2, 2) => q(ep[1], em[2], 0.5),
                (0, 1, 3) => q(em[2], p[2], 0.75),
                // Edge 2 → 0 (j = 0).
                (1, 0, 3) => q(p[2], ep[2], 0.25),
                (2, 0, 2) => q(ep[2], em[0], 0.5),
                (3, 0, 1) => q(em[0], p[0], 0.75),
                // Interior: blended at evaluation.
                _ => [0.0; 3],
            };
        }
        net
    }

    /// Position and derivatives at `(u, v)`: `[p, du, dv, duu, duv, dvv]`. Exact everywhere
    /// but at the three corners, where the interior blend has no second derivative (there it
    /// is frozen at its mean).
    pub fn eval(&self, u: f64, v: f64) -> [[f64; 3]; 6] {
        let net = self.net();
        let b = bernstein(u, v);
        let idx = bezier_indices();
        let mut out = [[0.0; 3]; 6];
        for (n, &ijk) in idx.iter().enumerate() {
            let slot = match ijk {
                (2, 1, 1) => Some(0),
                (1, 2, 1) => Some(1),
                (1, 1, 2) => Some(2),
                _ => None,
            };
            match slot {
                None => {
                    for d in 0..6 {
                        for x in 0..3 {
                            out[d][x] += b[d][n] * net[n][x];
                        }
                    }
                }
                Some(i) => {
                    let (fm, fp) = (self.f_minus[i], self.f_plus[i]);
                    let a = blend(i, u, v);
                    let f = lerp(fm, fp, a[0]);
                    let df = [0, 1, 2].map(|x| fp[x] - fm[x]);
                    let bn = [b[0][n], b[1][n], b[2][n], b[3][n], b[4][n], b[5][n]];
                    for x in 0..3 {
                        // P = B F, F = f⁻ + a (f⁺ − f⁻): product rule to second order.
                        out[0][x] += bn[0] * f[x];
                        out[1][x] += bn[1] * f[x] + bn[0] * a[1] * df[x];
                        out[2][x] += bn[2] * f[x] + bn[0] * a[2] * df[x];
                        out[3][x] += bn[3] * f[x] + (2.0 * bn[1] * a[1] + bn[0] * a[3]) * df[x];
                        out[4][x] +=
                            bn[4] * f[x] + (bn[1] * a[2] + bn[2] * a[1] + bn[0] * a[4]) * df[x];
                        out[5][x] += bn[5] * f[x] + (2.0 * bn[2] * a[2] + bn[0] * a[5]) * df[x];
                    }
                }
            }
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn rand_tri(seed: u64) -> GregoryTri {
        let mut s = seed;
        let mut r = || {
            s = s
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((s >> 11) as f64 / (1u64 << 53) as f64) * 2.0 - 1.0
        };
        let mut pt = || [r(), r(), r()];
        GregoryTri {
            p: [pt(), pt(), pt()],
            e_plus: [pt(), pt(), pt()],
            e_minus: [pt(), pt(), pt()],
            f_plus: [pt(), pt(), pt()],
            f_minus: [pt(), pt(), pt()],
        }
    }

    /// The analytic derivatives equal central differences (step 2e-6: truncation h²/6 times
    /// a third derivative that reaches ~10³ next to a corner, so ~1e-9; rounding ~1e-10).
    #[test]
    fn derivatives_match_finite_differences() {
        let h = 2e-6;
        for seed in 0..20 {
            let g = rand_tri(seed);
            for &(u, v) in &[
                (0.2, 0.3),
                (0.6, 0.1),
                (0.05, 0.9),
                (0.33, 0.33),
                (0.5, 0.0),
            ] {
                let e = g.eval(u, v);
                let (up, um) = (g.eval(u + h, v), g.eval(u - h, v));
                let (vp, vm) = (g.eval(u, v + h), g.eval(u, v - h));
                for x in 0..3 {
                    let du = (up[0][x] - um[0][x]) / (2.0 * h);
                    let dv = (vp[0][x] - vm[0][x]) / (2.0 * h);
                    assert!((du - e[1][x]).abs() < 1e-8, "du {du} vs {}", e[1][x]);
                    assert!((dv - e[2][x]).abs() < 1e-8, "dv {dv} vs {}", e[2][x]);
                    let duu = (up[1][x] - um[1][x]) / (2.0 * h);
                    let duv = (vp[1][x] - vm[1][x]) / (2.0 * h);
                    let dvv = (vp[2][x] - vm[2][x]) / (2.0 * h);
                    assert!((duu - e[3][x]).abs() < 1e-6, "duu {duu} vs {}", e[3][x]);
                    assert!((duv - e[4][x]).abs() < 1e-6, "duv {duv} vs {}", e[4][x]);
                    assert!((dvv - e[5][x]).abs() < 1e-6, "dvv {dvv} vs {}", e[5][x]);
                }
            }
        }
    }

    /// Corners are interpolated and each boundary is the cubic Bézier curve of its corner and
    /// edge points (to rounding).
    #[test]
    fn boundaries_are_the_cubic_curves() {
        let g = rand_tri(7);
        let cubic = |a: [f64; 3], b: [f64; 3], c: [f64; 3], d: [f64; 3], t: f64| {
            let s = 1.0 - t;
            [0, 1, 2].map(|x| {
                s * s * s * a[x]
                    + 3.0 * s * s * t * b[x]
                    + 3.0 * s * t * t * c[x]
                    + t * t * t * d[x]
            })
        };
        for i in 0..=10 {
            let t = i as f64 / 10.0;
            let want = [
                (
                    cubic(g.p[0], g.e_plus[0], g.e_minus[1], g.p[1], t),
                    (t, 0.0),
                ),
                (
                    cubic(g.p[1], g.e_plus[1], g.e_minus[2], g.p[2], t),
                    (1.0 - t, t),
                ),
                (
                    cubic(g.p[2], g.e_plus[2], g.e_minus[0], g.p[0], t),
                    (0.0, 1.0 - t),
                ),
            ];
            for (w, (u, v)) in want {
                let got = g.eval(u, v)[0];
                for x in 0..3 {
                    assert!((got[x] - w[x]).abs() < 1e-14, "{got:?} vs {w:?}");
                }
            }
        }
    }
}
