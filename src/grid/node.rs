//! Four and eight boxes at once: the inner nodes of a grid block's implicit hierarchy
//! ([`Box4`]) and of the top level over blocks ([`Box8`]).

use crate::bvh::triangle::{PreparedRay, GAMMA3};

/// Eight axis-aligned boxes, structure of arrays, as [`Box4`]: the child boxes of a top-level
/// node. The same type as the triangle BVH's exact child boxes.
pub use crate::bvh::mesh::WideBoxes as Box8;

/// Four axis-aligned boxes, structure of arrays; an absent child is the empty box
/// (`lo = +∞`, `hi = −∞`), which no ray meets.
#[derive(Clone, Copy, Debug, PartialEq, bytemuck::Zeroable)]
#[repr(C, align(16))]
pub struct Box4 {
    /// Lower corners: `lo[axis][child]`.
    pub lo: [[f32; 4]; 3],
    /// Upper corners.
    pub hi: [[f32; 4]; 3],
}

impl Default for Box4 {
    fn default() -> Self {
        Box4 {
            lo: [[f32::INFINITY; 4]; 3],
            hi: [[f32::NEG_INFINITY; 4]; 3],
        }
    }
}

/// Grows child `c` of the boxes `lo`, `hi` to contain point `p`.
fn include<const N: usize>(lo: &mut [[f32; N]; 3], hi: &mut [[f32; N]; 3], c: usize, p: [f32; 3]) {
    for a in 0..3 {
        lo[a][c] = lo[a][c].min(p[a]);
        hi[a][c] = hi[a][c].max(p[a]);
    }
}

/// Bounds of child `c` of the boxes `lo`, `hi` (`[lo, hi]`).
fn child<const N: usize>(lo: &[[f32; N]; 3], hi: &[[f32; N]; 3], c: usize) -> [[f32; 3]; 2] {
    [
        std::array::from_fn(|a| lo[a][c]),
        std::array::from_fn(|a| hi[a][c]),
    ]
}

impl Box4 {
    /// Grows child `c` to contain point `p`.
    pub fn include(&mut self, c: usize, p: [f32; 3]) {
        include(&mut self.lo, &mut self.hi, c, p);
    }

    /// Bounds of child `c` (`[lo, hi]`).
    pub fn child(&self, c: usize) -> [[f32; 3]; 2] {
        child(&self.lo, &self.hi, c)
    }
}

impl Box8 {
    /// Grows child `c` to contain point `p`.
    pub fn include(&mut self, c: usize, p: [f32; 3]) {
        include(&mut self.lo, &mut self.hi, c, p);
    }

    /// Bounds of child `c` (`[lo, hi]`).
    pub fn child(&self, c: usize) -> [[f32; 3]; 2] {
        child(&self.lo, &self.hi, c)
    }
}

/// [`PreparedRay::hits_box`] on each of the `N` boxes `lo`, `hi`: bit `c` set for a child
/// met within `tmax`, with its entry distance.
fn test_scalar<const N: usize>(
    lo: &[[f32; N]; 3],
    hi: &[[f32; N]; 3],
    r: &PreparedRay,
    tmax: f32,
) -> (u32, [f32; N]) {
    let mut mask = 0;
    let mut near = [0f32; N];
    for c in 0..N {
        let mut n = r.tmin;
        let mut f = tmax;
        for a in 0..3 {
            let (l, h) = if r.inv[a].is_sign_negative() {
                (hi[a][c], lo[a][c])
            } else {
                (lo[a][c], hi[a][c])
            };
            let tn = (l - r.o[a]) * r.inv[a];
            let tf = (h - r.o[a]) * r.inv[a] * (1.0 + 2.0 * GAMMA3);
            n = n.max(tn);
            f = f.min(tf);
        }
        if n <= f {
            mask |= 1 << c;
        }
        near[c] = n;
    }
    (mask, near)
}

/// Reference: [`PreparedRay::hits_box`] on each child; bit `c` set for a child met within
/// `tmax`, with its entry distance.
pub fn test4_scalar(b: &Box4, r: &PreparedRay, tmax: f32) -> (u32, [f32; 4]) {
    test_scalar(&b.lo, &b.hi, r, tmax)
}

