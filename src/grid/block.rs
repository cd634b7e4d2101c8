//! Grid blocks: a diced domain's regular grid cut into blocks of at most
//! [`BLOCK`]` × `[`BLOCK`] quads, each stored once as `f32` vertex planes with compact
//! normals, its hierarchy implicit in the grid (quadrants of 4×4 quads, windows of 2×2 quads).

use super::node::Box4;

/// The largest block side, in quads.
pub const BLOCK: usize = 8;

/// A block's header. Its vertices are `(cols + 1) × (rows + 1)`, row by row, in three planes
/// (`x`, `y`, `z`) of [`super::GridMesh`]'s coordinates; everything about a hit on it — the
/// triangle's id in the diced mesh, the face, the `(u, v)` of its corners — follows from the
/// header and the grid index.
#[derive(Clone, Copy, Debug, Default, PartialEq, bytemuck::Zeroable)]
#[repr(C)]
pub struct Block {
    /// The hierarchy's first node: the windows of a block of at most 4×4 quads, else the
    /// quadrants.
    pub root: Box4,
    /// Offset of the `x` plane in the coordinates (`y`, `z` follow, one plane apart). Blocks'
    /// coordinates are consecutive, three per vertex, so the first vertex's normal is at
    /// [`Block::normal`]` = vert / 3`.
    pub vert: u32,
    /// Offset of the quadrants' [`Box4`] nodes (four, of their windows) when the block has
    /// more than 4×4 quads.
    pub boxes: u32,
    /// Offset of the per-triangle levels (two per quad, row by row) in
    /// [`super::GridMesh::levels`]; or, with [`LEVEL_UNIFORM`] set, the one level of all its
    /// triangles in the low byte (a block of a domain that is one patch stores no levels).
    pub level: u32,
    /// Diced-mesh id of the first quad's first triangle.
    pub tri0: u32,
    /// Id step from one quad row to the next (twice the region's width).
    pub tri_stride: u32,
    /// Base face.
    pub face: u32,
    /// Sub-face (0 for quads).
    pub k: u32,
    /// Grid point `(i, j)` of the first vertex in the domain's `nu × nv` grid.
    pub ij: [u32; 2],
    /// The domain's grid size: point `(i, j)` is at `(i / nu, j / nv)`.
    pub n: [u32; 2],
    /// Quads across and up (`1..=BLOCK`).
    pub cols: u8,
    /// See `cols`.
    pub rows: u8,
}

/// Flag of [`Block::level`]: every triangle of the block has the level in its low byte.
pub const LEVEL_UNIFORM: u32 = 1 << 31;

impl Block {
    /// The level of half `h` of quad `(x, y)`, from the block's uniform level or `levels`
    /// (the grid mesh's per-triangle levels).
    pub fn triangle_level(&self, levels: &[u8], x: usize, y: usize, h: usize) -> u8 {
        match self.level_index(x, y, h) {
            Some(i) => levels[i],
            None => self.level as u8,
        }
    }

    /// Where the level of half `h` of quad `(x, y)` is in the grid mesh's per-triangle levels;
    /// `None` when the block has one level for all its triangles.
    pub fn level_index(&self, x: usize, y: usize, h: usize) -> Option<usize> {
        (self.level & LEVEL_UNIFORM == 0)
            .then(|| self.level as usize + 2 * (y * self.cols as usize + x) + h)
    }

    /// Number of per-triangle levels the block stores.
    pub fn num_levels(&self) -> usize {
        if self.level & LEVEL_UNIFORM != 0 {
            0
        } else {
            2 * self.cols as usize * self.rows as usize
        }
    }

    /// Number of vertices.
    pub fn num_vertices(&self) -> usize {
        (self.cols as usize + 1) * (self.rows as usize + 1)
    }

    /// Index of the first vertex's normal in [`super::GridMesh::normals`].
    pub fn normal(&self) -> u32 {
        self.vert / 3
    }

    /// Whether the hierarchy has a quadrant level.
    pub fn two_level(&self) -> bool {
        self.cols as usize > BLOCK / 2 || self.rows as usize > BLOCK / 2
    }

