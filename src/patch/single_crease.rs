//! Direct evaluation of a regular bicubic patch with one semi-sharp crease on a boundary edge
//! (paper 000: Nießner, Loop, Greiner 2012, §3 and §3.1), under RenderMan's uniform rule.
//!
//! # The curve case
//!
//! Across the crease the surface is the tensor product of a cubic B-spline in the other
//! direction and a 1-D curve with control points `P = (P0, P1, P2, P3)` whose vertex `P2` is a
//! crease vertex of sharpness `s`; the curve's segment `t ∈ [0, 1]` runs from near `P1` to the
//! crease at `t = 1`. (On a regular grid with a crease of constant sharpness along a whole line
//! of edges every Catmull-Clark rule is the tensor product of the 1-D cubic rule along the
//! crease and the 1-D rule across it, so the surface reduces to this curve exactly.)
//!
//! One refinement step of the half segment next to the crease maps `P` to
//! `R(w) P = ((1 − w) R + w R_p) P`, where `R` is the smooth cubic B-spline rule restricted to
//! the four children that define `t ∈ [½, 1]` and `R_p` the same with the crease vertex kept in
//! place. Level `k` uses the weight `w_k = clamp(s − k, 0, 1)` (sharp while the decremented
//! sharpness is at least 1, blended by its fractional part in the level where it runs out,
//! smooth afterwards). Transforming the refined control points back to the parameter of the
//! original segment (`N(2t − 1) R = N(t)` for the smooth rule) gives, with `n = ⌊s⌋`,
//! `f = s − n` and `M_k = (R⁻¹)^k R_p^k`:
//!
//! | `t` | control points |
//! |---|---|
//! | `[0, 1 − 2^−n]` | `M_∞ P` (the infinitely sharp curve; empty for `n = 0`) |
//! | `(1 − 2^−n, 1 − 2^−(n+1)]` | `((1 − f) M_n + f M_∞) P` (only when `f > 0`) |
//! | `(1 − 2^−(n+1), 1]` | `((1 − f) M_n + f M_(n+1)) P` (only when `f > 0`) |
//! | `(1 − 2^−n, 1]` | `M_n P` (when `f = 0`) |
//!
//! `M_∞` replaces `P3` by the phantom point `2 P2 − P1`. It is `L⁻¹ L_p`, where `L` and `L_p`
//! are the smooth and sharp rules for the children that define the left half `t ∈ [0, ½]`
//! (edge 0–1, vertex 1, edge 1–2, vertex 2): the piece next to a crease vertex that is not its
//! end is exact after one step. It commutes through the sharp steps (`M_∞ R_p = R M_∞`), which
//! is why the infinitely sharp piece needs no power of `R`.
//! These are the paper's formulas; its closed form of `M_s` ([`transition_matrix`]) is correct
//! as printed for integer `s` (checked exactly against the powers,
//! [`transition_matrix_by_powers`]).
//! For fractional `s` the closed form evaluated at `σ = 2^s` is *not* the RenderMan surface;
//! the blends above are.
//!
//! Conditioning: the pieces near the crease are extrapolated control points of a piece of
//! length `2^−s`, and `M_n` has entries of size `2^n` (`4^n` in its first row, which only meets
//! the tiny weight `N_0(t)`), so rounding near the crease grows like `2^s ε`: about `1e-14` of
//! the control grid's size at `s = 9.6`.
//!
//! Sharpness `s ≤ 0` is the plain B-spline patch; `s ≥` [`SHARPNESS_INFINITE`] (10) is
//! infinitely sharp, `M_∞` on the whole segment, as the refiner treats it.
//!
//! # Patch edges
//!
//! The crease lies on one of the patch's four boundary edges, numbered like OpenSubdiv's
//! boundary bits (counter-clockwise around the face 5 → 6 → 10 → 9 of the control grid, see
//! [`super::bspline`]):
//!
//! | edge | where | crease runs through | curve parameter `t` |
//! |---|---|---|---|
//! | 0 | `v = 0` (points 5, 6) | control row `j = 1` | `1 − v` |
//! | 1 | `u = 1` (points 6, 10) | control column `i = 2` | `u` |
//! | 2 | `v = 1` (points 10, 9) | control row `j = 2` | `v` |
//! | 3 | `u = 0` (points 9, 5) | control column `i = 1` | `1 − u` |
//!
//! The crease must carry the same sharpness along the whole line through the patch's 4 × 4
//! neighbourhood (the paper's condition); the other three edges and all other vertices of the
//! neighbourhood are smooth and regular.

