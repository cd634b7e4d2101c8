//! A domain's lattice of points evaluated at once: [`PatchTable::eval`]'s position and first
//! derivatives at every interior point of `(i / nu, j / nv)`, the same bits as point by point,
//! with what the points of a leaf share (a B-spline's contracted columns, a Stam patch's
//! regular sub-patches, a single-crease patch's crease pieces, a leaf's control rows
//! contracted along its `s`) computed once per domain.

use super::eval::{stam_corner, LeafParts};
use super::tree::Frame;
use super::{PatchKind, PatchTable};
use crate::coord::FaceCoord;
use crate::patch::bspline::{self, ControlGrid, PointD1};
use crate::patch::single_crease::{self, CreaseCurve};
use crate::patch::stam::{self, StamBasis};

impl PatchTable {
    /// [`Self::eval_d1`] at the interior points of the lattice `(i / nu, j / nv)` of domain
    /// `(face, k)`, `0 < i < nu`, `0 < j < nv`, row by row from `j = 1`: the same bits as
    /// point by point at a fraction of the cost. A domain that is one B-spline patch contracts
    /// each lattice column once ([`bspline::eval_lattice`]); any other domain looks each
    /// point's leaf up and evaluates it with the leaf's shared parts kept for the domain.
    /// Returns `false`, evaluating nothing, for an approximate or Loop table, a domain out of
    /// range, or one with a hole at a lattice point (point-by-point evaluation names it).
    pub fn eval_domain_lattice(
        &self,
        face: usize,
        k: usize,
        nu: u32,
        nv: u32,
        out: impl FnMut(PointD1),
    ) -> bool {
        self.eval_domain_lattice_with::<true>(face, k, nu, nv, out)
    }

    /// [`Self::eval_domain_lattice`] with the derivatives (`D1`), or the positions alone
    /// (zero derivatives), the same bits: a B-spline leaf's, a single-crease leaf's and a Stam
    /// leaf's regular sub-patch's points are then summed without their derivatives
    /// ([`bspline::eval_lattice_p`] where the domain is one B-spline patch); other points are
    /// evaluated whole.
    pub(crate) fn eval_domain_lattice_with<const D1: bool>(
        &self,
        face: usize,
        k: usize,
        nu: u32,
        nv: u32,
        mut out: impl FnMut(PointD1),
    ) -> bool {
        if !self.exact_domain(face, k) {
            return false;
        }
        let root = (face as u32, k as u32);
        if !D1 && self.eval_domain_lattice_p(root, nu, nv, |p| out(alone(p))) {
            return true;
        }
        if let Some(patch) = self.bspline_root(face, k) {
            bspline::eval_lattice(&self.grid(patch), nu, nv, |pt| {
                // The root's frame, as `eval` applies it (the identity up to the sign of zeros).
                out(Frame::UNIT.face_point_d1(pt))
            });
            return true;
        }
        // Every point's leaf first: a hole anywhere leaves the domain to point-by-point
        // evaluation, with nothing evaluated here.
        let (face32, k32) = (face as u32, k as u32);
        let mut leaves = Vec::with_capacity((nu.saturating_sub(1) * nv.saturating_sub(1)) as usize);
        for j in 1..nv {
            let v = j as f64 / nv as f64;
            for i in 1..nu {
                let at = FaceCoord::new(face32, k32, i as f64 / nu as f64, v);
                match self.find_leaf_unframed(at) {
                    Some(leaf) => leaves.push(leaf),
                    None => return false,
                }
            }
        }
        let mut kept = Kept::default();
        // A B-spline, single-crease or Stam sub-patch leaf's rows contracted along its `s`
        // are shared by its points of the same `s`: a lattice column's, or a row's where the
        // leaf's frame is turned (kept per lattice column and per row, the last leaf's each).
        let (mut by_column, mut by_row) = (
            vec![Rows::EMPTY; nu as usize],
            vec![Rows::EMPTY; nv as usize],
        );
        for (n, (p, s, t)) in leaves.into_iter().enumerate() {
            let (i, j) = (n % (nu as usize - 1) + 1, n / (nu as usize - 1) + 1);
            let slots = (&mut by_column[i], &mut by_row[j]);
            out(self.leaf_point::<D1>(p, s, t, slots, &mut kept));
        }
        true
    }

