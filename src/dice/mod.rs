//! Dicing: the limit surface as a crack-free triangle mesh whose vertices lie exactly on it
//! (paper 001 §4–5, §7).
//!
//! The unit of dicing is a *domain*: a quad base face, or one sub-face of an n-gon (which is a
//! level-1 face, so its rate is halved, paper 001 §7). Every domain is a unit square in its
//! ptex parameters; its interior is a regular grid evaluated with the exact patch table
//! ([`crate::patch::PatchTable::eval`]), so every patch inside a domain at level `l` gets
//! `rate / 2^l` segments per edge (and patches smaller than one micro-triangle share their
//! ancestor's, instead of forcing a vertex of their own). Sides carry their own rates and are
//! stitched to the grid ([`pattern`]).
//!
//! Watertightness is structural: every point on a side of a domain — base vertices, samples on
//! control edges, n-gon centres and the samples on the spokes between sub-faces — is evaluated
//! once and stored once, and both domains that share it use the same vertex index. The two
//! sides of an edge therefore agree bit for bit and no T-junction exists: the sample count of a
//! shared side is a property of the edge, not of the domain. Only at infinitely sharp features
//! (sharp creases, corners, non-manifold edges), where the two sides have different normals,
//! does a side vertex get a copy per domain: the copy's position is the same `f32` bits.

pub mod displace;
pub mod each;
pub mod estimate;
mod normals;
mod pattern;
mod rates;
mod shared;

pub use displace::Displacement;
pub(crate) use each::dice_each_planned;
pub use each::{dice_each, DiceLayout, DomainPlan, DomainView};
pub use estimate::DiceEstimate;
pub use pattern::{pattern, side_uv, GridPart, Pattern};
pub use rates::{edge_rates, DiceRate, Rates, ScreenRate};

use crate::coord::FaceCoord;
use crate::error::{Error, ErrorKind, Result};
use crate::mesh::ControlMesh;
use crate::oct::oct_encode_all;
use crate::patch::bspline::PointD1;
use crate::patch::table::{Kept, LeafLevels};
use crate::patch::PatchTable;
use crate::refine::crease;
use crate::refine::Level;
use crate::threads::split_off;
use crate::vec3::{norm, sub};
use normals::unit_normal;
use rayon::prelude::*;
use rustc_hash::FxHashMap as HashMap;
use shared::{Run, Shared};

/// Options of [`dice`].
#[derive(Clone, Debug, PartialEq)]
pub struct DiceOptions {
    /// How many segments each edge gets.
    pub rate: DiceRate,
    /// Upper bound on the segments of one edge.
    pub max_rate: u32,
    /// Displacement along the limit normal applied to every diced vertex ([`displace`]).
    pub displace: Option<Displacement>,
}

impl Default for DiceOptions {
    fn default() -> Self {
        DiceOptions {
            rate: DiceRate::Uniform(4),
            max_rate: 256,
            displace: None,
        }
    }
}

/// Per-triangle attributes.
#[derive(Clone, Copy, Debug, Default, PartialEq, bytemuck::Zeroable)]
pub struct TriInfo {
    /// Base face.
    pub face: u32,
    /// Sub-face (0 for quads).
    pub k: u32,
    /// Level of the patch at the triangle's centroid.
    pub level: u8,
    /// `(u, v)` of the three corners in `(face, k)`'s parameterisation.
    pub uv: [[f32; 2]; 3],
}

/// A diced limit surface.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct DicedMesh {
    /// Limit-surface points (object space), rounded once from `f64` evaluation.
    pub positions: Vec<[f32; 3]>,
    /// Unit limit normals.
    pub normals: Vec<[f32; 3]>,
    /// `(face, k, u, v)` of each vertex in the domain that evaluated it.
    pub params: Vec<FaceCoord>,
    /// Triangles, counter-clockwise as the control faces.
    pub triangles: Vec<[u32; 3]>,
    /// Attributes of each triangle.
    pub tri_info: Vec<TriInfo>,
    /// The regular grids among the triangles, one per domain that has one.
    pub grids: Vec<GridRegion>,
    /// The vertices of the grids' frames ([`GridRegion::frame`]).
    pub grid_frames: Vec<u32>,
}

/// A domain's regular grid of quads in a [`DicedMesh`]: `quads[0] × quads[1]` quads, row by
/// row, each as two consecutive triangles `[a, b, c]`, `[a, c, d]` (`a` its corner of lowest
/// `(u, v)`, counter-clockwise), starting at triangle `first_triangle`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct GridRegion {
    /// Index of the first quad's first triangle.
    pub first_triangle: u32,
    /// Base face.
    pub face: u32,
    /// Sub-face (0 for quads).
    pub k: u32,
    /// Where the grid lies in the domain.
    pub part: GridPart,
    /// The level of all the domain's triangles when the domain is one patch
    /// ([`PatchTable::domain_level`]); `None` when [`TriInfo::level`] varies.
    pub level: Option<u8>,
    /// Offset of the grid's frame in [`DicedMesh::grid_frames`]: the vertices of its first row,
    /// last row (each `quads[0] + 1`, left to right), first column and last column (each
    /// `quads[1] + 1`, bottom to top).
    pub frame: u32,
    /// The vertex of the domain's grid point `(1, 1)`: grid point `(i, j)` inside the frame is
    /// vertex `interior + (j − 1)(nu − 1) + (i − 1)`.
    pub interior: u32,
}

impl GridRegion {
    /// The vertex at point `(x, y)` of the grid (`x ≤ quads[0]`, `y ≤ quads[1]`), from the
    /// frame in `frames` ([`DicedMesh::grid_frames`]) or the interior.
    pub fn vertex(&self, frames: &[u32], x: u32, y: u32) -> u32 {
        let [qc, qr] = self.part.quads;
        let f = self.frame as usize;
        let (w, h) = (qc as usize + 1, qr as usize + 1);
        if y == 0 {
            frames[f + x as usize]
        } else if y == qr {
            frames[f + w + x as usize]
        } else if x == 0 {
            frames[f + 2 * w + y as usize]
        } else if x == qc {
            frames[f + 2 * w + h + y as usize]
        } else {
            let (i, j) = (self.part.origin[0] + x, self.part.origin[1] + y);
            self.interior + (j - 1) * (self.part.n[0] - 1) + (i - 1)
        }
    }

    /// The vertices of the `out.len()` consecutive points of row `y` from column `x`, each
    /// [`Self::vertex`]: a frame row's are a run of the frame, an inner row's are consecutive
    /// interior vertices between its frame ends.
    pub fn row_vertices(&self, frames: &[u32], x: u32, y: u32, out: &mut [u32]) {
        let [qc, qr] = self.part.quads;
        let f = self.frame as usize;
        if y == 0 || y == qr {
            let start = f + if y == 0 { 0 } else { qc as usize + 1 } + x as usize;
            out.copy_from_slice(&frames[start..start + out.len()]);
            return;
        }
        // Interior vertex of column `x'` of this row: `first + x'`.
        let j = self.part.origin[1] + y;
        let first = self.interior + (j - 1) * (self.part.n[0] - 1) + self.part.origin[0] - 1;
        for (o, xi) in out.iter_mut().zip(x..) {
            *o = if xi == 0 || xi == qc {
                self.vertex(frames, xi, y)
            } else {
                first + xi
            };
        }
    }
}

impl DicedMesh {
    /// Memory used, in bytes.
    pub fn bytes(&self) -> usize {
        self.positions.len() * 12
            + self.normals.len() * 12
            + self.params.len() * std::mem::size_of::<FaceCoord>()
            + self.triangles.len() * 12
            + self.tri_info.len() * std::mem::size_of::<TriInfo>()
            + self.grids.len() * std::mem::size_of::<GridRegion>()
            + self.grid_frames.len() * 4
    }

