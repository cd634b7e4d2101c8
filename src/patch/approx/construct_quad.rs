//! Paper 004's Gregory-patch approximation of a Catmull-Clark surface (Loop, Schaefer, Ni,
//! Castaño 2009), after one level of subdivision (their "Gregory2": every face a quad, each
//! extraordinary vertex isolated in its own faces): one bicubic Gregory patch per level-1 quad,
//! built in two passes that share what neighbours share.
//!
//! **Per edge: the boundary curve.** Corners are the exact limit positions
//! ([`LimitStencils`]). At a smooth vertex of valence `n` the edge points are
//! `e_j = p + (2/3) λ_n t_j`, with `λ_n` Catmull-Clark's subdominant eigenvalue
//! `(4 + A_n)/16`, `A_n = 1 + cos(2π/n) + cos(π/n) √(2 (9 + cos(2π/n)))`, and `t_j` the limit
//! tangent mask toward edge `j`,
//! `Σ_k [A_n cos θ_kj E_k + (cos θ_kj + cos θ_(k+1)j) F_k] / (3n)`, `θ_kj = 2π(k − j)/n`: at
//! valence 4 it is the B-spline's derivative, so `e_j` is the B-spline's Bézier point.
//! Elsewhere (boundaries, creases, corners, darts, non-manifold) an infinitely sharp edge
//! takes the exact surface's derivative along it (a cubic B-spline crease), any other edge the
//! chord's third projected into the corner's exact tangent plane.
//!
//! **Per edge: the cross-boundary derivatives.** With `T(t)` the boundary's derivative, each
//! face's inward cross derivative along the edge is built as
//! - `D(t) = α(t) T(t) ± R(t)`, `α` linear from `cos(2π/n_a)` to `−cos(2π/n_b)`, `R` one cubic
//!   shared by both faces with opposite signs, where both ends are smooth vertices. This is the
//!   construction of Loop et al.: with edge points from one pair of tangents per vertex, the
//!   two faces' derivatives at a corner sum to `2 cos(2π/n) T`. `R` is pinned at the ends by
//!   those derivatives. Its two middle coefficients interpolate, at `t = 1/3` and `2/3`, half
//!   the difference of the two faces' exact cross derivatives (the paper's Loop cross
//!   tangents, taken from the exact surface). A regular patch is therefore reproduced exactly:
//!   `α = 0`, and `R` is then the B-spline's cubic cross derivative.
//! - `D(t) = α(t) T(t) + β(t) R(t)` otherwise: `α`, `β` linear and fitted to each face's
//!   derivatives at the corners, and `R` quadratic through the exact tangent planes at the ends
//!   and at the midpoint (`n × T`).
//!
//! Either way both faces' derivatives lie in `span{T(t), R(t)}`, so the patches are tangent-plane
//! continuous across every smooth edge (measured in the tests). The two middle Bézier
//! coefficients of `D` give the edge's two interior points.

use super::construct::{decompose, in_plane};
use super::gregory_quad::GregoryQuad;
use crate::coord::FaceCoord;
use crate::error::Result;
use crate::mesh::{ControlMesh, Options};
use crate::patch::{PatchTable, Sample};
use crate::refine::limit::LimitStencils;
use crate::refine::{crease, Level, Refiner};
use crate::vec3::{add, cross, dot, normalize, scale, sub};
use rayon::prelude::*;
use std::f64::consts::PI;

/// Corners of a quad's parameter square, in the quad's vertex order.
const CORNER: [[f64; 2]; 4] = [[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]];

/// Where a level-1 quad lies in its base face's domain: base face and sub-face, and the affine
/// map `(u, v) = o + s a + t b` from the quad's parameter.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct QuadFrame {
    /// Base face.
    pub face: u32,
    /// Sub-face of the base face (0 for a quad).
    pub k: u32,
    /// Origin of the map.
    pub o: [f64; 2],
    /// Image of `s`'s unit vector.
    pub a: [f64; 2],
    /// Image of `t`'s unit vector.
    pub b: [f64; 2],
}

