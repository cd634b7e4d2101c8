//! The regular Loop patch (paper 002 §2): over a triangle whose three vertices are regular, the
//! Loop limit surface is the quartic three-direction box spline of the 12 vertices of their
//! one-rings, which this module evaluates in quartic triangular Bézier form.
//!
//! The 12 control points sit on the triangle lattice at [`LATTICE`], the triangle being
//! `(0,0), (1,0), (0,1)` in OpenSubdiv's triangle parameter `(u, v)`. The 15 × 12 matrix from
//! them to the Bézier net is not typed in: [`bezier_matrix`] derives it once from the library's
//! own Loop refinement of a regular lattice (two levels put a vertex at each of the 15 Bézier
//! domain points, whose limit positions Loop's limit mask gives exactly) by solving the
//! Bernstein interpolation system. Its entries come out as multiples of 1/24, the box spline's
//! known denominator (tested).
//!
//! [`gather`] recognises a regular triangle on a level and reads its 12 points: every vertex
//! of the triangle is either smooth (valence 6, interior, nothing sharp) or a regular crease
//! vertex (two infinitely sharp edges, three faces on the triangle's side, as on a regular
//! boundary). Lattice points beyond an infinitely sharp edge are phantoms `a + b − c`, the
//! reflection of the triangle `(a, b, c)` across its sharp edge `a b`: with them the smooth
//! rules reproduce the crease rules (edge midpoint; `3/4 v + 1/8 (a + b)` at the vertex), so
//! the box spline of the extended net is the creased limit surface (tested against refinement).

use crate::mesh::{MeshBuilder, Options, Scheme};
use crate::refine::crease;
use crate::refine::loop_rules::stationary_limit_mask;
use crate::refine::{Level, Refiner};
use std::sync::OnceLock;

/// Lattice coordinates of the 12 control points: the triangle's vertices, then the rest of
/// their one-rings.
pub const LATTICE: [(i32, i32); 12] = [
    (0, 0),
    (1, 0),
    (0, 1),
    (-1, 0),
    (0, -1),
    (1, -1),
    (-1, 1),
    (2, -1),
    (2, 0),
    (1, 1),
    (0, 2),
    (-1, 2),
];

/// The Bézier net's multi-indices `(i, j, k)`, `i + j + k = 4`, for `w^i u^j v^k` with
/// `w = 1 − u − v`; the domain point of `(i, j, k)` is `(j/4, k/4)`.
pub fn bezier_indices() -> [(usize, usize, usize); 15] {
    let mut out = [(0, 0, 0); 15];
    let mut n = 0;
    for k in 0..=4 {
        for j in 0..=4 - k {
            out[n] = (4 - j - k, j, k);
            n += 1;
        }
    }
    out
}

fn lattice_index(p: (i32, i32)) -> Option<usize> {
    LATTICE.iter().position(|&q| q == p)
}

/// `n!/(n−m)! x^(n−m)`: the `m`-th derivative of `x^n`.
fn dpow(x: f64, n: usize, m: usize) -> f64 {
    if m > n {
        return 0.0;
    }
    let mut c = 1.0;
    for t in 0..m {
        c *= (n - t) as f64;
    }
    c * x.powi((n - m) as i32)
}

