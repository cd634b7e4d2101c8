//! Textures: procedural noise ([`noise`]) for tests and displacement, and image textures
//! (`image`, feature `render`: PNG, JPEG and OpenEXR files as filtered mip pyramids).

#[cfg(feature = "render")]
pub mod image;
pub mod noise;
