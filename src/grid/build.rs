//! Building a [`GridMesh`]: each grid region's blocks planned (headers and the room they
//! take), then stored in parallel, run by run, straight into the mesh's arrays; the loose
//! triangles in strips; the top level over blocks and strips.
//!
//! Two sources feed the same steps: a [`DicedMesh`] ([`GridMesh::build`]), and the dicing
//! itself ([`GridMesh::dice`]), whose workers store each domain's blocks from their own
//! buffers as soon as it is diced (no mesh-wide array of diced points in between).

use super::block::{plane_boxes, Block, BLOCK, LEVEL_UNIFORM};
use super::node::Box4;
use super::top::{self, Top};
use super::{GridMesh, Loose, STRIP};
use crate::dice::{dice_each_planned, DiceOptions, DicePlan, DicedMesh, GridRegion};
use crate::error::{Error, ErrorKind, Result};
use crate::mesh::ControlMesh;
use crate::oct::oct_encode_all;
use crate::patch::PatchTable;
use crate::threads::split_off;
use rayon::prelude::*;
use std::mem::MaybeUninit;
use std::ops::Range;
use std::sync::atomic::{AtomicUsize, Ordering};

/// Where a planned block starts in its region's grid (its header is apart, in
/// [`GridMesh::blocks`]).
#[derive(Clone, Copy, bytemuck::Zeroable)]
struct Planned {
    origin: [u32; 2],
}

