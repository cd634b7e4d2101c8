//! Octahedral normals: a unit vector in 32 bits (two 16-bit fixed-point coordinates of its
//! point on the octahedron, folded into the square), encoded as the best of the four nearest
//! codes, decoded to `f32`.

/// Octahedral encoding of a unit vector in two 16-bit fixed-point numbers (a `u32`, `x` in
/// the low half); the best of the four nearest codes is kept.
pub fn oct_encode(n: [f32; 3]) -> u32 {
    let l1 = n[0].abs() + n[1].abs() + n[2].abs();
    if !(l1 > 0.0 && l1.is_finite()) {
        return oct_encode([0.0, 0.0, 1.0]);
    }
    let (mut x, mut y) = (n[0] / l1, n[1] / l1);
    if n[2] < 0.0 {
        let (ax, ay) = (x.abs(), y.abs());
        x = (1.0 - ay) * if x >= 0.0 { 1.0 } else { -1.0 };
        y = (1.0 - ax) * if y >= 0.0 { 1.0 } else { -1.0 };
    }
    // The cast truncates, which is `floor` on these non-negative values (without SSE4.1's
    // `roundss`, `floor` is a call into libm).
    let q = |v: f32| ((v.clamp(-1.0, 1.0) * 0.5 + 0.5) * 65535.0) as u32;
    let (qx, qy) = (q(x), q(y));
    let (qx1, qy1) = ((qx + 1).min(65535), (qy + 1).min(65535));
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx2") {
        // SAFETY: AVX2 is present (detected).
        return unsafe { oct_best_avx2(n, [qx, qx1], [qy, qy1]) };
    }
    oct_best(n, [qx, qx1], [qy, qy1])
}

/// Normals encoded side by side by [`oct_encode_all`].
const LANES: usize = 8;

/// [`oct_encode`] of every normal of `normals` into `codes` (of the same length): the same
/// codes, eight normals side by side (in AVX2 intrinsics where detected, else in lanes the
/// compiler vectorises), the rest one by one.
pub fn oct_encode_all(normals: &[[f32; 3]], codes: &mut [u32]) {
    assert_eq!(normals.len(), codes.len(), "one code per normal");
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx2") {
        // SAFETY: AVX2 is present (detected).
        return unsafe { encode_all_avx2(normals, codes) };
    }
    encode_all(normals, codes)
}

/// [`encode_all_with`] the AVX2 lanes ([`encode_lanes_avx2`]).
///
/// # Safety
/// The processor must have AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn encode_all_avx2(normals: &[[f32; 3]], codes: &mut [u32]) {
    // SAFETY: AVX2 is present (this function's contract).
    encode_all_with(normals, codes, |n| unsafe { encode_lanes_avx2(n) })
}

