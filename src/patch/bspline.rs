//! Uniform cubic B-splines: the 1-D basis with its derivatives, and the bicubic tensor-product
//! patch of a 4 × 4 control grid.
//!
//! Control grids use OpenSubdiv's regular-patch layout: `cp[4 * j + i]` is the point in column
//! `i` (along `u`) and row `j` (along `v`). The patch's face is bounded by points 5, 6, 10 and 9
//! (grid positions (1,1), (2,1), (2,2), (1,2)); `(u, v) = (0, 0)` is the limit-surface corner
//! near point 5 and `(1, 1)` the corner near point 10.

/// A 4 × 4 control grid, row-major (`4 * j + i`, `i` along `u`, `j` along `v`).
pub type ControlGrid = [[f64; 3]; 16];

/// A 4 × 4 matrix acting on the four control points of a curve (`out[r] = Σ_c m[r][c] in[c]`).
pub type Mat4 = [[f64; 4]; 4];

/// The 4 × 4 identity matrix.
pub const IDENTITY: Mat4 = [
    [1.0, 0.0, 0.0, 0.0],
    [0.0, 1.0, 0.0, 0.0],
    [0.0, 0.0, 1.0, 0.0],
    [0.0, 0.0, 0.0, 1.0],
];

/// The row vector `n` times `m` ([`Basis::transformed`]'s product, one vector of it).
#[inline]
pub fn row_times(n: &[f64; 4], m: &Mat4) -> [f64; 4] {
    let mut out = [0.0; 4];
    for (r, &nr) in n.iter().enumerate() {
        for c in 0..4 {
            out[c] += nr * m[r][c];
        }
    }
    out
}

/// Values of the four uniform cubic B-spline basis functions on the segment `t ∈ [0, 1]`
/// (control point 1 sits near `t = 0`, control point 2 near `t = 1`).
#[inline]
pub fn basis(t: f64) -> [f64; 4] {
    let s = 1.0 - t;
    let t2 = t * t;
    let t3 = t2 * t;
    [
        s * s * s / 6.0,
        (3.0 * t3 - 6.0 * t2 + 4.0) / 6.0,
        (-3.0 * t3 + 3.0 * t2 + 3.0 * t + 1.0) / 6.0,
        t3 / 6.0,
    ]
}

/// First derivatives of [`basis`] with respect to `t`.
#[inline]
pub fn basis_d1(t: f64) -> [f64; 4] {
    let s = 1.0 - t;
    [
        -0.5 * s * s,
        0.5 * t * (3.0 * t - 4.0),
        0.5 * (-3.0 * t * t + 2.0 * t + 1.0),
        0.5 * t * t,
    ]
}

/// Second derivatives of [`basis`] with respect to `t`.
#[inline]
pub fn basis_d2(t: f64) -> [f64; 4] {
    [1.0 - t, 3.0 * t - 2.0, 1.0 - 3.0 * t, t]
}

/// Four weights over a curve's control points and their first and second derivatives with
/// respect to the curve parameter: one direction of a tensor-product evaluation.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Basis {
    /// Weights of the point.
    pub w: [f64; 4],
    /// Weights of the first derivative.
    pub d1: [f64; 4],
    /// Weights of the second derivative.
    pub d2: [f64; 4],
}

impl Basis {
    /// The plain uniform cubic B-spline basis at `t`.
    #[inline]
    pub fn at(t: f64) -> Self {
        Basis {
            w: basis(t),
            d1: basis_d1(t),
            d2: basis_d2(t),
        }
    }

    /// The weights after a change of control points `P' = M P`: `N(t) M` (a row vector times
    /// `m`), so that evaluating the result on `P` equals evaluating `self` on `M P`.
    #[inline]
    pub fn transformed(&self, m: &Mat4) -> Self {
        Basis {
            w: row_times(&self.w, m),
            d1: row_times(&self.d1, m),
            d2: row_times(&self.d2, m),
        }
    }

