//! The top level's 8-wide nodes from a planned collapse ([`super::collapse`]), with their
//! exact child boxes.
//!
//! The first levels of wide nodes, from the root, are emitted breadth first, until a level
//! holds at least [`TASKS`] nodes (or none is left); the subtrees below that level's nodes
//! are then emitted side by side (rayon), each into a block of its own, and the blocks laid
//! out after the first levels in the level's order. Within a block a node's children are
//! numbered when the node is emitted, after it, so that children follow their parents
//! everywhere and every box is found in one pass from the back. The nodes are the same at
//! any thread count.

use super::collapse::Collapse;
use super::top::{union, Bounds, Node8, Ref, EMPTY, LEAF, NONE, WIDTH};
use crate::threads::split_off;
use obvhs::bvh2::Bvh2;
use rayon::prelude::*;

/// A level of wide nodes with at least this many is where the subtrees emitted side by side
/// start.
const TASKS: usize = 16;

/// A child of a wide node: a primitive (its reference, [`LEAF`] set) or the binary node of a
/// wide node (`Err`).
type Kid = Result<Ref, usize>;

/// The children of the wide node made from binary node `bin`, in the collapse's order, into
/// `out` (`buf` is scratch space).
fn children(
    bvh2: &Bvh2,
    collapse: &Collapse,
    bin: usize,
    buf: &mut Vec<usize>,
    out: &mut Vec<Kid>,
) {
    collapse.children_into(bin, buf);
    out.clear();
    for &k in buf.iter() {
        let node = &bvh2.nodes[k];
        if node.is_leaf() {
            for i in 0..node.prim_count {
                out.push(Ok(
                    LEAF | bvh2.primitive_indices[(node.first_index + i) as usize]
                ));
            }
        } else {
            out.push(Err(k));
        }
    }
    assert!(out.len() <= WIDTH, "at most eight children");
}

/// Sets child `c` of `node` to `r`, with `b` the union of what lies below it, and widens
/// `all` (the union below the node) by `b`.
fn set_child(node: &mut Node8, c: usize, (r, b): (Ref, Bounds), all: &mut Bounds) {
    node.child[c] = r;
    node.boxes.include(c, b[0]);
    node.boxes.include(c, b[1]);
    *all = union(*all, b);
}

/// Sets `node`'s boxes from its children (`boxes` for primitives, `content` for nodes: the
/// union of what lies below node `i` at `content[i]`) and returns their union.
fn fill_boxes(node: &mut Node8, boxes: &[Bounds], content: &[Bounds]) -> Bounds {
    let mut all = NONE;
    for c in 0..WIDTH {
        let r = node.child[c];
        let b = if r == EMPTY {
            continue;
        } else if r & LEAF != 0 {
            boxes[(r & !LEAF) as usize]
        } else {
            content[r as usize]
        };
        set_child(node, c, (r, b), &mut all);
    }
    all
}

/// The wide subtree of binary node `root` (a wide node at level `level`): its nodes, the
/// root first, numbered from 0 (each node's children after it), with their boxes; the union
/// of the boxes below the root; the deepest level.
fn subtree(
    bvh2: &Bvh2,
    collapse: &Collapse,
    boxes: &[Bounds],
    (root, level): (usize, usize),
) -> (Vec<Node8>, Bounds, usize) {
    let mut nodes = vec![Node8::EMPTY];
    let mut work = vec![(root, 0usize, level)];
    let mut depth = level;
    let (mut buf, mut kids) = (Vec::with_capacity(WIDTH), Vec::with_capacity(WIDTH));
    while let Some((bin, slot, level)) = work.pop() {
        depth = depth.max(level);
        children(bvh2, collapse, bin, &mut buf, &mut kids);
        let mut refs = [EMPTY; WIDTH];
        for (r, &k) in refs.iter_mut().zip(&kids) {
            *r = match k {
                Ok(prim) => prim,
                Err(b) => {
                    nodes.push(Node8::EMPTY);
                    work.push((b, nodes.len() - 1, level + 1));
                    (nodes.len() - 1) as Ref
                }
            };
        }
        nodes[slot].child = refs;
    }
    let mut content = vec![NONE; nodes.len()];
    for n in (0..nodes.len()).rev() {
        assert!(
            nodes[n]
                .child
                .iter()
                .all(|&r| r & LEAF != 0 || r as usize > n),
            "children follow their parents"
        );
        content[n] = fill_boxes(&mut nodes[n], boxes, &content);
    }
    (nodes, content[0], depth)
}