    /// The point at `(s, t)` of leaf `p` as [`Self::eval_d1`] gives it (the same bits), with
    /// the derivatives (`D1`) or the position alone (zero derivatives). A B-spline,
    /// single-crease or Stam sub-patch leaf's rows contracted along its `s` are kept in one
    /// of `slots` (the first where the leaf's `s` runs along the domain's `u`, else the
    /// second) for the next points of the same leaf and `s`; other leaves are evaluated whole,
    /// their parts kept in `kept`.
    #[inline(always)]
    fn leaf_point<const D1: bool>(
        &self,
        p: u32,
        s: f64,
        t: f64,
        slots: (&mut Rows, &mut Rows),
        kept: &mut Kept,
    ) -> PointD1 {
        let patch = &self.patches[p as usize];
        let frame = patch.frame();
        let pt = match patch.kind {
            PatchKind::BSpline { .. } => {
                let rows = Rows::of(&frame, slots).get((p, 0), s, || {
                    contract::<D1>(&self.grid(patch), &bspline::basis(s), || {
                        bspline::basis_d1(s)
                    })
                });
                if !D1 {
                    let w = kept.along_t.get(u32::MAX, t, || bspline::basis(t));
                    return alone(bspline::finish_v_p(&rows.0, w));
                }
                bspline::finish_v(rows, &bspline::basis(t), &bspline::basis_d1(t))
            }
            PatchKind::SingleCrease { edge, sharpness } => {
                let i = kept.curve_index(p, sharpness as f64);
                let curve = &kept.curves[i].1;
                let edge = edge as usize;
                if !D1 {
                    // The weights alone, those along `t` kept for the next point of the leaf
                    // and `t` (the row's next point).
                    let rows = Rows::of(&frame, slots).get((p, 0), s, || {
                        let w = single_crease::weights_u(edge, curve, s, t);
                        contract::<false>(&self.grid(patch), &w, || [0.0; 4])
                    });
                    let w = kept
                        .along_t
                        .get(p, t, || single_crease::weights_v(edge, curve, s, t));
                    return alone(bspline::finish_v_p(&rows.0, w));
                }
                let rows = Rows::of(&frame, slots).get((p, 0), s, || {
                    let bu = single_crease::basis_u(edge, curve, s, t);
                    contract::<D1>(&self.grid(patch), &bu.w, || bu.d1)
                });
                let bv = single_crease::basis_v(edge, curve, s, t);
                bspline::finish_v(rows, &bv.w, &bv.d1)
            }
            // A Stam patch's point in a regular sub-patch (not at the extraordinary corner):
            // `leaf_d1`'s steps, with the sub-patch's rows shared.
            PatchKind::Stam { valence, corner } => {
                let basis = self.stam_basis(valence);
                let first = patch.first_point as usize;
                let cps = &self.points[first..first + basis.size];
                let (rot, s1, t1) = stam_corner(corner, s, t);
                let located = match s1 == 0.0 && t1 == 0.0 {
                    true => None,
                    false => stam::locate(s1, t1),
                };
                let Some((m, q, s2, t2, sub)) = located else {
                    // At the extraordinary corner (or nearer it than the deepest sub-patch)
                    // the position is the limit point's, whose derivatives `leaf_d1` takes
                    // from a sub-patch at the deepest level: without them, the limit alone.
                    if !D1 {
                        return alone(basis.limit(cps));
                    }
                    return self.leaf_d1(p, frame, s, t, kept);
                };
                let frame = frame.then(&rot.then(&sub.child(q)));
                let key = (p, 1 + (m as u32) * 4 + q as u32);
                let rows = Rows::of(&frame, slots).get(key, s2, || {
                    let grid = kept.stam_grid(p, basis, (m, q), cps);
                    contract::<D1>(&grid, &bspline::basis(s2), || bspline::basis_d1(s2))
                });
                if !D1 {
                    let w = kept.along_t.get(u32::MAX, t2, || bspline::basis(t2));
                    return alone(bspline::finish_v_p(&rows.0, w));
                }
                let pt = bspline::finish_v(rows, &bspline::basis(t2), &bspline::basis_d1(t2));
                return frame.face_point_d1(pt);
            }
            _ => return self.leaf_d1(p, frame, s, t, kept),
        };
        frame.face_point_d1(pt)
    }
}

