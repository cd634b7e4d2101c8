//! The shared points of a dicing: every point on a side of a domain (base vertices, samples
//! on control edges, n-gon centres, samples on the spokes between sub-faces), evaluated once
//! in the domain of its owner face and used by every domain that has the side. They are the
//! diced mesh's first vertices, entity by entity: a *run* of points per entity, its points
//! generated from the run (each run is a few bytes where a list of every point's parameters
//! took 24 bytes a point: on a 316² grid, 16.8 MB written and paged in).

use super::face_edge_param;
use crate::coord::FaceCoord;
use crate::refine::Level;

/// The points of one entity, in its owner face `face` (of `n` sides).
#[derive(Clone, Copy, Debug)]
pub(super) struct Run {
    /// Index of its first point.
    pub first: u32,
    /// Owner face.
    pub face: u32,
    /// Sides of the owner face.
    n: u32,
    kind: RunKind,
}

/// What a [`Run`]'s points are.
#[derive(Clone, Copy, Debug)]
enum RunKind {
    /// The base vertex at corner `m` of the face (one point).
    Vertex { m: u32 },
    /// The `r − 1` inner samples of the face's edge `m` (rate `r`), from the edge's first
    /// vertex: along the face's edge when `forward`, else against it.
    Edge { m: u32, r: u32, forward: bool },
    /// The n-gon's centre (one point).
    Centre,
    /// The `s − 1` inner samples of spoke `k` (rate `s`), from the edge's midpoint inwards.
    Spoke { k: u32, s: u32 },
}

impl Run {
    /// Number of points.
    pub fn len(&self) -> usize {
        match self.kind {
            RunKind::Vertex { .. } | RunKind::Centre => 1,
            RunKind::Edge { r, .. } => r as usize - 1,
            RunKind::Spoke { s, .. } => s as usize - 1,
        }
    }

    /// The one domain `(face, k)` all its points lie in: a quad's (every run of a quad), the
    /// single point's (a corner, a centre), a spoke's sub-face; `None` for a run along an
    /// n-gon's edge (it crosses from one sub-face into the next).
    #[inline]
    pub fn one_domain(&self) -> Option<(u32, u32)> {
        match self.kind {
            _ if self.n == 4 => Some((self.face, 0)),
            RunKind::Vertex { m } => Some((self.face, m)),
            RunKind::Centre => Some((self.face, 0)),
            RunKind::Spoke { k, .. } => Some((self.face, k)),
            RunKind::Edge { .. } => None,
        }
    }

    /// Where its `i`-th point lies, in its owner's domains.
    #[inline]
    pub fn at(&self, i: usize) -> FaceCoord {
        let n = self.n as usize;
        let (k, u, v) = match self.kind {
            RunKind::Vertex { m } => face_edge_param(n, m as usize, 0.0),
            RunKind::Edge { m, r, forward } => {
                let j = i as u32 + 1;
                let t = if forward {
                    j as f64 / r as f64
                } else {
                    (r - j) as f64 / r as f64
                };
                face_edge_param(n, m as usize, t)
            }
            RunKind::Centre => (0, 1.0, 1.0),
            RunKind::Spoke { k, s } => (k, 1.0, (i + 1) as f64 / s as f64),
        };
        FaceCoord::new(self.face, k, u, v)
    }
}

/// The shared points' layout: the runs, and where each entity's points start.
pub(super) struct Shared {
    /// Every run with points, in point order (vertices, edges, then each n-gon's centre and
    /// spokes).
    pub runs: Vec<Run>,
    /// Number of points.
    pub len: usize,
    /// Index of each base vertex's point (`u32::MAX` if no live face uses it).
    pub vertex: Vec<u32>,
    /// First index of each edge's interior samples (`r_e - 1` of them, from `edge_verts[0]`).
    pub edge_first: Vec<u32>,
    /// Index of each n-gon's centre point.
    pub centre: Vec<u32>,
    /// First index of each n-gon spoke's interior samples, per face-vertex slot.
    pub spoke_first: Vec<u32>,
}

impl Shared {
    /// The shared points of `level` diced at edge rates `edge` and spoke rates `spoke`, each
    /// entity owned by its first live face.
    pub fn new(level: &Level, edge: &[u32], spoke: &[u32]) -> Shared {
        let topo = &level.topo;
        let live = |f: usize| !level.face_hole[f];
        let mut runs = Vec::with_capacity(topo.num_vertices + topo.num_edges());
        let mut len = 0u32;
        let mut push = |runs: &mut Vec<Run>, face: usize, kind: RunKind| {
            let run = Run {
                first: len,
                face: face as u32,
                n: topo.face_size(face) as u32,
                kind,
            };
            len += run.len() as u32;
            if run.len() > 0 {
                runs.push(run);
            }
            run.first
        };
        let mut vertex = vec![u32::MAX; topo.num_vertices];
        for (v, slot) in vertex.iter_mut().enumerate() {
            let faces = topo.vertex_faces(v);
            let corners = topo.vertex_face_corners(v);
            if let Some(i) = (0..faces.len()).find(|&i| live(faces[i] as usize)) {
                let m = corners[i];
                *slot = push(&mut runs, faces[i] as usize, RunKind::Vertex { m });
            }
        }
        let mut edge_first = vec![u32::MAX; topo.num_edges()];
        for (e, slot) in edge_first.iter_mut().enumerate() {
            let faces = topo.edge_face_list(e as u32);
            let Some(&f) = faces.iter().find(|&&f| live(f as usize)) else {
                continue;
            };
            let f = f as usize;
            let m = (0..topo.face_size(f))
                .find(|&m| topo.face_edge(f, m) == e as u32)
                .expect("edge of its face");
            let forward = topo.face_vertices(f)[m] == topo.edge_verts[e][0];
            let kind = RunKind::Edge {
                m: m as u32,
                r: edge[e],
                forward,
            };
            *slot = push(&mut runs, f, kind);
        }
        let mut centre = vec![u32::MAX; topo.num_faces()];
        let mut spoke_first = vec![u32::MAX; topo.face_verts.len()];
        for f in 0..topo.num_faces() {
            if topo.face_size(f) == 4 || !live(f) {
                continue;
            }
            centre[f] = push(&mut runs, f, RunKind::Centre);
            let base = topo.face_offsets[f] as usize;
            for k in 0..topo.face_size(f) {
                let s = spoke[base + k];
                spoke_first[base + k] = push(&mut runs, f, RunKind::Spoke { k: k as u32, s });
            }
        }
        Shared {
            runs,
            len: len as usize,
            vertex,
            edge_first,
            centre,
            spoke_first,
        }
    }

