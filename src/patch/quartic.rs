//! A regular Loop patch as a tensor-product quartic over the square of its triangle, for the
//! reference intersector.
//!
//! A regular Loop patch is a polynomial of total degree 4 in the triangle parameter `(u, v)`
//! ([`crate::patch::loop_box`] gives its triangular Bézier net). Every such polynomial is
//! also a tensor-product polynomial of degree (4, 4), so it has 25 Bernstein points over the
//! unit square `[0, 1]²`, whose lower-left half `u + v ≤ 1` is the triangle. In that form the
//! bicubic machinery carries over: the points' convex hull bounds the polynomial over the
//! square (so over the triangle), de Casteljau halves it into quadrants, and the Krawczyk
//! test takes a tensor grid.
//!
//! The conversion goes straight to the three quadrants of the square that hold part of the
//! triangle (`[0, ½]²`, `[½, 1] × [0, ½]`, `[0, ½] × [½, 1]`; the fourth lies beyond it), so
//! the polynomial is never continued far past the triangle: the rounding gain is 1 for the
//! inner quadrant and 16 for the two on the hypotenuse (81 for the whole square). It is exact
//! up to one rounding per term: each quadrant's matrix from the 15 triangular to the 25
//! tensor points is an integer matrix over 144 · 16², built once with integer arithmetic
//! (monomials of degree ≤ 4 in each variable turn into Bernstein form with the denominators
//! `C(4, m) C(4, n)`, which divide 144, and each halving divides by at most 2⁴ per axis).

use crate::patch::loop_box::bezier_indices;
use std::sync::OnceLock;

/// Bernstein points of a tensor-product quartic over `[0, 1]²`: `g[5 j + i]` is the point of
/// `B_i(s) B_j(t)`.
pub type QuarticGrid = [[f64; 3]; 25];

/// The quadrants [`from_triangle`] gives: the unit square's corners `(0,0), (1,0), (0,1)`
/// (indices into `(0,0), (1,0), (1,1), (0,1)`), each with side ½.
pub const QUADRANTS: [usize; 3] = [0, 1, 3];

/// The common denominator of the whole square's conversion.
const DENOM: i64 = 144;
/// The common denominator of a quadrant's conversion.
const QDENOM: i64 = DENOM * 256;

fn binom(n: usize, k: usize) -> i64 {
    if k > n {
        return 0;
    }
    (0..k).fold(1i64, |c, i| c * (n - i) as i64 / (i as i64 + 1))
}

fn factorial(n: usize) -> i64 {
    (1..=n as i64).product()
}

/// The 25 × 15 integer matrix, over [`DENOM`], from the triangular Bézier net
/// ([`bezier_indices`] order) to the tensor grid over the whole square.
fn square_matrix() -> [[i64; 15]; 25] {
    let mut m = [[0i64; 15]; 25];
    for (n, &(i, j, k)) in bezier_indices().iter().enumerate() {
        // 4!/(i! j! k!) (1 − s − t)^i s^j t^k in monomials s^a t^b.
        let multi = factorial(4) / (factorial(i) * factorial(j) * factorial(k));
        let mut mono = [[0i64; 5]; 5];
        for q in 0..=i {
            for r in 0..=i - q {
                let p = i - q - r;
                let c = factorial(i) / (factorial(p) * factorial(q) * factorial(r));
                let sign = if (q + r) % 2 == 0 { 1 } else { -1 };
                mono[j + q][k + r] += sign * multi * c;
            }
        }
        // s^a = Σ_{x ≥ a} C(x, a) / C(4, a) B_x(s), and likewise in t.
        for (a, row) in mono.iter().enumerate() {
            for (b, &c) in row.iter().enumerate() {
                if c == 0 {
                    continue;
                }
                let scale = DENOM / (binom(4, a) * binom(4, b));
                for x in a..5 {
                    for y in b..5 {
                        m[5 * y + x][n] += c * scale * binom(x, a) * binom(y, b);
                    }
                }
            }
        }
    }
    m
}

/// One half of a quartic's Bernstein coefficients (`high`: the half at 1), times 16: the
/// de Casteljau averages `Σ C(r, i) p_i / 2^r`, scaled to integers.
fn half16(p: [i64; 5], high: bool) -> [i64; 5] {
    let mut out = [0i64; 5];
    for r in 0..5 {
        let first = if high { 4 - r } else { 0 };
        let sum: i64 = (0..=r).map(|i| binom(r, i) * p[first + i]).sum();
        out[if high { 4 - r } else { r }] = sum << (4 - r);
    }
    out
}