/// Splits `n` quads into runs of at most [`BLOCK`], as even as possible, even lengths first:
/// `(start, length)` of each, in order (nothing allocated).
pub(super) fn runs(n: usize) -> impl Iterator<Item = (usize, usize)> + Clone {
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

/// Writes the blocks of region `g` to the fronts of `out` and `headers`: where each lies, and
/// its header without offsets (nothing is read from the diced points). Returns how many
/// ([`blocks_of`]).
fn plan_region(g: &GridRegion, out: &mut [Planned], headers: &mut [Block]) -> usize {
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

    /// Its normal codes: one per vertex, with shading normals.
    fn normals(self, with_normals: bool) -> usize {
        if with_normals {
            self.coords / 3
        } else {
            0
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

/// Where blocks' data goes: [`GridMesh::coords`], `normals`, `boxes` and `levels`, their
/// spare capacity, not yet initialised. Each block's part is written item by item by the
/// worker that stores the block ([`fill_block`], every item once); a run's part no block took
/// is cleared when its store is dropped. Cleared first instead (at allocation, `calloc`, or
/// block by block before the block is written), the arrays cost a second pass over memory
/// the first touches make slow: on the 316² grid at rate 4, clearing took 13% of a
/// one-thread build, its page faults included.
#[derive(Default)]
struct Spare<'a> {
    coords: &'a mut [MaybeUninit<f32>],
    /// Empty unless the mesh stores shading normals (`with_normals`).
    normals: &'a mut [MaybeUninit<u32>],
    boxes: &'a mut [MaybeUninit<Box4>],
    levels: &'a mut [MaybeUninit<u8>],
    with_normals: bool,
}

/// Zeroes `items` (now initialised).
fn clear<T: bytemuck::Zeroable>(items: &mut [MaybeUninit<T>]) {
    // SAFETY: writes `items.len()` zeroed values within the slice.
    unsafe { std::ptr::write_bytes(items.as_mut_ptr(), 0, items.len()) }
}

impl<'a> Spare<'a> {
    /// The first `e` of each; `self` keeps the rest.
    fn split_off(&mut self, e: Extent) -> Spare<'a> {
        Spare {
            coords: split_off(&mut self.coords, e.coords),
            normals: split_off(&mut self.normals, e.normals(self.with_normals)),
            boxes: split_off(&mut self.boxes, e.boxes),
            levels: split_off(&mut self.levels, e.levels),
            with_normals: self.with_normals,
        }
    }

    /// Items of the four arrays together.
    fn len(&self) -> usize {
        self.coords.len() + self.normals.len() + self.boxes.len() + self.levels.len()
    }

    /// Clears every item.
    fn clear(self) {
        clear(self.coords);
        clear(self.normals);
        clear(self.boxes);
        clear(self.levels);
    }
}

/// Where a block's vertices come from: region `g`, whose frame is in `frames`; each vertex's
/// position and normal code by `point`, and (where the region has no one level) each grid
/// triangle's level by its id, by `level`.
struct Source<'a, P, L> {
    g: &'a GridRegion,
    frames: &'a [u32],
    point: P,
    level: L,
}

/// Stores the block of header `h` starting at `origin` in its region into `out` (its
/// [`Extent::of`]), writing each item once; returns its root node.
fn fill_block<P, L>(s: &Source<P, L>, origin: [u32; 2], h: &Block, out: Spare) -> Box4
where
    P: Fn(u32) -> ([f32; 3], u32),
    L: Fn(u32) -> u8,
{
    let (cols, rows) = (h.cols as usize, h.rows as usize);
    let [x0, y0] = origin.map(|x| x as usize);
    let w = cols + 1;
    let levels = if s.g.level.is_some() {
        0
    } else {
        2 * rows * cols
    };
    // What `Extent::of(h)` gives, as the loops below cover it.
    let codes = if out.with_normals { w * (rows + 1) } else { 0 };
    assert!(
        out.coords.len() == 3 * w * (rows + 1)
            && out.normals.len() == codes
            && out.boxes.len() == if h.two_level() { 4 } else { 0 }
            && out.levels.len() == levels,
        "a block's storage is its extent"
    );
    let mut row = [0u32; BLOCK + 1];
    let row = &mut row[..w];
    for (y, plane) in out.coords.chunks_exact_mut(3 * w).enumerate() {
        s.g.row_vertices(s.frames, x0 as u32, (y0 + y) as u32, row);
        let (xs, yz) = plane.split_at_mut(w);
        let (ys, zs) = yz.split_at_mut(w);
        let planes = row.iter().zip(xs).zip(ys).zip(zs);
        if codes > 0 {
            let codes = &mut out.normals[y * w..(y + 1) * w];
            for ((((&v, px), py), pz), c) in planes.zip(codes) {
                let (q, code) = (s.point)(v);
                px.write(q[0]);
                py.write(q[1]);
                pz.write(q[2]);
                c.write(code);
            }
        } else {
            for (((&v, px), py), pz) in planes {
                let q = (s.point)(v).0;
                px.write(q[0]);
                py.write(q[1]);
                pz.write(q[2]);
            }
        }
    }
    // SAFETY: the planes (`rows + 1` of `3 w` coordinates: the whole slice, as asserted) were
    // written item by item just above, each plane's three rows of `w` from the `w` vertices
    // of `row` (and each row's `w` codes, the whole of `out.normals`, where it has them);
    // `MaybeUninit<f32>` has `f32`'s layout.
    let coords = unsafe { &*(out.coords as *const [MaybeUninit<f32>] as *const [f32]) };
    let mut quadrants = [Box4::default(); 4];
    let root = plane_boxes(h, coords, &mut quadrants[..out.boxes.len()]);
    for (b, q) in out.boxes.iter_mut().zip(quadrants) {
        b.write(q);
    }
    if levels > 0 {
        // Where the region has no one level: each triangle's (a one-patch region's level is
        // in the header, and its triangles' records are not read).
        for y in 0..rows {
            for x in 0..cols {
                for k in 0..2 {
                    out.levels[2 * (y * cols + x) + k].write((s.level)(h.triangle(x, y, k)));
                }
            }
        }
    }
    root
}

/// One run's planned blocks and their storage: the blocks are stored in their planned order,
/// one after the other ([`Self::fill_region`]).
struct RunStore<'a> {
    /// Where the run's arrays start in the mesh's.
    base: Extent,
    plans: &'a [Planned],
    headers: &'a mut [Block],
    out: Spare<'a>,
    /// Items of the run's arrays, all initialised by the time the store is dropped: added
    /// then to the mesh's count of initialised items ([`Planning::finish`] checks that every
    /// run's add up to the arrays' lengths; once per run, not per block, where every worker's
    /// adds would contend for one cache line).
    items: usize,
    initialised: &'a AtomicUsize,
}

