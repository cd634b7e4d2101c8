//! The Krawczyk test (interval Newton) for a ray against a bicubic Bézier piece.
//!
//! Projected onto the plane perpendicular to the ray, a piece is a map `Q: [0, 1]² → R²` and
//! the ray's line meets the piece where `Q(s, t) = 0`. With `x₀` the centre of the square
//! `X`, `Y` any non-singular matrix (the inverse of the Jacobian's midpoint) and `J(X)` an
//! interval enclosure of the Jacobian over `X`, Krawczyk's operator
//!
//! ```text
//! K(X) = x₀ − Y Q(x₀) + (I − Y J(X)) (X − x₀)
//! ```
//!
//! contains every zero of `Q` in `X`. So `K(X) ∩ X = ∅` proves that the line misses the
//! piece, and `K(X) ⊂ int X` proves that it meets it exactly once (Kahan's theorem), inside
//! `K(X)`. Both enclosures come from the Bernstein form: the partial derivatives are bicubic
//! patches of degree (2, 3) and (3, 2) whose Bézier points are differences of the piece's, so
//! their coordinate ranges over those points bound `J(X)`.

/// What the test proves about the zeros of `Q` in `[0, 1]²`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Verdict {
    /// No zero.
    Exclude,
    /// Exactly one zero, in the box `[lo, hi]` (of `(s, t)`).
    Unique {
        /// Lower corner of the enclosure.
        lo: [f64; 2],
        /// Upper corner.
        hi: [f64; 2],
    },
    /// Undecided (split the piece).
    Unknown,
}

