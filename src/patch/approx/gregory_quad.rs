//! The bicubic Gregory patch (Loop, Schaefer, Ni, Castaño 2009; paper 004 §4.4): 20 control
//! points. Cubic Bézier boundaries (corners `p_i` at `(0,0), (1,0), (1,1), (0,1)`, edge points
//! `e_i⁺` on edge `i → i + 1` and `e_i⁻` on edge `i → i − 1`, next to corner `i`) and four
//! interior points each blended from two, `f_i⁺` (which belongs to edge `i → i + 1`) and
//! `f_i⁻` (edge `i → i − 1`), by the distances to the corner's two edges:
//!
//! ```text
//! F_0 = (s f_0⁺ + t f_0⁻) / (s + t)              F_1 = (t f_1⁺ + (1−s) f_1⁻) / (t + 1 − s)
//! F_2 = ((1−s) f_2⁺ + (1−t) f_2⁻) / (2 − s − t)  F_3 = ((1−t) f_3⁺ + s f_3⁻) / (1 − t + s)
//! ```
//!
//! On an edge only that edge's two interior points are seen, so each edge's cross-boundary
//! derivative is set by its own points (see [`super::construct_quad`]). A patch whose `f⁺`
//! and `f⁻` coincide is an ordinary bicubic Bézier patch.

/// A bicubic Gregory patch: 20 control points.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct GregoryQuad {
    /// Corners at `(0,0), (1,0), (1,1), (0,1)`.
    pub p: [[f64; 3]; 4],
    /// Edge point on edge `i → i + 1`, next to corner `i`.
    pub e_plus: [[f64; 3]; 4],
    /// Edge point on edge `i → i − 1`, next to corner `i`.
    pub e_minus: [[f64; 3]; 4],
    /// Interior point next to corner `i` that belongs to edge `i → i + 1`.
    pub f_plus: [[f64; 3]; 4],
    /// Interior point next to corner `i` that belongs to edge `i → i − 1`.
    pub f_minus: [[f64; 3]; 4],
}

/// A scalar and its derivatives `[value, d/ds, d/dt, d²/ds², d²/dsdt, d²/dt²]`.
type Jet = [f64; 6];

/// `x / (x + y)` for `x`, `y` affine in `(s, t)` (given as `[constant, d/ds, d/dt]`), with
/// derivatives; `1/2` with zero derivatives where `x + y` vanishes (a corner, where the blend
/// has no limit but its factor `B` does).
fn ratio(x: [f64; 3], y: [f64; 3], s: f64, t: f64) -> Jet {
    let xv = x[0] + x[1] * s + x[2] * t;
    let (ss, st) = (x[1] + y[1], x[2] + y[2]);
    let sum = xv + y[0] + y[1] * s + y[2] * t;
    if sum <= 0.0 {
        return [0.5, 0.0, 0.0, 0.0, 0.0, 0.0];
    }
    let a = xv / sum;
    let a_s = (x[1] * sum - xv * ss) / (sum * sum);
    let a_t = (x[2] * sum - xv * st) / (sum * sum);
    [
        a,
        a_s,
        a_t,
        -2.0 * ss * a_s / sum,
        (x[1] * st - x[2] * ss) / (sum * sum) - 2.0 * st * a_s / sum,
        -2.0 * st * a_t / sum,
    ]
}

/// The weight of `f_i⁺` in interior point `i`.
fn blend(i: usize, s: f64, t: f64) -> Jet {
    let (one_minus_s, one_minus_t) = ([1.0, -1.0, 0.0], [1.0, 0.0, -1.0]);
    let (s_, t_) = ([0.0, 1.0, 0.0], [0.0, 0.0, 1.0]);
    match i {
        0 => ratio(s_, t_, s, t),
        1 => ratio(t_, one_minus_s, s, t),
        2 => ratio(one_minus_s, one_minus_t, s, t),
        _ => ratio(one_minus_t, s_, s, t),
    }
}

