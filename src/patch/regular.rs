//! Recognising faces whose limit surface is a bicubic B-spline patch (interior, boundary,
//! corner, infinitely sharp creases as boundaries) or a regular patch with one semi-sharp crease
//! (paper 000), and gathering their 16 control points.
//!
//! Grid layout as in [`super::bspline`]: `4 j + i`; the face's corner `k` sits at grid position
//! `C[k]` with its own axes `U[k]` (towards corner k+1) and `V[k]` (towards corner k−1).
//! Missing points across a boundary or infinitely sharp edge are phantoms, reflections of the
//! row inside: `P(outside) = 2 P(on the edge) − P(inside)`, which reproduces the crease and
//! corner rules exactly.

use crate::refine::crease;
use crate::refine::Level;

/// Grid position of each face corner.
const C: [[i32; 2]; 4] = [[1, 1], [2, 1], [2, 2], [1, 2]];
/// Axis towards the next corner.
const U: [[i32; 2]; 4] = [[1, 0], [0, 1], [-1, 0], [0, -1]];
/// Axis towards the previous corner.
const V: [[i32; 2]; 4] = [[0, 1], [-1, 0], [0, -1], [1, 0]];

/// A control point as a combination of level vertices: a vertex, or a reflection across a
/// boundary (`2a − b`), or a reflection of reflections at a corner (four terms at most), held
/// in place (a regular face's sixteen control points allocate nothing).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Combo {
    len: u8,
    terms: [(u32, f64); 4],
}

impl Combo {
    /// Vertex `v` alone.
    pub fn one(v: u32) -> Combo {
        let mut c = Combo::default();
        c.add(v, 1.0);
        c
    }

    /// The terms (vertex, weight).
    pub fn terms(&self) -> &[(u32, f64)] {
        &self.terms[..self.len as usize]
    }

    /// Adds `w` times vertex `v`, merged with a term of `v` already there.
    fn add(&mut self, v: u32, w: f64) {
        let n = self.len as usize;
        if let Some(t) = self.terms[..n].iter_mut().find(|t| t.0 == v) {
            t.1 += w;
        } else {
            // Two reflections of two terms each: no combination has more than four.
            self.terms[n] = (v, w);
            self.len += 1;
        }
    }
}

impl std::ops::Deref for Combo {
    type Target = [(u32, f64)];
    fn deref(&self) -> &[(u32, f64)] {
        self.terms()
    }
}

impl<'a> IntoIterator for &'a Combo {
    type Item = &'a (u32, f64);
    type IntoIter = std::slice::Iter<'a, (u32, f64)>;
    fn into_iter(self) -> Self::IntoIter {
        self.terms().iter()
    }
}

/// What kind of regular patch a face is.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum RegularKind {
    /// Bicubic B-spline; `closed` counts the face's edges that are boundaries or infinitely
    /// sharp (0 interior, 1 boundary, 2 corner, …).
    BSpline {
        /// Number of the face's edges that are boundaries (phantom rows).
        closed: u8,
    },
    /// B-spline with one semi-sharp crease of `sharpness` on face edge `edge`.
    SingleCrease {
        /// Face edge (0..4, edge k from corner k to k+1) carrying the crease.
        edge: u8,
        /// Its sharpness.
        sharpness: f32,
    },
}

fn at(p: [i32; 2]) -> usize {
    (4 * p[1] + p[0]) as usize
}
fn add(a: [i32; 2], b: [i32; 2]) -> [i32; 2] {
    [a[0] + b[0], a[1] + b[1]]
}
fn sub(a: [i32; 2], b: [i32; 2]) -> [i32; 2] {
    [a[0] - b[0], a[1] - b[1]]
}

fn reflect(grid: &[Combo; 16], on: usize, inside: usize) -> Combo {
    let mut sum = Combo::default();
    for &(i, w) in &grid[on] {
        sum.add(i, 2.0 * w);
    }
    for &(i, w) in &grid[inside] {
        sum.add(i, -w);
    }
    // The terms that cancel are left out, the others kept in order.
    let mut out = Combo::default();
    for &(i, w) in sum.terms() {
        if w != 0.0 {
            out.terms[out.len as usize] = (i, w);
            out.len += 1;
        }
    }
    out
}

