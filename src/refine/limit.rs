//! Exact limit positions and tangents at the vertices of any refinement level.
//!
//! The limit of a vertex depends only on its one-ring (the vertex, its edge neighbours and the
//! vertices of its faces). While anything in that ring is still semi-sharp, or a face is not a
//! quad, the ring is subdivided locally with exactly the rules of [`super::rules`] (Chaikin's
//! rule included: each ring edge carries the sharpness of the edges at its far end). Once the
//! ring is stationary (every sharpness 0 or infinite, all quads) the ring's subdivision matrix
//! `S` no longer changes and the limit is an eigen-analysis of `S`:
//! - position: the dominant left eigenvector of `S` (eigenvalue 1), found by iterating
//!   `x ← x S` to machine precision. This is exact for every rule, darts included (OpenSubdiv's
//!   `Limit` uses the smooth mask at darts and treats semi-sharp vertices as infinitely sharp).
//! - tangents of a smooth vertex of valence ≥ 3: the closed-form eigenvector masks
//!   (cosine weights), scaled so that valence 4 gives the B-spline parametric derivatives
//!   `dP/du`, `dP/dv` along edge 0 and edge 1; other valences use the same `1/(3n)` scale.
//! - tangents at a crease (two sharp edges): along the crease, the cubic B-spline derivative
//!   `(E_a − E_b)/2`; across, into the side of face 0, the left eigenvector of `S`'s largest
//!   eigenvalue that does not come from the crease curve, normalised so that a regular boundary
//!   gives the parametric derivative.
//! - darts and valence 2: the dominant two-dimensional invariant subspace of `Sᵀ` on weight
//!   vectors summing to zero (subspace iteration); it spans the exact tangent plane, and the
//!   pair is oriented along edges 0 and 1 (magnitudes are a convention there).
//! - corners (vertex stays): the one-sided edge directions `E_0 − V`, `E_1 − V` (exact for the
//!   B-spline corner of a boundary, a convention elsewhere: a sharp vertex has no tangent plane).
//! - non-manifold vertices: position by the rule in force (corner or crease); tangents along
//!   two of their edges.
//!
//! Tangent magnitudes are given in the units of the level's parameter (one edge = 1).

use super::crease::{self, Rule};
use super::rules::{edge_mask, face_mask, vertex_mask, VertexRing};
use super::stencil::{Accumulator, StencilTable};
use super::Level;
use crate::mesh::CreaseMethod;
use rayon::prelude::*;

/// Limit position and two tangents of one vertex.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct LimitFrame {
    /// Limit position.
    pub position: [f64; 3],
    /// First tangent (along the vertex's edge 0).
    pub du: [f64; 3],
    /// Second tangent (along edge 1, or across the crease).
    pub dv: [f64; 3],
}

/// Limit stencils of a level: rows over the level's vertices.
#[derive(Clone, Debug)]
pub struct LimitStencils {
    /// Position masks.
    pub position: StencilTable,
    /// First tangent masks.
    pub du: StencilTable,
    /// Second tangent masks.
    pub dv: StencilTable,
}

impl LimitStencils {
    /// Builds limit masks for every vertex of `level`.
    pub fn new(level: &Level, method: CreaseMethod) -> Self {
        let nv = level.num_vertices();
        let rows: Vec<[Vec<(u32, f64)>; 3]> = (0..nv)
            .into_par_iter()
            .map(|v| vertex_limit_masks(level, v, method))
            .collect();
        let mut tables = [
            StencilTable::new(nv),
            StencilTable::new(nv),
            StencilTable::new(nv),
        ];
        let mut acc = Accumulator::new();
        for r in &rows {
            for (t, terms) in tables.iter_mut().zip(r) {
                for &(i, w) in terms {
                    acc.add(i, w);
                }
                t.push_row(&mut acc);
            }
        }
        let [position, du, dv] = tables;
        LimitStencils { position, du, dv }
    }

