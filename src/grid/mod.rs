//! The grid tracing core: a diced limit surface as grid blocks under one top-level BVH.
//!
//! Each diced domain's regular grid ([`crate::dice::GridRegion`]) is cut into blocks of at
//! most 8×8 quads ([`block`]). A block stores its vertices once, as `f32` planes, with
//! octahedral normals ([`crate::oct`]); its hierarchy is implicit (quadrants, then 2×2-quad
//! windows, boxes in [`node::Box4`]), and its leaf test runs on the eight triangles of a
//! window at once ([`window`]). The triangles outside the grids (zippers between different
//! rates, tiny domains) are *loose* triangles with their own records, grouped into strips of
//! at most [`STRIP`] consecutive triangles of one domain. An 8-wide BVH over blocks and
//! strips is the top level ([`top`]: a binary tree of binned SAH splits, `binned.rs`,
//! collapsed by [`collapse`]), its boxes exact.
//!
//! The vertices are the diced mesh's `f32` points, copied bit for bit: a vertex on a shared
//! edge has the same bits in every block and loose triangle that holds it, and every triangle
//! is tested with the same watertight test as [`crate::bvh::MeshBvh`] on the same corners in
//! the same order. Hits and `t` are therefore those of the triangle BVH; on equal `t` the
//! lowest triangle id among those the walk reaches wins. Which of several triangles at
//! exactly the same `t` the walk reaches can depend on its order: the culling compares
//! rounded quantities (a box's entry distance, the leaf test's `t_scaled` against `tmax ×
//! det`) with the best `t` so far. The GPU kernels therefore walk the same tree in the same
//! order as this walk, and `tests/gpu.rs` checks that they agree bit for bit, ties included.

mod binned;
pub mod block;
mod build;
pub mod collapse;
mod emit;
mod grouped;
pub mod node;
pub mod top;
pub mod window;

use crate::bvh::mesh::Corners;
use crate::bvh::ray::{Hit, Ray};
use crate::bvh::triangle::{intersect_prepared, PreparedRay};
use crate::oct::oct_decode3;
use block::{slot, Block, Slot};
use node::{child_of, in_order, test4, Box4};
use rayon::prelude::*;
use top::{Top, Visit};
use window::{lane_mask, Rows};

/// A triangle outside the grids, with everything its hits need.
#[derive(Clone, Copy, Debug, PartialEq, bytemuck::Zeroable)]
pub struct Loose {
    /// Corners.
    pub p: [[f32; 3]; 3],
    /// Octahedral normals of the corners (zero in a mesh without
    /// [`GridMesh::shading_normals`]).
    pub n: [u32; 3],
    /// `(u, v)` of the corners.
    pub uv: [[f32; 2]; 3],
    /// Id in the diced mesh.
    pub id: u32,
    /// Base face.
    pub face: u32,
    /// Sub-face.
    pub k: u32,
    /// Subdivision level at its centroid.
    pub level: u8,
}

/// A diced limit surface as grid blocks and loose triangles under a top-level BVH.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct GridMesh {
    /// Block headers.
    pub blocks: Vec<Block>,
    /// Vertex coordinates of all blocks (per block, row by row: the row's `x`, then `y`, then
    /// `z` values), then four padding values (window rows are read four values at a time).
    pub coords: Vec<f32>,
    /// Octahedral vertex normals of all blocks (empty without [`Self::shading_normals`]).
    pub normals: Vec<u32>,
    /// Box nodes of all blocks.
    pub boxes: Vec<Box4>,
    /// Per-triangle subdivision levels of all blocks.
    pub levels: Vec<u8>,
    /// Triangles outside the grids.
    pub loose: Vec<Loose>,
    /// Strips of loose triangles: `[first, count]` in [`Self::loose`], at most [`STRIP`]
    /// consecutive loose triangles of one domain, each strip one primitive of the top level.
    pub strips: Vec<[u32; 2]>,
    /// Top level over blocks (primitives `0..blocks.len()`) then strips (primitive
    /// `blocks.len() + i`).
    pub top: Top,
    /// Per block, then one entry past the last: the offset of its coordinates, and of its
    /// quadrant nodes in `boxes` (`u32::MAX`: none), for the traversal's prefetch. A block's
    /// coordinates end where the next one's start, so the prefetch reads its sizes here, in
    /// one or two adjacent entries (reading them from its header stalled the walk on the
    /// header's cache miss).
    pub fetch: Vec<[u32; 2]>,
    /// Number of triangles.
    pub triangles: usize,
    /// Bounds of all vertices (`[min, max]`; inverted when empty).
    pub bounds: [[f32; 3]; 2],
    /// Whether the mesh stores the limit surface's unit normals at its vertices, which hits
    /// interpolate as their shading normal ([`Hit::ns`]); without them
    /// ([`GridMesh::dice_geometry`]) a hit's shading normal is its geometric normal.
    pub shading_normals: bool,
}