    /// The same weights seen from the other end of the curve: control points in reverse order
    /// and the parameter running the other way (`t ↦ 1 − t`), so the first derivative changes
    /// sign.
    #[inline]
    pub fn reversed(&self) -> Self {
        let rev = |a: &[f64; 4]| [a[3], a[2], a[1], a[0]];
        let neg = |a: [f64; 4]| [-a[0], -a[1], -a[2], -a[3]];
        Basis {
            w: rev(&self.w),
            d1: neg(rev(&self.d1)),
            d2: rev(&self.d2),
        }
    }
}

/// A point of a patch with its first and second partial derivatives.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PatchPoint {
    /// Position.
    pub p: [f64; 3],
    /// `∂P/∂u`.
    pub du: [f64; 3],
    /// `∂P/∂v`.
    pub dv: [f64; 3],
    /// `∂²P/∂u²`.
    pub duu: [f64; 3],
    /// `∂²P/∂u∂v`.
    pub duv: [f64; 3],
    /// `∂²P/∂v²`.
    pub dvv: [f64; 3],
}

#[inline]
fn axpy(acc: &mut [f64; 3], w: f64, p: &[f64; 3]) {
    acc[0] += w * p[0];
    acc[1] += w * p[1];
    acc[2] += w * p[2];
}

/// Tensor-product evaluation of `cp` with weights `bu` along `u` (columns `i`) and `bv` along
/// `v` (rows `j`): `P = Σ_j Σ_i bu.w[i] bv.w[j] cp[4 j + i]`, and likewise for the
/// derivatives.
pub fn eval_tensor(cp: &ControlGrid, bu: &Basis, bv: &Basis) -> PatchPoint {
    let mut out = PatchPoint::default();
    for j in 0..4 {
        // Contract row j along u first.
        let mut r = [0.0; 3];
        let mut ru = [0.0; 3];
        let mut ruu = [0.0; 3];
        for i in 0..4 {
            let p = &cp[4 * j + i];
            axpy(&mut r, bu.w[i], p);
            axpy(&mut ru, bu.d1[i], p);
            axpy(&mut ruu, bu.d2[i], p);
        }
        axpy(&mut out.p, bv.w[j], &r);
        axpy(&mut out.dv, bv.d1[j], &r);
        axpy(&mut out.dvv, bv.d2[j], &r);
        axpy(&mut out.du, bv.w[j], &ru);
        axpy(&mut out.duv, bv.d1[j], &ru);
        axpy(&mut out.duu, bv.w[j], &ruu);
    }
    out
}

/// [`eval_tensor`]'s position and first derivatives alone, bit for bit (the same products
/// summed in the same order).
#[inline]
pub fn eval_tensor_d1(cp: &ControlGrid, bu: &Basis, bv: &Basis) -> PointD1 {
    tensor_d1(cp, [&bu.w, &bu.d1], [&bv.w, &bv.d1])
}

/// Position and first derivatives of `cp` with weights and first-derivative weights `u`
/// along `u` (columns `i`) and `v` along `v` (rows `j`): each row contracted along `u` first,
/// as [`eval_tensor`] sums.
#[inline(always)]
fn tensor_d1(cp: &ControlGrid, u: [&[f64; 4]; 2], v: [&[f64; 4]; 2]) -> PointD1 {
    let mut out = PointD1::default();
    for j in 0..4 {
        let mut r = [0.0; 3];
        let mut ru = [0.0; 3];
        for i in 0..4 {
            let p = &cp[4 * j + i];
            axpy(&mut r, u[0][i], p);
            axpy(&mut ru, u[1][i], p);
        }
        axpy(&mut out.p, v[0][j], &r);
        axpy(&mut out.dv, v[1][j], &r);
        axpy(&mut out.du, v[0][j], &ru);
    }
    out
}

/// A point of a patch with its first partial derivatives.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PointD1 {
    /// Position.
    pub p: [f64; 3],
    /// `∂P/∂u`.
    pub du: [f64; 3],
    /// `∂P/∂v`.
    pub dv: [f64; 3],
}

/// The four rows of a control grid, each contracted to one point.
pub(crate) type Rows = [[f64; 3]; 4];

