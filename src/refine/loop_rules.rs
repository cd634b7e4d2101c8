//! Loop subdivision masks with RenderMan creases (paper 002 §2, OpenSubdiv's Sdc semantics for
//! `SCHEME_LOOP`). Crease and corner rules, and the blending of a parent rule with its child
//! rule under fractional sharpness, are shared with Catmull-Clark ([`super::rules`]); only the
//! smooth edge and vertex rules are Loop's own.

use super::crease;
use super::rules::{vertex_mask_with, VertexRing};
use super::stencil::Accumulator;

/// Loop's smooth vertex weight per edge neighbour, `β(n) = (5/8 − (3/8 + 1/4·cos 2π/n)²) / n`
/// (Loop's thesis; OpenSubdiv's `Sdc::Scheme<SCHEME_LOOP>`). Valence 6 gives exactly 1/16.
pub fn beta(n: usize) -> f64 {
    if n == 6 {
        return 0.0625;
    }
    let nf = n as f64;
    let c = 0.375 + 0.25 * (2.0 * std::f64::consts::PI / nf).cos();
    (0.625 - c * c) / nf
}

/// Edge point of edge `a`–`b` with sharpness `s`; `opposite` holds, for each incident triangle,
/// its vertex off the edge. `child_sharp` tells whether both child edges are still sharp. Smooth
/// edges with two triangles take `3/8 (a + b) + 1/8 (c + d)`; sharp edges the midpoint; a
/// sharpness that ends at this level blends the two with weight `s` (unclamped, as in
/// [`super::rules::edge_mask`] and OpenSubdiv).
pub fn edge_mask(
    acc: &mut Accumulator,
    a: u32,
    b: u32,
    opposite: &[u32],
    s: f32,
    child_sharp: bool,
) {
    let crease_w = if opposite.len() != 2 {
        1.0
    } else if !crease::is_sharp(s) {
        0.0
    } else if child_sharp {
        1.0
    } else {
        s as f64
    };
    if crease_w > 0.0 {
        acc.add(a, 0.5 * crease_w);
        acc.add(b, 0.5 * crease_w);
    }
    let smooth_w = 1.0 - crease_w;
    if smooth_w != 0.0 {
        acc.add(a, 0.375 * smooth_w);
        acc.add(b, 0.375 * smooth_w);
        for &c in opposite {
            acc.add(c, 0.125 * smooth_w);
        }
    }
}

/// Vertex point under the Loop scheme (smooth rule: `1 − n·β(n)` of the vertex and `β(n)` of
/// each edge neighbour); `ring.faces` is not used.
pub fn vertex_mask(acc: &mut Accumulator, ring: &VertexRing) {
    vertex_mask_with(acc, ring, smooth_vertex_mask);
}

fn smooth_vertex_mask(acc: &mut Accumulator, ring: &VertexRing, scale: f64) {
    let n = ring.edge_ends.len();
    let b = beta(n);
    acc.add(ring.center, scale * (1.0 - n as f64 * b));
    for &end in ring.edge_ends {
        acc.add(end, scale * b);
    }
}

/// Weight of each edge neighbour in the limit position of a smooth interior vertex of valence
/// `n`: `χ = 1 / (n + 3 / (8 β(n)))`, the vertex keeping `1 − n χ` (the dominant left
/// eigenvector of Loop's subdivision matrix; valence 6 gives 1/12 and 1/2).
pub fn limit_weight(n: usize) -> f64 {
    if n == 6 {
        return 1.0 / 12.0;
    }
    1.0 / (n as f64 + 0.375 / beta(n))
}

