//! Procedurally generated control meshes, for benchmarks and tests.

use super::ControlMesh;

/// An `n` × `n` grid of unit quads with a gentle height field, identical to the `--grid N`
/// mesh of OpenSubdiv's reference benchmark (`benches/osd/osd_refine_bench.cpp`):
///
/// - vertex `(i, j)`, `0 <= i, j <= n`, has index `i * (n + 1) + j` and position
///   `(i, j, 0.1 * sin(0.3 * i) * cos(0.2 * j))`, computed in `f64` (the reference stores it
///   rounded to `f32`);
/// - face `(i, j)`, `0 <= i, j < n`, has index `i * n + j` and vertices `(i, j)`, `(i + 1, j)`,
///   `(i + 1, j + 1)`, `(i, j + 1)` (counter-clockwise seen from +z);
/// - no tags, default options (edge-and-corner boundaries, uniform creases).
///
/// `n = 0` gives a single vertex and no faces.
///
/// ```
/// let mesh = limitray::mesh::generate::grid(2);
/// assert_eq!(mesh.num_vertices(), 9);
/// assert_eq!(mesh.face(3), &[4, 7, 8, 5]);
/// ```
pub fn grid(n: usize) -> ControlMesh {
    let side = n + 1;
    let mut positions = Vec::with_capacity(side * side);
    for i in 0..side {
        for j in 0..side {
            let (x, y) = (i as f64, j as f64);
            positions.push([x, y, 0.1 * (x * 0.3).sin() * (y * 0.2).cos()]);
        }
    }
    let idx = |i: usize, j: usize| u32::try_from(i * side + j).expect("grid too large for u32");
    let mut face_verts = Vec::with_capacity(n * n * 4);
    for i in 0..n {
        for j in 0..n {
            face_verts.extend_from_slice(&[
                idx(i, j),
                idx(i + 1, j),
                idx(i + 1, j + 1),
                idx(i, j + 1),
            ]);
        }
    }
    let face_offsets = (0..=n * n).map(|f| (f * 4) as u32).collect();
    ControlMesh {
        positions,
        face_offsets,
        face_verts,
        ..ControlMesh::default()
    }
}

/// Largest `n` of [`try_grid`]: `4n²` face-vertex indices must fit a `u32`.
pub const MAX_GRID: usize = 32_767;

/// [`grid`] after checking `n` (at most [`MAX_GRID`]) and the memory the mesh takes (positions
/// 24 bytes a vertex, faces 20 bytes) against the budget ([`crate::memory`]), so that
/// `--grid 100000` is an error rather than an out-of-memory abort.
pub fn try_grid(n: usize) -> crate::Result<ControlMesh> {
    if n > MAX_GRID {
        return Err(crate::Error::new(
            crate::ErrorKind::Usage,
            format!("--grid {n} is above the maximum of {MAX_GRID} (4n² indices must fit 32 bits)"),
        ));
    }
    let side = (n + 1) as f64;
    crate::memory::check(
        &format!("the {n} × {n} grid mesh"),
        side * side * 24.0 + (n * n) as f64 * 20.0,
        "lower --grid",
    )?;
    Ok(grid(n))
}