/// The two vertices of the quad across edge `k` of quad `f` (corners `fv`) that are not on
/// the edge: the one next to corner `k + 1`, then the one next to corner `k` (grid positions
/// `C[k] − V[k]` and `C[k+1] − V[k]`); `None` when no other face holds the edge as a quad
/// running the other way.
fn across(topo: &crate::mesh::Topology, f: usize, fv: &[u32], k: usize) -> Option<[u32; 2]> {
    let k1 = (k + 1) % 4;
    let g = topo
        .edge_face_list(topo.face_edge(f, k))
        .iter()
        .copied()
        .find(|&g| g as usize != f)? as usize;
    let gv = topo.face_vertices(g);
    // In g the edge runs v_{k+1} -> v_k.
    let m = (0..4).find(|&i| gv[i] == fv[k1] && gv[(i + 1) % 4] == fv[k])?;
    Some([gv[(m + 2) % 4], gv[(m + 3) % 4]])
}

/// The vertex diagonally opposite corner vertex `v` of quad `f`, in the face opposite `f`
/// around `v` (an interior valence-4 ring).
fn diagonal(topo: &crate::mesh::Topology, f: usize, v: usize) -> Option<u32> {
    let (faces, corners) = (topo.vertex_faces(v), topo.vertex_face_corners(v));
    let ci = faces.iter().position(|&g| g as usize == f)?;
    let oi = (ci + 2) % 4;
    let gv = topo.face_vertices(faces[oi] as usize);
    Some(gv[(corners[oi] as usize + 2) % 4])
}

/// Where corner `k`'s quadrant lies in the grid of control points (`4 y + x`): the corner
/// `C[k]`, the points beside it across the edge out of it (`C[k] − V[k]`) and across the edge
/// into it (`C[k] − U[k]`), and the diagonal point (`C[k] − U[k] − V[k]`).
const QUADRANT: [[usize; 4]; 4] = {
    let mut q = [[0; 4]; 4];
    let mut k = 0;
    while k < 4 {
        let (c, u, v) = (C[k], U[k], V[k]);
        q[k] = [
            (4 * c[1] + c[0]) as usize,
            (4 * (c[1] - v[1]) + c[0] - v[0]) as usize,
            (4 * (c[1] - u[1]) + c[0] - u[0]) as usize,
            (4 * (c[1] - u[1] - v[1]) + c[0] - u[0] - v[0]) as usize,
        ];
        k += 1;
    }
    q
};

/// Whether vertex `v` of `level` is a corner [`interior_points`] takes: smooth, manifold and
/// interior, of valence 4 among quads, with no sharp edge.
pub fn regular_corner(level: &Level, v: usize) -> bool {
    let topo = &level.topo;
    let tag = topo.vert_tags[v];
    if tag.nonmanifold || tag.boundary || level.vertex_sharpness[v] != 0.0 {
        return false;
    }
    let (edges, faces) = (topo.vertex_edges(v), topo.vertex_faces(v));
    edges.len() == 4
        && faces.len() == 4
        && !edges
            .iter()
            .any(|&e| crease::is_sharp(level.edge_sharpness[e as usize]))
        && faces.iter().all(|&g| topo.face_size(g as usize) == 4)
}

/// [`regular_corner`] of every vertex of `level`, in parallel: each vertex tested once, not
/// once per face around it.
pub fn regular_corners(level: &Level) -> Vec<bool> {
    use rayon::prelude::*;
    (0..level.num_vertices())
        .into_par_iter()
        .with_min_len(crate::threads::min_len().max(4096))
        .map(|v| regular_corner(level, v))
        .collect()
}

/// The sixteen control points of face `f` of `level` when it is an interior B-spline patch
/// whose every corner is a smooth valence-4 vertex of quads with nothing sharp around it,
/// as vertex indices in grid order; `None` otherwise, whatever [`classify`] makes of the face.
/// Where it gives the points, [`classify`] gives the same ones (each a vertex alone) and kind
/// `BSpline { closed: 0 }`: the common case taken without [`Combo`]s (building and copying
/// them took about 40% of the 316² grid's level-0 decisions: 32–34 → 19 ms at 1 thread).
pub fn interior_points(level: &Level, f: usize) -> Option<[u32; 16]> {
    interior_points_by(level, f, |v| regular_corner(level, v))
}