    /// Number of [`Box4`] nodes besides the root.
    pub fn num_boxes(&self) -> usize {
        if self.two_level() {
            4
        } else {
            0
        }
    }

    /// Windows across and up.
    pub fn windows(&self) -> [usize; 2] {
        [
            (self.cols as usize).div_ceil(2),
            (self.rows as usize).div_ceil(2),
        ]
    }

    /// The triangle id of half `h` of quad `(x, y)`.
    pub fn triangle(&self, x: usize, y: usize, h: usize) -> u32 {
        self.tri0 + y as u32 * self.tri_stride + 2 * x as u32 + h as u32
    }

    /// `(u, v)` of vertex `(x, y)`, as the dicing computed it (`f64`, rounded once).
    pub fn uv(&self, x: usize, y: usize) -> [f32; 2] {
        [
            ((self.ij[0] as usize + x) as f64 / self.n[0] as f64) as f32,
            ((self.ij[1] as usize + y) as f64 / self.n[1] as f64) as f32,
        ]
    }

    /// [`Self::uv`] of quad `(x, y)`'s corners `(x, y)`, `(x + 1, y)`, `(x + 1, y + 1)` and
    /// `(x, y + 1)`, bit for bit: the two `(u, v)` divisions (SSE2) of its diagonal corners,
    /// whose coordinates the others share.
    #[inline]
    pub fn quad_uvs(&self, x: usize, y: usize) -> [[f32; 2]; 4] {
        #[cfg(target_arch = "x86_64")]
        // SAFETY: SSE2 is part of the x86_64 baseline.
        let [[u0, v0], [u1, v1]] = unsafe {
            use std::arch::x86_64::{_mm_div_pd, _mm_set_pd, _mm_storeu_pd};
            let n = _mm_set_pd(self.n[1] as f64, self.n[0] as f64);
            [(x, y), (x + 1, y + 1)].map(|(x, y)| {
                let ij = _mm_set_pd(
                    (self.ij[1] as usize + y) as f64,
                    (self.ij[0] as usize + x) as f64,
                );
                let mut q = [0f64; 2];
                _mm_storeu_pd(q.as_mut_ptr(), _mm_div_pd(ij, n));
                q.map(|c| c as f32)
            })
        };
        #[cfg(not(target_arch = "x86_64"))]
        let [[u0, v0], [u1, v1]] = [self.uv(x, y), self.uv(x + 1, y + 1)];
        [[u0, v0], [u1, v0], [u1, v1], [u0, v1]]
    }
}

// The header is nine 16-byte lines: its root box (six) and 46 bytes of fields.
const _: () = assert!(std::mem::size_of::<Block>() == 144);

/// Where a node slot of a block's hierarchy leads.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Slot {
    /// Box node `i` (relative to the block's first).
    Node(usize),
    /// Window `(wx, wy)`.
    Window(usize, usize),
}

/// Child `c` of box node `node` of block `b` (node 0: the root; node `1 + q`: quadrant `q`).
#[inline(always)]
pub fn slot(b: &Block, node: usize, c: usize) -> Slot {
    let (cx, cy) = (c % 2, c / 2);
    if !b.two_level() {
        Slot::Window(cx, cy)
    } else if node == 0 {
        Slot::Node(1 + c)
    } else {
        let q = node - 1;
        Slot::Window(2 * (q % 2) + cx, 2 * (q / 2) + cy)
    }
}