/// The 8-wide nodes of the collapse of `bvh2` (whose root is an inner node), the root first,
/// with the exact boxes of what lies below each child (`boxes`: the primitives'), and the
/// number of node levels on the longest path.
pub(super) fn nodes(bvh2: &Bvh2, collapse: &Collapse, boxes: &[Bounds]) -> (Vec<Node8>, usize) {
    // The first levels, breadth first: each node's binary node and level, and its children
    // (a node's `Err(j)`: the `j`-th node of the next level).
    let mut first: Vec<(usize, usize)> = vec![(0, 1)];
    let mut first_kids: Vec<[Kid; WIDTH]> = Vec::new();
    let (mut buf, mut kids) = (Vec::with_capacity(WIDTH), Vec::with_capacity(WIDTH));
    let mut start = 0;
    // The level whose nodes root the subtrees (empty when the first levels are all).
    let tasks = loop {
        let end = first.len();
        let mut next = Vec::new();
        for &(bin, level) in &first[start..end] {
            children(bvh2, collapse, bin, &mut buf, &mut kids);
            let mut refs = [Ok(EMPTY); WIDTH];
            for (r, &k) in refs.iter_mut().zip(&kids) {
                *r = k.map_err(|b| {
                    next.push((b, level + 1));
                    next.len() - 1
                });
            }
            first_kids.push(refs);
        }
        if next.len() >= TASKS {
            break next;
        }
        if next.is_empty() {
            break Vec::new();
        }
        first.extend(next);
        start = end;
    };
    let blocks: Vec<(Vec<Node8>, Bounds, usize)> = tasks
        .par_iter()
        .with_min_len(crate::threads::min_len())
        .map(|&task| subtree(bvh2, collapse, boxes, task))
        .collect();
    // Block `j` starts at `offsets[j]`, after the first levels.
    let mut offsets = Vec::with_capacity(blocks.len());
    let mut total = first.len();
    for b in &blocks {
        offsets.push(total);
        total += b.0.len();
    }
    let mut out: Vec<Node8> = Vec::with_capacity(total);
    crate::huge_pages::advise(&mut out);
    {
        let (head, mut rest) = out.spare_capacity_mut()[..total].split_at_mut(first.len());
        let mut parts = Vec::with_capacity(blocks.len());
        for (b, &off) in blocks.iter().zip(&offsets) {
            parts.push((split_off(&mut rest, b.0.len()), &b.0, off as Ref));
        }
        // Each block moved to its place, its node references shifted with it.
        parts
            .into_par_iter()
            .with_min_len(crate::threads::min_len())
            .for_each(|(dst, block, off)| {
                for (d, n) in dst.iter_mut().zip(block) {
                    let mut n = *n;
                    for r in &mut n.child {
                        if *r != EMPTY && *r & LEAF == 0 {
                            *r += off;
                        }
                    }
                    d.write(n);
                }
            });
        // The first levels from the back: a node of the last one refers to the blocks, the
        // others to the next level (which starts where the node's own level ends).
        let mut content = vec![NONE; first.len()];
        let last = start;
        let mut level_end = first.len();
        for i in (0..first.len()).rev() {
            if i < start && first[i].1 != first[i + 1].1 {
                level_end = i + 1;
            }
            // Each child's reference and the union of what lies below it: a primitive's box,
            // a block root's union, or a next level's node's (in `content`).
            let mut node = Node8::EMPTY;
            let mut all = NONE;
            for (c, k) in first_kids[i].into_iter().enumerate() {
                let child = match k {
                    Ok(EMPTY) => continue,
                    Ok(r) => (r, boxes[(r & !LEAF) as usize]),
                    Err(j) if i >= last => (offsets[j] as Ref, blocks[j].1),
                    Err(j) => ((level_end + j) as Ref, content[level_end + j]),
                };
                set_child(&mut node, c, child, &mut all);
            }
            content[i] = all;
            head[i].write(node);
        }
    }
    // SAFETY: the first `first.len()` items were written above, one per node of the first
    // levels, and each block's part (its exact length) by its worker: all `total` items.
    unsafe { out.set_len(total) };
    let depth = blocks
        .iter()
        .map(|b| b.2)
        .chain(first.iter().map(|f| f.1))
        .max()
        .unwrap_or(1);
    (out, depth)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::harness::rng::SplitMix64;

    /// The nodes one by one from the root, as the emission before this module made them
    /// (serially, each node's children numbered when it is emitted, the last pushed emitted
    /// first), with their boxes; and the deepest level.
    fn serial(bvh2: &Bvh2, collapse: &Collapse, boxes: &[Bounds]) -> (Vec<Node8>, usize) {
        let (nodes, _, depth) = subtree(bvh2, collapse, boxes, (0, 1));
        (nodes, depth)
    }

    /// Trees `a` and `b` below references `ra` and `rb` are the same: the same primitives
    /// and boxes in the same child slots, node for node.
    fn same(a: &[Node8], ra: Ref, b: &[Node8], rb: Ref) -> bool {
        if ra & LEAF != 0 || rb & LEAF != 0 {
            return ra == rb;
        }
        let (na, nb) = (&a[ra as usize], &b[rb as usize]);
        na.boxes == nb.boxes
            && na
                .child
                .iter()
                .zip(&nb.child)
                .all(|(&x, &y)| (x == EMPTY) == (y == EMPTY) && (x == EMPTY || same(a, x, b, y)))
    }

    /// The nodes emitted level by level and in blocks side by side are the serial emission's
    /// tree, node for node with the same boxes and depth, laid out with children after their
    /// parents, and the same at one thread; on random boxes from a handful to seventy (no
    /// level of sixteen wide nodes: no blocks) and from 600 to 40,000 (blocks).
    #[test]
    fn blocks_side_by_side_are_the_serial_tree() {
        let mut rng = SplitMix64(43);
        for n in [2usize, 9, 70, 600, 5_000, 40_000] {
            let boxes: Vec<Bounds> = (0..n)
                .map(|_| {
                    let c: [f32; 3] = std::array::from_fn(|_| (rng.next_f64() * 10.0) as f32);
                    let e: [f32; 3] = std::array::from_fn(|_| (rng.next_f64() * 0.2) as f32);
                    [c, std::array::from_fn(|a| c[a] + e[a])]
                })
                .collect();
            let bvh2 = super::super::binned::build(&boxes);
            let collapse = Collapse::new(&bvh2);
            let (want, want_depth) = serial(&bvh2, &collapse, &boxes);
            // The widest level of wide nodes: blocks are emitted side by side below the first
            // level of at least `TASKS` nodes, which the larger trees have.
            let (mut level, mut widest) = (vec![0 as Ref], 1);
            while !level.is_empty() {
                level = level
                    .iter()
                    .flat_map(|&r| want[r as usize].child)
                    .filter(|&r| r != EMPTY && r & LEAF == 0)
                    .collect();
                widest = widest.max(level.len());
            }
            assert_eq!(
                widest >= TASKS,
                n >= 600,
                "n {n}: blocks below a wide level"
            );
            let (got, depth) = nodes(&bvh2, &collapse, &boxes);
            assert_eq!(got.len(), want.len(), "n {n}: node count");
            assert_eq!(depth, want_depth, "n {n}: depth");
            assert!(same(&got, 0, &want, 0), "n {n}: the same tree");
            for (i, node) in got.iter().enumerate() {
                assert!(
                    node.child
                        .iter()
                        .all(|&r| r == EMPTY || r & LEAF != 0 || r as usize > i),
                    "n {n}: node {i}'s children follow it"
                );
            }
            let one = crate::threads::pool(1).unwrap();
            let (alone, _) = one.install(|| nodes(&bvh2, &collapse, &boxes));
            assert!(alone == got, "n {n}: the same nodes at one thread");
        }
    }
}
