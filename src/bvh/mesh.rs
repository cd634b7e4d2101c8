//! One diced mesh in an obvhs compressed wide BVH (CWBVH, 8 children per 80-byte node),
//! traversed with a conservative box test and the watertight triangle test.
//!
//! obvhs quantises child boxes to 8 bits per plane, rounding in `f32`; its own traversal also
//! clamps `t` to `1e-4`. Neither is acceptable for a leak-free guarantee, so after building,
//! every quantised child box is checked against the exact bounds of what lies below it, as the
//! traversal decodes it (`p + 2^e · q`, rounded as the traversal rounds), and widened by
//! whole quantisation steps where rounding left a vertex outside. Traversal is then this
//! module's own, over obvhs's node layout and child ordering.

use super::ray::{Hit, Ray};
use super::triangle::{intersect_prepared, PreparedRay};
use crate::dice::DicedMesh;
// `UVec2` is named inside obvhs's `traverse!` macro.
use glam::{UVec2, Vec3A};
use obvhs::cwbvh::builder::build_cwbvh;
use obvhs::cwbvh::node::{extract_byte64, CwBvhNode};
use obvhs::cwbvh::CwBvh;
use obvhs::{aabb::Aabb, Boundable, BvhBuildParams};
use rayon::prelude::*;

/// A diced mesh with its BVH.
#[derive(Clone, Debug)]
pub struct MeshBvh {
    /// The diced mesh (attributes of hits).
    pub diced: DicedMesh,
    /// obvhs's compressed wide BVH (root = node 0) with boxes made conservative.
    pub cwbvh: CwBvh,
    /// Triangle corners in BVH leaf order.
    pub tri_verts: Vec<[[f32; 3]; 3]>,
    /// BVH leaf order → [`DicedMesh::triangles`] index.
    pub tri_index: Vec<u32>,
    /// Exact `f32` bounds of every node's children, for the CPU traversal (the quantised
    /// boxes in `cwbvh` are kept conservative too, for compact uploads such as the GPU's).
    pub boxes: Vec<WideBoxes>,
    /// Number of child planes that had to be widened after quantisation.
    pub widened_planes: usize,
    /// Number of node levels (the traversal stack needs at most one entry per level).
    pub depth: usize,
}

/// The exact bounds of a node's eight children, structure of arrays (empty slots are empty
/// boxes, `lo = +∞`, `hi = −∞`).
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C, align(32))]
pub struct WideBoxes {
    /// Lower corners, per axis, per child.
    pub lo: [[f32; 8]; 3],
    /// Upper corners, per axis, per child.
    pub hi: [[f32; 8]; 3],
}

impl Default for WideBoxes {
    fn default() -> Self {
        WideBoxes {
            lo: [[f32::INFINITY; 8]; 3],
            hi: [[f32::NEG_INFINITY; 8]; 3],
        }
    }
}

struct TriBox([[f32; 3]; 3]);

impl Boundable for TriBox {
    fn aabb(&self) -> Aabb {
        let [a, b, c] = self.0;
        let lo = Vec3A::new(
            a[0].min(b[0]).min(c[0]),
            a[1].min(b[1]).min(c[1]),
            a[2].min(b[2]).min(c[2]),
        );
        let hi = Vec3A::new(
            a[0].max(b[0]).max(c[0]),
            a[1].max(b[1]).max(c[1]),
            a[2].max(b[2]).max(c[2]),
        );
        Aabb::new(lo, hi)
    }
}

/// Decoded bounds of child `c` of `node`, exactly as the traversal computes them.
#[inline(always)]
pub(crate) fn child_box(node: &CwBvhNode, c: usize) -> ([f32; 3], [f32; 3]) {
    let e = node.compute_extent();
    let p = node.p;
    (
        [
            p.x + e.x * node.child_min_x[c] as f32,
            p.y + e.y * node.child_min_y[c] as f32,
            p.z + e.z * node.child_min_z[c] as f32,
        ],
        [
            p.x + e.x * node.child_max_x[c] as f32,
            p.y + e.y * node.child_max_y[c] as f32,
            p.z + e.z * node.child_max_z[c] as f32,
        ],
    )
}

