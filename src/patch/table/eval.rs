//! Evaluation: the lookup of the leaf holding `(face, k, u, v)` in the quadtree, and the
//! evaluation of B-spline and single-crease leaves (end caps in `end_cap`).

use super::tree::{descend, Frame, Node, CORNER, UAX, VAX};
use super::{Patch, PatchKind, PatchTable, Sample};
use crate::coord::FaceCoord;
use crate::error::{Error, ErrorKind, Result};
use crate::patch::bspline::{self, ControlGrid, PatchPoint, PointD1};
use crate::patch::single_crease::{self, CreaseCurve};
use crate::patch::stam;

impl PatchTable {
    /// Evaluates the limit surface at `at`; errors when `at` is outside the domain or in a hole.
    pub fn eval(&self, at: FaceCoord) -> Result<Sample> {
        if let Some(approx) = &self.approx {
            return approx.eval_sub_quad(at);
        }
        if let Some(surface) = &self.loop_surface {
            return surface.eval_sub_quad(at);
        }
        self.check(at)?;
        if let Some(q) = &self.quad_approx {
            return q.eval(at);
        }
        let (patch, frame, s, t) = self.leaf(at)?;
        let (pt, local, extra) = self.eval_patch(patch, s, t);
        let pt = match local {
            Some(l) => frame.then(&l).face_point(pt),
            None => frame.face_point(pt),
        };
        Ok(Sample {
            p: pt.p,
            du: pt.du,
            dv: pt.dv,
            duu: pt.duu,
            duv: pt.duv,
            dvv: pt.dvv,
            level: patch.level + extra,
        })
    }

    /// [`Self::eval`]'s position alone, the same bits. On an exact Loop surface it skips the
    /// secants that stand in for the derivatives at an irregular vertex (two descents 24
    /// levels deep: [`crate::patch::LoopSurface::position`]); elsewhere it is
    /// [`Self::eval_d1`]'s position (no second derivatives).
    pub fn position(&self, at: FaceCoord) -> Result<[f64; 3]> {
        match (&self.approx, &self.loop_surface) {
            (None, Some(surface)) => surface.position_sub_quad(at),
            _ => Ok(self.eval_d1(at)?.p),
        }
    }

    /// [`Self::eval`]'s position and first derivatives, the same bits, without the second
    /// derivatives' work where the leaf is a B-spline patch (what dicing needs).
    pub fn eval_d1(&self, at: FaceCoord) -> Result<PointD1> {
        self.eval_d1_with(at, &mut Recent::default())
    }

    /// [`Self::eval_d1`] with the parts of leaves shared between points from `parts`.
    pub(super) fn eval_d1_with(
        &self,
        at: FaceCoord,
        parts: &mut impl LeafParts,
    ) -> Result<PointD1> {
        let d1 = |s: &Sample| PointD1 {
            p: s.p,
            du: s.du,
            dv: s.dv,
        };
        if self.approx.is_some() || self.loop_surface.is_some() {
            return self.eval(at).map(|s| d1(&s));
        }
        self.check(at)?;
        if self.quad_approx.is_some() {
            return self.eval(at).map(|s| d1(&s));
        }
        let (p, frame, s, t) = self.leaf_index(at)?;
        Ok(self.leaf_d1(p, frame, s, t, parts))
    }

