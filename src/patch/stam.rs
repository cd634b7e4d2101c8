//! Exact evaluation of a quad with one smooth extraordinary corner in constant time (Stam,
//! SIGGRAPH 1998; paper 004 discusses it).
//!
//! A quad whose corner `c` is an interior vertex of valence `n` and whose other corners are
//! regular, all around it smooth quads (no sharpness, no holes), has a limit surface that
//! depends only on the `K = 2n + 8` vertices of its one-ring, gathered in a canonical order by
//! [`gather`]. One subdivision step maps them to the `K` vertices of the same configuration
//! around the child quad at the extraordinary corner: `C₁ = A C₀` (a `K × K` matrix); the
//! other three children are regular bicubic B-spline patches, with control points `B_q C₀`
//! (`q = 1, 2, 3`, `16 × K`). A point with `max(s, t) ∈ [2^-m, 2^-(m-1))` (the extraordinary
//! corner at `(0, 0)`) lies in child `q` of the `(m−1)`-th descendant at the corner, so its
//! patch has control points `B_q A^(m-1) C₀`.
//!
//! `A` and `B_q` are not typed in: they are the library's own refinement ([`step::refine`],
//! [`classify`]) of a generated valence-`n` neighbourhood ([`generate::star`]), read off the
//! stencil rows, so they follow exactly the rules on-demand subdivision uses. Instead of an
//! eigen-decomposition the products `W[m][q] = B_q A^(m-1)` are tabulated for `m = 1..=`
//! [`MAX_DEPTH`] once per valence and shared process-wide ([`basis`]); this is exact for every
//! valence (no defective eigenstructure to worry about) and costs one `16 × K` product per
//! query. Beyond [`MAX_DEPTH`] levels, and at the corner itself, the corner's exact limit
//! position applies.

use super::bspline::{self, ControlGrid, PatchPoint, PointD1};
use super::local::child_face;
use super::regular::{classify, RegularKind};
use super::table::tree::{descend, Frame};
use crate::mesh::{generate, CreaseMethod, Options};
use crate::refine::limit::vertex_limit_masks;
use crate::refine::{step, Level};
use std::collections::HashMap;
use std::sync::{Arc, OnceLock};

/// Largest valence evaluated by Stam's method; end caps at higher valences are subdivided on
/// demand.
pub const MAX_VALENCE: usize = 50;

/// Levels tabulated; points closer than 2^-60 of the patch to the extraordinary corner take
/// its exact limit position (as on-demand subdivision does).
pub const MAX_DEPTH: usize = 60;

/// Levels tabulated when the matrices are built; deeper ones, which only points within
/// 2^-8 of the patch of the extraordinary corner need (dicing rates above 256, or queries
/// at arbitrary points), on first use.
const SHALLOW: usize = 8;

/// The tabulated matrices of one valence.
#[derive(Debug)]
pub struct StamBasis {
    /// Valence of the extraordinary vertex.
    pub valence: usize,
    /// Number of control points, `2n + 8`.
    pub size: usize,
    /// `W[m][q]` for `m = 1..=SHALLOW`, `q = 1..=3`, transposed: for each control point
    /// `i`, its 16 weights (one per patch point), at `((m − 1)·3 + q − 1)·16·size + 16 i`
    /// (this order lets the product run over 16 independent sums, which vectorise).
    weights: Vec<f64>,
    /// The same for `m = SHALLOW + 1..=MAX_DEPTH` (from `m = SHALLOW + 1`), tabulated on
    /// first use by continuing the products (the same bits as tabulating them at once).
    deep: OnceLock<Vec<f64>>,
    /// Limit position of the extraordinary vertex as weights over the control points.
    limit: Vec<f64>,
    /// The configuration's faces over the control points, as [`gather`] visits them.
    faces: Vec<LocalFace>,
    /// `A`, row-major `size × size`: one step maps the control points to those of the child
    /// quad at the extraordinary corner.
    step: Vec<f64>,
}

/// Appends the transposed weights of levels `depths` ([`StamBasis::weights`]) from `cur`, the
/// 16 rows of each `q` at the first of them, multiplying the rows by `step` (`A`) after each
/// level below [`MAX_DEPTH`].
fn tabulate(
    weights: &mut Vec<f64>,
    cur: &mut [Vec<Vec<f64>>],
    step: &[f64],
    depths: std::ops::RangeInclusive<usize>,
) {
    let size = step.len().isqrt();
    let mut next = vec![0.0; size];
    for m in depths {
        for rows in cur.iter_mut() {
            for i in 0..size {
                weights.extend(rows.iter().map(|r| r[i]));
            }
            if m < MAX_DEPTH {
                for r in rows.iter_mut() {
                    times_step(r, step, &mut next);
                }
            }
        }
    }
}

/// `r ← r · A` for `A` = `step` (row-major, `r.len()` square), through `next`.
fn times_step(r: &mut [f64], step: &[f64], next: &mut [f64]) {
    next.iter_mut().for_each(|x| *x = 0.0);
    for (&ri, arow) in r.iter().zip(step.chunks_exact(r.len())) {
        if ri != 0.0 {
            for (x, &aij) in next.iter_mut().zip(arow) {
                *x += ri * aij;
            }
        }
    }
    r.copy_from_slice(next);
}

/// Walks the quads around vertex `v`, starting with face `f`, crossing each face's edge that
/// ends at `v` (the one from the corner before `v`), and calls `visit(face, corner of v)`.
/// Returns `None` unless the walk meets only quads that are not holes, crosses only manifold,
/// consistently oriented edges, and comes back to `f` after exactly `count` faces.
fn walk(
    level: &Level,
    v: u32,
    f: usize,
    count: usize,
    mut visit: impl FnMut(usize, usize),
) -> Option<()> {
    let topo = &level.topo;
    let quad = |g: usize| <&[u32; 4]>::try_from(topo.face_vertices(g)).ok();
    let mut g = f;
    let mut gv = quad(f)?;
    // Where `v` is in the face walked (in the next face, found when its edge is crossed).
    let mut j = gv.iter().position(|&x| x == v)?;
    for i in 0..count {
        if (i > 0 && g == f) || level.face_hole[g] {
            return None;
        }
        visit(g, j);
        let e = topo.face_edge_list(g)[(j + 3) % 4];
        let faces = topo.edge_face_list(e);
        if faces.len() != 2 || topo.edge_nonmanifold[e as usize] {
            return None;
        }
        let next = if faces[0] as usize == g {
            faces[1]
        } else {
            faces[0]
        } as usize;
        // The next face runs the shared edge the other way: v first, then gv[j + 3].
        let nv = quad(next)?;
        let k = nv.iter().position(|&x| x == v)?;
        if nv[(k + 1) % 4] != gv[(j + 3) % 4] {
            return None;
        }
        (g, gv, j) = (next, nv, k);
    }
    (g == f).then_some(())
}

