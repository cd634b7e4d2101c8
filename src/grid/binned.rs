//! The top level's binary tree: built top down by binned surface-area-heuristic splits, one
//! primitive per leaf, then collapsed 8 wide by [`super::collapse`].
//!
//! A split bins the cluster's box centres in up to [`BINS`] equal bins along each axis of the
//! centres' bounds (as many bins as items below that: a small cluster's split costs what its
//! items do), keeping each bin's count and the union of its boxes, and takes the plane
//! between bins of least `area(left) · count(left) + area(right) · count(right)`; a cluster
//! whose centres fall in one bin on every axis is halved by its order. Every node's box is
//! the union of its primitives' boxes (`f32` minimum and maximum: exact, whatever the order).
//!
//! Boxes are four `f32` lanes (the fourth unused), unions and bin indices taken four lanes at
//! once, and consecutive items are binned into two sets of bins that are merged after (an
//! item's bin is often the previous item's: one set would wait on its own last store).
//! Clusters of at least [`PARALLEL`] items with both halves not too unequal build their
//! halves side by side (rayon) into node ranges fixed by their counts: the tree is the same,
//! node for node, at any thread count.

use super::top::Bounds;
use glam::Vec3A;
use obvhs::aabb::Aabb;
use obvhs::bvh2::{node::Bvh2Node, Bvh2};

/// Bins per axis, at most.
const BINS: usize = 32;

/// Clusters of at most this many items are split exactly ([`split_small`]).
const SMALL: usize = 32;

/// Binary levels split by the surface area heuristic; deeper clusters are halved at their
/// median ([`split_median`]). Splits that cut off a few items at a time (centres spaced
/// geometrically, say) would otherwise make the build quadratic; with this bound a build visits
/// each item at most `DEEP + log₂ n` times.
const DEEP: usize = 48;

/// Clusters of at least this many items may build their halves in parallel.
const PARALLEL: usize = 4096;

/// A lane-by-lane operation on two [`F4`]s: one SSE instruction (`$sse`) on x86_64, exactly the
/// scalar `$scalar` on each lane elsewhere (IEEE operations: the same bits).
macro_rules! lanes {
    ($a:expr, $b:expr, $sse:ident, $scalar:expr) => {{
        #[cfg(target_arch = "x86_64")]
        // SAFETY: SSE is part of x86_64; `F4` is 16 bytes, aligned to 16.
        unsafe {
            use std::arch::x86_64::{_mm_load_ps, _mm_store_ps, $sse};
            let mut out = F4([0.0; 4]);
            _mm_store_ps(
                out.0.as_mut_ptr(),
                $sse(_mm_load_ps($a.0.as_ptr()), _mm_load_ps($b.0.as_ptr())),
            );
            out
        }
        #[cfg(not(target_arch = "x86_64"))]
        {
            let f = $scalar;
            F4(std::array::from_fn(|i| f($a.0[i], $b.0[i])))
        }
    }};
}

/// Four `f32` lanes: `x`, `y`, `z` and one unused.
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C, align(16))]
struct F4([f32; 4]);

impl F4 {
    const INF: F4 = F4([f32::INFINITY; 4]);
    const NEG_INF: F4 = F4([f32::NEG_INFINITY; 4]);

    /// Lane by lane `a < b ? a : b` (`minps` exactly; never given a NaN here).
    #[inline(always)]
    fn min(self, b: F4) -> F4 {
        lanes!(self, b, _mm_min_ps, |x: f32, y: f32| if x < y {
            x
        } else {
            y
        })
    }

    /// Lane by lane `a > b ? a : b` (`maxps` exactly).
    #[inline(always)]
    fn max(self, b: F4) -> F4 {
        lanes!(self, b, _mm_max_ps, |x: f32, y: f32| if x > y {
            x
        } else {
            y
        })
    }

    #[inline(always)]
    fn add(self, b: F4) -> F4 {
        lanes!(self, b, _mm_add_ps, |x: f32, y: f32| x + y)
    }

    #[inline(always)]
    fn sub(self, b: F4) -> F4 {
        lanes!(self, b, _mm_sub_ps, |x: f32, y: f32| x - y)
    }

    #[inline(always)]
    fn mul(self, b: F4) -> F4 {
        lanes!(self, b, _mm_mul_ps, |x: f32, y: f32| x * y)
    }