type Bounds = ([f32; 3], [f32; 3]);

fn union(a: Bounds, b: Bounds) -> Bounds {
    (
        std::array::from_fn(|i| a.0[i].min(b.0[i])),
        std::array::from_fn(|i| a.1[i].max(b.1[i])),
    )
}

const EMPTY: Bounds = ([f32::INFINITY; 3], [f32::NEG_INFINITY; 3]);

impl MeshBvh {
    /// Builds the BVH of `diced` with obvhs's medium preset (no spatial splits).
    pub fn build(diced: DicedMesh) -> MeshBvh {
        MeshBvh::build_with(diced, BvhBuildParams::medium_build())
    }

    /// Builds the BVH of `diced` with obvhs build parameters `params` (spatial pre-splits are
    /// turned off: a leaf's box must contain its whole triangles).
    pub fn build_with(diced: DicedMesh, params: BvhBuildParams) -> MeshBvh {
        let prims: Vec<TriBox> = diced
            .triangles
            .iter()
            .map(|t| TriBox(t.map(|i| diced.positions[i as usize])))
            .collect();
        if prims.is_empty() {
            return MeshBvh {
                diced,
                cwbvh: CwBvh::default(),
                tri_verts: Vec::new(),
                tri_index: Vec::new(),
                boxes: Vec::new(),
                widened_planes: 0,
                depth: 0,
            };
        }
        let mut params = params;
        params.pre_split = false;
        let mut cwbvh =
            build_deep(|| build_cwbvh(&prims, params, &mut std::time::Duration::default()));
        let tri_index = cwbvh.primitive_indices.clone();
        let tri_verts: Vec<[[f32; 3]; 3]> =
            tri_index.iter().map(|&i| prims[i as usize].0).collect();
        let (widened_planes, boxes, depth) = make_conservative(&mut cwbvh, &tri_verts);
        MeshBvh {
            diced,
            cwbvh,
            tri_verts,
            tri_index,
            boxes,
            widened_planes,
            depth,
        }
    }

    /// Memory of the BVH and the triangle data, in bytes (the diced mesh included).
    pub fn bytes(&self) -> usize {
        self.cwbvh.nodes.len() * std::mem::size_of::<CwBvhNode>()
            + self.boxes.len() * std::mem::size_of::<WideBoxes>()
            + self.cwbvh.primitive_indices.len() * 4
            + self.tri_verts.len() * 36
            + self.tri_index.len() * 4
            + self.diced.bytes()
    }

    /// Bounds of the mesh.
    pub fn bounds(&self) -> [[f32; 3]; 2] {
        self.diced.bounds()
    }

    /// Traverses with `ray`, calling `leaf(leaf_index, tmax)` for each triangle whose leaf
    /// box is met; `leaf` returns the new `tmax` and whether to stop.
    #[inline(always)]
    fn traverse(&self, r: &PreparedRay, leaf: impl FnMut(usize, f32) -> (f32, bool)) {
        let pf = Prefetch {
            boxes: &self.boxes,
            nodes: &self.cwbvh.nodes,
            tris: &self.tri_verts,
        };
        walk(&self.cwbvh, self.depth, pf, r, leaf);
    }