impl QuadFrame {
    /// The frames of every level-1 face of `base`, in level-1 face order: child `c` of a quad
    /// is its corner `c`'s quarter (vertex, edge point `c`, face point, edge point `c − 1`);
    /// child `c` of another face is its sub-face `c`.
    pub fn of_level(base: &Level) -> Vec<QuadFrame> {
        let mut out = Vec::new();
        for f in 0..base.num_faces() {
            let n = base.topo.face_size(f);
            for c in 0..n {
                let (o, a, b) = if n == 4 {
                    [
                        ([0.0, 0.0], [0.5, 0.0], [0.0, 0.5]),
                        ([1.0, 0.0], [0.0, 0.5], [-0.5, 0.0]),
                        ([1.0, 1.0], [-0.5, 0.0], [0.0, -0.5]),
                        ([0.0, 1.0], [0.0, -0.5], [0.5, 0.0]),
                    ][c]
                } else {
                    ([0.0, 0.0], [1.0, 0.0], [0.0, 1.0])
                };
                out.push(QuadFrame {
                    face: f as u32,
                    k: if n == 4 { 0 } else { c as u32 },
                    o,
                    a,
                    b,
                });
            }
        }
        out
    }

    /// The base domain point of `(s, t)`.
    pub fn coord(&self, s: f64, t: f64) -> FaceCoord {
        let u = self.o[0] + s * self.a[0] + t * self.b[0];
        let v = self.o[1] + s * self.a[1] + t * self.b[1];
        FaceCoord::new(self.face, self.k, u.clamp(0.0, 1.0), v.clamp(0.0, 1.0))
    }

    /// `(s, t)` of a base domain point `(u, v)` in this quad.
    pub fn local(&self, u: f64, v: f64) -> (f64, f64) {
        let (du, dv) = (u - self.o[0], v - self.o[1]);
        let det = self.a[0] * self.b[1] - self.a[1] * self.b[0];
        let s = (du * self.b[1] - dv * self.b[0]) / det;
        let t = (self.a[0] * dv - self.a[1] * du) / det;
        (s.clamp(0.0, 1.0), t.clamp(0.0, 1.0))
    }

    /// The exact surface at `(s, t)`, derivatives with respect to `(s, t)`.
    fn exact(&self, table: &PatchTable, s: f64, t: f64) -> Option<Sample> {
        let r = table.eval(self.coord(s, t)).ok()?;
        let d = |x: [f64; 2]| add(scale(r.du, x[0]), scale(r.dv, x[1]));
        let h = |x: [f64; 2], y: [f64; 2]| {
            [0, 1, 2].map(|i| {
                r.duu[i] * x[0] * y[0]
                    + r.duv[i] * (x[0] * y[1] + x[1] * y[0])
                    + r.dvv[i] * x[1] * y[1]
            })
        };
        Some(Sample {
            p: r.p,
            du: d(self.a),
            dv: d(self.b),
            duu: h(self.a, self.a),
            duv: h(self.a, self.b),
            dvv: h(self.b, self.b),
            level: r.level,
        })
    }

    /// The patch's `[p, ds, dt, dss, dst, dtt]` as a sample in the base domain's `(u, v)`.
    pub fn to_domain(&self, r: [[f64; 3]; 6]) -> Sample {
        let det = self.a[0] * self.b[1] - self.a[1] * self.b[0];
        // ∂(s, t)/∂u and ∂(s, t)/∂v: the columns of the inverse map.
        let su = [self.b[1] / det, -self.a[1] / det];
        let sv = [-self.b[0] / det, self.a[0] / det];
        let d = |x: [f64; 2]| add(scale(r[1], x[0]), scale(r[2], x[1]));
        let h = |x: [f64; 2], y: [f64; 2]| {
            [0, 1, 2].map(|i| {
                r[3][i] * x[0] * y[0]
                    + r[4][i] * (x[0] * y[1] + x[1] * y[0])
                    + r[5][i] * x[1] * y[1]
            })
        };
        Sample {
            p: r[0],
            du: d(su),
            dv: d(sv),
            duu: h(su, su),
            duv: h(su, sv),
            dvv: h(sv, sv),
            level: 1,
        }
    }
}

/// Catmull-Clark's `A_n` and subdominant eigenvalue `λ_n = (4 + A_n)/16`.
fn catmark_a_lambda(n: usize) -> (f64, f64) {
    let c = (2.0 * PI / n as f64).cos();
    let a = 1.0 + c + (PI / n as f64).cos() * (2.0 * (9.0 + c)).sqrt();
    (a, (4.0 + a) / 16.0)
}