    /// Applies the masks to the level's positions.
    pub fn frames(&self, pos: &[[f64; 3]]) -> Vec<LimitFrame> {
        let p = self.position.apply_points(pos);
        let du = self.du.apply_points(pos);
        let dv = self.dv.apply_points(pos);
        (0..p.len())
            .map(|i| LimitFrame {
                position: p[i],
                du: du[i],
                dv: dv[i],
            })
            .collect()
    }
}

/// Exact limit position and tangents of one vertex of `level`, given the level's positions.
pub fn vertex_limit_frame(
    level: &Level,
    v: usize,
    pos: &[[f64; 3]],
    method: CreaseMethod,
) -> LimitFrame {
    let [p, du, dv] = vertex_limit_masks(level, v, method);
    let apply = |terms: &[(u32, f64)]| {
        let mut out = [0.0; 3];
        for &(i, w) in terms {
            for k in 0..3 {
                out[k] += w * pos[i as usize][k];
            }
        }
        out
    };
    LimitFrame {
        position: apply(&p),
        du: apply(&du),
        dv: apply(&dv),
    }
}

/// Exact limit positions of every vertex of `level`, given the level's positions.
pub fn limit_positions(level: &Level, pos: &[[f64; 3]], method: CreaseMethod) -> Vec<[f64; 3]> {
    LimitStencils::new(level, method).position.apply_points(pos)
}

/// A vertex's one-ring as local points with weights over the level's vertices.
#[derive(Clone, Debug)]
struct Ring {
    /// Weights of each local point over `inputs` (dense, length `inputs.len()`).
    points: Vec<Vec<f64>>,
    /// Faces as local point indices; face `i` starts at the centre (local 0).
    faces: Vec<Vec<u32>>,
    /// Far end of edge `i` is local point `1 + i`.
    num_edges: usize,
    boundary: bool,
    edge_sharpness: Vec<f32>,
    /// Sharpness of the other edges at the far end of each ring edge.
    far_sharpness: Vec<Vec<f32>>,
    vertex_sharpness: f32,
    /// The level's smooth-triangle rule (see [`Level::smooth_triangles`]).
    smooth_triangles: bool,
}

impl Ring {
    fn is_stationary(&self) -> bool {
        self.faces.iter().all(|f| f.len() == 4)
            && self
                .edge_sharpness
                .iter()
                .all(|&s| !crease::is_semi_sharp(s))
            && !crease::is_semi_sharp(self.vertex_sharpness)
    }