/// The 15 Bernstein polynomials and their derivatives at `(u, v)`: `[value, d/du, d/dv,
/// d²/du², d²/dudv, d²/dv²]`, each in [`bezier_indices`] order.
pub fn bernstein(u: f64, v: f64) -> [[f64; 15]; 6] {
    let w = 1.0 - u - v;
    let fact = [1.0, 1.0, 2.0, 6.0, 24.0];
    let mut out = [[0.0; 15]; 6];
    for (n, &(i, j, k)) in bezier_indices().iter().enumerate() {
        let c = 24.0 / (fact[i] * fact[j] * fact[k]);
        // Derivatives in the independent (w, u, v): ∂^a_w ∂^b_u ∂^c_v.
        let d = |a: usize, b: usize, cc: usize| c * dpow(w, i, a) * dpow(u, j, b) * dpow(v, k, cc);
        // d/du = ∂u − ∂w, d/dv = ∂v − ∂w (w = 1 − u − v).
        out[0][n] = d(0, 0, 0);
        out[1][n] = d(0, 1, 0) - d(1, 0, 0);
        out[2][n] = d(0, 0, 1) - d(1, 0, 0);
        out[3][n] = d(0, 2, 0) - 2.0 * d(1, 1, 0) + d(2, 0, 0);
        out[4][n] = d(0, 1, 1) - d(1, 1, 0) - d(1, 0, 1) + d(2, 0, 0);
        out[5][n] = d(0, 0, 2) - 2.0 * d(1, 0, 1) + d(2, 0, 0);
    }
    out
}

/// The 15 × 12 matrix from the control points ([`LATTICE`] order) to the Bézier net
/// ([`bezier_indices`] order), derived once (see the module documentation).
pub fn bezier_matrix() -> &'static [[f64; 12]; 15] {
    static M: OnceLock<[[f64; 12]; 15]> = OnceLock::new();
    // Derived without forking: a static initialiser that waits on rayon workers that are
    // themselves waiting for this cell deadlocks (see `threads::sequential`).
    M.get_or_init(|| crate::threads::sequential(|| derive_bezier_matrix().0))
}

/// A regular lattice of `(2r+1)²` points `(i, j)`, `|i|, |j| ≤ r`, each unit square cut along
/// its `(1,0)–(0,1)` diagonal, as a Loop control mesh.
pub(crate) fn lattice_mesh(r: i32) -> (crate::mesh::ControlMesh, impl Fn(i32, i32) -> u32) {
    let side = 2 * r + 1;
    let id = move |i: i32, j: i32| ((j + r) * side + (i + r)) as u32;
    let mut positions = Vec::new();
    for j in -r..=r {
        for i in -r..=r {
            positions.push([i as f64, j as f64, 0.0]);
        }
    }
    let mut idx = Vec::new();
    for j in -r..r {
        for i in -r..r {
            idx.extend_from_slice(&[id(i, j), id(i + 1, j), id(i, j + 1)]);
            idx.extend_from_slice(&[id(i + 1, j), id(i + 1, j + 1), id(i, j + 1)]);
        }
    }
    let sizes = vec![3; idx.len() / 3];
    let mesh = MeshBuilder::new()
        .positions(positions)
        .faces(&sizes, &idx)
        .options(Options {
            scheme: Scheme::Loop,
            ..Options::default()
        })
        .build()
        .expect("the lattice is a valid triangle mesh");
    (mesh, id)
}

