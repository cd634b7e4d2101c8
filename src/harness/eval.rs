//! Random evaluation queries and their parallel evaluation: the pieces of `limitray
//! bench-eval` and of the criterion benchmark `benches/eval.rs`.

use super::rng::SplitMix64;
use crate::coord::FaceCoord;
use crate::error::{Error, ErrorKind, Result};
use crate::mesh::ControlMesh;
use crate::patch::table::tree::{CORNER, UAX, VAX};
use crate::patch::PatchTable;
use crate::refine::{step, Level};
use rayon::prelude::*;

/// Where [`eval_queries_near`] places its queries.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "cli", derive(clap::ValueEnum))]
pub enum Near {
    /// `u` and `v` uniform in `[0, 1)` (as [`eval_queries`]).
    Uniform,
    /// The centre `(0.5, 0.5)` of each (sub-)face.
    Centre,
    /// Within [`EV_DISTANCE`] (in each of `u` and `v`) of a corner of the (sub-)face that is an
    /// extraordinary vertex.
    Ev,
}

impl Near {
    /// The name printed in benchmark output.
    pub fn name(self) -> &'static str {
        match self {
            Near::Uniform => "uniform",
            Near::Centre => "centre",
            Near::Ev => "ev",
        }
    }
}

/// How close to an extraordinary corner [`Near::Ev`] queries lie: 2^-10 of the (sub-)face.
pub const EV_DISTANCE: f64 = 1.0 / 1024.0;

/// The extraordinary corners of every (sub-)face of `mesh` that is not a hole in `table`:
/// `(face, k, corner)` with `corner` 0..4 in the (sub-)face's `(u, v)` (0 at `(0, 0)`, 1 at
/// `(1, 0)`, 2 at `(1, 1)`, 3 at `(0, 1)`). A vertex is extraordinary when it is neither an
/// interior vertex of valence 4 nor a boundary vertex of valence 3 nor a corner of valence 2
/// (sub-faces of n-gons are read at level 1, where the face point has valence n).
pub fn extraordinary_corners(
    mesh: &ControlMesh,
    table: &PatchTable,
) -> Result<Vec<(u32, u32, u8)>> {
    let (base, _) = Level::base(mesh, &table.mesh_options)?;
    let (one, _) = step::refine(&base, table.method);
    let ev = |level: &Level, v: usize| {
        let t = &level.topo;
        let n = t.vertex_edges(v).len();
        let faces = t.vertex_faces(v).len();
        let regular = if t.vert_tags[v].boundary {
            (n == 3 && faces == 2) || (n == 2 && faces == 1)
        } else {
            n == 4 && faces == 4
        };
        !regular || t.vert_tags[v].nonmanifold
    };
    let mut out = Vec::new();
    for f in 0..table.num_faces() {
        if table.eval(FaceCoord::quad(f as u32, 0.5, 0.5)).is_err() {
            continue;
        }
        let n = base.topo.face_size(f);
        for k in 0..table.sub_faces(f) {
            let (level, verts) = if n == 4 {
                (&base, base.topo.face_vertices(f))
            } else {
                let c = crate::patch::local::child_face(&base, f, k);
                (&one, one.topo.face_vertices(c))
            };
            for (c, &v) in verts.iter().enumerate() {
                if ev(level, v as usize) {
                    out.push((f as u32, k as u32, c as u8));
                }
            }
        }
    }
    Ok(out)
}

/// `samples` queries placed by `near`, deterministic in `seed`. [`Near::Uniform`] is
/// [`eval_queries`]; [`Near::Centre`] draws (sub-)faces like it and evaluates at `(0.5, 0.5)`;
/// [`Near::Ev`] draws uniformly among the extraordinary corners
/// ([`extraordinary_corners`]) and places the query uniformly in the square of side
/// [`EV_DISTANCE`] at that corner, inside the (sub-)face. Fails when there is nothing to
/// sample (no faces, or for `Ev` no extraordinary corner).
pub fn eval_queries_near(
    mesh: &ControlMesh,
    table: &PatchTable,
    samples: usize,
    seed: u64,
    near: Near,
) -> Result<Vec<FaceCoord>> {
    match near {
        Near::Uniform => eval_queries(table, samples, seed),
        Near::Centre => Ok(eval_queries(table, samples, seed)?
            .into_iter()
            .map(|q| FaceCoord {
                u: 0.5,
                v: 0.5,
                ..q
            })
            .collect()),
        Near::Ev => {
            let corners = extraordinary_corners(mesh, table)?;
            if corners.is_empty() && samples > 0 {
                return Err(Error::new(
                    ErrorKind::Usage,
                    "the mesh has no extraordinary vertex to sample near",
                ));
            }
            let mut rng = SplitMix64(seed);
            Ok((0..samples)
                .map(|_| {
                    let (face, k, c) = corners[rng.below(corners.len())];
                    let c = c as usize;
                    let s = rng.next_f64() * EV_DISTANCE;
                    let t = rng.next_f64() * EV_DISTANCE;
                    let uv =
                        |i: usize| (CORNER[c][i] + s * UAX[c][i] + t * VAX[c][i]).clamp(0.0, 1.0);
                    FaceCoord {
                        face,
                        k,
                        u: uv(0),
                        v: uv(1),
                    }
                })
                .collect())
        }
    }
}