/// Limit position mask of vertex `v` of a Loop level whose rule at `v` is stationary (no
/// semi-sharp vertex or incident edge), as `(vertex, weight)` terms: a corner stays, a crease
/// vertex takes the cubic B-spline limit `2/3 v + 1/6 (a + b)` of its two sharp edges, a smooth
/// vertex with no sharp edge Loop's limit mask ([`limit_weight`]). `None` for a dart (one sharp
/// edge), whose limit has no closed form here, and where anything is still semi-sharp.
pub fn stationary_limit_mask(level: &super::Level, v: usize) -> Option<Vec<(u32, f64)>> {
    let topo = &level.topo;
    let edges = topo.vertex_edges(v);
    let vs = level.vertex_sharpness[v];
    if crease::is_semi_sharp(vs)
        || edges
            .iter()
            .any(|&e| crease::is_semi_sharp(level.edge_sharpness[e as usize]))
    {
        return None;
    }
    let sharp: Vec<u32> = edges
        .iter()
        .filter(|&&e| crease::is_sharp(level.edge_sharpness[e as usize]))
        .map(|&e| topo.other_vertex(e, v as u32))
        .collect();
    match crease::vertex_rule(vs, sharp.len()) {
        crease::Rule::Corner => Some(vec![(v as u32, 1.0)]),
        crease::Rule::Crease => Some(vec![
            (v as u32, 2.0 / 3.0),
            (sharp[0], 1.0 / 6.0),
            (sharp[1], 1.0 / 6.0),
        ]),
        crease::Rule::Smooth if sharp.is_empty() && !edges.is_empty() => {
            let w = limit_weight(edges.len());
            let mut out = vec![(v as u32, 1.0 - edges.len() as f64 * w)];
            out.extend(edges.iter().map(|&e| (topo.other_vertex(e, v as u32), w)));
            Some(out)
        }
        crease::Rule::Smooth if edges.is_empty() => Some(vec![(v as u32, 1.0)]),
        crease::Rule::Smooth => None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::refine::stencil::StencilTable;

    fn row(acc: &mut Accumulator, n: usize) -> Vec<(u32, f64)> {
        let mut t = StencilTable::new(n);
        t.push_row(acc);
        let (idx, w) = t.row(0);
        let mut out: Vec<(u32, f64)> = idx.iter().copied().zip(w.iter().copied()).collect();
        out.sort_by_key(|p| p.0);
        out
    }

    #[test]
    fn beta_is_loops_weight() {
        // Closed forms: valence 3 gives 3/16 (Warren's choice coincides there), valence 6
        // gives 1/16, and the formula is continuous at 6.
        assert!((beta(3) - 3.0 / 16.0).abs() < 1e-15);
        assert_eq!(beta(6), 0.0625);
        let c: f64 = 0.375 + 0.25 * (std::f64::consts::PI / 3.0).cos();
        assert!(((0.625 - c * c) / 6.0 - 0.0625).abs() < 1e-16);
        // Valence 4: cos(π/2) = 0, β = (5/8 − 9/64)/4 = 31/256.
        assert!((beta(4) - 31.0 / 256.0).abs() < 1e-15);
    }

    #[test]
    fn limit_weight_is_the_fixed_point_of_the_masks() {
        // The limit mask is a left eigenvector (eigenvalue 1) of the ring's subdivision matrix
        // restricted to the vertex and its edge neighbours' average: with v' = (1 − nβ) v +
        // nβ e and e' = 3/8 v + 5/8 e (the average of the edge points: 3/8 v + 3/8 e + 1/8·2 e),
        // the limit l = a v + (1 − a) e must satisfy a (1 − nβ) + (1 − a) 3/8 = a.
        for n in 2..30 {
            let a = 1.0 - n as f64 * limit_weight(n);
            let nb = n as f64 * beta(n);
            assert!(
                (a * (1.0 - nb) + (1.0 - a) * 0.375 - a).abs() < 1e-14,
                "valence {n}"
            );
        }
        assert!((limit_weight(6) - 1.0 / 12.0).abs() < 1e-17);
    }

    #[test]
    fn smooth_and_sharp_edges() {
        let mut acc = Accumulator::new();
        edge_mask(&mut acc, 0, 1, &[2, 3], 0.0, false);
        assert_eq!(
            row(&mut acc, 4),
            vec![(0, 0.375), (1, 0.375), (2, 0.125), (3, 0.125)]
        );
        edge_mask(&mut acc, 0, 1, &[2, 3], 2.0, true);
        assert_eq!(row(&mut acc, 4), vec![(0, 0.5), (1, 0.5)]);
        // Sharpness 0.25 ending here: a quarter of the midpoint, three quarters smooth.
        edge_mask(&mut acc, 0, 1, &[2, 3], 0.25, false);
        let w = row(&mut acc, 4);
        assert!((w[0].1 - (0.125 + 0.75 * 0.375)).abs() < 1e-15, "{w:?}");
        assert!((w[2].1 - 0.75 * 0.125).abs() < 1e-15, "{w:?}");
        // A boundary edge (one triangle) is the midpoint.
        edge_mask(&mut acc, 0, 1, &[2], 0.0, false);
        assert_eq!(row(&mut acc, 3), vec![(0, 0.5), (1, 0.5)]);
    }

    #[test]
    fn smooth_vertex_weights_sum_to_one() {
        for n in 2..40 {
            let ends: Vec<u32> = (1..=n as u32).collect();
            let zeros = vec![0.0f32; n];
            let ring = VertexRing {
                center: 0,
                edge_ends: &ends,
                edge_sharpness: &zeros,
                child_edge_sharpness: &zeros,
                faces: &[],
                sharpness: 0.0,
                child_sharpness: 0.0,
            };
            let mut acc = Accumulator::new();
            vertex_mask(&mut acc, &ring);
            let w = row(&mut acc, n + 1);
            let sum: f64 = w.iter().map(|p| p.1).sum();
            assert!((sum - 1.0).abs() < 1e-14, "valence {n}: {sum}");
            assert!((w[1].1 - beta(n)).abs() < 1e-15);
        }
    }
}