/// A smooth vertex's ring in face order: edge neighbours `E_k` and the face points `F_k`
/// between `E_k` and `E_(k+1)`.
struct Ring {
    e: Vec<u32>,
    f: Vec<u32>,
}

/// The ring of `v` when it is smooth, interior and manifold with nothing sharp and only quads
/// around it; `None` otherwise.
fn smooth_ring(level: &Level, v: usize) -> Option<Ring> {
    let topo = &level.topo;
    let tag = topo.vert_tags[v];
    if tag.boundary || tag.nonmanifold || level.vertex_sharpness[v] != 0.0 {
        return None;
    }
    let (edges, faces) = (topo.vertex_edges(v), topo.vertex_faces(v));
    if edges.len() != faces.len() || edges.len() < 3 {
        return None;
    }
    if edges
        .iter()
        .any(|&e| level.edge_sharpness[e as usize] != 0.0)
        || faces
            .iter()
            .any(|&f| topo.face_size(f as usize) != 4 || level.face_hole[f as usize])
    {
        return None;
    }
    let corners = topo.vertex_face_corners(v);
    let quad = |i: usize| {
        let fv = topo.face_vertices(faces[i] as usize);
        let c = corners[i] as usize;
        (fv[(c + 1) % 4], fv[(c + 2) % 4], fv[(c + 3) % 4])
    };
    let (mut e, mut f) = (Vec::new(), Vec::new());
    let first = quad(0).0;
    let mut cur = first;
    for _ in 0..faces.len() {
        let i = (0..faces.len()).find(|&i| quad(i).0 == cur)?;
        let (x, y, z) = quad(i);
        e.push(x);
        f.push(y);
        cur = z;
    }
    let mut sorted = e.clone();
    sorted.sort_unstable();
    sorted.dedup();
    (cur == first && sorted.len() == e.len()).then_some(Ring { e, f })
}

/// A smooth vertex's ring, its `cos θ` and `sin θ` limit tangent masks applied, and its unit
/// normal.
struct Smooth {
    ring: Ring,
    tc: [f64; 3],
    ts: [f64; 3],
    normal: [f64; 3],
}

/// What a vertex gives its edges.
struct VertexData {
    p: [f64; 3],
    smooth: Option<Smooth>,
}

impl VertexData {
    /// The edge point toward ring neighbour `w` (smooth vertices).
    fn mask_edge_point(&self, w: u32) -> Option<[f64; 3]> {
        let sm = self.smooth.as_ref()?;
        let n = sm.ring.e.len();
        let j = sm.ring.e.iter().position(|&x| x == w)?;
        let th = 2.0 * PI * j as f64 / n as f64;
        let t = add(scale(sm.tc, th.cos()), scale(sm.ts, th.sin()));
        let (_, lambda) = catmark_a_lambda(n);
        Some(add(self.p, scale(t, 2.0 / 3.0 * lambda)))
    }
}

/// One edge's boundary curve (from `edge_verts[0]` to `edge_verts[1]`) and the data its
/// transversal needs.
#[derive(Clone, Copy, Debug)]
struct Curve {
    c: [[f64; 3]; 4],
    /// Unit normals at the two ends (from the canonical face where not smooth).
    n: [[f64; 3]; 2],
}

/// The transversal of an edge, in the direction `edge_verts[0] → edge_verts[1]`.
#[derive(Clone, Copy, Debug)]
enum Transversal {
    /// Shared cubic `R`, `+R` for the edge's first face and `−R` for its second; `α` from
    /// `cos(2π/n)` of the two ends.
    Symmetric {
        r: [[f64; 3]; 4],
        first: u32,
        c: [f64; 2],
    },
    /// Quadratic `R` through the exact tangent planes; `α`, `β` fitted per face.
    Fitted { r: [[f64; 3]; 3] },
}