    /// The lanes truncated towards zero (`cvttps2dq`; every lane in `i32`'s range).
    #[inline(always)]
    fn trunc(self) -> [i32; 4] {
        #[cfg(target_arch = "x86_64")]
        // SAFETY: SSE2 is part of x86_64; `F4` is 16 bytes, aligned to 16.
        unsafe {
            use std::arch::x86_64::{_mm_cvttps_epi32, _mm_load_ps, _mm_storeu_si128};
            let mut out = [0i32; 4];
            _mm_storeu_si128(
                out.as_mut_ptr().cast(),
                _mm_cvttps_epi32(_mm_load_ps(self.0.as_ptr())),
            );
            out
        }
        #[cfg(not(target_arch = "x86_64"))]
        // SAFETY: the caller's lanes are in range (see above).
        std::array::from_fn(|k| unsafe { self.0[k].to_int_unchecked::<i32>() })
    }

    fn xyz(self) -> [f32; 3] {
        [self.0[0], self.0[1], self.0[2]]
    }
}

/// A primitive, 32 bytes (moved whole when clusters are split): its box, and its index in the
/// fourth lane of `lo` (as bits; [`Item::lo`] clears it).
#[derive(Clone, Copy)]
#[repr(C, align(32))]
struct Item {
    lo_id: F4,
    hi: F4,
}

impl Item {
    /// The box's lower corner, fourth lane zero.
    #[inline(always)]
    fn lo(&self) -> F4 {
        // All ones in the first three lanes: the fourth (the id's bits) becomes +0.
        const KEEP: F4 = F4([
            f32::from_bits(u32::MAX),
            f32::from_bits(u32::MAX),
            f32::from_bits(u32::MAX),
            0.0,
        ]);
        lanes!(self.lo_id, KEEP, _mm_and_ps, |x: f32, k: f32| {
            f32::from_bits(x.to_bits() & k.to_bits())
        })
    }

    fn id(&self) -> u32 {
        self.lo_id.0[3].to_bits()
    }

    /// Twice the box centre (fourth lane zero; the factor is the same for every item).
    #[inline(always)]
    fn centre(&self) -> F4 {
        self.lo().add(self.hi)
    }
}

/// Half the surface area of a box; zero when empty.
fn area(lo: F4, hi: F4) -> f32 {
    let d = hi.sub(lo).0;
    if d[0] < 0.0 {
        return 0.0;
    }
    d[0] * d[1] + d[1] * d[2] + d[2] * d[0]
}

/// A run of items: its range in the build's item array, the union of its boxes and the
/// bounds of its (doubled) centres.
#[derive(Clone, Copy)]
struct Cluster {
    begin: usize,
    end: usize,
    lo: F4,
    hi: F4,
    centre_lo: F4,
    centre_hi: F4,
}

impl Cluster {
    fn len(&self) -> usize {
        self.end - self.begin
    }

    /// The cluster of `items` (which start at `begin`).
    fn of(items: &[Item], begin: usize) -> Cluster {
        let mut c = Cluster {
            begin,
            end: begin + items.len(),
            lo: F4::INF,
            hi: F4::NEG_INF,
            centre_lo: F4::INF,
            centre_hi: F4::NEG_INF,
        };
        // One pass: the boxes' union and the centres' bounds, each in item order.
        let (mut lo, mut hi) = (F4::INF, F4::NEG_INF);
        for it in items {
            let l = it.lo();
            c.lo = c.lo.min(l);
            c.hi = c.hi.max(it.hi);
            let m = l.add(it.hi);
            lo = lo.min(m);
            hi = hi.max(m);
        }
        (c.centre_lo, c.centre_hi) = (lo, hi);
        c
    }

    /// The clusters of `items[..mid]` and `items[mid..]` (`items` start at `begin`).
    fn halves(items: &[Item], begin: usize, mid: usize) -> (Cluster, Cluster) {
        (
            Cluster::of(&items[..mid], begin),
            Cluster::of(&items[mid..], begin + mid),
        )
    }

