//! Random evaluation queries and their parallel evaluation: the pieces of `limitray
//! bench-eval` and of the criterion benchmark `benches/eval.rs`.

use super::rng::SplitMix64;
use crate::coord::FaceCoord;
use crate::error::{Error, ErrorKind, Result};
use crate::patch::PatchTable;
use rayon::prelude::*;

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

    #[test]
    fn eval_queries_pentagon_sub_faces() {
        // A single pentagon has five sub-faces; all should be drawn.
        let pos = (0..5)
            .map(|i| {
                let a = i as f64 * std::f64::consts::TAU / 5.0;
                [a.cos(), a.sin(), 0.0]
            })
            .collect();
        let mesh = crate::mesh::MeshBuilder::new()
            .positions(pos)
            .faces(&[5], &[0, 1, 2, 3, 4])
            .build()
            .unwrap();
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