impl Drop for RunStore<'_> {
    /// Clears what no block took (nothing, unless a run stopped early): every item of the
    /// arrays is initialised once every store is gone.
    fn drop(&mut self) {
        std::mem::take(&mut self.out).clear();
        self.initialised.fetch_add(self.items, Ordering::Relaxed);
    }
}

impl RunStore<'_> {
    /// Stores the next blocks of the run, those of region `s.g` (the run's regions come in
    /// the order they were planned).
    fn fill_region<P, L>(&mut self, s: &Source<P, L>)
    where
        P: Fn(u32) -> ([f32; 3], u32),
        L: Fn(u32) -> u8,
    {
        let n = blocks_of(s.g);
        let (plans, rest) = std::mem::take(&mut self.plans).split_at(n);
        self.plans = rest;
        for (p, h) in plans.iter().zip(split_off(&mut self.headers, n)) {
            self.base.offset(h);
            let mine = self.out.split_off(Extent::of(h));
            h.root = fill_block(s, p.origin, h, mine);
        }
    }
}

/// A grid mesh's block arrays while it is built: the plans, the headers, and the mesh with
/// its coordinates, normals, boxes and levels allocated.
#[derive(Default)]
struct Planning {
    plans: Vec<Planned>,
    headers: Vec<Block>,
    /// The mesh, its block arrays allocated but empty until [`Self::finish`] (their items
    /// are written by the stores).
    mesh: GridMesh,
    /// What the blocks take, all together.
    total: Extent,
    /// Items of the block arrays initialised by the stores.
    initialised: AtomicUsize,
    /// Whether the mesh stores shading normals ([`GridMesh::shading_normals`]).
    normals: bool,
}