/// `samples` random queries, deterministic in `seed`: the face uniform over the base faces
/// that are not holes, the sub-face uniform over that face's sub-faces, `u` and `v` uniform in
/// `[0, 1)`. A face counts as a hole when evaluating its centre fails (the table marks holes,
/// whether tagged or made by the boundary rule, as empty). Fails when every face is a hole.
pub fn eval_queries(table: &PatchTable, samples: usize, seed: u64) -> Result<Vec<FaceCoord>> {
    let faces: Vec<u32> = (0..table.num_faces())
        .filter(|&f| table.eval(FaceCoord::quad(f as u32, 0.5, 0.5)).is_ok())
        .map(|f| u32::try_from(f).expect("face index fits u32"))
        .collect();
    if faces.is_empty() && samples > 0 {
        return Err(Error::new(
            ErrorKind::Usage,
            "the mesh has no faces to evaluate (all are holes)",
        ));
    }
    let mut rng = SplitMix64(seed);
    Ok((0..samples)
        .map(|_| {
            let face = faces[rng.below(faces.len())];
            let k = rng.below(table.sub_faces(face as usize)) as u32;
            let u = rng.next_f64();
            let v = rng.next_f64();
            FaceCoord { face, k, u, v }
        })
        .collect())
}

/// Evaluates `queries` in parallel (rayon, in the current pool) and returns the limit
/// positions in query order.
pub fn eval_batch(table: &PatchTable, queries: &[FaceCoord]) -> Result<Vec<[f64; 3]>> {
    queries
        .par_iter()
        .map(|q| table.eval(*q).map(|s| s.p))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::generate;
    use crate::patch::PatchOptions;

    #[test]
    fn eval_queries_skip_holes_and_are_deterministic() {
        let mut mesh = generate::grid(4);
        mesh.holes = vec![5, 6];
        let table = PatchTable::new(&mesh, PatchOptions::default()).unwrap();
        let a = eval_queries(&table, 2000, 42).unwrap();
        assert_eq!(a, eval_queries(&table, 2000, 42).unwrap());
        assert_ne!(a, eval_queries(&table, 2000, 43).unwrap());
        let mut seen = [0usize; 16];
        for q in &a {
            assert!(q.face != 5 && q.face != 6, "query on a hole: {q:?}");
            assert_eq!(q.k, 0);
            assert!((0.0..1.0).contains(&q.u) && (0.0..1.0).contains(&q.v));
            seen[q.face as usize] += 1;
        }
        // Roughly uniform over the 14 other faces (2000 / 14 ≈ 143 each).
        assert!(seen
            .iter()
            .enumerate()
            .all(|(f, &n)| f == 5 || f == 6 || (80..220).contains(&n)));
        let points = eval_batch(&table, &a).unwrap();
        assert_eq!(points.len(), a.len());
        // All faces holes: nothing to sample.
        mesh.holes = (0..16).collect();
        let table = PatchTable::new(&mesh, PatchOptions::default()).unwrap();
        assert!(eval_queries(&table, 10, 1).is_err());
    }

    /// One regular pentagon in the z = 0 plane.
    fn pentagon() -> ControlMesh {
        let pos = (0..5)
            .map(|i| {
                let a = i as f64 * std::f64::consts::TAU / 5.0;
                [a.cos(), a.sin(), 0.0]
            })
            .collect();
        crate::mesh::MeshBuilder::new()
            .positions(pos)
            .faces(&[5], &[0, 1, 2, 3, 4])
            .build()
            .unwrap()
    }

    #[test]
    fn queries_near_extraordinary_corners() {
        // A pentagon: the centre (level-1 face point, valence 5) is corner 2 of each
        // sub-face; its own corners are boundary corners of valence 2 (regular).
        let mesh = pentagon();
        let table = PatchTable::new(&mesh, PatchOptions::default()).unwrap();
        let corners = extraordinary_corners(&mesh, &table).unwrap();
        assert_eq!(corners, (0..5).map(|k| (0, k, 2)).collect::<Vec<_>>());
        let q = eval_queries_near(&mesh, &table, 200, 5, Near::Ev).unwrap();
        for x in &q {
            assert!(x.u > 1.0 - EV_DISTANCE && x.v > 1.0 - EV_DISTANCE, "{x:?}");
        }
        let c = eval_queries_near(&mesh, &table, 10, 5, Near::Centre).unwrap();
        assert!(c.iter().all(|x| x.u == 0.5 && x.v == 0.5));
        // A grid has no extraordinary vertex.
        let grid = generate::grid(3);
        let table = PatchTable::new(&grid, PatchOptions::default()).unwrap();
        assert!(eval_queries_near(&grid, &table, 10, 1, Near::Ev).is_err());
    }

    #[test]
    fn eval_queries_pentagon_sub_faces() {
        // A single pentagon has five sub-faces; all should be drawn.
        let mesh = pentagon();
        let table = PatchTable::new(&mesh, PatchOptions::default()).unwrap();
        assert_eq!(table.sub_faces(0), 5);
        let q = eval_queries(&table, 500, 3).unwrap();
        let mut seen = [false; 5];
        for x in &q {
            seen[x.k as usize] = true;
        }
        assert!(seen.iter().all(|&s| s));
        assert_eq!(eval_batch(&table, &q).unwrap().len(), 500);
    }
}
