//! Image output: OpenEXR with AOVs ([`exr`]) and tone-mapped PNG previews ([`png`]).

pub mod exr;
pub mod png;