    /// [`Self::eval_d1`] at `(s, t)` of leaf patch `p`, whose frame within its domain is
    /// `frame`; Stam patches' sub-patches and single-crease patches' crease pieces from
    /// `parts` (their own, whoever keeps them).
    pub(super) fn leaf_d1(
        &self,
        p: u32,
        frame: Frame,
        s: f64,
        t: f64,
        parts: &mut impl LeafParts,
    ) -> PointD1 {
        let patch = &self.patches[p as usize];
        let (pt, local) = match patch.kind {
            PatchKind::BSpline { .. } => (bspline::eval_d1(&self.grid(patch), s, t), None),
            PatchKind::SingleCrease { edge, sharpness } => {
                let curve = parts.curve(p, sharpness as f64);
                (
                    single_crease::eval_with_d1(&self.grid(patch), edge as usize, curve, s, t),
                    None,
                )
            }
            PatchKind::EndCap => {
                let (pt, _) = self.on_demand(&self.end_caps[patch.end_cap as usize], s, t);
                let d1 = PointD1 {
                    p: pt.p,
                    du: pt.du,
                    dv: pt.dv,
                };
                (d1, None)
            }
            PatchKind::Stam { valence, corner } => {
                let basis = self.stam_basis(valence);
                let first = patch.first_point as usize;
                let cps = &self.points[first..first + basis.size];
                let (rot, s1, t1) = stam_corner(corner, s, t);
                let (pt, sub) = parts.stam(p, basis, cps, s1, t1);
                (pt, Some(rot.then(&sub)))
            }
        };
        let frame = match local {
            Some(l) => frame.then(&l),
            None => frame,
        };
        frame.face_point_d1(pt)
    }

    /// Stam's matrices of `valence`.
    pub(super) fn stam_basis(&self, valence: u8) -> &stam::StamBasis {
        self.stam[valence as usize]
            .as_ref()
            .expect("the table holds the matrices of its Stam patches")
    }

    /// An error when `at` is outside the table's domains. Inlined, its error made apart
    /// ([`Self::check_error`]): called out of line, a `FaceCoord` stored by its caller field
    /// by field is read back with wider loads, a store-forwarding stall a point.
    #[inline(always)]
    pub(super) fn check(&self, at: FaceCoord) -> Result<()> {
        let (face, k, u, v) = (at.face as usize, at.k as usize, at.u, at.v);
        let inside = face < self.num_faces()
            && k < self.sub_faces(face)
            && (0.0..=1.0).contains(&u)
            && (0.0..=1.0).contains(&v);
        if inside {
            Ok(())
        } else {
            Err(self.check_error(at))
        }
    }

    /// [`Self::check`]'s error: what is out of range at `at`.
    #[cold]
    #[inline(never)]
    fn check_error(&self, at: FaceCoord) -> Error {
        let (face, k, u, v) = (at.face as usize, at.k as usize, at.u, at.v);
        if face >= self.num_faces() {
            return Error::new(ErrorKind::Usage, format!("face {face} out of range"));
        }
        if k >= self.sub_faces(face) {
            return Error::new(
                ErrorKind::Usage,
                format!(
                    "face {face} has {} sub-face(s); k = {k} is out of range",
                    self.sub_faces(face)
                ),
            );
        }
        Error::new(
            ErrorKind::Usage,
            format!("(u, v) = ({u}, {v}) is outside [0, 1]²"),
        )
    }

    /// The leaf of the quadtree holding `at` (in range), its frame and `at` in the leaf's
    /// `(s, t)`; an error in a hole.
    fn leaf(&self, at: FaceCoord) -> Result<(&Patch, Frame, f64, f64)> {
        let (p, frame, s, t) = self.leaf_index(at)?;
        Ok((&self.patches[p as usize], frame, s, t))
    }

    /// [`Self::leaf`] with the patch's index.
    fn leaf_index(&self, at: FaceCoord) -> Result<(u32, Frame, f64, f64)> {
        self.find_leaf(at)
            .ok_or_else(|| Error::new(ErrorKind::Usage, format!("face {} is a hole", at.face)))
    }

    /// [`Self::leaf_index`], `None` in a hole.
    #[inline(always)]
    pub(super) fn find_leaf(&self, at: FaceCoord) -> Option<(u32, Frame, f64, f64)> {
        self.descend_to_leaf::<true>(at)
    }

    /// [`Self::find_leaf`] without the frame (the leaf's [`Patch::frame`] is the same).
    #[inline(always)]
    pub(super) fn find_leaf_unframed(&self, at: FaceCoord) -> Option<(u32, f64, f64)> {
        self.descend_to_leaf::<false>(at)
            .map(|(p, _, s, t)| (p, s, t))
    }