/// Recognises Stam's configuration at face `f` of `level` and gathers its control points.
///
/// Returns the corner `c` of `f` that is extraordinary and the `2n + 8` vertices in canonical
/// order: the extraordinary vertex; for each face around it, starting with `f` and turning
/// from `f`'s corner `c + 1` towards `c + 3`, the face's vertex after it and the opposite one;
/// then the remaining vertices of the faces around corners `c + 1`, `c + 2`, `c + 3` (each
/// walked from `f` in the same sense, each face's vertices in order from that corner). `None`
/// unless: `f` is a quad, not a hole; exactly one corner is not an interior vertex of valence
/// 4, and it is interior, manifold, of valence `3..=MAX_VALENCE`; every face around the
/// corners is a quad, not a hole; no edge of those faces and none of the gathered vertices
/// has any sharpness; and the faces, written over the gathered vertices, are exactly those of
/// the canonical configuration of valence `n` (so the neighbourhood is that configuration, not
/// one with vertices shared in other ways).
///
/// The canonical configuration guides the gathering: each face walked writes its vertices
/// into the slots its canonical face names, and a vertex found in a slot already filled must
/// be the one there. The answer is the searching one's (the faces walked collected, each
/// face's vertices found among those gathered, then the faces compared with the
/// configuration's: a test checks that both agree), without the searches and without
/// collecting the faces.
pub fn gather(level: &Level, f: usize) -> Option<(usize, Vec<u32>)> {
    let (c, ev, n) = stam_corner(level, f)?;
    let topo = &level.topo;
    let fv = topo.face_vertices(f);
    let canonical = &basis_ref(n).faces;
    // On the stack (two vectors a call took a tenth of its time).
    let mut all = [u32::MAX; 2 * MAX_VALENCE + 8];
    let out = &mut all[..2 * n + 8];
    out[0] = ev;
    // Faces walked so far; whether every vertex went to a free slot or to its own; whether
    // every edge of the faces walked is smooth.
    let (mut walked, mut consistent, mut smooth_edges) = (0, true, true);
    let mut visit = |g: usize, j: usize| {
        let gv = topo.face_vertices(g);
        smooth_edges &= topo
            .face_edge_list(g)
            .iter()
            .all(|&e| level.edge_sharpness[e as usize] == 0.0);
        match canonical.get(walked) {
            Some(local) => {
                for (i, &slot) in local.iter().enumerate() {
                    let x = gv[(j + i) % 4];
                    let at = &mut out[slot as usize];
                    if *at == u32::MAX {
                        *at = x;
                    } else if *at != x {
                        consistent = false;
                    }
                }
            }
            None => consistent = false,
        }
        walked += 1;
    };
    walk(level, ev, f, n, &mut visit)?;
    for k in 1..4 {
        walk(level, fv[(c + k) % 4], f, 4, &mut visit)?;
    }
    if !consistent || walked != canonical.len() || out.contains(&u32::MAX) {
        return None;
    }
    // Distinct vertices (a vertex in two slots is another configuration).
    let mut copy = all;
    let sorted = &mut copy[..2 * n + 8];
    sorted.sort_unstable();
    if sorted.windows(2).any(|w| w[0] == w[1]) {
        return None;
    }
    let out = &all[..2 * n + 8];
    // No sharpness on the walked faces' edges (checked as they were walked) or the gathered
    // vertices.
    let smooth_verts = out
        .iter()
        .all(|&v| level.vertex_sharpness[v as usize] == 0.0);
    (smooth_edges && smooth_verts).then(|| (c, out.to_vec()))
}

/// A face of the configuration as positions in the gathered vertices, from the corner walked.
type LocalFace = [u8; 4];

/// The first checks of Stam's configuration at face `f` (see [`gather`]): `f` is a quad, not
/// a hole; exactly one corner `c` is not an interior vertex of valence 4, and that vertex
/// `ev` is interior, manifold, of valence `n` in `3..=MAX_VALENCE`; no edge at `ev` and no
/// corner of `f` is sharp. Returns `(c, ev, n)`.
fn stam_corner(level: &Level, f: usize) -> Option<(usize, u32, usize)> {
    let topo = &level.topo;
    let fv = topo.face_vertices(f);
    if fv.len() != 4 || level.face_hole[f] {
        return None;
    }
    let interior = |v: u32| {
        let t = topo.vert_tags[v as usize];
        !t.boundary && !t.nonmanifold
    };
    let valence = |v: u32| topo.vertex_edges(v as usize).len();
    let mut irregular = (0..4).filter(|&k| !(interior(fv[k]) && valence(fv[k]) == 4));
    let (Some(c), None) = (irregular.next(), irregular.next()) else {
        return None;
    };
    let ev = fv[c];
    let n = valence(ev);
    if !interior(ev) || !(3..=MAX_VALENCE).contains(&n) || topo.vertex_faces(ev as usize).len() != n
    {
        return None;
    }
    // A sharp edge at the extraordinary vertex or a sharp corner of the face: refused by the
    // smoothness test after the walk (which the faces beside a crease, isolated level after
    // level, paid every time).
    let sharp_edge = |e: &u32| level.edge_sharpness[*e as usize] != 0.0;
    if topo.vertex_edges(ev as usize).iter().any(sharp_edge)
        || fv
            .iter()
            .any(|&v| level.vertex_sharpness[v as usize] != 0.0)
    {
        return None;
    }
    Some((c, ev, n))
}

