//! The top level's binary tree over groups of primitives that lie side by side in a grid (a
//! domain's blocks): each group cut by regular splits of its grid into chunks of a few
//! primitives, the surface area heuristic over the chunks' boxes ([`super::binned`]), and
//! below each chunk its regular splits.
//!
//! A domain diced at rate 64 is 8 × 8 blocks in a regular grid; binning its 64 blocks as
//! unrelated boxes costs the car at rate 64 (100,800 blocks in 1,575 domains) most of its top
//! level's build. A group's primitives are halved along the longer side of their grid cells
//! (`(i, j)` of each block's first vertex in the domain's grid), at the median, down to chunks
//! of at most [`CHUNK`]; the chunks are binned, and each chunk's primitives are halved again
//! below its leaf, down to one primitive per leaf. Measured on the car at rate 64 (BENCHMARKS.md,
//! twenty-ninth step): whole domains as chunks cut the top level's build by half but cost the
//! rays 6.6% more instructions (binning within each domain instead of its regular splits did
//! not win them back); chunks of 16 blocks, 4.3%; chunks of 4, 1.2%, for a third off the build.
//!
//! The result is the binary tree [`super::binned::build`] makes, node layout included: one
//! primitive per leaf, `2n − 1` nodes, the two children of a node side by side, first the
//! children, then the first child's descendants, then the second's; every node's box the exact
//! union of its primitives' boxes. [`super::collapse`] then takes it as it takes that one.

use super::top::{union, Bounds, NONE};
use glam::Vec3A;
use obvhs::aabb::Aabb;
use obvhs::bvh2::{node::Bvh2Node, Bvh2};
use std::ops::Range;

/// The most primitives of a group that stay together below one leaf of the binned tree (a
/// 2 × 2 square of a domain's blocks).
const CHUNK: usize = 4;