/// The boxes of block `b` whose vertices are stored as planes in `coords` (coordinate `a` of
/// vertex `(x, y)` at `coords[(3 * y + a) * (cols + 1) + x]`, as [`super::GridMesh`] stores
/// them): the root, returned, and the quadrants' nodes, written to `quadrants` (its
/// [`Block::num_boxes`] nodes). Per axis, each vertex row's extremes over each window's three
/// columns are found once, then a window's box from its three rows' (a row or column past the
/// block repeats its last); the box is its quadrant's child and a part of the root's.
pub fn plane_boxes(b: &Block, coords: &[f32], quadrants: &mut [Box4]) -> Box4 {
    let (cols, rows) = (b.cols as usize, b.rows as usize);
    let [wc, wr] = b.windows();
    let width = cols + 1;
    let two = b.two_level();
    let mut root = Box4::default();
    let mut quads = [Box4::default(); 4];
    // Plain comparisons (`minps`, `maxps`): the coordinates are finite, and on ties these
    // keep the first operand, as `f32::min` and `f32::max` do. Reducing each window's rows
    // first, then the rows in order, keeps the first extreme in row-major order, as point by
    // point (signed zeros included).
    let min = |a: f32, b: f32| if b < a { b } else { a };
    let max = |a: f32, b: f32| if b > a { b } else { a };
    for a in 0..3 {
        // Per vertex row, its extremes over each window's three columns (a column past the
        // block repeats the last).
        let mut row_lo = [[0f32; BLOCK / 2]; BLOCK + 1];
        let mut row_hi = [[0f32; BLOCK / 2]; BLOCK + 1];
        for y in 0..=rows {
            let row = &coords[(3 * y + a) * width..][..width];
            if let Ok(p) = <&[f32; BLOCK + 1]>::try_from(row) {
                // A full row: every window's columns are in it.
                row_lo[y] = std::array::from_fn(|w| min(min(p[2 * w], p[2 * w + 1]), p[2 * w + 2]));
                row_hi[y] = std::array::from_fn(|w| max(max(p[2 * w], p[2 * w + 1]), p[2 * w + 2]));
            } else {
                // The row's windows alone (the rest of `row_lo[y]` is never read); only the
                // last window's third column may lie past the block.
                for w in 0..wc {
                    let (a, b, c) = (row[2 * w], row[2 * w + 1], row[(2 * w + 2).min(cols)]);
                    row_lo[y][w] = min(min(a, b), c);
                    row_hi[y][w] = max(max(a, b), c);
                }
            }
        }
        for wy in 0..wr {
            // The window row's three vertex rows (a row past the block repeats the last).
            let [y0, y1, y2] = [0, 1, 2].map(|dy| (2 * wy + dy).min(rows));
            for wx in 0..wc {
                let l = min(min(row_lo[y0][wx], row_lo[y1][wx]), row_lo[y2][wx]);
                let h = max(max(row_hi[y0][wx], row_hi[y1][wx]), row_hi[y2][wx]);
                if two {
                    let (q, c) = (2 * (wy / 2) + wx / 2, 2 * (wy % 2) + wx % 2);
                    quads[q].lo[a][c] = l;
                    quads[q].hi[a][c] = h;
                    root.lo[a][q] = min(root.lo[a][q], l);
                    root.hi[a][q] = max(root.hi[a][q], h);
                } else {
                    root.lo[a][2 * wy + wx] = l;
                    root.hi[a][2 * wy + wx] = h;
                }
            }
        }
    }
    if two {
        quadrants.copy_from_slice(&quads);
    }
    root
}

#[cfg(test)]
mod tests {
    use super::*;

    /// [`Block::quad_uvs`] gives [`Block::uv`]'s bits at the quad's corners: random grid
    /// sizes (1 to 2^20 points a side) and positions in them.
    #[test]
    fn quad_uvs_are_uv_bit_for_bit() {
        let mut rng = crate::harness::rng::SplitMix64(116);
        for _ in 0..100_000 {
            let mut r = |n: u64| (rng.next_u64() % n) as u32;
            let n = [1 + r(1 << 20), 1 + r(1 << 20)];
            let b = Block {
                n,
                ij: [r(n[0] as u64), r(n[1] as u64)],
                ..Block::default()
            };
            let (x, y) = (r(8) as usize, r(8) as usize);
            let got = b.quad_uvs(x, y);
            let at = [(x, y), (x + 1, y), (x + 1, y + 1), (x, y + 1)];
            for (k, &(x, y)) in at.iter().enumerate() {
                assert_eq!(got[k].map(f32::to_bits), b.uv(x, y).map(f32::to_bits));
            }
        }
    }

