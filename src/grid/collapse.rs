//! The collapse of a binary BVH into an 8-wide one that minimises the surface area heuristic:
//! which binary nodes become 8-wide nodes, and which children each of them holds.
//!
//! Every primitive sits in a slot of some 8-wide node whatever the collapse, so its own cost
//! (its area times the cost of testing it) is the same in every tree; what the collapse
//! changes is the set of nodes, each costing a ray that reaches it one 8-wide box test.
//! The expected cost of a tree is therefore, up to a constant, the sum of its nodes' areas,
//! and the best tree is found by dynamic programming over the binary tree, bottom up:
//! `cost(n, i)` is the least cost of the subtree of `n` given `i` slots of its parent
//! (`1 ≤ i ≤ 8`). A leaf takes one slot at no cost. An inner node either becomes a node
//! itself (one slot; its area plus the best spread of its two children over eight slots)
//! or gives its slots to its two children, `j` to the first and `i − j` to the second.
//! `cost(n, i)` does not grow with `i`, so a spread over `i` slots never needs fewer.

use crate::prefetch;
use crate::threads::split_off;
use obvhs::bvh2::Bvh2;

/// Slots of a node.
const SLOTS: usize = 8;

/// The optimal collapse of a binary BVH whose leaves hold one primitive each.
pub struct Collapse<'a> {
    bvh2: &'a Bvh2,
    /// Per binary node and slot count `i` (index `i − 1`): how many of the slots its first
    /// child gets when the node gives its slots away, or 0 when it takes one slot itself.
    split: Vec<[u8; SLOTS]>,
    /// Per binary inner node: how many of a new node's eight slots its first child gets.
    spread: Vec<u8>,
}

impl<'a> Collapse<'a> {
    /// Plans the collapse of `bvh2` (not empty).
    ///
    /// Bottom up: a node is solved once its two children are. Subtrees whose nodes lie in
    /// ranges of their own (`subtree_ranges`: the binned builder numbers a subtree's
    /// descendants contiguously) are solved side by side first, each alone in its range;
    /// then one pass over the rest from the last node (a builder numbers most children after
    /// their parent, so most are ready by then, and the pass reads the nodes in memory
    /// order); the few that are not wait for a pass over the waiting ones, repeated until
    /// none waits (in a tree, some waiting node always has both children solved). A
    /// depth-first order instead read the nodes scattered, twice: 16 of the 316² grid's 54 ms
    /// of top level. A node's solution depends on its children's alone, so the plan is the
    /// same in any order and at any thread count.
    pub fn new(bvh2: &'a Bvh2) -> Self {
        Self::plan(bvh2, PARALLEL_RANGE)
    }

    /// [`Self::new`] with subtree ranges of fewer than `most` nodes.
    fn plan(bvh2: &'a Bvh2, most: usize) -> Self {
        let n = bvh2.nodes.len();
        let mut cost = vec![[0f32; SLOTS]; n];
        let mut split = vec![[0u8; SLOTS]; n];
        let mut spread = vec![0u8; n];
        let mut done = vec![false; n];
        {
            use rayon::prelude::*;
            let ranges = subtree_ranges(bvh2, most);
            let mut parts = Vec::with_capacity(ranges.len());
            let (mut c, mut s) = (&mut cost[..], &mut split[..]);
            let (mut p, mut d) = (&mut spread[..], &mut done[..]);
            let mut at = 0;
            for r in &ranges {
                let skip = r.start - at;
                let len = r.len();
                parts.push((
                    r.start,
                    Part {
                        cost: &mut split_off(&mut c, skip + len)[skip..],
                        split: &mut split_off(&mut s, skip + len)[skip..],
                        spread: &mut split_off(&mut p, skip + len)[skip..],
                        done: &mut split_off(&mut d, skip + len)[skip..],
                    },
                ));
                at = r.end;
            }
            parts
                .into_par_iter()
                .with_min_len(crate::threads::min_len())
                .for_each(|(first, mut part)| {
                    for i in (0..part.done.len()).rev() {
                        solve(bvh2, first, i, &mut part);
                    }
                });
        }
        let mut all = Part {
            cost: &mut cost,
            split: &mut split,
            spread: &mut spread,
            done: &mut done,
        };
        let mut waiting = Vec::new();
        for i in (0..n).rev() {
            prefetch::prefetch(
                i.checked_sub(prefetch::AHEAD)
                    .and_then(|a| bvh2.nodes.get(a)),
            );
            if !all.done[i] && !solve(bvh2, 0, i, &mut all) {
                waiting.push(i);
            }
        }
        while !waiting.is_empty() {
            let before = waiting.len();
            waiting.retain(|&i| !solve(bvh2, 0, i, &mut all));
            assert!(waiting.len() < before, "the binary BVH is a tree");
        }
        Collapse {
            bvh2,
            split,
            spread,
        }
    }