    /// Axis-aligned bounds of the vertices (`[max, min]` inverted when empty).
    pub fn bounds(&self) -> [[f32; 3]; 2] {
        let mut b = [[f32::INFINITY; 3], [f32::NEG_INFINITY; 3]];
        for p in &self.positions {
            for i in 0..3 {
                b[0][i] = b[0][i].min(p[i]);
                b[1][i] = b[1][i].max(p[i]);
            }
        }
        b
    }
}

/// A point evaluated on the limit surface.
#[derive(Clone, Copy, Debug, Default)]
struct Point {
    p: [f32; 3],
    n: [f32; 3],
    param: FaceCoord,
}

/// A displaced limit surface: a displacement with what its lookups need (the mesh's limit
/// texture coordinates for an image map; none on a mesh without them, where the (sub-)face's
/// own `(u, v)` address the image). [`dice`] evaluates it at every diced vertex.
pub struct DisplacedSurface<'a> {
    d: &'a Displacement,
    table: &'a PatchTable,
    uv: Option<crate::patch::uv::UvSurface>,
}

impl<'a> DisplacedSurface<'a> {
    /// The surface of `table` (built from `mesh`) displaced by `d`.
    pub fn new(d: &'a Displacement, table: &'a PatchTable, mesh: &ControlMesh) -> Result<Self> {
        let uv = if d.uses_uv() && !mesh.face_uvs.is_empty() {
            let m = ControlMesh {
                options: table.mesh_options,
                ..mesh.clone()
            };
            crate::patch::uv::UvSurface::new(&m, table.mesh_options.fvar)?
        } else {
            None
        };
        Ok(DisplacedSurface { d, table, uv })
    }

    /// The displaced surface `opts` asks for, if any.
    fn of(
        opts: &'a DiceOptions,
        table: &'a PatchTable,
        mesh: &ControlMesh,
    ) -> Result<Option<Self>> {
        opts.displace
            .as_ref()
            .map(|d| DisplacedSurface::new(d, table, mesh))
            .transpose()
    }

    /// The displaced point at `at` (in `f64`, before the dicer rounds it to `f32`).
    pub fn point(&self, at: FaceCoord) -> Result<[f64; 3]> {
        let (s, n) = limit_frame(self.table, at)?;
        Ok(self.apply(&s, n, at)?.0)
    }

    fn apply(
        &self,
        s: &crate::patch::Sample,
        n: [f64; 3],
        at: FaceCoord,
    ) -> Result<([f64; 3], [f64; 3])> {
        let st = if !self.d.uses_uv() {
            None
        } else if let Some(uv) = &self.uv {
            let x = uv.eval(at)?;
            Some((x.st, x.du, x.dv))
        } else {
            Some(([at.u, at.v], [1.0, 0.0], [0.0, 1.0]))
        };
        Ok(self.d.apply_at(s, n, st))
    }

    /// How many cells of the displacement's detail (noise lattice cells, or texels) the
    /// longest edge of the parameter triangle `uv` of `(face, k)` crosses, measured at 9
    /// points along each edge (what [`crate::harness::probe::displaced_triangle_error_bound`]
    /// sizes its sampling by).
    pub fn detail_across(&self, face: u32, k: u32, uv: [[f64; 2]; 3]) -> Result<f64> {
        const N: usize = 8;
        let mut most = 0.0f64;
        for e in 0..3 {
            let (a, b) = (uv[e], uv[(e + 1) % 3]);
            let at = |t: f64| (k, a[0] + (b[0] - a[0]) * t, a[1] + (b[1] - a[1]) * t);
            let plain = (0..=N)
                .map(|i| {
                    let (k, u, v) = at(i as f64 / N as f64);
                    Ok(self.table.eval(FaceCoord::new(face, k, u, v))?.p)
                })
                .collect::<Result<Vec<_>>>()?;
            most = most.max(self.detail_along(face, &plain, &at)?);
        }
        Ok(most)
    }

    /// How many cells of the displacement's detail (noise lattice cells, or texels along the
    /// image's larger side) the curve through `plain` (limit points at `points(i / (len - 1))`
    /// of face `f`) crosses.
    fn detail_along(
        &self,
        f: u32,
        plain: &[[f64; 3]],
        points: &dyn Fn(f64) -> (u32, f64, f64),
    ) -> Result<f64> {
        #[cfg(not(feature = "render"))]
        let _ = (f, points);
        match self.d {
            Displacement::Noise { frequency, .. } => {
                let len: f64 = plain.windows(2).map(|w| norm(sub(w[1], w[0]))).sum();
                Ok(len * frequency)
            }
            #[cfg(feature = "render")]
            Displacement::Map { texture, .. } => {
                let n = plain.len().max(2) - 1;
                let mut st = Vec::with_capacity(n + 1);
                for i in 0..=n {
                    let (k, u, v) = points(i as f64 / n as f64);
                    st.push(match &self.uv {
                        Some(uv) => uv.eval(FaceCoord::new(f, k, u, v))?.st,
                        None => [u, v],
                    });
                }
                let len: f64 = st
                    .windows(2)
                    .map(|w| (w[1][0] - w[0][0]).hypot(w[1][1] - w[0][1]))
                    .sum();
                Ok(len * texture.width().max(texture.height()) as f64)
            }
        }
    }
}

/// The limit sample at `at` and its unit normal ([`unit_normal`]).
fn limit_frame(table: &PatchTable, at: FaceCoord) -> Result<(crate::patch::Sample, [f64; 3])> {
    let s = table.eval(at)?;
    let n = unit_normal(table, at, s.du, s.dv)?;
    Ok((s, n))
}

/// Evaluates position and unit normal at `(face, k, u, v)` ([`limit_frame`]), displaced if
/// asked.
fn eval_point(
    table: &PatchTable,
    displace: Option<&DisplacedSurface>,
    face: u32,
    k: u32,
    u: f64,
    v: f64,
) -> Result<Point> {
    let at = FaceCoord::new(face, k, u, v);
    let (p, n) = match displace {
        Some(d) => {
            let (s, n) = limit_frame(table, at)?;
            d.apply(&s, n, at)?
        }
        None => {
            // Position and first derivatives only: the same bits as `limit_frame`'s.
            let pt = table.eval_d1(at)?;
            (pt.p, unit_normal(table, at, pt.du, pt.dv)?)
        }
    };
    rounded(at, p, n)
}

/// The diced point at `at` of position `p` and normal `n`, rounded to `f32`; an error where
/// `p` is out of the numeric range.
fn rounded(at: FaceCoord, p: [f64; 3], n: [f64; 3]) -> Result<Point> {
    in_range(at, p)?;
    Ok(point(at, p, n))
}

/// An error where position `p` at `at` is out of the numeric range.
#[inline(always)]
fn in_range(at: FaceCoord, p: [f64; 3]) -> Result<()> {
    if crate::numeric::in_range(p) {
        Ok(())
    } else {
        Err(out_of_range(at, p))
    }
}

/// [`rounded`] of a point known to be in range: a `Point`, not a `Result` (moved through
/// memory, a `Result<Point>` is read back with wider loads than its stores: a stall a point).
#[inline(always)]
fn point(at: FaceCoord, p: [f64; 3], n: [f64; 3]) -> Point {
    Point {
        p: p.map(|x| x as f32),
        n: n.map(|x| x as f32),
        param: at,
    }
}

/// The error of a diced point at `at` whose position `p` is out of the numeric range.
#[cold]
#[inline(never)]
fn out_of_range(at: FaceCoord, p: [f64; 3]) -> Error {
    let FaceCoord { face, k, u, v } = at;
    Error::new(
        ErrorKind::Usage,
        format!(
            "face {face}: the displaced point {p:?} at ({k}, {u}, {v}) is outside the numeric \
             range ±{:e}",
            crate::numeric::MAX_COORD
        ),
    )
}

