//! The top level over grid blocks and loose triangles: an 8-wide BVH collapsed from a binary
//! tree of binned surface-area-heuristic splits (`binned.rs`; the collapse of least
//! total node area, [`super::collapse`]; its nodes emitted subtree by subtree in parallel,
//! `emit.rs`), with exact `f32` child boxes ([`Box8`]) and an
//! ordered, distance-culled stack traversal. Eight children per node halve the levels a ray walks
//! against a 4-wide tree, and one AVX2 test (or two SSE2 halves) tests all eight boxes.
//!
//! Each node's eight boxes are the exact bounds of what lies below each child (recomputed from
//! the primitives' boxes, never taken from the builder), so the conservative box test of
//! [`crate::bvh::triangle::PreparedRay::hits_box`] can never cull a primitive the ray meets.

use super::collapse::Collapse;
use super::node::{child_of, in_order, test8, Box8};
use crate::bvh::triangle::PreparedRay;
use std::mem::MaybeUninit;

/// A child reference: a node index, or a primitive with [`LEAF`] set; [`EMPTY`] for none.
pub type Ref = u32;
/// Marks a primitive reference.
pub const LEAF: u32 = 1 << 31;
/// An absent child.
pub const EMPTY: u32 = u32::MAX;

/// Children per node.
pub const WIDTH: usize = 8;

/// A node: eight child boxes and references.
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C, align(32))]
pub struct Node8 {
    /// Child boxes (absent children: empty boxes).
    pub boxes: Box8,
    /// Child references.
    pub child: [Ref; WIDTH],
}

impl Node8 {
    pub(super) const EMPTY: Node8 = Node8 {
        boxes: Box8 {
            lo: [[f32::INFINITY; WIDTH]; 3],
            hi: [[f32::NEG_INFINITY; WIDTH]; 3],
        },
        child: [EMPTY; WIDTH],
    };
}

/// What [`Top::walk`] does at the primitives it reaches. A trait rather than closures:
/// closures do not inherit a function's `#[target_feature]`, so a closure's body was compiled
/// for the baseline instruction set and called from the AVX2 walk, not inlined into it (with
/// its own calls to the AVX2 leaf test). Implementations mark both methods
/// `#[inline(always)]`.
pub trait Visit {
    /// Visits primitive `prim`, which the ray meets within `tmax`: the new `tmax` and whether
    /// to stop.
    fn visit(&mut self, prim: u32, tmax: f32) -> (f32, bool);
    /// Prefetches what visiting `prim` reads first, when it is reached or pushed.
    fn prefetch(&self, prim: u32);
}

/// The top level.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Top {
    /// Nodes (the root first, when the root is a node).
    pub nodes: Vec<Node8>,
    /// The root reference ([`EMPTY`] when there is nothing).
    pub root: Ref,
    /// Node levels on the longest path.
    pub depth: usize,
    /// The most entries [`Top::walk`]'s stack can hold at once, over every ray: on each
    /// root-to-leaf path, one plus the siblings pushed below each node (see
    /// [`Top::stack_need`]).
    pub stack: usize,
}

/// An axis-aligned box, `[lo, hi]`.
pub(super) type Bounds = [[f32; 3]; 2];

/// The smallest box holding `a` and `b`.
pub(super) fn union(a: Bounds, b: Bounds) -> Bounds {
    [
        std::array::from_fn(|i| a[0][i].min(b[0][i])),
        std::array::from_fn(|i| a[1][i].max(b[1][i])),
    ]
}

/// The empty box (the union's identity).
pub(super) const NONE: Bounds = [[f32::INFINITY; 3], [f32::NEG_INFINITY; 3]];

/// Groups of primitives and each primitive's grid cell ([`Top::build_grouped`]).
type Grouping<'a> = (&'a [std::ops::Range<u32>], &'a [[u32; 2]]);

impl Top {
    /// Builds the top level over primitives with bounds `boxes` (`[min, max]`).
    pub fn build(boxes: &[[[f32; 3]; 2]]) -> Top {
        Self::build_with(boxes, None)
    }

    /// [`Self::build`] over primitives in `groups` (consecutive ranges, together all of
    /// them, none empty) that lie side by side in a grid, primitive `p` at grid cell
    /// `cells[p]` of its group (a domain's blocks, each at the grid point of its first
    /// vertex): each group cut by its grid's regular splits into squares of at most four,
    /// the squares binned, each square split regularly below its leaf (`grouped.rs`).
    pub(crate) fn build_grouped(
        boxes: &[[[f32; 3]; 2]],
        groups: &[std::ops::Range<u32>],
        cells: &[[u32; 2]],
    ) -> Top {
        Self::build_with(boxes, Some((groups, cells)))
    }

