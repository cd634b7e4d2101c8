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
/// rule, and a sharpness that ends at this level blends the two with weight `min(s, 1)`.
pub fn edge_mask(
    acc: &mut Accumulator,
    a: u32,
    b: u32,
    faces: &[&[u32]],
    s: f32,
    child_sharp: bool,
) {
    let crease_w = if !crease::is_sharp(s) {
        0.0
    } else if child_sharp || s >= 1.0 {
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
    if smooth_w > 0.0 {
        acc.add(a, 0.25 * smooth_w);
        acc.add(b, 0.25 * smooth_w);
        for f in faces {
            face_mask(acc, f, 0.25 * smooth_w);
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
    if ring.edge_ends.is_empty() {
        acc.add(ring.center, 1.0);
        return;
    }
    let p = ring.parent_rule();
    let c = ring.child_rule();
    if p == c {
        rule_mask(acc, ring, p, ring.edge_sharpness, 1.0);
        return;
    }
    let w = crease::fractional_weight(
        ring.sharpness,
        ring.child_sharpness,
        ring.edge_sharpness,
        ring.child_edge_sharpness,
    );
    if w > 0.0 {
        rule_mask(acc, ring, p, ring.edge_sharpness, w);
    }
    if w < 1.0 {
        rule_mask(acc, ring, c, ring.child_edge_sharpness, 1.0 - w);
    }
}

fn rule_mask(acc: &mut Accumulator, ring: &VertexRing, rule: Rule, sharp: &[f32], scale: f64) {
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
        Rule::Smooth => {
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
    }
}