    /// One local subdivision step; returns the new ring and its rows over the old local points.
    fn subdivide(&self, method: CreaseMethod) -> (Ring, Vec<Vec<(u32, f64)>>) {
        let ne = self.num_edges;
        let nf = self.faces.len();
        let ends: Vec<u32> = (1..=ne as u32).collect();
        let child_es: Vec<f32> = self
            .edge_sharpness
            .iter()
            .map(|&s| crease::child_edge_sharpness(method, s, &self.edge_sharpness))
            .collect();
        let far_child: Vec<f32> = (0..ne)
            .map(|i| {
                let mut inc = vec![self.edge_sharpness[i]];
                inc.extend_from_slice(&self.far_sharpness[i]);
                crease::child_edge_sharpness(method, self.edge_sharpness[i], &inc)
            })
            .collect();
        let faces: Vec<&[u32]> = self.faces.iter().map(|f| f.as_slice()).collect();
        let child_vs = crease::decrement(self.vertex_sharpness);
        let mut rows = Vec::with_capacity(1 + ne + nf);
        let mut acc = Accumulator::new();
        vertex_mask(
            &mut acc,
            &VertexRing {
                center: 0,
                edge_ends: &ends,
                edge_sharpness: &self.edge_sharpness,
                child_edge_sharpness: &child_es,
                faces: &faces,
                sharpness: self.vertex_sharpness,
                child_sharpness: child_vs,
            },
        );
        rows.push(acc.terms().to_vec());
        for i in 0..ne {
            acc.clear();
            // Faces on either side of edge i: face i (leading) and face i-1 (trailing).
            let mut ef: Vec<&[u32]> = Vec::with_capacity(2);
            if i < nf {
                ef.push(faces[i]);
            }
            if self.boundary {
                if i > 0 {
                    ef.push(faces[i - 1]);
                }
            } else {
                ef.push(faces[(i + nf - 1) % nf]);
            }
            let child_sharp = crease::is_sharp(child_es[i]) && crease::is_sharp(far_child[i]);
            edge_mask(
                &mut acc,
                0,
                1 + i as u32,
                &ef,
                self.edge_sharpness[i],
                child_sharp,
                self.smooth_triangles,
            );
            rows.push(acc.terms().to_vec());
        }
        for f in &faces {
            acc.clear();
            face_mask(&mut acc, f, 1.0);
            rows.push(acc.terms().to_vec());
        }
        let m = self.points[0].len();
        let points: Vec<Vec<f64>> = rows
            .iter()
            .map(|row| {
                let mut w = vec![0.0; m];
                for &(j, c) in row {
                    for (x, y) in w.iter_mut().zip(&self.points[j as usize]) {
                        *x += c * y;
                    }
                }
                w
            })
            .collect();
        let new_faces = (0..nf)
            .map(|i| {
                let next = if self.boundary { i + 1 } else { (i + 1) % ne };
                vec![0, 1 + i as u32, (1 + ne + i) as u32, 1 + next as u32]
            })
            .collect();
        let ring = Ring {
            points,
            faces: new_faces,
            num_edges: ne,
            boundary: self.boundary,
            edge_sharpness: child_es,
            far_sharpness: far_child.iter().map(|&s| vec![s]).collect(),
            vertex_sharpness: child_vs,
            smooth_triangles: self.smooth_triangles,
        };
        (ring, rows)
    }
}

fn to_terms(inputs: &[u32], w: &[f64]) -> Vec<(u32, f64)> {
    inputs
        .iter()
        .zip(w)
        .filter(|(_, &x)| x != 0.0)
        .map(|(&i, &x)| (i, x))
        .collect()
}

fn combine(ring: &Ring, local: &[f64]) -> Vec<f64> {
    let m = ring.points[0].len();
    let mut out = vec![0.0; m];
    for (c, p) in local.iter().zip(&ring.points) {
        if *c != 0.0 {
            for (o, x) in out.iter_mut().zip(p) {
                *o += c * x;
            }
        }
    }
    out
}