    fn build_with(boxes: &[[[f32; 3]; 2]], grouped: Option<Grouping<'_>>) -> Top {
        if boxes.is_empty() {
            return Top {
                nodes: Vec::new(),
                root: EMPTY,
                depth: 0,
                stack: 0,
            };
        }
        if boxes.len() == 1 {
            let mut node = Node8::EMPTY;
            node.child[0] = LEAF;
            node.boxes.include(0, boxes[0][0]);
            node.boxes.include(0, boxes[0][1]);
            return Top {
                nodes: vec![node],
                root: 0,
                depth: 1,
                stack: 1,
            };
        }
        let bvh2 = match grouped {
            // Groups of one primitive each: the same tree as binned over them.
            Some((groups, cells)) if groups.len() < boxes.len() => {
                super::grouped::build(boxes, groups, cells)
            }
            _ => super::binned::build(boxes),
        };
        crate::stages::mark("grid: top-level binning");
        let collapse = Collapse::new(&bvh2);
        crate::stages::mark("grid: top-level collapse");
        // The 8-wide nodes with their exact boxes, emitted in blocks side by side (`emit.rs`),
        // and the stack bound: the stage still named for the boxes it ends with.
        let (nodes, depth) = super::emit::nodes(&bvh2, &collapse, boxes);
        let mut top = Top {
            nodes,
            root: 0,
            depth,
            stack: 0,
        };
        top.stack = top.stack_need();
        crate::stages::mark("grid: top-level boxes");
        top
    }

    /// The most entries the walk's stack can hold at once, over every ray. Visiting a node
    /// pops it and pushes its children met (at most all of them), nearest on top; below the
    /// deepest entry the rest wait. So a node whose subtree needs `s` entries when reached
    /// needs `max(children, (children − 1) + max over inner children of their need)`, and
    /// the root needs its own (one entry on an empty stack when the root is a primitive).
    pub fn stack_need(&self) -> usize {
        if self.root == EMPTY {
            return 0;
        }
        if self.root & LEAF != 0 {
            return 1;
        }
        // Children follow their parents: one pass from the back.
        let mut need = vec![0usize; self.nodes.len()];
        for n in (0..self.nodes.len()).rev() {
            let kids = self.nodes[n].child.iter().filter(|&&r| r != EMPTY);
            let count = kids.clone().count();
            let deepest = kids
                .filter(|&&r| r & LEAF == 0)
                .map(|&r| need[r as usize])
                .max()
                .unwrap_or(0);
            need[n] = count.max(count.saturating_sub(1) + deepest);
        }
        need[self.root as usize]
    }

    /// Bytes.
    pub fn bytes(&self) -> usize {
        self.nodes.len() * std::mem::size_of::<Node8>()
    }

