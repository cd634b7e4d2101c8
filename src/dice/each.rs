//! Dicing domain by domain into the caller's storage ([`dice_each`]): the grid core's build
//! ([`crate::grid::GridMesh::dice`]) stores each domain's blocks and loose triangles straight
//! from the worker's buffers, so that the diced points between the shared ones are never held
//! in a mesh-wide array (at the car's rate 64, 104 MB of positions and normal codes written,
//! paged in and read back).

use super::{prepare, DomainCtx, DomainSlices, GridRegion, Scratch, TriInfo, CHUNK};
use crate::dice::DiceOptions;
use crate::error::{Error, Result};
use crate::mesh::ControlMesh;
use crate::oct::oct_encode_all;
use crate::patch::PatchTable;
use rayon::prelude::*;
use std::ops::Range;

/// A domain's place in [`dice_each`]'s layout (the same ids as [`super::dice`]'s mesh).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct DomainPlan {
    /// Base face.
    pub face: u32,
    /// Sub-face (0 for quads).
    pub k: u32,
    /// Its first triangle.
    pub first_triangle: u32,
    /// Its triangles: those of its grid region first ([`Self::grid_triangles`]), then the
    /// loose ones.
    pub triangles: u32,
    /// Its grid region, if any; the region's frame is the domain's own list
    /// ([`DomainView::frame`], offset 0).
    pub region: Option<GridRegion>,
}

impl DomainPlan {
    /// Number of its triangles in its grid region (`2 × quads`).
    pub fn grid_triangles(&self) -> u32 {
        self.region
            .map_or(0, |g| 2 * g.part.quads[0] * g.part.quads[1])
    }

    /// Number of its triangles outside its grid region.
    pub fn loose_triangles(&self) -> u32 {
        self.triangles - self.grid_triangles()
    }
}

/// What [`dice_each`] tells its planner before a point is evaluated.
#[derive(Clone, Debug)]
pub struct DiceLayout {
    /// Every domain, in order.
    pub domains: Vec<DomainPlan>,
    /// The domains of each parallel job, in order: a job's domains are visited in order, one
    /// after the other, with the job's storage.
    pub jobs: Vec<Range<usize>>,
    /// Number of triangles in all.
    pub triangles: usize,
}

/// One diced domain, in its worker's buffers (valid during the `visit` call).
pub struct DomainView<'a> {
    /// Where it lies in the layout.
    pub plan: &'a DomainPlan,
    /// Its grid region's frame: the vertices of its first row, last row, first column and
    /// last column ([`GridRegion::frame`]); empty without a region.
    pub frame: &'a [u32],
    /// Index of its first own point.
    base: u32,
    /// Its own points (seam copies, then the interior) and their normals' octahedral codes
    /// (zero when dicing finds no normals).
    positions: &'a [[f32; 3]],
    codes: &'a [u32],
    /// The shared points and their codes.
    shared_positions: &'a [[f32; 3]],
    shared_codes: &'a [u32],
    /// Per triangle: the levels of grid triangles (where the region has no one level).
    levels: &'a [u8],
    /// Per triangle: the corners and records of loose triangles.
    triangles: &'a [[u32; 3]],
    tri_info: &'a [TriInfo],
}

impl DomainView<'_> {
    /// Position and normal code (of [`super::dice`]'s normal, [`crate::oct::oct_encode`]; zero
    /// when [`dice_each`] finds no normals) of vertex `v`: a shared point, or one of the
    /// domain's own.
    #[inline(always)]
    pub fn point(&self, v: u32) -> ([f32; 3], u32) {
        match v.checked_sub(self.base) {
            Some(i) => (self.positions[i as usize], self.codes[i as usize]),
            None => (
                self.shared_positions[v as usize],
                self.shared_codes[v as usize],
            ),
        }
    }

    /// The level of grid triangle `t` (an id in the domain's grid region, whose region has no
    /// one [`GridRegion::level`]).
    #[inline(always)]
    pub fn level(&self, t: u32) -> u8 {
        self.levels[(t - self.plan.first_triangle) as usize]
    }

    /// The loose triangles, in id order: id, corners (vertices for [`Self::point`]), record.
    pub fn loose(&self) -> impl Iterator<Item = (u32, [u32; 3], &TriInfo)> + '_ {
        let first = self.plan.grid_triangles() as usize;
        let n = self.plan.triangles as usize;
        (first..n).map(move |i| {
            (
                self.plan.first_triangle + i as u32,
                self.triangles[i],
                &self.tri_info[i],
            )
        })
    }
}

/// A worker's buffers for one domain at a time, grown, never shrunk or cleared (every
/// domain writes all that its view reads).
#[derive(Default)]
struct Buffers {
    positions: Vec<[f32; 3]>,
    normals: Vec<[f32; 3]>,
    codes: Vec<u32>,
    triangles: Vec<[u32; 3]>,
    tri_info: Vec<TriInfo>,
    levels: Vec<u8>,
    frame: Vec<u32>,
}

/// The first `n` elements of `v`, grown to hold them.
fn room<T: Clone + Default>(v: &mut Vec<T>, n: usize) -> &mut [T] {
    if v.len() < n {
        v.resize(n, T::default());
    }
    &mut v[..n]
}

