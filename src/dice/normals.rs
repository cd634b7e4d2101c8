//! The unit normal of a diced point, one at a time ([`unit_normal`]) or a domain's lattice at
//! once ([`unit_normals`], the same bits, four points per instruction where the CPU has AVX).

use crate::coord::FaceCoord;
use crate::error::Result;
use crate::patch::bspline::PointD1;
use crate::patch::PatchTable;
use crate::vec3::{cross, dot, norm};

/// The unit normal at `at` of the surface whose derivatives there are `du`, `dv`. Where the
/// parametric normal vanishes (corners of boundary faces, crease ends), the normal is taken a
/// little inside the domain.
pub(super) fn unit_normal(
    table: &PatchTable,
    at: FaceCoord,
    du: [f64; 3],
    dv: [f64; 3],
) -> Result<[f64; 3]> {
    let mut n = cross(du, dv);
    let clear = clears(dot(n, n), dot(du, du), dot(dv, dv));
    if !clear && (norm(n).is_nan() || norm(n) <= 1e-10 * (norm(du) * norm(dv))) {
        let (u2, v2) = (at.u + (0.5 - at.u) * 1e-4, at.v + (0.5 - at.v) * 1e-4);
        let s2 = table.eval_d1(FaceCoord::new(at.face, at.k, u2, v2))?;
        n = cross(s2.du, s2.dv);
    }
    let l = norm(n);
    Ok(if l > 0.0 && l.is_finite() {
        [n[0] / l, n[1] / l, n[2] / l]
    } else {
        [0.0, 0.0, 1.0]
    })
}

/// Whether a parametric normal of squared length `n2` is for sure longer than `1e-10 |du|
/// |dv|` (`uu`, `vv` the derivatives' squared lengths), without the square roots: the squares
/// clear the bound by a relative 1e-12 (rounding moves either side by a few 1e-16) in the
/// normal range. Otherwise [`unit_normal`] decides by the test as stated.
#[inline(always)]
fn clears(n2: f64, uu: f64, vv: f64) -> bool {
    let bound = 1e-20 * uu * vv;
    bound.is_normal() && n2.is_normal() && n2 > bound * (1.0 + 1e-12)
}

/// [`unit_normal`] of the points `pts`, the `i`-th at `at(i)`, into `out` (cleared first), the
/// same bits point by point: the points whose parametric normal clearly does not vanish are
/// normalised four at a time, the others one by one.
pub(super) fn unit_normals(
    table: &PatchTable,
    pts: &[PointD1],
    at: impl Fn(usize) -> FaceCoord,
    out: &mut Vec<[f64; 3]>,
) -> Result<()> {
    out.clear();
    out.resize(pts.len(), [0.0; 3]);
    let mut clear = [false; LANES];
    for (c, (pts, out)) in pts.chunks(LANES).zip(out.chunks_mut(LANES)).enumerate() {
        let all = normalise(pts, out, &mut clear);
        if !all {
            for (i, pt) in pts.iter().enumerate().filter(|&(i, _)| !clear[i]) {
                out[i] = unit_normal(table, at(c * LANES + i), pt.du, pt.dv)?;
            }
        }
    }
    Ok(())
}

/// Points normalised at once.
const LANES: usize = 4;

/// [`unit_normal`]'s clear case for up to [`LANES`] points: `out[i]` is `pts[i]`'s unit
/// normal where `clear[i]`; true when every point is clear.
fn normalise(pts: &[PointD1], out: &mut [[f64; 3]], clear: &mut [bool; LANES]) -> bool {
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx") {
        // SAFETY: the CPU has AVX (checked just above).
        return unsafe { normalise_avx(pts, out, clear) };
    }
    normalise_lanes(pts, out, clear)
}

/// [`normalise_lanes`] compiled for AVX (four `f64` lanes per instruction).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx")]
unsafe fn normalise_avx(pts: &[PointD1], out: &mut [[f64; 3]], clear: &mut [bool; LANES]) -> bool {
    normalise_lanes(pts, out, clear)
}