    /// Closest hit of `ray` in `[tmin, tmax]`.
    pub fn intersect(&self, ray: &Ray) -> Option<Hit> {
        let r = PreparedRay::new(ray)?;
        let mut best: Option<(usize, f32, f32, f32)> = None;
        self.traverse(&r, |li, tmax| {
            let [a, b, c] = self.tri_verts[li];
            if let Some((t, b1, b2)) = intersect_prepared(&r, a, b, c, tmax) {
                // Equal t: the lowest leaf index wins, so the answer does not depend on the
                // traversal order (the GPU backend reproduces it).
                if best.is_none_or(|x| t < x.1 || (t == x.1 && li < x.0)) {
                    best = Some((li, t, b1, b2));
                    return (t, false);
                }
            }
            (tmax, false)
        });
        best.map(|(li, t, b1, b2)| self.hit(li, t, b1, b2))
    }

    /// True if anything is hit in `[tmin, tmax]`.
    pub fn occluded(&self, ray: &Ray) -> bool {
        let Some(r) = PreparedRay::new(ray) else {
            return false;
        };
        let mut hit = false;
        self.traverse(&r, |li, tmax| {
            let [a, b, c] = self.tri_verts[li];
            if intersect_prepared(&r, a, b, c, tmax).is_some() {
                hit = true;
                return (tmax, true);
            }
            (tmax, false)
        });
        hit
    }

    /// Closest hits of many rays, in parallel.
    pub fn intersect_batch(&self, rays: &[Ray]) -> Vec<Option<Hit>> {
        rays.par_iter()
            .with_min_len(256)
            .map(|r| self.intersect(r))
            .collect()
    }

    /// The hit record of leaf triangle `li` at `t` with barycentrics `b1, b2`.
    pub fn hit(&self, li: usize, t: f32, b1: f32, b2: f32) -> Hit {
        let tri = self.tri_index[li];
        let info = &self.diced.tri_info[tri as usize];
        let idx = self.diced.triangles[tri as usize];
        Corners {
            p: self.tri_verts[li],
            n: Some(idx.map(|i| self.diced.normals[i as usize])),
            uv: info.uv,
        }
        .hit(t, b1, b2, tri, info.face, info.k, info.level, li as u32)
    }
}

/// What a hit record interpolates: a triangle's corners, their unit normals and parameters.
pub(crate) struct Corners {
    /// Positions.
    pub p: [[f32; 3]; 3],
    /// Unit shading normals (`None` where the structure stores none: the shading normal is
    /// then the geometric one).
    pub n: Option<[[f32; 3]; 3]>,
    /// `(u, v)` in the face's parameterisation.
    pub uv: [[f32; 2]; 3],
}

impl Corners {
    /// The hit at `t` with barycentrics `b1, b2`: parameters and shading normal interpolated,
    /// geometric normal from the edges (the shading normal falls back to it where the
    /// interpolated normals cancel, and is it without corner normals).
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn hit(
        &self,
        t: f32,
        b1: f32,
        b2: f32,
        triangle: u32,
        face: u32,
        k: u32,
        level: u8,
        leaf: u32,
    ) -> Hit {
        let uv = &self.uv;
        let [a, b, c] = self.p;
        let b0 = 1.0 - b1 - b2;
        let u = b0 * uv[0][0] + b1 * uv[1][0] + b2 * uv[2][0];
        let v = b0 * uv[0][1] + b1 * uv[1][1] + b2 * uv[2][1];
        let e1 = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
        let e2 = [c[0] - a[0], c[1] - a[1], c[2] - a[2]];
        let cross = [
            e1[1] * e2[2] - e1[2] * e2[1],
            e1[2] * e2[0] - e1[0] * e2[2],
            e1[0] * e2[1] - e1[1] * e2[0],
        ];
        let (ng, ns) = match &self.n {
            Some(n) => normalize2(
                cross,
                std::array::from_fn(|i| b0 * n[0][i] + b1 * n[1][i] + b2 * n[2][i]),
            ),
            None => {
                let ng = normalize(cross);
                (ng, ng)
            }
        };
        Hit {
            t,
            triangle,
            face,
            k,
            u,
            v,
            b1,
            b2,
            ng,
            ns: if ns.iter().all(|x| x.is_finite()) {
                ns
            } else {
                ng
            },
            level,
            leaf,
        }
    }
}