/// [`gather`] without the comparison with the canonical configuration; also returns the faces
/// visited (in visiting order) over the gathered vertices.
fn gather_faces(level: &Level, f: usize) -> Option<(usize, Vec<u32>, Vec<LocalFace>)> {
    let topo = &level.topo;
    let fv = topo.face_vertices(f);
    let (c, ev, n) = stam_corner(level, f)?;
    let mut out = vec![ev];
    let mut faces = Vec::with_capacity(n + 12);
    walk(level, ev, f, n, |g, j| {
        let gv = topo.face_vertices(g);
        out.push(gv[(j + 1) % 4]);
        out.push(gv[(j + 2) % 4]);
        faces.push((g, j));
    })?;
    for k in 1..4 {
        let w = fv[(c + k) % 4];
        walk(level, w, f, 4, |g, j| {
            let gv = topo.face_vertices(g);
            for i in 1..4 {
                let x = gv[(j + i) % 4];
                if !out.contains(&x) {
                    out.push(x);
                }
            }
            faces.push((g, j));
        })?;
    }
    if out.len() != 2 * n + 8 {
        return None;
    }
    let mut sorted = out.clone();
    sorted.sort_unstable();
    sorted.dedup();
    if sorted.len() != out.len() {
        return None;
    }
    let mut local = Vec::with_capacity(faces.len());
    for &(g, j) in &faces {
        let gv = topo.face_vertices(g);
        let mut lf = [0u8; 4];
        for (i, x) in lf.iter_mut().enumerate() {
            *x = out.iter().position(|&y| y == gv[(j + i) % 4])? as u8;
        }
        local.push(lf);
    }
    let smooth_edges = faces.iter().all(|&(g, _)| {
        topo.face_edge_list(g)
            .iter()
            .all(|&e| level.edge_sharpness[e as usize] == 0.0)
    });
    let smooth_verts = out
        .iter()
        .all(|&v| level.vertex_sharpness[v as usize] == 0.0);
    (smooth_edges && smooth_verts).then_some((c, out, local))
}

impl StamBasis {
    /// Builds the matrices of valence `n` (3..=[`MAX_VALENCE`]) from the library's refinement of
    /// [`generate::star`]`(n, 3)`.
    pub fn new(n: usize) -> Self {
        assert!(
            (3..=MAX_VALENCE).contains(&n),
            "valence {n} outside 3..={MAX_VALENCE}"
        );
        let mesh = generate::star(n, 3);
        let (s0, _) = Level::base(&mesh, &Options::default()).expect("the star mesh is valid");
        let (c0, g0, faces) =
            gather_faces(&s0, 0).expect("face 0 of the star is Stam's configuration");
        assert_eq!(c0, 0);
        let size = g0.len();
        let (s1, table) = step::refine(&s0, CreaseMethod::Uniform);
        let (c1, g1, faces1) =
            gather_faces(&s1, child_face(&s0, 0, 0)).expect("so is its corner child");
        assert_eq!((c1, &faces1), (0, &faces));
        let col: HashMap<u32, usize> = g0.iter().enumerate().map(|(i, &v)| (v, i)).collect();
        // A child vertex as weights over the parent configuration; everything it reads must be
        // in the configuration (that is what makes it closed under subdivision).
        let row_of = |v: u32| -> Vec<f64> {
            let mut r = vec![0.0; size];
            let (idx, w) = table.row(v as usize);
            for (&i, &w) in idx.iter().zip(w) {
                let j = col
                    .get(&i)
                    .expect("the configuration is closed under refinement");
                r[*j] += w;
            }
            r
        };
        let a: Vec<Vec<f64>> = g1.iter().map(|&v| row_of(v)).collect();
        let mut weights = Vec::with_capacity(SHALLOW * 3 * 16 * size);
        let mut cur: Vec<Vec<Vec<f64>>> = (1..4)
            .map(|q| {
                let (kind, cps) = classify(&s1, child_face(&s0, 0, q), false)
                    .expect("the other children are regular");
                assert_eq!(kind, RegularKind::BSpline { closed: 0 });
                cps.iter()
                    .map(|combo| {
                        let mut r = vec![0.0; size];
                        for &(v, w) in combo {
                            for (x, y) in r.iter_mut().zip(row_of(v)) {
                                *x += w * y;
                            }
                        }
                        r
                    })
                    .collect()
            })
            .collect();
        // Level m needs B_q A^(m-1): store, then multiply by A for the next level.
        let step = a.concat();
        tabulate(&mut weights, &mut cur, &step, 1..=SHALLOW);
        let [pos, _, _] = vertex_limit_masks(&s0, 0, CreaseMethod::Uniform);
        let mut limit = vec![0.0; size];
        for (v, w) in pos {
            limit[*col.get(&v).expect("the limit mask reads the one-ring")] += w;
        }
        StamBasis {
            valence: n,
            size,
            weights,
            deep: OnceLock::new(),
            limit,
            faces,
            step,
        }
    }

    /// The transposed weights `W[m][q]` (see [`StamBasis::weights`]), `m` in
    /// `1..=MAX_DEPTH`, `q` in `1..=3`.
    fn weights_at(&self, m: usize, q: usize) -> &[f64] {
        let k = self.size;
        let (table, m) = if m <= SHALLOW {
            (&self.weights, m)
        } else {
            (self.deep.get_or_init(|| self.deeper()), m - SHALLOW)
        };
        &table[((m - 1) * 3 + q - 1) * 16 * k..][..16 * k]
    }

    /// The 16 rows of `W[m][q]` for each `q` (untransposed), `m` in `1..=SHALLOW`.
    fn rows_at(&self, m: usize) -> Vec<Vec<Vec<f64>>> {
        let k = self.size;
        (1..4)
            .map(|q| {
                let w = &self.weights[((m - 1) * 3 + q - 1) * 16 * k..][..16 * k];
                (0..16)
                    .map(|p| (0..k).map(|i| w[16 * i + p]).collect())
                    .collect()
            })
            .collect()
    }

    /// The weights of levels `SHALLOW + 1..=MAX_DEPTH`: the products continued from level
    /// `SHALLOW`'s rows.
    fn deeper(&self) -> Vec<f64> {
        let k = self.size;
        let mut cur = self.rows_at(SHALLOW);
        let mut next = vec![0.0; k];
        for rows in &mut cur {
            for r in rows.iter_mut() {
                times_step(r, &self.step, &mut next);
            }
        }
        let mut deep = Vec::with_capacity((MAX_DEPTH - SHALLOW) * 3 * 16 * k);
        tabulate(&mut deep, &mut cur, &self.step, SHALLOW + 1..=MAX_DEPTH);
        deep
    }