/// The point at fraction `t ∈ [0, 1]` along face edge `m` of face `f` (from its vertex `m`
/// to vertex `m + 1`), as `(k, u, v)` in that face's domains.
pub fn face_edge_param(n: usize, m: usize, t: f64) -> (u32, f64, f64) {
    if n == 4 {
        let [u, v] = side_uv(m, t);
        (0, u, v)
    } else if t <= 0.5 {
        (m as u32, 2.0 * t, 0.0)
    } else {
        (((m + 1) % n) as u32, 0.0, 2.0 - 2.0 * t)
    }
}

/// Upper bounds on the size of [`dice`]'s result, from the edge rates alone.
pub fn estimate_size(
    table: &PatchTable,
    mesh: &ControlMesh,
    opts: &DiceOptions,
) -> Result<DiceEstimate> {
    plan(table, mesh, opts).map(|p| p.estimate)
}

/// The edge rates of one dicing, found once: the size they imply, for a check of a whole
/// scene's memory before anything is diced, and then the dicing itself
/// ([`crate::grid::GridMesh::dice_planned`]), which would otherwise measure every edge again.
#[derive(Clone, Debug)]
pub struct DicePlan {
    rates: Rates,
    estimate: DiceEstimate,
}

impl DicePlan {
    /// Upper bounds on the size of the diced mesh ([`estimate_size`]'s).
    pub fn estimate(&self) -> DiceEstimate {
        self.estimate
    }

    /// The rates, checked against the base level of the mesh they are used on: a plan made
    /// for another mesh is an error, not a wrong dicing.
    pub(crate) fn into_rates(self, level: &Level) -> Result<Rates> {
        if self.rates.edge.len() != level.topo.num_edges()
            || self.rates.spoke.len() != level.topo.face_verts.len()
        {
            return Err(Error::new(
                ErrorKind::Usage,
                "the dicing plan was made for another mesh",
            ));
        }
        Ok(self.rates)
    }
}

/// Plans the dicing of `mesh` (whose patch table is `table`) with `opts`: its edge rates and
/// the size they imply. [`crate::grid::GridMesh::dice_planned`] dices by it with the same
/// `table`, `mesh` and `opts`.
pub fn plan(table: &PatchTable, mesh: &ControlMesh, opts: &DiceOptions) -> Result<DicePlan> {
    let mut built = None;
    let level = table.base_level_of(mesh, &mut built)?;
    let displacer = DisplacedSurface::of(opts, table, mesh)?;
    let rates = rates::rates_for(table, level, opts, displacer.as_ref())?;
    let estimate = estimate::estimate(level, &rates);
    Ok(DicePlan { rates, estimate })
}

/// Dices the limit surface of `mesh` (whose patch table is `table`) into triangles. The size
/// is estimated first and checked against the memory budget ([`crate::memory`]).
pub fn dice(table: &PatchTable, mesh: &ControlMesh, opts: &DiceOptions) -> Result<DicedMesh> {
    prepare(table, mesh, opts, None, false, true, |p| p.mesh())
}

/// Everything dicing knows before it evaluates a point: the domains, their sizes, and what
/// [`DomainCtx`] reads (the shared points' positions are filled in once evaluated).
struct Prepared<'a> {
    ctx: DomainCtx<'a>,
    /// Every live domain `(face, k)`, in order.
    domains: Vec<(u32, u32)>,
    /// What each adds.
    sizes: Vec<DomainSize>,
}

/// Domains per parallel job of the domain pass (each job's outputs are split off in order;
/// each domain's own within its job's worker: the slices of every domain made up front took a
/// 316² grid 10 ms and 3,500 page faults, serially).
const CHUNK: usize = 64;

/// Prepares the dicing of `mesh` (rates, unless `planned` gives them, the shared points'
/// layout, the domains' sizes) and hands it to `then`; with `lean`, domains write no
/// per-point parameters, and of their grid triangles neither corners nor records, only the
/// levels, apart (see [`dice_each`]); without `normals` (lean only), the points' shading
/// normals are not found where they need not be (every point of an undisplaced exact
/// surface: [`LatticeScratch::finish`]), nor encoded.
fn prepare<R>(
    table: &PatchTable,
    mesh: &ControlMesh,
    opts: &DiceOptions,
    planned: Option<DicePlan>,
    lean: bool,
    normals: bool,
    then: impl FnOnce(&Prepared) -> Result<R>,
) -> Result<R> {
    // The table's level 0 where it kept it (building it again took 34 ms of the 316² grid's
    // 242 ms of dicing).
    let mut built = None;
    let level = table.base_level_of(mesh, &mut built)?;
    if table.num_faces() != level.num_faces() {
        return Err(Error::new(
            ErrorKind::Usage,
            "the patch table was built from another mesh",
        ));
    }
    let topo = &level.topo;
    let live = |f: usize| !level.face_hole[f];
    let displacer = DisplacedSurface::of(opts, table, mesh)?;
    let rates = match planned {
        Some(plan) => plan.into_rates(level)?,
        None => rates::rates_for(table, level, opts, displacer.as_ref())?,
    };
    crate::memory::check(
        "dicing",
        estimate::estimate(level, &rates).bytes(),
        "lower the dicing rate (--rate, or the scene's rate, max_rate or pixels_per_edge)",
    )?;

    crate::stages::mark("dice: rates");
    // Entities with a seam: infinitely sharp edges, and vertices with one such edge or an
    // infinitely sharp corner.
    let sharp_edge: Vec<bool> = level
        .edge_sharpness
        .iter()
        .map(|&s| crease::is_infinite(s))
        .collect();
    let sharp_vertex: Vec<bool> = (0..topo.num_vertices)
        .map(|v| {
            crease::is_infinite(level.vertex_sharpness[v])
                || topo.vertex_edges(v).iter().any(|&e| sharp_edge[e as usize])
        })
        .collect();

    // --- Shared points: laid out (evaluated once the domains' sizes are known). ----------
    let shared = Shared::new(level, &rates.edge, &rates.spoke);

    // --- Domains: stitch patterns, evaluate interiors, in parallel. -----------------------
    let domains: Vec<(u32, u32)> = (0..topo.num_faces())
        .filter(|&f| live(f))
        .flat_map(|f| {
            let n = topo.face_size(f);
            let ks = if n == 4 { 1 } else { n };
            (0..ks).map(move |k| (f as u32, k as u32))
        })
        .collect();
    crate::stages::mark("dice: shared layout");
    let ctx = DomainCtx {
        table,
        level,
        rates: &rates,
        shared: &shared,
        shared_positions: &[],
        sharp_edge: &sharp_edge,
        sharp_vertex: &sharp_vertex,
        displace: displacer.as_ref(),
        lean,
        normals: normals || !lean,
    };
    // Sizes first (patterns only, nothing evaluated), so that every domain then writes its
    // points and triangles in place, in parallel, with no per-domain buffers to copy.
    // Patterns by side rates cached per worker (a cache per chunk of domains made each chunk
    // build its patterns again: 1,560 times on a 316² grid).
    let sizes: Vec<DomainSize> = domains
        .par_iter()
        .with_min_len(64)
        .map_init(Default::default, |scratch, &(f, k)| {
            ctx.domain_size(f as usize, k as usize, scratch)
        })
        .collect();
    crate::stages::mark("dice: sizes");
    then(&Prepared {
        ctx,
        domains,
        sizes,
    })
}