/// The most loose triangles in one strip (one top-level primitive).
pub const STRIP: usize = 8;

/// Marks a loose triangle's location in a [`Hit::leaf`] (its index in [`GridMesh::loose`]
/// below); a location without it is the block `leaf >> 7`, quad row `(leaf >> 4) & 7`, column
/// `(leaf >> 1) & 7`, half `leaf & 1` (blocks have at most 8×8 quads, and a mesh at most
/// 2^24 blocks).
pub const LEAF_LOOSE: u32 = 1 << 31;

/// Where a hit was found.
#[derive(Clone, Copy, Debug)]
enum Found {
    /// Block, quad `(x, y)`, half.
    Grid(u32, u8, u8, u8),
    /// Loose triangle.
    Loose(u32),
}

impl Found {
    /// The location as a [`Hit::leaf`].
    fn leaf(self) -> u32 {
        match self {
            Found::Grid(b, x, y, h) => (b << 7) | ((y as u32) << 4) | ((x as u32) << 1) | h as u32,
            Found::Loose(i) => LEAF_LOOSE | i,
        }
    }

    /// The location of a [`Hit::leaf`].
    fn of(leaf: u32) -> Found {
        if leaf & LEAF_LOOSE != 0 {
            Found::Loose(leaf & !LEAF_LOOSE)
        } else {
            Found::Grid(
                leaf >> 7,
                ((leaf >> 1) & 7) as u8,
                ((leaf >> 4) & 7) as u8,
                (leaf & 1) as u8,
            )
        }
    }
}

#[derive(Clone, Copy, Debug)]
struct Best {
    at: Found,
    id: u32,
    t: f32,
    b1: f32,
    b2: f32,
}

/// Whether a hit at `t` on triangle `id` beats `best`: nearer, or as near on a lower id.
#[inline(always)]
fn beats(best: Option<Best>, t: f32, id: u32) -> bool {
    best.is_none_or(|x| t < x.t || (t == x.t && id < x.id))
}

/// What [`GridMesh::walk_block`] does at each window met (a trait, not a closure: see
/// [`Visit`]).
trait Leaf {
    /// Tests window `(wx, wy)` of block `b` within `tmax`: the new `tmax` and whether to stop.
    fn leaf(&mut self, b: &Block, wx: usize, wy: usize, tmax: f32) -> (f32, bool);
}

/// A closest-hit query's walk: the nearest hit so far (ties to the lowest triangle id).
struct Closest<'a, const AVX2: bool> {
    mesh: &'a GridMesh,
    r: &'a PreparedRay,
    /// The block being walked.
    block: u32,
    best: Option<Best>,
}

impl<'a, const AVX2: bool> Closest<'a, AVX2> {
    /// # Safety
    /// With `AVX2`, the processor must have AVX2 (its methods run the AVX2 leaf test).
    unsafe fn new(mesh: &'a GridMesh, r: &'a PreparedRay) -> Self {
        Closest {
            mesh,
            r,
            block: 0,
            best: None,
        }
    }
}

