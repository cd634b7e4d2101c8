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
    /// Counter-clockwise triangles (in `(u, v)`, hence as the control face): the grid's
    /// quads first (see [`pattern`]), then the zippers.
    pub triangles: Vec<[u32; 3]>,
    /// Where the grid quads lie (`None` if the pattern has none).
    pub grid: Option<GridPart>,
    /// Per triangle: its corners' `(u, v)` rounded to `f32` (what a diced triangle records).
    pub tri_uv: Vec<[[f32; 2]; 3]>,
    /// Per triangle: its centroid `(u, v)` (where a triangle's level is looked up), in `f64`.
    pub tri_centre: Vec<[f64; 2]>,
    /// The points of the grid's frame, as point indices (ring or interior): its first row,
    /// its last row (each `quads[0] + 1` points, left to right), its first column and its last
    /// column (each `quads[1] + 1` points, bottom to top); empty without a grid. The points
    /// inside the frame are interior points, `(i, j)` being interior point
    /// `(j − 1)(nu − 1) + (i − 1)`.
    pub grid_frame: Vec<u32>,
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

/// The regular part of a [`Pattern`]: a block of grid quads.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct GridPart {
    /// Grid size of the whole domain, `(nu, nv)`: point `(i, j)` is at `(i/nu, j/nv)`.
    pub n: [u32; 2],
    /// First column and row of the block's points.
    pub origin: [u32; 2],
    /// Quads across and up.
    pub quads: [u32; 2],
}