/// A position alone, as a point with zero derivatives.
#[inline(always)]
fn alone(p: [f64; 3]) -> PointD1 {
    PointD1 {
        p,
        ..PointD1::default()
    }
}

/// [`bspline::contract_u`] with weights `w` and, with `D1`, derivative weights `d1()`; without,
/// the value rows alone (the same bits) and zero derivative rows.
#[inline(always)]
fn contract<const D1: bool>(
    cp: &ControlGrid,
    w: &[f64; 4],
    d1: impl FnOnce() -> [f64; 4],
) -> (bspline::Rows, bspline::Rows) {
    if D1 {
        bspline::contract_u(cp, w, &d1())
    } else {
        (bspline::contract_u_p(cp, w), [[0.0; 3]; 4])
    }
}

/// A leaf's control rows contracted along `s` ([`bspline::contract_u`]), with the leaf (and
/// for a Stam patch, `1 + 4m + q` of its sub-patch, 0 otherwise) and the `s` (its bits) they
/// are for.
#[derive(Clone)]
struct Rows {
    leaf: (u32, u32),
    s: u64,
    rows: (bspline::Rows, bspline::Rows),
}

impl Rows {
    const EMPTY: Rows = Rows {
        leaf: (u32::MAX, 0),
        s: 0,
        rows: ([[0.0; 3]; 4], [[0.0; 3]; 4]),
    };

    /// Where the rows along `s` of a leaf whose frame is `frame` are kept: in the lattice
    /// column's slot, or in the row's where the frame is turned (`s` runs along `v`).
    #[inline(always)]
    fn of<'a>(frame: &Frame, (column, row): (&'a mut Rows, &'a mut Rows)) -> &'a mut Rows {
        match frame.a[0] != 0.0 {
            true => column,
            false => row,
        }
    }

    /// The rows of leaf `leaf` at `s`: these, or `contract()` when they are another's.
    #[inline(always)]
    fn get(
        &mut self,
        leaf: (u32, u32),
        s: f64,
        contract: impl FnOnce() -> (bspline::Rows, bspline::Rows),
    ) -> &(bspline::Rows, bspline::Rows) {
        if self.leaf != leaf || self.s != s.to_bits() {
            self.rows = contract();
            (self.leaf, self.s) = (leaf, s.to_bits());
        }
        &self.rows
    }
}

/// The shared parts of the leaves of one domain, kept while its points are evaluated (a
/// domain has a few leaves: a linear search finds them); also [`PatchTable::eval_d1_kept`]'s.
#[derive(Default)]
pub(crate) struct Kept {
    /// Crease pieces by single-crease patch.
    curves: Vec<(u32, CreaseCurve)>,
    /// Regular sub-patches by Stam patch, depth and quadrant.
    grids: Vec<(u32, u8, u8, ControlGrid)>,
    /// The last weights along a leaf's `t` (positions alone).
    along_t: Weights,
}

/// The last weights computed along a leaf's `t`, with their key (the single-crease patch they
/// are for, or `u32::MAX` for a B-spline's) and the `t` (its bits): the points of a lattice
/// row in one leaf share them.
struct Weights {
    key: u32,
    t: u64,
    w: [f64; 4],
}

