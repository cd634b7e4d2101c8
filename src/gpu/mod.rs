//! The wgpu compute backend: the same BVH, the same watertight triangle test and the same
//! conservative box test as the CPU path, in WGSL (`kernels/*.wgsl`), on any Vulkan adapter
//! (lavapipe on machines without a GPU: `bash scripts/setup-lavapipe.sh`).
//!
//! On an adapter whose `+ − × ÷` round like Rust's `f32` (lavapipe does, and the CPU code uses
//! no fused multiply-add), closest hits are bitwise the CPU's: the same triangle and the same
//! `t`. The CPU's `f64` re-evaluation of zero edge functions is emulated exactly with integer
//! arithmetic (`kernels/exact.wgsl`).
//!
//! Modules: [`device`] (adapter choice, device, error scopes), [`layout`] (every word layout
//! shared with the kernels, defined once; the WGSL prelude), [`geometry`] (the scene as
//! words over several storage bindings), [`trace`] (closest hits, `trace --backend gpu`),
//! [`render`] (the path tracer, `render --backend gpu`), [`texture`] (its texture maps and
//! texture coordinates), [`exact`] (the exact edge function,
//! for tests); the command-line pieces are in `crate::cli::gpu`.

pub mod device;
pub mod exact;
pub mod geometry;
pub mod layout;
pub mod render;
pub mod texture;
pub mod trace;

pub use device::{adapters, context_for_tests, GpuContext};
pub use geometry::{GpuGeometry, PackedScene};
pub use trace::{trace_mesh, trace_scene, GpuTracer, RawHit, TraceOptions};