/// [`encode_lanes`] written with AVX2 intrinsics, bit for bit: the same operations in the
/// same order (no FMA), the `f64` cosines in two halves of four lanes, the bests kept in
/// registers and replaced by blends (the compiler's version of [`encode_lanes`] stores them
/// with masked stores, which the next candidate's loads cannot forward from).
///
/// # Safety
/// The processor must have AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn encode_lanes_avx2(n: &[[f32; 3]; LANES]) -> [u32; LANES] {
    use std::arch::x86_64::*;
    let coord = |a: usize| {
        _mm256_setr_ps(
            n[0][a], n[1][a], n[2][a], n[3][a], n[4][a], n[5][a], n[6][a], n[7][a],
        )
    };
    let (zero, one, sign) = (
        _mm256_setzero_ps(),
        _mm256_set1_ps(1.0),
        _mm256_set1_ps(-0.0),
    );
    let abs = |v: __m256| _mm256_andnot_ps(sign, v);
    let l1 = |x: __m256, y: __m256, z: __m256| _mm256_add_ps(_mm256_add_ps(abs(x), abs(y)), abs(z));
    let (x0, y0, z0) = (coord(0), coord(1), coord(2));
    // Invalid normals (`l1` zero, infinite or NaN) are `+z`.
    let l = l1(x0, y0, z0);
    let ok = _mm256_and_ps(
        _mm256_cmp_ps::<_CMP_GT_OQ>(l, zero),
        _mm256_cmp_ps::<_CMP_LT_OQ>(l, _mm256_set1_ps(f32::INFINITY)),
    );
    let nx = _mm256_and_ps(ok, x0);
    let ny = _mm256_and_ps(ok, y0);
    let nz = _mm256_blendv_ps(one, z0, ok);
    let l = l1(nx, ny, nz);
    let (x, y) = (_mm256_div_ps(nx, l), _mm256_div_ps(ny, l));
    // `(1 − |y|)·±1`: the sign flipped where `x ≥ 0` is false, as the multiplication does.
    let flip = |v: __m256, s: __m256| {
        _mm256_xor_ps(
            v,
            _mm256_andnot_ps(_mm256_cmp_ps::<_CMP_GE_OQ>(s, zero), sign),
        )
    };
    let fx = flip(_mm256_sub_ps(one, abs(y)), x);
    let fy = flip(_mm256_sub_ps(one, abs(x)), y);
    let lower = _mm256_cmp_ps::<_CMP_LT_OQ>(nz, zero);
    let (x, y) = (
        _mm256_blendv_ps(x, fx, lower),
        _mm256_blendv_ps(y, fy, lower),
    );
    let q = |v: __m256| {
        let c = _mm256_min_ps(_mm256_max_ps(v, _mm256_set1_ps(-1.0)), one);
        let half = _mm256_set1_ps(0.5);
        _mm256_cvttps_epi32(_mm256_mul_ps(
            _mm256_add_ps(_mm256_mul_ps(c, half), half),
            _mm256_set1_ps(65535.0),
        ))
    };
    let (qx, qy) = (q(x), q(y));
    let top = _mm256_set1_epi32(65535);
    // The normal in `f64`, low and high halves.
    let wide = |v: __m256| {
        [
            _mm256_cvtps_pd(_mm256_castps256_ps128(v)),
            _mm256_cvtps_pd(_mm256_extractf128_ps::<1>(v)),
        ]
    };
    let (dx, dy, dz) = (wide(nx), wide(ny), wide(nz));
    let mut best_num = [_mm256_set1_pd(f64::NEG_INFINITY); 2];
    let mut best_len2 = [_mm256_set1_pd(1.0); 2];
    let mut best = [_mm256_setzero_si256(); 2];
    // The two codes and their coordinates along each axis, each found once.
    let oc = |q: __m256i| {
        _mm256_sub_ps(
            _mm256_mul_ps(
                _mm256_div_ps(_mm256_cvtepi32_ps(q), _mm256_set1_ps(65535.0)),
                _mm256_set1_ps(2.0),
            ),
            one,
        )
    };
    let next = |q: __m256i| _mm256_min_epu32(_mm256_add_epi32(q, _mm256_set1_epi32(1)), top);
    let (qxs, qys) = ([qx, next(qx)], [qy, next(qy)]);
    let (oxs, oys) = (qxs.map(oc), qys.map(oc));
    for c in 0..4 {
        let (cx, cy) = (qxs[c % 2], qys[c / 2]);
        let (ox, oy) = (oxs[c % 2], oys[c / 2]);
        let (ax, ay) = (abs(ox), abs(oy));
        let z = _mm256_sub_ps(_mm256_sub_ps(one, ax), ay);
        let folded = _mm256_cmp_ps::<_CMP_LT_OQ>(z, zero);
        let wx = _mm256_blendv_ps(ox, flip(_mm256_sub_ps(one, ay), ox), folded);
        let wy = _mm256_blendv_ps(oy, flip(_mm256_sub_ps(one, ax), oy), folded);
        let (wx, wy, wz) = (wide(wx), wide(wy), wide(z));
        let code = _mm256_or_si256(cx, _mm256_slli_epi32::<16>(cy));
        let codes = [
            _mm256_cvtepu32_epi64(_mm256_castsi256_si128(code)),
            _mm256_cvtepu32_epi64(_mm256_extracti128_si256::<1>(code)),
        ];
        for h in 0..2 {
            let dot = _mm256_add_pd(
                _mm256_add_pd(_mm256_mul_pd(wx[h], dx[h]), _mm256_mul_pd(wy[h], dy[h])),
                _mm256_mul_pd(wz[h], dz[h]),
            );
            let len2 = _mm256_add_pd(
                _mm256_add_pd(_mm256_mul_pd(wx[h], wx[h]), _mm256_mul_pd(wy[h], wy[h])),
                _mm256_mul_pd(wz[h], wz[h]),
            );
            let num = _mm256_mul_pd(dot, _mm256_andnot_pd(_mm256_set1_pd(-0.0), dot));
            let better = _mm256_cmp_pd::<_CMP_GT_OQ>(
                _mm256_mul_pd(num, best_len2[h]),
                _mm256_mul_pd(best_num[h], len2),
            );
            best_num[h] = _mm256_blendv_pd(best_num[h], num, better);
            best_len2[h] = _mm256_blendv_pd(best_len2[h], len2, better);
            best[h] = _mm256_castpd_si256(_mm256_blendv_pd(
                _mm256_castsi256_pd(best[h]),
                _mm256_castsi256_pd(codes[h]),
                better,
            ));
        }
    }
    let mut out = [0u64; LANES];
    _mm256_storeu_si256(out.as_mut_ptr() as *mut __m256i, best[0]);
    _mm256_storeu_si256(out.as_mut_ptr().add(4) as *mut __m256i, best[1]);
    out.map(|c| c as u32)
}

