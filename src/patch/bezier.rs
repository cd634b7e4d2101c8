//! Bicubic Bézier patches: the exact Bernstein form of a uniform B-spline patch over any
//! sub-rectangle of its domain, de Casteljau's split into four quadrants, and evaluation.
//!
//! The Bernstein form is what makes bounds certain: a bicubic patch lies in the convex hull of
//! its 16 Bézier points (the basis functions are non-negative and sum to one), and so does
//! every derivative in the hull of its difference points. The reference intersector
//! ([`crate::exact`]) bounds pieces of the limit surface this way.
//!
//! Grids use the library's layout ([`super::bspline`]): `g[4 * j + i]`, `i` along `s`, `j`
//! along `t`.

use super::bspline::ControlGrid;

/// The 16 Bézier points of a bicubic patch, `g[4 * j + i]`.
pub type BezierGrid = [[f64; 3]; 16];

/// The Bernstein points of the cubic B-spline segment of `p` (`t ∈ [0, 1]`) restricted to
/// `[a, b]`, through the Taylor expansion at `a` (well conditioned for `0 ≤ a < b ≤ 1`).
fn curve(p: [[f64; 3]; 4], a: f64, b: f64) -> [[f64; 3]; 4] {
    let h = b - a;
    let mut out = [[0.0; 3]; 4];
    for c in 0..3 {
        let (p0, p1, p2, p3) = (p[0][c], p[1][c], p[2][c], p[3][c]);
        // Power form p(t) = c0 + c1 t + c2 t² + c3 t³ of the uniform cubic B-spline segment.
        let c0 = (p0 + 4.0 * p1 + p2) / 6.0;
        let c1 = (p2 - p0) / 2.0;
        let c2 = (p0 - 2.0 * p1 + p2) / 2.0;
        let c3 = (-p0 + 3.0 * p1 - 3.0 * p2 + p3) / 6.0;
        // Taylor coefficients at a, scaled to x ∈ [0, 1]: q(x) = d0 + d1 x + d2 x² + d3 x³.
        let d0 = c0 + a * (c1 + a * (c2 + a * c3));
        let d1 = h * (c1 + a * (2.0 * c2 + 3.0 * a * c3));
        let d2 = h * h * (c2 + 3.0 * a * c3);
        let d3 = h * h * h * c3;
        out[0][c] = d0;
        out[1][c] = d0 + d1 / 3.0;
        out[2][c] = d0 + (2.0 * d1 + d2) / 3.0;
        out[3][c] = d0 + d1 + d2 + d3;
    }
    out
}

/// The Bézier grid of the B-spline patch `cp` over `[s0, s1] × [t0, t1]` (a sub-rectangle of
/// `[0, 1]²`), reparameterised to `[0, 1]²`.
pub fn from_bspline(cp: &ControlGrid, s0: f64, s1: f64, t0: f64, t1: f64) -> BezierGrid {
    let mut rows = [[0.0; 3]; 16];
    for j in 0..4 {
        let r = curve(std::array::from_fn(|i| cp[4 * j + i]), s0, s1);
        rows[4 * j..4 * j + 4].copy_from_slice(&r);
    }
    let mut out = [[0.0; 3]; 16];
    for i in 0..4 {
        let c = curve(std::array::from_fn(|j| rows[4 * j + i]), t0, t1);
        for j in 0..4 {
            out[4 * j + i] = c[j];
        }
    }
    out
}

fn mid(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    std::array::from_fn(|c| 0.5 * (a[c] + b[c]))
}

/// De Casteljau at ½: the two halves of a cubic.
fn halve(p: [[f64; 3]; 4]) -> ([[f64; 3]; 4], [[f64; 3]; 4]) {
    let a = mid(p[0], p[1]);
    let b = mid(p[1], p[2]);
    let c = mid(p[2], p[3]);
    let ab = mid(a, b);
    let bc = mid(b, c);
    let m = mid(ab, bc);
    ([p[0], a, ab, m], [m, bc, c, p[3]])
}