    /// The control points of the child quad at the extraordinary corner (`A · cps`): the
    /// corner's quarter of the patch is in their convex hull (every rule's weights are
    /// non-negative).
    pub(crate) fn corner_child(&self, cps: &[[f64; 3]]) -> Vec<[f64; 3]> {
        let k = self.size;
        (0..k)
            .map(|r| {
                let mut p = [0.0; 3];
                for (&w, c) in self.step[r * k..(r + 1) * k].iter().zip(cps) {
                    for i in 0..3 {
                        p[i] += w * c[i];
                    }
                }
                p
            })
            .collect()
    }

    /// The 16 control points of the regular patch `q` (1..=3) at level `m` (1..=MAX_DEPTH).
    pub(crate) fn grid(&self, m: usize, q: usize, cps: &[[f64; 3]]) -> ControlGrid {
        let w = self.weights_at(m, q);
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx") {
            // SAFETY: the CPU has AVX (checked just above).
            return unsafe { grid_avx(w, cps) };
        }
        grid_product(w, cps)
    }

    /// [`Self::grid`] through a small per-thread cache of the last sub-patches computed:
    /// dicing evaluates the points of one sub-patch one after another, and comparing the
    /// `2n + 8` control points (bit for bit) costs a sixteenth of the product.
    fn grid_recent(&self, m: usize, q: usize, cps: &[[f64; 3]]) -> ControlGrid {
        RECENT.with(|cell| {
            let mut cache = cell.borrow_mut();
            let same = |e: &Recent| {
                e.m == m
                    && e.q == q
                    && e.cps.len() == cps.len()
                    && e.cps
                        .iter()
                        .zip(cps)
                        .all(|(a, b)| (0..3).all(|i| a[i].to_bits() == b[i].to_bits()))
            };
            if let Some(e) = cache.entries.iter().find(|e| same(e)) {
                return e.grid;
            }
            let grid = self.grid(m, q, cps);
            let slot = cache.next;
            cache.next = (slot + 1) % RECENT_SIZE;
            if cache.entries.len() < RECENT_SIZE {
                cache.entries.push(Recent {
                    m,
                    q,
                    cps: cps.to_vec(),
                    grid,
                });
            } else {
                let e = &mut cache.entries[slot];
                (e.m, e.q, e.grid) = (m, q, grid);
                e.cps.clear();
                e.cps.extend_from_slice(cps);
            }
            grid
        })
    }

    /// Exact limit position of the extraordinary vertex.
    pub fn limit(&self, cps: &[[f64; 3]]) -> [f64; 3] {
        let mut acc = [0.0; 3];
        for (&wi, c) in self.limit.iter().zip(cps) {
            acc[0] += wi * c[0];
            acc[1] += wi * c[1];
            acc[2] += wi * c[2];
        }
        acc
    }

    /// Evaluates the patch of control points `cps` (in [`gather`]'s order) at `(s, t)`, with
    /// the extraordinary vertex at `(0, 0)` and `s` running towards the face's next corner.
    /// Returns the point with derivatives in `(s, t)`, and the level of the regular patch used
    /// (as on-demand subdivision counts it). At `(0, 0)` the position is the exact limit
    /// and the derivatives those at `(2^-10, 2^-10)`.
    pub fn eval(&self, cps: &[[f64; 3]], s: f64, t: f64) -> (PatchPoint, u8) {
        let (pt, frame, m) = self.eval_local(cps, s, t);
        (frame.face_point(pt), m)
    }

    /// [`Self::eval`] with the derivatives left in the regular sub-patch's own parameters,
    /// and that sub-patch's frame within the patch (so that a caller can compose frames and
    /// convert derivatives once).
    pub(crate) fn eval_local(&self, cps: &[[f64; 3]], s: f64, t: f64) -> (PatchPoint, Frame, u8) {
        let grid = &mut |m, q| self.grid_recent(m, q, cps);
        self.eval_local_by(cps, s, t, grid, bspline::eval)
    }

    /// [`Self::eval_local`]'s position and first derivatives, the same bits, for a third
    /// fewer multiply-adds; the regular sub-patch `(m, q)`'s control points come from
    /// `grid(m, q)`, which must return [`Self::grid`]'s (a caller evaluating many points of
    /// one patch keeps them; [`Self::eval_local_d1_recent`] looks them up in a small cache).
    pub(crate) fn eval_local_d1(
        &self,
        cps: &[[f64; 3]],
        s: f64,
        t: f64,
        grid: &mut impl FnMut(usize, usize) -> ControlGrid,
    ) -> (PointD1, Frame) {
        let (pt, frame, _) = self.eval_local_by(cps, s, t, grid, bspline::eval_d1);
        (pt, frame)
    }

    /// [`Self::eval_local`] with the sub-patches from `grid(m, q)` and the regular
    /// sub-patch evaluated by `eval` (with or without second derivatives).
    fn eval_local_by<P: Located>(
        &self,
        cps: &[[f64; 3]],
        s: f64,
        t: f64,
        grid: &mut impl FnMut(usize, usize) -> ControlGrid,
        eval: impl Fn(&ControlGrid, f64, f64) -> P + Copy,
    ) -> (P, Frame, u8) {
        debug_assert_eq!(cps.len(), self.size);
        if s == 0.0 && t == 0.0 {
            let (mut pt, frame, m) =
                self.eval_local_by(cps, CORNER_NUDGE, CORNER_NUDGE, grid, eval);
            pt.set_position(self.limit(cps));
            return (pt, frame, m);
        }
        match locate(s, t) {
            Some((m, q, s2, t2, frame)) => (eval(&grid(m, q), s2, t2), frame.child(q), m as u8),
            None => {
                let mut pt = P::default();
                pt.set_position(self.limit(cps));
                (pt, Frame::UNIT, MAX_DEPTH as u8)
            }
        }
    }

    /// [`Self::eval_local_d1`] with the sub-patches from the per-thread cache of the last
    /// ones computed.
    pub(crate) fn eval_local_d1_recent(
        &self,
        cps: &[[f64; 3]],
        s: f64,
        t: f64,
    ) -> (PointD1, Frame) {
        self.eval_local_d1(cps, s, t, &mut |m, q| self.grid_recent(m, q, cps))
    }
}

/// A patch point whose position can be replaced (the corner's exact limit), with or without
/// second derivatives.
trait Located: Default {
    fn set_position(&mut self, p: [f64; 3]);
}