impl<const AVX2: bool> Leaf for Closest<'_, AVX2> {
    #[inline(always)]
    fn leaf(&mut self, b: &Block, wx: usize, wy: usize, tmax: f32) -> (f32, bool) {
        let (w, lanes) = self.mesh.window(b, wx, wy);
        // SAFETY: with `AVX2` the processor has AVX2 (the contract of `Closest::new`).
        let found = unsafe { window::window_with::<AVX2>(self.r, &w, lanes, tmax) };
        if let Some((l, t, b1, b2)) = found {
            let (qy, qx, h) = (l / 4, (l / 2) % 2, l % 2);
            let (x, y) = (2 * wx + qx, 2 * wy + qy);
            let id = b.triangle(x, y, h);
            if beats(self.best, t, id) {
                self.mesh.prefetch_record(b, x, y);
                self.best = Some(Best {
                    at: Found::Grid(self.block, x as u8, y as u8, h as u8),
                    id,
                    t,
                    b1,
                    b2,
                });
                return (t, false);
            }
        }
        (tmax, false)
    }
}

impl<const AVX2: bool> Visit for Closest<'_, AVX2> {
    #[inline(always)]
    fn visit(&mut self, prim: u32, tmax: f32) -> (f32, bool) {
        let (mesh, r) = (self.mesh, self.r);
        let nblocks = mesh.blocks.len();
        let prim = prim as usize;
        if prim < nblocks {
            self.block = prim as u32;
            let (t, _) = mesh.walk_block::<true>(prim, r, tmax, self);
            return (t, false);
        }
        let [first, count] = mesh.strips[prim - nblocks];
        let mut tmax = tmax;
        for li in first..first + count {
            let tri = &mesh.loose[li as usize];
            let [a, b, c] = tri.p;
            if let Some((t, b1, b2)) = intersect_prepared(r, a, b, c, tmax) {
                if beats(self.best, t, tri.id) {
                    self.best = Some(Best {
                        at: Found::Loose(li),
                        id: tri.id,
                        t,
                        b1,
                        b2,
                    });
                    tmax = t;
                }
            }
        }
        (tmax, false)
    }

    #[inline(always)]
    fn prefetch(&self, prim: u32) {
        self.mesh.prefetch::<true>(prim);
    }
}

/// An any-hit query's walk: whether anything was hit.
struct Occluded<'a, const AVX2: bool> {
    mesh: &'a GridMesh,
    r: &'a PreparedRay,
    hit: bool,
}

impl<'a, const AVX2: bool> Occluded<'a, AVX2> {
    /// # Safety
    /// With `AVX2`, the processor must have AVX2 (its methods run the AVX2 leaf test).
    unsafe fn new(mesh: &'a GridMesh, r: &'a PreparedRay) -> Self {
        Occluded {
            mesh,
            r,
            hit: false,
        }
    }
}

impl<const AVX2: bool> Leaf for Occluded<'_, AVX2> {
    #[inline(always)]
    fn leaf(&mut self, b: &Block, wx: usize, wy: usize, tmax: f32) -> (f32, bool) {
        let (w, lanes) = self.mesh.window(b, wx, wy);
        // SAFETY: with `AVX2` the processor has AVX2 (the contract of `Occluded::new`).
        let found = unsafe { window::window_with::<AVX2>(self.r, &w, lanes, tmax) };
        (tmax, found.is_some())
    }
}

impl<const AVX2: bool> Visit for Occluded<'_, AVX2> {
    #[inline(always)]
    fn visit(&mut self, prim: u32, tmax: f32) -> (f32, bool) {
        let (mesh, r) = (self.mesh, self.r);
        let nblocks = mesh.blocks.len();
        let prim = prim as usize;
        self.hit = if prim < nblocks {
            mesh.walk_block::<false>(prim, r, tmax, self).1
        } else {
            let [first, count] = mesh.strips[prim - nblocks];
            mesh.loose[first as usize..(first + count) as usize]
                .iter()
                .any(|l| intersect_prepared(r, l.p[0], l.p[1], l.p[2], tmax).is_some())
        };
        (tmax, self.hit)
    }

    #[inline(always)]
    fn prefetch(&self, prim: u32) {
        self.mesh.prefetch::<false>(prim);
    }
}