    /// Where shared point `i` lies, in its owner's domains.
    pub fn at(&self, i: u32) -> FaceCoord {
        let r = self.runs.partition_point(|r| r.first <= i) - 1;
        let run = &self.runs[r];
        run.at((i - run.first) as usize)
    }

    /// The runs in groups of at least `points` points each (the last may have fewer), each
    /// with its number of points, in order.
    pub fn groups(&self, points: usize) -> Vec<(&[Run], usize)> {
        let mut out = Vec::with_capacity(self.len / points.max(1) + 1);
        let (mut start, mut count) = (0, 0);
        for (i, r) in self.runs.iter().enumerate() {
            count += r.len();
            if count >= points || i + 1 == self.runs.len() {
                out.push((&self.runs[start..=i], count));
                (start, count) = (i + 1, 0);
            }
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::{generate, shapes, Options};

    /// The runs number the points in order without gaps, [`Shared::at`] finds each point's
    /// run, a run's one domain ([`Run::one_domain`]) is its points', every vertex's point is a
    /// corner of its owner's domain, and every edge's and spoke's samples lie on their side,
    /// evenly spaced, on meshes with n-gons (triangles) and holes, at rates 1 (no inner
    /// samples) to 7.
    #[test]
    fn runs_number_the_points_and_lie_on_their_sides() {
        let mut meshes = vec![
            shapes::gear(7),
            generate::star(5, 3),
            shapes::spindle(5),
            shapes::triangulated(&generate::grid(3)),
        ];
        let mut holed = generate::grid(4);
        holed.holes = vec![5];
        meshes.push(holed);
        for mesh in &meshes {
            let (level, _) = Level::base(mesh, &Options::default()).unwrap();
            let topo = &level.topo;
            for rate in 1..=7u32 {
                let edge: Vec<u32> = (0..topo.num_edges())
                    .map(|e| 1 + (e as u32 + rate) % rate)
                    .collect();
                let spoke = vec![rate; topo.face_verts.len()];
                let sh = Shared::new(&level, &edge, &spoke);
                let all: Vec<FaceCoord> = sh
                    .runs
                    .iter()
                    .flat_map(|r| (0..r.len()).map(move |i| r.at(i)))
                    .collect();
                assert_eq!(all.len(), sh.len);
                let mut next = 0;
                let mut crossing = 0;
                for r in &sh.runs {
                    assert_eq!(r.first as usize, next);
                    next += r.len();
                    // A run's one domain is every one of its points' (and only an n-gon's
                    // edge has none: its points may lie in two sub-faces).
                    let domains: Vec<(u32, u32)> =
                        (0..r.len()).map(|i| (r.at(i).face, r.at(i).k)).collect();
                    match r.one_domain() {
                        Some(d) => assert!(domains.iter().all(|&x| x == d), "{r:?}"),
                        None => {
                            assert!(r.n != 4 && matches!(r.kind, RunKind::Edge { .. }));
                            crossing += usize::from(domains.iter().any(|&x| x != domains[0]));
                        }
                    }
                }
                if (0..mesh.num_faces()).any(|f| mesh.face_size(f) != 4) && rate >= 3 {
                    assert!(crossing > 0, "no run crosses sub-faces");
                }
                for (i, &p) in all.iter().enumerate() {
                    assert_eq!(sh.at(i as u32), p, "point {i}");
                }
                for (v, &i) in sh.vertex.iter().enumerate() {
                    if i == u32::MAX {
                        continue;
                    }
                    let p = all[i as usize];
                    let corner = [p.u, p.v].iter().all(|&x| x == 0.0 || x == 1.0);
                    assert!(corner, "vertex {v}: {p:?}");
                    assert!(!level.face_hole[p.face as usize]);
                }
                for (e, &first) in sh.edge_first.iter().enumerate() {
                    if first == u32::MAX {
                        continue;
                    }
                    let r = edge[e] as usize;
                    let pts = &all[first as usize..first as usize + r - 1];
                    for p in pts {
                        let on_side = [p.u, p.v].iter().any(|&x| x == 0.0 || x == 1.0);
                        let corner = [p.u, p.v].iter().all(|&x| x == 0.0 || x == 1.0);
                        // An n-gon's edge midpoint is its sub-face's corner (1, 0).
                        let midpoint =
                            topo.face_size(p.face as usize) != 4 && (p.u, p.v) == (1.0, 0.0);
                        assert!(on_side && (!corner || midpoint), "edge {e}: {p:?}");
                    }
                }
                for (slot, &first) in sh.spoke_first.iter().enumerate() {
                    if first == u32::MAX {
                        continue;
                    }
                    for j in 0..rate as usize - 1 {
                        let p = all[first as usize + j];
                        assert_eq!(
                            (p.u, p.v),
                            (1.0, (j + 1) as f64 / rate as f64),
                            "slot {slot}"
                        );
                    }
                }
            }
        }
    }
}
