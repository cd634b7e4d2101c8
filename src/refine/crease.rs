//! RenderMan crease semantics: vertex rules, sharpness decrement (uniform and Chaikin) and the
//! fractional weights that blend a parent rule with its child rule (paper 001 §3.1).

use crate::mesh::{CreaseMethod, SHARPNESS_INFINITE};

/// The rule that computes a vertex's child position.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub enum Rule {
    /// No sharp incident edge, or one (a dart): the smooth Catmull-Clark rule.
    Smooth,
    /// Exactly two sharp incident edges: the cubic B-spline curve rule along them.
    Crease,
    /// A sharp vertex or more than two sharp edges: the vertex stays put.
    Corner,
}

/// True for sharpness that is not zero.
#[inline]
pub fn is_sharp(s: f32) -> bool {
    s > 0.0
}

/// True for sharpness at or above [`SHARPNESS_INFINITE`].
#[inline]
pub fn is_infinite(s: f32) -> bool {
    s >= SHARPNESS_INFINITE
}

/// True for sharpness strictly between zero and infinite.
#[inline]
pub fn is_semi_sharp(s: f32) -> bool {
    s > 0.0 && s < SHARPNESS_INFINITE
}

/// Clamps input sharpness to the canonical range: negative is an error caught earlier, values
/// at or above 10 become exactly [`SHARPNESS_INFINITE`].
#[inline]
pub fn canonical(s: f32) -> f32 {
    if s >= SHARPNESS_INFINITE {
        SHARPNESS_INFINITE
    } else {
        s.max(0.0)
    }
}

/// Sharpness after one level under the uniform rule: `s - 1`, never below zero; infinite stays.
#[inline]
pub fn decrement(s: f32) -> f32 {
    if is_infinite(s) {
        SHARPNESS_INFINITE
    } else if s > 1.0 {
        s - 1.0
    } else {
        0.0
    }
}

/// The rule of a vertex with sharpness `vertex_sharpness` and `sharp_edges` incident edges of
/// non-zero sharpness.
#[inline]
pub fn vertex_rule(vertex_sharpness: f32, sharp_edges: usize) -> Rule {
    if is_sharp(vertex_sharpness) || sharp_edges > 2 {
        Rule::Corner
    } else if sharp_edges == 2 {
        Rule::Crease
    } else {
        Rule::Smooth
    }
}

/// Sharpness of the child edge that an edge of sharpness `s` produces at vertex `v`, where
/// `incident` holds the sharpness of every edge at `v` (the edge itself included once).
/// Uniform: `decrement(s)`. Chaikin: `decrement(3/4 s + 1/4 avg)` where `avg` averages the
/// other semi-sharp edges at `v` (when there are any).
pub fn child_edge_sharpness(method: CreaseMethod, s: f32, incident: &[f32]) -> f32 {
    if method == CreaseMethod::Uniform || incident.len() < 2 || !is_semi_sharp(s) {
        return decrement(s);
    }
    let mut sum = 0.0f32;
    let mut count = 0;
    for &x in incident {
        if is_semi_sharp(x) {
            sum += x;
            count += 1;
        }
    }
    // `incident` contains `s` itself once.
    let mut t = s;
    if count > 1 {
        let avg = (sum - s) / (count - 1) as f32;
        t = 0.75 * s + 0.25 * avg;
    }
    t -= 1.0;
    if t > 0.0 {
        t
    } else {
        0.0
    }
}

/// The weight of the parent rule when a vertex's rule changes between parent and child:
/// the average parent sharpness of the features (vertex and incident edges) that are sharp in
/// the parent and smooth in the child, clamped to 1.
pub fn fractional_weight(
    parent_vertex: f32,
    child_vertex: f32,
    parent_edges: &[f32],
    child_edges: &[f32],
) -> f64 {
    let mut sum = 0.0f64;
    let mut count = 0usize;
    if is_sharp(parent_vertex) && !is_sharp(child_vertex) {
        sum += parent_vertex as f64;
        count += 1;
    }
    for (&p, &c) in parent_edges.iter().zip(child_edges) {
        if is_sharp(p) && !is_sharp(c) {
            sum += p as f64;
            count += 1;
        }
    }
    if count == 0 {
        0.0
    } else {
        (sum / count as f64).min(1.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn uniform_decrement() {
        assert_eq!(decrement(2.5), 1.5);
        assert_eq!(decrement(0.7), 0.0);
        assert_eq!(decrement(10.0), 10.0);
        assert_eq!(
            child_edge_sharpness(CreaseMethod::Uniform, 3.0, &[3.0, 1.0]),
            2.0
        );
    }

    #[test]
    fn chaikin_averages_with_other_semi_sharp_edges() {
        // 3/4 * 3 + 1/4 * 1 - 1 = 1.5
        assert_eq!(
            child_edge_sharpness(CreaseMethod::Chaikin, 3.0, &[3.0, 1.0, 0.0]),
            1.5
        );
        // infinite and smooth neighbours do not take part
        assert_eq!(
            child_edge_sharpness(CreaseMethod::Chaikin, 3.0, &[3.0, 10.0, 0.0]),
            2.0
        );
        assert_eq!(
            child_edge_sharpness(CreaseMethod::Chaikin, 10.0, &[10.0, 1.0]),
            10.0
        );
    }

    #[test]
    fn rules_and_weights() {
        assert_eq!(vertex_rule(0.0, 1), Rule::Smooth);
        assert_eq!(vertex_rule(0.0, 2), Rule::Crease);
        assert_eq!(vertex_rule(0.0, 3), Rule::Corner);
        assert_eq!(vertex_rule(0.5, 0), Rule::Corner);
        assert_eq!(fractional_weight(0.0, 0.0, &[0.25, 0.75], &[0.0, 0.0]), 0.5);
        assert_eq!(fractional_weight(0.0, 0.0, &[2.0, 0.5], &[1.0, 0.0]), 0.5);
        assert_eq!(fractional_weight(1.5, 0.0, &[], &[]), 1.0);
    }
}