/// Cubic Bernstein polynomials and their first and second derivatives at `x`.
fn bernstein3(x: f64) -> [[f64; 4]; 3] {
    let y = 1.0 - x;
    [
        [y * y * y, 3.0 * x * y * y, 3.0 * x * x * y, x * x * x],
        [
            -3.0 * y * y,
            3.0 * y * (y - 2.0 * x),
            3.0 * x * (2.0 * y - x),
            3.0 * x * x,
        ],
        [
            6.0 * y,
            6.0 * (3.0 * x - 2.0),
            6.0 * (1.0 - 3.0 * x),
            6.0 * x,
        ],
    ]
}

impl GregoryQuad {
    /// The Bézier net `[i][j]` (`i` along `s`, `j` along `t`) with the interior points left
    /// zero (blended at evaluation).
    fn net(&self) -> [[[f64; 3]; 4]; 4] {
        let (p, ep, em) = (&self.p, &self.e_plus, &self.e_minus);
        let mut b = [[[0.0; 3]; 4]; 4];
        b[0][0] = p[0];
        b[3][0] = p[1];
        b[3][3] = p[2];
        b[0][3] = p[3];
        b[1][0] = ep[0];
        b[2][0] = em[1];
        b[3][1] = ep[1];
        b[3][2] = em[2];
        b[2][3] = ep[2];
        b[1][3] = em[3];
        b[0][2] = ep[3];
        b[0][1] = em[0];
        b
    }