impl super::ray::Intersect for MeshBvh {
    fn intersect(&self, ray: &Ray) -> Option<Hit> {
        MeshBvh::intersect(self, ray)
    }
    fn occluded(&self, ray: &Ray) -> bool {
        MeshBvh::occluded(self, ray)
    }
}

/// Runs an obvhs build in a thread pool of its own whose threads have large stacks: obvhs's
/// tree conversion recurses once per level of the binary hierarchy, which degenerate input
/// (many coincident triangles, e.g. a thin shape far from the origin) makes thousands of
/// levels deep. A pool of its own, rather than one spawned thread, also keeps builds that are
/// started from rayon workers (several meshes built in parallel) from waiting on each other.
pub(crate) fn build_deep<T: Send>(f: impl FnOnce() -> T + Send) -> T {
    // Started from a pinned worker, its threads get the process's CPUs, not that worker's one.
    let inherit = crate::affinity::spawn_mask();
    match rayon::ThreadPoolBuilder::new()
        .num_threads(rayon::current_num_threads())
        .start_handler(move |_| crate::affinity::apply_spawn_mask(&inherit))
        .stack_size(1 << 30)
        .thread_name(|i| format!("limitray-bvh-{i}"))
        .build()
    {
        Ok(pool) => pool.install(f),
        Err(_) => f(),
    }
}

/// [`normalize`] of `a` and `b`, bit for bit: where both squared lengths are normal `f32`
/// (always, but for degenerate triangles), one vector square root and three divisions for
/// the two (SSE2; IEEE per lane), else each through [`normalize`].
#[inline]
pub fn normalize2(a: [f32; 3], b: [f32; 3]) -> ([f32; 3], [f32; 3]) {
    #[cfg(target_arch = "x86_64")]
    // SAFETY: SSE2 is part of the x86_64 baseline.
    unsafe {
        use std::arch::x86_64::*;
        let axis = |i: usize| _mm_set_ps(0.0, 0.0, b[i], a[i]);
        let (x, y, z) = (axis(0), axis(1), axis(2));
        let l2 = _mm_add_ps(
            _mm_add_ps(_mm_mul_ps(x, x), _mm_mul_ps(y, y)),
            _mm_mul_ps(z, z),
        );
        let mut l = [0f32; 4];
        _mm_storeu_ps(l.as_mut_ptr(), l2);
        if l[..2]
            .iter()
            .all(|l2| l2.is_finite() && *l2 >= f32::MIN_POSITIVE)
        {
            let l = _mm_sqrt_ps(l2);
            let mut out = [[0f32; 4]; 3];
            _mm_storeu_ps(out[0].as_mut_ptr(), _mm_div_ps(x, l));
            _mm_storeu_ps(out[1].as_mut_ptr(), _mm_div_ps(y, l));
            _mm_storeu_ps(out[2].as_mut_ptr(), _mm_div_ps(z, l));
            let lane = |k: usize| [out[0][k], out[1][k], out[2][k]];
            return (lane(0), lane(1));
        }
    }
    (normalize(a), normalize(b))
}

/// Normalises `v` (zero stays zero). Where the squared length is not a normal `f32`
/// (cross products of edges near [`crate::numeric::MAX_COORD`] reach `2^67`, whose square
/// overflows; tiny ones underflow), the vector is first divided by its largest component.
pub fn normalize(v: [f32; 3]) -> [f32; 3] {
    let l2 = v[0] * v[0] + v[1] * v[1] + v[2] * v[2];
    if l2.is_finite() && l2 >= f32::MIN_POSITIVE {
        let l = l2.sqrt();
        return [v[0] / l, v[1] / l, v[2] / l];
    }
    let m = v[0].abs().max(v[1].abs()).max(v[2].abs());
    if !(m > 0.0 && m.is_finite()) {
        return v;
    }
    let w = v.map(|x| x / m);
    let l = (w[0] * w[0] + w[1] * w[1] + w[2] * w[2]).sqrt();
    [w[0] / l, w[1] / l, w[2] / l]
}