impl Prepared<'_> {
    /// Number of shared points (the diced mesh's first vertices).
    fn num_shared(&self) -> usize {
        self.ctx.shared.len
    }

    /// Evaluates the shared points in parallel into their slots (no buffer of points to copy
    /// from), in groups of runs whose normals are found at once: their positions, and their
    /// normals and parameters (non-lean: `codes` empty) or their normals' octahedral codes
    /// (lean: `normals` and `params` empty; `codes` too when dicing finds no normals).
    fn eval_shared(
        &self,
        positions: &mut [[f32; 3]],
        mut normals: &mut [[f32; 3]],
        mut params: &mut [FaceCoord],
        mut codes: &mut [u32],
    ) -> Result<()> {
        const GROUP: usize = 256;
        let (table, lean, with_normals) = (self.ctx.table, self.ctx.lean, self.ctx.normals);
        let displacer = self.ctx.displace;
        let groups = self.ctx.shared.groups(GROUP);
        let mut jobs = Vec::with_capacity(groups.len());
        let mut rest = positions;
        for (runs, len) in groups {
            let (nl, cl) = match (lean, with_normals) {
                (false, _) => (len, 0),
                (true, true) => (0, len),
                (true, false) => (0, 0),
            };
            jobs.push((
                runs,
                split_off(&mut rest, len),
                split_off(&mut normals, nl),
                split_off(&mut params, nl),
                split_off(&mut codes, cl),
            ));
        }
        jobs.into_par_iter().try_for_each_init(
            || (LatticeScratch::default(), Vec::new(), Vec::new()),
            |(scratch, group_normals, coords), (runs, p, nrm, prm, cds)| {
                if displacer.is_none() && !with_normals && nrm.is_empty() && prm.is_empty() {
                    // Positions alone (the grid core's lean dicing without normals).
                    return positions_alone(table, runs, p, scratch, coords);
                }
                // The group's points' parameters, from their runs.
                coords.clear();
                coords.extend(
                    runs.iter()
                        .flat_map(|r: &Run| (0..r.len()).map(move |i| r.at(i))),
                );
                // Lean: the group's normals gathered here, then encoded at once (`cds`).
                group_normals.clear();
                group_normals.resize(cds.len(), [0.0; 3]);
                let mut put = |i: usize, q: Point| {
                    p[i] = q.p;
                    if let Some(slot) = group_normals.get_mut(i) {
                        *slot = q.n;
                    }
                    if let Some(slot) = nrm.get_mut(i) {
                        *slot = q.n;
                    }
                    if let Some(slot) = prm.get_mut(i) {
                        *slot = q.param;
                    }
                };
                let at = |i: usize| coords[i];
                if displacer.is_some() {
                    for (i, &FaceCoord { face, k, u, v }) in coords.iter().enumerate() {
                        put(i, eval_point(table, displacer, face, k, u, v)?);
                    }
                } else {
                    // A run's points (an edge's) lie in one domain and share its leaves'
                    // parts, kept while the next runs are in the same domain.
                    scratch.points.clear();
                    let mut domain = None;
                    let mut rest = &coords[..];
                    for run in runs {
                        let (mine, after) = rest.split_at(run.len());
                        rest = after;
                        let Some(at) = mine.first() else { continue };
                        if domain != Some((at.face, at.k)) {
                            domain = Some((at.face, at.k));
                            scratch.kept.clear();
                        }
                        // Without normals, positions alone (the same bits).
                        if with_normals
                            || !table.eval_points_p(mine, &mut scratch.kept, &mut scratch.points)?
                        {
                            table.eval_d1_points(mine, &mut scratch.kept, &mut scratch.points)?;
                        }
                    }
                    scratch.finish(table, at, put, with_normals)?;
                }
                if lean && with_normals {
                    oct_encode_all(group_normals, cds);
                }
                Ok::<(), Error>(())
            },
        )
    }

    /// Each domain's first point, first triangle and first frame entry, in domain order (sums
    /// only).
    fn firsts(&self) -> Vec<[u32; 3]> {
        let mut at = [self.num_shared() as u32, 0, 0];
        self.sizes
            .iter()
            .map(|z| {
                let first = at;
                at[0] += z.points as u32;
                at[1] += z.triangles as u32;
                at[2] += z.frame as u32;
                first
            })
            .collect()
    }

    /// Domain `i`'s grid region, if it has one, from its firsts ([`Self::firsts`]; the frame
    /// entry is where the region's frame starts).
    fn region(&self, i: usize, [base, first_triangle, frame]: [u32; 3]) -> Option<GridRegion> {
        let ((face, k), z) = (self.domains[i], &self.sizes[i]);
        z.grid.map(|part| GridRegion {
            first_triangle,
            face,
            k,
            part,
            level: self.ctx.table.domain_level(face as usize, k as usize),
            frame,
            interior: base + z.copies as u32,
        })
    }

    /// Total points (shared ones included) and triangles; an error past 2^31 points.
    fn totals(&self) -> Result<(usize, usize)> {
        let points = self.num_shared() + self.sizes.iter().map(|z| z.points).sum::<usize>();
        let triangles = self.sizes.iter().map(|z| z.triangles).sum();
        if u32::try_from(points).is_err() || points as u64 >= LOCAL as u64 {
            return Err(Error::new(
                ErrorKind::Usage,
                "diced mesh exceeds 2^31 vertices",
            ));
        }
        Ok((points, triangles))
    }

    /// The diced mesh ([`dice`]).
    fn mesh(&self) -> Result<DicedMesh> {
        let (total_points, total_tris) = self.totals()?;
        let sizes = &self.sizes;
        let mut out = DicedMesh {
            positions: vec![[0.0; 3]; total_points],
            normals: vec![[0.0; 3]; total_points],
            // Zeroed allocations (every page is first touched by the domain that writes it,
            // in parallel; `vec![x; n]` of a struct writes every element here, sequentially).
            params: bytemuck::zeroed_vec(total_points),
            triangles: vec![[0; 3]; total_tris],
            tri_info: bytemuck::zeroed_vec(total_tris),
            grids: Vec::new(),
            grid_frames: vec![0; sizes.iter().map(|z| z.frame).sum()],
        };
        let n = self.num_shared();
        let (shared_positions, positions) = out.positions.split_at_mut(n);
        let (shared_normals, normals) = out.normals.split_at_mut(n);
        let (shared_params, params) = out.params.split_at_mut(n);
        self.eval_shared(shared_positions, shared_normals, shared_params, &mut [])?;
        let firsts = self.firsts();
        out.grids = (0..firsts.len())
            .filter_map(|i| self.region(i, firsts[i]))
            .collect();
        let ctx = DomainCtx {
            shared_positions,
            ..self.ctx
        };
        let mut rest = DomainSlices {
            base: n as u32,
            positions,
            normals,
            params,
            triangles: &mut out.triangles[..],
            tri_info: &mut out.tri_info[..],
            levels: &mut [],
            frame: &mut out.grid_frames[..],
        };
        let mut chunks = Vec::with_capacity(self.domains.len().div_ceil(CHUNK));
        for (ds, zs) in self.domains.chunks(CHUNK).zip(sizes.chunks(CHUNK)) {
            let total = zs.iter().fold(DomainSize::default(), |a, z| DomainSize {
                points: a.points + z.points,
                triangles: a.triangles + z.triangles,
                frame: a.frame + z.frame,
                ..a
            });
            chunks.push((ds, zs, rest.split_off(&total)));
        }
        chunks.into_par_iter().try_for_each_init(
            Scratch::default,
            |scratch, (ds, zs, mut chunk)| {
                for (&(f, k), z) in ds.iter().zip(zs) {
                    ctx.domain(f as usize, k as usize, scratch, chunk.split_off(z))?;
                }
                Ok::<(), Error>(())
            },
        )?;
        Ok(out)
    }
}

/// Flag of a domain-local vertex index in a domain's triangles before they are stored.
const LOCAL: u32 = 1 << 31;

/// What a domain adds to the diced mesh.
#[derive(Default)]
struct DomainSize {
    /// Points of its own: seam copies, then the interior.
    points: usize,
    /// Triangles.
    triangles: usize,
    /// Its regular grid, if any.
    grid: Option<GridPart>,
    /// Seam copies among its points (they come first).
    copies: usize,
    /// Points of its grid's frame.
    frame: usize,
}