/// The first half of [`eval_tensor_d1`], the same bits: the four rows of `cp` contracted
/// along `u` with weights `w` and first-derivative weights `d1` (value rows, derivative rows),
/// which every point of the same `u` shares.
#[inline(always)]
pub(crate) fn contract_u(cp: &ControlGrid, w: &[f64; 4], d1: &[f64; 4]) -> (Rows, Rows) {
    let mut r = [[0.0; 3]; 4];
    let mut ru = [[0.0; 3]; 4];
    for j in 0..4 {
        for i in 0..4 {
            let p = &cp[4 * j + i];
            axpy(&mut r[j], w[i], p);
            axpy(&mut ru[j], d1[i], p);
        }
    }
    (r, ru)
}

/// The second half of [`eval_tensor_d1`], the same bits: the rows of [`contract_u`] summed
/// with weights `w` and first-derivative weights `d1` along `v`.
#[inline(always)]
pub(crate) fn finish_v((r, ru): &(Rows, Rows), w: &[f64; 4], d1: &[f64; 4]) -> PointD1 {
    let mut pt = PointD1::default();
    for j in 0..4 {
        axpy(&mut pt.p, w[j], &r[j]);
        axpy(&mut pt.dv, d1[j], &r[j]);
        axpy(&mut pt.du, w[j], &ru[j]);
    }
    pt
}

/// The patch of `cp` at the interior points of the lattice `(i / nu, j / nv)`, `0 < i < nu`,
/// `0 < j < nv`, row by row from `j = 1`: position and first derivatives, bit for bit those of
/// [`eval`] at the same `(u, v)` (the same products summed in the same order). Each lattice
/// column's contraction along `u` is done once, so a point costs 36 multiply-adds where
/// [`eval`] spends 216 and two basis evaluations.
pub fn eval_lattice(cp: &ControlGrid, nu: u32, nv: u32, mut out: impl FnMut(PointD1)) {
    if nu < 2 || nv < 2 {
        return;
    }
    // Per interior column i: the four rows contracted along u, value and u-derivative.
    let column = |i: usize| {
        let bu = Basis::at((i + 1) as f64 / nu as f64);
        contract_u(cp, &bu.w, &bu.d1)
    };
    with_columns(nu as usize - 1, column, |cols| {
        for j in 1..nv {
            let t = j as f64 / nv as f64;
            let (w, d1) = (basis(t), basis_d1(t));
            for rows in cols {
                out(finish_v(rows, &w, &d1));
            }
        }
    })
}

/// Lattice columns a domain keeps on the stack (more go to the heap).
const STACK_COLUMNS: usize = 64;

/// Calls `f` with `[make(0), …, make(n - 1)]`, held on the stack when `n` ≤
/// [`STACK_COLUMNS`] (and not initialised beyond them: zeroing or allocating the buffer cost
/// more than the few columns a low rate has — at rate 4, zeroing was a fifth of a lattice's
/// positions), else in a vector.
#[inline(always)]
fn with_columns<T: Copy, R>(
    n: usize,
    mut make: impl FnMut(usize) -> T,
    f: impl FnOnce(&[T]) -> R,
) -> R {
    if n > STACK_COLUMNS {
        return f(&(0..n).map(make).collect::<Vec<T>>());
    }
    let mut buf = [const { std::mem::MaybeUninit::<T>::uninit() }; STACK_COLUMNS];
    for (i, c) in buf[..n].iter_mut().enumerate() {
        c.write(make(i));
    }
    // SAFETY: the first `n` entries were written just above, and `MaybeUninit<T>` has `T`'s
    // layout (`T: Copy`: nothing to drop).
    f(unsafe { std::slice::from_raw_parts(buf.as_ptr().cast::<T>(), n) })
}

/// [`contract_u`]'s value rows alone, the same bits.
#[inline(always)]
pub(crate) fn contract_u_p(cp: &ControlGrid, w: &[f64; 4]) -> Rows {
    let mut r = [[0.0; 3]; 4];
    for j in 0..4 {
        for i in 0..4 {
            axpy(&mut r[j], w[i], &cp[4 * j + i]);
        }
    }
    r
}

/// [`finish_v`]'s position alone, the same bits.
#[inline(always)]
pub(crate) fn finish_v_p(r: &Rows, w: &[f64; 4]) -> [f64; 3] {
    let mut p = [0.0; 3];
    for j in 0..4 {
        axpy(&mut p, w[j], &r[j]);
    }
    p
}