/// Position, du and dv masks of vertex `v` as (input vertex, weight) lists.
pub(crate) fn vertex_limit_masks(
    level: &Level,
    v: usize,
    method: CreaseMethod,
) -> [Vec<(u32, f64)>; 3] {
    let topo = &level.topo;
    let edges = topo.vertex_edges(v);
    let tag = topo.vert_tags[v];
    let vu = v as u32;
    if edges.is_empty() {
        return [vec![(vu, 1.0)], vec![], vec![]];
    }
    if tag.nonmanifold {
        return nonmanifold_masks(level, v);
    }
    // Local points: centre, edge ends, then the remaining vertices of each face.
    let mut inputs = vec![vu];
    inputs.extend(edges.iter().map(|&e| topo.other_vertex(e, vu)));
    let local_of = |inputs: &mut Vec<u32>, x: u32| -> u32 {
        if let Some(p) = inputs.iter().position(|&y| y == x) {
            p as u32
        } else {
            inputs.push(x);
            (inputs.len() - 1) as u32
        }
    };
    let mut faces = Vec::new();
    for (&f, &c) in topo.vertex_faces(v).iter().zip(topo.vertex_face_corners(v)) {
        let fv = topo.face_vertices(f as usize);
        let n = fv.len();
        let lf: Vec<u32> = (0..n)
            .map(|k| local_of(&mut inputs, fv[(c as usize + k) % n]))
            .collect();
        faces.push(lf);
    }
    let m = inputs.len();
    let points = (0..m)
        .map(|i| {
            let mut w = vec![0.0; m];
            w[i] = 1.0;
            w
        })
        .collect();
    let mut inc = Vec::new();
    let far_sharpness = edges
        .iter()
        .map(|&e| {
            let far = topo.other_vertex(e, vu) as usize;
            let mut out = Vec::new();
            for &e2 in topo.vertex_edges(far) {
                if e2 != e {
                    out.push(level.edge_sharpness[e2 as usize]);
                }
            }
            out
        })
        .collect();
    level.incident_sharpness(v, &mut inc);
    let mut ring = Ring {
        points,
        faces,
        num_edges: edges.len(),
        boundary: tag.boundary,
        edge_sharpness: inc,
        far_sharpness,
        vertex_sharpness: level.vertex_sharpness[v],
        smooth_triangles: level.smooth_triangles,
    };
    // At least one step makes the ring canonical: face i = (centre, edge end i, face point i,
    // edge end i+1), all quads.
    let mut scale = 1.0;
    let mut steps = 0;
    while steps == 0 || (!ring.is_stationary() && steps < 64) {
        ring = ring.subdivide(method).0;
        scale *= 2.0;
        steps += 1;
    }
    let ne = ring.num_edges;
    let sharp: Vec<usize> = (0..ne)
        .filter(|&i| crease::is_sharp(ring.edge_sharpness[i]))
        .collect();
    let rule = crease::vertex_rule(ring.vertex_sharpness, sharp.len());
    let (_, s_rows) = ring.subdivide(method);
    let size = s_rows.len();
    let pos_local = dominant_left(&s_rows, size);
    let (du_local, dv_local) = match rule {
        Rule::Smooth if sharp.is_empty() && ne >= 3 => smooth_tangents(ne),
        Rule::Smooth => subspace_tangents(&dense(&s_rows, size), ne),
        Rule::Crease => crease_tangents(
            &dense(&s_rows, size),
            ne,
            ring.faces.len(),
            sharp[0],
            sharp[1],
        ),
        Rule::Corner => {
            let mut du = vec![0.0; size];
            let mut dv = vec![0.0; size];
            du[0] = -1.0;
            du[1] = 1.0;
            dv[0] = -1.0;
            dv[2.min(ne)] += 1.0;
            (du, dv)
        }
    };
    let pos = combine(&ring, &pos_local);
    let du = combine(&ring, &du_local);
    let dv = combine(&ring, &dv_local);
    [
        to_terms(&inputs, &pos),
        to_terms(&inputs, &du.iter().map(|x| x * scale).collect::<Vec<_>>()),
        to_terms(&inputs, &dv.iter().map(|x| x * scale).collect::<Vec<_>>()),
    ]
}

fn dense(rows: &[Vec<(u32, f64)>], size: usize) -> Vec<Vec<f64>> {
    rows.iter()
        .map(|r| {
            let mut d = vec![0.0; size];
            for &(j, w) in r {
                d[j as usize] += w;
            }
            d
        })
        .collect()
}

/// x S for a row vector x.
fn left_mul(x: &[f64], s: &[Vec<f64>]) -> Vec<f64> {
    let mut out = vec![0.0; x.len()];
    for (xi, row) in x.iter().zip(s) {
        if *xi != 0.0 {
            for (o, r) in out.iter_mut().zip(row) {
                *o += xi * r;
            }
        }
    }
    out
}

/// Dominant left eigenvector (eigenvalue 1) of a subdivision matrix given by sparse rows,
/// normalised to sum 1.
fn dominant_left(rows: &[Vec<(u32, f64)>], size: usize) -> Vec<f64> {
    let mut x = vec![0.0; size];
    x[0] = 1.0;
    let mut y = vec![0.0; size];
    for _ in 0..4000 {
        y.fill(0.0);
        for (xi, row) in x.iter().zip(rows) {
            if *xi != 0.0 {
                for &(j, w) in row {
                    y[j as usize] += xi * w;
                }
            }
        }
        let diff = y
            .iter()
            .zip(&x)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        std::mem::swap(&mut x, &mut y);
        if diff < 1e-17 {
            break;
        }
    }
    let sum: f64 = x.iter().sum();
    x.iter().map(|v| v / sum).collect()
}

