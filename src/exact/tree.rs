//! A bounding-volume hierarchy in `f64` over the root pieces of the limit surface: boxes of
//! the pieces' hull points, padded for rounding, split at the median of the longest axis.

/// An axis-aligned box `[lo, hi]`.
pub type Aabb = ([f64; 3], [f64; 3]);

/// A node: inner (`count == 0`, children `first` and `first + 1`) or a leaf (`count` items
/// from `first` in [`PieceTree::items`]).
#[derive(Clone, Copy, Debug)]
pub struct Node {
    /// The node's box.
    pub bounds: Aabb,
    /// First child or first item.
    pub first: u32,
    /// Items in a leaf; 0 for inner nodes.
    pub count: u32,
}

/// The hierarchy.
#[derive(Clone, Debug, Default)]
pub struct PieceTree {
    /// Nodes, the root first.
    pub nodes: Vec<Node>,
    /// Item indices, leaf by leaf.
    pub items: Vec<u32>,
}

const LEAF: usize = 4;

fn union(a: &Aabb, b: &Aabb) -> Aabb {
    (
        std::array::from_fn(|i| a.0[i].min(b.0[i])),
        std::array::from_fn(|i| a.1[i].max(b.1[i])),
    )
}

const EMPTY: Aabb = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);

impl PieceTree {
    /// Builds the tree over `boxes`.
    pub fn build(boxes: &[Aabb]) -> PieceTree {
        let mut tree = PieceTree {
            nodes: Vec::with_capacity(2 * boxes.len() / LEAF + 1),
            items: (0..boxes.len() as u32).collect(),
        };
        if boxes.is_empty() {
            return tree;
        }
        tree.nodes.push(Node {
            bounds: EMPTY,
            first: 0,
            count: 0,
        });
        let mut stack = vec![(0usize, 0usize, boxes.len())];
        while let Some((node, lo, hi)) = stack.pop() {
            let items = &mut tree.items[lo..hi];
            let bounds = items
                .iter()
                .fold(EMPTY, |b, &i| union(&b, &boxes[i as usize]));
            if hi - lo <= LEAF {
                tree.nodes[node] = Node {
                    bounds,
                    first: lo as u32,
                    count: (hi - lo) as u32,
                };
                continue;
            }
            let centre = |i: u32, a: usize| boxes[i as usize].0[a] + boxes[i as usize].1[a];
            let mut cb = EMPTY;
            for &i in items.iter() {
                let c: [f64; 3] = std::array::from_fn(|a| 0.5 * centre(i, a));
                cb = union(&cb, &(c, c));
            }
            let axis = (0..3)
                .max_by(|&a, &b| (cb.1[a] - cb.0[a]).total_cmp(&(cb.1[b] - cb.0[b])))
                .unwrap_or(0);
            let m = items.len() / 2;
            items.select_nth_unstable_by(m, |&a, &b| centre(a, axis).total_cmp(&centre(b, axis)));
            let first = tree.nodes.len();
            for _ in 0..2 {
                tree.nodes.push(Node {
                    bounds: EMPTY,
                    first: 0,
                    count: 0,
                });
            }
            tree.nodes[node] = Node {
                bounds,
                first: first as u32,
                count: 0,
            };
            stack.push((first, lo, lo + m));
            stack.push((first + 1, lo + m, hi));
        }
        tree
    }
}

/// The parameter interval `[t0, t1]` where the ray `o + t d` (`inv` = 1/d per axis) is in
/// box `b`, if it meets it with `t1 ≥ 0`.
pub fn slab(b: &Aabb, o: &[f64; 3], inv: &[f64; 3]) -> Option<(f64, f64)> {
    let (mut t0, mut t1) = (f64::NEG_INFINITY, f64::INFINITY);
    for a in 0..3 {
        if inv[a].is_infinite() {
            // Parallel to the slab: inside or not at all.
            if o[a] < b.0[a] || o[a] > b.1[a] {
                return None;
            }
            continue;
        }
        let (x, y) = ((b.0[a] - o[a]) * inv[a], (b.1[a] - o[a]) * inv[a]);
        t0 = t0.max(x.min(y));
        t1 = t1.min(x.max(y));
    }
    // Widen by the rounding of the products above.
    let w = 4.0 * f64::EPSILON * (t0.abs().max(t1.abs()));
    let (t0, t1) = (t0 - w, t1 + w);
    (t0 <= t1 && t1 >= 0.0).then_some((t0, t1))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_item_is_in_one_leaf_inside_its_box() {
        let boxes: Vec<Aabb> = (0..37)
            .map(|i| {
                let x = i as f64;
                ([x, -x, 0.5 * x], [x + 1.0, -x + 2.0, 0.5 * x + 0.25])
            })
            .collect();
        let t = PieceTree::build(&boxes);
        let mut seen = vec![0; boxes.len()];
        for n in &t.nodes {
            if n.count > 0 {
                for &i in &t.items[n.first as usize..(n.first + n.count) as usize] {
                    seen[i as usize] += 1;
                    let b = &boxes[i as usize];
                    assert!((0..3).all(|a| n.bounds.0[a] <= b.0[a] && b.1[a] <= n.bounds.1[a]));
                }
            }
        }
        assert!(seen.iter().all(|&c| c == 1));
        assert!(slab(
            &boxes[3],
            &[3.5, 10.0, 1.6],
            &[f64::INFINITY, -1.0, f64::INFINITY]
        )
        .is_some());
        assert!(slab(
            &boxes[3],
            &[3.5, 10.0, 1.6],
            &[f64::INFINITY, 1.0, f64::INFINITY]
        )
        .is_none());
    }
}