    /// [`Self::find_leaf`], the frame followed down only with `FRAME` (the unit frame is
    /// returned otherwise).
    #[inline(always)]
    fn descend_to_leaf<const FRAME: bool>(&self, at: FaceCoord) -> Option<(u32, Frame, f64, f64)> {
        let (face, k) = (at.face as usize, at.k as usize);
        let mut node = self.nodes[self.roots[self.root_offsets[face] as usize + k] as usize];
        let mut frame = Frame::UNIT;
        let (mut s, mut t) = (at.u, at.v);
        loop {
            match node {
                Node::Empty => return None,
                Node::Inner(c) => {
                    let (q, s2, t2) = descend(s, t);
                    if FRAME {
                        frame = frame.child(q);
                    }
                    s = s2;
                    t = t2;
                    node = self.kids[c as usize][q];
                }
                Node::Leaf(p) => return Some((p, frame, s, t)),
            }
        }
    }

    /// Under the Loop scheme, the surface (exact or approximate) at `(face, 0, u, v)` in
    /// OpenSubdiv's triangle parameter, as `limitray eval` reads it; [`Self::eval`] takes
    /// the sub-quad domains dicing uses instead. An error for Catmull-Clark tables.
    pub fn eval_triangle(&self, at: FaceCoord) -> Result<Sample> {
        if let Some(approx) = &self.approx {
            return approx.eval(at);
        }
        match &self.loop_surface {
            Some(surface) => surface.eval(at),
            None => Err(Error::new(
                ErrorKind::Usage,
                "the triangle parameter belongs to Loop surfaces; this one is Catmull-Clark",
            )),
        }
    }

    /// The subdivision level of the patch at `at`: [`Sample::level`] of [`Self::eval`], found
    /// by the quadtree lookup alone where the leaf is a B-spline or single-crease patch (whose
    /// level is its own), by evaluation elsewhere (end caps and Stam patches report how deep
    /// their evaluation went).
    #[inline]
    pub fn level_at(&self, at: FaceCoord) -> Result<u8> {
        if self.is_approximate() {
            return Ok(self.eval(at)?.level);
        }
        if let Some(surface) = &self.loop_surface {
            return surface.level_sub_quad(at);
        }
        let leaf = self
            .check(at)
            .ok()
            .and_then(|_| self.descend_to_leaf::<false>(at));
        if let Some((p, _, s, t)) = leaf {
            let patch = &self.patches[p as usize];
            match patch.kind {
                PatchKind::BSpline { .. } | PatchKind::SingleCrease { .. } => {
                    return Ok(patch.level);
                }
                // How deep Stam's evaluation goes depends on (s, t) alone.
                PatchKind::Stam { corner, .. } => {
                    let (_, s1, t1) = stam_corner(corner, s, t);
                    return Ok(patch.level + stam::depth(s1, t1));
                }
                PatchKind::EndCap => {}
            }
        }
        Ok(self.eval(at)?.level)
    }

