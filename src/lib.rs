//! limitray: ray tracing of exact Catmull-Clark limit surfaces with RenderMan semi-sharp creases.
//!
//! The pipeline runs one way, one stage per module:
//! [`mesh`] (control mesh, tags, validated topology) → [`refine`] (subdivision rules, stencil
//! tables, limit masks) → [`patch`] (feature-adaptive patch table, exact evaluation) →
//! [`dice`] (crack-free limit-surface triangles) → [`bvh`] (watertight ray queries) → rendering.
#![warn(missing_docs)]
// Mesh code indexes several parallel arrays by the same element index; range loops say so.
#![allow(clippy::needless_range_loop)]

pub mod bench;
pub mod bvh;
pub mod cli_eval;
pub mod cli_render;
pub mod cli_trace;
pub mod coord;
pub mod dice;
#[cfg(feature = "embree")]
pub mod embree;
pub mod error;
pub mod gpu;
pub mod info;
pub mod io;
pub mod lines;
pub mod memory;
pub mod mesh;
pub mod numeric;
pub mod patch;
pub mod probe;
pub mod refine;
pub mod render;
pub mod threads;
pub mod vec3;

pub use coord::FaceCoord;
pub use error::{Error, ErrorKind, Result};