/// Runs the test on the projected Bézier points `q` of a tensor-product patch of degree
/// `N − 1` in each parameter (`q[N j + i]`, `i` along `s`; bicubic pieces have `N = 4`, the
/// quartic pieces of Loop patches `N = 5`), each known within `pad` (an absolute bound on
/// rounding in the points, so that the proofs hold for the exact surface).
pub fn krawczyk<const N: usize>(q: &[[f64; 2]], pad: f64) -> Verdict {
    assert_eq!(
        q.len(),
        N * N,
        "a degree-{} piece has {} points",
        N - 1,
        N * N
    );
    let deg = (N - 1) as f64;
    // Interval enclosures of ∂Q/∂s and ∂Q/∂t: ranges of their Bézier points.
    let mut j = [[[f64::INFINITY, f64::NEG_INFINITY]; 2]; 2]; // j[component][s|t] = [lo, hi]
    for row in 0..N {
        for col in 0..N - 1 {
            let (a, b) = (q[N * row + col], q[N * row + col + 1]);
            let (c, d) = (q[N * col + row], q[N * (col + 1) + row]);
            for comp in 0..2 {
                let ds = deg * (b[comp] - a[comp]);
                let dt = deg * (d[comp] - c[comp]);
                j[comp][0] = [j[comp][0][0].min(ds), j[comp][0][1].max(ds)];
                j[comp][1] = [j[comp][1][0].min(dt), j[comp][1][1].max(dt)];
            }
        }
    }
    let scale = q
        .iter()
        .flat_map(|p| p.iter())
        .fold(0.0f64, |m, &x| m.max(x.abs()));
    let round = 32.0 * f64::EPSILON * scale;
    // The derivatives of a perturbation of the points by `pad` are within 2·deg·pad.
    let dpad = 2.0 * deg * (pad + round);
    for row in &mut j {
        for e in row.iter_mut() {
            e[0] -= dpad;
            e[1] += dpad;
        }
    }
    let mid = |e: [f64; 2]| 0.5 * (e[0] + e[1]);
    let (a, b, c, d) = (mid(j[0][0]), mid(j[0][1]), mid(j[1][0]), mid(j[1][1]));
    let det = a * d - b * c;
    if det == 0.0 || !det.is_finite() {
        return Verdict::Unknown;
    }
    let y = [[d / det, -b / det], [-c / det, a / det]];
    // Q at the centre: Bernstein weights C(N − 1, i) / 2^(N − 1) in each direction (exact).
    let w: [f64; N] = {
        let mut w = [0.0; N];
        w[0] = 1.0;
        for i in 1..N {
            w[i] = w[i - 1] * (N - i) as f64 / i as f64;
        }
        w.map(|x| x * 0.5f64.powi(N as i32 - 1))
    };
    let mut f0 = [0.0; 2];
    for row in 0..N {
        for col in 0..N {
            let wt = w[row] * w[col];
            f0[0] += wt * q[N * row + col][0];
            f0[1] += wt * q[N * row + col][1];
        }
    }
    let frad = pad + round;
    let mut k = [[0.0; 2]; 2];
    for i in 0..2 {
        let c = 0.5 - (y[i][0] * f0[0] + y[i][1] * f0[1]);
        let mut rad = (y[i][0].abs() + y[i][1].abs()) * frad;
        for col in 0..2 {
            // (I − Y J)[i][col] as an interval.
            let mut lo = if i == col { 1.0 } else { 0.0 };
            let mut hi = lo;
            for (r, jr) in j.iter().enumerate() {
                let e = jr[col];
                let (p, q2) = (-y[i][r] * e[0], -y[i][r] * e[1]);
                lo += p.min(q2);
                hi += p.max(q2);
            }
            rad += 0.5 * lo.abs().max(hi.abs());
        }
        // Slack for the rounding of this very computation.
        let slack = 1e-12 * (1.0 + c.abs() + rad);
        k[i] = [c - rad - slack, c + rad + slack];
    }
    if !(k[0][0].is_finite() && k[0][1].is_finite() && k[1][0].is_finite() && k[1][1].is_finite()) {
        return Verdict::Unknown;
    }
    if k.iter().any(|e| e[1] < 0.0 || e[0] > 1.0) {
        return Verdict::Exclude;
    }
    if k.iter().all(|e| e[0] > 0.0 && e[1] < 1.0) {
        return Verdict::Unique {
            lo: [k[0][0], k[1][0]],
            hi: [k[0][1], k[1][1]],
        };
    }
    Verdict::Unknown
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A bilinear-like plane patch `Q(s, t) = (s − s*, t − t*)` in Bernstein form.
    fn plane(zs: f64, zt: f64) -> [[f64; 2]; 16] {
        std::array::from_fn(|n| {
            let (i, j) = (n % 4, n / 4);
            [i as f64 / 3.0 - zs, j as f64 / 3.0 - zt]
        })
    }

    #[test]
    fn plane_inside_is_unique_and_outside_excluded() {
        match krawczyk::<4>(&plane(0.3, 0.6), 0.0) {
            Verdict::Unique { lo, hi } => {
                assert!(lo[0] <= 0.3 && 0.3 <= hi[0] && lo[1] <= 0.6 && 0.6 <= hi[1]);
                assert!(hi[0] - lo[0] < 1e-9);
            }
            v => panic!("{v:?}"),
        }
        assert_eq!(krawczyk::<4>(&plane(1.5, 0.5), 0.0), Verdict::Exclude);
        assert_eq!(krawczyk::<4>(&plane(0.5, -0.2), 0.0), Verdict::Exclude);
    }

    #[test]
    fn a_fold_is_not_certified() {
        // Q(s, t) = ((s − ½)² − 0.01, t − ½): two zeros, s = 0.4 and 0.6.
        let mut q = plane(0.0, 0.5);
        for (n, p) in q.iter_mut().enumerate() {
            // Bernstein points of (s − ½)² − 0.01 = 0.24 − s + s² on [0, 1].
            p[0] = [0.24, 0.24 - 1.0 / 3.0, 0.24 - 1.0 / 3.0, 0.24][n % 4];
        }
        assert_eq!(krawczyk::<4>(&q, 0.0), Verdict::Unknown);
    }
}