    /// [`Self::level_at`], with the leaf around `at` where the levels of the points strictly
    /// inside it follow without a lookup ([`LeafLevels`]): the leaf's square with its level
    /// where the level is the leaf's own (a B-spline or single-crease leaf); a Stam leaf's
    /// square, whose points' levels are the leaf's plus the depth of their sub-patch. A point
    /// strictly inside a leaf's square reaches that leaf: the descents classify points exactly
    /// (each step subtracts a corner and doubles, exact operations on these values). Dicing
    /// reuses the leaf for the next triangles whose centres lie inside (no lookup each).
    #[inline]
    pub fn leaf_levels(&self, at: FaceCoord) -> Result<(u8, Option<LeafLevels>)> {
        if !self.is_approximate() && self.loop_surface.is_none() && self.check(at).is_ok() {
            if let Some((p, frame, s, t)) = self.descend_to_leaf::<true>(at) {
                let patch = &self.patches[p as usize];
                let square = square(&frame);
                match patch.kind {
                    PatchKind::BSpline { .. } | PatchKind::SingleCrease { .. } => {
                        return Ok((patch.level, Some(LeafLevels::Square(square, patch.level))));
                    }
                    PatchKind::Stam { corner, .. } => {
                        let side = square[2] - square[0];
                        let leaf = LeafLevels::Stam {
                            square,
                            origin: frame.o,
                            to_s: frame.a.map(|x| x / (side * side)),
                            to_t: frame.b.map(|x| x / (side * side)),
                            level: patch.level,
                            corner,
                        };
                        // A power-of-two side (as every leaf's is) along the axes: the leaf
                        // coordinates of the points inside follow exactly.
                        let dyadic = side > 0.0 && side.log2().fract() == 0.0;
                        let aligned = [frame.a, frame.b].iter().all(|x| {
                            (x[0] == 0.0 && x[1].abs() == side)
                                || (x[1] == 0.0 && x[0].abs() == side)
                        });
                        let (_, s1, t1) = stam_corner(corner, s, t);
                        let level = patch.level + stam::depth(s1, t1);
                        return Ok((level, (dyadic && aligned).then_some(leaf)));
                    }
                    PatchKind::EndCap => {}
                }
            }
        }
        Ok((self.level_at(at)?, None))
    }

    /// The level [`Self::level_at`] gives everywhere in domain `(face, k)` when the whole
    /// domain is one B-spline or single-crease patch; `None` otherwise (or out of range).
    pub fn domain_level(&self, face: usize, k: usize) -> Option<u8> {
        if face >= self.num_faces() || k >= self.sub_faces(face) {
            return None;
        }
        if self.is_approximate() {
            // One patch per triangle or level-1 quad: the level `eval` reports everywhere.
            return Some(1);
        }
        if self.loop_surface.is_some() {
            return None;
        }
        let patch = self.root_patch(face, k)?;
        matches!(
            patch.kind,
            PatchKind::BSpline { .. } | PatchKind::SingleCrease { .. }
        )
        .then_some(patch.level)
    }

    /// The patch of domain `(face, k)` when its quadtree is that one leaf (`face` and `k` in
    /// range).
    pub(super) fn root_patch(&self, face: usize, k: usize) -> Option<&Patch> {
        match self.nodes[self.roots[self.root_offsets[face] as usize + k] as usize] {
            Node::Leaf(p) => Some(&self.patches[p as usize]),
            _ => None,
        }
    }

    /// Evaluates many samples in parallel.
    pub fn eval_batch(&self, samples: &[FaceCoord]) -> Vec<Result<Sample>> {
        use rayon::prelude::*;
        samples.par_iter().map(|&at| self.eval(at)).collect()
    }