/// [`oct_encode_all`] with the compiler's lanes ([`encode_lanes`]), for whatever instructions
/// the caller was compiled for.
fn encode_all(normals: &[[f32; 3]], codes: &mut [u32]) {
    encode_all_with(normals, codes, encode_lanes)
}

/// [`oct_encode_all`]: `lanes` on each run of [`LANES`] normals, the rest one by one.
#[inline(always)]
fn encode_all_with(
    normals: &[[f32; 3]],
    codes: &mut [u32],
    lanes: impl Fn(&[[f32; 3]; LANES]) -> [u32; LANES],
) {
    let mut n = normals.chunks_exact(LANES);
    let mut c = codes.chunks_exact_mut(LANES);
    for (n, c) in (&mut n).zip(&mut c) {
        c.copy_from_slice(&lanes(n.try_into().expect("a chunk of LANES")));
    }
    for (n, c) in n.remainder().iter().zip(c.into_remainder()) {
        *c = oct_encode(*n);
    }
}

/// [`oct_encode`] of [`LANES`] normals, lane by lane the same operations in the same order
/// (no FMA), with selects for its branches: the code of an invalid normal is that of `+z`,
/// so `+z` is encoded in its place.
#[inline(always)]
fn encode_lanes(n: &[[f32; 3]; LANES]) -> [u32; LANES] {
    let (mut nx, mut ny, mut nz) = ([0f32; LANES], [0f32; LANES], [0f32; LANES]);
    for i in 0..LANES {
        let l1 = n[i][0].abs() + n[i][1].abs() + n[i][2].abs();
        let ok = l1 > 0.0 && l1.is_finite();
        nx[i] = if ok { n[i][0] } else { 0.0 };
        ny[i] = if ok { n[i][1] } else { 0.0 };
        nz[i] = if ok { n[i][2] } else { 1.0 };
    }
    let (mut qx, mut qy) = ([0u32; LANES], [0u32; LANES]);
    for i in 0..LANES {
        let l1 = nx[i].abs() + ny[i].abs() + nz[i].abs();
        let (x, y) = (nx[i] / l1, ny[i] / l1);
        let (ax, ay) = (x.abs(), y.abs());
        let fx = (1.0 - ay) * if x >= 0.0 { 1.0 } else { -1.0 };
        let fy = (1.0 - ax) * if y >= 0.0 { 1.0 } else { -1.0 };
        let lower = nz[i] < 0.0;
        let (x, y) = (if lower { fx } else { x }, if lower { fy } else { y });
        // SAFETY: `x` and `y` are finite (`l1` is finite and positive, so every coordinate
        // is finite), so the clamped value lies in [0, 65535], where the unchecked
        // truncation is `oct_encode`'s saturating cast to `u32` (and vectorises).
        let q = |v: f32| unsafe {
            ((v.clamp(-1.0, 1.0) * 0.5 + 0.5) * 65535.0).to_int_unchecked::<i32>() as u32
        };
        qx[i] = q(x);
        qy[i] = q(y);
    }
    let mut best_num = [f64::NEG_INFINITY; LANES];
    let mut best_len2 = [1.0f64; LANES];
    let mut best = [0u32; LANES];
    // The candidates in `oct_best`'s order: `dx` within `dy`.
    for c in 0..4u32 {
        for i in 0..LANES {
            let cx = (qx[i] + c % 2).min(65535);
            let cy = (qy[i] + c / 2).min(65535);
            let w = oct_fold(oct_coord(cx), oct_coord(cy)).map(f64::from);
            let nd = [nx[i], ny[i], nz[i]].map(f64::from);
            let dot = w[0] * nd[0] + w[1] * nd[1] + w[2] * nd[2];
            let len2 = w[0] * w[0] + w[1] * w[1] + w[2] * w[2];
            let num = dot * dot.abs();
            let better = num * best_len2[i] > best_num[i] * len2;
            best_num[i] = if better { num } else { best_num[i] };
            best_len2[i] = if better { len2 } else { best_len2[i] };
            best[i] = if better { cx | cy << 16 } else { best[i] };
        }
    }
    best
}