impl Default for Weights {
    fn default() -> Self {
        Weights {
            key: u32::MAX,
            t: u64::MAX,
            w: [0.0; 4],
        }
    }
}

impl Weights {
    /// The weights of `key` at `t`: these, or `make()` when they are another's.
    #[inline(always)]
    fn get(&mut self, key: u32, t: f64, make: impl FnOnce() -> [f64; 4]) -> &[f64; 4] {
        if self.key != key || self.t != t.to_bits() {
            self.w = make();
            (self.key, self.t) = (key, t.to_bits());
        }
        &self.w
    }
}

impl Kept {
    /// Regular sub-patch `(m, q)` of Stam patch `p` (matrices `basis`, control points `cps`).
    fn stam_grid(
        &mut self,
        p: u32,
        basis: &StamBasis,
        (m, q): (usize, usize),
        cps: &[[f64; 3]],
    ) -> ControlGrid {
        stam_grid(&mut self.grids, p, basis, (m, q), cps)
    }

    /// Forgets every leaf's parts (before the points of other leaves, so that the searches
    /// stay short).
    pub(crate) fn clear(&mut self) {
        self.curves.clear();
        self.grids.clear();
        self.along_t = Weights::default();
    }

    /// Where single-crease patch `p`'s crease pieces are in `curves` (made the first time).
    #[inline]
    fn curve_index(&mut self, p: u32, sharpness: f64) -> usize {
        match self.curves.iter().position(|(q, _)| *q == p) {
            Some(i) => i,
            None => {
                self.curves.push((p, CreaseCurve::new(sharpness)));
                self.curves.len() - 1
            }
        }
    }
}

impl PatchTable {
    /// [`Self::eval_d1`] at each of `coords`, appended to `out`: the same bits, with the parts
    /// of leaves that points share (a single-crease patch's crease pieces, a Stam patch's
    /// sub-patches) kept in `kept` for the next points (made once, not once per point). Where
    /// the points all lie in one domain that is one B-spline patch (a regular face's side
    /// or corner, as the shared points of dicing come), its control points are gathered once
    /// and no point looks its leaf up; points of one `u` (a side along `v`) share their rows
    /// contracted along `u`, so each costs 12 multiply-adds instead of 44.
    pub(crate) fn eval_d1_points(
        &self,
        coords: &[FaceCoord],
        kept: &mut Kept,
        out: &mut Vec<PointD1>,
    ) -> crate::error::Result<()> {
        let Some(patch) = self.one_bspline_domain(coords) else {
            for &at in coords {
                out.push(self.eval_d1_with(at, kept)?);
            }
            return Ok(());
        };
        for &at in coords {
            self.check(at)?;
        }
        let grid = self.grid(patch);
        let u = coords[0].u;
        // The root's frame, as `eval_d1` applies it (the identity up to the sign of zeros).
        if coords.len() > 1 && coords.iter().all(|c| c.u.to_bits() == u.to_bits()) {
            let rows = bspline::contract_u(&grid, &bspline::basis(u), &bspline::basis_d1(u));
            out.extend(coords.iter().map(|c| {
                let (w, d1) = (bspline::basis(c.v), bspline::basis_d1(c.v));
                Frame::UNIT.face_point_d1(bspline::finish_v(&rows, &w, &d1))
            }));
        } else {
            out.extend(
                coords
                    .iter()
                    .map(|c| Frame::UNIT.face_point_d1(bspline::eval_d1(&grid, c.u, c.v))),
            );
        }
        Ok(())
    }