    /// The children of the 8-wide node made from binary node `n`: binary nodes that are
    /// leaves (primitives) or nodes of their own, at most eight. A leaf `n` is its own one
    /// child.
    pub fn children(&self, n: usize) -> Vec<usize> {
        let mut out = Vec::with_capacity(SLOTS);
        self.children_into(n, &mut out);
        out
    }

    /// [`Self::children`] into `out` (cleared first: one buffer for every node).
    pub fn children_into(&self, n: usize, out: &mut Vec<usize>) {
        out.clear();
        let node = &self.bvh2.nodes[n];
        if node.prim_count != 0 {
            out.push(n);
            return;
        }
        let first = node.first_index as usize;
        let j = self.spread[n] as usize;
        self.fill(first, j, out);
        self.fill(first + 1, SLOTS - j, out);
    }

    /// Fills `slots` slots with the subtree of binary node `n`.
    fn fill(&self, n: usize, slots: usize, out: &mut Vec<usize>) {
        let j = self.split[n][slots - 1] as usize;
        if j == 0 {
            out.push(n);
        } else {
            let first = self.bvh2.nodes[n].first_index as usize;
            self.fill(first, j, out);
            self.fill(first + 1, slots - j, out);
        }
    }
}

/// Nodes below which a subtree's range is not split further for [`Collapse::new`]'s
/// parallel pass (a range of fewer is one worker's job).
const PARALLEL_RANGE: usize = 8192;

/// The plan's arrays for the nodes `first..first + done.len()` (all of them, or a subtree's
/// range).
struct Part<'p> {
    cost: &'p mut [[f32; SLOTS]],
    split: &'p mut [[u8; SLOTS]],
    spread: &'p mut [u8],
    done: &'p mut [bool],
}

/// Solves node `first + i` of `bvh2` into `part` (whose arrays start at node `first`) if its
/// children are solved there: `false` if it must wait (a child unsolved, or outside `part`).
fn solve(bvh2: &Bvh2, first: usize, i: usize, part: &mut Part) -> bool {
    let node = &bvh2.nodes[first + i];
    if node.prim_count != 0 {
        // A leaf: one slot, no cost (the zeros already there).
        part.done[i] = true;
        return true;
    }
    let Some(l) = (node.first_index as usize).checked_sub(first) else {
        return false;
    };
    let r = l + 1;
    if r >= part.done.len() || !(part.done[l] && part.done[r]) {
        return false;
    }
    let cost = &mut *part.cost;
    // The best spread of the two children over `s` slots, for s = 2..=8.
    let mut open = [(f32::INFINITY, 0u8); SLOTS];
    for s in 2..=SLOTS {
        for j in 1..s {
            let c = cost[l][j - 1] + cost[r][s - j - 1];
            if c < open[s - 1].0 {
                open[s - 1] = (c, j as u8);
            }
        }
    }
    let own = area(node.aabb()) + open[SLOTS - 1].0;
    part.spread[i] = open[SLOTS - 1].1;
    cost[i][0] = own;
    for s in 2..=SLOTS {
        let (c, j) = open[s - 1];
        (cost[i][s - 1], part.split[i][s - 1]) = if c < own { (c, j) } else { (own, 0) };
    }
    part.done[i] = true;
    true
}

/// Disjoint ranges of node indices, each the descendants of one subtree where `bvh2` is laid
/// out as the binned builder lays it out (a node's two children first in its descendants'
/// range, then the first child's descendants, then the second's), in increasing order. The
/// root's range is split at its children, and the largest range again, until every range
/// holds fewer than `most` nodes or the layout is not that one there (its range is then
/// kept whole). Whatever the layout, the ranges are disjoint: a node whose children lie
/// outside its range is left to the serial pass.
fn subtree_ranges(bvh2: &Bvh2, most: usize) -> Vec<std::ops::Range<usize>> {
    let nodes = &bvh2.nodes;
    if nodes.len() < most.saturating_mul(2) || nodes[0].prim_count != 0 || nodes[0].first_index != 1
    {
        return Vec::new();
    }
    // (range of descendants, the node they descend from); only ranges that may be split.
    let mut open = vec![(1..nodes.len(), 0usize)];
    let mut kept = Vec::new();
    while let Some((range, p)) = open.pop() {
        let a = range.start;
        let node = &nodes[p];
        let splits = range.len() >= most
            && node.prim_count == 0
            && node.first_index as usize == a
            && a + 2 <= range.end;
        if !splits {
            kept.push(range);
            continue;
        }
        let (c1, c2) = (a, a + 1);
        // Where the second child's descendants start (the range's end if it is a leaf).
        let second = match nodes[c2].prim_count {
            0 => nodes[c2].first_index as usize,
            _ => range.end,
        };
        if !(a + 2 <= second && second <= range.end) {
            kept.push(range);
            continue;
        }
        if nodes[c1].prim_count == 0 && second > a + 2 {
            open.push((a + 2..second, c1));
        }
        if nodes[c2].prim_count == 0 && second < range.end {
            open.push((second..range.end, c2));
        }
    }
    kept.retain(|r| !r.is_empty());
    kept.sort_unstable_by_key(|r| r.start);
    kept
}