/// Builds the binary tree over primitives `boxes` in `groups` (consecutive ranges of
/// primitives, together `0..boxes.len()`, none empty), primitive `p` at grid cell `cells[p]`
/// of its group. At least two primitives.
pub(super) fn build(boxes: &[Bounds], groups: &[Range<u32>], cells: &[[u32; 2]]) -> Bvh2 {
    debug_assert!(boxes.len() >= 2 && cells.len() == boxes.len());
    debug_assert!(groups.first().is_some_and(|g| g.start == 0));
    debug_assert!(groups
        .windows(2)
        .all(|w| w[0].end == w[1].start && w[1].start < w[1].end));
    debug_assert!(groups.last().is_some_and(|g| g.end as usize == boxes.len()));
    // Each group cut by its regular splits into chunks of at most CHUNK primitives (ranges
    // of `ids`, a group's primitives reordered by its splits).
    let n = boxes.len();
    let mut ids: Vec<u32> = (0..n as u32).collect();
    let mut chunks: Vec<Range<usize>> = Vec::with_capacity(groups.len());
    for g in groups {
        let mut todo: Vec<Range<usize>> = Vec::with_capacity(8);
        todo.push(g.start as usize..g.end as usize);
        while let Some(r) = todo.pop() {
            if r.len() <= CHUNK {
                chunks.push(r);
                continue;
            }
            let mid = r.start + halve(&mut ids[r.clone()], cells);
            todo.push(mid..r.end);
            todo.push(r.start..mid);
        }
    }
    // The chunks' tree: binned over their boxes (one chunk: its own subtree at the root).
    let over_chunks = (chunks.len() >= 2).then(|| {
        let chunk_boxes: Vec<Bounds> = chunks
            .iter()
            .map(|c| {
                ids[c.clone()]
                    .iter()
                    .fold(NONE, |a, &p| union(a, boxes[p as usize]))
            })
            .collect();
        super::binned::build(&chunk_boxes)
    });
    let mut nodes = vec![Bvh2Node::default(); 1];
    nodes.reserve(2 * n - 2);
    let mut prims: Vec<u32> = Vec::with_capacity(n);
    enum Job {
        /// A node of the chunks' tree.
        Group(usize),
        /// Primitives `ids[range]` of one chunk.
        Cells(Range<usize>),
    }
    let first = match &over_chunks {
        Some(_) => Job::Group(0),
        None => Job::Cells(0..n),
    };
    // (slot in `nodes`, what goes there); the first child is taken next, so that each node's
    // descendants are numbered after its children, the first child's before the second's.
    let mut stack = vec![(0usize, first)];
    while let Some((slot, job)) = stack.pop() {
        let range = match job {
            Job::Group(x) => {
                let t = over_chunks.as_ref().expect("a chunks' tree");
                let node = &t.nodes[x];
                if node.prim_count == 0 {
                    let a = nodes.len();
                    nodes.resize(a + 2, Bvh2Node::default());
                    nodes[slot] = Bvh2Node::new(node.aabb, 0, a as u32);
                    let f = node.first_index as usize;
                    stack.push((a + 1, Job::Group(f + 1)));
                    stack.push((a, Job::Group(f)));
                    continue;
                }
                chunks[t.primitive_indices[node.first_index as usize] as usize].clone()
            }
            Job::Cells(range) => range,
        };
        let part = &mut ids[range.clone()];
        if let [p] = part {
            nodes[slot] = Bvh2Node::new(aabb(boxes[*p as usize]), 1, prims.len() as u32);
            prims.push(*p);
            continue;
        }
        let mid = halve(part, cells);
        let a = nodes.len();
        nodes.resize(a + 2, Bvh2Node::default());
        // Its box once its children's are known (below).
        nodes[slot] = Bvh2Node::new(Aabb::empty(), 0, a as u32);
        stack.push((a + 1, Job::Cells(range.start + mid..range.end)));
        stack.push((a, Job::Cells(range.start..range.start + mid)));
    }
    // Every inner node's box: the union of its children's (children come
    // after their parents), exact in any order.
    for i in (0..nodes.len()).rev() {
        if nodes[i].prim_count == 0 {
            let f = nodes[i].first_index as usize;
            let (a, b) = (&nodes[f].aabb, &nodes[f + 1].aabb);
            nodes[i].aabb = Aabb::new(a.min.min(b.min), a.max.max(b.max));
        }
    }
    debug_assert_eq!(nodes.len(), 2 * n - 1);
    Bvh2 {
        nodes,
        primitive_indices: prims,
        ..Bvh2::default()
    }
}

/// Splits `part` (at least two primitives) at its median along the longer side of its
/// cells' bounds (the first axis on a tie): the first half's length, the primitives before it
/// lower on that axis (then on the other, then by index: a total order, so the split is the
/// same whatever the order of `part`).
fn halve(part: &mut [u32], cells: &[[u32; 2]]) -> usize {
    let (lo, hi) = part
        .iter()
        .fold(([u32::MAX; 2], [0u32; 2]), |(lo, hi), &p| {
            let c = cells[p as usize];
            (
                [lo[0].min(c[0]), lo[1].min(c[1])],
                [hi[0].max(c[0]), hi[1].max(c[1])],
            )
        });
    let axis = usize::from(hi[1] - lo[1] > hi[0] - lo[0]);
    let mid = part.len() / 2;
    part.select_nth_unstable_by_key(mid, |&p| {
        let c = cells[p as usize];
        (c[axis], c[1 - axis], p)
    });
    mid
}