    /// Walks the top level front to back: `visit(prim, tmax)` for each primitive whose box the
    /// ray meets within the current `tmax` ([`Visit::visit`], which returns the new `tmax`
    /// and whether to stop), and [`Visit::prefetch`] when a primitive is reached or pushed.
    /// The node test is [`test8`]'s with `AVX2`.
    ///
    /// The nearest child met goes on at once, without the stack; only the others are pushed,
    /// far to near, with their entry distances, and skipped when popped beyond `tmax`.
    /// Without `ORDERED` (any-hit queries, whose answer does not depend on the order) nothing
    /// is sorted: the lowest child met goes on, the others are pushed as they come. The
    /// stack is a fixed array when [`Top::stack`] fits it (it bounds this walk too: it counts
    /// every child met as pushed), else one heap array of that size.
    ///
    /// # Safety
    /// With `AVX2`, the processor must have AVX2.
    #[inline(always)]
    pub unsafe fn walk<const AVX2: bool, const ORDERED: bool>(
        &self,
        r: &PreparedRay,
        mut tmax: f32,
        v: &mut impl Visit,
    ) {
        if self.root == EMPTY || r.tmin > tmax {
            return;
        }
        // Not initialised (a fixed array of zeros would be cleared for every ray): an entry
        // is read only below `len`, after it was written.
        let mut fixed = [const { MaybeUninit::<(Ref, f32)>::uninit() }; FIXED_STACK];
        let mut heap = Vec::new();
        let stack: &mut [MaybeUninit<(Ref, f32)>] = if self.stack <= FIXED_STACK {
            &mut fixed
        } else {
            heap.resize(self.stack, MaybeUninit::uninit());
            &mut heap
        };
        let mut len = 0;
        let mut node = self.root;
        loop {
            if node & LEAF != 0 {
                let (t, stop) = v.visit(node & !LEAF, tmax);
                tmax = t;
                if stop {
                    return;
                }
            } else {
                let n = &self.nodes[node as usize];
                // SAFETY: this function's contract.
                let (mask, d) = unsafe { test8::<AVX2>(&n.boxes, r, tmax) };
                if mask != 0 {
                    if mask & (mask - 1) == 0 {
                        node = n.child[mask.trailing_zeros() as usize];
                        if node & LEAF != 0 {
                            v.prefetch(node & !LEAF);
                        }
                        continue;
                    }
                    let mut keys = [0; 8];
                    let count = in_order::<ORDERED, 8>(mask, &d, &mut keys);
                    // The first goes on now. The others are pushed far to near (the nearest
                    // waiting is popped first), or unordered as they come (the highest is
                    // popped first: measured faster than the lowest).
                    let rest = &keys[1..count];
                    for i in 0..rest.len() {
                        let k = if ORDERED {
                            rest[rest.len() - 1 - i]
                        } else {
                            rest[i]
                        };
                        let c = child_of(k);
                        let child = n.child[c];
                        if child & LEAF != 0 {
                            v.prefetch(child & !LEAF);
                        } else {
                            prefetch_node(&self.nodes, child);
                        }
                        stack[len].write((child, d[c]));
                        len += 1;
                    }
                    node = n.child[child_of(keys[0])];
                    if node & LEAF != 0 {
                        v.prefetch(node & !LEAF);
                    }
                    continue;
                }
            }
            // Pop the nearest waiting entry still within `tmax` (a NaN distance is kept).
            loop {
                if len == 0 {
                    return;
                }
                len -= 1;
                // SAFETY: every entry below the length was written when pushed.
                let (next, near) = unsafe { stack[len].assume_init() };
                if near > tmax {
                    continue;
                }
                node = next;
                break;
            }
        }
    }
}

/// Entries of the walk's stack held in a fixed array (deeper hierarchies use the heap).
const FIXED_STACK: usize = 128;

