//! Image output: OpenEXR with AOVs ([`exr`]) and tone-mapped PNG previews ([`png`]), both
//! written through [`output::Output`] (checked paths, atomic replacement).

pub mod exr;
pub mod output;
pub mod png;