/// `b` as an [`Aabb`].
fn aabb(b: Bounds) -> Aabb {
    Aabb::new(Vec3A::from(b[0]), Vec3A::from(b[1]))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::harness::rng::SplitMix64;

    /// Groups of grid cells (rows × columns of boxes, each group somewhere else, some of one
    /// primitive), their primitives numbered group by group.
    fn grids(
        rng: &mut SplitMix64,
        sizes: &[[u32; 2]],
    ) -> (Vec<Bounds>, Vec<Range<u32>>, Vec<[u32; 2]>) {
        let (mut boxes, mut groups, mut cells) = (Vec::new(), Vec::new(), Vec::new());
        for (g, &[cols, rows]) in sizes.iter().enumerate() {
            let start = boxes.len() as u32;
            let origin: [f32; 3] = std::array::from_fn(|_| (rng.next_f64() * 50.0) as f32);
            for y in 0..rows {
                for x in 0..cols {
                    let lo = [
                        origin[0] + x as f32,
                        origin[1] + y as f32,
                        origin[2] + g as f32 * 0.1,
                    ];
                    let e = rng.next_f64() as f32 * 0.3;
                    boxes.push([lo, [lo[0] + 1.0 + e, lo[1] + 1.0, lo[2] + 0.5]]);
                    // Cells as the blocks' first vertices: 8 grid points apart.
                    cells.push([8 * x, 8 * y]);
                }
            }
            groups.push(start..boxes.len() as u32);
        }
        (boxes, groups, cells)
    }

    /// The union of the boxes below node `n` (checked against each node's own box, bit for
    /// bit), and its leaves' primitives in order; children after their parents, siblings
    /// side by side, each node's descendants numbered in one range after its children.
    fn below(t: &Bvh2, boxes: &[Bounds], n: usize, prims: &mut Vec<u32>) -> (Bounds, usize) {
        let node = &t.nodes[n];
        let (b, count) = if node.prim_count != 0 {
            assert_eq!(node.prim_count, 1, "one primitive per leaf");
            let p = t.primitive_indices[node.first_index as usize];
            prims.push(p);
            (boxes[p as usize], 1)
        } else {
            let f = node.first_index as usize;
            assert!(f > n, "children after their parents");
            let (a, na) = below(t, boxes, f, prims);
            let (b, nb) = below(t, boxes, f + 1, prims);
            (union(a, b), na + nb)
        };
        let got = [node.aabb.min.to_array(), node.aabb.max.to_array()];
        assert_eq!(
            got.map(|v| v.map(f32::to_bits)),
            b.map(|v| v.map(f32::to_bits))
        );
        (b, count)
    }

    /// Every primitive in exactly one leaf of `2n − 1` nodes with exact boxes; each group of
    /// at most [`CHUNK`] primitives under one subtree of its own (its leaves consecutive in
    /// depth-first order); an 8 × 8 group's chunks its aligned 2 × 2 squares.
    #[test]
    fn chunks_stay_together_in_exact_boxes() {
        let mut rng = SplitMix64(5);
        let cases: [&[[u32; 2]]; 5] = [
            &[[8, 8]],
            &[[8, 8], [1, 1], [3, 5], [8, 8], [1, 1]],
            &[[2, 2]; 40],
            &[[1, 1]; 7],
            &[[2, 1], [1, 3], [2, 2], [1, 1]],
        ];
        for sizes in cases {
            let (boxes, groups, cells) = grids(&mut rng, sizes);
            let t = build(&boxes, &groups, &cells);
            let n = boxes.len();
            assert_eq!(t.nodes.len(), 2 * n - 1);
            let mut prims = Vec::new();
            let (_, count) = below(&t, &boxes, 0, &mut prims);
            assert_eq!(count, n);
            let mut sorted = prims.clone();
            sorted.sort_unstable();
            assert_eq!(
                sorted,
                (0..n as u32).collect::<Vec<_>>(),
                "every primitive once"
            );
            let together = |set: &dyn Fn(u32) -> bool| {
                let at: Vec<usize> = (0..n).filter(|&i| set(prims[i])).collect();
                at.last().unwrap() - at[0] + 1 == at.len()
            };
            for g in groups.iter().filter(|g| g.len() <= CHUNK) {
                assert!(together(&|p| g.contains(&p)), "group {g:?} together");
            }
            for g in groups.iter().filter(|g| g.len() == 64) {
                for (a, b) in (0..4).flat_map(|a| (0..4).map(move |b| (a, b))) {
                    let square = |p: u32| {
                        let c = cells[p as usize];
                        g.contains(&p) && c[0] / 16 == a && c[1] / 16 == b
                    };
                    assert!(together(&square), "square ({a}, {b}) of {g:?} together");
                }
            }
        }
    }
}