/// The code among `(qx[dx], qy[dy])` (in the order `dy`, then `dx`) whose decoded direction
/// is nearest `n`: the largest cosine, in `f64` (`1 − cos` of these angles is below `f32`'s
/// resolution), of the direction before its normalisation, so no square root per candidate:
/// cos² with its sign, `dot·|dot| / len²`, compared cross-multiplied (no division); the first
/// of equals is kept.
fn oct_best(n: [f32; 3], qx: [u32; 2], qy: [u32; 2]) -> u32 {
    // The candidates' coordinates before folding, each computed once ([`oct_direction`]).
    let (xs, ys) = (qx.map(oct_coord), qy.map(oct_coord));
    let nd = n.map(f64::from);
    let (mut nums, mut lens) = ([0f64; 4], [0f64; 4]);
    for i in 0..4 {
        let w = oct_fold(xs[i % 2], ys[i / 2]).map(f64::from);
        let dot = w[0] * nd[0] + w[1] * nd[1] + w[2] * nd[2];
        lens[i] = w[0] * w[0] + w[1] * w[1] + w[2] * w[2];
        nums[i] = dot * dot.abs();
    }
    oct_choose(&nums, &lens, qx, qy)
}

/// The code of the candidate (in [`oct_best`]'s order) with the largest `num / len2`,
/// compared cross-multiplied; the first of equals.
#[inline(always)]
fn oct_choose(nums: &[f64; 4], lens: &[f64; 4], qx: [u32; 2], qy: [u32; 2]) -> u32 {
    let (mut best_num, mut best_len2, mut best) = (f64::NEG_INFINITY, 1.0, 0);
    for i in 0..4 {
        let better = nums[i] * best_len2 > best_num * lens[i];
        best_num = if better { nums[i] } else { best_num };
        best_len2 = if better { lens[i] } else { best_len2 };
        best = if better {
            qx[i % 2] | qy[i / 2] << 16
        } else {
            best
        };
    }
    best
}

