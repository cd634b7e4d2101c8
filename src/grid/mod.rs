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
pub mod collapse;
pub mod node;
pub mod top;
pub mod window;

use crate::bvh::mesh::Corners;
use crate::bvh::ray::{Hit, Ray};
use crate::bvh::triangle::{intersect_prepared, PreparedRay};
use crate::dice::{DicedMesh, GridRegion, LeanDiced};
use crate::error::{Error, ErrorKind, Result};
use crate::oct::{oct_decode3, oct_encode_all};
use crate::threads::split_off;
use block::{plane_boxes, slot, Block, Slot, BLOCK, LEVEL_UNIFORM};
use node::{child_of, in_order, test4, Box4};
use rayon::prelude::*;
use top::Top;
use window::{lane_mask, Rows};

/// A triangle outside the grids, with everything its hits need.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Loose {
    /// Corners.
    pub p: [[f32; 3]; 3],
    /// Octahedral normals of the corners.
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
    /// Octahedral vertex normals of all blocks.
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

/// Where a planned block lies: its region (index in [`DicedMesh::grids`]) and where it
/// starts in the region's grid (its header is apart, in [`GridMesh::blocks`]).
#[derive(Clone, Copy, bytemuck::Zeroable)]
struct Planned {
    region: u32,
    origin: [u32; 2],
}

/// Splits `n` quads into runs of at most [`BLOCK`], as even as possible, even lengths first:
/// `(start, length)` of each, in order (nothing allocated).
fn runs(n: usize) -> impl Iterator<Item = (usize, usize)> + Clone {
    let count = n.div_ceil(BLOCK);
    let mut start = 0;
    (0..count).map(move |i| {
        let left = n - start;
        let parts = count - i;
        let mut len = left.div_ceil(parts);
        if len % 2 == 1 && len < left && len < BLOCK {
            len += 1;
        }
        let run = (start, len.min(left));
        start += run.1;
        run
    })
}

/// How many blocks [`plan_region`] makes of region `g`.
fn blocks_of(g: &GridRegion) -> usize {
    let [qc, qr] = g.part.quads.map(|x| x as usize);
    qc.div_ceil(BLOCK) * qr.div_ceil(BLOCK)
}

/// Writes the blocks of region `region` (`g`) to the fronts of `out` and `headers`: where
/// each lies, and its header without offsets (nothing is read from the diced mesh). Returns
/// how many ([`blocks_of`]).
fn plan_region(region: usize, g: &GridRegion, out: &mut [Planned], headers: &mut [Block]) -> usize {
    let [qc, qr] = g.part.quads.map(|x| x as usize);
    let mut made = 0;
    for (y0, rows) in runs(qr) {
        for (x0, cols) in runs(qc) {
            headers[made] = Block {
                tri0: g.first_triangle + 2 * (y0 * qc + x0) as u32,
                tri_stride: 2 * qc as u32,
                face: g.face,
                k: g.k,
                ij: [g.part.origin[0] + x0 as u32, g.part.origin[1] + y0 as u32],
                n: g.part.n,
                cols: cols as u8,
                rows: rows as u8,
                // A one-patch domain's level, once for the block.
                level: g.level.map_or(0, |l| LEVEL_UNIFORM | l as u32),
                ..Block::default()
            };
            out[made] = Planned {
                region: region as u32,
                origin: [x0 as u32, y0 as u32],
            };
            made += 1;
        }
    }
    made
}

/// Space in [`GridMesh`]'s arrays: coordinates, box nodes and levels.
#[derive(Clone, Copy, Default)]
struct Extent {
    coords: usize,
    boxes: usize,
    levels: usize,
}

impl Extent {
    /// What `h` takes.
    fn of(h: &Block) -> Extent {
        Extent {
            coords: 3 * h.num_vertices(),
            boxes: h.num_boxes(),
            levels: h.num_levels(),
        }
    }