    /// The 16 control points of B-spline or single-crease patch `patch`: in place, or
    /// gathered from the vertices for a direct patch.
    pub(crate) fn grid(&self, patch: &Patch) -> std::borrow::Cow<'_, ControlGrid> {
        let first = patch.first_point as usize;
        if patch.direct {
            // `+ 0.0` as a stencil row of one unit term sums (`0 + 1·x`): the same bits,
            // the sign of a zero included.
            // One bounds check for the 16 indices, then one a vertex.
            let at: &[u32; 16] = self.direct[first..first + 16]
                .try_into()
                .expect("a direct patch has 16 vertices");
            std::borrow::Cow::Owned(at.map(|v| self.verts[v as usize].map(|x| x + 0.0)))
        } else {
            std::borrow::Cow::Borrowed(
                self.points[first..first + 16]
                    .try_into()
                    .expect("a B-spline or single-crease patch has 16 control points"),
            )
        }
    }

    /// Evaluates a leaf at local (s, t); returns the point (derivatives in the leaf's (s, t),
    /// or in the frame given within the leaf) and the number of on-demand levels used.
    fn eval_patch(&self, patch: &Patch, s: f64, t: f64) -> (PatchPoint, Option<Frame>, u8) {
        match patch.kind {
            PatchKind::BSpline { .. } => (bspline::eval(&self.grid(patch), s, t), None, 0),
            PatchKind::SingleCrease { edge, sharpness } => (
                single_crease::eval(&self.grid(patch), edge as usize, sharpness as f64, s, t),
                None,
                0,
            ),
            PatchKind::EndCap => {
                let (pt, extra) = self.on_demand(&self.end_caps[patch.end_cap as usize], s, t);
                (pt, None, extra)
            }
            PatchKind::Stam { valence, corner } => {
                let basis = self.stam_basis(valence);
                let first = patch.first_point as usize;
                let cps = &self.points[first..first + basis.size];
                // The extraordinary vertex to (0, 0): (s, t) = CORNER[c] + s'·UAX[c] + t'·VAX[c].
                let (rot, s1, t1) = stam_corner(corner, s, t);
                let (pt, sub, depth) = basis.eval_local(cps, s1, t1);
                (pt, Some(rot.then(&sub)), depth)
            }
        }
    }
}

/// Where [`PatchTable::leaf_d1`] gets the parts of a leaf that serve all its points: a
/// Stam patch's regular sub-patches, a single-crease patch's crease pieces.
pub(super) trait LeafParts {
    /// The crease pieces of sharpness `sharpness` (of single-crease patch `p`).
    fn curve(&mut self, p: u32, sharpness: f64) -> &CreaseCurve;
    /// [`stam::StamBasis::eval_local_d1`] of Stam patch `p` (matrices `basis`, control
    /// points `cps`) at local `(s, t)`.
    fn stam(
        &mut self,
        p: u32,
        basis: &stam::StamBasis,
        cps: &[[f64; 3]],
        s: f64,
        t: f64,
    ) -> (PointD1, Frame);
}

/// The parts of a single point's leaf: crease pieces built for it, Stam sub-patches from
/// the per-thread cache of recent ones.
#[derive(Default)]
struct Recent {
    curve: Option<CreaseCurve>,
}

impl LeafParts for Recent {
    fn curve(&mut self, _: u32, sharpness: f64) -> &CreaseCurve {
        self.curve.insert(CreaseCurve::new(sharpness))
    }
    fn stam(
        &mut self,
        _: u32,
        basis: &stam::StamBasis,
        cps: &[[f64; 3]],
        s: f64,
        t: f64,
    ) -> (PointD1, Frame) {
        basis.eval_local_d1_recent(cps, s, t)
    }
}

/// A leaf found by [`PatchTable::leaf_levels`], with what gives the levels of the points
/// strictly inside its square `[u0, v0, u1, v1]`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum LeafLevels {
    /// A leaf whose points all have its level.
    Square([f64; 4], u8),
    /// A Stam leaf: a point's level is the leaf's plus the depth of the sub-patch holding it,
    /// from its coordinates in the leaf (its frame's: from the leaf's corner `origin`, `s`
    /// and `t` grow by `to_s` and `to_t` per unit of `u` and `v`, each one component `±1 /
    /// side` and the other zero).
    Stam {
        /// The leaf's square.
        square: [f64; 4],
        /// The frame's origin.
        origin: [f64; 2],
        /// `s` per unit of `u` and of `v`.
        to_s: [f64; 2],
        /// `t` per unit of `u` and of `v`.
        to_t: [f64; 2],
        /// The leaf's level.
        level: u8,
        /// Its extraordinary corner.
        corner: u8,
    },
}

impl LeafLevels {
    /// The leaf's square.
    pub fn square(&self) -> [f64; 4] {
        match *self {
            LeafLevels::Square(square, _) | LeafLevels::Stam { square, .. } => square,
        }
    }