use super::bspline::{self, Basis, ControlGrid, Mat4, PatchPoint, PointD1, IDENTITY};
use crate::mesh::SHARPNESS_INFINITE;

/// The smooth refinement matrix `R` of the half segment next to the crease (paper 000 §3):
/// rows are the children `(vertex 1, edge 1–2, vertex 2, edge 2–3)`.
pub const R: Mat4 = [
    [0.125, 0.75, 0.125, 0.0],
    [0.0, 0.5, 0.5, 0.0],
    [0.0, 0.125, 0.75, 0.125],
    [0.0, 0.0, 0.5, 0.5],
];

/// The sharp refinement matrix `R_p`: like [`R`] with the crease vertex `P2` kept in place.
pub const R_P: Mat4 = [
    [0.125, 0.75, 0.125, 0.0],
    [0.0, 0.5, 0.5, 0.0],
    [0.0, 0.0, 1.0, 0.0],
    [0.0, 0.0, 0.5, 0.5],
];

/// `R⁻¹` (exact; all entries are dyadic).
pub const R_INV: Mat4 = [
    [8.0, -14.5, 10.0, -2.5],
    [0.0, 2.5, -2.0, 0.5],
    [0.0, -0.5, 2.0, -0.5],
    [0.0, 0.5, -2.0, 2.5],
];

/// `M_∞`: the infinitely sharp curve, `P3 ↦ 2 P2 − P1` (the crease vertex `P2` is interpolated
/// at `t = 1`).
pub const M_INF: Mat4 = [
    [1.0, 0.0, 0.0, 0.0],
    [0.0, 1.0, 0.0, 0.0],
    [0.0, 0.0, 1.0, 0.0],
    [0.0, -1.0, 2.0, 0.0],
];

/// The largest `n` accepted by [`transition_matrix`] (its entries stay exact in `f64`).
pub const MAX_TRANSITION_LEVEL: u32 = 16;

/// Product of two 4 × 4 matrices.
pub fn mat_mul(a: &Mat4, b: &Mat4) -> Mat4 {
    let mut out = [[0.0; 4]; 4];
    for r in 0..4 {
        for c in 0..4 {
            out[r][c] = (0..4).map(|k| a[r][k] * b[k][c]).sum();
        }
    }
    out
}

/// `(1 − f) a + f b`.
pub fn mat_lerp(a: &Mat4, b: &Mat4, f: f64) -> Mat4 {
    let mut out = [[0.0; 4]; 4];
    for r in 0..4 {
        for c in 0..4 {
            out[r][c] = (1.0 - f) * a[r][c] + f * b[r][c];
        }
    }
    out
}

