//! The leaf test: a ray against the eight triangles of a 3×3-vertex window of a grid block
//! (2×2 quads, each split along its `a–c` diagonal), with Woop, Benthin and Wald's watertight
//! test ([`crate::bvh::triangle`]).
//!
//! The nine vertices are carried into the ray's sheared space once; the edge functions, the
//! determinant and `t` of the eight triangles are then computed eight lanes at once with AVX2
//! where the processor has it (detected at run time), else four lanes at a time with SSE2
//! (part of every x86-64). Every lane performs exactly the operations of the scalar test, in
//! the same order and without fused multiply-adds, and a lane whose edge function is zero is
//! redone in `f64` as the scalar test does, so either SIMD answer equals the scalar one bit
//! for bit, whatever the width ([`window_scalar`] is the reference; a test checks both
//! against it).
//!
//! Lanes are numbered by quad row, quad column, then half (`[a, b, c]` before `[a, c, d]`),
//! which is also the order of the triangles' ids in their diced mesh; of equal `t` the lowest
//! lane wins.

use crate::bvh::triangle::{intersect_prepared, PreparedRay};

/// The nine vertices of a window, `x`, `y`, `z` planes, row-major (`3 j + i`).
pub type Window = [[f32; 9]; 3];

/// Corner indices (into the 3×3 window) of the eight triangles, by lane.
pub const CORNERS: [[usize; 3]; 8] = {
    let mut c = [[0usize; 3]; 8];
    let mut l = 0;
    while l < 8 {
        let (qy, qx, h) = (l / 4, (l / 2) % 2, l % 2);
        let a = 3 * qy + qx;
        let (b, cc, d) = (a + 1, a + 4, a + 3);
        c[l] = if h == 0 { [a, b, cc] } else { [a, cc, d] };
        l += 1;
    }
    c
};

/// The best hit found in a window: `(lane, t, b1, b2)`.
pub type LaneHit = (usize, f32, f32, f32);

/// Lanes present in a window of `qx × qy` quads (`1..=2` each): bit `l` for lane `l`.
pub fn lane_mask(qx: usize, qy: usize) -> u32 {
    let mut m = 0;
    for y in 0..qy {
        for x in 0..qx {
            m |= 0b11 << (4 * y + 2 * x);
        }
    }
    m
}

/// Reference: the scalar watertight test on each present lane; the closest hit within `tmax`
/// (lowest lane on equal `t`).
pub fn window_scalar(r: &PreparedRay, w: &Window, lanes: u32, tmax: f32) -> Option<LaneHit> {
    let mut best: Option<LaneHit> = None;
    for (l, c) in CORNERS.iter().enumerate() {
        if lanes & (1 << l) == 0 {
            continue;
        }
        let p = |i: usize| [w[0][c[i]], w[1][c[i]], w[2][c[i]]];
        let limit = best.map_or(tmax, |b| b.1);
        if let Some((t, b1, b2)) = intersect_prepared(r, p(0), p(1), p(2), limit) {
            if best.is_none_or(|b| t < b.1) {
                best = Some((l, t, b1, b2));
            }
        }
    }
    best
}

/// Where a window's vertices lie in a block: the block's coordinates and the offsets of the
/// window's three rows; a row's `x` values start at its offset, its `y` values `plane` later,
/// its `z` values `2 plane` later. Each row's three vertices are consecutive; a fourth value
/// is read and ignored (at least three values must follow the last).
#[derive(Clone, Copy, Debug)]
pub struct Rows<'a> {
    /// The block's coordinates, to the end of the mesh's (padded) array.
    pub coords: &'a [f32],
    /// Distance from a row's `x` values to its `y` values, and from those to its `z` values.
    pub plane: usize,
    /// Offset of each row's first `x` value.
    pub offs: [usize; 3],
}

/// A window stored on its own, for tests and benchmarks of the leaf test outside a mesh: each
/// plane's three rows four values apart, the planes twelve apart, then four values of padding
/// (`NaN`, which no lane may read); [`Rows::lone`] reads it.
pub fn lone_coords(w: &Window) -> Vec<f32> {
    let mut coords = vec![f32::NAN; 3 * 12 + 4];
    for a in 0..3 {
        for k in 0..9 {
            coords[a * 12 + 4 * (k / 3) + k % 3] = w[a][k];
        }
    }
    coords
}

