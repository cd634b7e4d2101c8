//! The triangulation pattern of one quad domain in parameter space, given the number of
//! segments on each of its four sides.
//!
//! A domain is the unit square of a quad face or of one sub-face of an n-gon. Its sides, in
//! counter-clockwise order, are `0: (0,0)→(1,0)`, `1: (1,0)→(1,1)`, `2: (1,1)→(0,1)`,
//! `3: (0,1)→(0,0)`. Side `s` has `rates[s]` segments of equal parametric length. The interior
//! is a regular `nu × nv` grid with `nu = max(r0, r2)` and `nv = max(r1, r3)`; the ring of
//! interior points next to the boundary is stitched to each side by a zipper, so sides may have
//! any rates and no T-junction arises: every boundary point is a triangle corner.
//!
//! Points are numbered boundary ring first (side 0's points from `(0,0)`, then side 1's from
//! `(1,0)`, …, each side's last point being the next side's first), then interior points.

/// Triangles and interior points of a domain.
#[derive(Clone, Debug, PartialEq)]
pub struct Pattern {
    /// Segments per side.
    pub rates: [u32; 4],
    /// `(u, v)` of the interior points, numbered after the ring.
    pub interior: Vec<[f64; 2]>,
    /// Counter-clockwise triangles (in `(u, v)`, hence as the control face).
    pub triangles: Vec<[u32; 3]>,
}

impl Pattern {
    /// Number of boundary points.
    pub fn ring_len(&self) -> usize {
        self.rates.iter().map(|&r| r as usize).sum()
    }

    /// `(u, v)` of point `i` (ring or interior).
    pub fn uv(&self, i: usize) -> [f64; 2] {
        let n = self.ring_len();
        if i >= n {
            return self.interior[i - n];
        }
        let mut j = i as u32;
        for s in 0..4 {
            if j < self.rates[s] {
                return side_uv(s, j as f64 / self.rates[s] as f64);
            }
            j -= self.rates[s];
        }
        unreachable!("ring index in range")
    }

    /// Ring index of point `j` (`0..=rates[s]`) of side `s`.
    pub fn ring_index(&self, s: usize, j: u32) -> u32 {
        let offset: u32 = self.rates[..s].iter().sum();
        let n = self.ring_len() as u32;
        (offset + j) % n
    }
}

/// The point at fraction `t` along side `s`.
pub fn side_uv(s: usize, t: f64) -> [f64; 2] {
    match s {
        0 => [t, 0.0],
        1 => [1.0, t],
        2 => [1.0 - t, 1.0],
        _ => [0.0, 1.0 - t],
    }
}

/// Builds the pattern for side rates `rates` (each at least 1).
pub fn pattern(rates: [u32; 4]) -> Pattern {
    assert!(rates.iter().all(|&r| r >= 1), "side rates must be positive");
    let nu = rates[0].max(rates[2]);
    let nv = rates[1].max(rates[3]);
    let mut p = Pattern {
        rates,
        interior: Vec::new(),
        triangles: Vec::new(),
    };
    let side = |p: &Pattern, s: usize| -> Vec<u32> {
        (0..=rates[s]).map(|j| p.ring_index(s, j)).collect()
    };
    if nu >= 2 && nv >= 2 {
        let n = p.ring_len() as u32;
        let (iu, iv) = (nu - 1, nv - 1);
        for j in 1..nv {
            for i in 1..nu {
                p.interior
                    .push([i as f64 / nu as f64, j as f64 / nv as f64]);
            }
        }
        let inner = |i: u32, j: u32| n + (j - 1) * iu + (i - 1);
        for j in 1..nv - 1 {
            for i in 1..nu - 1 {
                let (a, b, c, d) = (
                    inner(i, j),
                    inner(i + 1, j),
                    inner(i + 1, j + 1),
                    inner(i, j + 1),
                );
                p.triangles.push([a, b, c]);
                p.triangles.push([a, c, d]);
            }
        }
        // Inner ring sides, running the same way as the outer sides.
        let bottom: Vec<u32> = (1..=iu).map(|i| inner(i, 1)).collect();
        let right: Vec<u32> = (1..=iv).map(|j| inner(iu, j)).collect();
        let top: Vec<u32> = (1..=iu).rev().map(|i| inner(i, iv)).collect();
        let left: Vec<u32> = (1..=iv).rev().map(|j| inner(1, j)).collect();
        for (s, inner_side) in [bottom, right, top, left].into_iter().enumerate() {
            let outer = side(&p, s);
            let tris = zip(&p, s, &outer, &inner_side);
            p.triangles.extend(tris);
        }
    } else if nu >= 2 {
        // One row: zip side 0 with side 2 reversed.
        let bottom = side(&p, 0);
        let mut top = side(&p, 2);
        top.reverse();
        let tris = zip(&p, 0, &bottom, &top);
        p.triangles.extend(tris);
    } else if nv >= 2 {
        let right = side(&p, 1);
        let mut left = side(&p, 3);
        left.reverse();
        let tris = zip(&p, 1, &right, &left);
        p.triangles.extend(tris);
    } else {
        p.triangles.push([0, 1, 2]);
        p.triangles.push([0, 2, 3]);
    }
    p
}