/// The transition matrix `M_n = (R⁻¹)^n R_p^n` for integer sharpness `n`, from the paper's
/// closed form (σ = 2^n):
///
/// ```text
///        ⎡ 1   −A        2A                 −A        ⎤   A = (σ−1)(2σ−1)(3σ−1) / 6σ
/// M_n =  ⎢ 0   D         −2B                B         ⎥   B = (σ−1)(2σ−1) / 6σ
///        ⎢ 0   −C        (σ²+3σ−1) / 3σ     −C        ⎥   C = (σ²−1) / 6σ
///        ⎣ 0   B         −2B                D         ⎦   D = (2σ+1)(σ+1) / 6σ
/// ```
///
/// (the paper's matrix with its factor `(1 − σ)/6σ` multiplied in, which also makes `n = 0`
/// the identity). The numerators are divisible by 3 and the entries are dyadic, so they are
/// computed exactly in integers. Panics if `n > MAX_TRANSITION_LEVEL`.
pub fn transition_matrix(n: u32) -> Mat4 {
    assert!(
        n <= MAX_TRANSITION_LEVEL,
        "transition_matrix: n = {n} is above {MAX_TRANSITION_LEVEL}"
    );
    let sigma: i128 = 1 << n;
    // num / (6σ), with num divisible by 3: (num / 3) / 2σ, exact in f64.
    let over_6_sigma = |num: i128| -> f64 {
        debug_assert_eq!(num % 3, 0);
        (num / 3) as f64 / (2 * sigma) as f64
    };
    let a = over_6_sigma((sigma - 1) * (2 * sigma - 1) * (3 * sigma - 1));
    let b = over_6_sigma((sigma - 1) * (2 * sigma - 1));
    let c = over_6_sigma(sigma * sigma - 1);
    let d = over_6_sigma((2 * sigma + 1) * (sigma + 1));
    let e = over_6_sigma(2 * (sigma * sigma + 3 * sigma - 1));
    [
        [1.0, -a, 2.0 * a, -a],
        [0.0, d, -2.0 * b, b],
        [0.0, -c, e, -c],
        [0.0, b, -2.0 * b, d],
    ]
}

/// `M_n = (R⁻¹)^n R_p^n` by the recursion `M_(k+1) = R⁻¹ M_k R_p` (a check of
/// [`transition_matrix`]; every intermediate value is dyadic and, for `n ≤ 12`, exact in `f64`).
pub fn transition_matrix_by_powers(n: u32) -> Mat4 {
    let mut m = IDENTITY;
    for _ in 0..n {
        m = mat_mul(&mat_mul(&R_INV, &m), &R_P);
    }
    m
}

/// One piece of the crease curve: `t ∈ (start, end]` (the first piece includes `start = 0`)
/// is the B-spline of the control points `matrix · P`, in the original parameter `t`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Segment {
    /// Lower end of the parameter interval.
    pub start: f64,
    /// Upper end of the parameter interval.
    pub end: f64,
    /// Control-point transform of the piece.
    pub matrix: Mat4,
}

/// The piecewise description of the curve across a crease of one sharpness: one to three
/// [`Segment`]s with breakpoints at `1 − 2^−k`, precomputed once per sharpness.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CreaseCurve {
    sharpness: f64,
    len: usize,
    segments: [Segment; 3],
}

impl CreaseCurve {
    /// The pieces for crease sharpness `s` (uniform rule). `s ≤ 0` (or NaN) is smooth: one
    /// identity piece; `s ≥ 10` is infinitely sharp: one `M_∞` piece.
    pub fn new(s: f64) -> Self {
        let seg = |start: f64, end: f64, matrix: Mat4| Segment { start, end, matrix };
        let unused = seg(1.0, 1.0, IDENTITY);
        let mut segments = [unused; 3];
        let len;
        let sharpness = if s > 0.0 { s } else { 0.0 };
        if sharpness == 0.0 {
            segments[0] = seg(0.0, 1.0, IDENTITY);
            len = 1;
        } else if sharpness >= SHARPNESS_INFINITE as f64 {
            segments[0] = seg(0.0, 1.0, M_INF);
            len = 1;
        } else {
            let n = sharpness.floor();
            let f = sharpness - n;
            let n = n as u32;
            // 1 − 2^−k, exact.
            let bp = |k: u32| 1.0 - 0.5f64.powi(k as i32);
            let m_n = transition_matrix(n);
            let mut k = 0;
            if n > 0 {
                segments[k] = seg(0.0, bp(n), M_INF);
                k += 1;
            }
            if f > 0.0 {
                let m_n1 = transition_matrix(n + 1);
                segments[k] = seg(bp(n), bp(n + 1), mat_lerp(&m_n, &M_INF, f));
                segments[k + 1] = seg(bp(n + 1), 1.0, mat_lerp(&m_n, &m_n1, f));
                k += 2;
            } else {
                segments[k] = seg(bp(n), 1.0, m_n);
                k += 1;
            }
            len = k;
        }
        CreaseCurve {
            sharpness,
            len,
            segments,
        }
    }

    /// The sharpness this curve was built for (negative input reads as 0).
    pub fn sharpness(&self) -> f64 {
        self.sharpness
    }