    /// The level [`PatchTable::level_at`] gives at `(u, v)` of the leaf's domain, for a point
    /// strictly inside the leaf's square; `None` outside.
    #[inline]
    pub fn level(&self, u: f64, v: f64) -> Option<u8> {
        let [u0, v0, u1, v1] = self.square();
        if !(u0 < u && u < u1 && v0 < v && v < v1) {
            return None;
        }
        match *self {
            LeafLevels::Square(_, level) => Some(level),
            LeafLevels::Stam {
                origin: [ou, ov],
                to_s,
                to_t,
                level,
                corner,
                ..
            } => {
                // The descent's leaf coordinates, exactly: a descent step subtracts a corner
                // only from a coordinate at least 1/2 and doubles, so each point's leaf
                // coordinates are exact images of `(u, v)`; here `u − ou` and `v − ov` are
                // those images scaled by the side (representable, so computed exactly), and
                // each is scaled back by a signed power of two of at least 1 (exact, no
                // underflow), plus a zero.
                let (du, dv) = (u - ou, v - ov);
                let s = du * to_s[0] + dv * to_s[1];
                let t = du * to_t[0] + dv * to_t[1];
                let (_, s1, t1) = stam_corner(corner, s, t);
                Some(level + stam::depth(s1, t1))
            }
        }
    }
}

/// The bounds `[u0, v0, u1, v1]` of frame `f`'s unit square: its corners `o`, `o + a`,
/// `o + b`, `o + a + b` (dyadic, so exact).
fn square(f: &Frame) -> [f64; 4] {
    let ends = |i: usize| {
        let c = [
            f.o[i],
            f.o[i] + f.a[i],
            f.o[i] + f.b[i],
            f.o[i] + f.a[i] + f.b[i],
        ];
        let lo = c.iter().copied().fold(f64::INFINITY, f64::min);
        let hi = c.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        (lo, hi)
    };
    let ((u0, u1), (v0, v1)) = (ends(0), ends(1));
    [u0, v0, u1, v1]
}

/// Patch `(s, t)` in the frame of a Stam patch whose extraordinary vertex is at corner
/// `corner`: the frame mapping the local square back to the patch, and the local `(s', t')`
/// with the extraordinary vertex at `(0, 0)`: `(s, t) = CORNER[c] + s'·UAX[c] + t'·VAX[c]`.
pub(super) fn stam_corner(corner: u8, s: f64, t: f64) -> (Frame, f64, f64) {
    let c = corner as usize;
    let rot = Frame {
        o: CORNER[c],
        a: UAX[c],
        b: VAX[c],
    };
    let d = [s - CORNER[c][0], t - CORNER[c][1]];
    let s1 = (d[0] * UAX[c][0] + d[1] * UAX[c][1]).clamp(0.0, 1.0);
    let t1 = (d[0] * VAX[c][0] + d[1] * VAX[c][1]).clamp(0.0, 1.0);
    (rot, s1, t1)
}

#[cfg(test)]
pub(super) mod tests {
    use crate::coord::FaceCoord;
    use crate::harness::rng::SplitMix64;
    use crate::patch::{PatchOptions, PatchTable};

    /// Tables with B-spline, single-crease, Stam and end-cap leaves (extraordinary vertices,
    /// semi-sharp creases, n-gons, and poles of valence 60, beyond Stam's tables).
    pub(in crate::patch::table) fn tables() -> Vec<PatchTable> {
        [
            crate::mesh::shapes::rounded_box(2.0),
            crate::mesh::shapes::gear(7),
            crate::mesh::shapes::blob(),
            crate::mesh::generate::grid(6),
            crate::mesh::shapes::spindle(60),
        ]
        .iter()
        .map(|mesh| PatchTable::new(mesh, PatchOptions::default()).unwrap())
        .collect()
    }

    /// A random domain `(face, k)` of `table`.
    fn random_domain(rng: &mut SplitMix64, table: &PatchTable) -> (usize, usize) {
        let f = rng.below(table.num_faces());
        (f, rng.below(table.sub_faces(f)))
    }