/// Reference for [`test8`]: [`PreparedRay::hits_box`] on each of the eight children.
pub fn test8_scalar(b: &Box8, r: &PreparedRay, tmax: f32) -> (u32, [f32; 8]) {
    test_scalar(&b.lo, &b.hi, r, tmax)
}

/// [`test_scalar`] with SSE2 on the four boxes whose lower corners start at `lo[axis]` and
/// upper at `hi[axis]` (16-byte aligned): the mask, and the entry distances stored at `near`.
///
/// # Safety
/// Each pointer must address four aligned `f32`s, and `near` four writable ones.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
unsafe fn test_quad(
    lo: [*const f32; 3],
    hi: [*const f32; 3],
    r: &PreparedRay,
    tmax: f32,
    near_out: *mut f32,
) -> u32 {
    use std::arch::x86_64::*;
    // SAFETY: SSE2 is part of the x86_64 baseline; the pointers as this function's contract.
    unsafe {
        let scale = _mm_set1_ps(1.0 + 2.0 * GAMMA3);
        let mut near = _mm_set1_ps(r.tmin);
        let mut far = _mm_set1_ps(tmax);
        for a in 0..3 {
            let l = _mm_load_ps(lo[a]);
            let h = _mm_load_ps(hi[a]);
            let o = _mm_set1_ps(r.o[a]);
            let inv = _mm_set1_ps(r.inv[a]);
            // The near and far planes chosen by the sign of `inv` without a branch (which
            // mispredicted on the first boxes of every incoherent ray): all ones where the
            // sign bit is set, as `is_sign_negative` reads it.
            let neg = _mm_castsi128_ps(_mm_srai_epi32::<31>(_mm_castps_si128(inv)));
            let n = _mm_or_ps(_mm_and_ps(neg, h), _mm_andnot_ps(neg, l));
            let f = _mm_or_ps(_mm_and_ps(neg, l), _mm_andnot_ps(neg, h));
            let tn = _mm_mul_ps(_mm_sub_ps(n, o), inv);
            let tf = _mm_mul_ps(_mm_mul_ps(_mm_sub_ps(f, o), inv), scale);
            near = _mm_max_ps(tn, near);
            far = _mm_min_ps(tf, far);
        }
        _mm_storeu_ps(near_out, near);
        _mm_movemask_ps(_mm_cmple_ps(near, far)) as u32
    }
}

/// [`test4_scalar`] with SSE2 where available, bit for bit (`max`/`min` keep the bound when
/// the slab distance is NaN, as `f32::max` does).
#[inline(always)]
pub fn test4(b: &Box4, r: &PreparedRay, tmax: f32) -> (u32, [f32; 4]) {
    #[cfg(target_arch = "x86_64")]
    {
        let mut near = [0f32; 4];
        let lo = b.lo.each_ref().map(|x| x.as_ptr());
        let hi = b.hi.each_ref().map(|x| x.as_ptr());
        // SAFETY: `Box4` is 16-byte aligned, so each row of four is.
        let mask = unsafe { test_quad(lo, hi, r, tmax, near.as_mut_ptr()) };
        (mask, near)
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        test4_scalar(b, r, tmax)
    }
}

/// The sort key of child `c` entered at distance `d`: the distance's bits mapped to an
/// unsigned order (the order of `f32::total_cmp`) above the child index in the low byte.
#[inline(always)]
fn order_key(d: f32, c: usize) -> u64 {
    let b = d.to_bits();
    let ordered = if b >> 31 != 0 { !b } else { b | 1 << 31 };
    (ordered as u64) << 32 | c as u64
}