/// The obvhs hit mask of `node`'s children whose exact boxes `b` the ray `r` meets
/// (conservatively) within `tmax`.
#[inline(always)]
pub fn wide_hitmask(
    node: &CwBvhNode,
    b: &WideBoxes,
    r: &PreparedRay,
    oct_inv4: u32,
    tmax: f32,
    prefetch: Prefetch,
) -> u32 {
    #[cfg(target_arch = "x86_64")]
    {
        // SAFETY: SSE2 is part of the x86_64 baseline.
        unsafe { wide_hitmask_sse(node, b, r, oct_inv4, tmax, prefetch) }
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        let _ = prefetch;
        wide_hitmask_scalar(node, b, r, oct_inv4, tmax)
    }
}

/// What the node test may prefetch for the children it finds hit: their boxes and nodes, and
/// the triangles of hit leaves (traversal is bound by memory latency on large meshes).
#[derive(Clone, Copy)]
pub struct Prefetch<'a> {
    /// Exact child boxes of all nodes.
    pub boxes: &'a [WideBoxes],
    /// All nodes.
    pub nodes: &'a [CwBvhNode],
    /// Leaf-ordered triangles (empty for the top level).
    pub tris: &'a [[[f32; 3]; 3]],
}

impl<'a> Prefetch<'a> {
    /// Prefetches nothing for leaves.
    pub fn nodes_only(boxes: &'a [WideBoxes], nodes: &'a [CwBvhNode]) -> Prefetch<'a> {
        Prefetch {
            boxes,
            nodes,
            tris: &[],
        }
    }
}

/// Scalar reference of [`wide_hitmask`].
#[inline(always)]
pub fn wide_hitmask_scalar(
    node: &CwBvhNode,
    b: &WideBoxes,
    r: &PreparedRay,
    oct_inv4: u32,
    tmax: f32,
) -> u32 {
    let (child_bits8, bit_index8) = node.get_child_and_index_bits(oct_inv4);
    let mut mask = 0u32;
    for c in 0..8 {
        let lo = [b.lo[0][c], b.lo[1][c], b.lo[2][c]];
        let hi = [b.hi[0][c], b.hi[1][c], b.hi[2][c]];
        if node.child_meta[c] != 0 && r.hits_box(lo, hi, tmax) {
            mask |= extract_byte64(child_bits8, c) << extract_byte64(bit_index8, c);
        }
    }
    mask
}