/// The three quadrants' 25 × 15 integer matrices over [`QDENOM`] ([`QUADRANTS`] order), and
/// each one's largest row sum of absolute values over [`QDENOM`] (its rounding gain).
fn conversion() -> &'static [([[i64; 15]; 25], f64); 3] {
    static M: OnceLock<[([[i64; 15]; 25], f64); 3]> = OnceLock::new();
    M.get_or_init(|| {
        let full = square_matrix();
        QUADRANTS.map(|q| {
            let (hs, ht) = (q == 1 || q == 2, q == 2 || q == 3);
            let mut m = [[0i64; 15]; 25];
            for n in 0..15 {
                let mut rows = [[0i64; 5]; 5];
                for (j, row) in rows.iter_mut().enumerate() {
                    *row = half16(std::array::from_fn(|i| full[5 * j + i][n]), hs);
                }
                for i in 0..5 {
                    let col = half16(std::array::from_fn(|j| rows[j][i]), ht);
                    for j in 0..5 {
                        m[5 * j + i][n] = col[j];
                    }
                }
            }
            let gain = m
                .iter()
                .map(|r| r.iter().map(|x| x.abs()).sum::<i64>())
                .max()
                .unwrap_or(0) as f64
                / QDENOM as f64;
            (m, gain)
        })
    })
}

/// The tensor grids of the quartic whose triangular Bézier net is `tri` ([`bezier_indices`]
/// order, the triangle `(0,0), (1,0), (0,1)` of `(s, t)`) over the three [`QUADRANTS`] that
/// hold the triangle, each reparameterised to `[0, 1]²`; with bounds on their rounding
/// relative to the largest coordinate of `tri`.
pub fn from_triangle(tri: &[[f64; 3]; 15]) -> [(QuarticGrid, f64); 3] {
    conversion().each_ref().map(|(m, gain)| {
        let mut g = [[0.0; 3]; 25];
        for (out, row) in g.iter_mut().zip(m.iter()) {
            for (&w, p) in row.iter().zip(tri) {
                if w != 0 {
                    for c in 0..3 {
                        out[c] += w as f64 * p[c];
                    }
                }
            }
            for x in out.iter_mut() {
                *x /= QDENOM as f64;
            }
        }
        // Each product rounds once (|w| < 2^53), each of the 15 sums and the division once.
        (g, 17.0 * f64::EPSILON * gain)
    })
}

fn mid(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    std::array::from_fn(|c| 0.5 * (a[c] + b[c]))
}

/// De Casteljau at ½: the two halves of a quartic.
fn halve(p: [[f64; 3]; 5]) -> ([[f64; 3]; 5], [[f64; 3]; 5]) {
    let mut lo = [[0.0; 3]; 5];
    let mut hi = [[0.0; 3]; 5];
    let mut cur = p;
    for r in 0..5 {
        lo[r] = cur[0];
        hi[4 - r] = cur[4 - r];
        for i in 0..4 - r {
            cur[i] = mid(cur[i], cur[i + 1]);
        }
    }
    (lo, hi)
}

/// The four quadrants, in the order of the unit square's corners `(0,0), (1,0), (1,1),
/// (0,1)`, each reparameterised to `[0, 1]²` with the axes kept.
pub fn split(g: &QuarticGrid) -> [QuarticGrid; 4] {
    let mut lo = [[0.0; 3]; 25];
    let mut hi = [[0.0; 3]; 25];
    for j in 0..5 {
        let (l, h) = halve(std::array::from_fn(|i| g[5 * j + i]));
        lo[5 * j..5 * j + 5].copy_from_slice(&l);
        hi[5 * j..5 * j + 5].copy_from_slice(&h);
    }
    let mut out = [[[0.0; 3]; 25]; 4];
    for (src, (bottom, top)) in [(&lo, (0, 3)), (&hi, (1, 2))] {
        for i in 0..5 {
            let (l, h) = halve(std::array::from_fn(|j| src[5 * j + i]));
            for j in 0..5 {
                out[bottom][5 * j + i] = l[j];
                out[top][5 * j + i] = h[j];
            }
        }
    }
    out
}

/// Quartic Bernstein weights at `x`.
fn bernstein(x: f64) -> [f64; 5] {
    let y = 1.0 - x;
    [
        y * y * y * y,
        4.0 * x * y * y * y,
        6.0 * x * x * y * y,
        4.0 * x * x * x * y,
        x * x * x * x,
    ]
}