/// [`oct_best`] bit for bit, its four candidates side by side: the fold in four `f32`
/// lanes, the cosines in four `f64` lanes (the same operations in the same order, no FMA),
/// the choice scalar and in the same order.
///
/// # Safety
/// The processor must have AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn oct_best_avx2(n: [f32; 3], qx: [u32; 2], qy: [u32; 2]) -> u32 {
    use std::arch::x86_64::*;
    let (xs, ys) = (qx.map(oct_coord), qy.map(oct_coord));
    // Lanes in the scalar loop's order: (x0, y0), (x1, y0), (x0, y1), (x1, y1).
    let x = _mm_setr_ps(xs[0], xs[1], xs[0], xs[1]);
    let y = _mm_setr_ps(ys[0], ys[0], ys[1], ys[1]);
    let zero = _mm_setzero_ps();
    let one = _mm_set1_ps(1.0);
    let sign = _mm_set1_ps(-0.0);
    let (ax, ay) = (_mm_andnot_ps(sign, x), _mm_andnot_ps(sign, y));
    let z = _mm_sub_ps(_mm_sub_ps(one, ax), ay);
    // Folded: `(1 − |y|)·±1` is `1 − |y|` with its sign flipped where `x < 0` (`x ≥ 0`
    // false), exactly as the multiplication by −1 does.
    let fx = _mm_xor_ps(
        _mm_sub_ps(one, ay),
        _mm_andnot_ps(_mm_cmpge_ps(x, zero), sign),
    );
    let fy = _mm_xor_ps(
        _mm_sub_ps(one, ax),
        _mm_andnot_ps(_mm_cmpge_ps(y, zero), sign),
    );
    let lower = _mm_cmplt_ps(z, zero);
    let wx = _mm256_cvtps_pd(_mm_blendv_ps(x, fx, lower));
    let wy = _mm256_cvtps_pd(_mm_blendv_ps(y, fy, lower));
    let wz = _mm256_cvtps_pd(z);
    let [n0, n1, n2] = n.map(|c| _mm256_set1_pd(f64::from(c)));
    let dot = _mm256_add_pd(
        _mm256_add_pd(_mm256_mul_pd(wx, n0), _mm256_mul_pd(wy, n1)),
        _mm256_mul_pd(wz, n2),
    );
    let len2 = _mm256_add_pd(
        _mm256_add_pd(_mm256_mul_pd(wx, wx), _mm256_mul_pd(wy, wy)),
        _mm256_mul_pd(wz, wz),
    );
    let num = _mm256_mul_pd(dot, _mm256_andnot_pd(_mm256_set1_pd(-0.0), dot));
    let (mut nums, mut lens) = ([0f64; 4], [0f64; 4]);
    _mm256_storeu_pd(nums.as_mut_ptr(), num);
    _mm256_storeu_pd(lens.as_mut_ptr(), len2);
    oct_choose(&nums, &lens, qx, qy)
}

/// One coordinate of an octahedral code's point before folding, in `[-1, 1]`.
#[inline(always)]
fn oct_coord(q: u32) -> f32 {
    (q as f32 / 65535.0) * 2.0 - 1.0
}

/// The point `(x, y)` of the square on the octahedron: the upper half where `|x| + |y| ≤ 1`,
/// the lower half folded out to the corners otherwise.
#[inline(always)]
fn oct_fold(x: f32, y: f32) -> [f32; 3] {
    let z = 1.0 - x.abs() - y.abs();
    if z < 0.0 {
        let (ax, ay) = (x.abs(), y.abs());
        [
            (1.0 - ay) * if x >= 0.0 { 1.0 } else { -1.0 },
            (1.0 - ax) * if y >= 0.0 { 1.0 } else { -1.0 },
            z,
        ]
    } else {
        [x, y, z]
    }
}

/// The direction of an octahedral code before normalisation (on the octahedron).
#[inline(always)]
fn oct_direction(code: u32) -> [f32; 3] {
    oct_fold(oct_coord(code & 0xFFFF), oct_coord(code >> 16))
}