impl Planning {
    /// Plans the blocks of `regions`, run by run (`runs`: ranges of `regions`), in parallel,
    /// allocates the arrays they take, and splits them into one store per run.
    fn plan(&mut self, regions: &[GridRegion], runs: &[Range<usize>]) -> Result<Vec<RunStore<'_>>> {
        let counts: Vec<usize> = runs
            .iter()
            .map(|r| regions[r.clone()].iter().map(blocks_of).sum())
            .collect();
        let nplanned = counts.iter().sum::<usize>();
        if nplanned >= 1 << 24 {
            return Err(too_many(nplanned, "grid blocks", "2^24"));
        }
        // Zeroed: the pages are first touched by the run that writes them, in parallel.
        self.plans = bytemuck::zeroed_vec(nplanned);
        self.headers = bytemuck::zeroed_vec(nplanned);
        crate::huge_pages::advise(&mut self.headers);
        let mut jobs = Vec::with_capacity(runs.len());
        {
            let (mut p, mut h) = (&mut self.plans[..], &mut self.headers[..]);
            for (r, &n) in runs.iter().zip(&counts) {
                jobs.push((
                    &regions[r.clone()],
                    split_off(&mut p, n),
                    split_off(&mut h, n),
                ));
            }
        }
        // Headers with offsets within their run, and each run's extent.
        let extents: Vec<Extent> = jobs
            .into_par_iter()
            .map(|(regions, plans, headers)| {
                let mut at = 0;
                for g in regions {
                    at += plan_region(g, &mut plans[at..], &mut headers[at..]);
                }
                headers.iter_mut().fold(Extent::default(), |e, h| {
                    e.offset(h);
                    e.add(Extent::of(h))
                })
            })
            .collect();
        let total = extents.iter().fold(Extent::default(), |a, &e| a.add(e));
        let m = &mut self.mesh;
        self.total = total;
        *self.initialised.get_mut() = 0;
        // Window rows are read four values at a time: the last plane's last row reads past it
        // into four zeros (written now, with the arrays' lengths, in `finish`).
        m.coords = Vec::with_capacity(total.coords + 4);
        crate::huge_pages::advise(&mut m.coords);
        for z in &mut m.coords.spare_capacity_mut()[total.coords..] {
            z.write(0.0);
        }
        let normals = total.normals(self.normals);
        m.normals = Vec::with_capacity(normals);
        m.boxes = Vec::with_capacity(total.boxes);
        m.levels = Vec::with_capacity(total.levels);
        crate::huge_pages::advise(&mut m.normals);
        crate::huge_pages::advise(&mut m.boxes);
        crate::huge_pages::advise(&mut m.levels);
        let mut rest = Spare {
            coords: &mut m.coords.spare_capacity_mut()[..total.coords],
            normals: &mut m.normals.spare_capacity_mut()[..normals],
            boxes: &mut m.boxes.spare_capacity_mut()[..total.boxes],
            levels: &mut m.levels.spare_capacity_mut()[..total.levels],
            with_normals: self.normals,
        };
        let initialised = &self.initialised;
        let (mut p, mut h) = (&self.plans[..], &mut self.headers[..]);
        let mut base = Extent::default();
        let mut stores = Vec::with_capacity(runs.len());
        for (&n, &e) in counts.iter().zip(&extents) {
            let (plans, after) = p.split_at(n);
            p = after;
            let out = rest.split_off(e);
            stores.push(RunStore {
                base,
                plans,
                headers: split_off(&mut h, n),
                items: out.len(),
                out,
                initialised,
            });
            base = base.add(e);
        }
        Ok(stores)
    }

    /// The grid mesh of the stored blocks and of `loose` (in id order), of `triangles`
    /// triangles: the blocks' bounds from their roots, the loose triangles in strips, the
    /// top level over both.
    fn finish(self, loose: Vec<Loose>, triangles: usize) -> Result<GridMesh> {
        let Planning {
            headers,
            mesh: mut m,
            total,
            initialised,
            normals: with_normals,
            ..
        } = self;
        let normals = total.normals(with_normals);
        // Every item of the block arrays was initialised: written by its block, or cleared by
        // its store when it was dropped.
        let items = total.coords + normals + total.boxes + total.levels;
        assert_eq!(
            initialised.into_inner(),
            items,
            "every block array item is initialised before the arrays are read"
        );
        assert!(
            m.coords.capacity() >= total.coords + 4
                && m.normals.capacity() >= normals
                && m.boxes.capacity() >= total.boxes
                && m.levels.capacity() >= total.levels,
            "the block arrays are allocated before they are read"
        );
        // SAFETY: each array's first items (and the coordinates' four padding zeros) are
        // initialised, as just checked; the capacities were allocated for these lengths.
        unsafe {
            m.coords.set_len(total.coords + 4);
            m.normals.set_len(normals);
            m.boxes.set_len(total.boxes);
            m.levels.set_len(total.levels);
        }
        if loose.len() >= 1 << 31 {
            return Err(too_many(loose.len(), "loose triangles", "2^31"));
        }
        m.triangles = triangles;
        m.shading_normals = with_normals;
        // Each block's bounds: the union of its root's children (absent ones are empty).
        let mut prim_boxes: Vec<top::Bounds> = headers
            .iter()
            .map(|h| (0..4).fold(top::NONE, |b, c| top::union(b, h.root.child(c))))
            .collect();
        // Strips: runs of at most STRIP loose triangles of one domain, in id order (a
        // domain's zipper triangles are consecutive, side by side).
        let mut strips: Vec<[u32; 2]> = Vec::new();
        for (i, t) in loose.iter().enumerate() {
            let same = i > 0 && {
                let l = &loose[i - 1];
                l.face == t.face && l.k == t.k && l.id + 1 == t.id
            };
            match strips.last_mut() {
                Some(s) if same && (s[1] as usize) < STRIP => s[1] += 1,
                _ => {
                    strips.push([i as u32, 1]);
                    prim_boxes.push(top::NONE);
                }
            }
            let b = prim_boxes.last_mut().expect("the strip's box");
            *b = t.p.iter().fold(*b, |b, &q| top::union(b, [q, q]));
        }
        m.bounds = prim_boxes
            .iter()
            .fold([[f32::INFINITY; 3], [f32::NEG_INFINITY; 3]], |a, &b| {
                top::union(a, b)
            });
        if prim_boxes.is_empty() {
            return Ok(m);
        }
        crate::stages::mark("grid: block bounds and strips");
        // Each domain's blocks (consecutive, in its grid) one group, each strip its own.
        let mut groups: Vec<std::ops::Range<u32>> = Vec::new();
        for (i, h) in headers.iter().enumerate() {
            match groups.last_mut() {
                Some(g)
                    if {
                        let first = &headers[g.start as usize];
                        (first.face, first.k) == (h.face, h.k)
                    } =>
                {
                    g.end += 1
                }
                _ => groups.push(i as u32..i as u32 + 1),
            }
        }
        groups.extend((headers.len()..prim_boxes.len()).map(|i| i as u32..i as u32 + 1));
        let cells: Vec<[u32; 2]> = headers
            .iter()
            .map(|h| h.ij)
            .chain(std::iter::repeat_n([0, 0], strips.len()))
            .collect();
        m.top = Top::build_grouped(&prim_boxes, &groups, &cells);
        // Block headers and strips stay in the order they were made (the mesh's), the order
        // of the blocks' vertices: put in the top level's depth-first order instead, the
        // headers cost the 316² grid 10 ms of gathering and the rays nothing (the same rays
        // per second within 3%, BENCHMARKS.md, fourteenth step).
        let ncoords = m.coords.len() - 4;
        m.fetch = headers
            .iter()
            .map(|h| [h.vert, if h.two_level() { h.boxes } else { u32::MAX }])
            .chain([[ncoords as u32, u32::MAX]])
            .collect();
        m.blocks = headers;
        m.strips = strips;
        m.loose = loose;
        crate::stages::mark("grid: block fetch list");
        Ok(m)
    }
}