/// A disc of quads around one interior vertex of valence `n` (an extraordinary vertex for
/// `n != 4`): `n` sectors, each an `r` × `r` grid of quads, glued along rays from the centre.
///
/// - vertex 0 is the centre; ray `i` (`0 <= i < n`, direction angle `2πi/n`) has vertices
///   `1 + i r + (d − 1)` at distance `d = 1..=r`; then the inner vertices of each sector;
/// - sector `i` spans rays `i` and `i + 1`; its quad `(a, b)`, `0 <= a, b < r`, is face
///   `i r² + a r + b` with corners `(a, b)`, `(a + 1, b)`, `(a + 1, b + 1)`, `(a, b + 1)` in
///   the sector's coordinates (along ray `i`, along ray `i + 1`); face 0 has the centre at its
///   corner 0;
/// - position of sector point `(a, b)`: `a·dᵢ + b·dᵢ₊₁` in the plane, with the height
///   `0.1·sin(0.7 x)·cos(0.5 y)`; no tags, default options.
///
/// Every vertex other than the centre is regular (valence 4 inside, boundary vertices at the
/// rim). `n` must be at least 3 and `r` at least 1.
///
/// ```
/// let m = limitray::mesh::generate::star(5, 3);
/// assert_eq!(m.num_faces(), 45);
/// assert_eq!(m.face(0)[0], 0);
/// ```
pub fn star(n: usize, r: usize) -> ControlMesh {
    assert!(n >= 3 && r >= 1, "star({n}, {r}): needs n >= 3 and r >= 1");
    let rays = 1 + n * r;
    let nv = rays + n * r * r;
    let id = |i: usize, a: usize, b: usize| -> u32 {
        let v = match (a, b) {
            (0, 0) => 0,
            (a, 0) => 1 + i * r + (a - 1),
            (0, b) => 1 + ((i + 1) % n) * r + (b - 1),
            (a, b) => rays + i * r * r + (a - 1) * r + (b - 1),
        };
        u32::try_from(v).expect("star mesh too large for u32")
    };
    let mut positions = vec![[0.0; 3]; nv];
    let mut face_verts = Vec::with_capacity(4 * n * r * r);
    for i in 0..n {
        let angle = |k: usize| std::f64::consts::TAU * (k % n) as f64 / n as f64;
        let (d0, d1) = (angle(i), angle(i + 1));
        for a in 0..=r {
            for b in 0..=r {
                let (af, bf) = (a as f64, b as f64);
                let x = af * d0.cos() + bf * d1.cos();
                let y = af * d0.sin() + bf * d1.sin();
                positions[id(i, a, b) as usize] = [x, y, 0.1 * (0.7 * x).sin() * (0.5 * y).cos()];
            }
        }
        for a in 0..r {
            for b in 0..r {
                face_verts.extend_from_slice(&[
                    id(i, a, b),
                    id(i, a + 1, b),
                    id(i, a + 1, b + 1),
                    id(i, a, b + 1),
                ]);
            }
        }
    }
    let face_offsets = (0..=n * r * r).map(|f| (f * 4) as u32).collect();
    ControlMesh {
        positions,
        face_offsets,
        face_verts,
        ..ControlMesh::default()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn try_grid_checks() {
        assert_eq!(try_grid(3).unwrap(), grid(3));
        let e = try_grid(100_000).unwrap_err();
        assert_eq!(
            e.to_string(),
            "--grid 100000 is above the maximum of 32767 (4n² indices must fit 32 bits)"
        );
        assert!(crate::memory::check_with(1 << 30, "g", 32768.0 * 32768.0 * 44.0, "x").is_err());
    }

    #[test]
    fn counts_and_layout() {
        let m = grid(5);
        assert_eq!(m.num_vertices(), 36);
        assert_eq!(m.num_faces(), 25);
        assert_eq!(m.face_verts.len(), 100);
        m.validate().unwrap();
        // Face (1, 2) is face 7: vertices (1,2), (2,2), (2,3), (1,3).
        assert_eq!(m.face(7), &[8, 14, 15, 9]);
        let p = m.positions[2 * 6 + 3];
        assert_eq!(p[0], 2.0);
        assert_eq!(p[1], 3.0);
        assert_eq!(p[2], 0.1 * (2.0f64 * 0.3).sin() * (3.0f64 * 0.2).cos());
    }

    #[test]
    fn refines() {
        let m = grid(3);
        let r = crate::refine::Refiner::new(&m, 1).unwrap();
        // 9 faces -> 36; (3*2+1)^2 = 49 vertices.
        assert_eq!(r.levels[1].num_faces(), 36);
        assert_eq!(r.levels[1].num_vertices(), 49);
    }

    #[test]
    fn star_topology() {
        for n in [3, 5, 12] {
            let m = star(n, 3);
            m.validate().unwrap();
            let (l, _) = crate::refine::Level::base(&m, &m.options).unwrap();
            let t = &l.topo;
            assert_eq!(t.vertex_edges(0).len(), n);
            assert!(!t.vert_tags[0].boundary);
            for v in 1..m.num_vertices() {
                let regular = if t.vert_tags[v].boundary {
                    t.vertex_faces(v).len() <= 2
                } else {
                    t.vertex_edges(v).len() == 4
                };
                assert!(regular, "vertex {v} of star({n}, 3)");
            }
        }
    }

    #[test]
    fn empty() {
        let m = grid(0);
        assert_eq!(m.num_vertices(), 1);
        assert_eq!(m.num_faces(), 0);
    }
}