/// [`eval_lattice`]'s positions alone, the same bits and order, for 12 multiply-adds a point
/// (beside each column's contraction, 48) and no derivative weights: for points whose
/// normals are not wanted.
pub fn eval_lattice_p(cp: &ControlGrid, nu: u32, nv: u32, mut out: impl FnMut([f64; 3])) {
    if nu < 2 || nv < 2 {
        return;
    }
    let column = |i: usize| contract_u_p(cp, &basis((i + 1) as f64 / nu as f64));
    with_columns(nu as usize - 1, column, |cols| {
        for j in 1..nv {
            let w = basis(j as f64 / nv as f64);
            for rows in cols {
                out(finish_v_p(rows, &w));
            }
        }
    })
}

/// [`eval_d1`]'s position alone, the same bits.
#[inline]
pub fn eval_p(cp: &ControlGrid, u: f64, v: f64) -> [f64; 3] {
    finish_v_p(&contract_u_p(cp, &basis(u)), &basis(v))
}

/// The patch's points at `coords` (`(u, v)` each), positions alone: [`eval_d1`]'s bits, and
/// where the points share one `u` (a side along `v`), their rows contracted once.
pub fn eval_points_p(
    cp: &ControlGrid,
    coords: impl ExactSizeIterator<Item = [f64; 2]> + Clone,
    mut out: impl FnMut([f64; 3]),
) {
    let mut first = coords.clone();
    let u = first.next().map(|[u, _]| u);
    match u {
        Some(u) if coords.len() > 1 && first.all(|[x, _]| x.to_bits() == u.to_bits()) => {
            let rows = contract_u_p(cp, &basis(u));
            for [_, v] in coords {
                out(finish_v_p(&rows, &basis(v)));
            }
        }
        _ => {
            for [u, v] in coords {
                out(eval_p(cp, u, v));
            }
        }
    }
}

/// The bicubic uniform B-spline patch of `cp` at `(u, v)`, with derivatives.
#[inline]
pub fn eval(cp: &ControlGrid, u: f64, v: f64) -> PatchPoint {
    eval_tensor(cp, &Basis::at(u), &Basis::at(v))
}