/// [`normalise`] lane by lane: the derivatives transposed into lanes, then [`unit_normal`]'s
/// operations in the same order on every lane (no fused multiply-adds: the same bits).
#[inline(always)]
fn normalise_lanes(pts: &[PointD1], out: &mut [[f64; 3]], clear: &mut [bool; LANES]) -> bool {
    let mut du = [[0.0f64; LANES]; 3];
    let mut dv = [[0.0f64; LANES]; 3];
    for (i, pt) in pts.iter().enumerate() {
        for a in 0..3 {
            du[a][i] = pt.du[a];
            dv[a][i] = pt.dv[a];
        }
    }
    // Absent lanes stay zero and unclear.
    let n: [[f64; LANES]; 3] = [
        std::array::from_fn(|i| du[1][i] * dv[2][i] - du[2][i] * dv[1][i]),
        std::array::from_fn(|i| du[2][i] * dv[0][i] - du[0][i] * dv[2][i]),
        std::array::from_fn(|i| du[0][i] * dv[1][i] - du[1][i] * dv[0][i]),
    ];
    let dot3 = |a: &[[f64; LANES]; 3], b: &[[f64; LANES]; 3]| -> [f64; LANES] {
        std::array::from_fn(|i| a[0][i] * b[0][i] + a[1][i] * b[1][i] + a[2][i] * b[2][i])
    };
    let n2 = dot3(&n, &n);
    let (uu, vv) = (dot3(&du, &du), dot3(&dv, &dv));
    let l: [f64; LANES] = std::array::from_fn(|i| n2[i].sqrt());
    let mut all = true;
    for i in 0..LANES {
        clear[i] = clears(n2[i], uu[i], vv[i]);
        all &= clear[i] || i >= pts.len();
    }
    for (i, o) in out.iter_mut().enumerate() {
        *o = [n[0][i] / l[i], n[1][i] / l[i], n[2][i] / l[i]];
    }
    all
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::harness::rng::SplitMix64;
    use crate::mesh::generate;
    use crate::patch::PatchOptions;

    /// Batches give [`unit_normal`]'s bits point by point: random derivatives over many
    /// magnitudes (clear lanes), and degenerate ones (zero, parallel, tiny, huge, subnormal,
    /// infinite, NaN) that take the point-by-point rule, in batches of every length.
    #[test]
    fn batches_are_point_by_point_bit_for_bit() {
        let mesh = generate::grid(2);
        let table = PatchTable::new(&mesh, PatchOptions::default()).unwrap();
        let mut rng = SplitMix64::new(7);
        let mut vec3 = |scale: f64| -> [f64; 3] {
            std::array::from_fn(|_| (rng.next_f64() * 2.0 - 1.0) * scale)
        };
        let mut pts = Vec::new();
        for i in 0..400 {
            let scale = 10f64.powi(i % 41 - 20);
            let du = vec3(scale);
            let dv = match i % 10 {
                0 => du,
                1 => [0.0; 3],
                2 => du.map(|x| x * 1e-300),
                3 => du.map(|x| x + f64::MIN_POSITIVE),
                4 => [f64::INFINITY, 0.0, 1.0],
                5 => [f64::NAN, 1.0, 0.0],
                6 => du.map(|x| -x * 3.0),
                _ => vec3(scale * 10f64.powi(i % 7 - 3)),
            };
            pts.push(PointD1 {
                p: [0.0; 3],
                du,
                dv,
            });
        }
        let uv: Vec<[f64; 2]> = (0..pts.len())
            .map(|i| [(i % 9 + 1) as f64 / 10.0, (i % 7 + 1) as f64 / 8.0])
            .collect();
        let bits = |n: [f64; 3]| n.map(f64::to_bits);
        let want: Vec<_> = pts
            .iter()
            .zip(&uv)
            .map(|(pt, &[u, v])| {
                bits(unit_normal(&table, FaceCoord::new(3, 0, u, v), pt.du, pt.dv).unwrap())
            })
            .collect();
        let mut out = Vec::new();
        for len in [1, 2, 3, 4, 5, 7, 8, 9, 400] {
            for start in (0..pts.len() - len).step_by(37) {
                let end = start + len;
                let at = |i: usize| {
                    let [u, v] = uv[start + i];
                    FaceCoord::new(3, 0, u, v)
                };
                unit_normals(&table, &pts[start..end], at, &mut out).unwrap();
                let got: Vec<_> = out.iter().map(|&n| bits(n)).collect();
                assert_eq!(got, want[start..end], "batch {start}..{end}");
            }
        }
        let unclear = pts.iter().filter(|pt| {
            let mut out = [[0.0; 3]];
            let mut clear = [false; LANES];
            !normalise(std::slice::from_ref(pt), &mut out, &mut clear)
        });
        assert!(unclear.count() >= 100, "degenerate cases covered");
    }
}