/// The unit vector of an octahedral code.
#[inline(always)]
pub fn oct_decode(code: u32) -> [f32; 3] {
    crate::bvh::mesh::normalize(oct_direction(code))
}

/// The unit vectors of three octahedral codes: [`oct_decode`]'s, bit for bit, with one
/// vector operation per step for the three (a hit record decodes its corners together).
#[inline]
pub fn oct_decode3(codes: [u32; 3]) -> [[f32; 3]; 3] {
    #[cfg(target_arch = "x86_64")]
    // SAFETY: SSE2 is part of the x86_64 baseline.
    unsafe {
        decode3_sse2(codes)
    }
    #[cfg(not(target_arch = "x86_64"))]
    codes.map(oct_decode)
}

/// [`oct_decode3`] in SSE2: the codes in three lanes, the same operations in the same order as
/// [`oct_coord`], [`oct_fold`] and the normalisation (IEEE per lane, so the same bits; a
/// point on the octahedron has a squared length in `[1/3, 1]`, so the normalisation never
/// takes its fallback).
#[cfg(target_arch = "x86_64")]
#[inline(always)]
unsafe fn decode3_sse2(c: [u32; 3]) -> [[f32; 3]; 3] {
    use std::arch::x86_64::*;
    let lane = |f: fn(u32) -> u32| _mm_set_epi32(0, f(c[2]) as i32, f(c[1]) as i32, f(c[0]) as i32);
    let (one, zero) = (_mm_set1_ps(1.0), _mm_setzero_ps());
    let coord = |q: __m128i| {
        let unit = _mm_div_ps(_mm_cvtepi32_ps(q), _mm_set1_ps(65535.0));
        _mm_sub_ps(_mm_mul_ps(unit, _mm_set1_ps(2.0)), one)
    };
    let x = coord(lane(|c| c & 0xFFFF));
    let y = coord(lane(|c| c >> 16));
    let abs = _mm_castsi128_ps(_mm_set1_epi32(0x7FFF_FFFF));
    let (ax, ay) = (_mm_and_ps(x, abs), _mm_and_ps(y, abs));
    let z = _mm_sub_ps(_mm_sub_ps(one, ax), ay);
    let select = |m: __m128, a: __m128, b: __m128| _mm_or_ps(_mm_and_ps(m, a), _mm_andnot_ps(m, b));
    let sign = |v: __m128| select(_mm_cmpge_ps(v, zero), one, _mm_set1_ps(-1.0));
    let folded = _mm_cmplt_ps(z, zero);
    let x = select(folded, _mm_mul_ps(_mm_sub_ps(one, ay), sign(x)), x);
    let y = select(folded, _mm_mul_ps(_mm_sub_ps(one, ax), sign(y)), y);
    let l2 = _mm_add_ps(
        _mm_add_ps(_mm_mul_ps(x, x), _mm_mul_ps(y, y)),
        _mm_mul_ps(z, z),
    );
    let l = _mm_sqrt_ps(l2);
    let mut out = [[0f32; 4]; 3];
    _mm_storeu_ps(out[0].as_mut_ptr(), _mm_div_ps(x, l));
    _mm_storeu_ps(out[1].as_mut_ptr(), _mm_div_ps(y, l));
    _mm_storeu_ps(out[2].as_mut_ptr(), _mm_div_ps(z, l));
    std::array::from_fn(|i| [out[0][i], out[1][i], out[2][i]])
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::harness::rng::SplitMix64;

    /// Octahedral normals are within 5e-5 rad of the encoded unit vector: 16 bits per
    /// coordinate make a cell of the octahedron 2/65535 wide, whose diagonal subtends at most
    /// about 4.3e-5 rad on the sphere (measured in `f64` on the same codes), and the best of
    /// the four corner codes is kept; `f32` decoding adds ~1e-7.
    /// [`oct_decode3`] gives [`oct_decode`]'s bits: every code whose two coordinates are
    /// both multiples of 97 or at the ends and middle of their range (the fold's edges, where
    /// the signs change), and 300,000 random codes, in every lane.
    #[test]
    fn decode3_is_decode_bit_for_bit() {
        let mut coords: Vec<u32> = (0..65536).step_by(97).collect();
        coords.extend([0, 1, 32766, 32767, 32768, 32769, 65534, 65535]);
        let mut codes: Vec<u32> = coords
            .iter()
            .flat_map(|&x| coords.iter().map(move |&y| x | y << 16))
            .collect();
        let mut rng = SplitMix64(97);
        codes.extend((0..300_000).map(|_| rng.next_u64() as u32));
        let bits = |n: [f32; 3]| n.map(f32::to_bits);
        for w in codes.windows(3) {
            let got = oct_decode3([w[0], w[1], w[2]]);
            for i in 0..3 {
                assert_eq!(bits(got[i]), bits(oct_decode(w[i])), "code {:#x}", w[i]);
            }
        }
    }

    #[test]
    fn octahedral_normals_round_trip() {
        let mut rng = SplitMix64(3);
        let mut worst = 0f64;
        for i in 0..200000 {
            let mut n = [
                rng.next_f64() * 2.0 - 1.0,
                rng.next_f64() * 2.0 - 1.0,
                rng.next_f64() * 2.0 - 1.0,
            ];
            if i < 6 {
                n = [0.0; 3];
                n[i / 2] = if i % 2 == 0 { 1.0 } else { -1.0 };
            }
            let l = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
            let n = n.map(|x| (x / l) as f32);
            let m = oct_decode(oct_encode(n));
            // atan2(|n × m|, n · m): `acos` of a dot product of unit-ish `f32` vectors would
            // read their length error (1e-7) as an angle of 5e-4.
            let (n, m) = (n.map(f64::from), m.map(f64::from));
            let c = [
                n[1] * m[2] - n[2] * m[1],
                n[2] * m[0] - n[0] * m[2],
                n[0] * m[1] - n[1] * m[0],
            ];
            let sin = (c[0] * c[0] + c[1] * c[1] + c[2] * c[2]).sqrt();
            let cos = n[0] * m[0] + n[1] * m[1] + n[2] * m[2];
            worst = worst.max(sin.atan2(cos));
        }
        assert!(worst < 5e-5, "worst angle {worst}");
    }

    /// The encoder as first written: every candidate decoded in full, the best kept by
    /// branches; [`oct_encode`] must choose the same codes.
    fn oct_encode_reference(n: [f32; 3]) -> u32 {
        let l1 = n[0].abs() + n[1].abs() + n[2].abs();
        if !(l1 > 0.0 && l1.is_finite()) {
            return oct_encode_reference([0.0, 0.0, 1.0]);
        }
        let (mut x, mut y) = (n[0] / l1, n[1] / l1);
        if n[2] < 0.0 {
            let (ax, ay) = (x.abs(), y.abs());
            x = (1.0 - ay) * if x >= 0.0 { 1.0 } else { -1.0 };
            y = (1.0 - ax) * if y >= 0.0 { 1.0 } else { -1.0 };
        }
        let q = |v: f32| ((v.clamp(-1.0, 1.0) * 0.5 + 0.5) * 65535.0).floor() as u32;
        let (qx, qy) = (q(x), q(y));
        let nd = n.map(f64::from);
        let (mut best_num, mut best_len2, mut best) = (f64::NEG_INFINITY, 1.0, 0);
        for dy in 0..2u32 {
            for dx in 0..2u32 {
                let code = (qx + dx).min(65535) | ((qy + dy).min(65535) << 16);
                let w = oct_direction(code).map(f64::from);
                let dot = w[0] * nd[0] + w[1] * nd[1] + w[2] * nd[2];
                let len2 = w[0] * w[0] + w[1] * w[1] + w[2] * w[2];
                let num = dot * dot.abs();
                if num * best_len2 > best_num * len2 {
                    (best_num, best_len2, best) = (num, len2, code);
                }
            }
        }
        best
    }

    /// The batch encoder gives every normal `oct_encode`'s code, on both instruction paths,
    /// whatever the length (whole chunks of lanes and a remainder), invalid normals included.
    #[test]
    fn batch_encoder_equals_one_by_one() {
        let mut rng = SplitMix64(29);
        let mut normals = vec![
            [0.0, 0.0, 0.0],
            [f32::NAN, 0.0, 1.0],
            [f32::INFINITY, 0.0, 0.0],
            [-0.0, -0.0, -1.0],
            [0.6, -0.8, -0.0],
            [0.0, 0.0, -1.0],
            [1e-30, -1e-30, 1e-30],
        ];
        for _ in 0..100_003 {
            let v = [(); 3].map(|_| rng.next_f64() as f32 * 2.0 - 1.0);
            normals.push(match rng.below(4) {
                0 => [v[0], v[1], 0.0],
                1 => [v[0], 0.0, v[2]],
                _ => v,
            });
        }
        let want: Vec<u32> = normals.iter().map(|&n| oct_encode(n)).collect();
        for len in [0, 5, 8, 13, normals.len()] {
            let mut codes = vec![0; len];
            oct_encode_all(&normals[..len], &mut codes);
            assert_eq!(codes, want[..len], "dispatched, {len} normals");
            let mut codes = vec![0; len];
            encode_all(&normals[..len], &mut codes);
            assert_eq!(codes, want[..len], "baseline instructions, {len} normals");
        }
    }

    #[test]
    fn octahedral_encoder_equals_reference() {
        let mut rng = SplitMix64(17);
        let mut special = vec![
            [0.0, 0.0, 1.0],
            [0.0, 0.0, -1.0],
            [1.0, 0.0, 0.0],
            [-1.0, 0.0, 0.0],
            [0.0, -1.0, 0.0],
            [0.0, 0.0, 0.0],
            [f32::NAN, 0.0, 1.0],
            [f32::INFINITY, 0.0, 0.0],
            [-0.0, -0.0, -1.0],
            [0.6, -0.8, -0.0],
        ];
        for _ in 0..200_000 {
            let v = [(); 3].map(|_| rng.next_f64() as f32 * 2.0 - 1.0);
            // Some on the octahedron's edges and the equator, where codes saturate or fold.
            special.push(match rng.below(4) {
                0 => [v[0], v[1], 0.0],
                1 => [v[0], 0.0, v[2]],
                _ => v,
            });
        }
        for n in special {
            let want = oct_encode_reference(n);
            assert_eq!(oct_encode(n), want, "{n:?}");
            // The scalar chooser, whichever one `oct_encode` dispatched to.
            let l1 = n[0].abs() + n[1].abs() + n[2].abs();
            if l1 > 0.0 && l1.is_finite() {
                let (qx, qy) = (want & 0xFFFF, want >> 16);
                let near = |q: u32| [q.saturating_sub(1), q, (q + 1).min(65535)];
                // Every pair of neighbouring candidates around the chosen code: the AVX2
                // chooser (when present) picks as the scalar one does.
                for x0 in near(qx) {
                    for y0 in near(qy) {
                        let (xq, yq) = ([x0, (x0 + 1).min(65535)], [y0, (y0 + 1).min(65535)]);
                        let scalar = oct_best(n, xq, yq);
                        #[cfg(target_arch = "x86_64")]
                        if std::arch::is_x86_feature_detected!("avx2") {
                            // SAFETY: AVX2 is present (detected).
                            assert_eq!(unsafe { oct_best_avx2(n, xq, yq) }, scalar, "{n:?}");
                        }
                        assert!([xq[0], xq[1]].contains(&(scalar & 0xFFFF)));
                    }
                }
            }
        }
    }
}