/// Where a domain stores its points and triangles in the diced mesh.
struct DomainSlices<'a> {
    /// Index of its first point.
    base: u32,
    positions: &'a mut [[f32; 3]],
    normals: &'a mut [[f32; 3]],
    params: &'a mut [FaceCoord],
    triangles: &'a mut [[u32; 3]],
    tri_info: &'a mut [TriInfo],
    /// Lean dicing: the levels of its grid triangles (empty otherwise).
    levels: &'a mut [u8],
    /// Its grid's frame ([`GridRegion::frame`]).
    frame: &'a mut [u32],
}

impl<'a> DomainSlices<'a> {
    /// The slices of the first domains, of `z.points` points, `z.triangles` triangles and
    /// `z.frame` frame entries in all (a diced mesh's: no levels apart); `self` keeps the rest.
    fn split_off(&mut self, z: &DomainSize) -> DomainSlices<'a> {
        let head = DomainSlices {
            base: self.base,
            positions: split_off(&mut self.positions, z.points),
            normals: split_off(&mut self.normals, z.points),
            params: split_off(&mut self.params, z.points),
            triangles: split_off(&mut self.triangles, z.triangles),
            tri_info: split_off(&mut self.tri_info, z.triangles),
            levels: &mut [],
            frame: split_off(&mut self.frame, z.frame),
        };
        self.base += z.points as u32;
        head
    }

    /// Stores the domain's point `i` (its parameters too, unless dicing is lean).
    fn put(&mut self, i: usize, q: Point) {
        self.positions[i] = q.p;
        self.normals[i] = q.n;
        if let Some(slot) = self.params.get_mut(i) {
            *slot = q.param;
        }
    }
}

/// What a worker keeps from domain to domain: the stitch patterns by side rates, the
/// buffers of a lattice's points and normals, the domain's sides and its index map.
#[derive(Default)]
struct Scratch {
    patterns: HashMap<[u32; 4], Pattern>,
    lattice: LatticeScratch,
    sides: Sides,
    /// Pattern indices to vertex indices.
    map: Vec<u32>,
}

/// `f32` slots filled with `f64` positions one after another, each rounded once, the first
/// out of the numeric range remembered for [`Self::check`] (a point's range is checked as
/// it comes; its error, which needs the point's parameters, only once all are in).
struct Rounded<'a> {
    slots: &'a mut [[f32; 3]],
    next: usize,
    outside: Option<(usize, [f64; 3])>,
}

impl<'a> Rounded<'a> {
    fn new(slots: &'a mut [[f32; 3]]) -> Self {
        Rounded {
            slots,
            next: 0,
            outside: None,
        }
    }

    /// Stores the next position.
    #[inline(always)]
    fn put(&mut self, q: [f64; 3]) {
        if self.outside.is_none() && !crate::numeric::in_range(q) {
            self.outside = Some((self.next, q));
        }
        self.slots[self.next] = q.map(|x| x as f32);
        self.next += 1;
    }

    /// The error of the first position out of range, the `i`-th being at `at(i)` ([`in_range`]).
    fn check(&self, at: impl FnOnce(usize) -> FaceCoord) -> Result<()> {
        match self.outside {
            Some((i, q)) => in_range(at(i), q),
            None => Ok(()),
        }
    }
}

/// The positions alone of the shared points of `runs` into `out` (one slot a point, in run
/// order), the bits [`Prepared::eval_shared`]'s general path gives: a run whose points lie in
/// one domain that is one B-spline patch is summed straight into its slots
/// ([`PatchTable::eval_domain_points_p`]: its control points gathered once, no lookup, check
/// or record per point); any other run by the general evaluation, with its parameters
/// (`coords`, scratch) and leaves' parts (`scratch`) of its own.
fn positions_alone(
    table: &PatchTable,
    runs: &[Run],
    out: &mut [[f32; 3]],
    scratch: &mut LatticeScratch,
    coords: &mut Vec<FaceCoord>,
) -> Result<()> {
    let mut first = 0;
    for run in runs {
        let slots = &mut out[first..first + run.len()];
        first += run.len();
        let mut rounded = Rounded::new(slots);
        let uv = (0..run.len()).map(|i| {
            let c = run.at(i);
            [c.u, c.v]
        });
        if run
            .one_domain()
            .is_some_and(|d| table.eval_domain_points_p(d, uv, |q| rounded.put(q)))
        {
            rounded.check(|i| run.at(i))?;
            continue;
        }
        coords.clear();
        coords.extend((0..run.len()).map(|i| run.at(i)));
        scratch.points.clear();
        scratch.kept.clear();
        if !table.eval_points_p(coords, &mut scratch.kept, &mut scratch.points)? {
            table.eval_d1_points(coords, &mut scratch.kept, &mut scratch.points)?;
        }
        for ((slot, q), &c) in slots.iter_mut().zip(&scratch.points).zip(coords.iter()) {
            in_range(c, q.p)?;
            *slot = q.p.map(|x| x as f32);
        }
    }
    Ok(())
}

/// A run of evaluated points (a domain's lattice, or shared points) and their unit normals.
#[derive(Default)]
struct LatticeScratch {
    points: Vec<PointD1>,
    normals: Vec<[f64; 3]>,
    /// The leaves' parts that a run's points share.
    kept: Kept,
}

impl LatticeScratch {
    /// The diced points of [`Self::points`], the `i`-th at `at(i)`: their unit normals found at
    /// once ([`normals::unit_normals`]; zero without `with_normals`), then `put(i, point)`,
    /// rounded ([`rounded`]).
    fn finish(
        &mut self,
        table: &PatchTable,
        at: impl Fn(usize) -> FaceCoord,
        mut put: impl FnMut(usize, Point),
        with_normals: bool,
    ) -> Result<()> {
        if with_normals {
            normals::unit_normals(table, &self.points, &at, &mut self.normals)?;
        }
        for (i, pt) in self.points.iter().enumerate() {
            let at = at(i);
            in_range(at, pt.p)?;
            let n = if with_normals {
                self.normals[i]
            } else {
                [0.0; 3]
            };
            put(i, point(at, pt.p, n));
        }
        Ok(())
    }
}

#[derive(Clone, Copy)]
struct DomainCtx<'a> {
    table: &'a PatchTable,
    level: &'a Level,
    rates: &'a rates::Rates,
    shared: &'a Shared,
    /// The shared points' positions (empty until they are evaluated, after the domains'
    /// sizes are known).
    shared_positions: &'a [[f32; 3]],
    sharp_edge: &'a [bool],
    sharp_vertex: &'a [bool],
    displace: Option<&'a DisplacedSurface<'a>>,
    /// Dicing for the grid core ([`dice_each`]): no per-point parameters, and of grid
    /// triangles neither corners nor records (only their levels, apart, where the domain has
    /// several).
    lean: bool,
    /// Whether the points' shading normals are found (always, unless lean dicing is asked to
    /// skip them: [`dice_each`]).
    normals: bool,
}

/// A point on a domain's side: its shared index, and whether it lies on a seam.
#[derive(Clone, Copy)]
struct SidePoint {
    index: u32,
    seam: bool,
}

/// A domain's four sides ([`DomainCtx::sides`]) and a fifth list of scratch space, kept by a
/// worker from domain to domain (lists allocated per domain took a 316² grid's dicing 9 ms).
#[derive(Default)]
struct Sides([Vec<SidePoint>; 5]);

impl Sides {
    /// The four sides.
    fn get(&self) -> &[Vec<SidePoint>] {
        &self.0[..4]
    }
}

