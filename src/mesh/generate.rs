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
    fn empty() {
        let m = grid(0);
        assert_eq!(m.num_vertices(), 1);
        assert_eq!(m.num_faces(), 0);
    }
}
