//! Output files: every file is written through [`output::Output`] (checked paths, atomic
//! replacement); with feature `render`, OpenEXR planes (`exr`) and RGB8 PNGs (`png`).

#[cfg(feature = "render")]
pub mod exr;
pub mod output;
#[cfg(feature = "render")]
pub mod png;