impl<'a> Rows<'a> {
    /// The rows of a window stored by [`lone_coords`].
    pub fn lone(coords: &'a [f32]) -> Rows<'a> {
        Rows {
            coords,
            plane: 12,
            offs: [0, 4, 8],
        }
    }

    /// The nine vertices (row `y`, column `x` at `3 y + x`).
    pub fn gather(&self) -> Window {
        std::array::from_fn(|a| {
            std::array::from_fn(|i| self.coords[a * self.plane + self.offs[i / 3] + i % 3])
        })
    }
}

/// The closest hit of the window within `tmax`: [`window_scalar`]'s answer on
/// [`Rows::gather`], eight lanes at once with AVX2 where the processor has it (detected at
/// run time), four at a time with SSE2 on other x86-64 processors.
#[inline(always)]
pub fn window(r: &PreparedRay, rows: &Rows, lanes: u32, tmax: f32) -> Option<LaneHit> {
    #[cfg(target_arch = "x86_64")]
    if has_avx2() {
        // SAFETY: AVX2 is present (detected).
        return unsafe { window_with::<true>(r, rows, lanes, tmax) };
    }
    // SAFETY: without `AVX2` nothing beyond the baseline is used.
    unsafe { window_with::<false>(r, rows, lanes, tmax) }
}

/// [`window`] with the instruction set chosen by the caller: the AVX2 test when `AVX2`, else
/// SSE2 (the scalar test off x86-64). A traversal compiled for AVX2 calls it with `true`:
/// the AVX2 test is then called from AVX2 code (inlining it too measured slower on the grid).
///
/// # Safety
/// With `AVX2`, the processor must have AVX2.
#[inline(always)]
pub unsafe fn window_with<const AVX2: bool>(
    r: &PreparedRay,
    rows: &Rows,
    lanes: u32,
    tmax: f32,
) -> Option<LaneHit> {
    #[cfg(target_arch = "x86_64")]
    {
        assert!(rows
            .offs
            .iter()
            .all(|&o| 2 * rows.plane + o + 4 <= rows.coords.len()));
        if AVX2 {
            // SAFETY: AVX2 is present (the caller's contract); the loads are in bounds.
            unsafe { window_avx2(r, rows, lanes, tmax) }
        } else {
            // SAFETY: SSE2 is part of the x86_64 baseline; the loads are in bounds (asserted).
            unsafe { window_sse(r, rows, lanes, tmax) }
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        window_scalar(r, &rows.gather(), lanes, tmax)
    }
}

/// The `f64` edge functions of a lane whose `f32` ones have a zero, as the scalar test redoes
/// them.
#[inline(never)]
fn exact_edges(a: [f32; 2], b: [f32; 2], c: [f32; 2]) -> [f32; 3] {
    let (ax, ay, bx, by, cx, cy) = (
        a[0] as f64,
        a[1] as f64,
        b[0] as f64,
        b[1] as f64,
        c[0] as f64,
        c[1] as f64,
    );
    [
        (cx * by - cy * bx) as f32,
        (ax * cy - ay * cx) as f32,
        (bx * ay - by * ax) as f32,
    ]
}

/// Which leaf test [`window`] runs on this processor: `"avx2"` (eight lanes), `"sse2"` (four
/// lanes) or `"scalar"`.
pub fn leaf_isa() -> &'static str {
    #[cfg(target_arch = "x86_64")]
    {
        if has_avx2() {
            "avx2"
        } else {
            "sse2"
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        "scalar"
    }
}

/// AVX2 is present (std caches the detection: one load).
#[cfg(target_arch = "x86_64")]
#[inline(always)]
pub fn has_avx2() -> bool {
    std::arch::is_x86_feature_detected!("avx2")
}

/// The window's three rows in the ray's sheared space, `[row][x, y, z]`, four lanes each (the
/// fourth ignored): the scalar test's operations per vertex, in the same order.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
unsafe fn sheared(r: &PreparedRay, rows: &Rows) -> [[std::arch::x86_64::__m128; 3]; 3] {
    use std::arch::x86_64::*;
    let [kx, ky, kz] = r.k;
    let p = rows.coords.as_ptr();
    let (ox, oy, oz) = (
        _mm_set1_ps(r.o[kx]),
        _mm_set1_ps(r.o[ky]),
        _mm_set1_ps(r.o[kz]),
    );
    let (sx, sy, sz) = (
        _mm_set1_ps(r.s[0]),
        _mm_set1_ps(r.s[1]),
        _mm_set1_ps(r.s[2]),
    );
    let mut sh = [[_mm_setzero_ps(); 3]; 3];
    for (y, row) in sh.iter_mut().enumerate() {
        let o = rows.offs[y];
        let atx = _mm_sub_ps(_mm_loadu_ps(p.add(kx * rows.plane + o)), ox);
        let aty = _mm_sub_ps(_mm_loadu_ps(p.add(ky * rows.plane + o)), oy);
        let atz = _mm_sub_ps(_mm_loadu_ps(p.add(kz * rows.plane + o)), oz);
        row[0] = _mm_sub_ps(atx, _mm_mul_ps(sx, atz));
        row[1] = _mm_sub_ps(aty, _mm_mul_ps(sy, atz));
        row[2] = _mm_mul_ps(sz, atz);
    }
    sh
}

/// Corner lanes of a quad row between vertex rows `r0` and `r1` (see [`CORNERS`]):
/// a = [r0₀ r0₀ r0₁ r0₁], b = [r0₁ r1₁ r0₂ r1₂], c = [r1₁ r1₀ r1₂ r1₁].
#[cfg(target_arch = "x86_64")]
#[inline(always)]
unsafe fn corners(
    r0: std::arch::x86_64::__m128,
    r1: std::arch::x86_64::__m128,
) -> [std::arch::x86_64::__m128; 3] {
    use std::arch::x86_64::*;
    let a = _mm_shuffle_ps::<0b01_01_00_00>(r0, r0);
    let lo = _mm_unpacklo_ps(r0, r1);
    let hi = _mm_unpackhi_ps(r0, r1);
    let b = _mm_shuffle_ps::<0b01_00_11_10>(lo, hi);
    let c = _mm_shuffle_ps::<0b01_10_00_01>(r1, r1);
    [a, b, c]
}

/// Stores the sheared rows as scalars for the edge-function fallback: coordinate `a` of
/// window vertex `3 y + x` at `s[a][4 y + x]`.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
unsafe fn store_sheared(sh: &[[std::arch::x86_64::__m128; 3]; 3]) -> [[f32; 12]; 3] {
    let mut s = [[0f32; 12]; 3];
    for (y, row) in sh.iter().enumerate() {
        for (a, v) in row.iter().enumerate() {
            std::arch::x86_64::_mm_storeu_ps(s[a].as_mut_ptr().add(4 * y), *v);
        }
    }
    s
}

/// The `f64` edge functions of lane `lane` (its corners from [`CORNERS`]) from the stored
/// sheared vertices.
#[inline(always)]
fn lane_exact_edges(s: &[[f32; 12]; 3], lane: usize) -> [f32; 3] {
    // Vertex `3 y + x` of the window is lane `x` of row `y`: index `4 y + x`.
    let at = |i: usize| 4 * (i / 3) + i % 3;
    let c = CORNERS[lane];
    let p = |i: usize| [s[0][at(c[i])], s[1][at(c[i])]];
    exact_edges(p(0), p(1), p(2))
}

/// Per-lane results of the vector test, stored for the scalar choice of the closest hit.
#[derive(Default)]
struct Lanes {
    t: [f32; 8],
    ts: [f32; 8],
    ad: [f32; 8],
    b1: [f32; 8],
    b2: [f32; 8],
}

impl Lanes {
    /// Takes the lanes in `hits` (bit `j`: lane `first + j`) in lane order into `best`. The
    /// scalar loop tests each lane against the best so far as its `tmax`, then keeps it only
    /// if strictly closer: the two tests that depend on `tmax` are redone with it (a lane that
    /// passed them with a larger `tmax` may fail them now; one that failed cannot pass).
    #[inline(always)]
    fn resolve(&self, mut hits: u32, first: usize, tmax: f32, best: &mut Option<LaneHit>) {
        while hits != 0 {
            let j = hits.trailing_zeros() as usize;
            hits &= hits - 1;
            let lim = best.map_or(tmax, |b| b.1);
            if self.ts[j] > lim * self.ad[j] || self.t[j] > lim {
                continue;
            }
            if best.is_none_or(|b| self.t[j] < b.1) {
                *best = Some((first + j, self.t[j], self.b1[j], self.b2[j]));
            }
        }
    }
}

#[cfg(target_arch = "x86_64")]
#[inline(always)]
unsafe fn window_sse(r: &PreparedRay, rows: &Rows, lanes: u32, tmax: f32) -> Option<LaneHit> {
    use std::arch::x86_64::*;
    let sh = sheared(r, rows);
    // The edge-function fallback reads the sheared vertices back as scalars.
    let mut s = None;
    let mut best: Option<LaneHit> = None;
    for half in 0..2 {
        let group = (lanes >> (4 * half)) & 0xF;
        if group == 0 {
            continue;
        }
        let [ax, bx, cx] = corners(sh[half][0], sh[half + 1][0]);
        let [ay, by, cy] = corners(sh[half][1], sh[half + 1][1]);
        let [az, bz, cz] = corners(sh[half][2], sh[half + 1][2]);
        let mut u = _mm_sub_ps(_mm_mul_ps(cx, by), _mm_mul_ps(cy, bx));
        let mut v = _mm_sub_ps(_mm_mul_ps(ax, cy), _mm_mul_ps(ay, cx));
        let mut wv = _mm_sub_ps(_mm_mul_ps(bx, ay), _mm_mul_ps(by, ax));
        let zero = _mm_setzero_ps();
        let zeros = _mm_movemask_ps(_mm_or_ps(
            _mm_or_ps(_mm_cmpeq_ps(u, zero), _mm_cmpeq_ps(v, zero)),
            _mm_cmpeq_ps(wv, zero),
        )) as u32
            & group;
        if zeros != 0 {
            let mut uu = [0f32; 4];
            let mut vv = [0f32; 4];
            let mut ww = [0f32; 4];
            _mm_storeu_ps(uu.as_mut_ptr(), u);
            _mm_storeu_ps(vv.as_mut_ptr(), v);
            _mm_storeu_ps(ww.as_mut_ptr(), wv);
            let s = s.get_or_insert_with(|| store_sheared(&sh));
            let mut z = zeros;
            while z != 0 {
                let j = z.trailing_zeros() as usize;
                z &= z - 1;
                [uu[j], vv[j], ww[j]] = lane_exact_edges(s, 4 * half + j);
            }
            u = _mm_loadu_ps(uu.as_ptr());
            v = _mm_loadu_ps(vv.as_ptr());
            wv = _mm_loadu_ps(ww.as_ptr());
        }
        // Mixed signs: a miss.
        let neg = _mm_or_ps(
            _mm_or_ps(_mm_cmplt_ps(u, zero), _mm_cmplt_ps(v, zero)),
            _mm_cmplt_ps(wv, zero),
        );
        let pos = _mm_or_ps(
            _mm_or_ps(_mm_cmpgt_ps(u, zero), _mm_cmpgt_ps(v, zero)),
            _mm_cmpgt_ps(wv, zero),
        );
        let det = _mm_add_ps(_mm_add_ps(u, v), wv);
        let t_scaled = _mm_add_ps(
            _mm_add_ps(_mm_mul_ps(u, az), _mm_mul_ps(v, bz)),
            _mm_mul_ps(wv, cz),
        );
        let sign = _mm_set1_ps(-0.0);
        let det_neg = _mm_cmplt_ps(det, zero);
        // (ts, ad) = det < 0 ? (−t_scaled, −det) : (t_scaled, det); negation is a sign flip.
        let ts = _mm_xor_ps(t_scaled, _mm_and_ps(det_neg, sign));
        let ad = _mm_xor_ps(det, _mm_and_ps(det_neg, sign));
        let limit = best.map_or(tmax, |b| b.1);
        let tmin4 = _mm_set1_ps(r.tmin);
        let tmax4 = _mm_set1_ps(limit);
        let out_of_range = _mm_or_ps(
            _mm_cmplt_ps(ts, _mm_mul_ps(tmin4, ad)),
            _mm_cmpgt_ps(ts, _mm_mul_ps(tmax4, ad)),
        );
        let reject = _mm_or_ps(
            _mm_or_ps(_mm_and_ps(neg, pos), _mm_cmpeq_ps(det, zero)),
            out_of_range,
        );
        // Most halves end here, before the division.
        let hits = !(_mm_movemask_ps(reject) as u32) & group;
        if hits == 0 {
            continue;
        }
        let rcp = _mm_div_ps(_mm_set1_ps(1.0), det);
        let t = _mm_mul_ps(t_scaled, rcp);
        let t_out = _mm_or_ps(_mm_cmplt_ps(t, tmin4), _mm_cmpgt_ps(t, tmax4));
        // NaN comparisons are false, as in the scalar test: a NaN `t` is never rejected by
        // them and never accepted either (the scalar test's `t < tmin || t > tmax` is false
        // for NaN, so it would return it; keep that lane and let the comparison below see it).
        let hits = hits & !(_mm_movemask_ps(t_out) as u32);
        if hits == 0 {
            continue;
        }
        let mut lane = Lanes::default();
        _mm_storeu_ps(lane.t.as_mut_ptr(), t);
        _mm_storeu_ps(lane.ts.as_mut_ptr(), ts);
        _mm_storeu_ps(lane.ad.as_mut_ptr(), ad);
        _mm_storeu_ps(lane.b1.as_mut_ptr(), _mm_mul_ps(v, rcp));
        _mm_storeu_ps(lane.b2.as_mut_ptr(), _mm_mul_ps(wv, rcp));
        lane.resolve(hits, 4 * half, tmax, &mut best);
    }
    best
}

/// [`window_sse`] on all eight lanes at once: the same operations per lane, in 256-bit
/// registers (the quad rows' corner lanes side by side), one pass of the `f64` fallback and
/// one scalar choice of the closest hit.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
#[inline]
unsafe fn window_avx2(r: &PreparedRay, rows: &Rows, lanes: u32, tmax: f32) -> Option<LaneHit> {
    use std::arch::x86_64::*;
    let group = lanes & 0xFF;
    if group == 0 {
        return None;
    }
    let sh = sheared(r, rows);
    // Coordinate `k` of the corners of all eight lanes: quad row 0 low, quad row 1 high.
    let pair = |k: usize| -> [__m256; 3] {
        let [a0, b0, c0] = corners(sh[0][k], sh[1][k]);
        let [a1, b1, c1] = corners(sh[1][k], sh[2][k]);
        [
            _mm256_set_m128(a1, a0),
            _mm256_set_m128(b1, b0),
            _mm256_set_m128(c1, c0),
        ]
    };
    let [ax, bx, cx] = pair(0);
    let [ay, by, cy] = pair(1);
    let [az, bz, cz] = pair(2);
    let mut u = _mm256_sub_ps(_mm256_mul_ps(cx, by), _mm256_mul_ps(cy, bx));
    let mut v = _mm256_sub_ps(_mm256_mul_ps(ax, cy), _mm256_mul_ps(ay, cx));
    let mut wv = _mm256_sub_ps(_mm256_mul_ps(bx, ay), _mm256_mul_ps(by, ax));
    let zero = _mm256_setzero_ps();
    let eq = |a: __m256| _mm256_cmp_ps::<_CMP_EQ_OQ>(a, zero);
    let lt = |a: __m256, b: __m256| _mm256_cmp_ps::<_CMP_LT_OQ>(a, b);
    let gt = |a: __m256, b: __m256| _mm256_cmp_ps::<_CMP_GT_OQ>(a, b);
    let zeros = _mm256_movemask_ps(_mm256_or_ps(_mm256_or_ps(eq(u), eq(v)), eq(wv))) as u32 & group;
    if zeros != 0 {
        let mut uu = [0f32; 8];
        let mut vv = [0f32; 8];
        let mut ww = [0f32; 8];
        _mm256_storeu_ps(uu.as_mut_ptr(), u);
        _mm256_storeu_ps(vv.as_mut_ptr(), v);
        _mm256_storeu_ps(ww.as_mut_ptr(), wv);
        let s = store_sheared(&sh);
        let mut z = zeros;
        while z != 0 {
            let j = z.trailing_zeros() as usize;
            z &= z - 1;
            [uu[j], vv[j], ww[j]] = lane_exact_edges(&s, j);
        }
        u = _mm256_loadu_ps(uu.as_ptr());
        v = _mm256_loadu_ps(vv.as_ptr());
        wv = _mm256_loadu_ps(ww.as_ptr());
    }
    // Mixed signs: a miss.
    let neg = _mm256_or_ps(_mm256_or_ps(lt(u, zero), lt(v, zero)), lt(wv, zero));
    let pos = _mm256_or_ps(_mm256_or_ps(gt(u, zero), gt(v, zero)), gt(wv, zero));
    let det = _mm256_add_ps(_mm256_add_ps(u, v), wv);
    let t_scaled = _mm256_add_ps(
        _mm256_add_ps(_mm256_mul_ps(u, az), _mm256_mul_ps(v, bz)),
        _mm256_mul_ps(wv, cz),
    );
    let sign = _mm256_set1_ps(-0.0);
    let det_neg = lt(det, zero);
    // (ts, ad) = det < 0 ? (−t_scaled, −det) : (t_scaled, det); negation is a sign flip.
    let ts = _mm256_xor_ps(t_scaled, _mm256_and_ps(det_neg, sign));
    let ad = _mm256_xor_ps(det, _mm256_and_ps(det_neg, sign));
    let tmin8 = _mm256_set1_ps(r.tmin);
    let tmax8 = _mm256_set1_ps(tmax);
    let out_of_range = _mm256_or_ps(
        lt(ts, _mm256_mul_ps(tmin8, ad)),
        gt(ts, _mm256_mul_ps(tmax8, ad)),
    );
    let reject = _mm256_or_ps(_mm256_or_ps(_mm256_and_ps(neg, pos), eq(det)), out_of_range);
    // Most windows end here, before the division.
    let hits = !(_mm256_movemask_ps(reject) as u32) & group;
    if hits == 0 {
        return None;
    }
    let rcp = _mm256_div_ps(_mm256_set1_ps(1.0), det);
    let t = _mm256_mul_ps(t_scaled, rcp);
    // NaN `t`: as in [`window_sse`].
    let hits = hits & !(_mm256_movemask_ps(_mm256_or_ps(lt(t, tmin8), gt(t, tmax8))) as u32);
    if hits == 0 {
        return None;
    }
    let mut lane = Lanes::default();
    _mm256_storeu_ps(lane.t.as_mut_ptr(), t);
    _mm256_storeu_ps(lane.ts.as_mut_ptr(), ts);
    _mm256_storeu_ps(lane.ad.as_mut_ptr(), ad);
    _mm256_storeu_ps(lane.b1.as_mut_ptr(), _mm256_mul_ps(v, rcp));
    _mm256_storeu_ps(lane.b2.as_mut_ptr(), _mm256_mul_ps(wv, rcp));
    let mut best = None;
    lane.resolve(hits, 0, tmax, &mut best);
    best
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bvh::Ray;
    use crate::harness::rng::SplitMix64;

    fn random_window(rng: &mut SplitMix64, flat: bool) -> Window {
        let mut w = [[0f32; 9]; 3];
        for j in 0..3 {
            for i in 0..3 {
                let k = 3 * j + i;
                let jitter = |rng: &mut SplitMix64| ((rng.next_f64() - 0.5) * 0.6) as f32;
                w[0][k] = i as f32 + jitter(rng);
                w[1][k] = j as f32 + jitter(rng);
                w[2][k] = if flat { 0.5 } else { jitter(rng) };
            }
        }
        w
    }

    /// The SSE2 and AVX2 window tests (and [`window`]'s choice between them) equal the scalar
    /// reference bit for bit, on random windows and rays, rays aimed exactly at vertices and
    /// edge points (where edge functions vanish), flat windows seen edge-on, partial windows
    /// and short `tmax`.
    #[test]
    fn simd_windows_match_scalar() {
        #[cfg(target_arch = "x86_64")]
        if !has_avx2() {
            println!("note: this processor has no AVX2; only the SSE2 window test is checked");
        }
        let mut rng = SplitMix64(17);
        let mut hits = 0;
        for i in 0..40000 {
            let w = random_window(&mut rng, i % 7 == 0);
            let lanes = lane_mask(1 + (i % 2), 1 + ((i / 2) % 2));
            let o = [
                ((rng.next_f64() - 0.5) * 8.0) as f32,
                ((rng.next_f64() - 0.5) * 8.0) as f32,
                ((rng.next_f64() + 0.2) * if i % 3 == 0 { -4.0 } else { 4.0 }) as f32,
            ];
            let target = match i % 4 {
                0 => {
                    let k = (rng.next_f64() * 9.0) as usize;
                    [w[0][k], w[1][k], w[2][k]]
                }
                1 => {
                    let c = CORNERS[(rng.next_f64() * 8.0) as usize];
                    let s = rng.next_f64() as f32;
                    std::array::from_fn(|a| w[a][c[0]] + s * (w[a][c[1]] - w[a][c[0]]))
                }
                _ => [
                    (rng.next_f64() * 2.4 - 0.2) as f32,
                    (rng.next_f64() * 2.4 - 0.2) as f32,
                    0.0,
                ],
            };
            let mut d: [f32; 3] = std::array::from_fn(|a| target[a] - o[a]);
            if i % 11 == 0 {
                d[(i / 11) % 3] = 0.0;
            }
            if d == [0.0; 3] {
                continue;
            }
            let r = PreparedRay::new(&Ray::new(o, d)).unwrap();
            // Rows four values apart (the fourth a stray value), planes twelve apart.
            let coords = lone_coords(&w);
            let rows = Rows::lone(&coords);
            assert_eq!(rows.gather(), w);
            for tmax in [f32::INFINITY, 0.999, 1.0] {
                let a = window(&r, &rows, lanes, tmax);
                let b = window_scalar(&r, &w, lanes, tmax);
                let bits = |h: Option<LaneHit>| {
                    h.map(|(l, t, b1, b2)| (l, t.to_bits(), b1.to_bits(), b2.to_bits()))
                };
                assert_eq!(bits(a), bits(b), "case {i}, tmax {tmax}");
                #[cfg(target_arch = "x86_64")]
                {
                    // SAFETY: SSE2 is baseline; AVX2 only where detected; rows in bounds.
                    let sse = unsafe { window_sse(&r, &rows, lanes, tmax) };
                    assert_eq!(bits(sse), bits(b), "SSE2, case {i}, tmax {tmax}");
                    if has_avx2() {
                        let avx = unsafe { window_avx2(&r, &rows, lanes, tmax) };
                        assert_eq!(bits(avx), bits(b), "AVX2, case {i}, tmax {tmax}");
                    }
                }
                hits += usize::from(a.is_some());
            }
        }
        assert!(hits > 20000, "{hits} hits: the rays should mostly hit");
    }

    #[test]
    fn lanes_cover_the_window() {
        assert_eq!(lane_mask(2, 2), 0xFF);
        assert_eq!(lane_mask(1, 1), 0b11);
        assert_eq!(lane_mask(1, 2), 0b11_0011);
        // Each quad's two triangles share the diagonal a–c.
        for l in (0..8).step_by(2) {
            assert_eq!(CORNERS[l][0], CORNERS[l + 1][0]);
            assert_eq!(CORNERS[l][2], CORNERS[l + 1][1]);
        }
    }
}