    /// A random point of a random domain of `table`.
    fn random_point(rng: &mut SplitMix64, table: &PatchTable) -> FaceCoord {
        let (f, k) = random_domain(rng, table);
        FaceCoord::new(f as u32, k as u32, rng.next_f64(), rng.next_f64())
    }

    /// `level_at` is `eval(..).level`, on meshes with B-spline, single-crease, Stam and
    /// end-cap leaves (extraordinary vertices, semi-sharp creases, n-gons).
    #[test]
    fn level_at_is_the_evaluated_level() {
        let mut rng = SplitMix64(8);
        let mut whole = 0;
        for table in tables() {
            for _ in 0..4000 {
                let at = random_point(&mut rng, &table);
                let want = table.eval(at).map(|s| s.level).ok();
                assert_eq!(table.level_at(at).ok(), want, "{at:?}");
                if let Some(l) = table.domain_level(at.face as usize, at.k as usize) {
                    assert_eq!(Some(l), want, "{at:?}");
                    whole += 1;
                }
            }
        }
        assert!(whole > 1000, "only {whole} samples in whole-patch domains");
    }

    /// `leaf_levels` gives `level_at`'s level, and where it gives a leaf, every point strictly
    /// inside the leaf's square (random ones, and ones a rounding step inside the corners)
    /// lies in that leaf and has the level the leaf gives it, `level_at`'s; the square is a
    /// dyadic square of the domain. Stam leaves are among them.
    #[test]
    fn leaf_levels_are_the_levels_inside() {
        let mut rng = SplitMix64(23);
        let (mut bounded, mut stam, mut inside_stam) = (0, 0, 0);
        for table in tables() {
            for _ in 0..3000 {
                let at = random_point(&mut rng, &table);
                let (level, leaf) = table.leaf_levels(at).unwrap();
                assert_eq!(Ok(level), table.level_at(at), "{at:?}");
                let Some(leaf) = leaf else {
                    continue;
                };
                bounded += 1;
                let stam_leaf = matches!(leaf, super::LeafLevels::Stam { .. });
                stam += usize::from(stam_leaf);
                let [u0, v0, u1, v1] = leaf.square();
                assert!(
                    u0 <= at.u && at.u <= u1 && v0 <= at.v && at.v <= v1,
                    "{at:?}"
                );
                let side = u1 - u0;
                assert!(side > 0.0 && side == v1 - v0 && side.log2().fract() == 0.0);
                let found = table.find_leaf(at).map(|l| l.0);
                let up = |x: f64| x.next_up();
                let down = |x: f64| x.next_down();
                let mut inside = vec![(up(u0), up(v0)), (down(u1), down(v1)), (up(u0), down(v1))];
                for _ in 0..8 {
                    let (x, y) = (rng.next_f64(), rng.next_f64());
                    inside.push((u0 + x * side, v0 + y * side));
                    // Near the leaf's corners too, where Stam's sub-patches are small.
                    inside.push((u0 + x * x * x * side, v0 + y * y * y * side));
                    inside.push((u1 - x * x * x * side, v1 - y * y * y * side));
                }
                for (u, v) in inside {
                    if !(u0 < u && u < u1 && v0 < v && v < v1) {
                        assert_eq!(leaf.level(u, v), None);
                        continue;
                    }
                    let p = FaceCoord::new(at.face, at.k, u, v);
                    assert_eq!(leaf.level(u, v).map(Ok), Some(table.level_at(p)), "{p:?}");
                    assert_eq!(table.find_leaf(p).map(|l| l.0), found, "{p:?} in {leaf:?}");
                    inside_stam += usize::from(stam_leaf);
                }
            }
        }
        assert!(bounded > 2500, "only {bounded} samples with a leaf");
        assert!(
            stam > 100 && inside_stam > 1000,
            "{stam} Stam leaves, {inside_stam} points"
        );
    }