/// [`eval`]'s position and first derivatives alone, bit for bit (the same products summed in
/// the same order), for 44 multiply-adds instead of 72 and no second-derivative basis.
#[inline]
pub fn eval_d1(cp: &ControlGrid, u: f64, v: f64) -> PointD1 {
    let (wu, du) = (basis(u), basis_d1(u));
    let (wv, dv) = (basis(v), basis_d1(v));
    tensor_d1(cp, [&wu, &du], [&wv, &dv])
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The position-only evaluations give the positions of the full ones bit for bit:
    /// random control points, lattices of every size up to past the column buffer, and
    /// points along a side (one `u`) and scattered.
    #[test]
    fn positions_alone_are_the_full_positions() {
        let mut rng = crate::harness::rng::SplitMix64(5);
        let cp: ControlGrid =
            std::array::from_fn(|_| std::array::from_fn(|_| rng.next_f64() * 20.0 - 10.0));
        for (nu, nv) in [
            (1, 5),
            (2, 2),
            (3, 7),
            (8, 8),
            (16, 3),
            (64, 2),
            (65, 4),
            (70, 70),
        ] {
            let (mut full, mut alone) = (Vec::new(), Vec::new());
            eval_lattice(&cp, nu, nv, |pt| full.push(pt.p.map(f64::to_bits)));
            eval_lattice_p(&cp, nu, nv, |p| alone.push(p.map(f64::to_bits)));
            assert_eq!(full, alone, "{nu} x {nv}");
        }
        let side: Vec<[f64; 2]> = (1..8).map(|j| [0.25, j as f64 / 8.0]).collect();
        let scattered: Vec<[f64; 2]> = (0..50).map(|_| [rng.next_f64(), rng.next_f64()]).collect();
        for coords in [&side[..], &scattered[..], &side[..1]] {
            let mut alone = Vec::new();
            eval_points_p(&cp, coords.iter().copied(), |p| {
                alone.push(p.map(f64::to_bits))
            });
            let full: Vec<_> = coords
                .iter()
                .map(|&[u, v]| eval_d1(&cp, u, v).p.map(f64::to_bits))
                .collect();
            assert_eq!(full, alone);
        }
    }

    #[test]
    fn partition_of_unity_and_derivatives() {
        for k in 0..=16 {
            let t = k as f64 / 16.0;
            let b = Basis::at(t);
            assert!((b.w.iter().sum::<f64>() - 1.0).abs() < 1e-15);
            assert!(b.d1.iter().sum::<f64>().abs() < 1e-15);
            assert!(b.d2.iter().sum::<f64>().abs() < 1e-15);
            // Linear precision: control points at -1, 0, 1, 2 reproduce t.
            let x: f64 = (0..4).map(|i| b.w[i] * (i as f64 - 1.0)).sum();
            assert!((x - t).abs() < 1e-15);
            let h = 1e-6;
            let (p, m) = (basis(t + h), basis(t - h));
            let (p1, m1) = (basis_d1(t + h), basis_d1(t - h));
            for i in 0..4 {
                assert!(((p[i] - m[i]) / (2.0 * h) - b.d1[i]).abs() < 1e-9);
                assert!(((p1[i] - m1[i]) / (2.0 * h) - b.d2[i]).abs() < 1e-9);
            }
        }
    }

    #[test]
    fn reversed_is_mirror() {
        // By symmetry N_i(t) = N_{3-i}(1 - t): reversing the basis at 1 - t gives the basis at
        // t, and d/dt of the reversed weights is the derivative at t.
        let t = 0.3;
        let a = Basis::at(1.0 - t).reversed();
        let b = Basis::at(t);
        for i in 0..4 {
            assert!((a.w[i] - b.w[i]).abs() < 1e-15);
            assert!((a.d1[i] - b.d1[i]).abs() < 1e-15);
            assert!((a.d2[i] - b.d2[i]).abs() < 1e-15);
        }
    }

    #[test]
    fn lattice_is_eval_bit_for_bit() {
        // A non-planar grid with coordinates of mixed magnitude, so that any change in the
        // order of the sums would show in the last bits.
        let mut cp = [[0.0; 3]; 16];
        for (n, c) in cp.iter_mut().enumerate() {
            let x = n as f64;
            *c = [x.sin() * 3.7, (x * 0.7).cos() * 1e3, x * x * 0.013 - 0.1];
        }
        for (nu, nv) in [(2, 2), (3, 7), (16, 16), (13, 5)] {
            let mut got = Vec::new();
            eval_lattice(&cp, nu, nv, |p| got.push(p));
            assert_eq!(got.len(), ((nu - 1) * (nv - 1)) as usize);
            let mut n = 0;
            for j in 1..nv {
                for i in 1..nu {
                    let e = eval(&cp, i as f64 / nu as f64, j as f64 / nv as f64);
                    let g = got[n];
                    n += 1;
                    for (a, b) in [(g.p, e.p), (g.du, e.du), (g.dv, e.dv)] {
                        assert_eq!(a.map(f64::to_bits), b.map(f64::to_bits), "({i}, {j})");
                    }
                }
            }
        }
        let mut none = 0;
        eval_lattice(&cp, 1, 9, |_| none += 1);
        assert_eq!(none, 0);
    }

    #[test]
    fn bilinear_grid_reproduces_parameters() {
        let mut cp = [[0.0; 3]; 16];
        for j in 0..4 {
            for i in 0..4 {
                cp[4 * j + i] = [i as f64 - 1.0, j as f64 - 1.0, 0.0];
            }
        }
        let p = eval(&cp, 0.25, 0.75);
        let close = |a: [f64; 3], b: [f64; 3]| (0..3).all(|c| (a[c] - b[c]).abs() < 1e-15);
        assert!(close(p.p, [0.25, 0.75, 0.0]));
        assert!(close(p.du, [1.0, 0.0, 0.0]));
        assert!(close(p.dv, [0.0, 1.0, 0.0]));
        assert!(close(p.duu, [0.0; 3]) && close(p.duv, [0.0; 3]) && close(p.dvv, [0.0; 3]));
    }
}