/// Writes the children in `mask` to `keys[..n]`, nearest entry first (ties by child index),
/// each child's index in its key's low byte ([`child_of`]), and returns `n`. The keys are
/// written and read as 64-bit words in the caller's array: a returned array would be copied
/// with wide loads over the insertion's narrower stores, which stalls store forwarding.
#[inline(always)]
pub fn front_to_back<const N: usize>(mask: u32, near: &[f32; N], keys: &mut [u64; N]) -> usize {
    let mut n = 0;
    let mut m = mask;
    while m != 0 {
        let c = m.trailing_zeros() as usize;
        m &= m - 1;
        let k = order_key(near[c], c);
        let mut i = n;
        while i > 0 && k < keys[i - 1] {
            keys[i] = keys[i - 1];
            i -= 1;
        }
        keys[i] = k;
        n += 1;
    }
    n
}

/// The children in `mask` as [`front_to_back`] keys: sorted with `ORDERED`, else in child
/// order (any-hit queries, whose answer does not depend on the order).
#[inline(always)]
pub fn in_order<const ORDERED: bool, const N: usize>(
    mask: u32,
    near: &[f32; N],
    keys: &mut [u64; N],
) -> usize {
    if ORDERED {
        return front_to_back(mask, near, keys);
    }
    let mut n = 0;
    let mut m = mask;
    while m != 0 {
        keys[n] = m.trailing_zeros() as u64;
        m &= m - 1;
        n += 1;
    }
    n
}

/// The child index of a [`front_to_back`] key.
#[inline(always)]
pub fn child_of(key: u64) -> usize {
    (key & 0xFF) as usize
}