impl GridMesh {
    /// Prefetches what visiting primitive `prim` reads first: a block's header and root, its
    /// quadrant nodes and its vertices; with `NORMALS`, its vertices' normals too, which a
    /// closest-hit query's hit record reads (unprefetched, the record's load of its corners'
    /// normals missed the cache on most hits: on the 316² grid a coherent ray took 35% longer).
    #[inline(always)]
    fn prefetch<const NORMALS: bool>(&self, prim: u32) {
        use crate::prefetch::prefetch_bytes;
        let i = prim as usize;
        if let (Some(&[v, q]), Some(&[end, _])) = (self.fetch.get(i), self.fetch.get(i + 1)) {
            prefetch_bytes(
                self.blocks.as_ptr().wrapping_add(i),
                std::mem::size_of::<Block>(),
            );
            if q != u32::MAX {
                prefetch_bytes(
                    self.boxes.as_ptr().wrapping_add(q as usize),
                    4 * std::mem::size_of::<Box4>(),
                );
            }
            let (v, coords) = (v as usize, end.wrapping_sub(v) as usize);
            prefetch_bytes(self.coords.as_ptr().wrapping_add(v), 4 * coords);
            if NORMALS && self.shading_normals {
                prefetch_bytes(self.normals.as_ptr().wrapping_add(v / 3), 4 * coords / 3);
            }
        }
    }

    /// Prefetches what the hit record of quad `(x, y)` of block `b` reads beyond the block's
    /// vertices: its corners' normals (two rows, where the mesh has them) and its triangles'
    /// levels.
    #[inline(always)]
    fn prefetch_record(&self, b: &Block, x: usize, y: usize) {
        #[cfg(target_arch = "x86_64")]
        {
            use std::arch::x86_64::{_mm_prefetch, _MM_HINT_T0};
            if self.shading_normals {
                let w = b.cols as usize + 1;
                let first = b.normal() as usize + y * w + x;
                let p = self.normals.as_ptr().wrapping_add(first) as *const i8;
                // The quad's diagonal corners `(x, y)` and `(x + 1, y + 1)`; the other two
                // share their lines unless a line ends between them.
                // SAFETY: prefetching never faults and has no effect on memory.
                unsafe {
                    _mm_prefetch::<_MM_HINT_T0>(p);
                    _mm_prefetch::<_MM_HINT_T0>(p.wrapping_add(4 * w + 4));
                }
            }
            if let Some(at) = b.level_index(x, y, 0) {
                // SAFETY: as above.
                unsafe {
                    _mm_prefetch::<_MM_HINT_T0>(self.levels.as_ptr().wrapping_add(at) as *const i8)
                };
            }
        }
        #[cfg(not(target_arch = "x86_64"))]
        let _ = (b, x, y);
    }

    /// Memory of everything the queries read, in bytes.
    pub fn bytes(&self) -> usize {
        self.blocks.len() * std::mem::size_of::<Block>()
            + self.coords.len() * 4
            + self.normals.len() * 4
            + self.boxes.len() * std::mem::size_of::<Box4>()
            + self.levels.len()
            + self.loose.len() * std::mem::size_of::<Loose>()
            + self.strips.len() * std::mem::size_of::<[u32; 2]>()
            + self.top.bytes()
            + self.fetch.len() * 8
    }

    /// Bounds of the mesh.
    pub fn bounds(&self) -> [[f32; 3]; 2] {
        self.bounds
    }

    /// The rows of window `(wx, wy)` of block `b` (a row past the block repeats its last; a
    /// column past it reads the next row's first vertex: their lanes are absent) and its
    /// lanes.
    #[inline(always)]
    fn window(&self, b: &Block, wx: usize, wy: usize) -> (Rows<'_>, u32) {
        let (cols, rows) = (b.cols as usize, b.rows as usize);
        let offs = std::array::from_fn(|y| 3 * (2 * wy + y).min(rows) * (cols + 1) + 2 * wx);
        let qx = (cols - 2 * wx).min(2);
        let qy = (rows - 2 * wy).min(2);
        (
            Rows {
                coords: &self.coords[b.vert as usize..],
                plane: cols + 1,
                offs,
            },
            lane_mask(qx, qy),
        )
    }