impl GridMesh {
    /// Builds the grid mesh of `d`; the diced mesh is not kept. Everything is stored region
    /// by region, as the blocks were planned: block headers, vertices, normals, boxes and
    /// levels, then the loose triangles in strips in id order. Fails when the mesh needs more
    /// than 2^24 blocks or 2^31 loose triangles (see [`super::LEAF_LOOSE`]).
    pub fn build(d: &DicedMesh) -> Result<GridMesh> {
        // Runs of regions of about CHUNK blocks.
        const CHUNK: usize = 128;
        let mut runs = Vec::new();
        let (mut start, mut count) = (0, 0);
        for (i, g) in d.grids.iter().enumerate() {
            count += blocks_of(g);
            if count >= CHUNK || i + 1 == d.grids.len() {
                runs.push(start..i + 1);
                (start, count) = (i + 1, 0);
            }
        }
        // Each vertex's octahedral normal, encoded once (a block border's vertices are held by
        // two or four blocks, a loose triangle's corners by several triangles).
        let mut codes = vec![0u32; d.normals.len()];
        codes
            .par_chunks_mut(4096)
            .zip(d.normals.par_chunks(4096))
            .for_each(|(c, n)| oct_encode_all(n, c));
        let mut planning = Planning {
            normals: true,
            ..Planning::default()
        };
        let stores = planning.plan(&d.grids, &runs)?;
        let codes = &codes;
        stores
            .into_par_iter()
            .zip(runs)
            .for_each(|(mut store, regions)| {
                for g in &d.grids[regions] {
                    store.fill_region(&Source {
                        g,
                        frames: &d.grid_frames,
                        point: |v: u32| (d.positions[v as usize], codes[v as usize]),
                        level: |t: u32| d.tri_info[t as usize].level,
                    });
                }
            });
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
        let loose = gaps
            .map(|i| {
                let (t, info) = (&d.triangles[i], &d.tri_info[i]);
                Loose {
                    p: t.map(|v| d.positions[v as usize]),
                    n: t.map(|v| codes[v as usize]),
                    uv: info.uv,
                    id: i as u32,
                    face: info.face,
                    k: info.k,
                    level: info.level,
                }
            })
            .collect();
        planning.finish(loose, d.triangles.len())
    }

    /// Dices the limit surface of `mesh` (whose patch table is `table`) under `opts` straight
    /// into a grid mesh: [`Self::build`] of [`crate::dice::dice`]'s mesh, the same bit for
    /// bit, but each domain's blocks and loose triangles are stored by the worker that dices
    /// it, from its own buffers ([`crate::dice::dice_each`]), and the diced mesh is never made.
    pub fn dice(table: &PatchTable, mesh: &ControlMesh, opts: &DiceOptions) -> Result<GridMesh> {
        Self::dice_staged(table, mesh, opts, None, true).map(|(m, _)| m)
    }