/// Coordinate along side `s`'s direction.
fn along(s: usize, uv: [f64; 2]) -> f64 {
    match s {
        0 => uv[0],
        1 => uv[1],
        2 => 1.0 - uv[0],
        _ => 1.0 - uv[1],
    }
}

/// Triangulates the strip between polyline `a` and polyline `b` that runs beside it on its
/// left, both in the direction of side `s`: starts with the segment `a[0]–b[0]` and ends with
/// `a[last]–b[last]`, advancing on whichever line's next point comes first along the side.
fn zip(p: &Pattern, s: usize, a: &[u32], b: &[u32]) -> Vec<[u32; 3]> {
    let coord = |i: u32| along(s, p.uv(i as usize));
    let (mut i, mut j) = (0, 0);
    let mut out = Vec::with_capacity(a.len() + b.len());
    while i + 1 < a.len() || j + 1 < b.len() {
        let advance_a = if j + 1 == b.len() {
            true
        } else if i + 1 == a.len() {
            false
        } else {
            // Compare the midpoints of the two candidate new edges' far ends.
            coord(a[i + 1]) <= coord(b[j + 1])
        };
        if advance_a {
            out.push([a[i], a[i + 1], b[j]]);
            i += 1;
        } else {
            out.push([a[i], b[j + 1], b[j]]);
            j += 1;
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn area(p: &Pattern, t: [u32; 3]) -> f64 {
        let [a, b, c] = t.map(|i| p.uv(i as usize));
        0.5 * ((b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]))
    }

    /// Every pattern tiles the unit square exactly: positive areas summing to 1, and every
    /// interior edge used once in each direction while boundary edges are used once.
    #[test]
    fn patterns_tile_the_square() {
        let rates = [1u32, 2, 3, 4, 7, 16];
        for &a in &rates {
            for &b in &rates {
                for &c in &[1u32, 3, 16] {
                    for &d in &[1u32, 2, 5] {
                        let p = pattern([a, b, c, d]);
                        let mut total = 0.0;
                        let mut edges = std::collections::HashMap::new();
                        for &t in &p.triangles {
                            let ar = area(&p, t);
                            assert!(ar > 0.0, "{:?}: triangle {t:?} area {ar}", p.rates);
                            total += ar;
                            for k in 0..3 {
                                *edges.entry((t[k], t[(k + 1) % 3])).or_insert(0) += 1;
                            }
                        }
                        assert!((total - 1.0).abs() < 1e-12, "{:?}: area {total}", p.rates);
                        let n = p.ring_len() as u32;
                        for (&(x, y), &count) in &edges {
                            assert_eq!(count, 1, "{:?}: edge {x}-{y} used twice", p.rates);
                            let boundary = x < n && y < n && (y == (x + 1) % n);
                            if !boundary {
                                assert_eq!(
                                    edges.get(&(y, x)),
                                    Some(&1),
                                    "{:?}: edge {x}-{y} has no twin",
                                    p.rates
                                );
                            }
                        }
                        // Every boundary segment is an edge: no T-junctions on the sides.
                        for x in 0..n {
                            assert!(edges.contains_key(&(x, (x + 1) % n)), "{:?}", p.rates);
                        }
                    }
                }
            }
        }
    }

    #[test]
    fn uniform_pattern_counts() {
        let p = pattern([4, 4, 4, 4]);
        assert_eq!(p.triangles.len(), 32);
        assert_eq!(p.interior.len(), 9);
        assert_eq!(pattern([1, 1, 1, 1]).triangles.len(), 2);
    }
}
