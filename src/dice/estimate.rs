//! Size of a diced mesh before it is made, from the edge rates alone, for the memory budget
//! ([`crate::memory`]).
//!
//! A domain whose sides have at most `R` segments has an interior grid of at most `R × R`
//! cells, so at most `(R + 1)²` points and `2(R + 1)²` triangles (the zippers that stitch the
//! sides replace the outermost cells); the estimate takes `R` per domain as the largest rate
//! of its face's edges (halved on n-gon sub-faces) and spokes, an upper bound.

use super::Rates;
use crate::refine::Level;

/// Bytes per diced vertex at the peak of [`super::dice`]: position, normal and `(face, k,
/// u, v)` (40 bytes), held twice while the domains are gathered into one mesh.
pub const VERTEX_BYTES: f64 = 80.0;
/// Bytes per diced triangle at the peak: indices and attributes (44 bytes), held twice.
pub const TRIANGLE_BYTES: f64 = 88.0;
/// Bytes per triangle of a BVH build ([`crate::bvh::MeshBvh`]): leaf corners and indices
/// (44), nodes with exact child boxes (about 70), and obvhs's binary hierarchy and
/// primitive boxes while building (about 140).
pub const BVH_TRIANGLE_BYTES: f64 = 256.0;

/// Upper bounds on the size of a diced mesh.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct DiceEstimate {
    /// Vertices.
    pub vertices: f64,
    /// Triangles.
    pub triangles: f64,
}

impl DiceEstimate {
    /// Peak bytes of dicing.
    pub fn bytes(&self) -> f64 {
        self.vertices * VERTEX_BYTES + self.triangles * TRIANGLE_BYTES
    }

    /// Peak bytes of dicing and then building the mesh's BVH.
    pub fn bytes_with_bvh(&self) -> f64 {
        self.bytes() + self.triangles * BVH_TRIANGLE_BYTES
    }
}

/// Estimates the diced mesh of `level` (a base level) with `rates`.
pub fn estimate(level: &Level, rates: &Rates) -> DiceEstimate {
    let topo = &level.topo;
    let mut est = DiceEstimate::default();
    for f in 0..topo.num_faces() {
        if level.face_hole[f] {
            continue;
        }
        let n = topo.face_size(f);
        let base = topo.face_offsets[f] as usize;
        let edges = topo.face_edge_list(f);
        let max_edge = edges
            .iter()
            .map(|&e| rates.edge[e as usize])
            .max()
            .unwrap_or(1) as f64;
        let (domains, r) = if n == 4 {
            (1.0, max_edge)
        } else {
            let spokes = rates.spoke[base..base + n]
                .iter()
                .copied()
                .max()
                .unwrap_or(1) as f64;
            (n as f64, (max_edge / 2.0).max(spokes))
        };
        let cells = (r + 1.0) * (r + 1.0);
        est.vertices += domains * cells;
        est.triangles += domains * 2.0 * cells;
    }
    est
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::dice::{dice, edge_rates, DiceOptions, DiceRate};
    use crate::mesh::shapes;
    use crate::patch::{PatchOptions, PatchTable};

    #[test]
    fn bounds_the_real_mesh() {
        // Quads with semi-sharp edges, and triangles (three sub-faces each).
        for mesh in [shapes::rounded_box(2.0), shapes::blob()] {
            let table = PatchTable::new(&mesh, PatchOptions::default()).unwrap();
            let (level, _) = Level::base(&mesh, &mesh.options).unwrap();
            for r in [1, 2, 7, 16] {
                let opts = DiceOptions {
                    rate: DiceRate::Uniform(r),
                    max_rate: 256,
                    displace: None,
                };
                let est = estimate(&level, &edge_rates(&table, &level, &opts).unwrap());
                let d = dice(&table, &mesh, &opts).unwrap();
                let (v, t) = (d.positions.len() as f64, d.triangles.len() as f64);
                assert!(
                    est.vertices >= v && est.triangles >= t,
                    "rate {r}: {est:?} {v} {t}"
                );
                // Not wildly above: within (1 + 1/R)² plus sharp-seam copies.
                assert!(
                    est.triangles <= 2.5 * t * (1.0 + 1.0 / r as f64).powi(2),
                    "rate {r}"
                );
            }
        }
    }
}
