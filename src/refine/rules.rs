//! Catmull-Clark subdivision masks with RenderMan creases (paper 001 §3.1, OpenSubdiv's Sdc
//! semantics). Each function adds the weights of one child point to an [`Accumulator`], over
//! whatever indices the caller uses for the parent points (a level's vertices, or the points of
//! a local ring).

use super::crease::{self, Rule};
use super::stencil::Accumulator;

/// Face point: the centroid of the face's vertices.
pub fn face_mask(acc: &mut Accumulator, verts: &[u32], scale: f64) {
    let w = scale / verts.len() as f64;
    for &v in verts {
        acc.add(v, w);
    }
}

/// Edge point of edge `a`–`b` with sharpness `s` and incident `faces` (each a vertex list);
/// `child_sharp` tells whether both child edges are still sharp (the child vertex is then a
/// crease). Sharp edges give the midpoint, smooth edges with two faces the Catmull-Clark edge
/// rule, and a sharpness that ends at this level (a child edge is smooth) blends the two with
/// weight `s`.
///
/// The weight is not clamped to 1: under Chaikin's rule an edge sharper than 1 can still have a
/// smooth child edge (its sharpness averaged down by a weaker crease at one end), and
/// OpenSubdiv's `Sdc::Scheme::ComputeEdgeVertexMask` then blends crease and smooth masks with
/// the parent's sharpness as it is (`pWeight = s`, `cWeight = 1 − s`), extrapolating past the
/// midpoint. That is the reference behaviour; the differential test against Far found it
/// (tests/osd_oracle.rs, `chaikin_edge_sharper_than_one_with_a_smooth_half`). Under the uniform
/// rule both children of an edge sharper than 1 stay sharp, so this never happens there.
pub fn edge_mask(
    acc: &mut Accumulator,
    a: u32,
    b: u32,
    faces: &[&[u32]],
    s: f32,
    child_sharp: bool,
    smooth_triangles: bool,
) {
    let crease_w = if !crease::is_sharp(s) {
        0.0
    } else if child_sharp {
        1.0
    } else {
        s as f64
    };
    let crease_w = if faces.len() != 2 { 1.0 } else { crease_w };
    if crease_w > 0.0 {
        acc.add(a, 0.5 * crease_w);
        acc.add(b, 0.5 * crease_w);
    }
    let smooth_w = 1.0 - crease_w;
    if smooth_w != 0.0 {
        let tri = |f: &[u32]| smooth_triangles && faces.len() == 2 && f.len() == 3;
        if faces.iter().any(|f| tri(f)) {
            // OpenSubdiv's TRI_SUB_SMOOTH (Sdc's Catmark edge mask): each face of the edge
            // counts 0.47 if it is a triangle, 0.25 otherwise; both face points get the mean
            // of the two, the edge's ends share what is left.
            let fw = 0.5
                * faces
                    .iter()
                    .map(|f| if tri(f) { 0.47 } else { 0.25 })
                    .sum::<f64>();
            let vw = 0.5 * (1.0 - 2.0 * fw);
            acc.add(a, vw * smooth_w);
            acc.add(b, vw * smooth_w);
            for f in faces {
                face_mask(acc, f, fw * smooth_w);
            }
        } else {
            acc.add(a, 0.25 * smooth_w);
            acc.add(b, 0.25 * smooth_w);
            for f in faces {
                face_mask(acc, f, 0.25 * smooth_w);
            }
        }
    }
}

/// The neighbourhood of a vertex as the vertex rules need it.
pub struct VertexRing<'a> {
    /// The vertex.
    pub center: u32,
    /// The far end of each incident edge.
    pub edge_ends: &'a [u32],
    /// Parent sharpness of each incident edge.
    pub edge_sharpness: &'a [f32],
    /// Child sharpness of each incident edge (at this vertex's end).
    pub child_edge_sharpness: &'a [f32],
    /// Vertex lists of the incident faces.
    pub faces: &'a [&'a [u32]],
    /// Parent vertex sharpness.
    pub sharpness: f32,
    /// Child vertex sharpness.
    pub child_sharpness: f32,
}

impl VertexRing<'_> {
    /// Rule before refinement.
    pub fn parent_rule(&self) -> Rule {
        rule_of(self.sharpness, self.edge_sharpness)
    }
    /// Rule after refinement.
    pub fn child_rule(&self) -> Rule {
        rule_of(self.child_sharpness, self.child_edge_sharpness)
    }
}

fn rule_of(vs: f32, es: &[f32]) -> Rule {
    crease::vertex_rule(vs, es.iter().filter(|&&s| crease::is_sharp(s)).count())
}