/// Derives the Bézier matrix; also returns the largest weight that the limit at the 15 domain
/// points puts on lattice points outside [`LATTICE`] (zero: the box spline's support).
pub(crate) fn derive_bezier_matrix() -> ([[f64; 12]; 15], f64) {
    let r = 4;
    let (mesh, id) = lattice_mesh(r);
    let refiner = Refiner::new(&mesh, 2).expect("the lattice refines");
    // Data per vertex: 12 indicator columns and one column for everything else.
    let nv = mesh.num_vertices();
    let mut data = vec![0.0; nv * 13];
    let mut mark = vec![12usize; nv];
    for (c, &(i, j)) in LATTICE.iter().enumerate() {
        mark[id(i, j) as usize] = c;
    }
    for v in 0..nv {
        data[v * 13 + mark[v]] = 1.0;
    }
    let pos2 = refiner.refine_positions(&mesh.positions, 2);
    let data2 = refiner.interpolate(&data, 13, 2);
    let level: &Level = &refiner.levels[2];
    let mut limit = [[0.0; 13]; 15];
    for (n, &(_, j, k)) in bezier_indices().iter().enumerate() {
        let (x, y) = (j as f64 / 4.0, k as f64 / 4.0);
        let v = pos2
            .iter()
            .position(|p| (p[0] - x).abs() < 1e-12 && (p[1] - y).abs() < 1e-12)
            .expect("level 2 has a vertex at each domain point");
        let mask = stationary_limit_mask(level, v).expect("a smooth vertex");
        for (u, w) in mask {
            for c in 0..13 {
                limit[n][c] += w * data2[u as usize * 13 + c];
            }
        }
    }
    let outside = limit.iter().map(|r| r[12].abs()).fold(0.0, f64::max);
    // Bernstein interpolation: B(domain point p)_q · X = limit, solved for X (15 × 12).
    let mut a = [[0.0; 15]; 15];
    for (n, &(_, j, k)) in bezier_indices().iter().enumerate() {
        a[n] = bernstein(j as f64 / 4.0, k as f64 / 4.0)[0];
    }
    let mut rhs = [[0.0; 12]; 15];
    for n in 0..15 {
        rhs[n].copy_from_slice(&limit[n][..12]);
    }
    (solve(a, rhs), outside)
}

/// Gaussian elimination with partial pivoting: `a · x = b`.
fn solve(mut a: [[f64; 15]; 15], mut b: [[f64; 12]; 15]) -> [[f64; 12]; 15] {
    for col in 0..15 {
        let piv = (col..15)
            .max_by(|&p, &q| a[p][col].abs().total_cmp(&a[q][col].abs()))
            .unwrap();
        a.swap(col, piv);
        b.swap(col, piv);
        for row in 0..15 {
            if row != col {
                let f = a[row][col] / a[col][col];
                if f != 0.0 {
                    for c in col..15 {
                        a[row][c] -= f * a[col][c];
                    }
                    for c in 0..12 {
                        b[row][c] -= f * b[col][c];
                    }
                }
            }
        }
    }
    for row in 0..15 {
        let d = a[row][row];
        for c in 0..12 {
            b[row][c] /= d;
        }
    }
    b
}

/// Position and derivatives of the box-spline patch of `cps` (12 points, [`LATTICE`] order)
/// at `(u, v)`: `[p, du, dv, duu, duv, dvv]`.
pub fn eval(cps: &[[f64; 3]; 12], u: f64, v: f64) -> [[f64; 3]; 6] {
    let m = bezier_matrix();
    let mut net = [[0.0; 3]; 15];
    for (n, row) in m.iter().enumerate() {
        for (c, &w) in row.iter().enumerate() {
            if w != 0.0 {
                for x in 0..3 {
                    net[n][x] += w * cps[c][x];
                }
            }
        }
    }
    let b = bernstein(u, v);
    let mut out = [[0.0; 3]; 6];
    for d in 0..6 {
        for n in 0..15 {
            for x in 0..3 {
                out[d][x] += b[d][n] * net[n][x];
            }
        }
    }
    out
}

/// True when vertex `v` of `level` allows a regular patch on the side of face `f`: smooth
/// (valence 6, interior, manifold, nothing sharp), or a regular crease vertex (two infinitely
/// sharp edges and nothing else sharp, three faces between them on `f`'s side).
pub fn regular_vertex(level: &Level, v: u32, f: usize) -> bool {
    let topo = &level.topo;
    let v = v as usize;
    if level.vertex_sharpness[v] != 0.0 || topo.vert_tags[v].nonmanifold {
        return false;
    }
    let edges = topo.vertex_edges(v);
    let mut sharp = 0;
    for &e in edges {
        let s = level.edge_sharpness[e as usize];
        if crease::is_infinite(s) {
            sharp += 1;
        } else if s != 0.0 {
            return false;
        }
    }
    match sharp {
        0 => edges.len() == 6 && topo.vertex_faces(v).len() == 6,
        2 => faces_on_side(level, v as u32, f) == Some(3),
        _ => false,
    }
}