    /// Walks block `bi`'s hierarchy front to back (in child order without `ORDERED`: any-hit
    /// queries), calling [`Leaf::leaf`] for each window met, which returns the new `tmax` and
    /// whether to stop.
    #[inline(always)]
    fn walk_block<const ORDERED: bool>(
        &self,
        bi: usize,
        r: &PreparedRay,
        mut tmax: f32,
        leaf: &mut impl Leaf,
    ) -> (f32, bool) {
        let b = &self.blocks[bi];
        let boxes = &self.boxes[b.boxes as usize..b.boxes as usize + b.num_boxes()];
        let (mask, near) = test4(&b.root, r, tmax);
        let mut order = [0; 4];
        let n = in_order::<ORDERED, 4>(mask, &near, &mut order);
        for &k in &order[..n] {
            let c = child_of(k);
            if near[c] > tmax {
                continue;
            }
            match slot(b, 0, c) {
                Slot::Window(wx, wy) => {
                    let (t, stop) = leaf.leaf(b, wx, wy, tmax);
                    tmax = t;
                    if stop {
                        return (tmax, true);
                    }
                }
                Slot::Node(q) => {
                    let (m2, near2) = test4(&boxes[q - 1], r, tmax);
                    let mut order2 = [0; 4];
                    let n2 = in_order::<ORDERED, 4>(m2, &near2, &mut order2);
                    for &k2 in &order2[..n2] {
                        let c2 = child_of(k2);
                        if near2[c2] > tmax {
                            continue;
                        }
                        if let Slot::Window(wx, wy) = slot(b, q, c2) {
                            let (t, stop) = leaf.leaf(b, wx, wy, tmax);
                            tmax = t;
                            if stop {
                                return (tmax, true);
                            }
                        }
                    }
                }
            }
        }
        (tmax, false)
    }

    /// Closest hit of `ray` in `[tmin, tmax]`.
    pub fn intersect(&self, ray: &Ray) -> Option<Hit> {
        #[cfg(target_arch = "x86_64")]
        if window::has_avx2() {
            // SAFETY: AVX2 is present (detected).
            return unsafe { self.intersect_avx2(ray) };
        }
        // SAFETY: without `AVX2` nothing beyond the baseline is used.
        unsafe { self.intersect_with::<false>(ray) }
    }

