//! Closest points on a triangle mesh: a median-split binary tree of boxes searched
//! nearest-box-first ([`ClosestMesh::closest`]), and the closest point of one triangle
//! ([`closest_on_triangle`]). What seeds the projection of a point onto a parametric surface
//! in [`super::approx_error`].

use crate::vec3::{add, dot, scale, sub};

/// A triangle mesh with a box tree for closest-point queries.
#[derive(Clone, Debug)]
pub struct ClosestMesh {
    points: Vec<[f64; 3]>,
    tris: Vec<[u32; 3]>,
    /// Nodes: box, then either children (`count == 0`, `first` the left child, right at
    /// `first + 1`) or a leaf range of `order`.
    nodes: Vec<Node>,
    order: Vec<u32>,
}

#[derive(Clone, Copy, Debug)]
struct Node {
    lo: [f64; 3],
    hi: [f64; 3],
    first: u32,
    count: u32,
}

const LEAF: usize = 4;

/// A closest point: the triangle, its barycentric weights `(w0, w1, w2)` and the squared
/// distance.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Closest {
    /// Triangle index.
    pub tri: u32,
    /// Barycentric weights of the triangle's three points.
    pub bary: [f64; 3],
    /// Squared distance.
    pub d2: f64,
}

impl ClosestMesh {
    /// The tree over `tris` (indices into `points`).
    pub fn new(points: Vec<[f64; 3]>, tris: Vec<[u32; 3]>) -> Self {
        let mut m = ClosestMesh {
            points,
            tris,
            nodes: Vec::new(),
            order: Vec::new(),
        };
        let centroids: Vec<[f64; 3]> = m
            .tris
            .iter()
            .map(|t| {
                scale(
                    add(
                        add(m.points[t[0] as usize], m.points[t[1] as usize]),
                        m.points[t[2] as usize],
                    ),
                    1.0 / 3.0,
                )
            })
            .collect();
        m.order = (0..m.tris.len() as u32).collect();
        m.nodes.push(Node {
            lo: [0.0; 3],
            hi: [0.0; 3],
            first: 0,
            count: 0,
        });
        let n = m.tris.len();
        m.build(0, 0, n, &centroids);
        m
    }

    fn bounds(&self, range: &[u32]) -> ([f64; 3], [f64; 3]) {
        let mut lo = [f64::INFINITY; 3];
        let mut hi = [f64::NEG_INFINITY; 3];
        for &t in range {
            for &v in &self.tris[t as usize] {
                let p = self.points[v as usize];
                for i in 0..3 {
                    lo[i] = lo[i].min(p[i]);
                    hi[i] = hi[i].max(p[i]);
                }
            }
        }
        (lo, hi)
    }

    fn build(&mut self, node: usize, start: usize, end: usize, centroids: &[[f64; 3]]) {
        let (lo, hi) = self.bounds(&self.order[start..end]);
        self.nodes[node].lo = lo;
        self.nodes[node].hi = hi;
        if end - start <= LEAF {
            self.nodes[node].first = start as u32;
            self.nodes[node].count = (end - start) as u32;
            return;
        }
        let ext = sub(hi, lo);
        let axis = (0..3)
            .max_by(|&a, &b| ext[a].total_cmp(&ext[b]))
            .unwrap_or(0);
        let mid = (start + end) / 2;
        self.order[start..end].select_nth_unstable_by(mid - start, |&a, &b| {
            centroids[a as usize][axis].total_cmp(&centroids[b as usize][axis])
        });
        let left = self.nodes.len();
        let blank = Node {
            lo: [0.0; 3],
            hi: [0.0; 3],
            first: 0,
            count: 0,
        };
        self.nodes.push(blank);
        self.nodes.push(blank);
        self.nodes[node].first = left as u32;
        self.nodes[node].count = 0;
        self.build(left, start, mid, centroids);
        self.build(left + 1, mid, end, centroids);
    }

    /// The diagonal of the points' bounding box.
    pub fn diagonal(&self) -> f64 {
        let mut lo = [f64::INFINITY; 3];
        let mut hi = [f64::NEG_INFINITY; 3];
        for p in &self.points {
            for i in 0..3 {
                lo[i] = lo[i].min(p[i]);
                hi[i] = hi[i].max(p[i]);
            }
        }
        crate::vec3::norm(sub(hi, lo))
    }

    /// Triangle `t`'s point indices.
    pub fn triangle(&self, t: u32) -> [u32; 3] {
        self.tris[t as usize]
    }