/// Closed-form tangent masks of a smooth interior vertex of valence n ≥ 3, all quads: edge
/// ends are local 1..=n, face diagonals local n+1..=2n (face i between edges i and i+1).
fn smooth_tangents(n: usize) -> (Vec<f64>, Vec<f64>) {
    let nf = n as f64;
    let pi = std::f64::consts::PI;
    let a = 1.0
        + (2.0 * pi / nf).cos()
        + (pi / nf).cos() * (2.0 * (9.0 + (2.0 * pi / nf).cos())).sqrt();
    let scale = 1.0 / (3.0 * nf);
    let mask = |rot: usize| {
        let mut t = vec![0.0; 1 + 2 * n];
        for i in 0..n {
            let k = (i + n - rot) % n;
            let c0 = (2.0 * pi * k as f64 / nf).cos();
            let c1 = (2.0 * pi * (k + 1) as f64 / nf).cos();
            t[1 + i] = scale * a * c0;
            t[1 + n + i] = scale * (c0 + c1);
        }
        t
    };
    (mask(0), mask(1))
}

/// Tangents at a crease: along the crease and across it into the side of face 0.
fn crease_tangents(
    s: &[Vec<f64>],
    ne: usize,
    nf: usize,
    a: usize,
    b: usize,
) -> (Vec<f64>, Vec<f64>) {
    let size = s.len();
    let (pa, pb) = (1 + a, 1 + b);
    let mut along = vec![0.0; size];
    along[pa] = 0.5;
    along[pb] = -0.5;
    // Points that are not on the crease curve: the block Y of S; its dominant left eigenvector
    // (Perron) gives the across mode, completed on the crease points through (λI − C).
    let crease_pts = [0usize, pa, pb];
    // Restrict to the side of face 0: faces a..b-1 (ring order from edge a).
    let side: Vec<usize> = (0..size)
        .filter(|&j| !crease_pts.contains(&j) && on_side(j, ne, nf, a, b))
        .collect();
    let mut ly = vec![1.0; side.len()];
    let mut lambda = 0.0;
    for _ in 0..4000 {
        let mut y = vec![0.0; side.len()];
        for (ii, &i) in side.iter().enumerate() {
            for (jj, &j) in side.iter().enumerate() {
                y[jj] += ly[ii] * s[i][j];
            }
        }
        let norm: f64 = y.iter().map(|x| x.abs()).sum();
        if norm == 0.0 {
            break;
        }
        let y: Vec<f64> = y.iter().map(|x| x / norm).collect();
        let diff = y
            .iter()
            .zip(&ly)
            .map(|(p, q)| (p - q).abs())
            .fold(0.0, f64::max);
        ly = y;
        lambda = norm;
        if diff < 1e-16 {
            break;
        }
    }
    // g = l_y X restricted to crease points.
    let mut g = [0.0; 3];
    for (ii, &i) in side.iter().enumerate() {
        for (k, &c) in crease_pts.iter().enumerate() {
            g[k] += ly[ii] * s[i][c];
        }
    }
    // Left/right eigenvectors of the crease block C in (centre, a, b).
    let us = [
        [4.0 / 6.0, 1.0 / 6.0, 1.0 / 6.0],
        [0.0, 1.0, -1.0],
        [2.0, -1.0, -1.0],
    ];
    let rs = [[1.0, 1.0, 1.0], [0.0, 1.0, -1.0], [1.0, -2.0, -2.0]];
    let mus = [1.0, 0.5, 0.25];
    let mut lc = [0.0; 3];
    for k in 0..3 {
        let denom = lambda - mus[k];
        if denom.abs() < 1e-9 {
            continue;
        }
        let gr: f64 = (0..3).map(|j| g[j] * rs[k][j]).sum();
        let ur: f64 = (0..3).map(|j| us[k][j] * rs[k][j]).sum();
        for j in 0..3 {
            lc[j] += gr / (denom * ur) * us[k][j];
        }
    }
    let sum_y: f64 = ly.iter().sum();
    let mut across = vec![0.0; size];
    for (ii, &i) in side.iter().enumerate() {
        across[i] = ly[ii] / sum_y;
    }
    for (k, &c) in crease_pts.iter().enumerate() {
        across[c] += lc[k] / sum_y;
    }
    (along, across)
}