#[inline(always)]
fn prefetch_node(nodes: &[Node8], i: u32) {
    #[cfg(target_arch = "x86_64")]
    if let Some(n) = nodes.get(i as usize) {
        // SAFETY: prefetching a valid reference has no effect on memory.
        unsafe {
            use std::arch::x86_64::{_mm_prefetch, _MM_HINT_T0};
            let p = n as *const Node8 as *const i8;
            for l in 0..std::mem::size_of::<Node8>().div_ceil(64) {
                _mm_prefetch::<_MM_HINT_T0>(p.add(64 * l));
            }
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = (nodes, i);
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bvh::Ray;
    use crate::harness::rng::SplitMix64;

    /// Counts the visits of each primitive.
    struct Seen(Vec<u32>);

    impl Visit for Seen {
        fn visit(&mut self, prim: u32, tmax: f32) -> (f32, bool) {
            self.0[prim as usize] += 1;
            (tmax, false)
        }
        fn prefetch(&self, _: u32) {}
    }

    /// The walk visits every primitive whose box the ray meets (brute force over the boxes),
    /// each once, on random boxes of many sizes.
    #[test]
    fn walk_finds_every_box_met() {
        const INF: f32 = f32::INFINITY;
        let mut rng = SplitMix64(21);
        for n in [1usize, 2, 3, 5, 17, 300, 2000] {
            let boxes: Vec<[[f32; 3]; 2]> = (0..n)
                .map(|_| {
                    let c: [f32; 3] = std::array::from_fn(|_| (rng.next_f64() * 10.0) as f32);
                    let e: [f32; 3] = std::array::from_fn(|_| (rng.next_f64() * 0.5) as f32);
                    [
                        std::array::from_fn(|a| c[a] - e[a]),
                        std::array::from_fn(|a| c[a] + e[a]),
                    ]
                })
                .collect();
            let top = Top::build(&boxes);
            assert!(top.stack >= top.depth && top.stack <= (WIDTH - 1) * top.depth + 1);
            // The same tree with a larger stack bound (still a bound) walks on the heap.
            let on_heap = Top {
                stack: FIXED_STACK + 1,
                ..top.clone()
            };
            for i in 0..200 {
                let o: [f32; 3] = std::array::from_fn(|_| (rng.next_f64() * 14.0 - 2.0) as f32);
                let d: [f32; 3] = std::array::from_fn(|a| {
                    if i % 7 == 0 && a == 1 {
                        0.0
                    } else {
                        (rng.next_f64() - 0.5) as f32
                    }
                });
                let r = PreparedRay::new(&Ray::new(o, d)).unwrap();
                #[cfg(target_arch = "x86_64")]
                let avx = crate::grid::window::has_avx2();
                #[cfg(not(target_arch = "x86_64"))]
                let avx = false;
                for (wide, top, ordered) in [
                    (false, &top, true),
                    (avx, &top, true),
                    (false, &on_heap, true),
                    (avx, &top, false),
                ] {
                    let mut seen = Seen(vec![0u32; n]);
                    let v = &mut seen;
                    // SAFETY: AVX2 only where detected.
                    unsafe {
                        match (wide, ordered) {
                            (true, true) => top.walk::<true, true>(&r, INF, v),
                            (true, false) => top.walk::<true, false>(&r, INF, v),
                            (false, true) => top.walk::<false, true>(&r, INF, v),
                            (false, false) => top.walk::<false, false>(&r, INF, v),
                        }
                    }
                    for (p, b) in boxes.iter().enumerate() {
                        let want = r.hits_box(b[0], b[1], f32::INFINITY);
                        assert_eq!(seen.0[p], u32::from(want), "n {n}, ray {i}, prim {p}");
                    }
                }
            }
        }
    }
}

#[cfg(test)]
mod stack_tests {
    use super::*;

    /// The union of the boxes of the primitives below reference `r`, and their count.
    fn below(top: &Top, boxes: &[Bounds], r: Ref) -> (Bounds, usize) {
        if r & LEAF != 0 {
            return (boxes[(r & !LEAF) as usize], 1);
        }
        top.nodes[r as usize]
            .child
            .iter()
            .filter(|&&c| c != EMPTY)
            .fold((NONE, 0), |(b, n), &c| {
                let (cb, cn) = below(top, boxes, c);
                (union(b, cb), n + cn)
            })
    }

    /// Every child box of every node is the union of the boxes of the primitives below it,
    /// exactly (`==` on `f32`: the same values), and every primitive is below the root once;
    /// on random boxes, some sharing corners, with zeros of both signs among the bounds.
    #[test]
    fn child_boxes_are_the_unions_below() {
        let mut rng = crate::harness::rng::SplitMix64(77);
        for n in [2usize, 9, 64, 1000, 5000] {
            let boxes: Vec<Bounds> = (0..n)
                .map(|i| {
                    let c: [f32; 3] = std::array::from_fn(|_| match i % 5 {
                        0 => 0.0,
                        1 => -0.0,
                        _ => (rng.next_f64() * 8.0 - 4.0) as f32,
                    });
                    let e: [f32; 3] = std::array::from_fn(|_| (rng.next_f64() * 0.3) as f32);
                    [
                        std::array::from_fn(|a| c[a] - e[a]),
                        std::array::from_fn(|a| c[a] + e[a]),
                    ]
                })
                .collect();
            let top = Top::build(&boxes);
            assert_eq!(
                below(&top, &boxes, top.root).1,
                n,
                "n {n}: every primitive once"
            );
            for node in &top.nodes {
                for (c, &r) in node.child.iter().enumerate() {
                    if r == EMPTY {
                        continue;
                    }
                    assert_eq!(node.boxes.child(c), below(&top, &boxes, r).0, "n {n}");
                }
            }
        }
    }

    /// The stack bound of a hand-built tree: the root has three children, an inner node with
    /// eight primitives among them (`(3 − 1) + 8`), and a second inner node with two.
    #[test]
    fn stack_need_counts_waiting_siblings() {
        let mut top = Top {
            nodes: vec![Node8::EMPTY; 3],
            root: 0,
            depth: 2,
            stack: 0,
        };
        top.nodes[0].child[..3].copy_from_slice(&[1, LEAF, 2]);
        top.nodes[1].child = std::array::from_fn(|i| LEAF | i as u32);
        top.nodes[2].child[..2].copy_from_slice(&[LEAF | 8, LEAF | 9]);
        assert_eq!(top.stack_need(), 10);
        top.nodes[1].child[1..].fill(EMPTY);
        assert_eq!(top.stack_need(), 4);
    }
}