    /// [`Self::eval_d1_points`]'s positions alone (zero derivatives), the same bits, appended to
    /// `out`, where the points lie in exact domains: where they all lie in one that is one B-spline
    /// patch, its control points gathered once and no leaf looked up; elsewhere each point's leaf
    /// looked up and, as in a domain's lattice ([`Self::eval_domain_lattice_with`]), a B-spline,
    /// single-crease or Stam sub-patch leaf's point summed without derivatives (the rows along its
    /// `s` kept for the next point of the same leaf and `s`), other points evaluated whole (their
    /// leaves' parts kept in `kept`); the points of a run may lie in several domains (a side of an
    /// n-gon's sub-face runs on into the next sub-face), each found in its own. `Ok(false)`, with
    /// nothing appended, where a point is not in an exact domain or lies in a hole (point-by-point
    /// evaluation then names it).
    pub(crate) fn eval_points_p(
        &self,
        coords: &[FaceCoord],
        kept: &mut Kept,
        out: &mut Vec<PointD1>,
    ) -> crate::error::Result<bool> {
        let Some(a) = coords.first() else {
            return Ok(true);
        };
        let (face, k) = (a.face, a.k);
        if !coords
            .iter()
            .all(|c| self.exact_domain(c.face as usize, c.k as usize))
        {
            return Ok(false);
        }
        for &at in coords {
            self.check(at)?;
        }
        let one = coords.iter().all(|c| (c.face, c.k) == (face, k));
        let uv = coords.iter().map(|c| [c.u, c.v]);
        if one && self.eval_domain_points_p((face, k), uv, |p| out.push(alone(p))) {
            return Ok(true);
        }
        let start = out.len();
        let (mut along_u, mut along_v) = (Rows::EMPTY, Rows::EMPTY);
        for &at in coords {
            let Some((p, s, t)) = self.find_leaf_unframed(at) else {
                out.truncate(start);
                return Ok(false);
            };
            let slots = (&mut along_u, &mut along_v);
            out.push(self.leaf_point::<false>(p, s, t, slots, kept));
        }
        Ok(true)
    }

    /// The positions of points `uv` of domain `(face, k)` where the domain is one B-spline
    /// patch (`false`, with nothing evaluated, where it is not, or is out of range): the bits
    /// [`Self::eval_points_p`] gives them, its control points gathered once, rows contracted
    /// once for points of one `u`, with no lookup and no check per point (the caller's points
    /// lie in the domain: a shared run of dicing).
    pub(crate) fn eval_domain_points_p(
        &self,
        (face, k): (u32, u32),
        uv: impl ExactSizeIterator<Item = [f64; 2]> + Clone,
        out: impl FnMut([f64; 3]),
    ) -> bool {
        let Some(patch) = self.bspline_root(face as usize, k as usize) else {
            return false;
        };
        bspline::eval_points_p(&self.grid(patch), uv, out);
        true
    }

    /// The positions of the interior lattice points of domain `(face, k)` (as
    /// [`Self::eval_domain_lattice`] orders them) where the domain is one B-spline patch
    /// (`false`, with nothing evaluated, where it is not, or is out of range): the bits
    /// [`Self::eval_domain_lattice_with`] gives them without derivatives
    /// ([`bspline::eval_lattice_p`] on the same control points), handed over as they are
    /// summed, with no record per point.
    pub(crate) fn eval_domain_lattice_p(
        &self,
        (face, k): (u32, u32),
        nu: u32,
        nv: u32,
        out: impl FnMut([f64; 3]),
    ) -> bool {
        let Some(patch) = self.bspline_root(face as usize, k as usize) else {
            return false;
        };
        bspline::eval_lattice_p(&self.grid(patch), nu, nv, out);
        true
    }

    /// The B-spline patch that is the whole of the one domain all of `coords` lie in, if
    /// they do and it is one.
    fn one_bspline_domain(&self, coords: &[FaceCoord]) -> Option<&super::Patch> {
        let a = coords.first()?;
        coords
            .iter()
            .all(|c| (c.face, c.k) == (a.face, a.k))
            .then(|| self.bspline_root(a.face as usize, a.k as usize))?
    }