    /// Position and derivatives at `(s, t)`: `[p, ds, dt, dss, dst, dtt]`. Exact everywhere but
    /// at the four corners, where the interior blend has no second derivative (there it is
    /// frozen at its mean).
    pub fn eval(&self, s: f64, t: f64) -> [[f64; 3]; 6] {
        let net = self.net();
        let (bs, bt) = (bernstein3(s), bernstein3(t));
        // Which interior point sits at (i, j).
        let inner = |i: usize, j: usize| match (i, j) {
            (1, 1) => Some(0),
            (2, 1) => Some(1),
            (2, 2) => Some(2),
            (1, 2) => Some(3),
            _ => None,
        };
        let mut out = [[0.0; 3]; 6];
        for i in 0..4 {
            for j in 0..4 {
                // The tensor basis function and its derivatives.
                let n = [
                    bs[0][i] * bt[0][j],
                    bs[1][i] * bt[0][j],
                    bs[0][i] * bt[1][j],
                    bs[2][i] * bt[0][j],
                    bs[1][i] * bt[1][j],
                    bs[0][i] * bt[2][j],
                ];
                match inner(i, j) {
                    None => {
                        for d in 0..6 {
                            for x in 0..3 {
                                out[d][x] += n[d] * net[i][j][x];
                            }
                        }
                    }
                    Some(k) => {
                        let (fm, fp) = (self.f_minus[k], self.f_plus[k]);
                        let a = blend(k, s, t);
                        for x in 0..3 {
                            let df = fp[x] - fm[x];
                            let f = fm[x] + a[0] * df;
                            out[0][x] += n[0] * f;
                            out[1][x] += n[1] * f + n[0] * a[1] * df;
                            out[2][x] += n[2] * f + n[0] * a[2] * df;
                            out[3][x] += n[3] * f + (2.0 * n[1] * a[1] + n[0] * a[3]) * df;
                            out[4][x] += n[4] * f + (n[1] * a[2] + n[2] * a[1] + n[0] * a[4]) * df;
                            out[5][x] += n[5] * f + (2.0 * n[2] * a[2] + n[0] * a[5]) * df;
                        }
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
    use crate::harness::rng::SplitMix64;

    fn random_patch(seed: u64) -> GregoryQuad {
        let mut r = SplitMix64::new(seed);
        let mut pt = || {
            [
                r.next_f64() * 2.0 - 1.0,
                r.next_f64() * 2.0 - 1.0,
                r.next_f64() * 2.0 - 1.0,
            ]
        };
        let mut four = || [pt(), pt(), pt(), pt()];
        GregoryQuad {
            p: four(),
            e_plus: four(),
            e_minus: four(),
            f_plus: four(),
            f_minus: four(),
        }
    }

    /// The analytic derivatives equal central differences (step 2e-6: truncation ~1e-9 where
    /// the blend's third derivative is largest, next to a corner; rounding ~1e-10).
    #[test]
    fn derivatives_match_finite_differences() {
        let h = 2e-6;
        for seed in 0..20 {
            let g = random_patch(seed);
            for &(s, t) in &[
                (0.2, 0.3),
                (0.6, 0.1),
                (0.05, 0.9),
                (0.5, 0.5),
                (0.9, 0.95),
                (0.5, 0.0),
            ] {
                let e = g.eval(s, t);
                let (sp, sm) = (g.eval(s + h, t), g.eval(s - h, t));
                let (tp, tm) = (g.eval(s, t + h), g.eval(s, t - h));
                for x in 0..3 {
                    let ds = (sp[0][x] - sm[0][x]) / (2.0 * h);
                    let dt = (tp[0][x] - tm[0][x]) / (2.0 * h);
                    assert!((ds - e[1][x]).abs() < 1e-8, "ds {ds} vs {}", e[1][x]);
                    assert!((dt - e[2][x]).abs() < 1e-8, "dt {dt} vs {}", e[2][x]);
                    let dss = (sp[1][x] - sm[1][x]) / (2.0 * h);
                    let dst = (tp[1][x] - tm[1][x]) / (2.0 * h);
                    let dtt = (tp[2][x] - tm[2][x]) / (2.0 * h);
                    assert!((dss - e[3][x]).abs() < 1e-6, "dss {dss} vs {}", e[3][x]);
                    assert!((dst - e[4][x]).abs() < 1e-6, "dst {dst} vs {}", e[4][x]);
                    assert!((dtt - e[5][x]).abs() < 1e-6, "dtt {dtt} vs {}", e[5][x]);
                }
            }
        }
    }

    /// Each boundary is its cubic Bézier curve, and each edge's cross derivative is set by that
    /// edge's interior points alone: `∂P/∂t` at `t = 0` is `3 Σ B_j (row 1 − row 0)` with
    /// `f_0⁺`, `f_1⁻` in row 1.
    #[test]
    fn boundaries_and_cross_derivatives() {
        let g = random_patch(3);
        let cubic = |a: [f64; 3], b: [f64; 3], c: [f64; 3], d: [f64; 3], x: f64| {
            let w = bernstein3(x)[0];
            [0, 1, 2].map(|k| w[0] * a[k] + w[1] * b[k] + w[2] * c[k] + w[3] * d[k])
        };
        for i in 0..=10 {
            let x = i as f64 / 10.0;
            let got = g.eval(x, 0.0);
            let want = cubic(g.p[0], g.e_plus[0], g.e_minus[1], g.p[1], x);
            let row1 = [g.e_minus[0], g.f_plus[0], g.f_minus[1], g.e_plus[1]];
            let row0 = [g.p[0], g.e_plus[0], g.e_minus[1], g.p[1]];
            let d = [0, 1, 2, 3].map(|j| [0, 1, 2].map(|k| 3.0 * (row1[j][k] - row0[j][k])));
            let dwant = cubic(d[0], d[1], d[2], d[3], x);
            for k in 0..3 {
                assert!((got[0][k] - want[k]).abs() < 1e-14);
                assert!(
                    (got[2][k] - dwant[k]).abs() < 1e-13,
                    "{:?} vs {dwant:?}",
                    got[2]
                );
            }
            let side = g.eval(1.0, x);
            let want = cubic(g.p[1], g.e_plus[1], g.e_minus[2], g.p[2], x);
            for k in 0..3 {
                assert!((side[0][k] - want[k]).abs() < 1e-14);
            }
        }
    }
}