/// Dices the limit surface of `mesh` (whose patch table is `table`) as [`super::dice`]
/// does, the same points and triangles bit for bit, but hands the domains to the caller
/// instead of storing a mesh: `plan` is given the layout (every domain's triangles and grid
/// region, the parallel jobs) and returns one storage per job; then, in parallel, each job's
/// domains are diced one after the other and given to `visit` with that job's storage. Of
/// grid triangles the views hold no corners or records (the region implies them), only
/// their levels where the domain is not one patch. Without `normals`, the points' shading
/// normals are neither found (where the positions do not need them: an undisplaced exact
/// surface) nor encoded, and every normal code is zero; the positions are the same bits.
pub fn dice_each<C: Send>(
    table: &PatchTable,
    mesh: &ControlMesh,
    opts: &DiceOptions,
    normals: bool,
    plan: impl FnOnce(&DiceLayout) -> Result<Vec<C>>,
    visit: impl Fn(&mut C, &DomainView) -> Result<()> + Sync,
) -> Result<()> {
    dice_each_planned(table, mesh, opts, None, normals, plan, visit)
}

/// [`dice_each`] with the rates of `planned` where given ([`super::plan`] of the same
/// table, mesh and options), instead of measuring the edges again.
pub(crate) fn dice_each_planned<C: Send>(
    table: &PatchTable,
    mesh: &ControlMesh,
    opts: &DiceOptions,
    planned: Option<super::DicePlan>,
    normals: bool,
    plan: impl FnOnce(&DiceLayout) -> Result<Vec<C>>,
    visit: impl Fn(&mut C, &DomainView) -> Result<()> + Sync,
) -> Result<()> {
    prepare(table, mesh, opts, planned, true, normals, |p| {
        let (_, triangles) = p.totals()?;
        let n = p.num_shared();
        let mut shared_positions = vec![[0.0; 3]; n];
        // Zero without normals (never written: the zeroed pages read cost no clearing).
        let mut shared_codes = vec![0u32; n];
        let codes_out: &mut [u32] = if normals { &mut shared_codes } else { &mut [] };
        p.eval_shared(&mut shared_positions, &mut [], &mut [], codes_out)?;
        crate::stages::mark("dice: shared points");
        let firsts = p.firsts();
        // The regions (each looks its domain's level up in the table) in parallel; a region's
        // frame is the domain's own list ([`DomainView::frame`], offset 0).
        let domains: Vec<DomainPlan> = (0..firsts.len())
            .into_par_iter()
            .with_min_len(1024)
            .map(|i| {
                let [base, first_triangle, _] = firsts[i];
                let (face, k) = p.domains[i];
                DomainPlan {
                    face,
                    k,
                    first_triangle,
                    triangles: p.sizes[i].triangles as u32,
                    region: p.region(i, [base, first_triangle, 0]),
                }
            })
            .collect();
        let count = domains.len();
        let layout = DiceLayout {
            domains,
            jobs: (0..count)
                .step_by(CHUNK)
                .map(|s| s..(s + CHUNK).min(count))
                .collect(),
            triangles,
        };
        crate::stages::mark("dice: domain plans");
        let stores = plan(&layout)?;
        assert_eq!(stores.len(), layout.jobs.len(), "one store per job");
        let ctx = DomainCtx {
            shared_positions: &shared_positions,
            ..p.ctx
        };
        let (layout, visit) = (&layout, &visit);
        let (shared_positions, shared_codes) = (&shared_positions, &shared_codes);
        let done = stores
            .into_par_iter()
            .zip(layout.jobs.clone())
            .try_for_each_init(
                || (Scratch::default(), Buffers::default()),
                |(scratch, b), (mut store, job)| {
                    for i in job {
                        let (z, d) = (&p.sizes[i], &layout.domains[i]);
                        let base = firsts[i][0];
                        let slices = DomainSlices {
                            base,
                            positions: room(&mut b.positions, z.points),
                            normals: room(&mut b.normals, z.points),
                            params: &mut [],
                            triangles: room(&mut b.triangles, z.triangles),
                            tri_info: room(&mut b.tri_info, z.triangles),
                            levels: room(&mut b.levels, z.triangles),
                            frame: room(&mut b.frame, z.frame),
                        };
                        ctx.domain(d.face as usize, d.k as usize, scratch, slices)?;
                        // Without normals the buffer's codes stay zero (never encoded).
                        let codes = room(&mut b.codes, z.points);
                        if normals {
                            oct_encode_all(&b.normals[..z.points], codes);
                        }
                        let view = DomainView {
                            plan: d,
                            frame: &b.frame[..z.frame],
                            base,
                            positions: &b.positions[..z.points],
                            codes: &b.codes[..z.points],
                            shared_positions,
                            shared_codes,
                            levels: &b.levels[..z.triangles],
                            triangles: &b.triangles[..z.triangles],
                            tri_info: &b.tri_info[..z.triangles],
                        };
                        visit(&mut store, &view)?;
                    }
                    Ok::<(), Error>(())
                },
            );
        crate::stages::mark("dice: domains and their stores");
        done
    })
}