/// The patches of every level-1 quad (`None` for holes) and their frames.
pub fn build(
    mesh: &ControlMesh,
    options: Options,
    exact: &PatchTable,
) -> Result<(Vec<QuadFrame>, Vec<Option<GregoryQuad>>)> {
    let r = Refiner::with_options(mesh, options, 1)?;
    let (base, lvl) = (&r.levels[0], &r.levels[1]);
    let pos = r.refine_positions(&mesh.positions, 1);
    let frames = QuadFrame::of_level(base);
    let topo = &lvl.topo;
    let limit = LimitStencils::new(lvl, options.crease_method).frames(&pos);
    let verts: Vec<VertexData> = (0..lvl.num_vertices())
        .into_par_iter()
        .map(|v| {
            let smooth = smooth_ring(lvl, v).map(|ring| {
                let n = ring.e.len();
                let (a, _) = catmark_a_lambda(n);
                let (mut tc, mut ts) = ([0.0; 3], [0.0; 3]);
                for k in 0..n {
                    let th = 2.0 * PI * k as f64 / n as f64;
                    let th1 = 2.0 * PI * (k + 1) as f64 / n as f64;
                    let (e, f) = (pos[ring.e[k] as usize], pos[ring.f[k] as usize]);
                    tc = add(
                        tc,
                        add(scale(e, a * th.cos()), scale(f, th.cos() + th1.cos())),
                    );
                    ts = add(
                        ts,
                        add(scale(e, a * th.sin()), scale(f, th.sin() + th1.sin())),
                    );
                }
                let s = 1.0 / (3.0 * n as f64);
                let (tc, ts) = (scale(tc, s), scale(ts, s));
                let normal = normalize(cross(tc, ts));
                Smooth {
                    ring,
                    tc: in_plane(tc, normal),
                    ts: in_plane(ts, normal),
                    normal,
                }
            });
            VertexData {
                p: limit[v].position,
                smooth,
            }
        })
        .collect();
    // The exact sample at corner `c` of level-1 face `q`, with a usable normal.
    let corner_sample = |q: usize, c: usize| -> Option<(Sample, [f64; 3])> {
        let [s, t] = CORNER[c];
        let x = frames[q].exact(exact, s, t)?;
        let mut n = normalize(cross(x.du, x.dv));
        if n == [0.0; 3] {
            // A degenerate parameter at an irregular vertex: the normal just inside.
            let e = 1e-7;
            let y = frames[q].exact(exact, (s - e).abs(), (t - e).abs())?;
            n = normalize(cross(y.du, y.dv));
        }
        Some((x, n))
    };
    let first_face = |e: u32| {
        topo.edge_face_list(e)
            .iter()
            .copied()
            .find(|&f| !lvl.face_hole[f as usize])
    };
    let corner_of = |q: u32, v: u32| {
        topo.face_vertices(q as usize)
            .iter()
            .position(|&x| x == v)
            .unwrap_or(0)
    };
    // Pass 1: boundary curves.
    let curves: Vec<Option<Curve>> = (0..topo.num_edges() as u32)
        .into_par_iter()
        .map(|e| {
            let q = first_face(e)?;
            let [a, b] = topo.edge_verts[e as usize];
            let sharp =
                crease::is_infinite(lvl.edge_sharpness[e as usize]) || topo.edge_is_boundary(e);
            let end = |v: u32, w: u32| -> ([f64; 3], [f64; 3]) {
                let d = &verts[v as usize];
                if let (Some(pt), Some(sm)) = (d.mask_edge_point(w), &d.smooth) {
                    return (pt, sm.normal);
                }
                let (cv, cw) = (corner_of(q, v), corner_of(q, w));
                let Some((x, n)) = corner_sample(q as usize, cv) else {
                    return (d.p, [0.0; 3]);
                };
                let dir = [CORNER[cw][0] - CORNER[cv][0], CORNER[cw][1] - CORNER[cv][1]];
                let t = if sharp {
                    add(scale(x.du, dir[0]), scale(x.dv, dir[1]))
                } else {
                    sub(verts[w as usize].p, d.p)
                };
                (add(d.p, scale(in_plane(t, n), 1.0 / 3.0)), n)
            };
            let (ea, na) = end(a, b);
            let (eb, mut nb) = end(b, a);
            if dot(na, nb) < 0.0 {
                nb = scale(nb, -1.0);
            }
            Some(Curve {
                c: [verts[a as usize].p, ea, eb, verts[b as usize].p],
                n: [na, nb],
            })
        })
        .collect();
    // The edge point next to `v` on the other edge of face `q` at `v` (not `e`).
    let other_point = |q: u32, v: u32, e: u32| -> Option<[f64; 3]> {
        let c = corner_of(q, v);
        let fe = topo.face_edge_list(q as usize);
        let o = if fe[c] == e { fe[(c + 3) % 4] } else { fe[c] };
        let cu = curves[o as usize]?;
        Some(if topo.edge_verts[o as usize][0] == v {
            cu.c[1]
        } else {
            cu.c[2]
        })
    };
    // The inward cross derivative of face `q` along edge `e` at `τ` (from edge_verts[0]).
    let cross_derivative = |q: u32, e: u32, tau: f64| -> Option<[f64; 3]> {
        let [a, b] = topo.edge_verts[e as usize];
        let (ca, cb) = (corner_of(q, a), corner_of(q, b));
        let (i, x) = if cb == (ca + 1) % 4 {
            (ca, tau)
        } else {
            (cb, 1.0 - tau)
        };
        let pt = [[x, 0.0], [1.0, x], [1.0 - x, 1.0], [0.0, 1.0 - x]][i];
        let dir = [[0.0, 1.0], [-1.0, 0.0], [0.0, -1.0], [1.0, 0.0]][i];
        let s = frames[q as usize].exact(exact, pt[0], pt[1])?;
        Some(add(scale(s.du, dir[0]), scale(s.dv, dir[1])))
    };
    // Pass 2: transversals.
    let transversals: Vec<Option<Transversal>> = (0..topo.num_edges() as u32)
        .into_par_iter()
        .map(|e| {
            let cu = curves[e as usize]?;
            let [a, b] = topo.edge_verts[e as usize];
            let faces: Vec<u32> = topo
                .edge_face_list(e)
                .iter()
                .copied()
                .filter(|&f| !lvl.face_hole[f as usize])
                .collect();
            let t0 = scale(sub(cu.c[1], cu.c[0]), 3.0);
            let t1 = scale(sub(cu.c[3], cu.c[2]), 3.0);
            let (sa, sb) = (&verts[a as usize].smooth, &verts[b as usize].smooth);
            if let (Some(ra), Some(rb), [l, rr]) = (sa, sb, faces.as_slice()) {
                let ca = (2.0 * PI / ra.ring.e.len() as f64).cos();
                let cb = (2.0 * PI / rb.ring.e.len() as f64).cos();
                let da = scale(sub(other_point(*l, a, e)?, cu.c[0]), 3.0);
                let db = scale(sub(other_point(*l, b, e)?, cu.c[3]), 3.0);
                let r0 = sub(da, scale(t0, ca));
                let r3 = add(db, scale(t1, cb));
                let half = |tau: f64| -> Option<[f64; 3]> {
                    let (x, y) = (
                        cross_derivative(*l, e, tau)?,
                        cross_derivative(*rr, e, tau)?,
                    );
                    Some(scale(sub(x, y), 0.5))
                };
                let (h1, h2) = (half(1.0 / 3.0)?, half(2.0 / 3.0)?);
                // Cubic Bernstein at 1/3 and 2/3 is (8, 12, 6, 1)/27 and (1, 6, 12, 8)/27.
                let y1 = sub(sub(scale(h1, 27.0), scale(r0, 8.0)), r3);
                let y2 = sub(sub(scale(h2, 27.0), r0), scale(r3, 8.0));
                let r1 = scale(sub(scale(y1, 2.0), y2), 1.0 / 18.0);
                let r2 = scale(sub(scale(y2, 2.0), y1), 1.0 / 18.0);
                return Some(Transversal::Symmetric {
                    r: [r0, r1, r2, r3],
                    first: *l,
                    c: [ca, cb],
                });
            }
            // Fitted: through the exact tangent planes at the ends and the midpoint.
            let q = faces.first().copied()?;
            let (r0, r1) = (cross(cu.n[0], t0), cross(cu.n[1], t1));
            let (ca, cb) = (corner_of(q, a), corner_of(q, b));
            let mid = [0, 1].map(|i| 0.5 * (CORNER[ca][i] + CORNER[cb][i]));
            let rm = match frames[q as usize].exact(exact, mid[0], mid[1]) {
                Some(s) => {
                    let mut nm = normalize(cross(s.du, s.dv));
                    if dot(nm, add(cu.n[0], cu.n[1])) < 0.0 {
                        nm = scale(nm, -1.0);
                    }
                    let th = [0, 1, 2]
                        .map(|x| 0.75 * (cu.c[2][x] + cu.c[3][x] - cu.c[0][x] - cu.c[1][x]));
                    sub(scale(cross(nm, th), 2.0), scale(add(r0, r1), 0.5))
                }
                None => scale(add(r0, r1), 0.5),
            };
            Some(Transversal::Fitted { r: [r0, rm, r1] })
        })
        .collect();
    let patches = (0..lvl.num_faces())
        .into_par_iter()
        .map(|q| {
            if lvl.face_hole[q] {
                return None;
            }
            face_patch(lvl, q, &curves, &transversals)
        })
        .collect();
    Ok((frames, patches))
}