    fn add(self, b: Extent) -> Extent {
        Extent {
            coords: self.coords + b.coords,
            boxes: self.boxes + b.boxes,
            levels: self.levels + b.levels,
        }
    }

    /// Sets `h`'s offsets to `self` plus those it has.
    fn offset(self, h: &mut Block) {
        h.vert += self.coords as u32;
        h.boxes += self.boxes as u32;
        if h.level & LEVEL_UNIFORM == 0 {
            h.level += self.levels as u32;
        }
    }
}

/// The error of a diced mesh with more `what` (`count` of them) than the grid core addresses
/// (`most`).
fn too_many(count: usize, what: &str, most: &str) -> Error {
    Error::new(
        ErrorKind::Usage,
        format!(
            "the diced mesh has {count} {what}: more than the grid core addresses ({most}); \
             lower the dicing rate or split the mesh"
        ),
    )
}

/// Where one block's data goes: its slices of [`GridMesh::coords`], `normals`, `boxes` and
/// `levels`.
struct BlockSlices<'a> {
    coords: &'a mut [f32],
    normals: &'a mut [u32],
    boxes: &'a mut [Box4],
    levels: &'a mut [u8],
}

/// Stores block `p` of `d` into `out`; returns its root node.
fn fill_block(
    d: &DicedMesh,
    levels: Option<&[u8]>,
    codes: &[u32],
    p: Planned,
    h: &Block,
    out: BlockSlices,
) -> Box4 {
    let g = &d.grids[p.region as usize];
    let (cols, rows) = (h.cols as usize, h.rows as usize);
    let [x0, y0] = p.origin.map(|x| x as usize);
    let mut row = [0u32; BLOCK + 1];
    let row = &mut row[..=cols];
    for y in 0..=rows {
        g.row_vertices(&d.grid_frames, x0 as u32, (y0 + y) as u32, row);
        for (x, &v) in row.iter().enumerate() {
            let q = d.positions[v as usize];
            for a in 0..3 {
                out.coords[(3 * y + a) * (cols + 1) + x] = q[a];
            }
            out.normals[y * (cols + 1) + x] = codes[v as usize];
        }
    }
    let root = plane_boxes(h, out.coords, out.boxes);
    match g.level {
        // One patch: one level, in the header (the triangles' records are not read).
        Some(_) => debug_assert!(out.levels.is_empty()),
        None => {
            for y in 0..rows {
                for x in 0..cols {
                    for k in 0..2 {
                        let t = h.triangle(x, y, k) as usize;
                        out.levels[2 * (y * cols + x) + k] = match levels {
                            Some(l) => l[t],
                            None => d.tri_info[t].level,
                        };
                    }
                }
            }
        }
    }
    root
}

impl GridMesh {
    /// Builds the grid mesh of `d`; the diced mesh is not kept. Everything is stored region
    /// by region, as the blocks were planned: block headers, vertices, normals, boxes and
    /// levels, then the loose triangles in strips in id order. Fails when the
    /// mesh needs more than 2^24 blocks or 2^31 loose triangles (see [`LEAF_LOOSE`]).
    pub fn build(d: &DicedMesh) -> Result<GridMesh> {
        Self::build_from(d, None, None)
    }

    /// [`Self::build`] from a lean dicing ([`crate::dice::dice_lean`]): the same grid mesh,
    /// from less memory.
    pub fn build_lean(d: &LeanDiced) -> Result<GridMesh> {
        Self::build_from(&d.mesh, Some(&d.levels), Some(&d.codes))
    }