/// [`interior_points`] with its corners' test `regular(v)` ([`regular_corner`], or a level's
/// [`regular_corners`] looked up).
pub fn interior_points_by(
    level: &Level,
    f: usize,
    regular: impl Fn(usize) -> bool,
) -> Option<[u32; 16]> {
    let topo = &level.topo;
    let fv = topo.face_vertices(f);
    if fv.len() != 4 || !fv.iter().all(|&v| regular(v as usize)) {
        return None;
    }
    let fe = topo.face_edge_list(f);
    // Each corner's quadrant from its ring, ordered from `f` across `f`'s edge into the
    // corner (ring position `i + 1`), then the diagonal face (`i + 2`), then the face across
    // `f`'s edge out of it (`i + 3`): those faces hold the points beside the corner across
    // each edge, and the diagonal point. Their other corners are checked against `f`'s (a ring
    // ordered otherwise is not taken: `classify` gives the same points).
    let mut grid = [0u32; 16];
    for k in 0..4 {
        let (k1, k3) = ((k + 1) % 4, (k + 3) % 4);
        let e = fe[k];
        if topo.edge_face_count(e) != 2 || topo.edge_nonmanifold[e as usize] {
            return None;
        }
        let v = fv[k] as usize;
        let (faces, corners) = (topo.vertex_faces(v), topo.vertex_face_corners(v));
        if faces.len() != 4 {
            return None; // not a regular corner, whatever `regular` said
        }
        let i = faces.iter().position(|&g| g as usize == f)?;
        let quad = |j: usize| {
            let g = (i + j) % 4;
            (topo.face_vertices(faces[g] as usize), corners[g] as usize)
        };
        // Across the edge into the corner (from v_{k-1}): it runs v_k -> v_{k-1} there.
        let (h, ch) = quad(1);
        // Across the edge out of the corner (to v_{k+1}): it runs v_{k+1} -> v_k there.
        let (g, cg) = quad(3);
        let (d, cd) = quad(2);
        if [h.len(), g.len(), d.len()] != [4; 3]
            || h[(ch + 1) % 4] != fv[k3]
            || g[(cg + 3) % 4] != fv[k1]
        {
            return None;
        }
        let [corner, beside_out, beside_in, diagonal] = QUADRANT[k];
        grid[corner] = fv[k];
        grid[beside_out] = g[(cg + 1) % 4];
        grid[beside_in] = h[(ch + 3) % 4];
        grid[diagonal] = d[(cd + 2) % 4];
    }
    Some(grid)
}

