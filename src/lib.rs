//! limitray: ray tracing of exact Catmull-Clark limit surfaces with RenderMan semi-sharp creases.
//!
//! The pipeline runs one way, one stage per module:
//! [`mesh`] (control mesh, tags, hierarchical edits, validated topology) → [`refine`]
//! (subdivision rules, stencil tables, limit masks) → [`patch`] (feature-adaptive patch table,
//! exact evaluation) → [`dice`] (crack-free limit-surface triangles, displaced on request by
//! [`texture`]'s noise) → [`bvh`] (watertight ray queries) → `render` (path tracer, feature
//! `render`) / `gpu` (wgpu compute, feature `gpu`) → `io` (EXR, PNG).
//! [`harness`] holds the test and benchmark ray sets and probes; `cli` is the command-line tool
//! (feature `cli`).
//!
//! Features: `cli` (default; the `limitray` binary), `render` (default; the path tracer, EXR and
//! PNG output, TOML scenes), `gpu` (default; the wgpu backend), `embree` (cross-checks and
//! benchmarks against Embree 4; needs `bash scripts/setup-embree.sh`). The geometry core builds
//! with `default-features = false`.
#![warn(missing_docs)]
// Mesh code indexes several parallel arrays by the same element index; range loops say so.
#![allow(clippy::needless_range_loop)]

pub mod affinity;
pub mod bvh;
#[cfg(feature = "cli")]
// Flattened clap argument groups carry their help on their own fields.
#[allow(missing_docs)]
pub mod cli;
pub mod coord;
pub mod dice;
#[cfg(feature = "embree")]
pub mod embree;
pub mod error;
pub mod exact;
#[cfg(feature = "gpu")]
pub mod gpu;
pub mod grid;
pub mod harness;
pub mod huge_pages;
pub mod io;
pub mod lines;
pub mod memory;
pub mod mesh;
pub mod numeric;
pub mod oct;
pub mod patch;
pub mod prefetch;
pub mod refine;
#[cfg(feature = "render")]
pub mod render;
pub mod stages;
pub mod surface;
pub mod texture;
pub mod threads;
pub mod vec3;

pub use bvh::{Hit, Ray, Ray64};
pub use coord::FaceCoord;
pub use dice::{DiceOptions, DiceRate, DicedMesh};
pub use error::{Error, ErrorKind, Result};
pub use exact::{ExactHit, ExactTrace, ExactTracer};
pub use mesh::{BoundaryInterpolation, ControlMesh, CreaseMethod};
pub use patch::Sample;
pub use surface::{Surface, SurfaceOptions, TracedSurface};

/// The README's Rust examples, compiled and run as doctests.
#[cfg(doctest)]
#[doc = include_str!("../README.md")]
pub struct ReadmeDoctests;