    /// [`Self::build`], reading of `d` only what a [`LeanDiced`] holds: positions, grid
    /// regions and their frames, and the corners and records of loose triangles; the levels of
    /// grid triangles in regions without a [`GridRegion::level`] from `tri_levels` when given
    /// (a lean dicing's), else from their records; the normals' octahedral codes from
    /// `normal_codes` when given (a lean dicing's), else encoded from `d`'s normals.
    fn build_from(
        d: &DicedMesh,
        tri_levels: Option<&[u8]>,
        normal_codes: Option<&[u32]>,
    ) -> Result<GridMesh> {
        // Plan the blocks in runs of regions of about CHUNK blocks, in parallel (headers with
        // offsets within their run, and each run's extent), then store each in place, in
        // parallel, its offsets made global first, and take its bounds from its root box; the
        // top level is built over those bounds.
        const CHUNK: usize = 128;
        let mut chunks: Vec<(std::ops::Range<usize>, usize)> = Vec::new();
        let (mut start, mut count) = (0, 0);
        for (i, g) in d.grids.iter().enumerate() {
            count += blocks_of(g);
            if count >= CHUNK || i + 1 == d.grids.len() {
                chunks.push((start..i + 1, count));
                (start, count) = (i + 1, 0);
            }
        }
        let nplanned = chunks.iter().map(|c| c.1).sum::<usize>();
        if nplanned >= 1 << 24 {
            return Err(too_many(nplanned, "grid blocks", "2^24"));
        }
        // Zeroed: the pages are first touched by the run that writes them, in parallel.
        let mut plans: Vec<Planned> = bytemuck::zeroed_vec(nplanned);
        let mut headers: Vec<Block> = bytemuck::zeroed_vec(nplanned);
        let mut runs = Vec::with_capacity(chunks.len());
        {
            let (mut p, mut h) = (&mut plans[..], &mut headers[..]);
            for (regions, n) in &chunks {
                runs.push((
                    regions.clone(),
                    split_off(&mut p, *n),
                    split_off(&mut h, *n),
                ));
            }
        }
        let extents: Vec<Extent> = runs
            .into_par_iter()
            .map(|(regions, plans, headers)| {
                let mut at = 0;
                for i in regions {
                    at += plan_region(i, &d.grids[i], &mut plans[at..], &mut headers[at..]);
                }
                headers.iter_mut().fold(Extent::default(), |e, h| {
                    e.offset(h);
                    e.add(Extent::of(h))
                })
            })
            .collect();
        let total = extents.iter().fold(Extent::default(), |a, &e| a.add(e));
        let (ncoords, nboxes, nlevels) = (total.coords, total.boxes, total.levels);
        // Each vertex's octahedral normal, encoded once (a block border's vertices are held by
        // two or four blocks, a loose triangle's corners by several triangles).
        let encoded;
        let codes = match normal_codes {
            Some(codes) => codes,
            None => {
                let mut codes = vec![0u32; d.normals.len()];
                codes
                    .par_chunks_mut(4096)
                    .zip(d.normals.par_chunks(4096))
                    .for_each(|(c, n)| oct_encode_all(n, c));
                encoded = codes;
                &encoded[..]
            }
        };
        let mut m = GridMesh {
            triangles: d.triangles.len(),
            bounds: [[f32::INFINITY; 3], [f32::NEG_INFINITY; 3]],
            ..GridMesh::default()
        };
        // Window rows are read four values at a time: the last plane's last row reads past it
        // into four zeros.
        m.coords = vec![0.0; ncoords + 4];
        m.normals = vec![0; ncoords / 3];
        // Zeroed, not empty boxes: every block overwrites all of its slice (and a zeroed
        // allocation's pages are first touched by the block that writes them, in parallel).
        m.boxes = bytemuck::zeroed_vec(nboxes);
        m.levels = vec![0; nlevels];
        {
            let mut jobs = Vec::with_capacity(chunks.len());
            let (mut coords, mut normals) = (&mut m.coords[..ncoords], &mut m.normals[..]);
            let (mut boxes, mut levels) = (&mut m.boxes[..], &mut m.levels[..]);
            let (mut p, mut h) = (&plans[..], &mut headers[..]);
            let mut base = Extent::default();
            for (&(_, n), &e) in chunks.iter().zip(&extents) {
                let out = BlockSlices {
                    coords: split_off(&mut coords, e.coords),
                    normals: split_off(&mut normals, e.coords / 3),
                    boxes: split_off(&mut boxes, e.boxes),
                    levels: split_off(&mut levels, e.levels),
                };
                let (mine, rest) = p.split_at(n);
                p = rest;
                jobs.push((base, mine, split_off(&mut h, n), out));
                base = base.add(e);
            }
            jobs.into_par_iter()
                .for_each(|(base, plans, headers, mut out)| {
                    for (&p, h) in plans.iter().zip(headers) {
                        base.offset(h);
                        let e = Extent::of(h);
                        let mine = BlockSlices {
                            coords: split_off(&mut out.coords, e.coords),
                            normals: split_off(&mut out.normals, e.coords / 3),
                            boxes: split_off(&mut out.boxes, e.boxes),
                            levels: split_off(&mut out.levels, e.levels),
                        };
                        h.root = fill_block(d, tri_levels, codes, p, h, mine);
                    }
                });
        }
        // Each block's bounds: the union of its root's children (absent ones are empty).
        let mut prim_boxes: Vec<top::Bounds> = headers
            .iter()
            .map(|h| (0..4).fold(top::NONE, |b, c| top::union(b, h.root.child(c))))
            .collect();
        let mut loose = Vec::new();
        // Strips: runs of at most STRIP loose triangles of one domain, in id order (a
        // domain's zipper triangles are consecutive, side by side).
        let mut strips: Vec<[u32; 2]> = Vec::new();
        // The loose triangles: those between the grid regions (which are in id order).
        let grid_runs = d.grids.iter().map(|g| {
            let first = g.first_triangle as usize;
            first..first + 2 * (g.part.quads[0] * g.part.quads[1]) as usize
        });
        let gaps = grid_runs
            .clone()
            .map(|r| r.start)
            .chain([d.triangles.len()])
            .zip(std::iter::once(0).chain(grid_runs.map(|r| r.end)))
            .flat_map(|(end, start)| start..end);
        for i in gaps {
            let t = &d.triangles[i];
            let info = &d.tri_info[i];
            let p = t.map(|v| d.positions[v as usize]);
            let same = loose.last().is_some_and(|l: &Loose| {
                l.face == info.face && l.k == info.k && l.id + 1 == i as u32
            });
            match strips.last_mut() {
                Some(s) if same && (s[1] as usize) < STRIP => s[1] += 1,
                _ => {
                    strips.push([loose.len() as u32, 1]);
                    prim_boxes.push(top::NONE);
                }
            }
            let b = prim_boxes.last_mut().expect("the strip's box");
            *b = p.iter().fold(*b, |b, &q| top::union(b, [q, q]));
            loose.push(Loose {
                p,
                n: t.map(|v| codes[v as usize]),
                uv: info.uv,
                id: i as u32,
                face: info.face,
                k: info.k,
                level: info.level,
            });
        }
        m.bounds = prim_boxes.iter().fold(m.bounds, |a, &b| top::union(a, b));
        if loose.len() >= 1 << 31 {
            return Err(too_many(loose.len(), "loose triangles", "2^31"));
        }
        if prim_boxes.is_empty() {
            return Ok(m);
        }
        let bounds = prim_boxes;
        let top = Top::build(&bounds);
        // Block headers and strips stay in the order they were made (the mesh's), the order
        // of the blocks' vertices: put in the top level's depth-first order instead, the
        // headers cost the 316² grid 10 ms of gathering and the rays nothing (the same rays
        // per second within 3%, BENCHMARKS.md, fourteenth step).
        m.fetch = headers
            .iter()
            .map(|h| [h.vert, if h.two_level() { h.boxes } else { u32::MAX }])
            .chain([[ncoords as u32, u32::MAX]])
            .collect();
        m.blocks = headers;
        m.strips = strips;
        m.loose = loose;
        m.top = top;
        Ok(m)
    }

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
            if NORMALS {
                prefetch_bytes(self.normals.as_ptr().wrapping_add(v / 3), 4 * coords / 3);
            }
        }
    }

    /// Prefetches what the hit record of quad `(x, y)` of block `b` reads beyond the block's
    /// vertices: its corners' normals (two rows) and its triangles' levels.
    #[inline(always)]
    fn prefetch_record(&self, b: &Block, x: usize, y: usize) {
        #[cfg(target_arch = "x86_64")]
        {
            use std::arch::x86_64::{_mm_prefetch, _MM_HINT_T0};
            let w = b.cols as usize + 1;
            let first = b.normal() as usize + y * w + x;
            let p = self.normals.as_ptr().wrapping_add(first) as *const i8;
            // The quad's diagonal corners `(x, y)` and `(x + 1, y + 1)`; the other two share
            // their lines unless a line ends between them.
            // SAFETY: prefetching never faults and has no effect on memory.
            unsafe {
                _mm_prefetch::<_MM_HINT_T0>(p);
                _mm_prefetch::<_MM_HINT_T0>(p.wrapping_add(4 * w + 4));
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
    /// queries), calling `leaf(wx, wy, tmax)` for each window met; `leaf` returns the new
    /// `tmax` and whether to stop.
    #[inline(always)]
    fn walk_block<const ORDERED: bool>(
        &self,
        bi: usize,
        r: &PreparedRay,
        mut tmax: f32,
        leaf: &mut impl FnMut(&Block, usize, usize, f32) -> (f32, bool),
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
                    let (t, stop) = leaf(b, wx, wy, tmax);
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
                            let (t, stop) = leaf(b, wx, wy, tmax);
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
        let mut best: Option<Best> = None;
        let nblocks = self.blocks.len();
        let visit = |prim: u32, tmax: f32| {
            let prim = prim as usize;
            if prim < nblocks {
                let mut leaf = |b: &Block, wx: usize, wy: usize, tmax: f32| {
                    let (w, lanes) = self.window(b, wx, wy);
                    // SAFETY: this function's contract.
                    let found = unsafe { window::window_with::<AVX2>(&r, &w, lanes, tmax) };
                    if let Some((l, t, b1, b2)) = found {
                        let (qy, qx, h) = (l / 4, (l / 2) % 2, l % 2);
                        let (x, y) = (2 * wx + qx, 2 * wy + qy);
                        let id = b.triangle(x, y, h);
                        if best.is_none_or(|x| t < x.t || (t == x.t && id < x.id)) {
                            self.prefetch_record(b, x, y);
                            best = Some(Best {
                                at: Found::Grid(prim as u32, x as u8, y as u8, h as u8),
                                id,
                                t,
                                b1,
                                b2,
                            });
                            return (t, false);
                        }
                    }
                    (tmax, false)
                };
                let (t, _) = self.walk_block::<true>(prim, &r, tmax, &mut leaf);
                (t, false)
            } else {
                let [first, count] = self.strips[prim - nblocks];
                let mut tmax = tmax;
                for li in first..first + count {
                    let tri = &self.loose[li as usize];
                    let [a, b, c] = tri.p;
                    if let Some((t, b1, b2)) = intersect_prepared(&r, a, b, c, tmax) {
                        if best.is_none_or(|x| t < x.t || (t == x.t && tri.id < x.id)) {
                            best = Some(Best {
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
        };
        // SAFETY: this function's contract.
        unsafe {
            self.top
                .walk::<AVX2, true>(&r, r.tmax, visit, |p| self.prefetch::<true>(p))
        };
        best.map(|b| self.hit(b))
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
        let mut hit = false;
        let nblocks = self.blocks.len();
        let visit = |prim: u32, tmax: f32| {
            let prim = prim as usize;
            if prim < nblocks {
                let mut leaf = |b: &Block, wx: usize, wy: usize, tmax: f32| {
                    let (w, lanes) = self.window(b, wx, wy);
                    // SAFETY: this function's contract.
                    let found = unsafe { window::window_with::<AVX2>(&r, &w, lanes, tmax) };
                    (tmax, found.is_some())
                };
                hit = self.walk_block::<false>(prim, &r, tmax, &mut leaf).1;
            } else {
                let [first, count] = self.strips[prim - nblocks];
                hit = self.loose[first as usize..(first + count) as usize]
                    .iter()
                    .any(|l| intersect_prepared(&r, l.p[0], l.p[1], l.p[2], tmax).is_some());
            }
            (tmax, hit)
        };
        // SAFETY: this function's contract.
        unsafe {
            self.top
                .walk::<AVX2, false>(&r, r.tmax, visit, |p| self.prefetch::<false>(p))
        };
        hit
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
    /// backend's hits are completed with it).
    pub fn hit_at(&self, leaf: u32, t: f32, b1: f32, b2: f32) -> Hit {
        let (p, n, uv, id, face, k, level) = match Found::of(leaf) {
            Found::Grid(bi, x, y, h) => {
                let b = &self.blocks[bi as usize];
                let (x, y, h) = (x as usize, y as usize, h as usize);
                let uv = b.uvs(grid_corners(x, y, h));
                let level = b.triangle_level(&self.levels, x, y, h);
                let id = b.triangle(x, y, h);
                let n = self.corner_normals(leaf);
                (self.corners(leaf), n, uv, id, b.face, b.k, level)
            }
            Found::Loose(li) => {
                let l = &self.loose[li as usize];
                (l.p, oct_decode3(l.n), l.uv, l.id, l.face, l.k, l.level)
            }
        };
        Corners { p, n, uv }.hit(t, b1, b2, id, face, k, level, leaf)
    }

    /// The corners of the triangle at `leaf` (a [`Hit::leaf`]), in the order the hit's
    /// barycentrics refer to.
    pub fn corners(&self, leaf: u32) -> [[f32; 3]; 3] {
        match Found::of(leaf) {
            Found::Grid(bi, x, y, h) => {
                let b = &self.blocks[bi as usize];
                let w = b.cols as usize + 1;
                let c = &self.coords[b.vert as usize..];
                grid_corners(x as usize, y as usize, h as usize)
                    .map(|(cx, cy)| std::array::from_fn(|a| c[(3 * cy + a) * w + cx]))
            }
            Found::Loose(li) => self.loose[li as usize].p,
        }
    }

    /// The `(u, v)` at the corners of the triangle at `leaf`, as its hits interpolate them.
    pub fn corner_uvs(&self, leaf: u32) -> [[f32; 2]; 3] {
        match Found::of(leaf) {
            Found::Grid(bi, x, y, h) => {
                let b = &self.blocks[bi as usize];
                b.uvs(grid_corners(x as usize, y as usize, h as usize))
            }
            Found::Loose(li) => self.loose[li as usize].uv,
        }
    }

    /// The unit shading normals at the corners of the triangle at `leaf` (decoded).
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

/// The grid vertices `(x, y)` of half `h` of quad `(x, y)`: `[a, b, c]` or `[a, c, d]`.
fn grid_corners(x: usize, y: usize, h: usize) -> [(usize, usize); 3] {
    if h == 0 {
        [(x, y), (x + 1, y), (x + 1, y + 1)]
    } else {
        [(x, y), (x + 1, y + 1), (x, y + 1)]
    }
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
        use crate::dice::{dice_lean, DiceOptions, DiceRate};
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
                let d = dice_lean(&table, &mesh, &opts).unwrap();
                let m = GridMesh::build_lean(&d).unwrap();
                assert!(!m.blocks.is_empty());
                let all = check_ref(&m, m.top.root);
                assert_eq!(all, m.bounds, "rate {rate:?}");
                let mut direct = EMPTY_BOX;
                d.positions().iter().for_each(|&p| grow(&mut direct, p));
                assert_eq!(all, direct, "rate {rate:?}");
                strips |= !m.strips.is_empty();
            }
        }
        assert!(strips, "no mesh had loose triangles");
    }
}