    /// Whether domain `(face, k)` exists and the table evaluates it exactly (a Catmull-Clark
    /// table without an approximation).
    fn exact_domain(&self, face: usize, k: usize) -> bool {
        !self.is_approximate()
            && self.loop_surface.is_none()
            && face < self.num_faces()
            && k < self.sub_faces(face)
    }

    /// The B-spline patch that is the whole of domain `(face, k)`, in an exact table.
    fn bspline_root(&self, face: usize, k: usize) -> Option<&super::Patch> {
        if !self.exact_domain(face, k) {
            return None;
        }
        self.root_patch(face, k)
            .filter(|p| matches!(p.kind, PatchKind::BSpline { .. }))
    }
}

impl LeafParts for Kept {
    fn curve(&mut self, p: u32, sharpness: f64) -> &CreaseCurve {
        let i = self.curve_index(p, sharpness);
        &self.curves[i].1
    }

    fn stam(
        &mut self,
        p: u32,
        basis: &StamBasis,
        cps: &[[f64; 3]],
        s: f64,
        t: f64,
    ) -> (PointD1, Frame) {
        let grids = &mut self.grids;
        basis.eval_local_d1(cps, s, t, &mut |m, q| {
            stam_grid(grids, p, basis, (m, q), cps)
        })
    }
}

/// Regular sub-patch `(m, q)` of Stam patch `p` (matrices `basis`, control points `cps`),
/// from `grids` (by patch, depth and quadrant), where it is added the first time.
fn stam_grid(
    grids: &mut Vec<(u32, u8, u8, ControlGrid)>,
    p: u32,
    basis: &StamBasis,
    (m, q): (usize, usize),
    cps: &[[f64; 3]],
) -> ControlGrid {
    let key = (p, m as u8, q as u8);
    if let Some(e) = grids.iter().find(|e| (e.0, e.1, e.2) == key) {
        return e.3;
    }
    let grid = basis.grid(m, q, cps);
    grids.push((p, m as u8, q as u8, grid));
    grid
}

#[cfg(test)]
mod tests {
    use super::super::eval::tests::tables;
    use super::super::tree::Node;
    use super::super::PatchKind;
    use crate::coord::FaceCoord;
    use crate::mesh::MeshBuilder;
    use crate::patch::{PatchOptions, PatchTable};