    /// The closest point of the mesh to `x` (`None` for an empty mesh).
    pub fn closest(&self, x: [f64; 3]) -> Option<Closest> {
        if self.tris.is_empty() {
            return None;
        }
        let box_d2 = |n: &Node| {
            (0..3)
                .map(|i| {
                    let d = (n.lo[i] - x[i]).max(0.0).max(x[i] - n.hi[i]);
                    d * d
                })
                .sum::<f64>()
        };
        let mut best: Option<Closest> = None;
        let mut stack: Vec<(f64, u32)> = vec![(box_d2(&self.nodes[0]), 0)];
        while let Some((d2, n)) = stack.pop() {
            if best.is_some_and(|b| d2 >= b.d2) {
                continue;
            }
            let node = self.nodes[n as usize];
            if node.count > 0 {
                for &t in &self.order[node.first as usize..(node.first + node.count) as usize] {
                    let [a, b, c] = self.tris[t as usize].map(|v| self.points[v as usize]);
                    let (bary, q) = closest_on_triangle(x, a, b, c);
                    let e = sub(q, x);
                    let d2 = dot(e, e);
                    if best.is_none_or(|b| d2 < b.d2) {
                        best = Some(Closest { tri: t, bary, d2 });
                    }
                }
            } else {
                let (l, r) = (node.first, node.first + 1);
                let (dl, dr) = (
                    box_d2(&self.nodes[l as usize]),
                    box_d2(&self.nodes[r as usize]),
                );
                // Push the farther first: the nearer is searched next.
                if dl < dr {
                    stack.push((dr, r));
                    stack.push((dl, l));
                } else {
                    stack.push((dl, l));
                    stack.push((dr, r));
                }
            }
        }
        best
    }
}

/// The point of triangle `(a, b, c)` closest to `x`: its barycentric weights and position.
/// By the region of the triangle's plane `x` projects into (a vertex, an edge or the inside).
pub fn closest_on_triangle(
    x: [f64; 3],
    a: [f64; 3],
    b: [f64; 3],
    c: [f64; 3],
) -> ([f64; 3], [f64; 3]) {
    let ab = sub(b, a);
    let ac = sub(c, a);
    let ax = sub(x, a);
    let d1 = dot(ab, ax);
    let d2 = dot(ac, ax);
    if d1 <= 0.0 && d2 <= 0.0 {
        return ([1.0, 0.0, 0.0], a);
    }
    let bx = sub(x, b);
    let d3 = dot(ab, bx);
    let d4 = dot(ac, bx);
    if d3 >= 0.0 && d4 <= d3 {
        return ([0.0, 1.0, 0.0], b);
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        let t = d1 / (d1 - d3);
        return ([1.0 - t, t, 0.0], add(a, scale(ab, t)));
    }
    let cx = sub(x, c);
    let d5 = dot(ab, cx);
    let d6 = dot(ac, cx);
    if d6 >= 0.0 && d5 <= d6 {
        return ([0.0, 0.0, 1.0], c);
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        let t = d2 / (d2 - d6);
        return ([1.0 - t, 0.0, t], add(a, scale(ac, t)));
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        let t = (d4 - d3) / ((d4 - d3) + (d5 - d6));
        return ([0.0, 1.0 - t, t], add(b, scale(sub(c, b), t)));
    }
    let den = 1.0 / (va + vb + vc);
    let (v, w) = (vb * den, vc * den);
    ([1.0 - v - w, v, w], add(a, add(scale(ab, v), scale(ac, w))))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::harness::rng::SplitMix64;

    /// The tree's answer equals a brute-force scan (same squared distance) on random
    /// triangles and points.
    #[test]
    fn tree_matches_brute_force() {
        let mut r = SplitMix64::new(5);
        let mut pt = || [r.next_f64(), r.next_f64(), r.next_f64()];
        let points: Vec<[f64; 3]> = (0..600).map(|_| pt()).collect();
        let tris: Vec<[u32; 3]> = (0..200).map(|i| [3 * i, 3 * i + 1, 3 * i + 2]).collect();
        let m = ClosestMesh::new(points.clone(), tris.clone());
        for _ in 0..500 {
            let x = pt().map(|v| 2.0 * v - 0.5);
            let got = m.closest(x).unwrap();
            let brute = tris
                .iter()
                .map(|t| {
                    let (_, q) = closest_on_triangle(
                        x,
                        points[t[0] as usize],
                        points[t[1] as usize],
                        points[t[2] as usize],
                    );
                    dot(sub(q, x), sub(q, x))
                })
                .fold(f64::INFINITY, f64::min);
            assert!((got.d2 - brute).abs() <= 1e-15, "{} vs {brute}", got.d2);
        }
    }

    /// The closest point is on the triangle and no point of a fine sampling is closer.
    #[test]
    fn triangle_closest_point_is_minimal() {
        let mut r = SplitMix64::new(9);
        for _ in 0..200 {
            let mut pt = || [r.next_f64(), r.next_f64(), r.next_f64()];
            let (a, b, c, x) = (pt(), pt(), pt(), pt().map(|v| 3.0 * v - 1.0));
            let (w, q) = closest_on_triangle(x, a, b, c);
            assert!(w.iter().all(|&t| t >= -1e-12) && (w.iter().sum::<f64>() - 1.0).abs() < 1e-12);
            let d = dot(sub(q, x), sub(q, x));
            for i in 0..=40 {
                for j in 0..=40 - i {
                    let (s, t) = (i as f64 / 40.0, j as f64 / 40.0);
                    let p = add(a, add(scale(sub(b, a), s), scale(sub(c, a), t)));
                    assert!(dot(sub(p, x), sub(p, x)) >= d - 1e-12);
                }
            }
        }
    }
}