    /// [`Self::intersect`] compiled for AVX2 (the whole traversal, the eight-lane leaf test
    /// inlined).
    ///
    /// # Safety
    /// The processor must have AVX2.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    unsafe fn intersect_avx2(&self, ray: &Ray) -> Option<Hit> {
        // SAFETY: AVX2 is present (this function's contract).
        unsafe { self.intersect_with::<true>(ray) }
    }

    /// [`Self::intersect`] with the leaf test of [`window::window_with`].
    ///
    /// # Safety
    /// With `AVX2`, the processor must have AVX2.
    #[inline(always)]
    unsafe fn intersect_with<const AVX2: bool>(&self, ray: &Ray) -> Option<Hit> {
        let r = PreparedRay::new(ray)?;
        // SAFETY: this function's contract.
        let mut v = unsafe { Closest::<AVX2>::new(self, &r) };
        // SAFETY: this function's contract.
        unsafe { self.top.walk::<AVX2, true>(&r, r.tmax, &mut v) };
        v.best.map(|b| self.hit(b))
    }

    /// True if anything is hit in `[tmin, tmax]`.
    pub fn occluded(&self, ray: &Ray) -> bool {
        #[cfg(target_arch = "x86_64")]
        if window::has_avx2() {
            // SAFETY: AVX2 is present (detected).
            return unsafe { self.occluded_avx2(ray) };
        }
        // SAFETY: without `AVX2` nothing beyond the baseline is used.
        unsafe { self.occluded_with::<false>(ray) }
    }

    /// [`Self::occluded`] compiled for AVX2.
    ///
    /// # Safety
    /// The processor must have AVX2.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    unsafe fn occluded_avx2(&self, ray: &Ray) -> bool {
        // SAFETY: AVX2 is present (this function's contract).
        unsafe { self.occluded_with::<true>(ray) }
    }

    /// [`Self::occluded`] with the leaf test of [`window::window_with`].
    ///
    /// # Safety
    /// With `AVX2`, the processor must have AVX2.
    #[inline(always)]
    unsafe fn occluded_with<const AVX2: bool>(&self, ray: &Ray) -> bool {
        let Some(r) = PreparedRay::new(ray) else {
            return false;
        };
        // SAFETY: this function's contract.
        let mut v = unsafe { Occluded::<AVX2>::new(self, &r) };
        // SAFETY: this function's contract.
        unsafe { self.top.walk::<AVX2, false>(&r, r.tmax, &mut v) };
        v.hit
    }

    /// Closest hits of many rays, in parallel.
    pub fn intersect_batch(&self, rays: &[Ray]) -> Vec<Option<Hit>> {
        rays.par_iter()
            .with_min_len(256)
            .map(|r| self.intersect(r))
            .collect()
    }

    /// The hit record.
    fn hit(&self, best: Best) -> Hit {
        self.hit_at(best.at.leaf(), best.t, best.b1, best.b2)
    }

    /// The hit record of the triangle at `leaf` (a [`Hit::leaf`]: see [`LEAF_LOOSE`]) at `t`
    /// with barycentrics `b1, b2`: what [`Self::intersect`] returns for that triangle (the GPU
    /// backend's hits are completed with it). Without [`Self::shading_normals`] its shading
    /// normal is its geometric normal.
    pub fn hit_at(&self, leaf: u32, t: f32, b1: f32, b2: f32) -> Hit {
        let (p, uv, id, face, k, level) = match Found::of(leaf) {
            Found::Grid(bi, x, y, h) => {
                let b = &self.blocks[bi as usize];
                let (x, y, h) = (x as usize, y as usize, h as usize);
                let uv = triangle_of(b.quad_uvs(x, y), h);
                let level = b.triangle_level(&self.levels, x, y, h);
                let id = b.triangle(x, y, h);
                (self.grid_corners_of(b, x, y, h), uv, id, b.face, b.k, level)
            }
            Found::Loose(li) => {
                let l = &self.loose[li as usize];
                (l.p, l.uv, l.id, l.face, l.k, l.level)
            }
        };
        let n = self.shading_normals.then(|| self.corner_normals(leaf));
        Corners { p, n, uv }.hit(t, b1, b2, id, face, k, level, leaf)
    }

    /// The corners of the triangle at `leaf` (a [`Hit::leaf`]), in the order the hit's
    /// barycentrics refer to.
    pub fn corners(&self, leaf: u32) -> [[f32; 3]; 3] {
        match Found::of(leaf) {
            Found::Grid(bi, x, y, h) => {
                let b = &self.blocks[bi as usize];
                self.grid_corners_of(b, x as usize, y as usize, h as usize)
            }
            Found::Loose(li) => self.loose[li as usize].p,
        }
    }

    /// The corners of half `h` of quad `(x, y)` of block `b` ([`grid_corners`]' vertices),
    /// read from the block's planes: one row of a plane per corner row.
    #[inline]
    fn grid_corners_of(&self, b: &Block, x: usize, y: usize, h: usize) -> [[f32; 3]; 3] {
        let w = b.cols as usize + 1;
        let row = |y: usize| &self.coords[b.vert as usize + 3 * y * w..][..3 * w];
        let (r0, r1) = (row(y), row(y + 1));
        let at = |r: &[f32], x: usize| [r[x], r[w + x], r[2 * w + x]];
        triangle_of([at(r0, x), at(r0, x + 1), at(r1, x + 1), at(r1, x)], h)
    }

    /// The corners of every triangle, by id (the diced mesh's order: quad `(x, y)` of a grid
    /// region as `[a, b, c]` and `[a, c, d]` from its lower-left corner `a`).
    pub fn triangle_corners(&self) -> Vec<[[f32; 3]; 3]> {
        let mut out = vec![[[0.0; 3]; 3]; self.triangles];
        for (bi, b) in self.blocks.iter().enumerate() {
            for y in 0..b.rows as usize {
                for x in 0..b.cols as usize {
                    for h in 0..2 {
                        let leaf = Found::Grid(bi as u32, x as u8, y as u8, h as u8).leaf();
                        out[b.triangle(x, y, h) as usize] = self.corners(leaf);
                    }
                }
            }
        }
        for l in &self.loose {
            out[l.id as usize] = l.p;
        }
        out
    }

    /// The `(u, v)` at the corners of the triangle at `leaf`, as its hits interpolate them.
    pub fn corner_uvs(&self, leaf: u32) -> [[f32; 2]; 3] {
        match Found::of(leaf) {
            Found::Grid(bi, x, y, h) => {
                let b = &self.blocks[bi as usize];
                triangle_of(b.quad_uvs(x as usize, y as usize), h as usize)
            }
            Found::Loose(li) => self.loose[li as usize].uv,
        }
    }

    /// The unit shading normals at the corners of the triangle at `leaf` (decoded), in a mesh
    /// with [`Self::shading_normals`].
    pub fn corner_normals(&self, leaf: u32) -> [[f32; 3]; 3] {
        match Found::of(leaf) {
            Found::Grid(bi, x, y, h) => {
                let b = &self.blocks[bi as usize];
                let w = b.cols as usize + 1;
                oct_decode3(
                    grid_corners(x as usize, y as usize, h as usize)
                        .map(|(cx, cy)| self.normals[b.normal() as usize + cy * w + cx]),
                )
            }
            Found::Loose(li) => oct_decode3(self.loose[li as usize].n),
        }
    }
}

