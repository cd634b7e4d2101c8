//! Exact evaluation of a Loop limit surface at `(face, u, v)` (OpenSubdiv's triangle
//! parameter: `(0,0)` at the face's vertex 0, `(1,0)` at vertex 1, `(0,1)` at vertex 2).
//!
//! Feature-adaptive, on demand: a regular triangle ([`loop_box::gather`]: smooth valence-6
//! vertices, or regular crease vertices with phantoms) is a box-spline patch evaluated
//! directly. Any other triangle is cut out of its level with two rings of faces
//! ([`LocalMesh`]), refined once with the library's Loop rules, and the evaluation descends
//! into the child triangle that holds the point ([`crate::refine::loop_step::child_uv`]), until the triangle
//! is regular. A point that stays at an irregular vertex (an extraordinary vertex, a corner,
//! a dart, a crease vertex of another valence) takes that vertex's exact limit position once
//! its neighbourhood is stationary ([`stationary_limit_mask`]; a dart's by refining until the
//! position no longer moves). Points within 2^-[`MAX_DEPTH`] of such a vertex take the
//! barycentric blend of the exact limit positions of their tiny triangle's corners, which is
//! the surface to within the square of that size.
//!
//! Derivatives are with respect to `(u, v)`. At an irregular vertex itself the parametric
//! derivatives do not exist (they vanish or diverge as the characteristic map's eigenvalue
//! is below or above ½); there `du`, `dv` are the secants to the points at `2^-24` along the
//! face's two edges from that vertex, which lie in the tangent plane to within that distance,
//! and the second derivatives are zero.

use super::local::LocalMesh;
use super::loop_box::{self, Point};
use super::table::Sample;
use crate::coord::FaceCoord;
use crate::error::{Error, ErrorKind, Result};
use crate::mesh::{ControlMesh, CreaseMethod, Options, Scheme};
use crate::refine::crease;
use crate::refine::loop_rules::stationary_limit_mask;
use crate::refine::loop_step::{child_of, child_uv};
use crate::refine::Level;
use std::sync::OnceLock;

/// Deepest descent towards an irregular vertex.
pub const MAX_DEPTH: usize = 60;

/// Levels a dart's limit position is refined for at most.
const DART_LEVELS: usize = 200;

/// Levels of each face's tree built ahead: below, an irregular corner is refined on demand.
pub const TREE_DEPTH: usize = 4;

/// A node of a face's tree: the triangle is a regular patch, or split into its four children,
/// or (at [`TREE_DEPTH`], next to an irregular vertex) its cut-out, refined on demand.
#[derive(Clone, Debug)]
enum Node {
    Regular(Box<[[f64; 3]; 12]>),
    Split(Box<[Node; 4]>),
    Cap(Box<LocalMesh>),
    Hole,
}