    /// Every domain's lattice, at rates that put points on tree splits (even rates) and
    /// off them (odd), equals `eval_d1` point by point bit for bit (signs of zeros included),
    /// in the same order (and its positions alone, `eval_domain_lattice_with::<false>` and,
    /// where the domain is one B-spline patch, `eval_domain_lattice_p`, the same position
    /// bits), on meshes with B-spline, single-crease, Stam and end-cap leaves
    /// under trees.
    #[test]
    fn lattice_is_point_by_point_bit_for_bit() {
        let bits = |p: [[f64; 3]; 3]| p.map(|v| v.map(f64::to_bits));
        let mut kinds = [0usize; 4];
        let mut roots = 0;
        for table in tables() {
            for f in 0..table.num_faces() {
                for k in 0..table.sub_faces(f) {
                    for (nu, nv) in [(2, 2), (5, 3), (8, 8), (16, 16), (7, 12)] {
                        let mut got = Vec::new();
                        let done = table.eval_domain_lattice(f, k, nu, nv, |pt| {
                            got.push(bits([pt.p, pt.du, pt.dv]));
                        });
                        assert!(done, "domain ({f}, {k}) not evaluated");
                        let mut want = Vec::new();
                        for j in 1..nv {
                            for i in 1..nu {
                                let (u, v) = (i as f64 / nu as f64, j as f64 / nv as f64);
                                let at = FaceCoord::new(f as u32, k as u32, u, v);
                                let pt = table.eval_d1(at).unwrap();
                                want.push(bits([pt.p, pt.du, pt.dv]));
                            }
                        }
                        assert_eq!(got, want, "domain ({f}, {k}) at {nu} x {nv}");
                        // The positions alone: the same position bits, zero derivatives.
                        let mut alone = Vec::new();
                        table.eval_domain_lattice_with::<false>(f, k, nu, nv, |pt| {
                            alone.push(bits([pt.p, pt.du, pt.dv]));
                        });
                        let zero = [0.0f64.to_bits(); 3];
                        let want_p: Vec<_> = want.iter().map(|w| [w[0], zero, zero]).collect();
                        assert_eq!(alone, want_p, "domain ({f}, {k}) at {nu} x {nv}, alone");
                        // Where the domain is one B-spline patch, its positions handed over
                        // as summed: the same position bits.
                        let mut summed = Vec::new();
                        let root = table.eval_domain_lattice_p((f as u32, k as u32), nu, nv, |p| {
                            summed.push(p.map(f64::to_bits))
                        });
                        let want_p: Vec<_> = want.iter().map(|w| w[0]).collect();
                        if root {
                            assert_eq!(summed, want_p, "domain ({f}, {k}) at {nu} x {nv}, summed");
                            roots += 1;
                        } else {
                            assert!(summed.is_empty(), "domain ({f}, {k}): a tree, yet summed");
                        }
                    }
                    // Which leaves the domain's tree holds (a B-spline root takes the
                    // column path, every other domain the tree path).
                    let root =
                        table.nodes[table.roots[table.root_offsets[f] as usize + k] as usize];
                    let mut stack = vec![root];
                    while let Some(node) = stack.pop() {
                        match node {
                            Node::Inner(c) => stack.extend(table.kids[c as usize]),
                            Node::Leaf(p) if !matches!(root, Node::Leaf(_)) => {
                                kinds[match table.patches[p as usize].kind {
                                    PatchKind::BSpline { .. } => 0,
                                    PatchKind::SingleCrease { .. } => 1,
                                    PatchKind::Stam { .. } => 2,
                                    PatchKind::EndCap => 3,
                                }] += 1;
                            }
                            _ => {}
                        }
                    }
                }
            }
        }
        assert!(
            kinds.iter().all(|&n| n > 0),
            "leaves under trees by kind: {kinds:?}"
        );
        assert!(roots > 0, "no domain that is one B-spline patch");
    }