fn face_patch(
    lvl: &Level,
    q: usize,
    curves: &[Option<Curve>],
    transversals: &[Option<Transversal>],
) -> Option<GregoryQuad> {
    let topo = &lvl.topo;
    let fv = topo.face_vertices(q);
    let mut g = GregoryQuad::default();
    let mut oriented = [[[0.0; 3]; 4]; 4];
    let mut forward = [true; 4];
    for i in 0..4 {
        let e = topo.face_edge(q, i) as usize;
        let c = curves[e]?.c;
        forward[i] = topo.edge_verts[e][0] == fv[i];
        oriented[i] = if forward[i] {
            c
        } else {
            [c[3], c[2], c[1], c[0]]
        };
        g.p[i] = oriented[i][0];
        g.e_plus[i] = oriented[i][1];
        g.e_minus[(i + 1) % 4] = oriented[i][2];
    }
    for i in 0..4 {
        let (a, b) = (i, (i + 1) % 4);
        let e = topo.face_edge(q, i) as usize;
        let c = oriented[i];
        let tp = [sub(c[1], c[0]), sub(c[2], c[1]), sub(c[3], c[2])].map(|x| scale(x, 3.0));
        let (dc1, dc2) = match transversals[e]? {
            Transversal::Symmetric { r, first, c: cc } => {
                let sign = if first as usize == q { 1.0 } else { -1.0 };
                let (r, (c0, c1)) = if forward[i] {
                    (r, (cc[0], cc[1]))
                } else {
                    ([r[3], r[2], r[1], r[0]], (cc[1], cc[0]))
                };
                let (a0, a1) = (c0, -c1);
                (
                    add(
                        scale(add(scale(tp[1], 2.0 * a0), scale(tp[0], a1)), 1.0 / 3.0),
                        scale(r[1], sign),
                    ),
                    add(
                        scale(add(scale(tp[2], a0), scale(tp[1], 2.0 * a1)), 1.0 / 3.0),
                        scale(r[2], sign),
                    ),
                )
            }
            Transversal::Fitted { r } => {
                let r = if forward[i] { r } else { [r[2], r[1], r[0]] };
                let d0 = scale(sub(g.e_minus[a], g.p[a]), 3.0);
                let d1 = scale(sub(g.e_plus[b], g.p[b]), 3.0);
                let (a0, b0) = decompose(d0, tp[0], r[0]);
                let (a1, b1) = decompose(d1, tp[2], r[2]);
                (
                    add(
                        scale(add(scale(tp[1], 2.0 * a0), scale(tp[0], a1)), 1.0 / 3.0),
                        scale(add(scale(r[1], 2.0 * b0), scale(r[0], b1)), 1.0 / 3.0),
                    ),
                    add(
                        scale(add(scale(tp[2], a0), scale(tp[1], 2.0 * a1)), 1.0 / 3.0),
                        scale(add(scale(r[2], b0), scale(r[1], 2.0 * b1)), 1.0 / 3.0),
                    ),
                )
            }
        };
        // D(t) = 3 Σ B_j (row 1 − row 0): the edge's two interior points.
        g.f_plus[a] = add(g.e_plus[a], scale(dc1, 1.0 / 3.0));
        g.f_minus[b] = add(g.e_minus[b], scale(dc2, 1.0 / 3.0));
    }
    Some(g)
}