    /// The axis along which the centres spread most (the first of equals).
    fn widest_axis(&self) -> usize {
        let e = self.centre_hi.sub(self.centre_lo).0;
        if e[0] >= e[1] && e[0] >= e[2] {
            0
        } else if e[1] >= e[2] {
            1
        } else {
            2
        }
    }
}

/// One bin: the union of the boxes whose centres fell in it, and how many.
#[derive(Clone, Copy)]
struct Bin {
    lo: F4,
    hi: F4,
    count: u32,
}

const EMPTY_BIN: Bin = Bin {
    lo: F4::INF,
    hi: F4::NEG_INF,
    count: 0,
};

/// How a cluster's centres map to bins: per axis, the bin of centre `m` is
/// `min(max((m − lo) · scale, 0), last)` truncated (a NaN product is bin 0).
struct Binning {
    lo: F4,
    scale: F4,
    last: F4,
}

impl Binning {
    /// The three axes' bins of `it`.
    #[inline(always)]
    fn of(&self, it: &Item) -> [usize; 3] {
        self.bins(it.centre())
    }

    /// Axis `a`'s bin of the (doubled) centre `m`: lane `a` of [`Self::bins`].
    #[inline(always)]
    fn bin_of(&self, m: F4, a: usize) -> usize {
        self.bins(m)[a]
    }

    /// The three axes' bins of the (doubled) centre `m`.
    #[inline(always)]
    fn bins(&self, m: F4) -> [usize; 3] {
        let x = m
            .sub(self.lo)
            .mul(self.scale)
            .max(F4([0.0; 4]))
            .min(self.last);
        // Each lane is in 0..=last (a NaN gave way to 0 in `max`): truncation is in range.
        let i = x.trunc();
        [i[0] as usize, i[1] as usize, i[2] as usize]
    }
}

/// Splits a cluster of at most [`SMALL`] items (`items`) at the exact best plane across the
/// widest axis of its centres: the items sorted along it (stably), every position tried.
fn split_small(items: &mut [Item], c: &Cluster) -> (Cluster, Cluster) {
    let n = items.len();
    let a = c.widest_axis();
    if n == 2 {
        // The stable order of two, and its one position.
        if items[1].centre().0[a] < items[0].centre().0[a] {
            items.swap(0, 1);
        }
        return Cluster::halves(items, c.begin, 1);
    }
    // A stable insertion sort of the items by their centres along `a` (the keys beside).
    let mut keys = [0f32; SMALL];
    for i in 0..n {
        let it = items[i];
        let key = it.centre().0[a];
        let mut j = i;
        while j > 0 && keys[j - 1] > key {
            keys[j] = keys[j - 1];
            items[j] = items[j - 1];
            j -= 1;
        }
        keys[j] = key;
        items[j] = it;
    }
    let mut right_area = [0f32; SMALL];
    let (mut lo, mut hi) = (F4::INF, F4::NEG_INF);
    for i in (1..n).rev() {
        lo = lo.min(items[i].lo());
        hi = hi.max(items[i].hi);
        right_area[i] = area(lo, hi);
    }
    let (mut lo, mut hi) = (F4::INF, F4::NEG_INF);
    let mut best = (f32::INFINITY, n / 2);
    for i in 1..n {
        lo = lo.min(items[i - 1].lo());
        hi = hi.max(items[i - 1].hi);
        let cost = area(lo, hi) * i as f32 + right_area[i] * (n - i) as f32;
        if cost < best.0 {
            best = (cost, i);
        }
    }
    let mid = best.1;
    Cluster::halves(items, c.begin, mid)
}

/// Halves a cluster (`items`) at the median of its centres along their widest axis.
fn split_median(items: &mut [Item], c: &Cluster) -> (Cluster, Cluster) {
    let a = c.widest_axis();
    let mid = items.len() / 2;
    items.select_nth_unstable_by(mid, |x, y| x.centre().0[a].total_cmp(&y.centre().0[a]));
    Cluster::halves(items, c.begin, mid)
}