    /// The pieces, in increasing `t`.
    pub fn segments(&self) -> &[Segment] {
        &self.segments[..self.len]
    }

    /// Index of the piece that evaluates `t`: the first whose `end ≥ t`, so a breakpoint
    /// `1 − 2^−k` belongs to the piece on its left (the better-conditioned one). Parameters
    /// outside `[0, 1]` extrapolate the first or last piece.
    #[inline]
    pub fn segment_index(&self, t: f64) -> usize {
        (0..self.len - 1)
            .find(|&k| t <= self.segments[k].end)
            .unwrap_or(self.len - 1)
    }

    /// Weights over the original four control points (and their derivatives in `t`) at `t`:
    /// `N(t) M` with `M` the matrix of the piece containing `t`.
    #[inline]
    pub fn basis(&self, t: f64) -> Basis {
        Basis::at(t).transformed(&self.segments[self.segment_index(t)].matrix)
    }

    /// [`Self::basis`]'s weights alone (the same bits), without the derivatives' weights.
    #[inline]
    pub fn weights(&self, t: f64) -> [f64; 4] {
        bspline::row_times(
            &bspline::basis(t),
            &self.segments[self.segment_index(t)].matrix,
        )
    }

    /// The curve with control points `p` at `t`: position, first and second derivative.
    pub fn eval(&self, p: &[[f64; 3]; 4], t: f64) -> [[f64; 3]; 3] {
        let b = self.basis(t);
        let mut out = [[0.0; 3]; 3];
        for (k, pk) in p.iter().enumerate() {
            for c in 0..3 {
                out[0][c] += b.w[k] * pk[c];
                out[1][c] += b.d1[k] * pk[c];
                out[2][c] += b.d2[k] * pk[c];
            }
        }
        out
    }
}

/// The curve parameter `t` (crease at `t = 1`) of patch point `(u, v)` when the crease lies on
/// edge `crease_edge` (see the module documentation). Panics if `crease_edge >= 4`.
#[inline]
pub fn crease_parameter(crease_edge: usize, u: f64, v: f64) -> f64 {
    match crease_edge {
        0 => 1.0 - v,
        1 => u,
        2 => v,
        3 => 1.0 - u,
        _ => panic!("crease edge {crease_edge} is not in 0..4"),
    }
}

/// True when the crease edge runs along `u` (edges 0 and 2), so the curve across it runs
/// along `v` through the control rows.
#[inline]
fn across_is_v(crease_edge: usize) -> bool {
    crease_edge.is_multiple_of(2)
}

/// True when the curve parameter runs against the patch parameter (edges 0 and 3).
#[inline]
fn reversed(crease_edge: usize) -> bool {
    crease_edge == 0 || crease_edge == 3
}

/// Applies the curve transform `m` across the crease on edge `crease_edge` to a whole control
/// grid, keeping the grid's own orientation (for reversed edges the transform is mirrored).
pub fn transform_grid(cp: &ControlGrid, crease_edge: usize, m: &Mat4) -> ControlGrid {
    assert!(crease_edge < 4, "crease edge {crease_edge} is not in 0..4");
    // Transform in grid order: mm = J m J when the curve runs against the grid index.
    let mut mm = *m;
    if reversed(crease_edge) {
        for r in 0..4 {
            for c in 0..4 {
                mm[r][c] = m[3 - r][3 - c];
            }
        }
    }
    let mut out = [[0.0; 3]; 16];
    for a in 0..4 {
        for b in 0..4 {
            // a: index across the crease, b: index along it.
            let dst = if across_is_v(crease_edge) {
                4 * a + b
            } else {
                4 * b + a
            };
            let mut acc = [0.0; 3];
            for k in 0..4 {
                let src = if across_is_v(crease_edge) {
                    4 * k + b
                } else {
                    4 * b + k
                };
                for c in 0..3 {
                    acc[c] += mm[a][k] * cp[src][c];
                }
            }
            out[dst] = acc;
        }
    }
    out
}

