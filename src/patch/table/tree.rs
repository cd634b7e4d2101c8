//! The quadtree of a patch table: nodes (inner, leaf, empty), the frame of each node within its
//! (sub-)face, and the descent from a node to the child holding a point.

use crate::patch::bspline::{PatchPoint, PointD1};

#[derive(Clone, Copy, Debug)]
pub(crate) enum Node {
    Inner(u32),
    Leaf(u32),
    Empty,
}

/// Frame of a node within its (sub-)face: `(u, v) = o + s a + t b`.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Frame {
    pub(crate) o: [f64; 2],
    pub(crate) a: [f64; 2],
    pub(crate) b: [f64; 2],
}

/// Corner k of the unit square, and the child axes (see `regular::C/U/V`).
pub(crate) const CORNER: [[f64; 2]; 4] = [[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]];
pub(crate) const UAX: [[f64; 2]; 4] = [[1.0, 0.0], [0.0, 1.0], [-1.0, 0.0], [0.0, -1.0]];
pub(crate) const VAX: [[f64; 2]; 4] = [[0.0, 1.0], [-1.0, 0.0], [0.0, -1.0], [1.0, 0.0]];

impl Frame {
    pub(crate) const UNIT: Frame = Frame {
        o: [0.0, 0.0],
        a: [1.0, 0.0],
        b: [0.0, 1.0],
    };
    pub(crate) fn child(&self, k: usize) -> Frame {
        let map = |p: [f64; 2]| {
            [
                self.a[0] * p[0] + self.b[0] * p[1],
                self.a[1] * p[0] + self.b[1] * p[1],
            ]
        };
        let c = map(CORNER[k]);
        let ua = map(UAX[k]);
        let va = map(VAX[k]);
        Frame {
            o: [self.o[0] + c[0], self.o[1] + c[1]],
            a: [ua[0] * 0.5, ua[1] * 0.5],
            b: [va[0] * 0.5, va[1] * 0.5],
        }
    }
    /// The frame of `inner` (a frame within this one's (s, t)) in this frame's parent:
    /// `self ∘ inner`.
    pub(crate) fn then(&self, inner: &Frame) -> Frame {
        let map = |p: [f64; 2]| {
            [
                self.a[0] * p[0] + self.b[0] * p[1],
                self.a[1] * p[0] + self.b[1] * p[1],
            ]
        };
        let o = map(inner.o);
        Frame {
            o: [self.o[0] + o[0], self.o[1] + o[1]],
            a: map(inner.a),
            b: map(inner.b),
        }
    }

    /// First and second derivatives with respect to the (sub-)face's (u, v) from those in
    /// the frame's (s, t). The frame is a rotation and scaling by `h`, so
    /// `s = a·(x − o) / h²` and `t = b·(x − o) / h²`.
    pub(crate) fn face_point(&self, pt: PatchPoint) -> PatchPoint {
        let (a, b) = (self.a, self.b);
        let h2 = a[0] * a[0] + a[1] * a[1];
        let h4 = h2 * h2;
        let d2 = |x: usize, y: usize| -> [f64; 3] {
            std::array::from_fn(|i| {
                (a[x] * a[y] * pt.duu[i]
                    + (a[x] * b[y] + a[y] * b[x]) * pt.duv[i]
                    + b[x] * b[y] * pt.dvv[i])
                    / h4
            })
        };
        let d1 = self.face_point_d1(PointD1 {
            p: pt.p,
            du: pt.du,
            dv: pt.dv,
        });
        PatchPoint {
            p: d1.p,
            du: d1.du,
            dv: d1.dv,
            duu: d2(0, 0),
            duv: d2(0, 1),
            dvv: d2(1, 1),
        }
    }

    /// [`Self::face_point`] for the position and first derivatives alone (the same bits).
    #[inline]
    pub(crate) fn face_point_d1(&self, pt: PointD1) -> PointD1 {
        let (a, b) = (self.a, self.b);
        let h2 = a[0] * a[0] + a[1] * a[1];
        PointD1 {
            p: pt.p,
            du: std::array::from_fn(|i| (pt.du[i] * a[0] + pt.dv[i] * b[0]) / h2),
            dv: std::array::from_fn(|i| (pt.du[i] * a[1] + pt.dv[i] * b[1]) / h2),
        }
    }
}

/// Which child of a node holds local point (s, t), and the point in the child's coordinates.
pub(crate) fn descend(s: f64, t: f64) -> (usize, f64, f64) {
    let k = match (s >= 0.5, t >= 0.5) {
        (false, false) => 0,
        (true, false) => 1,
        (true, true) => 2,
        (false, true) => 3,
    };
    let d = [s - CORNER[k][0], t - CORNER[k][1]];
    let s2 = 2.0 * (d[0] * UAX[k][0] + d[1] * UAX[k][1]);
    let t2 = 2.0 * (d[0] * VAX[k][0] + d[1] * VAX[k][1]);
    (k, s2.clamp(0.0, 1.0), t2.clamp(0.0, 1.0))
}

/// The corner of the unit square at (s, t), if it is one.
pub(crate) fn corner_index(s: f64, t: f64) -> Option<usize> {
    match (s, t) {
        (0.0, 0.0) => Some(0),
        (1.0, 0.0) => Some(1),
        (1.0, 1.0) => Some(2),
        (0.0, 1.0) => Some(3),
        _ => None,
    }
}