/// [`test8_scalar`] bit for bit: one AVX2 pass with `AVX2`, else two SSE2 halves (the
/// operations of [`test4`]); the scalar reference off x86_64.
///
/// # Safety
/// With `AVX2`, the processor must have AVX2.
#[inline(always)]
pub unsafe fn test8<const AVX2: bool>(b: &Box8, r: &PreparedRay, tmax: f32) -> (u32, [f32; 8]) {
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::x86_64::*;
        let mut out = [0f32; 8];
        if AVX2 {
            // SAFETY: AVX2 is present (this function's contract); `Box8` is 32-byte aligned.
            unsafe {
                let scale = _mm256_set1_ps(1.0 + 2.0 * GAMMA3);
                let mut near = _mm256_set1_ps(r.tmin);
                let mut far = _mm256_set1_ps(tmax);
                for a in 0..3 {
                    let lo = _mm256_load_ps(b.lo[a].as_ptr());
                    let hi = _mm256_load_ps(b.hi[a].as_ptr());
                    let o = _mm256_set1_ps(r.o[a]);
                    let inv = _mm256_set1_ps(r.inv[a]);
                    // Near and far planes by the sign bit of `inv`, without a branch.
                    let n = _mm256_blendv_ps(lo, hi, inv);
                    let f = _mm256_blendv_ps(hi, lo, inv);
                    let tn = _mm256_mul_ps(_mm256_sub_ps(n, o), inv);
                    let tf = _mm256_mul_ps(_mm256_mul_ps(_mm256_sub_ps(f, o), inv), scale);
                    near = _mm256_max_ps(tn, near);
                    far = _mm256_min_ps(tf, far);
                }
                let mask = _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_LE_OQ>(near, far)) as u32;
                _mm256_storeu_ps(out.as_mut_ptr(), near);
                return (mask, out);
            }
        }
        let mut mask = 0;
        for half in 0..2 {
            // SAFETY: `Box8` is 32-byte aligned, so each half row of four is 16-byte aligned.
            unsafe {
                let lo = b.lo.each_ref().map(|x| x.as_ptr().add(4 * half));
                let hi = b.hi.each_ref().map(|x| x.as_ptr().add(4 * half));
                mask |= test_quad(lo, hi, r, tmax, out.as_mut_ptr().add(4 * half)) << (4 * half);
            }
        }
        (mask, out)
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        test8_scalar(b, r, tmax)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bvh::Ray;
    use crate::harness::rng::SplitMix64;

    /// The eight-box test matches the scalar reference bit for bit, with AVX2 (when the
    /// processor has it) and with two SSE2 halves, and so does the four-box test on the first
    /// four boxes; on random boxes, absent children, axis-parallel rays and origins on a face.
    /// The scalar tests are `hits_box`.
    #[test]
    fn box_tests_match_scalar() {
        let mut rng = SplitMix64(19);
        let mut f = |s: f64| ((rng.next_f64() - 0.5) * s) as f32;
        for i in 0..20000 {
            let mut b = Box8::default();
            for c in 0..8 {
                if (i + c) % 5 == 0 {
                    continue;
                }
                for a in 0..3 {
                    let (x, y) = (f(4.0), f(4.0));
                    b.lo[a][c] = x.min(y);
                    b.hi[a][c] = x.max(y);
                }
            }
            let mut d = [f(2.0), f(2.0), f(2.0)];
            if i % 4 == 0 {
                d[i % 3] = 0.0;
            }
            if d == [0.0; 3] {
                d[0] = 1.0;
            }
            let mut o = [f(8.0), f(8.0), f(8.0)];
            if i % 5 == 0 && b.lo[i % 3][6].is_finite() {
                o[i % 3] = b.lo[i % 3][6];
            }
            let r = PreparedRay::new(&Ray::new(o, d)).unwrap();
            let b4 = Box4 {
                lo: b.lo.map(|x| std::array::from_fn(|c| x[c])),
                hi: b.hi.map(|x| std::array::from_fn(|c| x[c])),
            };
            for tmax in [f32::INFINITY, 1.0] {
                let (m2, n2) = test8_scalar(&b, &r, tmax);
                let (m4, n4) = test4_scalar(&b4, &r, tmax);
                let (m1, n1) = test4(&b4, &r, tmax);
                assert_eq!((m1, n1.map(f32::to_bits)), (m4, n4.map(f32::to_bits)));
                assert_eq!(m4, m2 & 0xf);
                for c in 0..4 {
                    if m4 & (1 << c) != 0 {
                        assert_eq!(n4[c].to_bits(), n2[c].to_bits());
                    }
                }
                #[cfg(target_arch = "x86_64")]
                let avx = crate::grid::window::has_avx2();
                #[cfg(not(target_arch = "x86_64"))]
                let avx = false;
                // SAFETY: AVX2 only where detected.
                let runs = unsafe {
                    [
                        Some(test8::<false>(&b, &r, tmax)),
                        avx.then(|| test8::<true>(&b, &r, tmax)),
                    ]
                };
                for (m1, n1) in runs.into_iter().flatten() {
                    assert_eq!(m1, m2, "box {i}");
                    for c in 0..8 {
                        if m1 & (1 << c) != 0 {
                            assert_eq!(n1[c].to_bits(), n2[c].to_bits());
                        }
                    }
                }
                for c in 0..8 {
                    let [lo, hi] = b.child(c);
                    assert_eq!(m2 & (1 << c) != 0, r.hits_box(lo, hi, tmax));
                }
            }
        }
    }

    #[test]
    fn order_is_front_to_back() {
        let order = |mask: u32, near: &[f32; 8]| {
            let mut k = [0; 8];
            let n = front_to_back(mask, near, &mut k);
            k[..n].iter().map(|&k| child_of(k)).collect::<Vec<_>>()
        };
        let near = [0.0, 5.0, 2.0, 9.0, 9.0, 2.0, 0.0, 1.0];
        assert_eq!(order(0b1010_0110, &near), [7, 2, 5, 1]);
        assert_eq!(order(0b1111_1111, &near), [0, 6, 7, 2, 5, 1, 3, 4]);
        // Negative distances (a ray starting inside boxes with `tmin < 0`) come first,
        // infinities last.
        let far = [3.0, -1.0, f32::INFINITY, -0.5, 1.0, 0.0, -2.0, 3.0];
        assert_eq!(order(0xFF, &far), [6, 1, 3, 5, 4, 0, 7, 2]);
        let mut o = [0; 4];
        let n = front_to_back(0b1011, &[3.0, 1.0, 0.0, 1.0], &mut o);
        assert_eq!(
            o[..n].iter().map(|&k| child_of(k)).collect::<Vec<_>>(),
            [1, 3, 0]
        );
    }
}