/// The number of faces around `v` between its two sharp edges on the side of face `f`,
/// walking across smooth edges from `f` both ways.
fn faces_on_side(level: &Level, v: u32, f: usize) -> Option<usize> {
    let topo = &level.topo;
    let mut count = 1;
    for dir in [0usize, 2] {
        let mut g = f;
        let mut came = usize::MAX;
        loop {
            let fv = topo.face_vertices(g);
            let fe = topo.face_edge_list(g);
            let k = fv.iter().position(|&x| x == v)?;
            // Edge leaving v (k) or arriving at v (k + 2).
            let e = fe[(k + dir) % 3];
            if crease::is_sharp(level.edge_sharpness[e as usize]) {
                break;
            }
            let next = *topo.edge_face_list(e).iter().find(|&&h| h as usize != g)?;
            if next as usize == f || next as usize == came || count > 6 {
                return None;
            }
            came = g;
            g = next as usize;
            count += 1;
        }
    }
    Some(count)
}

/// The 12 control points (vertex indices of `level`, or phantoms as `a + b − c`) of face `f`
/// when it is a regular Loop patch; `None` otherwise (including holes' neighbourhoods that
/// do not matter: holes only remove faces from the surface, their points still count).
pub fn gather(level: &Level, f: usize) -> Option<[Point; 12]> {
    let topo = &level.topo;
    let fv = topo.face_vertices(f);
    if fv.len() != 3 || fv[0] == fv[1] || fv[1] == fv[2] || fv[0] == fv[2] {
        return None;
    }
    if !fv.iter().all(|&v| regular_vertex(level, v, f)) {
        return None;
    }
    let mut at: [Option<u32>; 12] = [None; 12];
    at[0] = Some(fv[0]);
    at[1] = Some(fv[1]);
    at[2] = Some(fv[2]);
    // Faces reached, with the lattice point of each corner.
    let mut queue = vec![(f, [LATTICE[0], LATTICE[1], LATTICE[2]])];
    let mut seen = vec![f];
    let mut phantoms: Vec<(usize, [u32; 3])> = Vec::new();
    while let Some((g, lat)) = queue.pop() {
        let gv = topo.face_vertices(g);
        let ge = topo.face_edge_list(g);
        for k in 0..3 {
            let (a, b, c) = (k, (k + 1) % 3, (k + 2) % 3);
            let across = (
                lat[a].0 + lat[b].0 - lat[c].0,
                lat[a].1 + lat[b].1 - lat[c].1,
            );
            let Some(slot) = lattice_index(across) else {
                continue;
            };
            let e = ge[k];
            if crease::is_sharp(level.edge_sharpness[e as usize]) {
                phantoms.push((slot, [gv[a], gv[b], gv[c]]));
                continue;
            }
            let &h = topo.edge_face_list(e).iter().find(|&&h| h as usize != g)?;
            let h = h as usize;
            let hv = topo.face_vertices(h);
            if hv.len() != 3 {
                return None;
            }
            // h runs b → a → w.
            let i = hv.iter().position(|&x| x == gv[b])?;
            if hv[(i + 1) % 3] != gv[a] {
                return None;
            }
            let w = hv[(i + 2) % 3];
            match at[slot] {
                Some(x) if x != w => return None,
                Some(_) => {}
                None => at[slot] = Some(w),
            }
            if !seen.contains(&h) {
                seen.push(h);
                // Corners in h's own vertex order.
                let mut hl = [(0, 0); 3];
                hl[i] = lat[b];
                hl[(i + 1) % 3] = lat[a];
                hl[(i + 2) % 3] = across;
                // Only faces whose corners are all control points carry on.
                if hl.iter().all(|&p| lattice_index(p).is_some()) {
                    queue.push((h, hl));
                }
            }
        }
    }
    let mut out = [Point::Vertex(0); 12];
    for slot in 0..12 {
        out[slot] = match at[slot] {
            Some(v) => Point::Vertex(v),
            None => {
                let mut cands = phantoms.iter().filter(|p| p.0 == slot);
                let first = cands.next()?;
                if cands.any(|p| p.1 != first.1) {
                    return None;
                }
                Point::Phantom(first.1)
            }
        };
    }
    Some(out)
}