/// The four quadrants of `g` in the order `[0, ½]×[0, ½]`, `[½, 1]×[0, ½]`, `[½, 1]×[½, 1]`,
/// `[0, ½]×[½, 1]` (each reparameterised to `[0, 1]²`, axes unchanged).
pub fn split(g: &BezierGrid) -> [BezierGrid; 4] {
    let mut lo = [[0.0; 3]; 16];
    let mut hi = [[0.0; 3]; 16];
    for j in 0..4 {
        let (l, h) = halve(std::array::from_fn(|i| g[4 * j + i]));
        lo[4 * j..4 * j + 4].copy_from_slice(&l);
        hi[4 * j..4 * j + 4].copy_from_slice(&h);
    }
    let mut out = [[[0.0; 3]; 16]; 4];
    for (src, (bottom, top)) in [(&lo, (0, 3)), (&hi, (1, 2))] {
        for i in 0..4 {
            let (l, h) = halve(std::array::from_fn(|j| src[4 * j + i]));
            for j in 0..4 {
                out[bottom][4 * j + i] = l[j];
                out[top][4 * j + i] = h[j];
            }
        }
    }
    out
}

/// Cubic Bernstein weights at `x`.
pub fn bernstein(x: f64) -> [f64; 4] {
    let y = 1.0 - x;
    [y * y * y, 3.0 * x * y * y, 3.0 * x * x * y, x * x * x]
}

/// The patch's point at `(s, t)`.
pub fn eval(g: &BezierGrid, s: f64, t: f64) -> [f64; 3] {
    let (bs, bt) = (bernstein(s), bernstein(t));
    let mut p = [0.0; 3];
    for j in 0..4 {
        for i in 0..4 {
            let w = bs[i] * bt[j];
            for c in 0..3 {
                p[c] += w * g[4 * j + i][c];
            }
        }
    }
    p
}

/// The largest absolute coordinate of the grid (the scale of its rounding errors).
pub fn max_abs(g: &[[f64; 3]]) -> f64 {
    g.iter()
        .flat_map(|p| p.iter())
        .fold(0.0f64, |m, &x| m.max(x.abs()))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::harness::rng::SplitMix64;
    use crate::patch::bspline;

    fn random_grid(rng: &mut SplitMix64) -> ControlGrid {
        std::array::from_fn(|_| std::array::from_fn(|_| 4.0 * rng.next_f64() - 2.0))
    }

    fn dist(a: [f64; 3], b: [f64; 3]) -> f64 {
        (0..3).map(|c| (a[c] - b[c]).abs()).fold(0.0, f64::max)
    }

    #[test]
    fn bezier_form_equals_the_bspline_patch_on_sub_rectangles() {
        let mut rng = SplitMix64::new(7);
        for _ in 0..200 {
            let cp = random_grid(&mut rng);
            let (a, b) = (rng.next_f64(), rng.next_f64());
            let (s0, s1) = (a.min(b), a.max(b));
            let (a, b) = (rng.next_f64(), rng.next_f64());
            let (t0, t1) = (a.min(b), a.max(b));
            let g = from_bspline(&cp, s0, s1, t0, t1);
            for _ in 0..10 {
                let (x, y) = (rng.next_f64(), rng.next_f64());
                let want = bspline::eval(&cp, s0 + x * (s1 - s0), t0 + y * (t1 - t0)).p;
                // Both are sums of 16 terms of size ≤ 2: rounding stays near 1e-15.
                assert!(dist(eval(&g, x, y), want) < 1e-13);
            }
        }
    }

    #[test]
    fn split_quadrants_reproduce_the_parent() {
        let mut rng = SplitMix64::new(8);
        let g = from_bspline(&random_grid(&mut rng), 0.0, 1.0, 0.0, 1.0);
        let kids = split(&g);
        let corner = [[0.0, 0.0], [0.5, 0.0], [0.5, 0.5], [0.0, 0.5]];
        for (q, k) in kids.iter().enumerate() {
            for _ in 0..20 {
                let (x, y) = (rng.next_f64(), rng.next_f64());
                let want = eval(&g, corner[q][0] + 0.5 * x, corner[q][1] + 0.5 * y);
                assert!(dist(eval(k, x, y), want) < 1e-14);
            }
        }
    }
}
