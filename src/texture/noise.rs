//! Procedural 3D gradient noise (Perlin's improved noise: a gradient from 12 edge directions
//! per lattice point, blended with the quintic fade `6t⁵ − 15t⁴ + 10t³`), with its exact
//! gradient, for tests and procedural displacement. Deterministic in `f64`: the same point gives
//! the same bits on every run and thread. The lattice hash is an integer mix of the cell's
//! coordinates, so there is no period to repeat within the numeric contract's range.

/// The 12 gradient directions: the midpoints of a cube's edges.
const GRADIENTS: [[f64; 3]; 12] = [
    [1.0, 1.0, 0.0],
    [-1.0, 1.0, 0.0],
    [1.0, -1.0, 0.0],
    [-1.0, -1.0, 0.0],
    [1.0, 0.0, 1.0],
    [-1.0, 0.0, 1.0],
    [1.0, 0.0, -1.0],
    [-1.0, 0.0, -1.0],
    [0.0, 1.0, 1.0],
    [0.0, -1.0, 1.0],
    [0.0, 1.0, -1.0],
    [0.0, -1.0, -1.0],
];

/// The gradient of lattice point `(x, y, z)`.
fn gradient(x: i64, y: i64, z: i64) -> [f64; 3] {
    let mut h = (x as u64).wrapping_mul(0x9e37_79b9_7f4a_7c15)
        ^ (y as u64).wrapping_mul(0xc2b2_ae3d_27d4_eb4f)
        ^ (z as u64).wrapping_mul(0x1656_67b1_9e37_79f9);
    h ^= h >> 31;
    h = h.wrapping_mul(0xbf58_476d_1ce4_e5b9);
    h ^= h >> 29;
    GRADIENTS[(h % 12) as usize]
}

fn fade(t: f64) -> (f64, f64) {
    let t2 = t * t;
    (
        t * t2 * (t * (6.0 * t - 15.0) + 10.0),
        30.0 * t2 * (t * (t - 2.0) + 1.0),
    )
}

/// Noise at `p` and its gradient. The value lies within ±1.1 (the blend of corner ramps of
/// slope ≤ √2; measured extremes about ±1.0), is zero at every lattice point and is C².
pub fn noise(p: [f64; 3]) -> (f64, [f64; 3]) {
    let cell = p.map(|x| x.floor());
    let f: [f64; 3] = std::array::from_fn(|a| p[a] - cell[a]);
    let c = cell.map(|x| x as i64);
    let w = f.map(fade);
    let mut value = 0.0;
    let mut grad = [0.0; 3];
    for corner in 0..8 {
        let b = [corner & 1, (corner >> 1) & 1, (corner >> 2) & 1];
        let g = gradient(c[0] + b[0], c[1] + b[1], c[2] + b[2]);
        let d: [f64; 3] = std::array::from_fn(|a| f[a] - b[a] as f64);
        let ramp = g[0] * d[0] + g[1] * d[1] + g[2] * d[2];
        // Weight along each axis: w for the far corner, 1 − w for the near one.
        let wt: [f64; 3] = std::array::from_fn(|a| if b[a] == 1 { w[a].0 } else { 1.0 - w[a].0 });
        let dw: [f64; 3] = std::array::from_fn(|a| if b[a] == 1 { w[a].1 } else { -w[a].1 });
        let weight = wt[0] * wt[1] * wt[2];
        value += weight * ramp;
        grad[0] += dw[0] * wt[1] * wt[2] * ramp + weight * g[0];
        grad[1] += wt[0] * dw[1] * wt[2] * ramp + weight * g[1];
        grad[2] += wt[0] * wt[1] * dw[2] * ramp + weight * g[2];
    }
    (value, grad)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The gradient equals central differences (step 1e-6: error ~1e-9); the value is zero on
    /// the lattice, bounded by 1.1, and not constant.
    #[test]
    fn gradient_matches_differences_and_values_are_bounded() {
        let mut state = 1u64;
        let mut next = || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        let (mut lo, mut hi) = (0.0f64, 0.0f64);
        for _ in 0..20_000 {
            let p = [
                next() * 20.0 - 10.0,
                next() * 20.0 - 10.0,
                next() * 20.0 - 10.0,
            ];
            let (v, g) = noise(p);
            lo = lo.min(v);
            hi = hi.max(v);
            for a in 0..3 {
                let h = 1e-6;
                let (mut q, mut r) = (p, p);
                q[a] += h;
                r[a] -= h;
                let fd = (noise(q).0 - noise(r).0) / (2.0 * h);
                assert!(
                    (fd - g[a]).abs() < 1e-7,
                    "axis {a} at {p:?}: {fd} vs {}",
                    g[a]
                );
            }
        }
        assert!(lo > -1.1 && hi < 1.1, "range {lo} {hi}");
        assert!(lo < -0.5 && hi > 0.5, "range {lo} {hi}");
        assert_eq!(noise([3.0, -7.0, 12.0]).0, 0.0);
    }
}