/// Builds the pattern for side rates `rates` (each at least 1).
///
/// A side whose rate equals the grid's count in its direction (`nu` for sides 0 and 2, `nv`
/// for 1 and 3) is *matched*: its points are the grid's outer row or column. The grid's quads
/// reach every matched side; an unmatched side is zipped to the grid's first row or column
/// inside it. With uniform rates every side is matched and the domain is one grid of
/// `nu × nv` quads. The grid quads come first in [`Pattern::triangles`], row by row from
/// `v = 0`, each quad `(a, b, c, d)` (counter-clockwise from its lower-left corner) as the
/// triangles `[a, b, c]` and `[a, c, d]`; [`Pattern::grid`] says where they lie.
pub fn pattern(rates: [u32; 4]) -> Pattern {
    assert!(rates.iter().all(|&r| r >= 1), "side rates must be positive");
    let nu = rates[0].max(rates[2]);
    let nv = rates[1].max(rates[3]);
    let mut p = Pattern {
        rates,
        interior: Vec::new(),
        triangles: Vec::new(),
        grid: None,
        tri_uv: Vec::new(),
        tri_centre: Vec::new(),
        grid_frame: Vec::new(),
    };
    let matched = [
        rates[0] == nu,
        rates[1] == nv,
        rates[2] == nu,
        rates[3] == nv,
    ];
    let side = |p: &Pattern, s: usize| -> Vec<u32> {
        (0..=rates[s]).map(|j| p.ring_index(s, j)).collect()
    };
    let all = matched.iter().all(|&m| m);
    if all || (nu >= 2 && nv >= 2) {
        let n = p.ring_len() as u32;
        let iu = nu.saturating_sub(1);
        for j in 1..nv {
            for i in 1..nu {
                p.interior
                    .push([i as f64 / nu as f64, j as f64 / nv as f64]);
            }
        }
        // Index of grid point (i, j): a ring point on the boundary, else an interior one.
        let point = |p: &Pattern, i: u32, j: u32| -> u32 {
            if j == 0 {
                p.ring_index(0, if i == nu { rates[0] } else { i })
            } else if i == nu {
                p.ring_index(1, if j == nv { rates[1] } else { j })
            } else if j == nv {
                p.ring_index(2, if i == 0 { rates[2] } else { nu - i })
            } else if i == 0 {
                p.ring_index(3, nv - j)
            } else {
                n + (j - 1) * iu + (i - 1)
            }
        };
        let a = matched.map(|m| u32::from(!m));
        let (c0, c1, r0, r1) = (a[3], nu - a[1], a[0], nv - a[2]);
        for j in r0..r1 {
            for i in c0..c1 {
                let (qa, qb, qc, qd) = (
                    point(&p, i, j),
                    point(&p, i + 1, j),
                    point(&p, i + 1, j + 1),
                    point(&p, i, j + 1),
                );
                p.triangles.push([qa, qb, qc]);
                p.triangles.push([qa, qc, qd]);
            }
        }
        if c1 > c0 && r1 > r0 {
            p.grid = Some(GridPart {
                n: [nu, nv],
                origin: [c0, r0],
                quads: [c1 - c0, r1 - r0],
            });
        }
        // The grid's outer rows and columns, running the same way as the sides.
        let inner: [Vec<u32>; 4] = [
            (c0..=c1).map(|i| point(&p, i, r0)).collect(),
            (r0..=r1).map(|j| point(&p, c1, j)).collect(),
            (c0..=c1).rev().map(|i| point(&p, i, r1)).collect(),
            (r0..=r1).rev().map(|j| point(&p, c0, j)).collect(),
        ];
        if p.grid.is_some() {
            // First row, last row (left to right), first column, last column (bottom to top).
            p.grid_frame = inner[0].clone();
            p.grid_frame.extend(inner[2].iter().rev());
            p.grid_frame.extend(inner[3].iter().rev());
            p.grid_frame.extend(&inner[1]);
        }
        for (s, inner_side) in inner.into_iter().enumerate() {
            if !matched[s] {
                let outer = side(&p, s);
                let tris = zip(&p, s, &outer, &inner_side);
                p.triangles.extend(tris);
            }
        }
    } else if nu >= 2 {
        // One row: zip side 0 with side 2 reversed.
        let bottom = side(&p, 0);
        let mut top = side(&p, 2);
        top.reverse();
        let tris = zip(&p, 0, &bottom, &top);
        p.triangles.extend(tris);
    } else {
        let right = side(&p, 1);
        let mut left = side(&p, 3);
        left.reverse();
        let tris = zip(&p, 1, &right, &left);
        p.triangles.extend(tris);
    }
    for t in &p.triangles {
        let uv = t.map(|i| p.uv(i as usize));
        p.tri_centre.push([
            (uv[0][0] + uv[1][0] + uv[2][0]) / 3.0,
            (uv[0][1] + uv[1][1] + uv[2][1]) / 3.0,
        ]);
        p.tri_uv.push(uv.map(|q| [q[0] as f32, q[1] as f32]));
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

    /// The grid quads come first, row by row, at the grid points they claim to be at; equal
    /// rates give one grid and no zipper, and matched sides reach the grid.
    #[test]
    fn grid_part_is_where_it_says() {
        for rates in [
            [4, 4, 4, 4],
            [3, 5, 3, 5],
            [4, 2, 4, 4],
            [2, 4, 3, 1],
            [1, 6, 1, 6],
            [1, 1, 1, 1],
        ] {
            let p = pattern(rates);
            let g = p.grid.expect("grid");
            let [nu, nv] = g.n;
            for qj in 0..g.quads[1] {
                for qi in 0..g.quads[0] {
                    let q = (qj * g.quads[0] + qi) as usize;
                    let (i, j) = ((g.origin[0] + qi) as f64, (g.origin[1] + qj) as f64);
                    let at = |x: u32, du: f64, dv: f64| {
                        // Ring points on sides 2 and 3 are at `1 − j/n`: within an ulp.
                        let uv = p.uv(x as usize);
                        let want = [(i + du) / nu as f64, (j + dv) / nv as f64];
                        assert!(
                            (uv[0] - want[0]).abs() <= 1e-15 && (uv[1] - want[1]).abs() <= 1e-15,
                            "{rates:?}: {uv:?} vs {want:?}"
                        );
                    };
                    let [a, b, c] = p.triangles[2 * q];
                    let [a2, c2, d] = p.triangles[2 * q + 1];
                    assert_eq!((a, c), (a2, c2));
                    at(a, 0.0, 0.0);
                    at(b, 1.0, 0.0);
                    at(c, 1.0, 1.0);
                    at(d, 0.0, 1.0);
                }
            }
            let grid_tris = 2 * (g.quads[0] * g.quads[1]) as usize;
            if rates[0] == rates[2] && rates[1] == rates[3] {
                assert_eq!(p.triangles.len(), grid_tris, "{rates:?}");
            }
        }
        assert_eq!(pattern([4, 2, 4, 4]).grid.unwrap().origin, [0, 0]);
        assert_eq!(pattern([4, 2, 4, 4]).grid.unwrap().quads, [3, 4]);
    }

    #[test]
    fn uniform_pattern_counts() {
        let p = pattern([4, 4, 4, 4]);
        assert_eq!(p.triangles.len(), 32);
        assert_eq!(p.interior.len(), 9);
        assert_eq!(pattern([1, 1, 1, 1]).triangles.len(), 2);
    }
}