/// Evaluates the patch of control grid `cp` with a crease of sharpness `s` on edge
/// `crease_edge` (0: `v = 0`, 1: `u = 1`, 2: `v = 1`, 3: `u = 0`) at `(u, v)`: position, first
/// and second derivatives. Builds the crease pieces on every call; use [`SingleCreasePatch`]
/// (or a shared [`CreaseCurve`] with [`eval_with`]) to evaluate one patch many times.
pub fn eval(cp: &ControlGrid, crease_edge: usize, s: f64, u: f64, v: f64) -> PatchPoint {
    eval_with(cp, crease_edge, &CreaseCurve::new(s), u, v)
}

/// Like [`eval`] with the crease pieces precomputed.
pub fn eval_with(
    cp: &ControlGrid,
    crease_edge: usize,
    curve: &CreaseCurve,
    u: f64,
    v: f64,
) -> PatchPoint {
    let (bu, bv) = bases(crease_edge, curve, u, v);
    bspline::eval_tensor(cp, &bu, &bv)
}

/// [`eval_with`]'s position and first derivatives alone, the same bits.
pub fn eval_with_d1(
    cp: &ControlGrid,
    crease_edge: usize,
    curve: &CreaseCurve,
    u: f64,
    v: f64,
) -> PointD1 {
    let (bu, bv) = bases(crease_edge, curve, u, v);
    bspline::eval_tensor_d1(cp, &bu, &bv)
}

/// The weights along `u` and along `v` at `(u, v)` of a patch whose crease (of `curve`) lies
/// on edge `crease_edge`: the plain B-spline's where the sharpness is zero.
#[inline]
fn bases(crease_edge: usize, curve: &CreaseCurve, u: f64, v: f64) -> (Basis, Basis) {
    (
        basis_u(crease_edge, curve, u, v),
        basis_v(crease_edge, curve, u, v),
    )
}

/// [`bases`]' weights along `u` (a function of `u` alone).
#[inline]
pub(crate) fn basis_u(crease_edge: usize, curve: &CreaseCurve, u: f64, v: f64) -> Basis {
    assert!(crease_edge < 4, "crease edge {crease_edge} is not in 0..4");
    if curve.sharpness() == 0.0 || across_is_v(crease_edge) {
        Basis::at(u)
    } else {
        across(crease_edge, curve, u, v)
    }
}

/// [`bases`]' weights along `v` (a function of `v` alone).
#[inline]
pub(crate) fn basis_v(crease_edge: usize, curve: &CreaseCurve, u: f64, v: f64) -> Basis {
    assert!(crease_edge < 4, "crease edge {crease_edge} is not in 0..4");
    if curve.sharpness() == 0.0 || !across_is_v(crease_edge) {
        Basis::at(v)
    } else {
        across(crease_edge, curve, u, v)
    }
}

/// [`basis_u`]'s weights alone (the same bits).
#[inline]
pub(crate) fn weights_u(crease_edge: usize, curve: &CreaseCurve, u: f64, v: f64) -> [f64; 4] {
    assert!(crease_edge < 4, "crease edge {crease_edge} is not in 0..4");
    if curve.sharpness() == 0.0 || across_is_v(crease_edge) {
        bspline::basis(u)
    } else {
        across_weights(crease_edge, curve, u, v)
    }
}

/// [`basis_v`]'s weights alone (the same bits).
#[inline]
pub(crate) fn weights_v(crease_edge: usize, curve: &CreaseCurve, u: f64, v: f64) -> [f64; 4] {
    assert!(crease_edge < 4, "crease edge {crease_edge} is not in 0..4");
    if curve.sharpness() == 0.0 || !across_is_v(crease_edge) {
        bspline::basis(v)
    } else {
        across_weights(crease_edge, curve, u, v)
    }
}

/// [`across`]'s weights alone (the same bits).
#[inline]
fn across_weights(crease_edge: usize, curve: &CreaseCurve, u: f64, v: f64) -> [f64; 4] {
    let w = curve.weights(crease_parameter(crease_edge, u, v));
    if reversed(crease_edge) {
        [w[3], w[2], w[1], w[0]]
    } else {
        w
    }
}