/// Whether local point `j` (not on the crease) lies on the side of face 0, i.e. between
/// crease edges `a` and `b` going through faces a..b-1.
fn on_side(j: usize, ne: usize, nf: usize, a: usize, b: usize) -> bool {
    if (1..=ne).contains(&j) {
        let e = j - 1;
        e > a && e < b
    } else {
        let f = j - 1 - ne;
        f < nf && f >= a && f < b
    }
}

/// Tangent plane of an interior vertex by subspace iteration on weight vectors of sum zero.
fn subspace_tangents(s: &[Vec<f64>], ne: usize) -> (Vec<f64>, Vec<f64>) {
    let size = s.len();
    let start = |k: usize| {
        let mut x = vec![0.0; size];
        x[0] = -1.0;
        x[1 + k % ne] = 1.0;
        x
    };
    let mut q = [start(0), start(1)];
    for _ in 0..3000 {
        let mut y = [left_mul(&q[0], s), left_mul(&q[1], s)];
        // Gram-Schmidt.
        let n0 = y[0].iter().map(|x| x * x).sum::<f64>().sqrt();
        if n0 < 1e-300 {
            break; // degenerate ring: keep the previous pair
        }
        y[0].iter_mut().for_each(|x| *x /= n0);
        let d: f64 = y[0].iter().zip(&y[1]).map(|(a, b)| a * b).sum();
        let (a, b) = y.split_at_mut(1);
        b[0].iter_mut().zip(&a[0]).for_each(|(x, p)| *x -= d * p);
        let n1 = y[1].iter().map(|x| x * x).sum::<f64>().sqrt();
        if n1 < 1e-300 {
            break;
        }
        y[1].iter_mut().for_each(|x| *x /= n1);
        q = y;
    }
    // Orient the pair along edges 0 and 1: express start vectors' projections.
    let proj = |x: &[f64]| -> Vec<f64> {
        let c0: f64 = q[0].iter().zip(x).map(|(a, b)| a * b).sum();
        let c1: f64 = q[1].iter().zip(x).map(|(a, b)| a * b).sum();
        q[0].iter()
            .zip(&q[1])
            .map(|(a, b)| c0 * a + c1 * b)
            .collect()
    };
    (proj(&start(0)), proj(&start(1)))
}

fn nonmanifold_masks(level: &Level, v: usize) -> [Vec<(u32, f64)>; 3] {
    let topo = &level.topo;
    let vu = v as u32;
    let edges = topo.vertex_edges(v);
    let sharp: Vec<u32> = edges
        .iter()
        .copied()
        .filter(|&e| crease::is_sharp(level.edge_sharpness[e as usize]))
        .collect();
    let ends = |e: u32| topo.other_vertex(e, vu);
    let pos = if level.vertex_rule(v) == Rule::Crease && sharp.len() == 2 {
        vec![
            (vu, 4.0 / 6.0),
            (ends(sharp[0]), 1.0 / 6.0),
            (ends(sharp[1]), 1.0 / 6.0),
        ]
    } else {
        vec![(vu, 1.0)]
    };
    let e1 = edges.get(1).copied().unwrap_or(edges[0]);
    [
        pos,
        vec![(vu, -1.0), (ends(edges[0]), 1.0)],
        vec![(vu, -1.0), (ends(e1), 1.0)],
    ]
}