/// Vertex point: the parent rule's mask, blended with the child rule's mask when the rule
/// changes at this level (fractional sharpness).
pub fn vertex_mask(acc: &mut Accumulator, ring: &VertexRing) {
    vertex_mask_with(acc, ring, smooth_vertex_mask);
}

/// A scheme's smooth vertex rule: adds `scale` times the mask of `ring`'s centre.
pub type SmoothMask = fn(&mut Accumulator, &VertexRing, f64);

/// The vertex point of any scheme, given its smooth rule: crease and corner rules and the
/// blending of a parent rule with a child rule (RenderMan's semantics, OpenSubdiv's
/// `Sdc::Scheme::ComputeVertexVertexMask`) are the same for Catmull-Clark and Loop.
pub fn vertex_mask_with(acc: &mut Accumulator, ring: &VertexRing, smooth: SmoothMask) {
    if ring.edge_ends.is_empty() {
        acc.add(ring.center, 1.0);
        return;
    }
    let p = ring.parent_rule();
    let c = ring.child_rule();
    if p == c {
        rule_mask(acc, ring, p, ring.edge_sharpness, 1.0, smooth);
        return;
    }
    let w = crease::fractional_weight(
        ring.sharpness,
        ring.child_sharpness,
        ring.edge_sharpness,
        ring.child_edge_sharpness,
    );
    if w > 0.0 {
        rule_mask(acc, ring, p, ring.edge_sharpness, w, smooth);
    }
    if w < 1.0 {
        rule_mask(acc, ring, c, ring.child_edge_sharpness, 1.0 - w, smooth);
    }
}

fn rule_mask(
    acc: &mut Accumulator,
    ring: &VertexRing,
    rule: Rule,
    sharp: &[f32],
    scale: f64,
    smooth: SmoothMask,
) {
    match rule {
        Rule::Corner => acc.add(ring.center, scale),
        Rule::Crease => {
            acc.add(ring.center, 0.75 * scale);
            for (&end, &s) in ring.edge_ends.iter().zip(sharp) {
                if crease::is_sharp(s) {
                    acc.add(end, 0.125 * scale);
                }
            }
        }
        Rule::Smooth => smooth(acc, ring, scale),
    }
}

/// Catmull-Clark's smooth vertex rule: `(n−2)/n` of the vertex, `1/n²` of each edge end and
/// each face point.
fn smooth_vertex_mask(acc: &mut Accumulator, ring: &VertexRing, scale: f64) {
    let n = ring.edge_ends.len() as f64;
    acc.add(ring.center, scale * (n - 2.0) / n);
    let w = scale / (n * n);
    for &end in ring.edge_ends {
        acc.add(end, w);
    }
    for f in ring.faces {
        face_mask(acc, f, w);
    }
}

#[cfg(test)]
mod edge_tests {
    use super::*;
    use crate::refine::stencil::StencilTable;

    fn weights(s: f32, child_sharp: bool) -> Vec<(u32, f64)> {
        let mut acc = Accumulator::new();
        let (f0, f1): (&[u32], &[u32]) = (&[0, 1, 2, 3], &[1, 0, 4, 5]);
        edge_mask(&mut acc, 0, 1, &[f0, f1], s, child_sharp, false);
        let mut t = StencilTable::new(6);
        t.push_row(&mut acc);
        let (idx, w) = t.row(0);
        let mut out: Vec<(u32, f64)> = idx.iter().copied().zip(w.iter().copied()).collect();
        out.sort_by_key(|p| p.0);
        out
    }

    #[test]
    fn sharp_edge_with_a_smooth_child_extrapolates_like_far() {
        // Far (Sdc::Scheme::ComputeEdgeVertexMask, crease-to-smooth): endpoint weight
        // s/2 + (1 - s)·3/8, face-point weight (1 - s)/4 per face, i.e. (1 - s)/16 per face
        // vertex off the edge and 1/16·(1 - s) more on each endpoint.
        let s = 1.25f32;
        let w = weights(s, false);
        let sum: f64 = w.iter().map(|p| p.1).sum();
        assert!((sum - 1.0).abs() < 1e-15);
        let c = 1.0 - s as f64;
        assert!(
            (w[0].1 - (0.5 * s as f64 + c * 0.375)).abs() < 1e-15,
            "{w:?}"
        );
        assert!((w[2].1 - c / 16.0).abs() < 1e-15, "{w:?}");
        // Both children sharp: the midpoint.
        assert_eq!(weights(s, true), vec![(0, 0.5), (1, 0.5)]);
    }
}