/// Surface area (half of it) of a box; zero when empty.
fn area(b: &obvhs::aabb::Aabb) -> f32 {
    let d = b.max - b.min;
    if d.x < 0.0 {
        return 0.0;
    }
    d.x * d.y + d.y * d.z + d.z * d.x
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::harness::rng::SplitMix64;
    use glam::Vec3A;
    use obvhs::aabb::Aabb;
    use obvhs::bvh2::builder::build_bvh2;
    use obvhs::BvhBuildParams;

    /// The binary nodes made 8-wide nodes by the collapse, from the root down.
    fn made(c: &Collapse, root: usize) -> Vec<usize> {
        let mut out = vec![root];
        let mut i = 0;
        while i < out.len() {
            let n = out[i];
            for k in c.children(n) {
                assert_ne!(k, n, "an inner node is not its own child");
                if c.bvh2.nodes[k].prim_count == 0 {
                    out.push(k);
                }
            }
            i += 1;
        }
        out
    }

    /// The least sum of node areas over every valid collapse, by trying every set of inner
    /// binary nodes (the root always in) as the 8-wide nodes: valid when each such node's
    /// children (the nearest chosen nodes or leaves below it) number at most eight.
    fn brute_force(bvh2: &Bvh2) -> f32 {
        let inner: Vec<usize> = (0..bvh2.nodes.len())
            .filter(|&n| n != 0 && bvh2.nodes[n].prim_count == 0)
            .collect();
        let mut best = f32::INFINITY;
        for set in 0u64..1 << inner.len() {
            let chosen = |n: usize| {
                n == 0
                    || inner
                        .iter()
                        .position(|&m| m == n)
                        .is_some_and(|i| set >> i & 1 == 1)
            };
            // Children of a chosen node: descend through unchosen inner nodes.
            let count = |n: usize| {
                let mut stack = vec![
                    bvh2.nodes[n].first_index as usize,
                    bvh2.nodes[n].first_index as usize + 1,
                ];
                let mut kids = 0;
                while let Some(k) = stack.pop() {
                    if bvh2.nodes[k].prim_count != 0 || chosen(k) {
                        kids += 1;
                    } else {
                        let f = bvh2.nodes[k].first_index as usize;
                        stack.extend([f, f + 1]);
                    }
                }
                kids
            };
            let nodes: Vec<usize> = std::iter::once(0)
                .chain(inner.iter().copied().filter(|&n| chosen(n)))
                .collect();
            if nodes.iter().all(|&n| count(n) <= SLOTS) {
                best = best.min(nodes.iter().map(|&n| area(bvh2.nodes[n].aabb())).sum());
            }
        }
        best
    }

    /// A binary BVH of `count` random boxes (one per leaf), built with `params`.
    fn random_tree(rng: &mut SplitMix64, count: usize, mut params: BvhBuildParams) -> Bvh2 {
        let boxes: Vec<Aabb> = (0..count)
            .map(|_| {
                let c = Vec3A::from([(); 3].map(|_| rng.next_f64() as f32 * 10.0));
                let e = Vec3A::from([(); 3].map(|_| rng.next_f64() as f32 * 2.0));
                Aabb::new(c, c + e)
            })
            .collect();
        params.pre_split = false;
        params.max_prims_per_leaf = 1;
        build_bvh2(&boxes, params, &mut std::time::Duration::default())
    }

    /// On random scenes small enough to try every collapse, the planned one is valid (at
    /// most eight children per node, every primitive once) and its sum of node areas is the
    /// least there is (to `f32` rounding of the sums, 1e-5 relative).
    #[test]
    fn collapse_is_optimal() {
        let mut rng = SplitMix64(40);
        for case in 0..60 {
            let count = 9 + case % 8;
            let bvh2 = random_tree(&mut rng, count, BvhBuildParams::medium_build());
            let c = Collapse::new(&bvh2);
            let nodes = made(&c, 0);
            let mut prims: Vec<usize> = Vec::new();
            for &n in &nodes {
                let kids = c.children(n);
                assert!(kids.len() <= SLOTS);
                prims.extend(kids.iter().filter(|&&k| bvh2.nodes[k].prim_count != 0));
            }
            prims.sort_unstable();
            assert_eq!(prims.len(), count, "every primitive once");
            assert!(
                prims.windows(2).all(|w| w[0] < w[1]),
                "every primitive once"
            );
            let got: f32 = nodes.iter().map(|&n| area(bvh2.nodes[n].aabb())).sum();
            let want = brute_force(&bvh2);
            assert!(got <= want * (1.0 + 1e-5), "case {case}: {got} > {want}");
        }
    }

    /// Binary nodes numbered in any order (here every sibling pair moved before its parent's,
    /// the reverse of the builder's order, so that nearly every node waits for a pass over
    /// the waiting ones): the same collapse, node for node.
    #[test]
    fn collapse_is_the_same_in_any_node_order() {
        let mut rng = SplitMix64(41);
        for case in 0..20 {
            let count = 20 + 37 * case;
            let bvh2 = random_tree(&mut rng, count, BvhBuildParams::fast_build());
            // Sibling pairs (they start at inner nodes' `first_index`) laid out in reverse.
            let mut starts: Vec<usize> = bvh2
                .nodes
                .iter()
                .filter(|n| n.prim_count == 0)
                .map(|n| n.first_index as usize)
                .collect();
            starts.sort_unstable();
            let mut map = vec![0usize; bvh2.nodes.len()];
            for (k, &s) in starts.iter().enumerate() {
                let to = 1 + 2 * (starts.len() - 1 - k);
                map[s] = to;
                map[s + 1] = to + 1;
            }
            let mut moved = bvh2.clone();
            for (old, node) in bvh2.nodes.iter().enumerate() {
                let mut node = *node;
                if node.prim_count == 0 {
                    node.first_index = map[node.first_index as usize] as u32;
                }
                moved.nodes[map[old]] = node;
            }
            // Inner nodes whose children come before them.
            let early = |t: &Bvh2| {
                t.nodes
                    .iter()
                    .enumerate()
                    .filter(|(i, n)| n.prim_count == 0 && (n.first_index as usize) < *i)
                    .count()
            };
            assert!(
                early(&moved) > early(&bvh2),
                "case {case}: children moved before their parents"
            );
            let (a, b) = (Collapse::new(&bvh2), Collapse::new(&moved));
            let nodes = made(&a, 0);
            assert_eq!(nodes.len(), made(&b, 0).len(), "case {case}");
            for &n in &nodes {
                let want: Vec<usize> = a.children(n).iter().map(|&k| map[k]).collect();
                assert_eq!(b.children(map[n]), want, "case {case}, node {n}");
            }
        }
    }
    /// Subtrees solved side by side in their ranges give the serial plan, entry for entry:
    /// on trees of the binned builder (whose layout the ranges follow: at this size four
    /// nodes in five or more lie in one) and of obvhs's (any layout: the ranges stay
    /// disjoint and the rest is solved after).
    #[test]
    fn subtrees_side_by_side_plan_as_serially() {
        let mut rng = SplitMix64(42);
        for case in 0..12 {
            let count = 50 + 311 * case;
            let boxes: Vec<[[f32; 3]; 2]> = (0..count)
                .map(|_| {
                    let c: [f32; 3] = std::array::from_fn(|_| rng.next_f64() as f32 * 10.0);
                    let e: [f32; 3] = std::array::from_fn(|_| rng.next_f64() as f32 * 0.5);
                    [c, std::array::from_fn(|a| c[a] + e[a])]
                })
                .collect();
            let binned = crate::grid::binned::build(&boxes);
            let obvhs = random_tree(&mut rng, count, BvhBuildParams::fast_build());
            for (name, bvh2) in [("binned", &binned), ("obvhs", &obvhs)] {
                let ranges = subtree_ranges(bvh2, 16);
                assert!(
                    ranges.windows(2).all(|w| w[0].end <= w[1].start),
                    "case {case} {name}: disjoint ranges in order"
                );
                let covered: usize = ranges.iter().map(|r| r.len()).sum();
                if name == "binned" {
                    assert!(
                        covered * 5 >= bvh2.nodes.len() * 4,
                        "case {case}: {covered} of {} nodes in ranges",
                        bvh2.nodes.len()
                    );
                }
                let (serial, ranged) = (Collapse::plan(bvh2, usize::MAX), Collapse::plan(bvh2, 16));
                assert!(serial.split == ranged.split, "case {case} {name}: split");
                assert!(serial.spread == ranged.spread, "case {case} {name}: spread");
            }
        }
    }
}