impl Located for PatchPoint {
    fn set_position(&mut self, p: [f64; 3]) {
        self.p = p;
    }
}

impl Located for PointD1 {
    fn set_position(&mut self, p: [f64; 3]) {
        self.p = p;
    }
}

/// Where the exact corner's derivatives are taken: `(2^-10, 2^-10)`.
const CORNER_NUDGE: f64 = 1.0 / 1024.0;

/// The regular child of the Stam quadtree holding local `(s, t) ≠ (0, 0)` (the extraordinary
/// corner at `(0, 0)`): its depth `m`, its quadrant `q` within the `(m − 1)`-th corner
/// descendant, the point's parameters in it, and that descendant's frame within the patch.
/// `None` within `2^-MAX_DEPTH` of the corner, where the corner's limit position applies.
pub(crate) fn locate(s: f64, t: f64) -> Option<(usize, usize, f64, f64, Frame)> {
    let (mut s, mut t) = (s, t);
    let mut frame = Frame::UNIT;
    for m in 1..=MAX_DEPTH {
        let (q, s2, t2) = descend(s, t);
        if q != 0 {
            return Some((m, q, s2, t2, frame));
        }
        frame = frame.child(0);
        s = s2;
        t = t2;
    }
    None
}

/// How many levels [`StamBasis::eval_local`] descends for local `(s, t)` (the extraordinary
/// corner at `(0, 0)`): the `m` of the regular child that holds the point, [`MAX_DEPTH`]
/// where the corner's limit position applies.
pub(crate) fn depth(s: f64, t: f64) -> u8 {
    let (s, t) = if s == 0.0 && t == 0.0 {
        (CORNER_NUDGE, CORNER_NUDGE)
    } else {
        (s, t)
    };
    locate(s, t).map_or(MAX_DEPTH, |(m, ..)| m) as u8
}

/// Sub-patch grids kept per thread by [`StamBasis::grid_recent`].
const RECENT_SIZE: usize = 16;

/// One cached sub-patch: depth `m`, child `q`, the control points it was computed from.
struct Recent {
    m: usize,
    q: usize,
    cps: Vec<[f64; 3]>,
    grid: ControlGrid,
}

/// The cache of [`StamBasis::grid_recent`], oldest entry replaced first.
#[derive(Default)]
struct RecentGrids {
    entries: Vec<Recent>,
    next: usize,
}

thread_local! {
    static RECENT: std::cell::RefCell<RecentGrids> = std::cell::RefCell::new(RecentGrids::default());
}

/// `Σ_i cps[i] · w[16 i + p]` for the 16 patch points `p`: 48 independent sums, which the
/// compiler vectorises (the same operations in the same order on every path, so results do
/// not depend on the CPU).
#[inline(always)]
fn grid_product(w: &[f64], cps: &[[f64; 3]]) -> ControlGrid {
    let (mut x, mut y, mut z) = ([0.0; 16], [0.0; 16], [0.0; 16]);
    for (wi, c) in w.chunks_exact(16).zip(cps) {
        for p in 0..16 {
            x[p] += wi[p] * c[0];
            y[p] += wi[p] * c[1];
            z[p] += wi[p] * c[2];
        }
    }
    std::array::from_fn(|p| [x[p], y[p], z[p]])
}

/// [`grid_product`] with AVX: four patch points' sums of one coordinate in a register, twelve
/// registers for the 48 sums, each control point's coordinates broadcast once. The same
/// operations in the same order (a product, then its sum, term by term from zero, without
/// fused multiply-adds), so the same bits; the compiler's own vectorisation of
/// [`grid_product`] interleaved the three coordinates with shuffles and spills, about three
/// times the instructions.
///
/// # Safety
/// The CPU must support AVX.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx")]
unsafe fn grid_avx(w: &[f64], cps: &[[f64; 3]]) -> ControlGrid {
    use std::arch::x86_64::*;
    let mut acc = [[_mm256_setzero_pd(); 4]; 3];
    for (wi, c) in w.chunks_exact(16).zip(cps) {
        // SAFETY: `wi` holds 16 values, read four at a time (unaligned loads).
        let wv: [__m256d; 4] =
            std::array::from_fn(|r| unsafe { _mm256_loadu_pd(wi[4 * r..].as_ptr()) });
        for (a, &x) in acc.iter_mut().zip(c) {
            let x = _mm256_set1_pd(x);
            for r in 0..4 {
                a[r] = _mm256_add_pd(a[r], _mm256_mul_pd(wv[r], x));
            }
        }
    }
    let mut sums = [[0.0f64; 16]; 3];
    for (out, a) in sums.iter_mut().zip(&acc) {
        for r in 0..4 {
            // SAFETY: four values written at `4r` of a 16-value array.
            unsafe { _mm256_storeu_pd(out[4 * r..].as_mut_ptr(), a[r]) };
        }
    }
    std::array::from_fn(|p| [sums[0][p], sums[1][p], sums[2][p]])
}

/// The tabulated matrices of valence `n` (3..=[`MAX_VALENCE`]), built on first use and
/// shared by every table in the process.
pub fn basis(n: usize) -> Arc<StamBasis> {
    basis_ref(n).clone()
}