/// Half `h` of the quad whose corners are `[a, b, c, d]` (counter-clockwise from its
/// lower-left `a`): `[a, b, c]` or `[a, c, d]`, the diced mesh's order. The one place that
/// order is written: corners, parameters and normals all take it from here.
#[inline(always)]
fn triangle_of<T: Copy>([a, b, c, d]: [T; 4], h: usize) -> [T; 3] {
    if h == 0 {
        [a, b, c]
    } else {
        [a, c, d]
    }
}

/// The grid vertices `(x, y)` of half `h` of quad `(x, y)`: `[a, b, c]` or `[a, c, d]`
/// ([`triangle_of`] the quad's corners).
fn grid_corners(x: usize, y: usize, h: usize) -> [(usize, usize); 3] {
    triangle_of([(x, y), (x + 1, y), (x + 1, y + 1), (x, y + 1)], h)
}

impl crate::bvh::Intersect for GridMesh {
    fn intersect(&self, ray: &Ray) -> Option<Hit> {
        GridMesh::intersect(self, ray)
    }
    fn occluded(&self, ray: &Ray) -> bool {
        GridMesh::occluded(self, ray)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn runs_tile_and_stay_small() {
        use block::BLOCK;
        use build::runs;
        for n in 1..40 {
            let r: Vec<_> = runs(n).collect();
            assert_eq!(r.iter().map(|x| x.1).sum::<usize>(), n);
            assert!(r.iter().all(|x| x.1 >= 1 && x.1 <= BLOCK), "{n}: {r:?}");
            for w in r.windows(2) {
                assert_eq!(w[0].0 + w[0].1, w[1].0);
            }
        }
        assert_eq!(runs(16).collect::<Vec<_>>(), vec![(0, 8), (8, 8)]);
        assert_eq!(runs(4).collect::<Vec<_>>(), vec![(0, 4)]);
    }

    use top::{union, Bounds, NONE as EMPTY_BOX};

    fn grow(b: &mut Bounds, p: [f32; 3]) {
        *b = union(*b, [p, p]);
    }

    /// Bounds of the vertices of quads `x0..x1` × `y0..y1` of block `b` (empty when none).
    fn quads_bounds(m: &GridMesh, b: &Block, [x0, x1]: [usize; 2], [y0, y1]: [usize; 2]) -> Bounds {
        let (cols, rows) = (b.cols as usize, b.rows as usize);
        let mut out = EMPTY_BOX;
        if x0 >= cols || y0 >= rows {
            return out;
        }
        let w = cols + 1;
        let c = &m.coords[b.vert as usize..];
        for y in y0..=y1.min(rows) {
            for x in x0..=x1.min(cols) {
                grow(&mut out, std::array::from_fn(|a| c[(3 * y + a) * w + x]));
            }
        }
        out
    }

    /// The exact bounds of what lies below top-level reference `r`, checking on the way that
    /// every node's child box is exactly that.
    fn check_ref(m: &GridMesh, r: top::Ref) -> Bounds {
        if r & top::LEAF != 0 {
            let prim = (r & !top::LEAF) as usize;
            if prim < m.blocks.len() {
                return m.blocks[prim].root_bounds_checked(m);
            }
            let [first, count] = m.strips[prim - m.blocks.len()];
            let mut out = EMPTY_BOX;
            for l in &m.loose[first as usize..(first + count) as usize] {
                l.p.iter().for_each(|&p| grow(&mut out, p));
            }
            return out;
        }
        let n = &m.top.nodes[r as usize];
        let mut out = EMPTY_BOX;
        for c in 0..top::WIDTH {
            let below = if n.child[c] == top::EMPTY {
                EMPTY_BOX
            } else {
                check_ref(m, n.child[c])
            };
            assert_eq!(n.boxes.child(c), below, "top node {r} child {c}");
            out = union(out, below);
        }
        out
    }

    impl Block {
        /// The block's bounds, checking that its root's and quadrants' child boxes are
        /// exactly those of their windows' vertices.
        fn root_bounds_checked(&self, m: &GridMesh) -> Bounds {
            let mut out = EMPTY_BOX;
            for c in 0..4 {
                let (cx, cy) = (c % 2, c / 2);
                let expect = if self.two_level() {
                    let q = &m.boxes[self.boxes as usize + c];
                    for w in 0..4 {
                        let (wx, wy) = (2 * cx + w % 2, 2 * cy + w / 2);
                        let window =
                            quads_bounds(m, self, [2 * wx, 2 * wx + 2], [2 * wy, 2 * wy + 2]);
                        assert_eq!(q.child(w), window, "quadrant {c} window {w}");
                    }
                    quads_bounds(m, self, [4 * cx, 4 * cx + 4], [4 * cy, 4 * cy + 4])
                } else {
                    quads_bounds(m, self, [2 * cx, 2 * cx + 2], [2 * cy, 2 * cy + 2])
                };
                assert_eq!(self.root.child(c), expect, "root child {c}");
                out = union(out, expect);
            }
            out
        }
    }

    /// Every box of the hierarchy, from the top level down to the windows, is exactly the
    /// bounds of the vertices below it (bit for bit), and the mesh's bounds are all of them:
    /// the boxes are as tight as `f32` boxes can be, and conservative.
    #[test]
    fn every_box_is_exactly_what_lies_below() {
        use crate::dice::{dice, DiceOptions, DiceRate};
        use crate::mesh::generate;
        use crate::patch::{PatchOptions, PatchTable};
        let mut strips = false;
        for mesh in [generate::grid(5), generate::star(5, 3)] {
            let table = PatchTable::new(&mesh, PatchOptions::default()).unwrap();
            // Uniform rates (every domain one grid, several blocks wide), and edge lengths
            // (rates differing between domains: zipper strips too).
            let rates = [1, 3, 8, 13, 19]
                .map(DiceRate::Uniform)
                .into_iter()
                .chain([0.3, 0.11].map(DiceRate::EdgeLength));
            for rate in rates {
                let opts = DiceOptions {
                    rate,
                    max_rate: 64,
                    displace: None,
                };
                let d = dice(&table, &mesh, &opts).unwrap();
                let m = GridMesh::dice(&table, &mesh, &opts).unwrap();
                assert!(!m.blocks.is_empty());
                let all = check_ref(&m, m.top.root);
                assert_eq!(all, m.bounds, "rate {rate:?}");
                let mut direct = EMPTY_BOX;
                d.positions.iter().for_each(|&p| grow(&mut direct, p));
                assert_eq!(all, direct, "rate {rate:?}");
                strips |= !m.strips.is_empty();
            }
        }
        assert!(strips, "no mesh had loose triangles");
    }
}