/// The weights across the crease (of `curve`, on edge `crease_edge`) at `(u, v)`: the
/// curve's at the crease parameter, reversed where it runs against the patch's.
#[inline]
fn across(crease_edge: usize, curve: &CreaseCurve, u: f64, v: f64) -> Basis {
    let t = crease_parameter(crease_edge, u, v);
    let across = curve.basis(t);
    if reversed(crease_edge) {
        across.reversed()
    } else {
        across
    }
}

/// A patch with one crease, ready for many evaluations: the control grid of every piece is
/// transformed once (as the paper's hull shader does), so each evaluation is a plain bicubic
/// B-spline evaluation of one of up to three grids.
#[derive(Clone, Debug, PartialEq)]
pub struct SingleCreasePatch {
    crease_edge: usize,
    curve: CreaseCurve,
    grids: Vec<ControlGrid>,
}

impl SingleCreasePatch {
    /// Prepares `cp` with a crease of sharpness `s` on edge `crease_edge` (0..4).
    pub fn new(cp: &ControlGrid, crease_edge: usize, s: f64) -> Self {
        Self::with_curve(cp, crease_edge, CreaseCurve::new(s))
    }

    /// Like [`SingleCreasePatch::new`] with the crease pieces already built (shared between
    /// patches of the same sharpness).
    pub fn with_curve(cp: &ControlGrid, crease_edge: usize, curve: CreaseCurve) -> Self {
        let grids = curve
            .segments()
            .iter()
            .map(|s| transform_grid(cp, crease_edge, &s.matrix))
            .collect();
        SingleCreasePatch {
            crease_edge,
            curve,
            grids,
        }
    }

    /// The edge that carries the crease.
    pub fn crease_edge(&self) -> usize {
        self.crease_edge
    }

    /// The crease pieces.
    pub fn curve(&self) -> &CreaseCurve {
        &self.curve
    }

    /// The transformed control grid of piece `k` (one per [`CreaseCurve::segments`]).
    pub fn grid(&self, k: usize) -> &ControlGrid {
        &self.grids[k]
    }

    /// Position and derivatives at `(u, v)`.
    #[inline]
    pub fn eval(&self, u: f64, v: f64) -> PatchPoint {
        let t = crease_parameter(self.crease_edge, u, v);
        bspline::eval(&self.grids[self.curve.segment_index(t)], u, v)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn inverse_is_exact() {
        assert_eq!(mat_mul(&R, &R_INV), IDENTITY);
        assert_eq!(mat_mul(&R_INV, &R), IDENTITY);
    }

    #[test]
    fn closed_form_matches_powers_exactly() {
        for n in 0..=12 {
            assert_eq!(
                transition_matrix(n),
                transition_matrix_by_powers(n),
                "n = {n}"
            );
        }
        assert_eq!(transition_matrix(0), IDENTITY);
        // s = 1 by hand: R⁻¹ R_p.
        assert_eq!(transition_matrix(1), mat_mul(&R_INV, &R_P));
    }

    #[test]
    fn sharp_segment_commutes_with_sharp_refinement() {
        assert_eq!(mat_mul(&M_INF, &R_P), mat_mul(&R, &M_INF));
    }

    #[test]
    fn segments_cover_the_domain() {
        for &s in &[0.0, 0.3, 1.0, 1.7, 2.0, 3.5, 9.0, 9.9, 10.0, 20.0] {
            let c = CreaseCurve::new(s);
            let segs = c.segments();
            assert_eq!(segs[0].start, 0.0);
            assert_eq!(segs.last().unwrap().end, 1.0);
            for w in segs.windows(2) {
                assert_eq!(w[0].end, w[1].start);
            }
            let expect = if s == 0.0 || s >= 10.0 {
                1
            } else if s.fract() == 0.0 || s < 1.0 {
                // M_∞ and M_n, or (for 0 < s < 1) the two blends.
                2
            } else {
                3
            };
            assert_eq!(segs.len(), expect, "s = {s}");
        }
        assert_eq!(CreaseCurve::new(-1.0), CreaseCurve::new(0.0));
        assert_eq!(CreaseCurve::new(f64::NAN), CreaseCurve::new(0.0));
    }
}