/// Splits the cluster `c`, whose items are `items` (`items[0]` is item `c.begin`), in two:
/// the items are reordered in place, left part first. `bins` is scratch space.
fn split(items: &mut [Item], c: &Cluster, bins: &mut [[[Bin; BINS]; 3]; 2]) -> (Cluster, Cluster) {
    let n = items.len();
    debug_assert!(n >= 2);
    if n <= SMALL {
        return split_small(items, c);
    }
    let nb = n.min(BINS);
    let mut scale = F4([0.0; 4]);
    for a in 0..3 {
        let extent = c.centre_hi.0[a] - c.centre_lo.0[a];
        if extent > 0.0 && extent.is_finite() {
            scale.0[a] = nb as f32 / extent;
        }
    }
    let binning = Binning {
        lo: c.centre_lo,
        scale,
        last: F4([(nb - 1) as f32; 4]),
    };
    for set in bins.iter_mut() {
        for axis in set.iter_mut() {
            axis[..nb].fill(EMPTY_BIN);
        }
    }
    let bin = |it: &Item, bins: &mut [[Bin; BINS]; 3]| {
        let k = binning.of(it);
        let lo = it.lo();
        for a in 0..3 {
            let b = &mut bins[a][k[a]];
            b.lo = b.lo.min(lo);
            b.hi = b.hi.max(it.hi);
            b.count += 1;
        }
    };
    let [even, odd] = bins;
    let mut pairs = items.chunks_exact(2);
    for p in &mut pairs {
        bin(&p[0], even);
        bin(&p[1], odd);
    }
    if let [last] = pairs.remainder() {
        bin(last, even);
    }
    for a in 0..3 {
        for k in 0..nb {
            even[a][k].lo = even[a][k].lo.min(odd[a][k].lo);
            even[a][k].hi = even[a][k].hi.max(odd[a][k].hi);
            even[a][k].count += odd[a][k].count;
        }
    }
    // The best plane: after bin `k` of axis `a`, of least cost.
    let mut best: Option<(f32, usize, usize)> = None;
    for a in 0..3 {
        if scale.0[a] == 0.0 {
            continue;
        }
        let mut right_area = [0f32; BINS];
        let (mut lo, mut hi) = (F4::INF, F4::NEG_INF);
        for k in (1..nb).rev() {
            lo = lo.min(even[a][k].lo);
            hi = hi.max(even[a][k].hi);
            right_area[k] = area(lo, hi);
        }
        let (mut lo, mut hi, mut left) = (F4::INF, F4::NEG_INF, 0u32);
        for k in 0..nb - 1 {
            lo = lo.min(even[a][k].lo);
            hi = hi.max(even[a][k].hi);
            left += even[a][k].count;
            let right = n as u32 - left;
            if left == 0 || right == 0 {
                continue;
            }
            let cost = area(lo, hi) * left as f32 + right_area[k + 1] * right as f32;
            if best.is_none_or(|(b, _, _)| cost < b) {
                best = Some((cost, a, k));
            }
        }
    }
    let Some((_, a, k)) = best else {
        // Every centre in one bin on every axis (equal centres): halve by order.
        return Cluster::halves(items, c.begin, n / 2);
    };
    // Items whose bin is at most `k` go left; each side's centre bounds are taken as its
    // items are classified (each item on the side it ends on; the one where the two scans
    // meet may be classified twice, the same way, which bounds do not mind).
    let mut centres = [(F4::INF, F4::NEG_INF); 2];
    let mut classify = |it: &Item| {
        let m = it.centre();
        let left = binning.bin_of(m, a) <= k;
        let s = &mut centres[usize::from(!left)];
        s.0 = s.0.min(m);
        s.1 = s.1.max(m);
        left
    };
    let (mut l, mut r) = (0, n);
    loop {
        while l < r && classify(&items[l]) {
            l += 1;
        }
        while l < r && !classify(&items[r - 1]) {
            r -= 1;
        }
        if l >= r {
            break;
        }
        items.swap(l, r - 1);
        l += 1;
        r -= 1;
    }
    // Each side's box: its bins' union (the partition used the bins' own index).
    let side = |bins: &[Bin], begin: usize, end: usize, (centre_lo, centre_hi): (F4, F4)| {
        let mut s = Cluster {
            begin: c.begin + begin,
            end: c.begin + end,
            lo: F4::INF,
            hi: F4::NEG_INF,
            centre_lo,
            centre_hi,
        };
        for b in bins {
            s.lo = s.lo.min(b.lo);
            s.hi = s.hi.max(b.hi);
        }
        s
    };
    (
        side(&even[a][..=k], 0, l, centres[0]),
        side(&even[a][k + 1..nb], l, n, centres[1]),
    )
}

