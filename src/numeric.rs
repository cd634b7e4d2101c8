//! The numeric contract: the range of coordinates every stage is safe for.
//!
//! Control points, transformed scene geometry, the camera and lights must lie in the cube
//! `|x|, |y|, |z| ≤ MAX_COORD = 2^32 ≈ 4.29e9`. Inside it:
//!
//! * the watertight ray/triangle test ([`crate::bvh`]) stays finite: relative to a ray origin
//!   in the cube, a vertex is at most `2^33` away per axis and at most `2^34` after the shear,
//!   its 2-D edge functions at most `2^69`, and the scaled distance `T` at most `2^77`, far
//!   below `f32::MAX ≈ 2^128` (at `3e13 ≈ 2^45` the same products reach `2^144`: `t = inf`);
//! * obvhs's build (surface areas `≤ 3 · 2^66` times primitive counts `< 2^32`) never
//!   overflows; at `±1e20` areas are `inf` and its BVH2 → CWBVH conversion and PLOC index out
//!   of bounds;
//! * the `f64` evaluation and the `f64` fallback of the triangle test have more than 2^900 of
//!   headroom.
//!
//! A value above `f32::MAX` (`v 1e39 0 0`) is outside the cube, so no stage ever rounds a
//! coordinate to `inf`. Precision is a separate matter: at `2^32` one `f32` step is 512
//! units, so geometry that far out should be scaled down by the caller.

/// Largest supported absolute coordinate, `2^32`.
pub const MAX_COORD: f64 = 4_294_967_296.0;

/// True when every component of `p` is finite and within [`MAX_COORD`].
pub fn in_range(p: [f64; 3]) -> bool {
    p.iter().all(|c| c.is_finite() && c.abs() <= MAX_COORD)
}

/// A short statement of the contract for error messages.
pub fn contract() -> String {
    format!("the supported range is |x|, |y|, |z| ≤ 2^32 = {MAX_COORD:.0}")
}