/// Classifies face `f` of `level` and gathers its control points, or `None` when the face is
/// irregular (needs more refinement). `single_crease` allows single-crease patches: one
/// semi-sharp edge, continued straight at both its ends by edges of the same sharpness, nothing
/// else sharp at its ends. Under Chaikin's rule a child edge's sharpness is `¾ s + ¼ s' − 1`
/// with `s'` that of the other sharp edge at its end: with `s' = s` this is the uniform rule's
/// `s − 1`, and the same holds again for the children inside each sub-patch's support, so the
/// single-crease patch is exact under both rules.
pub fn classify(
    level: &Level,
    f: usize,
    single_crease: bool,
) -> Option<(RegularKind, [Combo; 16])> {
    let topo = &level.topo;
    let fv = topo.face_vertices(f);
    if fv.len() != 4 {
        return None;
    }
    let fe = topo.face_edge_list(f);
    let es = |e: u32| level.edge_sharpness[e as usize];
    // The single semi-sharp crease, if any.
    let mut crease_edge = None;
    for k in 0..4 {
        let s = es(fe[k]);
        if crease::is_semi_sharp(s) {
            if !single_crease || crease_edge.is_some() {
                return None;
            }
            crease_edge = Some((k, s));
        }
    }
    // Edge states: open (surface continues into a quad across it) or closed (infinitely sharp).
    let mut open = [false; 4];
    for k in 0..4 {
        let e = fe[k];
        let s = es(e);
        if crease::is_infinite(s) {
            continue;
        }
        if topo.edge_face_count(e) != 2 || topo.edge_nonmanifold[e as usize] {
            return None;
        }
        let other = topo
            .edge_face_list(e)
            .iter()
            .copied()
            .find(|&g| g as usize != f)?;
        if topo.face_size(other as usize) != 4 {
            return None;
        }
        open[k] = true;
    }
    // Vertex conditions.
    for k in 0..4 {
        let v = fv[k] as usize;
        let nonmanifold = topo.vert_tags[v].nonmanifold;
        let vs = level.vertex_sharpness[v];
        let edges = topo.vertex_edges(v);
        let faces = topo.vertex_faces(v);
        let lead = fe[k];
        let trail = fe[(k + 3) % 4];
        let mut sharp = 0;
        let mut infinite = 0;
        for &e in edges {
            let s = es(e);
            if crease::is_semi_sharp(s) {
                // allowed only as the single crease or its straight continuation
                let (ck, cs) = crease_edge?;
                if s != cs {
                    return None;
                }
                let ce = fe[ck];
                if e != ce {
                    // continuation: opposite the crease edge in a valence-4 interior ring
                    let i = edges.iter().position(|&x| x == ce)?;
                    if edges.len() != 4 || topo.vert_tags[v].boundary || edges[(i + 2) % 4] != e {
                        return None;
                    }
                }
            }
            if crease::is_sharp(s) {
                sharp += 1;
            }
            if crease::is_infinite(s) {
                infinite += 1;
            }
        }
        if crease::is_semi_sharp(vs) {
            return None;
        }
        let (ol, ot) = (open[k], open[(k + 3) % 4]);
        match (ol, ot) {
            _ if nonmanifold && ol == ot => return None,
            (true, true) => {
                // interior, valence 4, smooth (or the single crease passing through)
                if vs != 0.0 || edges.len() != 4 || faces.len() != 4 || topo.vert_tags[v].boundary {
                    return None;
                }
                if faces.iter().any(|&g| topo.face_size(g as usize) != 4) {
                    return None;
                }
                let crease_through =
                    crease_edge.is_some_and(|(ck, _)| ck == k || (ck + 1) % 4 == k);
                if sharp != if crease_through { 2 } else { 0 } {
                    return None;
                }
                // The single crease must continue as itself: an infinitely sharp edge meeting
                // it here (a crease ending at, or turning into, an infinitely sharp one) makes
                // the vertex a crease vertex whose sharpness does not decay like the patch's.
                // Found by the differential test (tests/osd_oracle.rs,
                // `infinitely_sharp_crease_meets_semi_sharp`).
                if crease_through && infinite > 0 {
                    return None;
                }
            }
            (false, false) => {
                // corner: both face edges infinitely sharp, the face alone in its sector, the
                // vertex rule is the corner rule with only infinite sharpness around
                let rule = level.vertex_rule(v);
                if rule != crease::Rule::Corner || crease_edge.is_some() {
                    return None;
                }
                if !(vs == 0.0 || crease::is_infinite(vs)) {
                    return None;
                }
            }
            _ => {
                // boundary: exactly two sharp (infinite) edges at v, crease rule, and two faces
                // on this side: the face and its neighbour across the open edge, bounded by a
                // sharp edge
                if vs != 0.0
                    || sharp != 2
                    || crease_edge.is_some_and(|(ck, _)| ck == k || (ck + 1) % 4 == k)
                {
                    return None;
                }
                // The neighbour across the open edge at v, by face adjacency (this also works
                // at a crease of non-manifold edges, where the ring is not ordered).
                let eo = if ol { lead } else { trail };
                let g = topo
                    .edge_face_list(eo)
                    .iter()
                    .copied()
                    .find(|&g| g as usize != f)? as usize;
                let gv = topo.face_vertices(g);
                let gn = gv.len();
                let gi = gv.iter().position(|&x| x as usize == v)?;
                let ge = topo.face_edge_list(g);
                let (g_lead, g_trail) = (ge[gi], ge[(gi + gn - 1) % gn]);
                let far_edge = if g_lead == eo { g_trail } else { g_lead };
                if !crease::is_infinite(es(far_edge)) {
                    return None;
                }
            }
        }
    }
    // Gather (in place: each point is set before a reflection reads it).
    let mut grid = [Combo::default(); 16];
    for k in 0..4 {
        grid[at(C[k])] = Combo::one(fv[k]);
    }
    // Rows across each edge.
    for k in 0..4 {
        let k1 = (k + 1) % 4;
        let x = sub(C[k], V[k]);
        let y = sub(C[k1], V[k]);
        if open[k] {
            let [a, b] = across(topo, f, fv, k)?;
            grid[at(x)] = Combo::one(a);
            grid[at(y)] = Combo::one(b);
        }
    }
    for k in 0..4 {
        let k1 = (k + 1) % 4;
        if !open[k] {
            let x = sub(C[k], V[k]);
            let y = sub(C[k1], V[k]);
            grid[at(x)] = reflect(&grid, at(C[k]), at(add(C[k], V[k])));
            grid[at(y)] = reflect(&grid, at(C[k1]), at(add(C[k1], V[k])));
        }
    }
    // Diagonals.
    for k in 0..4 {
        let d = sub(sub(C[k], U[k]), V[k]);
        let (ol, ot) = (open[k], open[(k + 3) % 4]);
        if ol && ot {
            grid[at(d)] = Combo::one(diagonal(topo, f, fv[k] as usize)?);
        } else if !ol {
            // lead edge closed: reflect across it (along V)
            grid[at(d)] = reflect(&grid, at(add(d, V[k])), at(add(add(d, V[k]), V[k])));
        } else {
            grid[at(d)] = reflect(&grid, at(add(d, U[k])), at(add(add(d, U[k]), U[k])));
        }
    }
    let kind = match crease_edge {
        Some((k, s)) => RegularKind::SingleCrease {
            edge: k as u8,
            sharpness: s,
        },
        None => RegularKind::BSpline {
            closed: open.iter().filter(|&&o| !o).count() as u8,
        },
    };
    Some((kind, grid))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::{generate, shapes, EdgeCrease, Options, VertexCorner};
    use crate::refine::step;

    /// Wherever [`interior_points`] gives a face's points, [`classify`] gives the same points
    /// (each a vertex alone) as an interior B-spline patch, and [`interior_points_by`] with a
    /// level's [`regular_corners`] gives what it gives everywhere; and it gives them for every
    /// face of a grid whose corners are all interior: on level 0 and level 1 of meshes with
    /// boundaries, holes, n-gons (one among quads of valence-4 corners), extraordinary
    /// vertices, semi-sharp and infinitely sharp creases and a semi-sharp corner. Given a
    /// corners' test that takes every vertex, `interior_points_by` does not panic, and gives
    /// nothing where a corner is not of valence 4.
    #[test]
    fn interior_points_are_classify_s() {
        let mut creased = generate::grid(8);
        creased.holes = vec![20];
        creased.creases = vec![
            EdgeCrease {
                v0: 30,
                v1: 31,
                sharpness: 2.0,
            },
            EdgeCrease {
                v0: 50,
                v1: 59,
                sharpness: 10.0,
            },
        ];
        creased.corners = vec![VertexCorner {
            vertex: 40,
            sharpness: 1.5,
        }];
        // Faces 14 and 15 of a 6 x 6 grid made one hexagon: quads around it have valence-4
        // corners with a face that is not a quad.
        let mut hexagon = generate::grid(6);
        let faces: Vec<Vec<u32>> = (0..36)
            .filter(|&f| f != 15)
            .map(|f| {
                if f == 14 {
                    vec![16, 23, 24, 25, 18, 17]
                } else {
                    hexagon.face(f).to_vec()
                }
            })
            .collect();
        hexagon.face_offsets = std::iter::once(0)
            .chain(faces.iter().scan(0, |n, f| {
                *n += f.len() as u32;
                Some(*n)
            }))
            .collect();
        hexagon.face_verts = faces.concat();
        let meshes = [
            generate::grid(6),
            creased,
            hexagon,
            generate::star(5, 3),
            shapes::gear(7),
            shapes::rounded_box(2.0),
            shapes::blob(),
        ];
        let (mut taken, mut refused) = (0, 0);
        for (i, mesh) in meshes.iter().enumerate() {
            let (base, _) = Level::base(mesh, &Options::default()).unwrap();
            let (child, _) = step::refine(&base, mesh.options.crease_method);
            for level in [&base, &child] {
                let corners = regular_corners(level);
                for f in 0..level.num_faces() {
                    let by = interior_points_by(level, f, |v| corners[v]);
                    assert_eq!(by, interior_points(level, f), "mesh {i} face {f}");
                    // A corners' test that takes every vertex: no panic, and no points where
                    // a corner is not of valence 4.
                    let valence_4 = level
                        .topo
                        .face_vertices(f)
                        .iter()
                        .all(|&v| level.topo.vertex_faces(v as usize).len() == 4);
                    let any = interior_points_by(level, f, |_| true);
                    assert!(valence_4 || any.is_none(), "mesh {i} face {f}");
                    let Some(points) = by else {
                        refused += 1;
                        continue;
                    };
                    let (kind, cps) = classify(level, f, true).expect("a regular face");
                    assert_eq!(
                        kind,
                        RegularKind::BSpline { closed: 0 },
                        "mesh {i} face {f}"
                    );
                    assert_eq!(cps, points.map(Combo::one), "mesh {i} face {f}");
                    taken += 1;
                }
            }
        }
        assert!(
            taken > 500 && refused > 100,
            "taken {taken}, refused {refused}"
        );
        // A 6 x 6 grid: the 4 x 4 faces away from its boundary, and no other.
        let (grid, _) = Level::base(&meshes[0], &Options::default()).unwrap();
        let inside: Vec<usize> = (0..36)
            .filter(|&f| interior_points(&grid, f).is_some())
            .collect();
        let want: Vec<usize> = (1..5)
            .flat_map(|i| (1..5).map(move |j| 6 * i + j))
            .collect();
        assert_eq!(inside, want);
    }
}