/// A node of the binary tree: a leaf holds item `first` (its position in the final item
/// order), an inner node's children are nodes `first` and `first + 1`.
fn node2(c: &Cluster, leaf: bool, first: usize) -> Bvh2Node {
    let aabb = Aabb::new(Vec3A::from(c.lo.xyz()), Vec3A::from(c.hi.xyz()));
    Bvh2Node::new(aabb, u32::from(leaf), first as u32)
}

/// Builds what lies below the node of cluster `whole` (items `items`, at least two):
/// `below` holds its `2 · len − 2` descendants, `below[0]` being node `at`. The two children
/// of a node come first in its range, then the first child's descendants, then the second's:
/// every subtree's range is known from its count alone, so the halves of a large cluster are
/// built side by side into disjoint ranges. `depth` is the node's binary level.
fn build_below(
    items: &mut [Item],
    whole: Cluster,
    below: &mut [Bvh2Node],
    at: usize,
    depth: usize,
) {
    debug_assert_eq!(below.len(), 2 * whole.len() - 2);
    let base = whole.begin;
    let mut bins = [[[EMPTY_BIN; BINS]; 3]; 2];
    // Clusters to split (at least two items), with the start of their descendants' range and
    // their level.
    let mut work = vec![(whole, 0, depth)];
    while let Some((c, start, depth)) = work.pop() {
        let mine = &mut items[c.begin - base..c.end - base];
        let (l, r) = if depth < DEEP {
            split(mine, &c, &mut bins)
        } else {
            split_median(mine, &c)
        };
        // The first child's descendants start after the two children, the second's after
        // the first's.
        let (l_start, r_start) = (start + 2, start + 2 + 2 * l.len() - 2);
        for (k, (side, from)) in [(l, l_start), (r, r_start)].into_iter().enumerate() {
            below[start + k] = if side.len() == 1 {
                node2(&side, true, side.begin)
            } else {
                node2(&side, false, at + from)
            };
        }
        if c.len() >= PARALLEL && l.len().min(r.len()) >= (c.len() / 8).max(2) {
            // Halves at least an eighth each: the recursion is at most log₈⁄₇ of the
            // count deep.
            let (li, ri) = mine.split_at_mut(l.len());
            let (lb, rb) = below[l_start..start + 2 * c.len() - 2].split_at_mut(2 * l.len() - 2);
            rayon::join(
                || build_below(li, l, lb, at + l_start, depth + 1),
                || build_below(ri, r, rb, at + r_start, depth + 1),
            );
            continue;
        }
        // The second child is pushed first: the first is split next.
        if r.len() >= 2 {
            work.push((r, r_start, depth + 1));
        }
        if l.len() >= 2 {
            work.push((l, l_start, depth + 1));
        }
    }
}

/// The items of `boxes`, each with its index as its id.
fn items_of(boxes: &[Bounds]) -> Vec<Item> {
    boxes
        .iter()
        .enumerate()
        .map(|(i, b)| Item {
            lo_id: F4([b[0][0], b[0][1], b[0][2], f32::from_bits(i as u32)]),
            hi: F4([b[1][0], b[1][1], b[1][2], 0.0]),
        })
        .collect()
}