/// A leaf of a face's tree ([`LoopSurface::leaves`]).
pub(crate) enum Leaf<'a> {
    /// A regular box-spline patch: its 12 control points ([`loop_box::LATTICE`] order).
    Regular(&'a [[f64; 3]; 12]),
    /// A triangle next to an irregular vertex: face 0 of its cut-out.
    Cap(&'a LocalMesh),
}

/// A Loop control mesh ready to be evaluated: for each face, a tree of regular box-spline
/// patches down to [`TREE_DEPTH`] levels, with the cut-outs at irregular vertices kept for
/// on-demand refinement.
#[derive(Clone, Debug)]
pub struct LoopSurface {
    level: Level,
    /// Control positions, three numbers per vertex.
    positions: Vec<f64>,
    method: CreaseMethod,
    /// Each face's tree, built when the face is first evaluated.
    trees: Vec<OnceLock<Node>>,
}

impl LoopSurface {
    /// The surface of `mesh` under `options` (whose scheme must be Loop).
    pub fn new(mesh: &ControlMesh, options: Options) -> Result<Self> {
        if options.scheme != Scheme::Loop {
            return Err(Error::new(
                ErrorKind::Usage,
                "LoopSurface needs the Loop scheme",
            ));
        }
        let (level, _) = Level::base(mesh, &options)?;
        let mut surface = LoopSurface {
            level,
            positions: Vec::new(),
            method: options.crease_method,
            trees: Vec::new(),
        };
        surface.set_positions(&mesh.positions)?;
        Ok(surface)
    }

    /// Re-poses the surface: new control positions (one per control vertex), same topology
    /// and tags; the trees are rebuilt.
    pub fn set_positions(&mut self, base: &[[f64; 3]]) -> Result<()> {
        if base.len() != self.level.num_vertices() {
            return Err(Error::new(
                ErrorKind::Usage,
                format!(
                    "{} positions for {} control vertices",
                    base.len(),
                    self.level.num_vertices()
                ),
            ));
        }
        self.positions = base.as_flattened().to_vec();
        self.trees = (0..self.level.num_faces())
            .map(|_| OnceLock::new())
            .collect();
        Ok(())
    }

    /// The tree of face `f`, built on first use.
    fn tree(&self, f: usize) -> &Node {
        // Built without forking: see `threads::sequential` for the deadlock a fork here risks.
        self.trees[f].get_or_init(|| {
            crate::threads::sequential(|| {
                if self.level.face_hole[f] {
                    return Node::Hole;
                }
                let local = LocalMesh::extract(&self.level, &self.positions, 3, f, 2);
                self.build_node(local, 0)
            })
        })
    }

    fn build_node(&self, local: LocalMesh, depth: usize) -> Node {
        if let Some(cps) = loop_box::gather(&local.level, 0) {
            return Node::Regular(Box::new(cps.map(|p| p.position(|i| point(&local, i)))));
        }
        if depth == TREE_DEPTH {
            return Node::Cap(Box::new(local));
        }
        let refined = local.refine(self.method);
        let kids: [Node; 4] = std::array::from_fn(|k| {
            // A regular child is read off the refined cut-out directly.
            if let Some(cps) = loop_box::gather(&refined.level, k) {
                return Node::Regular(Box::new(cps.map(|p| p.position(|i| point(&refined, i)))));
            }
            let cut = LocalMesh::extract(&refined.level, &refined.data, 3, k, 2);
            self.build_node(cut, depth + 1)
        });
        Node::Split(Box::new(kids))
    }

    /// Visits the leaves of face `f`'s tree (none for a hole), each with its path of child
    /// indices from the face ([`child_uv`]'s children).
    pub(crate) fn leaves(&self, f: usize, visit: &mut dyn FnMut(&[u8], Leaf<'_>)) {
        fn walk(node: &Node, path: &mut Vec<u8>, visit: &mut dyn FnMut(&[u8], Leaf<'_>)) {
            match node {
                Node::Hole => {}
                Node::Regular(cps) => visit(path, Leaf::Regular(cps)),
                Node::Cap(local) => visit(path, Leaf::Cap(local)),
                Node::Split(kids) => {
                    for (k, kid) in kids.iter().enumerate() {
                        path.push(k as u8);
                        walk(kid, path, visit);
                        path.pop();
                    }
                }
            }
        }
        walk(self.tree(f), &mut Vec::new(), visit);
    }

    /// The refinement rule for creases (what refining a cut-out takes).
    pub fn crease_method(&self) -> CreaseMethod {
        self.method
    }

    /// Bytes held by the trees built so far (control points and cut-outs' data; not their
    /// topology).
    pub fn bytes(&self) -> usize {
        fn node_bytes(n: &Node) -> usize {
            std::mem::size_of::<Node>()
                + match n {
                    Node::Regular(_) => 12 * 24,
                    Node::Split(k) => k.iter().map(node_bytes).sum(),
                    Node::Cap(l) => l.data.len() * 8 + 64 * l.level.num_faces(),
                    Node::Hole => 0,
                }
        }
        self.trees
            .iter()
            .filter_map(|t| t.get())
            .map(node_bytes)
            .sum::<usize>()
            + self.positions.len() * 8
    }

    /// Exact limit positions of the vertices of `level`, refinement level `depth` of this
    /// surface's control mesh (as [`crate::refine::Refiner`] builds it; `refined` its
    /// positions): each vertex is evaluated at its place in a base face's triangle parameter.
    /// A vertex that only hole faces use keeps its refined position (it is not on the surface).
    pub fn limit_positions(
        &self,
        level: &Level,
        depth: usize,
        refined: &[[f64; 3]],
    ) -> Result<Vec<[f64; 3]>> {
        use rayon::prelude::*;
        let topo = &level.topo;
        (0..level.num_vertices())
            .into_par_iter()
            .map(|x| {
                let faces = topo.vertex_faces(x);
                let Some(&f) = faces
                    .iter()
                    .find(|&&f| !self.level.face_hole[f as usize >> (2 * depth)])
                else {
                    return Ok(refined[x]);
                };
                let c = topo
                    .face_vertices(f as usize)
                    .iter()
                    .position(|&v| v as usize == x)
                    .expect("a face of the vertex holds it");
                let (mut u, mut v) = [(0.0, 0.0), (1.0, 0.0), (0.0, 1.0)][c];
                for l in 0..depth {
                    (u, v) = child_uv((f as usize >> (2 * l)) & 3, u, v);
                }
                let base = (f as usize >> (2 * depth)) as u32;
                self.position(FaceCoord::new(base, 0, u, v))
            })
            .collect()
    }

    /// True when face `f` is a hole.
    pub fn is_hole(&self, f: usize) -> bool {
        self.level.face_hole[f]
    }

    /// Number of faces (each one triangle, one parameter domain).
    pub fn num_faces(&self) -> usize {
        self.level.num_faces()
    }

    /// Position and derivatives at `at` (`at.k` must be 0). Holes and parameters outside the
    /// triangle (`u, v ≥ 0`, `u + v ≤ 1`) are errors.
    pub fn eval(&self, at: FaceCoord) -> Result<Sample> {
        self.eval_with(at, true)
    }

    /// [`Self::eval`]'s position alone: at an irregular vertex it skips the secants (two
    /// descents 24 levels deep) that stand in for the derivatives there.
    pub fn position(&self, at: FaceCoord) -> Result<[f64; 3]> {
        Ok(self.eval_with(at, false)?.p)
    }

    fn eval_with(&self, at: FaceCoord, derivatives: bool) -> Result<Sample> {
        check_triangle_coord(at, self.num_faces())?;
        let (f, u, v) = (at.face as usize, at.u, at.v);
        let bad = |m: String| Err(Error::new(ErrorKind::Usage, m));
        // The tree: regular leaves directly, caps by on-demand descent.
        let (mut u, mut v) = (u.max(0.0), v.max(0.0));
        let mut node = self.tree(f);
        let mut scale = 1.0f64;
        let mut depth = 0;
        loop {
            match node {
                Node::Hole => return bad(format!("face {} is a hole", at.face)),
                Node::Regular(cps) => return Ok(sample(loop_box::eval(cps, u, v), scale, depth)),
                Node::Cap(local) => {
                    let mut s = self.descend((**local).clone(), u, v, derivatives);
                    s.du = s.du.map(|x| x * scale);
                    s.dv = s.dv.map(|x| x * scale);
                    let s2 = scale * scale;
                    s.duu = s.duu.map(|x| x * s2);
                    s.duv = s.duv.map(|x| x * s2);
                    s.dvv = s.dvv.map(|x| x * s2);
                    s.level = (s.level as usize + depth).min(255) as u8;
                    return Ok(s);
                }
                Node::Split(kids) => {
                    let (k, s, t) = child_of(u, v);
                    scale *= if k == 3 { -2.0 } else { 2.0 };
                    node = &kids[k];
                    (u, v) = (s, t);
                    depth += 1;
                }
            }
        }
    }

    /// The sub-quad parameter `(k, s, t)` of triangle face (Catmull-Clark's sub-face
    /// convention for a three-sided face: quad `k` runs from the face's vertex `k` (0,0) to the
    /// midpoint of edge `k` (1,0), the centroid (1,1) and the midpoint of edge `k − 1` (0,1))
    /// as the triangle's `(u, v)`, with `∂(u,v)/∂s`, `∂(u,v)/∂t` and the cross derivative
    /// (the map is bilinear).
    pub fn sub_quad_uv(k: usize, s: f64, t: f64) -> ([f64; 2], [[f64; 2]; 3]) {
        let corner = [[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]];
        let c = corner[k % 3];
        let next = corner[(k + 1) % 3];
        let prev = corner[(k + 2) % 3];
        let mk = [0.5 * (c[0] + next[0]), 0.5 * (c[1] + next[1])];
        let mp = [0.5 * (c[0] + prev[0]), 0.5 * (c[1] + prev[1])];
        let g = [1.0 / 3.0, 1.0 / 3.0];
        let f = |i: usize| {
            (1.0 - s) * (1.0 - t) * c[i]
                + s * (1.0 - t) * mk[i]
                + s * t * g[i]
                + (1.0 - s) * t * mp[i]
        };
        let ds = |i: usize| (1.0 - t) * (mk[i] - c[i]) + t * (g[i] - mp[i]);
        let dt = |i: usize| (1.0 - s) * (mp[i] - c[i]) + s * (g[i] - mk[i]);
        let dst = |i: usize| c[i] - mk[i] + g[i] - mp[i];
        (
            [f(0), f(1)],
            [[ds(0), ds(1)], [dt(0), dt(1)], [dst(0), dst(1)]],
        )
    }

    /// [`Self::eval`] at the sub-quad parameter `(face, k, s, t)` ([`Self::sub_quad_uv`]),
    /// derivatives with respect to `(s, t)`: how a triangle is diced, as three quads.
    pub fn eval_sub_quad(&self, at: FaceCoord) -> Result<Sample> {
        eval_sub_quad(at, |u, v| self.eval(FaceCoord::new(at.face, 0, u, v)))
    }

    /// [`Self::eval_sub_quad`]'s position alone, the same bits ([`Self::position`]: no
    /// secants at an irregular vertex).
    pub fn position_sub_quad(&self, at: FaceCoord) -> Result<[f64; 3]> {
        let ([u, v], _) = sub_quad_triangle_uv(at)?;
        self.position(FaceCoord::new(at.face, 0, u, v))
    }

    /// [`Sample::level`] of [`Self::eval`] at `at`, from the face's tree alone where the point
    /// is in a regular patch (an evaluation, without the vertex secants, in a cap).
    pub fn level_at(&self, at: FaceCoord) -> Result<u8> {
        check_triangle_coord(at, self.num_faces())?;
        let (mut u, mut v) = (at.u.max(0.0), at.v.max(0.0));
        let mut node = self.tree(at.face as usize);
        let mut depth = 0u8;
        loop {
            match node {
                Node::Hole => {
                    return Err(Error::new(
                        ErrorKind::Usage,
                        format!("face {} is a hole", at.face),
                    ))
                }
                Node::Regular(_) => return Ok(depth),
                Node::Cap(_) => return Ok(self.eval_with(at, false)?.level),
                Node::Split(kids) => {
                    let (k, s, t) = child_of(u, v);
                    node = &kids[k];
                    (u, v) = (s, t);
                    depth += 1;
                }
            }
        }
    }

    /// [`Self::level_at`] at the sub-quad parameter: [`Sample::level`] of
    /// [`Self::eval_sub_quad`].
    pub fn level_sub_quad(&self, at: FaceCoord) -> Result<u8> {
        let s = eval_sub_quad(at, |u, v| {
            Ok(Sample {
                level: self.level_at(FaceCoord::new(at.face, 0, u, v))?,
                ..Sample::default()
            })
        })?;
        Ok(s.level)
    }

    /// The base level (control mesh topology and tags) the surface refines.
    pub fn level(&self) -> &Level {
        &self.level
    }

    /// Control position of vertex `v`.
    pub fn control_point(&self, v: usize) -> [f64; 3] {
        [0, 1, 2].map(|x| self.positions[3 * v + x])
    }

    /// Evaluates at `(u, v)` of face 0 of `local`; `derivatives: false` skips the secants at
    /// an irregular vertex (its derivatives are then zero).
    fn descend(&self, local: LocalMesh, u: f64, v: f64, derivatives: bool) -> Sample {
        let mut offset = [0.0; 3];
        let mut s = self.descend_centred(local, u, v, derivatives, &mut offset);
        s.p = std::array::from_fn(|c| s.p[c] + offset[c]);
        s
    }

    /// [`Self::descend`] with the cut-out moved, at every level, so that the current
    /// triangle's vertex 0 is at the origin (`offset` accumulates the moves; the sample's
    /// position is relative to it). Refinement is affine, so the surface only moves; but the
    /// points keep the size of the current triangle's neighbourhood, so that their rounding
    /// shrinks with it. Without this, 36 levels down (a point 1e-11 from an irregular vertex)
    /// the derivatives, 2^36 times the differences of points about 1 apart, were wrong by tens
    /// of percent (the normals of `trace --exact` hits on loop_cube's top showed it).
    fn descend_centred(
        &self,
        mut local: LocalMesh,
        mut u: f64,
        mut v: f64,
        derivatives: bool,
        offset: &mut [f64; 3],
    ) -> Sample {
        recentre(&mut local, offset);
        // d/d(face param) = scale · d/d(current param), per axis with sign.
        let mut scale = 1.0f64;
        for depth in 0..=MAX_DEPTH {
            let pos = |i: u32| point(&local, i);
            if let Some(cps) = loop_box::gather(&local.level, 0) {
                let cps: [[f64; 3]; 12] = cps.map(|p: Point| p.position(pos));
                let r = loop_box::eval(&cps, u, v);
                return sample(r, scale, depth);
            }
            let fv = local.level.topo.face_vertices(0);
            let corner = if u == 0.0 && v == 0.0 {
                Some(0)
            } else if u == 1.0 && v == 0.0 {
                Some(1)
            } else if u == 0.0 && v == 1.0 {
                Some(2)
            } else {
                None
            };
            // At an irregular vertex the descent would never end: take its limit. (A regular
            // vertex's corner triangle becomes a regular patch after a few levels.)
            if let Some(c) = corner.filter(|&c| !loop_box::regular_vertex(&local.level, fv[c], 0)) {
                if let Some(p) = self.vertex_limit(&local, fv[c]) {
                    if !derivatives {
                        let z = [0.0; 3];
                        return sample([p, z, z, z, z, z], scale, depth);
                    }
                    return self.at_vertex(&local, c, p, scale, depth);
                }
            }
            if depth == MAX_DEPTH {
                // A triangle 2^-60 across: its corners' limits, blended.
                let mut p = [0.0; 3];
                let w = [1.0 - u - v, u, v];
                for c in 0..3 {
                    let l = self
                        .vertex_limit_refined(&local, fv[c])
                        .unwrap_or_else(|| pos(fv[c]));
                    for x in 0..3 {
                        p[x] += w[c] * l[x];
                    }
                }
                return sample(
                    [p, [0.0; 3], [0.0; 3], [0.0; 3], [0.0; 3], [0.0; 3]],
                    scale,
                    depth,
                );
            }
            let refined = local.refine(self.method);
            let (k, s, t) = child_of(u, v);
            let sign = if k == 3 { -2.0 } else { 2.0 };
            scale *= sign;
            local = LocalMesh::extract(&refined.level, &refined.data, 3, k, 2);
            recentre(&mut local, offset);
            u = s;
            v = t;
        }
        unreachable!("the loop returns at MAX_DEPTH")
    }

    /// The exact limit position of `local`'s vertex `x` when its neighbourhood is stationary
    /// (closed form) or a stationary dart (refined until it stops moving); `None` while
    /// anything at it is still semi-sharp.
    fn vertex_limit(&self, local: &LocalMesh, x: u32) -> Option<[f64; 3]> {
        if let Some(mask) = stationary_limit_mask(&local.level, x as usize) {
            return Some(apply(&mask, |i| point(local, i)));
        }
        let lvl = &local.level;
        let semi = crease::is_semi_sharp(lvl.vertex_sharpness[x as usize])
            || lvl
                .topo
                .vertex_edges(x as usize)
                .iter()
                .any(|&e| crease::is_semi_sharp(lvl.edge_sharpness[e as usize]));
        if semi {
            return None;
        }
        Some(self.dart_limit(local, x))
    }

    /// [`Self::vertex_limit`], refining first until the vertex is stationary.
    fn vertex_limit_refined(&self, local: &LocalMesh, x: u32) -> Option<[f64; 3]> {
        let mut cur = local.clone();
        let mut x = x;
        for _ in 0..=crate::refine::MAX_LEVEL {
            if let Some(p) = self.vertex_limit(&cur, x) {
                return Some(p);
            }
            (cur, x) = self.refine_at(&cur, x)?;
        }
        None
    }

    /// Refines `local` once and cuts it down again around vertex `x` (which keeps its index
    /// as a child of a vertex); returns the new local mesh and `x`'s index in it.
    fn refine_at(&self, local: &LocalMesh, x: u32) -> Option<(LocalMesh, u32)> {
        let refined = local.refine(self.method);
        let topo = &refined.level.topo;
        let &f = topo.vertex_faces(x as usize).first()?;
        let (cut, map) =
            LocalMesh::extract_with_map(&refined.level, &refined.data, 3, f as usize, 2);
        let nx = map.iter().position(|&o| o == x)? as u32;
        Some((cut, nx))
    }

    /// A dart's limit: refine around it until its position stops changing.
    fn dart_limit(&self, local: &LocalMesh, x: u32) -> [f64; 3] {
        let mut cur = local.clone();
        let mut x = x;
        let mut p = point(&cur, x);
        for _ in 0..DART_LEVELS {
            let Some((next, nx)) = self.refine_at(&cur, x) else {
                break;
            };
            let q = point(&next, nx);
            let moved = (0..3).map(|i| (q[i] - p[i]).abs()).fold(0.0, f64::max);
            let size = q.iter().map(|c| c.abs()).fold(1e-300, f64::max);
            cur = next;
            x = nx;
            p = q;
            if moved <= 1e-17 * size {
                break;
            }
        }
        p
    }

    /// The sample at corner `c` of the current triangle, an irregular vertex with limit `p`:
    /// secant derivatives along the triangle's two edges from `c`.
    fn at_vertex(
        &self,
        local: &LocalMesh,
        c: usize,
        p: [f64; 3],
        scale: f64,
        depth: usize,
    ) -> Sample {
        let h = (2.0f64).powi(-24);
        // Points along the edges from corner c, in the current triangle's parameter.
        let (a, b) = match c {
            0 => ((h, 0.0), (0.0, h)),
            1 => ((1.0 - h, 0.0), (1.0 - h, h)),
            _ => ((0.0, 1.0 - h), (h, 1.0 - h)),
        };
        let pa = self.descend(local.clone(), a.0, a.1, false).p;
        let pb = self.descend(local.clone(), b.0, b.1, false).p;
        let sec = |q: [f64; 3]| [0, 1, 2].map(|i| (q[i] - p[i]) / h);
        let (sa, sb) = (sec(pa), sec(pb));
        // Express the secants as d/du and d/dv of the current triangle.
        let (du, dv) = match c {
            0 => (sa, sb),
            // From vertex 1: a = −u direction, b = −u + v.
            1 => {
                let du = sa.map(|x| -x);
                let dv = [0, 1, 2].map(|i| sb[i] + du[i]);
                (du, dv)
            }
            // From vertex 2: a = −v, b = u − v.
            _ => {
                let dv = sa.map(|x| -x);
                let du = [0, 1, 2].map(|i| sb[i] + dv[i]);
                (du, dv)
            }
        };
        sample([p, du, dv, [0.0; 3], [0.0; 3], [0.0; 3]], scale, depth)
    }
}

/// Checks `at` as a point of a triangle surface of `faces` faces: `k` = 0, `u, v ≥ 0`,
/// `u + v ≤ 1` (to 1e-12).
pub fn check_triangle_coord(at: FaceCoord, faces: usize) -> Result<()> {
    let bad = |m: String| Err(Error::new(ErrorKind::Usage, m));
    if at.face as usize >= faces {
        return bad(format!("face {} is out of range ({faces} faces)", at.face));
    }
    if at.k != 0 {
        return bad(format!(
            "face {}: a triangle has no sub-face {}",
            at.face, at.k
        ));
    }
    let (u, v) = (at.u, at.v);
    if !(u >= 0.0 && v >= 0.0 && u + v <= 1.0 + 1e-12) {
        return bad(format!(
            "({u}, {v}) is outside the triangle u, v ≥ 0, u + v ≤ 1"
        ));
    }
    Ok(())
}

/// A triangle surface `eval(u, v)` (OpenSubdiv's triangle parameter) evaluated at the
/// sub-quad parameter `(face, k, s, t)` of [`LoopSurface::sub_quad_uv`], derivatives with
/// respect to `(s, t)` by the chain rule through the bilinear map: how every triangle
/// surface (exact or approximate) is diced, as three quads.
pub fn eval_sub_quad(at: FaceCoord, eval: impl Fn(f64, f64) -> Result<Sample>) -> Result<Sample> {
    let ([u, v], [ds, dt, dst]) = sub_quad_triangle_uv(at)?;
    let r = eval(u, v)?;
    let lin = |a: [f64; 3], b: [f64; 3], x: f64, y: f64| [0, 1, 2].map(|i| a[i] * x + b[i] * y);
    let quad = |x: [f64; 2], y: [f64; 2]| {
        [0, 1, 2].map(|i| {
            r.duu[i] * x[0] * y[0] + r.duv[i] * (x[0] * y[1] + x[1] * y[0]) + r.dvv[i] * x[1] * y[1]
        })
    };
    let cross = lin(r.du, r.dv, dst[0], dst[1]);
    let st = quad(ds, dt);
    Ok(Sample {
        p: r.p,
        du: lin(r.du, r.dv, ds[0], ds[1]),
        dv: lin(r.du, r.dv, dt[0], dt[1]),
        duu: quad(ds, ds),
        duv: [0, 1, 2].map(|i| st[i] + cross[i]),
        dvv: quad(dt, dt),
        level: r.level + 1,
    })
}

/// The triangle parameter `(u, v)` of sub-quad point `at` (the bilinear map of
/// [`LoopSurface::sub_quad_uv`], `u` kept within the triangle) and the map's derivatives;
/// errors for a sub-quad or parameter out of range.
fn sub_quad_triangle_uv(at: FaceCoord) -> Result<([f64; 2], [[f64; 2]; 3])> {
    if at.k > 2 {
        return Err(Error::new(
            ErrorKind::Usage,
            format!(
                "face {}: a triangle has sub-quads 0..=2, not {}",
                at.face, at.k
            ),
        ));
    }
    if !(0.0..=1.0).contains(&at.u) || !(0.0..=1.0).contains(&at.v) {
        return Err(Error::new(
            ErrorKind::Usage,
            format!("(u, v) = ({}, {}) is outside [0, 1]²", at.u, at.v),
        ));
    }
    let ([u, v], d) = LoopSurface::sub_quad_uv(at.k as usize, at.u, at.v);
    Ok(([u.min(1.0 - v), v], d))
}

fn point(local: &LocalMesh, i: u32) -> [f64; 3] {
    let d = local.point(i as usize);
    [d[0], d[1], d[2]]
}

fn apply(mask: &[(u32, f64)], pos: impl Fn(u32) -> [f64; 3]) -> [f64; 3] {
    let mut out = [0.0; 3];
    for &(i, w) in mask {
        let p = pos(i);
        for x in 0..3 {
            out[x] += w * p[x];
        }
    }
    out
}

/// A sample from `[p, du, dv, duu, duv, dvv]` in the current triangle's parameter, whose
/// derivatives scale by `scale` (first) and `scale²` (second) to the face's.
/// Moves `local` so that its face 0's vertex 0 is at the origin; adds the move to `offset`.
fn recentre(local: &mut LocalMesh, offset: &mut [f64; 3]) {
    let Some(&v0) = local.level.topo.face_vertices(0).first() else {
        return;
    };
    let c = point(local, v0);
    for q in local.data.chunks_exact_mut(3) {
        for (x, o) in q.iter_mut().zip(c) {
            *x -= o;
        }
    }
    for (o, x) in offset.iter_mut().zip(c) {
        *o += x;
    }
}

fn sample(r: [[f64; 3]; 6], scale: f64, depth: usize) -> Sample {
    let s2 = scale * scale;
    Sample {
        p: r[0],
        du: r[1].map(|x| x * scale),
        dv: r[2].map(|x| x * scale),
        duu: r[3].map(|x| x * s2),
        duv: r[4].map(|x| x * s2),
        dvv: r[5].map(|x| x * s2),
        level: depth as u8,
    }
}