    /// The boxes of a block whose vertex `(x, y)` is `p(x, y)`, point by point: the root,
    /// then the quadrants' nodes if any (the reference for [`plane_boxes`]).
    fn block_boxes(b: &Block, p: impl Fn(usize, usize) -> [f32; 3]) -> Vec<Box4> {
        let [wc, wr] = b.windows();
        let (cols, rows) = (b.cols as usize, b.rows as usize);
        let window_box = |bx: &mut Box4, c: usize, wx: usize, wy: usize| {
            for y in 2 * wy..=(2 * wy + 2).min(rows) {
                for x in 2 * wx..=(2 * wx + 2).min(cols) {
                    bx.include(c, p(x, y));
                }
            }
        };
        if !b.two_level() {
            let mut bx = Box4::default();
            for wy in 0..wr {
                for wx in 0..wc {
                    window_box(&mut bx, 2 * wy + wx, wx, wy);
                }
            }
            return vec![bx];
        }
        let mut out = vec![Box4::default(); 5];
        for q in 0..4 {
            for c in 0..4 {
                let (wx, wy) = (2 * (q % 2) + c % 2, 2 * (q / 2) + c / 2);
                if wx < wc && wy < wr {
                    // The window's box, once: its quadrant's child and a part of the root's.
                    let mut w = Box4::default();
                    window_box(&mut w, 0, wx, wy);
                    let [lo, hi] = w.child(0);
                    for (node, child) in [(1 + q, c), (0, q)] {
                        out[node].include(child, lo);
                        out[node].include(child, hi);
                    }
                }
            }
        }
        out
    }

    /// [`plane_boxes`] equals the point-by-point reference bit for bit on random blocks of
    /// every size from 1×1 to 8×8 quads (zeros of both signs among the coordinates).
    #[test]
    fn plane_boxes_are_the_points_boxes() {
        let mut rng = crate::harness::rng::SplitMix64(7);
        for cols in 1..=BLOCK as u8 {
            for rows in 1..=BLOCK as u8 {
                for _ in 0..20 {
                    let b = Block {
                        cols,
                        rows,
                        ..Block::default()
                    };
                    let width = cols as usize + 1;
                    let coords: Vec<f32> = (0..3 * width * (rows as usize + 1))
                        .map(|_| {
                            let r = rng.next_f64();
                            if r < 0.03 {
                                0.0
                            } else if r < 0.06 {
                                -0.0
                            } else {
                                ((r - 0.5) * 100.0) as f32
                            }
                        })
                        .collect();
                    let want = block_boxes(&b, |x, y| {
                        std::array::from_fn(|a| coords[(3 * y + a) * width + x])
                    });
                    let mut quadrants = vec![Box4::default(); b.num_boxes()];
                    let root = plane_boxes(&b, &coords, &mut quadrants);
                    let bits = |x: &Box4| [x.lo, x.hi].map(|p| p.map(|r| r.map(f32::to_bits)));
                    assert_eq!(bits(&root), bits(&want[0]), "{cols}x{rows} root");
                    for (q, w) in quadrants.iter().zip(&want[1..]) {
                        assert_eq!(bits(q), bits(w), "{cols}x{rows} quadrant");
                    }
                    assert_eq!(quadrants.len() + 1, want.len());
                }
            }
        }
    }

    #[test]
    fn slots_cover_the_windows() {
        for (cols, rows) in [(8u8, 8u8), (5, 3), (4, 4), (1, 1), (3, 8)] {
            let b = Block {
                cols,
                rows,
                ..Block::default()
            };
            let mut seen = std::collections::HashSet::new();
            let nodes = if b.two_level() {
                vec![1, 2, 3, 4]
            } else {
                vec![0]
            };
            for node in nodes {
                for c in 0..4 {
                    if let Slot::Window(x, y) = slot(&b, node, c) {
                        if x < b.windows()[0] && y < b.windows()[1] {
                            seen.insert((x, y));
                        }
                    }
                }
            }
            assert_eq!(seen.len(), b.windows()[0] * b.windows()[1], "{cols}x{rows}");
        }
    }
}