    /// [`Self::dice`] by the edge rates of `plan` ([`crate::dice::plan`] of the same `table`,
    /// `mesh` and `opts`: the same mesh, bit for bit), without measuring the edges again. A
    /// renderer plans every mesh first, to check the whole scene's memory, and then dices.
    pub fn dice_planned(
        table: &PatchTable,
        mesh: &ControlMesh,
        opts: &DiceOptions,
        plan: DicePlan,
    ) -> Result<GridMesh> {
        Self::dice_staged(table, mesh, opts, Some(plan), true).map(|(m, _)| m)
    }

    /// [`Self::dice`] without shading normals ([`GridMesh::shading_normals`] false): the
    /// same blocks, vertices, boxes, levels, loose triangles and top level bit for bit, and
    /// so the same hits, whose shading normal is then the geometric one ([`Hit::ns`] `=`
    /// [`Hit::ng`]). For tracing alone (intersection tests, visibility): the points' normals
    /// are neither found nor encoded, which on an undisplaced surface is a tenth of the
    /// build, and the mesh holds 4 bytes less per vertex. The exact limit normal at a hit is
    /// [`crate::Surface::limit_normal`] of its `(face, k, u, v)`.
    ///
    /// [`Hit::ns`]: crate::bvh::Hit::ns
    /// [`Hit::ng`]: crate::bvh::Hit::ng
    pub fn dice_geometry(
        table: &PatchTable,
        mesh: &ControlMesh,
        opts: &DiceOptions,
    ) -> Result<GridMesh> {
        Self::dice_staged(table, mesh, opts, None, false).map(|(m, _)| m)
    }

    /// [`Self::dice`] (with `normals`, else [`Self::dice_geometry`]), and when the blocks
    /// and loose triangles were all stored (the rest is the strips and the top level), for
    /// the benchmarks' split of the build.
    pub(crate) fn dice_staged(
        table: &PatchTable,
        mesh: &ControlMesh,
        opts: &DiceOptions,
        planned: Option<DicePlan>,
        normals: bool,
    ) -> Result<(GridMesh, std::time::Instant)> {
        let mut planning = Planning {
            normals,
            ..Planning::default()
        };
        let mut loose: Vec<Loose> = Vec::new();
        let mut triangles = 0;
        {
            let (planning, loose, triangles) = (&mut planning, &mut loose, &mut triangles);
            dice_each_planned(
                table,
                mesh,
                opts,
                planned,
                normals,
                move |layout| {
                    *triangles = layout.triangles;
                    // The regions in domain order, and each job's run of them.
                    let mut regions = Vec::new();
                    let mut runs = Vec::with_capacity(layout.jobs.len());
                    let mut counts = Vec::with_capacity(layout.jobs.len());
                    for job in &layout.jobs {
                        let start = regions.len();
                        let ds = &layout.domains[job.clone()];
                        regions.extend(ds.iter().filter_map(|d| d.region));
                        runs.push(start..regions.len());
                        counts.push(ds.iter().map(|d| d.loose_triangles() as usize).sum());
                    }
                    // Zeroed: the pages are first touched by the job that writes them.
                    *loose = bytemuck::zeroed_vec(counts.iter().sum());
                    let mut rest = &mut loose[..];
                    let stores = planning.plan(&regions, &runs)?;
                    crate::stages::mark("grid: block plans");
                    Ok(stores
                        .into_iter()
                        .zip(counts)
                        .map(|(s, n)| (s, split_off(&mut rest, n)))
                        .collect())
                },
                |(store, loose), view| {
                    if let Some(g) = &view.plan.region {
                        store.fill_region(&Source {
                            g,
                            frames: view.frame,
                            point: |v: u32| view.point(v),
                            level: |t: u32| view.level(t),
                        });
                    }
                    for (id, t, info) in view.loose() {
                        let corners = t.map(|v| view.point(v));
                        split_off(loose, 1)[0] = Loose {
                            p: corners.map(|c| c.0),
                            n: corners.map(|c| c.1),
                            uv: info.uv,
                            id,
                            face: info.face,
                            k: info.k,
                            level: info.level,
                        };
                    }
                    Ok(())
                },
            )?;
        }
        let stored = std::time::Instant::now();
        Ok((planning.finish(loose, triangles)?, stored))
    }
}
