//! Four boxes at once: the inner nodes of a grid block's implicit hierarchy.

use crate::bvh::triangle::{PreparedRay, GAMMA3};

/// Four axis-aligned boxes, structure of arrays; an absent child is the empty box
/// (`lo = +∞`, `hi = −∞`), which no ray meets.
#[derive(Clone, Copy, Debug, PartialEq)]
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

impl Box4 {
    /// Grows child `c` to contain point `p`.
    pub fn include(&mut self, c: usize, p: [f32; 3]) {
        for a in 0..3 {
            self.lo[a][c] = self.lo[a][c].min(p[a]);
            self.hi[a][c] = self.hi[a][c].max(p[a]);
        }
    }

    /// Bounds of child `c` (`[lo, hi]`).
    pub fn child(&self, c: usize) -> [[f32; 3]; 2] {
        [
            std::array::from_fn(|a| self.lo[a][c]),
            std::array::from_fn(|a| self.hi[a][c]),
        ]
    }
}

/// Reference: [`PreparedRay::hits_box`] on each child; bit `c` set for a child met within
/// `tmax`, with its entry distance.
pub fn test4_scalar(b: &Box4, r: &PreparedRay, tmax: f32) -> (u32, [f32; 4]) {
    let mut mask = 0;
    let mut near = [0f32; 4];
    for c in 0..4 {
        let mut n = r.tmin;
        let mut f = tmax;
        for a in 0..3 {
            let (lo, hi) = if r.inv[a].is_sign_negative() {
                (b.hi[a][c], b.lo[a][c])
            } else {
                (b.lo[a][c], b.hi[a][c])
            };
            let tn = (lo - r.o[a]) * r.inv[a];
            let tf = (hi - r.o[a]) * r.inv[a] * (1.0 + 2.0 * GAMMA3);
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

/// [`test4_scalar`] with SSE2 where available, bit for bit (`max`/`min` keep the bound when
/// the slab distance is NaN, as `f32::max` does).
#[inline(always)]
pub fn test4(b: &Box4, r: &PreparedRay, tmax: f32) -> (u32, [f32; 4]) {
    #[cfg(target_arch = "x86_64")]
    // SAFETY: SSE2 is part of the x86_64 baseline.
    unsafe {
        use std::arch::x86_64::*;
        let scale = _mm_set1_ps(1.0 + 2.0 * GAMMA3);
        let mut near = _mm_set1_ps(r.tmin);
        let mut far = _mm_set1_ps(tmax);
        for a in 0..3 {
            let lo = _mm_load_ps(b.lo[a].as_ptr());
            let hi = _mm_load_ps(b.hi[a].as_ptr());
            let (n, f) = if r.inv[a].is_sign_negative() {
                (hi, lo)
            } else {
                (lo, hi)
            };
            let o = _mm_set1_ps(r.o[a]);
            let inv = _mm_set1_ps(r.inv[a]);
            let tn = _mm_mul_ps(_mm_sub_ps(n, o), inv);
            let tf = _mm_mul_ps(_mm_mul_ps(_mm_sub_ps(f, o), inv), scale);
            near = _mm_max_ps(tn, near);
            far = _mm_min_ps(tf, far);
        }
        let mask = _mm_movemask_ps(_mm_cmple_ps(near, far)) as u32;
        let mut out = [0f32; 4];
        _mm_storeu_ps(out.as_mut_ptr(), near);
        (mask, out)
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        test4_scalar(b, r, tmax)
    }
}

/// The children in `mask`, nearest entry first (ties by child index).
#[inline(always)]
pub fn front_to_back(mask: u32, near: &[f32; 4]) -> ([u8; 4], usize) {
    let mut order = [0u8; 4];
    let mut n = 0;
    let mut m = mask;
    while m != 0 {
        let c = m.trailing_zeros() as usize;
        m &= m - 1;
        // Insertion: children arrive in index order, so `<` keeps ties in index order.
        let mut i = n;
        while i > 0 && near[c] < near[order[i - 1] as usize] {
            order[i] = order[i - 1];
            i -= 1;
        }
        order[i] = c as u8;
        n += 1;
    }
    (order, n)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bvh::Ray;
    use crate::harness::rng::SplitMix64;

    #[test]
    fn sse_box_test_matches_scalar() {
        let mut rng = SplitMix64(9);
        let mut f = |s: f64| ((rng.next_f64() - 0.5) * s) as f32;
        for i in 0..20000 {
            let mut b = Box4::default();
            for c in 0..4 {
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
            if i % 5 == 0 && b.lo[i % 3][1].is_finite() {
                o[i % 3] = b.lo[i % 3][1];
            }
            let r = PreparedRay::new(&Ray::new(o, d)).unwrap();
            for tmax in [f32::INFINITY, 1.0] {
                let (m1, n1) = test4(&b, &r, tmax);
                let (m2, n2) = test4_scalar(&b, &r, tmax);
                assert_eq!(m1, m2);
                for c in 0..4 {
                    if m1 & (1 << c) != 0 {
                        assert_eq!(n1[c].to_bits(), n2[c].to_bits());
                    }
                    // The scalar test is `hits_box`.
                    let [lo, hi] = b.child(c);
                    assert_eq!(m2 & (1 << c) != 0, r.hits_box(lo, hi, tmax));
                }
            }
        }
    }

    #[test]
    fn order_is_front_to_back() {
        let (o, n) = front_to_back(0b1011, &[3.0, 1.0, 0.0, 1.0]);
        assert_eq!((n, &o[..n]), (3, &[1u8, 3, 0][..]));
    }
}
