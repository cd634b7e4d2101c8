//! Textures: procedural noise ([`noise`]) for tests and displacement.

pub mod noise;