    /// `eval_d1` is `eval`'s position and first derivatives bit for bit (signs of zeros
    /// included), on B-spline, single-crease, Stam and end-cap leaves, at random points and at
    /// the corners and edges of the domains, where dicing evaluates most.
    #[test]
    fn eval_d1_is_eval_bit_for_bit() {
        let bits = |p: [[f64; 3]; 3]| p.map(|v| v.map(f64::to_bits));
        let mut rng = SplitMix64(21);
        for table in tables() {
            for i in 0..4000 {
                let (f, k) = random_domain(&mut rng, &table);
                let (u, v) = if i % 2 == 0 {
                    (rng.next_f64(), rng.next_f64())
                } else {
                    // On the domain's lattice at rate 8: corners, edges and interior.
                    (rng.below(9) as f64 / 8.0, rng.below(9) as f64 / 8.0)
                };
                let at = FaceCoord::new(f as u32, k as u32, u, v);
                let full = table.eval(at).map(|s| bits([s.p, s.du, s.dv]));
                let d1 = table.eval_d1(at).map(|s| bits([s.p, s.du, s.dv]));
                assert_eq!(d1.ok(), full.ok(), "{at:?}");
            }
        }
    }

    /// `position` is `eval`'s position bit for bit, and refuses what `eval` refuses: on exact
    /// Loop surfaces (the blob's irregular vertices among them: every sub-quad's corners,
    /// its edges' points and random interior points), an approximate Loop surface and
    /// Catmull-Clark tables; out-of-range sub-quads and parameters are errors both ways.
    #[test]
    fn position_is_the_evaluations() {
        use crate::mesh::{shapes, Scheme};
        use crate::patch::approx::Approximation;
        let mut loop_blob = shapes::blob();
        loop_blob.options.scheme = Scheme::Loop;
        let mut loop_box = shapes::triangulated(&shapes::rounded_box(2.0));
        loop_box.options.scheme = Scheme::Loop;
        let mut all: Vec<PatchTable> = vec![
            PatchTable::new(&loop_blob, PatchOptions::default()).unwrap(),
            PatchTable::new(
                &loop_blob,
                PatchOptions {
                    surface: Approximation::Gregory,
                    ..PatchOptions::default()
                },
            )
            .unwrap(),
        ];
        all.push(PatchTable::new(&loop_box, PatchOptions::default()).unwrap());
        all.extend(tables());
        let mut r = SplitMix64::new(3);
        let mut checked = 0;
        for table in &all {
            for face in 0..table.num_faces() as u32 {
                for k in 0..table.sub_faces(face as usize) as u32 {
                    let mut at = vec![[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [1.0, 1.0], [0.5, 0.0]];
                    at.extend((0..4).map(|_| [r.next_f64(), r.next_f64()]));
                    for [u, v] in at {
                        let at = FaceCoord::new(face, k, u, v);
                        match (table.eval(at), table.position(at)) {
                            (Ok(s), Ok(p)) => {
                                assert_eq!(s.p.map(f64::to_bits), p.map(f64::to_bits), "{at:?}");
                                checked += 1;
                            }
                            (Err(a), Err(b)) => assert_eq!(a.to_string(), b.to_string()),
                            (a, b) => panic!("{at:?}: {:?} vs {:?}", a.err(), b.err()),
                        }
                    }
                }
            }
            for bad in [
                FaceCoord::new(0, 7, 0.5, 0.5),
                FaceCoord::new(0, 0, 1.5, 0.5),
            ] {
                // Both refuse the coordinate, with the same message (two `Ok`s would compare
                // equal as `None`s: each must be an error).
                let (a, b) = (table.eval(bad), table.position(bad));
                match (a, b) {
                    (Err(a), Err(b)) => assert_eq!(a.to_string(), b.to_string(), "{bad:?}"),
                    (a, b) => panic!("{bad:?} must be refused: {:?} vs {:?}", a.ok(), b.ok()),
                }
            }
        }
        assert!(checked > 10_000, "{checked} points");
    }
}
