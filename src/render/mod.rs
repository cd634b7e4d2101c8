//! Offline rendering: scene files ([`scene`]), the scene's geometry and lights built from them
//! ([`world`]), camera, sampling, materials, lights, environment, and the CPU path tracer
//! ([`integrator`]) writing a [`film::Film`].

pub mod camera;
pub mod env;
pub mod film;
pub mod integrator;
pub mod light;
pub mod material;
pub mod output;
pub mod rng;
pub mod sampling;
pub mod scene;
pub mod texturing;
pub mod world;

pub use film::Film;
pub use scene::{read_scene, RenderSettings, SceneDesc};
pub use world::World;