/// A control point of a regular patch: a vertex, or the phantom `a + b − c`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Point {
    /// A vertex of the level.
    Vertex(u32),
    /// Reflection of `c` across the sharp edge `a b`: `a + b − c`.
    Phantom([u32; 3]),
}

impl Point {
    /// The point's position from the level's positions (`pos(v)`).
    pub fn position(&self, pos: impl Fn(u32) -> [f64; 3]) -> [f64; 3] {
        match *self {
            Point::Vertex(v) => pos(v),
            Point::Phantom([a, b, c]) => {
                let (a, b, c) = (pos(a), pos(b), pos(c));
                [0, 1, 2].map(|x| a[x] + b[x] - c[x])
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bezier_matrix_is_the_box_spline() {
        let (m, outside) = derive_bezier_matrix();
        // The limit over the triangle reads only its 12 points.
        assert!(outside < 1e-14, "{outside}");
        for (n, row) in m.iter().enumerate() {
            // Affine: each Bézier point is a combination summing to 1.
            let sum: f64 = row.iter().sum();
            assert!((sum - 1.0).abs() < 1e-13, "row {n}: {sum}");
            // The quartic box spline's Bézier ordinates are multiples of 1/24.
            for &w in row {
                let k = w * 24.0;
                assert!((k - k.round()).abs() < 1e-10, "row {n}: {w}");
            }
        }
        // The corner Bézier points are the limit positions: 1/2 of the vertex and 1/12 of each
        // of its six neighbours.
        let corner = m[0];
        assert!((corner[0] - 0.5).abs() < 1e-13);
        for c in [1, 2, 3, 4, 5, 6] {
            assert!((corner[c] - 1.0 / 12.0).abs() < 1e-13, "{corner:?}");
        }
    }

    #[test]
    fn bernstein_derivatives_match_differences() {
        let (u, v, h) = (0.3, 0.2, 1e-6);
        let b = bernstein(u, v);
        let bu = bernstein(u + h, v);
        let bv = bernstein(u, v + h);
        let sum: f64 = b[0].iter().sum();
        assert!((sum - 1.0).abs() < 1e-14);
        for n in 0..15 {
            assert!(((bu[0][n] - b[0][n]) / h - b[1][n]).abs() < 1e-5);
            assert!(((bv[0][n] - b[0][n]) / h - b[2][n]).abs() < 1e-5);
            assert!(((bu[1][n] - b[1][n]) / h - b[3][n]).abs() < 1e-4);
            assert!(((bv[1][n] - b[1][n]) / h - b[4][n]).abs() < 1e-4);
            assert!(((bv[2][n] - b[2][n]) / h - b[5][n]).abs() < 1e-4);
        }
    }

    #[test]
    fn lattice_patch_reproduces_the_plane() {
        // Linear precision: control points on a plane give that plane, with constant
        // derivatives.
        let cps: [[f64; 3]; 12] = LATTICE.map(|(i, j)| [i as f64, j as f64, 2.0 * i as f64]);
        let r = eval(&cps, 0.25, 0.6);
        assert!((r[0][0] - 0.25).abs() < 1e-14 && (r[0][1] - 0.6).abs() < 1e-14);
        assert!((r[1][0] - 1.0).abs() < 1e-13 && (r[1][2] - 2.0).abs() < 1e-13);
        assert!((r[2][1] - 1.0).abs() < 1e-13);
        assert!(r[3..].iter().flatten().all(|x| x.abs() < 1e-12));
    }
}