/// [`basis`] borrowed: no lock and no reference count to touch (every Stam face's gathering
/// reads its valence's configuration, from every worker at once).
fn basis_ref(n: usize) -> &'static Arc<StamBasis> {
    static CACHE: [OnceLock<Arc<StamBasis>>; MAX_VALENCE + 1] =
        [const { OnceLock::new() }; MAX_VALENCE + 1];
    assert!(
        (3..=MAX_VALENCE).contains(&n),
        "valence {n} outside 3..={MAX_VALENCE}"
    );
    CACHE[n].get_or_init(|| Arc::new(StamBasis::new(n)))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::coord::FaceCoord;
    use crate::harness::rng::SplitMix64;
    use crate::mesh::{shapes, ControlMesh};
    use crate::patch::table::{PatchKind, PatchOptions, PatchTable, Sample};

    /// Valences checked: every small one and a few large ones.
    const VALENCES: [usize; 13] = [3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 16, 24, 50];

    /// The levels tabulated on first use are those of one run of products from level 1, bit
    /// for bit (the rows at level 1 continued to `MAX_DEPTH` at once).
    #[test]
    fn deep_levels_are_the_products_continued() {
        for n in [3, 5, 7, 16] {
            let b = StamBasis::new(n);
            let k = b.size;
            assert!(b.deep.get().is_none(), "deep levels tabulated early");
            let mut cur = b.rows_at(1);
            let mut all = Vec::new();
            tabulate(&mut all, &mut cur, &b.step, 1..=MAX_DEPTH);
            for m in 1..=MAX_DEPTH {
                for q in 1..4 {
                    let want = &all[((m - 1) * 3 + q - 1) * 16 * k..][..16 * k];
                    let got = b.weights_at(m, q);
                    assert!(
                        got.iter()
                            .zip(want)
                            .all(|(x, y)| x.to_bits() == y.to_bits()),
                        "valence {n}, level {m}, sub-patch {q}"
                    );
                }
            }
        }
    }

    /// The AVX product is the scalar one bit for bit: on the tabulated weights (levels 1 and
    /// `MAX_DEPTH`) of every valence checked but 4 (regular: no Stam patch), and on random weights
    /// and points of mixed signs and magnitudes, signed zeros and subnormals among them (the sums'
    /// order and roundings, and the signs of zero sums, must all agree).
    #[test]
    fn grid_avx_is_grid_product() {
        if !std::arch::is_x86_feature_detected!("avx") {
            println!("note: no AVX on this CPU; grid_avx not checked");
            return;
        }
        let mut rng = SplitMix64::new(7);
        let value = |rng: &mut SplitMix64| match rng.next_u64() % 8 {
            0 => 0.0,
            1 => -0.0,
            2 => {
                f64::MIN_POSITIVE
                    * rng.next_f64()
                    * if rng.next_u64().is_multiple_of(2) {
                        1.0
                    } else {
                        -1.0
                    }
            }
            3 => (rng.next_f64() - 0.5) * 1e12,
            _ => rng.next_f64() * 2.0 - 1.0,
        };
        let bits = |g: ControlGrid| g.map(|p| p.map(f64::to_bits));
        let mut cases = 0;
        let valences: Vec<usize> = VALENCES.into_iter().filter(|&n| n != 4).collect();
        for &n in &valences {
            let b = StamBasis::new(n);
            let cps: Vec<[f64; 3]> = (0..b.size)
                .map(|_| std::array::from_fn(|_| value(&mut rng)))
                .collect();
            for (m, q) in [(1, 1), (1, 2), (1, 3), (MAX_DEPTH, 1), (MAX_DEPTH, 3)] {
                let w = b.weights_at(m, q);
                // SAFETY: AVX checked above.
                let got = unsafe { grid_avx(w, &cps) };
                assert_eq!(
                    bits(got),
                    bits(grid_product(w, &cps)),
                    "valence {n} ({m}, {q})"
                );
                cases += 1;
            }
        }
        for k in [1, 2, 14, 17, 58] {
            for _ in 0..50 {
                let w: Vec<f64> = (0..16 * k).map(|_| value(&mut rng)).collect();
                let cps: Vec<[f64; 3]> = (0..k)
                    .map(|_| std::array::from_fn(|_| value(&mut rng)))
                    .collect();
                // SAFETY: AVX checked above.
                let got = unsafe { grid_avx(&w, &cps) };
                assert_eq!(bits(got), bits(grid_product(&w, &cps)), "{k} points");
                cases += 1;
            }
        }
        assert_eq!(cases, valences.len() * 5 + 250);
    }

    #[test]
    fn basis_is_affine_and_closed() {
        for n in VALENCES {
            if n == 4 {
                continue;
            }
            let b = StamBasis::new(n);
            assert_eq!(b.size, 2 * n + 8);
            // Subdivision reproduces constants: every row of W[m][q] and the limit mask sum
            // to 1 (to rounding accumulated over 60 products of K terms).
            let blocks = (1..=MAX_DEPTH).flat_map(|m| (1..4).map(move |q| (m, q)));
            for block in blocks.map(|(m, q)| b.weights_at(m, q)) {
                for p in 0..16 {
                    let row: Vec<f64> = (0..b.size).map(|i| block[16 * i + p]).collect();
                    let sum: f64 = row.iter().sum();
                    assert!((sum - 1.0).abs() < 1e-12, "valence {n}: row sums to {sum}");
                    assert!(
                        row.iter().all(|&w| w > -1e-15),
                        "valence {n}: negative weight"
                    );
                }
            }
            assert!((b.limit.iter().sum::<f64>() - 1.0).abs() < 1e-14);
        }
    }

    /// [`gather`] (guided by the canonical configuration) answers as the searching reference
    /// does ([`gather_faces`], then the comparison of its faces with the configuration's):
    /// the same corner and vertices, or `None` both, on every face of two levels of stars of
    /// many valences (their faces rotated), of shapes with boundaries, creases, corners,
    /// n-gons and triangles, and of small closed grids whose rings wrap onto themselves
    /// (vertices shared in other ways), with random sharpness on some edges and vertices.
    #[test]
    fn guided_gathering_is_the_searching_one() {
        use crate::refine::{step, Level};
        let reference = |level: &Level, f: usize| {
            let (c, out, faces) = gather_faces(level, f)?;
            (faces == basis((out.len() - 8) / 2).faces).then_some((c, out))
        };
        let mut meshes: Vec<ControlMesh> = [3, 5, 6, 7, 12]
            .iter()
            .map(|&n| jittered_star(n, n as u64))
            .collect();
        meshes.extend([
            generate::star(4, 2),
            generate::grid(3),
            shapes::rounded_box(2.5),
            shapes::blob(),
            shapes::gear(6),
            shapes::spindle(5),
            shapes::edited_box(),
            shapes::cyclorama(2.0, 1.0, 1.0),
            shapes::triangulated(&shapes::rounded_box(0.0)),
        ]);
        let merged = meshes.len();
        // Stars with two vertices of one configuration merged (vertices not of one face, in
        // the rings around the face's regular corners): rings that share vertices in other
        // ways than the configuration's.
        for n in [3, 5, 6] {
            let star = jittered_star(n, 40 + n as u64);
            let (level, _) = Level::base(&star, &star.options).unwrap();
            let (_, ring) = (0..level.num_faces())
                .find_map(|f| reference(&level, f))
                .expect("a star has Stam's configuration");
            for i in 5..ring.len() {
                for j in i + 1..ring.len() {
                    let (a, b) = (ring[i], ring[j]);
                    let mut m = star.clone();
                    let together = (0..m.num_faces()).any(|f| {
                        let fv = &m.face_verts
                            [m.face_offsets[f] as usize..m.face_offsets[f + 1] as usize];
                        fv.contains(&a) && fv.contains(&b)
                    });
                    // No shared neighbour either (the merge would join two edges).
                    let nbrs = |x: u32| {
                        let mut out = Vec::new();
                        for f in 0..m.num_faces() {
                            let fv = &m.face_verts
                                [m.face_offsets[f] as usize..m.face_offsets[f + 1] as usize];
                            if let Some(k) = fv.iter().position(|&y| y == x) {
                                out.push(fv[(k + 1) % fv.len()]);
                                out.push(fv[(k + fv.len() - 1) % fv.len()]);
                            }
                        }
                        out
                    };
                    let (na, nb) = (nbrs(a), nbrs(b));
                    if !together && !na.iter().any(|x| nb.contains(x)) {
                        m.face_verts
                            .iter_mut()
                            .filter(|v| **v == b)
                            .for_each(|v| *v = a);
                        meshes.push(m);
                    }
                }
            }
        }
        let mut rng = SplitMix64::new(5);
        let (mut found, mut refused) = (0, 0);
        for (i, mesh) in meshes.iter().enumerate() {
            let Ok((mut level, _)) = Level::base(mesh, &mesh.options) else {
                continue;
            };
            if i >= merged {
                // A merged vertex is non-manifold, so sharp, which refuses every configuration
                // it is in before the sharing is looked at: its tag is cleared here.
                level.vertex_sharpness.fill(0.0);
            }
            for depth in 0..3 {
                // Every third level of every other mesh with random tags.
                if (i + depth) % 3 == 2 {
                    for x in level.edge_sharpness.iter_mut() {
                        if rng.next_f64() < 0.05 {
                            *x = (rng.next_f64() * 3.0) as f32;
                        }
                    }
                    for x in level.vertex_sharpness.iter_mut() {
                        if rng.next_f64() < 0.03 {
                            *x = 1.5;
                        }
                    }
                }
                for f in 0..level.num_faces() {
                    let want = reference(&level, f);
                    assert_eq!(gather(&level, f), want, "mesh {i}, level {depth}, face {f}");
                    match want {
                        Some(_) => found += 1,
                        None => refused += 1,
                    }
                }
                level = step::refine(&level, mesh.options.crease_method).0;
            }
        }
        assert!(
            found > 1000 && refused > 1000,
            "{found} found, {refused} refused"
        );
    }

    /// `star(n, 3)` with jittered positions and each face's vertex list rotated by its index
    /// (so the extraordinary vertex sits at every corner of some patch).
    fn jittered_star(n: usize, seed: u64) -> ControlMesh {
        let mut m = generate::star(n, 3);
        let mut rng = SplitMix64::new(seed);
        for p in &mut m.positions {
            for c in p.iter_mut() {
                *c += 0.3 * (rng.next_f64() - 0.5);
            }
        }
        for f in 0..m.num_faces() {
            let (a, b) = (m.face_offsets[f] as usize, m.face_offsets[f + 1] as usize);
            m.face_verts[a..b].rotate_left(f % 4);
        }
        m
    }

    fn diagonal(m: &ControlMesh) -> f64 {
        let mut lo = [f64::MAX; 3];
        let mut hi = [f64::MIN; 3];
        for p in &m.positions {
            for c in 0..3 {
                lo[c] = lo[c].min(p[c]);
                hi[c] = hi[c].max(p[c]);
            }
        }
        (0..3).map(|c| (hi[c] - lo[c]).powi(2)).sum::<f64>().sqrt()
    }

    fn count(table: &PatchTable, stam: bool) -> usize {
        table
            .patches
            .iter()
            .filter(|p| matches!(p.kind, PatchKind::Stam { .. }) == stam)
            .count()
    }

    /// Worst differences (position / diag, first and second derivatives / their tolerance).
    #[derive(Default, Debug)]
    struct Worst {
        p: f64,
        d1: f64,
        d2: f64,
        samples: usize,
    }

    /// Compares Stam evaluation with on-demand subdivision. Positions agree to 1e-12 of the
    /// bounding-box diagonal: both are sums of the same control points with weights that are
    /// products of the same masks, each rounding ~1e-16 relative, over at most 70 levels.
    /// Derivatives are those of a sub-patch at level `L` (in base-face parameters), i.e. control
    /// point differences scaled by 2^L (4^L for second derivatives): the same rounding allows
    /// 1e-12·diag·2^L (4^L), which is also a relative bound wherever the derivative is not
    /// smaller than that.
    ///
    /// Stam patches sit at the first level where the face is Stam's configuration, end caps
    /// at the maximum level; so at the corner itself (where both evaluate derivatives a fixed
    /// fraction of their own patch away) and within 2^-50 of it (where a corner at `u` or
    /// `v = 1` is a few `f64` ulps away: 1 − 2^-53 is the last value below 1, and a point
    /// nearer rounds onto the corner itself) only positions are compared (`exact_level`
    /// false).
    fn compare(a: &Sample, b: &Sample, diag: f64, exact_level: bool, w: &mut Worst) {
        let dist = |x: [f64; 3], y: [f64; 3]| {
            ((x[0] - y[0]).powi(2) + (x[1] - y[1]).powi(2) + (x[2] - y[2]).powi(2)).sqrt()
        };
        if !exact_level {
            let e = dist(a.p, b.p) / diag;
            assert!(e <= 1e-12, "position differs by {e:.2e} of the diagonal");
            w.p = w.p.max(e);
            w.samples += 1;
            return;
        }
        // On a line between sub-patches the two may report neighbouring levels (the quadtree
        // of a Stam patch is walked in its rotated frame): the finer one sets the scale.
        assert!(
            a.level.abs_diff(b.level) <= 1,
            "sub-patch levels {} and {}",
            a.level,
            b.level
        );
        let scale = 2f64.powi(a.level.max(b.level) as i32);
        let e = dist(a.p, b.p) / diag;
        let e1 = dist(a.du, b.du).max(dist(a.dv, b.dv)) / (diag * scale);
        let e2 = dist(a.duu, b.duu)
            .max(dist(a.duv, b.duv))
            .max(dist(a.dvv, b.dvv))
            / (diag * scale * scale);
        assert!(e <= 1e-12, "position differs by {e:.2e} of the diagonal");
        assert!(e1 <= 1e-12, "first derivatives differ by {e1:.2e} (scaled)");
        assert!(
            e2 <= 1e-12,
            "second derivatives differ by {e2:.2e} (scaled)"
        );
        w.p = w.p.max(e);
        w.d1 = w.d1.max(e1);
        w.d2 = w.d2.max(e2);
        w.samples += 1;
    }

    /// Random points of face `f` near its corner `c`: at distance 2^-k, k up to 70; and
    /// whether the point is neither the corner nor within 2^-50 of it.
    fn near_corner(rng: &mut SplitMix64, f: u32, c: usize) -> (FaceCoord, bool) {
        let k = rng.below(71) as i32;
        let r = 2f64.powi(-k);
        let (s, t) = match rng.below(8) {
            0 => (0.0, 0.0),
            1 => (r, 0.0),
            2 => (0.0, r),
            _ => (r * rng.next_f64(), r * rng.next_f64()),
        };
        use crate::patch::table::tree::{CORNER, UAX, VAX};
        let at = |i: usize| CORNER[c][i] + s * UAX[c][i] + t * VAX[c][i];
        let away = (s, t) != (0.0, 0.0) && k < 50;
        (
            FaceCoord::quad(f, at(0).clamp(0.0, 1.0), at(1).clamp(0.0, 1.0)),
            away,
        )
    }

    #[test]
    fn stam_equals_on_demand_on_stars() {
        let mut worst = Worst::default();
        for n in VALENCES {
            let mesh = jittered_star(n, n as u64);
            let diag = diagonal(&mesh);
            let opts = PatchOptions::default();
            let stam = PatchTable::build(&mesh, mesh.options, opts, true).unwrap();
            let cap = PatchTable::build(&mesh, mesh.options, opts, false).unwrap();
            assert_eq!(count(&cap, true), 0);
            if n == 4 {
                assert_eq!(count(&stam, true), 0, "valence 4 is regular");
                continue;
            }
            // One Stam patch per face at the centre, where the end-cap table isolates them
            // down to one end cap each at the maximum level.
            assert_eq!(count(&stam, true), n, "valence {n}: Stam patches");
            let caps = cap
                .patches
                .iter()
                .filter(|p| matches!(p.kind, PatchKind::EndCap))
                .count();
            assert_eq!(caps, n, "valence {n}: end caps");
            assert!(count(&stam, false) < count(&cap, false), "fewer leaves");
            let mut rng = SplitMix64::new(1000 + n as u64);
            for i in 0..n {
                // Sector i's face at the centre, corner (i·9) % 4 after the rotation.
                let f = (i * 9) as u32;
                let c = (4 - (f as usize % 4)) % 4;
                for _ in 0..60 {
                    let (q, away) = near_corner(&mut rng, f, c);
                    let (a, b) = (stam.eval(q).unwrap(), cap.eval(q).unwrap());
                    compare(&a, &b, diag, away, &mut worst);
                }
            }
        }
        eprintln!("stars: {worst:?}");
    }

    #[test]
    fn stam_equals_on_demand_on_the_blob_and_after_reposing() {
        let mesh = shapes::blob();
        let opts = PatchOptions::default();
        let mut stam = PatchTable::build(&mesh, mesh.options, opts, true).unwrap();
        let mut cap = PatchTable::build(&mesh, mesh.options, opts, false).unwrap();
        assert!(count(&stam, true) > 0);
        // Only smooth valence-3, 5 and 6 corners: every end cap is a Stam patch.
        assert_eq!(count(&stam, false) + count(&stam, true), stam.patches.len());
        assert!(!stam
            .patches
            .iter()
            .any(|p| matches!(p.kind, PatchKind::EndCap)));
        let corners = crate::harness::eval::extraordinary_corners(&mesh, &stam).unwrap();
        let mut rng = SplitMix64::new(7);
        let mut positions = mesh.positions.clone();
        for pass in 0..2 {
            let diag = diagonal(&ControlMesh {
                positions: positions.clone(),
                ..ControlMesh::default()
            });
            let mut worst = Worst::default();
            for _ in 0..3000 {
                let (f, k, c) = corners[rng.below(corners.len())];
                let (mut q, away) = near_corner(&mut rng, f, c as usize);
                q.k = k;
                compare(
                    &stam.eval(q).unwrap(),
                    &cap.eval(q).unwrap(),
                    diag,
                    away,
                    &mut worst,
                );
            }
            eprintln!("blob pass {pass}: {worst:?}");
            // Re-pose: the Stam control points follow their stencils.
            for p in &mut positions {
                p[2] += 0.2 * p[0].sin();
            }
            stam.set_positions(&positions);
            cap.set_positions(&positions);
        }
    }

    #[test]
    fn sharpness_or_boundary_falls_back_to_end_caps() {
        // An infinitely sharp edge at the centre (a dart): it is in every centre face's
        // one-ring. (A semi-sharp one has decayed to 0 by the maximum level.)
        let mut mesh = generate::star(5, 3);
        mesh.creases.push(crate::mesh::EdgeCrease {
            v0: 0,
            v1: 1,
            sharpness: crate::mesh::SHARPNESS_INFINITE,
        });
        let t = PatchTable::new(&mesh, PatchOptions::default()).unwrap();
        assert_eq!(
            count(&t, true),
            0,
            "the crease is in every centre face's one-ring"
        );
        // A valence-5 vertex on the boundary: the star's rim vertex would be regular; use a
        // star with one sector removed (the centre becomes a boundary vertex of valence 5).
        let mut m = generate::star(6, 2);
        m.face_offsets.truncate(m.face_offsets.len() - 4);
        m.face_verts.truncate(m.face_verts.len() - 16);
        let t = PatchTable::new(&m, PatchOptions::default()).unwrap();
        assert_eq!(count(&t, true), 0);
        // Too high a valence.
        let t =
            PatchTable::new(&generate::star(MAX_VALENCE + 1, 2), PatchOptions::default()).unwrap();
        assert_eq!(count(&t, true), 0);
        assert!(t.patches.iter().any(|p| p.kind == PatchKind::EndCap));
    }
}