/// Four children at a time with SSE; bit for bit the scalar test (`max`/`min` keep the
/// bound when the slab distance is NaN, as `f32::max` does).
#[cfg(target_arch = "x86_64")]
#[inline(always)]
unsafe fn wide_hitmask_sse(
    node: &CwBvhNode,
    b: &WideBoxes,
    r: &PreparedRay,
    oct_inv4: u32,
    tmax: f32,
    pf: Prefetch,
) -> u32 {
    use std::arch::x86_64::*;
    let (child_bits8, bit_index8) = node.get_child_and_index_bits(oct_inv4);
    let scale = _mm_set1_ps(1.0 + 2.0 * super::triangle::GAMMA3);
    let mut mask = 0u32;
    for h in 0..2 {
        let mut near = _mm_set1_ps(r.tmin);
        let mut far = _mm_set1_ps(tmax);
        for a in 0..3 {
            let lo = _mm_loadu_ps(b.lo[a].as_ptr().add(h * 4));
            let hi = _mm_loadu_ps(b.hi[a].as_ptr().add(h * 4));
            let (n, f) = if r.inv[a].is_sign_negative() {
                (hi, lo)
            } else {
                (lo, hi)
            };
            let o = _mm_set1_ps(r.o[a]);
            let inv = _mm_set1_ps(r.inv[a]);
            let tn = _mm_mul_ps(_mm_sub_ps(n, o), inv);
            let tf = _mm_mul_ps(_mm_mul_ps(_mm_sub_ps(f, o), inv), scale);
            near = _mm_max_ps(tn, near);
            far = _mm_min_ps(tf, far);
        }
        let mut hit = _mm_movemask_ps(_mm_cmple_ps(near, far)) as u32;
        while hit != 0 {
            let j = hit.trailing_zeros() as usize;
            hit &= hit - 1;
            let c = h * 4 + j;
            mask |= extract_byte64(child_bits8, c) << extract_byte64(bit_index8, c);
            if node.child_meta[c] == 0 {
                continue;
            }
            if node.is_leaf(c) {
                let (start, _) = node.child_primitives(c);
                if let Some(t) = pf.tris.get(start as usize) {
                    let p = t.as_ptr() as *const i8;
                    _mm_prefetch::<_MM_HINT_T0>(p);
                    _mm_prefetch::<_MM_HINT_T0>(p.add(64));
                }
            } else {
                let i = node.child_node_index(c) as usize;
                if let (Some(bx), Some(nd)) = (pf.boxes.get(i), pf.nodes.get(i)) {
                    let p = bx as *const WideBoxes as *const i8;
                    _mm_prefetch::<_MM_HINT_T0>(p);
                    _mm_prefetch::<_MM_HINT_T0>(p.add(64));
                    _mm_prefetch::<_MM_HINT_T0>(p.add(128));
                    _mm_prefetch::<_MM_HINT_T0>(nd as *const CwBvhNode as *const i8);
                }
            }
        }
    }
    mask
}

/// Widens quantised child boxes until, as decoded, they contain everything below them.
/// Returns the number of planes moved, the exact bounds of every node's children and the
/// number of node levels.
pub(crate) fn make_conservative(
    bvh: &mut CwBvh,
    tri_verts: &[[[f32; 3]; 3]],
) -> (usize, Vec<WideBoxes>, usize) {
    let n = bvh.nodes.len();
    let mut content = vec![EMPTY; n];
    let mut height = vec![1usize; n];
    let mut boxes = vec![WideBoxes::default(); n];
    let mut widened = 0;
    for i in (0..n).rev() {
        let mut node = bvh.nodes[i];
        let mut wants = [EMPTY; 8];
        for c in 0..8 {
            if node.child_meta[c] == 0 {
                continue;
            }
            wants[c] = if node.is_leaf(c) {
                let (start, count) = node.child_primitives(c);
                let mut b = EMPTY;
                for li in start..start + count {
                    for v in tri_verts[li as usize] {
                        b = union(b, (v, v));
                    }
                }
                b
            } else {
                let ci = node.child_node_index(c) as usize;
                assert!(ci > i, "CWBVH children follow their parents");
                height[i] = height[i].max(height[ci] + 1);
                content[ci]
            };
        }
        loop {
            let mut ok = true;
            for c in 0..8 {
                if node.child_meta[c] != 0 {
                    match widen(&mut node, c, wants[c]) {
                        Some(m) => widened += m,
                        None => ok = false,
                    }
                }
            }
            if ok {
                break;
            }
            // The node's frame does not reach: double its quantisation step and requantise.
            for a in 0..3 {
                node.e[a] += 1;
            }
            for q in [
                &mut node.child_min_x,
                &mut node.child_min_y,
                &mut node.child_min_z,
            ] {
                q.iter_mut().for_each(|x| *x /= 2);
            }
            for q in [
                &mut node.child_max_x,
                &mut node.child_max_y,
                &mut node.child_max_z,
            ] {
                q.iter_mut().for_each(|x| *x = x.div_ceil(2));
            }
        }
        bvh.nodes[i] = node;
        content[i] = wants.iter().fold(EMPTY, |a, &b| union(a, b));
        for c in 0..8 {
            for a in 0..3 {
                boxes[i].lo[a][c] = wants[c].0[a];
                boxes[i].hi[a][c] = wants[c].1[a];
            }
        }
    }
    (widened, boxes, height.first().copied().unwrap_or(0))
}