impl DomainCtx<'_> {
    /// The `r + 1` points of face edge `m` of face `f`, from its vertex `m` to vertex `m + 1`,
    /// into `pts` (cleared first).
    fn face_edge_points(&self, f: usize, m: usize, pts: &mut Vec<SidePoint>) {
        let topo = &self.level.topo;
        let n = topo.face_size(f);
        let e = topo.face_edge(f, m) as usize;
        let va = topo.face_vertices(f)[m] as usize;
        let vb = topo.face_vertices(f)[(m + 1) % n] as usize;
        pts.clear();
        pts.push(SidePoint {
            index: self.shared.vertex[va],
            seam: self.sharp_vertex[va],
        });
        let seam = self.sharp_edge[e];
        pts.extend(
            self.edge_inner(e, va)
                .map(|index| SidePoint { index, seam }),
        );
        pts.push(SidePoint {
            index: self.shared.vertex[vb],
            seam: self.sharp_vertex[vb],
        });
    }

    /// The shared indices of the first `r` of the `r + 1` points of face edge `m` of face
    /// `f` ([`Self::face_edge_points`]' without the last and their seam flags), pushed onto
    /// `out`.
    fn face_edge_ring(&self, f: usize, m: usize, out: &mut Vec<u32>) {
        let topo = &self.level.topo;
        let e = topo.face_edge(f, m) as usize;
        let va = topo.face_vertices(f)[m] as usize;
        out.push(self.shared.vertex[va]);
        out.extend(self.edge_inner(e, va));
    }

    /// The shared indices of the `r − 1` inner points of edge `e` (rate `r`), in order from
    /// its end `va`.
    #[inline(always)]
    fn edge_inner(&self, e: usize, va: usize) -> impl Iterator<Item = u32> {
        let r = self.rates.edge[e];
        let first = self.shared.edge_first[e];
        let forward = self.level.topo.edge_verts[e][0] as usize == va;
        (0..r - 1).map(move |j| {
            if forward {
                first + j
            } else {
                first + r - 2 - j
            }
        })
    }

    /// Spoke `k` of n-gon `f`: from the midpoint of edge `k` to the centre, into `pts`
    /// (cleared first; `edge` is scratch space).
    fn spoke_points(
        &self,
        f: usize,
        k: usize,
        pts: &mut Vec<SidePoint>,
        edge: &mut Vec<SidePoint>,
    ) {
        let topo = &self.level.topo;
        self.face_edge_points(f, k, edge);
        let slot = topo.face_offsets[f] as usize + k;
        let s = self.rates.spoke[slot];
        let first = self.shared.spoke_first[slot];
        pts.clear();
        pts.push(edge[edge.len() / 2]);
        pts.extend((0..s - 1).map(|i| SidePoint {
            index: first + i,
            seam: false,
        }));
        pts.push(SidePoint {
            index: self.shared.centre[f],
            seam: false,
        });
    }

    /// The interior points of domain `(f, k)` (the lattice of `pat`, `put(i, point)` for the
    /// `i`-th), evaluated at once when the surface is undisplaced and exact
    /// ([`PatchTable::eval_domain_lattice`]: the same bits as point by point); `false`, with
    /// nothing put, otherwise.
    fn lattice(
        &self,
        f: usize,
        k: usize,
        pat: &Pattern,
        scratch: &mut LatticeScratch,
        put: impl FnMut(usize, Point),
    ) -> Result<bool> {
        if self.displace.is_some() || pat.interior.is_empty() {
            return Ok(false);
        }
        let nu = pat.rates[0].max(pat.rates[2]);
        let nv = pat.rates[1].max(pat.rates[3]);
        debug_assert_eq!(pat.interior.len(), ((nu - 1) * (nv - 1)) as usize);
        let pts = &mut scratch.points;
        pts.clear();
        // Without normals, the positions alone where the leaves allow (the same bits).
        let push = |pt| pts.push(pt);
        let evaluated = match self.normals {
            true => self.table.eval_domain_lattice(f, k, nu, nv, push),
            false => self
                .table
                .eval_domain_lattice_with::<false>(f, k, nu, nv, push),
        };
        if !evaluated {
            return Ok(false);
        }
        let at = |i: usize| {
            let [u, v] = pat.interior[i];
            FaceCoord::new(f as u32, k as u32, u, v)
        };
        scratch.finish(self.table, at, put, self.normals)?;
        Ok(true)
    }

    /// The positions alone of the interior points of domain `(f, k)` (the lattice of `pat`)
    /// into `slots` where the surface is undisplaced and the domain one B-spline patch
    /// ([`PatchTable::eval_domain_lattice_p`]: the bits [`Self::lattice`] rounds, without a
    /// record or a normal per point; a point out of the numeric range is the same error);
    /// `false`, with nothing written, otherwise.
    fn lattice_positions(
        &self,
        f: usize,
        k: usize,
        pat: &Pattern,
        slots: &mut [[f32; 3]],
    ) -> Result<bool> {
        if self.displace.is_some() || pat.interior.is_empty() {
            return Ok(false);
        }
        let nu = pat.rates[0].max(pat.rates[2]);
        let nv = pat.rates[1].max(pat.rates[3]);
        debug_assert_eq!(slots.len(), ((nu - 1) * (nv - 1)) as usize);
        let mut rounded = Rounded::new(slots);
        let (f32_, k32) = (f as u32, k as u32);
        if !self
            .table
            .eval_domain_lattice_p((f32_, k32), nu, nv, |q| rounded.put(q))
        {
            return Ok(false);
        }
        rounded.check(|i| {
            let [u, v] = pat.interior[i];
            FaceCoord::new(f32_, k32, u, v)
        })?;
        Ok(true)
    }

    /// The points of the four sides of domain `(f, k)`, each from its start to its end, into
    /// `sides` (reused from domain to domain).
    fn sides(&self, f: usize, k: usize, sides: &mut Sides) {
        let topo = &self.level.topo;
        let n = topo.face_size(f);
        let [s0, s1, s2, s3, edge] = &mut sides.0;
        if n == 4 {
            for (m, side) in [s0, s1, s2, s3].into_iter().enumerate() {
                self.face_edge_points(f, m, side);
            }
        } else {
            let prev = (k + n - 1) % n;
            self.face_edge_points(f, k, s0);
            s0.truncate(s0.len() / 2 + 1);
            self.spoke_points(f, k, s1, edge);
            self.spoke_points(f, prev, s2, edge);
            s2.reverse();
            self.face_edge_points(f, prev, s3);
            s3.drain(..s3.len() / 2);
        }
    }

    /// Whether side point `sp` of domain `(f, k)` is a seam vertex owned by another domain
    /// (the domain stores a copy of its own).
    fn foreign_seam(&self, f: usize, k: usize, sp: SidePoint) -> bool {
        sp.seam && {
            let owner = self.shared.at(sp.index);
            owner.face as usize != f || owner.k as usize != k
        }
    }

    /// The side rates of quad `f` (its edges' rates, in face-edge order) when no point on its
    /// sides is a seam vertex (no infinitely sharp edge or vertex): what [`Self::sides`] would
    /// give as side lengths, without listing the points. `None` for other faces.
    fn seamless_quad_rates(&self, f: usize) -> Option<[u32; 4]> {
        let topo = &self.level.topo;
        if topo.face_size(f) != 4 {
            return None;
        }
        let a = topo.face_offsets[f] as usize;
        let verts = &topo.face_verts[a..a + 4];
        let edges = &topo.face_edges[a..a + 4];
        let seam = verts.iter().any(|&v| self.sharp_vertex[v as usize])
            || edges.iter().any(|&e| self.sharp_edge[e as usize]);
        (!seam).then(|| std::array::from_fn(|m| self.rates.edge[edges[m] as usize]))
    }

    /// What domain `(f, k)` adds to the diced mesh (nothing is evaluated).
    fn domain_size(
        &self,
        f: usize,
        k: usize,
        (cache, sides): &mut (HashMap<[u32; 4], Pattern>, Sides),
    ) -> DomainSize {
        let (rates, copies) = match self.seamless_quad_rates(f) {
            // A quad with no seam on its sides: its sides' rates are its edges', and it
            // copies no point (listing every side point to count none took a 316² grid 10 ms).
            Some(rates) => (rates, 0),
            None => {
                self.sides(f, k, sides);
                let sides = sides.get();
                let rates: [u32; 4] = std::array::from_fn(|s| sides[s].len() as u32 - 1);
                let copies = sides
                    .iter()
                    .flat_map(|side| &side[..side.len() - 1])
                    .filter(|&&sp| self.foreign_seam(f, k, sp))
                    .count();
                (rates, copies)
            }
        };
        let pat = cache.entry(rates).or_insert_with(|| pattern(rates));
        DomainSize {
            points: copies + pat.interior.len(),
            triangles: pat.triangles.len(),
            grid: pat.grid,
            copies,
            frame: pat.grid_frame.len(),
        }
    }

    /// Evaluates domain `(f, k)` into `out` (sized by [`Self::domain_size`]).
    fn domain(
        &self,
        f: usize,
        k: usize,
        scratch: &mut Scratch,
        mut out: DomainSlices,
    ) -> Result<()> {
        let Scratch {
            patterns,
            lattice,
            sides,
            map,
        } = scratch;
        // Map pattern indices to vertex indices: the ring's first.
        map.clear();
        let mut own = 0;
        let rates = match self.seamless_quad_rates(f) {
            // A quad with no seam on its sides: its ring is its edges' shared points, in
            // order, with no copy (no side points listed to find none).
            Some(rates) => {
                for m in 0..4 {
                    self.face_edge_ring(f, m, map);
                }
                rates
            }
            None => {
                self.sides(f, k, sides);
                let sides = sides.get();
                let rates: [u32; 4] = std::array::from_fn(|s| sides[s].len() as u32 - 1);
                for (s, side) in sides.iter().enumerate() {
                    for (j, &sp) in side[..side.len() - 1].iter().enumerate() {
                        if self.foreign_seam(f, k, sp) {
                            // A seam vertex owned by another domain: copy its position, own
                            // normal.
                            let [u, v] = side_uv(s, j as f64 / rates[s] as f64);
                            let mut q =
                                eval_point(self.table, self.displace, f as u32, k as u32, u, v)?;
                            q.p = self.shared_positions[sp.index as usize];
                            map.push(LOCAL | own as u32);
                            out.put(own, q);
                            own += 1;
                        } else {
                            map.push(sp.index);
                        }
                    }
                }
                rates
            }
        };
        let pat = patterns.entry(rates).or_insert_with(|| pattern(rates));
        debug_assert_eq!(map.len(), pat.ring_len());
        let first = own;
        map.extend((0..pat.interior.len()).map(|i| LOCAL | (first + i) as u32));
        let base = out.base;
        let global = move |v: u32| {
            if v & LOCAL != 0 {
                base + (v & !LOCAL)
            } else {
                v
            }
        };
        for (slot, &i) in out.frame.iter_mut().zip(&pat.grid_frame) {
            *slot = global(map[i as usize]);
        }
        // Positions alone (no normals, no parameters) summed straight into their slots where
        // the domain is one B-spline patch; else the lattice's records, else point by point.
        let interior = first..first + pat.interior.len();
        let alone = !self.normals
            && out.params.is_empty()
            && self.lattice_positions(f, k, pat, &mut out.positions[interior])?;
        if !alone && !self.lattice(f, k, pat, lattice, |i, q| out.put(first + i, q))? {
            for (i, &[u, v]) in pat.interior.iter().enumerate() {
                let q = eval_point(self.table, self.displace, f as u32, k as u32, u, v)?;
                out.put(first + i, q);
            }
        }
        // A domain that is one patch has one level (no lookup per triangle); elsewhere the last
        // leaf's bounds and level serve the next triangles whose centres lie strictly inside.
        let whole = self.table.domain_level(f, k);
        let mut leaf: Option<LeafLevels> = None;
        // Lean dicing writes of its grid triangles neither corners (the grid build reads the
        // frame) nor records, only the levels, apart, a leaf's run of quads at a time, and not
        // even those where the domain is one patch (its grid region carries the level).
        let unrecorded = match (self.lean, pat.grid) {
            (true, Some(g)) => {
                if whole.is_none() {
                    self.grid_levels(f, k, pat, g, &mut leaf, out.levels)?;
                }
                2 * (g.quads[0] * g.quads[1]) as usize
            }
            _ => 0,
        };
        for (ti, t) in pat.triangles.iter().enumerate().skip(unrecorded) {
            out.triangles[ti] = t.map(|i| global(map[i as usize]));
            let level = match whole {
                Some(l) => l,
                None => self.centre_level(f, k, pat.tri_centre[ti], &mut leaf)?,
            };
            out.tri_info[ti] = TriInfo {
                face: f as u32,
                k: k as u32,
                level,
                uv: pat.tri_uv[ti],
            };
        }
        Ok(())
    }

    /// The level at triangle centre `[cu, cv]` of domain `(f, k)`: from the last leaf
    /// (`leaf`, [`LeafLevels`]) when the centre lies strictly inside it, else looked up
    /// ([`PatchTable::leaf_levels`]), the leaf kept.
    #[inline(always)]
    fn centre_level(
        &self,
        f: usize,
        k: usize,
        [cu, cv]: [f64; 2],
        leaf: &mut Option<LeafLevels>,
    ) -> Result<u8> {
        if let Some(l) = leaf.and_then(|leaf| leaf.level(cu, cv)) {
            return Ok(l);
        }
        let at = FaceCoord::new(f as u32, k as u32, cu, cv);
        let (l, found) = self.table.leaf_levels(at)?;
        *leaf = found;
        Ok(l)
    }

    /// The levels of the grid triangles of domain `(f, k)` (grid `g` of pattern `pat`) into
    /// `levels`, each [`Self::centre_level`]'s: a quad whose box lies in the closed bounds of
    /// the leaf found for its first triangle, where that leaf has one level, has its centres
    /// strictly inside (at least a third of a quad from its sides, far beyond the rounding of
    /// the bounds), so that level is given at once to it and to the quads after it in its row
    /// that lie in the leaf too. In a Stam leaf each centre's level follows from its
    /// coordinates.
    fn grid_levels(
        &self,
        f: usize,
        k: usize,
        pat: &Pattern,
        g: GridPart,
        leaf: &mut Option<LeafLevels>,
        levels: &mut [u8],
    ) -> Result<()> {
        let [qc, qr] = g.quads.map(|q| q as usize);
        let [nu, nv] = g.n.map(f64::from);
        let [ou, ov] = g.origin.map(|o| o as usize);
        let u = |x: usize| (ou + x) as f64 / nu;
        for y in 0..qr {
            let (vlo, vhi) = ((ov + y) as f64 / nv, (ov + y + 1) as f64 / nv);
            let mut x = 0;
            while x < qc {
                let ti = 2 * (y * qc + x);
                let l = self.centre_level(f, k, pat.tri_centre[ti], leaf)?;
                match *leaf {
                    Some(LeafLevels::Square([u0, v0, u1, v1], _))
                        if v0 <= vlo && vhi <= v1 && u0 <= u(x) && u(x + 1) <= u1 =>
                    {
                        let mut end = x + 1;
                        while end < qc && u(end + 1) <= u1 {
                            end += 1;
                        }
                        levels[ti..2 * (y * qc + end)].fill(l);
                        x = end;
                    }
                    _ => {
                        levels[ti] = l;
                        levels[ti + 1] = self.centre_level(f, k, pat.tri_centre[ti + 1], leaf)?;
                        x += 1;
                    }
                }
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::generate;
    use crate::patch::{PatchOptions, PatchTable};

    /// A displacement that throws diced points out of the numeric range is an error naming
    /// the face and the point, not a mesh of infinite or huge coordinates; the same height
    /// within range dices.
    #[test]
    fn a_point_displaced_out_of_range_is_refused() {
        let mesh = crate::mesh::shapes::rounded_box(2.0);
        let table = PatchTable::new(&mesh, PatchOptions::default()).unwrap();
        let dice_at = |amplitude: f64| {
            let opts = DiceOptions {
                rate: DiceRate::Uniform(3),
                displace: Some(Displacement::Noise {
                    amplitude,
                    frequency: 1.3,
                }),
                ..DiceOptions::default()
            };
            dice(&table, &mesh, &opts)
        };
        let err = dice_at(1e12).unwrap_err().to_string();
        assert!(err.contains("outside the numeric range"), "{err}");
        assert!(err.starts_with("face "), "{err}");
        assert!(dice_at(0.1).is_ok());
    }

    /// Every diced triangle's level is the table's level at its centre (`level_at`), on
    /// meshes with quadtrees (creases, extraordinary vertices, n-gons), at uniform rates on
    /// and off the trees' splits and at edge-length rates (zippers between rates): dicing
    /// reuses a leaf's level for the next centres inside it. The centre is taken from the
    /// `f32` corners, so centres within 1e-6 of a split of the first twelve levels are left
    /// out (the `f64` centre dicing uses may lie on the other side).
    #[test]
    fn triangle_levels_are_the_centres_levels() {
        let meshes = [
            crate::mesh::shapes::rounded_box(2.0),
            crate::mesh::shapes::gear(7),
            crate::mesh::shapes::blob(),
            crate::mesh::shapes::spindle(60),
        ];
        let near_split = |x: f64| {
            let scaled = x * 4096.0;
            (scaled - scaled.round()).abs() < 1e-6 * 4096.0
        };
        let mut checked = 0;
        for mesh in &meshes {
            let table = PatchTable::new(mesh, PatchOptions::default()).unwrap();
            let rates = [
                DiceRate::Uniform(3),
                DiceRate::Uniform(4),
                DiceRate::Uniform(7),
                DiceRate::EdgeLength(0.05),
            ];
            for rate in rates {
                let opts = DiceOptions {
                    rate,
                    ..DiceOptions::default()
                };
                let d = dice(&table, mesh, &opts).unwrap();
                for t in &d.tri_info {
                    let c = [0, 1].map(|a| t.uv.iter().map(|p| f64::from(p[a])).sum::<f64>() / 3.0);
                    if c.iter().any(|&x| near_split(x)) {
                        continue;
                    }
                    let at = FaceCoord::new(t.face, t.k, c[0], c[1]);
                    assert_eq!(Ok(t.level), table.level_at(at), "{at:?}");
                    checked += 1;
                }
            }
        }
        assert!(checked > 20000, "only {checked} triangles checked");
    }

    /// A seamless quad's side rates, read from its edges, are the lengths of the sides listed
    /// point by point, with no seam copy among them; and the shortcut is taken for the quads
    /// away from seams and refused next to them: on a grid (boundary seams) with a hole, a
    /// grid with one infinitely sharp edge inside, a box with infinitely sharp creases and a
    /// star of n-gons, at uniform and edge-length rates.
    #[test]
    fn seamless_quads_rates_are_their_sides() {
        let mut holed = generate::grid(6);
        holed.holes = vec![14];
        // One infinitely sharp edge inside (vertices 7 x 7, row major): two of the quads at
        // each of its ends hold a seam vertex and no seam edge.
        let mut creased = generate::grid(6);
        creased.creases = vec![crate::mesh::EdgeCrease {
            v0: 3 * 7 + 3,
            v1: 3 * 7 + 4,
            sharpness: 10.0,
        }];
        let meshes = [
            holed,
            creased,
            crate::mesh::shapes::rounded_box(10.0),
            generate::star(5, 3),
        ];
        let (mut taken, mut refused) = (0, 0);
        for mesh in &meshes {
            let table = PatchTable::new(mesh, PatchOptions::default()).unwrap();
            for rate in [DiceRate::Uniform(3), DiceRate::EdgeLength(0.07)] {
                let opts = DiceOptions {
                    rate,
                    ..DiceOptions::default()
                };
                prepare(&table, mesh, &opts, None, false, true, |p| {
                    let mut sides = Sides::default();
                    for &(f, k) in &p.domains {
                        let (f, k) = (f as usize, k as usize);
                        p.ctx.sides(f, k, &mut sides);
                        let listed = sides.get();
                        let lens: [u32; 4] = std::array::from_fn(|s| listed[s].len() as u32 - 1);
                        let copies = listed
                            .iter()
                            .flat_map(|side| &side[..side.len() - 1])
                            .filter(|&&sp| p.ctx.foreign_seam(f, k, sp))
                            .count();
                        let seam = listed.iter().flatten().any(|sp| sp.seam);
                        match p.ctx.seamless_quad_rates(f) {
                            Some(rates) => {
                                assert_eq!((rates, copies), (lens, 0), "face {f}");
                                assert!(!seam, "face {f}");
                                taken += 1;
                            }
                            None => {
                                let quad = p.ctx.level.topo.face_size(f) == 4;
                                assert!(!quad || seam, "face {f}: a seamless quad refused");
                                refused += 1;
                            }
                        }
                    }
                    Ok(())
                })
                .unwrap();
            }
        }
        assert!(
            taken > 50 && refused > 50,
            "taken {taken}, refused {refused}"
        );
    }

    /// A row's vertices, taken at once, are each point's [`GridRegion::vertex`]: every row of
    /// every grid region of a diced mesh (frame rows, inner rows, grids that leave a side to a
    /// zipper), from every start column, every length; and every row of synthetic regions
    /// that start inside their domain.
    #[test]
    fn row_vertices_are_the_points_vertices() {
        let mesh = generate::star(5, 3);
        let table = PatchTable::new(&mesh, PatchOptions::default()).unwrap();
        let mut partial = false;
        // Seen from close by one side, rates differ between neighbours: zipped sides.
        let near = DiceRate::Screen(ScreenRate {
            eye: [0.3, 0.2, 1.0],
            pixels_per_radian: 400.0,
            pixels_per_edge: 4.0,
        });
        for rate in [DiceRate::Uniform(1), DiceRate::Uniform(6), near] {
            let opts = DiceOptions {
                rate,
                max_rate: 64,
                displace: None,
            };
            let d = dice(&table, &mesh, &opts).unwrap();
            for g in &d.grids {
                let [qc, qr] = g.part.quads;
                partial |= g.part.quads != g.part.n;
                for y in 0..=qr {
                    for x in 0..=qc {
                        for len in 0..=(qc - x + 1) {
                            let mut got = vec![0; len as usize];
                            g.row_vertices(&d.grid_frames, x, y, &mut got);
                            let want: Vec<u32> = (x..x + len)
                                .map(|xi| g.vertex(&d.grid_frames, xi, y))
                                .collect();
                            assert_eq!(got, want, "{rate:?} region {g:?} row {y} from {x}");
                        }
                    }
                }
            }
        }
        assert!(partial, "no grid region left a side to a zipper");
        // Grids inside their domains (origin past the domain's first row and column), the
        // frame numbered apart from the interior.
        for (origin, quads) in [([1, 1], [4, 3]), ([0, 2], [5, 1]), ([2, 0], [1, 4])] {
            let g = GridRegion {
                first_triangle: 0,
                face: 0,
                k: 0,
                part: GridPart {
                    n: [7, 6],
                    origin,
                    quads,
                },
                level: None,
                frame: 3,
                interior: 1000,
            };
            let frames: Vec<u32> = (0..3 + 2 * (quads[0] + quads[1] + 2))
                .map(|i| 500 + i)
                .collect();
            for y in 0..=quads[1] {
                for x in 0..=quads[0] {
                    let mut got = vec![0; (quads[0] - x + 1) as usize];
                    g.row_vertices(&frames, x, y, &mut got);
                    let want: Vec<u32> =
                        (x..=quads[0]).map(|xi| g.vertex(&frames, xi, y)).collect();
                    assert_eq!(got, want, "{origin:?} {quads:?} row {y} from {x}");
                }
            }
        }
    }
}