/// The binary BVH over `boxes` (at least two, finite), one primitive per leaf, children
/// after their parents.
pub(super) fn build(boxes: &[Bounds]) -> Bvh2 {
    debug_assert!(boxes.len() >= 2);
    let mut items = items_of(boxes);
    let whole = Cluster::of(&items, 0);
    // A binary tree of `n` leaves has `2n − 1` nodes: the root, then its descendants.
    let mut nodes = vec![node2(&whole, false, 1); 2 * boxes.len() - 1];
    build_below(&mut items, whole, &mut nodes[1..], 1, 0);
    Bvh2 {
        nodes,
        primitive_indices: items.iter().map(Item::id).collect(),
        ..Bvh2::default()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::harness::rng::SplitMix64;

    /// Random boxes: `n` of them, centres in a 10-unit cube (a quarter of them on a few
    /// shared centres, so that bins and the halving by order are both met).
    fn boxes(rng: &mut SplitMix64, n: usize) -> Vec<Bounds> {
        (0..n)
            .map(|i| {
                let c: [f32; 3] = if i % 4 == 0 {
                    [(i % 3) as f32; 3]
                } else {
                    std::array::from_fn(|_| (rng.next_f64() * 10.0) as f32)
                };
                let e: [f32; 3] = std::array::from_fn(|_| (rng.next_f64() * 0.5) as f32);
                [
                    std::array::from_fn(|a| c[a] - e[a]),
                    std::array::from_fn(|a| c[a] + e[a]),
                ]
            })
            .collect()
    }

    /// `split_small` is its specification: the items in the stable order of their centres
    /// along the widest axis, cut at the first position of least surface-area cost, each
    /// half's box and centre bounds those of its items (the unions taken in item order); on
    /// clusters of 2 to 32 random boxes, with shared centres and signed zeros among them.
    #[test]
    fn small_splits_are_their_specification() {
        let mut rng = SplitMix64::new(11);
        let bits = |f: F4| f.0.map(f32::to_bits);
        for round in 0..3000 {
            let n = 2 + round % (SMALL - 1);
            let mut b = boxes(&mut rng, n);
            for (i, x) in b.iter_mut().enumerate() {
                if i % 5 == 1 {
                    // Boxes of zero extent at ±0 on some axes (centres tie, unions meet −0).
                    let a = i % 3;
                    let z = if rng.next_f64() < 0.5 { -0.0 } else { 0.0 };
                    x[0][a] = z;
                    x[1][a] = z;
                }
            }
            let items = items_of(&b);
            let begin = 7;
            let whole = Cluster::of(&items, begin);
            // The specification, computed plainly.
            let a = whole.widest_axis();
            let mut order: Vec<Item> = items.clone();
            order.sort_by(|x, y| x.centre().0[a].partial_cmp(&y.centre().0[a]).unwrap());
            let union = |its: &[Item]| {
                let (mut lo, mut hi) = (F4::INF, F4::NEG_INF);
                for it in its {
                    lo = lo.min(it.lo());
                    hi = hi.max(it.hi);
                }
                (lo, hi)
            };
            let centres = |its: &[Item]| {
                let (mut lo, mut hi) = (F4::INF, F4::NEG_INF);
                for it in its {
                    lo = lo.min(it.centre());
                    hi = hi.max(it.centre());
                }
                (lo, hi)
            };
            let mut mid = n / 2;
            let mut least = f32::INFINITY;
            for i in 1..n {
                let (l, r) = (union(&order[..i]), union(&order[i..]));
                let cost = area(l.0, l.1) * i as f32 + area(r.0, r.1) * (n - i) as f32;
                if cost < least {
                    (least, mid) = (cost, i);
                }
            }
            let mut got = items.clone();
            let (l, r) = split_small(&mut got, &whole);
            let ids = |its: &[Item]| its.iter().map(Item::id).collect::<Vec<_>>();
            assert_eq!(ids(&got), ids(&order), "round {round}: order");
            for (side, its, first) in [(l, &order[..mid], begin), (r, &order[mid..], begin + mid)] {
                assert_eq!(
                    (side.begin, side.len()),
                    (first, its.len()),
                    "round {round}"
                );
                let (lo, hi) = union(its);
                let (clo, chi) = centres(its);
                assert_eq!(
                    [side.lo, side.hi, side.centre_lo, side.centre_hi].map(bits),
                    [lo, hi, clo, chi].map(bits),
                    "round {round}: bounds"
                );
            }
        }
    }

    /// The union of the boxes of the leaves below node `n`, and the leaves' primitives.
    fn below(t: &Bvh2, boxes: &[Bounds], n: usize, prims: &mut Vec<u32>) -> Bounds {
        let node = &t.nodes[n];
        if node.prim_count != 0 {
            assert_eq!(node.prim_count, 1, "one primitive per leaf");
            let p = t.primitive_indices[node.first_index as usize];
            prims.push(p);
            return boxes[p as usize];
        }
        let f = node.first_index as usize;
        assert!(f > n, "children after their parents");
        let (a, b) = (below(t, boxes, f, prims), below(t, boxes, f + 1, prims));
        super::super::top::union(a, b)
    }

    /// Every primitive in exactly one leaf, `2n − 1` nodes, and every node's box the exact
    /// union (bit for bit) of its primitives' boxes; sizes from two items to clusters that
    /// build their halves in parallel.
    #[test]
    fn tree_holds_every_box_once_in_exact_boxes() {
        let mut rng = SplitMix64(77);
        for n in [2usize, 3, 5, 17, 32, 33, 100, 1000, 3 * PARALLEL] {
            let boxes = boxes(&mut rng, n);
            let t = build(&boxes);
            assert_eq!(t.nodes.len(), 2 * n - 1);
            let mut prims = Vec::new();
            let check = |i: usize| {
                let mut p = Vec::new();
                let want = below(&t, &boxes, i, &mut p);
                let got = t.nodes[i].aabb;
                assert_eq!(
                    [got.min.to_array(), got.max.to_array()],
                    want,
                    "n {n}, node {i}"
                );
                p
            };
            prims.extend(check(0));
            for i in 1..t.nodes.len() {
                check(i);
            }
            prims.sort_unstable();
            assert_eq!(prims, (0..n as u32).collect::<Vec<_>>(), "n {n}");
        }
    }

    /// The same tree, node for node, on one thread and on four.
    #[test]
    fn tree_is_the_same_at_any_thread_count() {
        let mut rng = SplitMix64(78);
        let boxes = boxes(&mut rng, 5 * PARALLEL);
        let on = |threads: usize| {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            pool.install(|| build(&boxes))
        };
        let (a, b) = (on(1), on(4));
        assert_eq!(a.primitive_indices, b.primitive_indices);
        assert_eq!(a.nodes.len(), b.nodes.len());
        for (x, y) in a.nodes.iter().zip(&b.nodes) {
            assert_eq!(
                (x.aabb, x.prim_count, x.first_index),
                (y.aabb, y.prim_count, y.first_index)
            );
        }
    }

    /// Binary levels below node `n` (a leaf: 0).
    fn levels(t: &Bvh2, n: usize) -> usize {
        let node = &t.nodes[n];
        if node.prim_count != 0 {
            return 0;
        }
        let f = node.first_index as usize;
        1 + levels(t, f).max(levels(t, f + 1))
    }

    /// Boxes spaced and sized geometrically (each twice the last, over 71 orders of
    /// magnitude): the best planes cut off the largest boxes a few at a time (65 levels for
    /// 236 boxes). Below [`DEEP`] levels the clusters are halved instead, so the tree stays
    /// within `DEEP + log₂ n` levels (and its build linear in that depth).
    #[test]
    fn geometric_spacing_stays_within_the_depth_bound() {
        let n = 236usize;
        let boxes: Vec<Bounds> = (0..n)
            .map(|i| {
                let x = 2f32.powi(i as i32 - 120);
                [[x, 0.0, 0.0], [2.0 * x, 1.0, 1.0]]
            })
            .collect();
        let t = build(&boxes);
        let depth = levels(&t, 0);
        let bound = DEEP + (n as f64).log2().ceil() as usize;
        assert!(depth <= bound, "{depth} levels, bound {bound}");
        assert!(
            depth > DEEP,
            "{depth} levels: the median splits were not reached"
        );
    }

    /// Two groups of boxes far apart along one axis are the root's two children, whether
    /// the root is split by bins (many boxes) or exactly (few).
    #[test]
    fn far_groups_are_split_at_the_root() {
        let mut rng = SplitMix64(79);
        for (n, axis) in [(8usize, 0usize), (24, 1), (400, 2), (3000, 0)] {
            let mut boxes = boxes(&mut rng, n);
            // The odd boxes moved 1000 units along `axis`.
            for b in boxes.iter_mut().skip(1).step_by(2) {
                b[0][axis] += 1000.0;
                b[1][axis] += 1000.0;
            }
            let t = build(&boxes);
            let f = t.nodes[0].first_index as usize;
            for (k, side) in [f, f + 1].into_iter().enumerate() {
                let mut prims = Vec::new();
                below(&t, &boxes, side, &mut prims);
                let far = prims.iter().filter(|&&p| p % 2 == 1).count();
                assert!(
                    far == 0 || far == prims.len(),
                    "n {n}, child {k}: {far} of {} far",
                    prims.len()
                );
            }
        }
    }
}