    /// `eval_d1_points` equals `eval_d1` bit for bit (signs of zeros included), and the
    /// positions alone of `eval_points_p` and `eval_domain_points_p` equal its positions, on
    /// runs along each domain's sides and diagonal and at its corners, as shared points come
    /// (the parts kept from run to run, and from domain to domain where they are not cleared),
    /// on meshes with B-spline roots (both of their paths) and single-crease, Stam and end-cap
    /// leaves; holes are errors for both.
    #[test]
    fn points_are_eval_bit_for_bit() {
        let bits = |p: super::PointD1| [p.p, p.du, p.dv].map(|v| v.map(f64::to_bits));
        let mut paths = [0usize; 3];
        let mut domain_runs = 0;
        for table in tables() {
            let mut kept = super::Kept::default();
            for f in 0..table.num_faces() {
                for k in 0..table.sub_faces(f) {
                    let (f32_, k32) = (f as u32, k as u32);
                    let mut runs: Vec<Vec<FaceCoord>> = [(0.0, 0.0), (1.0, 0.0), (1.0, 1.0)]
                        .into_iter()
                        .map(|(u, v)| vec![FaceCoord::new(f32_, k32, u, v)])
                        .collect();
                    for r in [2, 3, 4, 7, 16] {
                        let side = |g: &dyn Fn(f64) -> (f64, f64)| -> Vec<FaceCoord> {
                            (1..r)
                                .map(|i| {
                                    let (u, v) = g(i as f64 / r as f64);
                                    FaceCoord::new(f32_, k32, u, v)
                                })
                                .collect()
                        };
                        runs.push(side(&|t| (t, 0.0)));
                        runs.push(side(&|t| (1.0, t)));
                        runs.push(side(&|t| (1.0 - t, 1.0)));
                        runs.push(side(&|t| (0.0, 1.0 - t)));
                        runs.push(side(&|t| (t, t)));
                    }
                    for run in &runs {
                        let mut got = Vec::new();
                        let done = table.eval_d1_points(run, &mut kept, &mut got);
                        let want: Result<Vec<_>, _> =
                            run.iter().map(|&at| table.eval_d1(at)).collect();
                        match (want, done) {
                            (Ok(want), Ok(())) => {
                                let got: Vec<_> = got.into_iter().map(bits).collect();
                                let want: Vec<_> = want.into_iter().map(bits).collect();
                                assert_eq!(got, want, "({f}, {k}) on {run:?}");
                            }
                            (Err(_), Err(_)) => {}
                            (a, b) => panic!("({f}, {k}) on {run:?}: {a:?} but {b:?}"),
                        }
                        let same_u = run.len() > 1 && run.iter().all(|c| c.u == run[0].u);
                        let one_domain =
                            run.iter().all(|c| (c.face, c.k) == (run[0].face, run[0].k));
                        // Positions alone, from `eval_points_p` and, for a run in one domain,
                        // from `eval_domain_points_p`: `eval_d1`'s position bits.
                        let want: Result<Vec<_>, _> = run
                            .iter()
                            .map(|&at| table.eval_d1(at).map(|p| p.p.map(f64::to_bits)))
                            .collect();
                        if let Ok(want) = want {
                            let mut got = Vec::new();
                            if let Ok(true) = table.eval_points_p(run, &mut kept, &mut got) {
                                let got: Vec<_> =
                                    got.iter().map(|p| p.p.map(f64::to_bits)).collect();
                                assert_eq!(got, want, "positions alone: ({f}, {k}) on {run:?}");
                            }
                            let mut alone = Vec::new();
                            let uv = run.iter().map(|c| [c.u, c.v]);
                            if one_domain
                                && table.eval_domain_points_p((f32_, k32), uv, |p| {
                                    alone.push(p.map(f64::to_bits))
                                })
                            {
                                assert_eq!(alone, want, "one domain: ({f}, {k}) on {run:?}");
                                domain_runs += 1;
                            }
                        }
                        let root = table.bspline_root(run[0].face as usize, run[0].k as usize);
                        paths[match root.filter(|_| one_domain) {
                            None => 0,
                            Some(_) if same_u => 1,
                            Some(_) => 2,
                        }] += 1;
                    }
                    if f % 2 == 0 {
                        kept.clear();
                    }
                }
            }
        }
        assert!(paths.iter().all(|&n| n > 0), "runs by path: {paths:?}");
        assert!(domain_runs > 0);
    }

    /// A hole at a lattice point leaves the whole domain to point-by-point evaluation (which
    /// names the hole), with nothing evaluated.
    #[test]
    fn a_hole_leaves_the_domain_to_points() {
        let positions = (0..16)
            .map(|i| [(i % 4) as f64, (i / 4) as f64, 0.0])
            .collect();
        let quads: Vec<u32> = (0..9)
            .flat_map(|q| {
                let v = 4 * (q / 3) + q % 3;
                [v, v + 1, v + 5, v + 4]
            })
            .collect();
        let mesh = MeshBuilder::new()
            .positions(positions)
            .faces(&[4; 9], &quads)
            .hole(4)
            .build()
            .unwrap();
        let table = PatchTable::new(&mesh, PatchOptions::default()).unwrap();
        let mut called = 0;
        assert!(!table.eval_domain_lattice(4, 0, 4, 4, |_| called += 1));
        assert_eq!(called, 0);
        assert!(table.eval_d1(FaceCoord::new(4, 0, 0.5, 0.5)).is_err());
        // Its neighbours are evaluated.
        assert!(table.eval_domain_lattice(3, 0, 4, 4, |_| called += 1));
        assert_eq!(called, 9);
    }
}