/// Traversal state with the fields obvhs's `traverse!` macro uses, over any stack.
struct Walk<S> {
    stack: S,
    current_group: UVec2,
    primitive_group: UVec2,
    oct_inv4: u32,
    primitive_id: u32,
    hitmask: u32,
}

/// Entries of the fixed traversal stack; deeper hierarchies use a growable one. (obvhs's own
/// 32-entry stack overwrites its top entry when full, which would skip subtrees.)
const STACK: usize = 64;

/// Walks `bvh` (of `depth` levels) with the conservative node test on the exact boxes in
/// `pf`, calling `leaf(leaf_index, tmax)` for the primitives of every leaf met; `leaf`
/// returns the new `tmax` and whether to stop.
#[inline(always)]
pub(crate) fn walk(
    bvh: &CwBvh,
    depth: usize,
    pf: Prefetch,
    r: &PreparedRay,
    mut leaf: impl FnMut(usize, f32) -> (f32, bool),
) {
    if bvh.nodes.is_empty() {
        return;
    }
    if depth < STACK {
        walk_with(
            bvh,
            obvhs::faststack::StackStack::<UVec2, STACK>::default(),
            pf,
            r,
            &mut leaf,
        );
    } else {
        walk_with(bvh, Vec::<UVec2>::with_capacity(depth), pf, r, &mut leaf);
    }
}

#[inline(always)]
fn walk_with<S: obvhs::faststack::FastStack<UVec2>>(
    bvh: &CwBvh,
    stack: S,
    pf: Prefetch,
    r: &PreparedRay,
    leaf: &mut impl FnMut(usize, f32) -> (f32, bool),
) {
    // The octant code of obvhs (`ray_get_octant_inv4`): child order front to back.
    let d = r.d;
    let oct_inv4 = (if d[0] < 0.0 { 0 } else { 0x0404_0404 })
        | (if d[1] < 0.0 { 0 } else { 0x0202_0202 })
        | (if d[2] < 0.0 { 0 } else { 0x0101_0101 });
    let mut state = Walk {
        stack,
        current_group: UVec2::new(0, 0x8000_0000),
        primitive_group: UVec2::ZERO,
        oct_inv4,
        primitive_id: 0,
        hitmask: 0,
    };
    let mut tmax = r.tmax;
    let mut node: &CwBvhNode;
    obvhs::traverse!(
        bvh,
        node,
        state,
        wide_hitmask(
            node,
            &pf.boxes[node_index(bvh, node)],
            r,
            state.oct_inv4,
            tmax,
            pf
        ),
        {
            let (t, s) = leaf(state.primitive_id as usize, tmax);
            tmax = t;
            if s {
                // `break` alone would only leave the macro's loop over this leaf's
                // primitives: empty the traversal state so that it ends here.
                state.stack.clear();
                state.current_group = UVec2::ZERO;
                state.primitive_group = UVec2::ZERO;
                break;
            }
        }
    );
    let _ = state.hitmask;
}

/// Index of `node` in `bvh.nodes` (the traversal macro hands out references).
#[inline(always)]
pub fn node_index(bvh: &CwBvh, node: &CwBvhNode) -> usize {
    // SAFETY: `node` points into `bvh.nodes` (the traversal only indexes that slice).
    unsafe { (node as *const CwBvhNode).offset_from(bvh.nodes.as_ptr()) as usize }
}