/// The polynomial's point at `(s, t)`.
pub fn eval(g: &QuarticGrid, s: f64, t: f64) -> [f64; 3] {
    let (bs, bt) = (bernstein(s), bernstein(t));
    let mut p = [0.0; 3];
    for j in 0..5 {
        for i in 0..5 {
            let w = bs[i] * bt[j];
            for c in 0..3 {
                p[c] += w * g[5 * j + i][c];
            }
        }
    }
    p
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::harness::rng::SplitMix64;
    use crate::patch::loop_box;

    fn random_net(seed: u64) -> [[f64; 3]; 15] {
        let mut r = SplitMix64::new(seed);
        std::array::from_fn(|_| std::array::from_fn(|_| r.next_f64() * 2.0 - 1.0))
    }

    /// The triangular net's polynomial at `(s, t)` (also outside the triangle).
    fn tri_eval(tri: &[[f64; 3]; 15], s: f64, t: f64) -> [f64; 3] {
        let w = 1.0 - s - t;
        let mut p = [0.0; 3];
        for (n, &(i, j, k)) in bezier_indices().iter().enumerate() {
            let c = (factorial(4) / (factorial(i) * factorial(j) * factorial(k))) as f64;
            let b = c * w.powi(i as i32) * s.powi(j as i32) * t.powi(k as i32);
            for x in 0..3 {
                p[x] += b * tri[n][x];
            }
        }
        p
    }

    /// Quadrant `q`'s `(s, t)` in the whole square.
    fn quadrant_point(q: usize, s: f64, t: f64) -> (f64, f64) {
        let corner = [[0.0, 0.0], [0.5, 0.0], [0.5, 0.5], [0.0, 0.5]];
        (corner[q][0] + 0.5 * s, corner[q][1] + 0.5 * t)
    }

    #[test]
    fn the_quadrant_grids_are_the_same_polynomial() {
        for seed in 0..20 {
            let tri = random_net(seed);
            let quads = from_triangle(&tri);
            let mut r = SplitMix64::new(100 + seed);
            for (&q, (g, pad)) in QUADRANTS.iter().zip(&quads) {
                assert!(*pad < 1e-13, "{pad:e}");
                for _ in 0..50 {
                    let (s, t) = (r.next_f64(), r.next_f64());
                    let (x, y) = quadrant_point(q, s, t);
                    let (a, b) = (eval(g, s, t), tri_eval(&tri, x, y));
                    for c in 0..3 {
                        assert!((a[c] - b[c]).abs() < 1e-13, "{x} {y}: {a:?} {b:?}");
                    }
                }
            }
        }
    }

    #[test]
    fn a_regular_patch_converts_exactly() {
        // The box spline of a random 12-point net: the grids equal loop_box's evaluation.
        let mut r = SplitMix64::new(7);
        let cps: [[f64; 3]; 12] = std::array::from_fn(|_| std::array::from_fn(|_| r.next_f64()));
        let m = loop_box::bezier_matrix();
        let tri: [[f64; 3]; 15] = std::array::from_fn(|n| {
            std::array::from_fn(|c| (0..12).map(|i| m[n][i] * cps[i][c]).sum())
        });
        for (&q, (g, _)) in QUADRANTS.iter().zip(&from_triangle(&tri)) {
            for (s, t) in [(0.0, 0.0), (1.0, 0.0), (0.0, 1.0), (0.4, 0.6), (0.5, 0.5)] {
                let (u, v) = quadrant_point(q, s, t);
                let want = loop_box::eval(&cps, u, v)[0];
                let got = eval(g, s, t);
                for c in 0..3 {
                    assert!((want[c] - got[c]).abs() < 1e-14, "{u} {v}");
                }
            }
        }
    }

    #[test]
    fn quadrants_are_the_polynomial_over_each_quarter() {
        let (g, _) = from_triangle(&random_net(3))[0];
        let kids = split(&g);
        let corner = [[0.0, 0.0], [0.5, 0.0], [0.5, 0.5], [0.0, 0.5]];
        for (q, kid) in kids.iter().enumerate() {
            for (s, t) in [(0.0, 0.0), (0.3, 0.9), (1.0, 1.0), (0.6, 0.1)] {
                let a = eval(kid, s, t);
                let b = eval(&g, corner[q][0] + 0.5 * s, corner[q][1] + 0.5 * t);
                for c in 0..3 {
                    assert!((a[c] - b[c]).abs() < 1e-14);
                }
            }
        }
    }

    #[test]
    fn conversions_are_exact_partitions_of_unity_with_small_gains() {
        for ((m, gain), want) in conversion().iter().zip([1.0, 16.0, 16.0]) {
            for row in m.iter() {
                assert_eq!(row.iter().sum::<i64>(), QDENOM, "partition of unity");
            }
            assert_eq!(*gain, want);
        }
        // Linear precision: for the plane (s, t, 1) the tensor points are the domain points.
        let tri: [[f64; 3]; 15] = std::array::from_fn(|n| {
            let (_, j, k) = bezier_indices()[n];
            [j as f64 / 4.0, k as f64 / 4.0, 1.0]
        });
        for (&q, (g, _)) in QUADRANTS.iter().zip(&from_triangle(&tri)) {
            for j in 0..5 {
                for i in 0..5 {
                    let (x, y) = quadrant_point(q, i as f64 / 4.0, j as f64 / 4.0);
                    assert_eq!(g[5 * j + i], [x, y, 1.0]);
                }
            }
        }
    }
}