/// Moves the planes of child `c` outwards until its decoded box contains `want`; `None` if a
/// plane reaches the end of the node's frame first.
fn widen(node: &mut CwBvhNode, c: usize, want: Bounds) -> Option<usize> {
    let mut moved = 0;
    loop {
        let (lo, hi) = child_box(node, c);
        let mut changed = false;
        let planes: [(&mut [u8; 8], bool, bool); 6] = [
            (&mut node.child_min_x, lo[0] > want.0[0], false),
            (&mut node.child_max_x, hi[0] < want.1[0], true),
            (&mut node.child_min_y, lo[1] > want.0[1], false),
            (&mut node.child_max_y, hi[1] < want.1[1], true),
            (&mut node.child_min_z, lo[2] > want.0[2], false),
            (&mut node.child_max_z, hi[2] < want.1[2], true),
        ];
        for (q, outside, upper) in planes {
            if outside {
                if upper && q[c] < 255 {
                    q[c] += 1;
                } else if !upper && q[c] > 0 {
                    q[c] -= 1;
                } else {
                    return None;
                }
                changed = true;
            }
        }
        if !changed {
            return Some(moved);
        }
        moved += 1;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bvh::Ray;

    /// [`normalize2`] gives [`normalize`]'s bits for both vectors: random vectors of
    /// magnitudes 2^-80 to 2^80 (squared lengths that underflow and overflow, so both paths
    /// are taken, alone and together), zero vectors and NaNs.
    #[test]
    fn normalize2_is_normalize_bit_for_bit() {
        let mut rng = crate::harness::rng::SplitMix64(12);
        let vector = |rng: &mut crate::harness::rng::SplitMix64| -> [f32; 3] {
            let scale = 2f32.powi((rng.next_f64() * 160.0) as i32 - 80);
            match rng.next_u64() % 50 {
                0 => [0.0; 3],
                1 => [f32::NAN, 1.0, 0.0],
                _ => std::array::from_fn(|_| (rng.next_f64() * 2.0 - 1.0) as f32 * scale),
            }
        };
        let bits = |v: [f32; 3]| v.map(f32::to_bits);
        for _ in 0..200_000 {
            let (a, b) = (vector(&mut rng), vector(&mut rng));
            let (na, nb) = normalize2(a, b);
            assert_eq!(bits(na), bits(normalize(a)), "{a:?}");
            assert_eq!(bits(nb), bits(normalize(b)), "{b:?}");
        }
    }

    /// The SSE node test equals the scalar one bit for bit on random boxes and rays,
    /// axis-parallel rays included; both contain every hit of the quantised test.
    #[test]
    fn sse_node_test_matches_scalar() {
        let mut rng = crate::harness::rng::SplitMix64(5);
        let mut f = |s: f64| ((rng.next_f64() - 0.5) * s) as f32;
        for i in 0..20000 {
            let mut node = CwBvhNode::default();
            let mut b = WideBoxes::default();
            for c in 0..8 {
                node.child_meta[c] = if c % 3 == 0 { 0b0010_0000 | c as u8 } else { 0 };
                for a in 0..3 {
                    let (x, y) = (f(4.0), f(4.0));
                    b.lo[a][c] = x.min(y);
                    b.hi[a][c] = x.max(y);
                }
            }
            let mut d = [f(2.0), f(2.0), f(2.0)];
            if i % 4 == 0 {
                d[i % 3] = 0.0;
            }
            if d == [0.0; 3] {
                d[0] = 1.0;
            }
            let mut o = [f(8.0), f(8.0), f(8.0)];
            if i % 5 == 0 {
                o[i % 3] = b.lo[i % 3][0];
            }
            let r = PreparedRay::new(&Ray::new(o, d)).unwrap();
            for tmax in [f32::INFINITY, 1.0] {
                assert_eq!(
                    wide_hitmask(
                        &node,
                        &b,
                        &r,
                        0x0707_0707,
                        tmax,
                        Prefetch::nodes_only(&[], &[])
                    ),
                    wide_hitmask_scalar(&node, &b, &r, 0x0707_0707, tmax)
                );
            }
        }
    }
}
