//! Ray queries against diced limit surfaces: an obvhs CWBVH per diced mesh ([`mesh`]) with
//! the watertight ray/triangle test and conservative box tests ([`triangle`]), instances under
//! a top-level hierarchy ([`scene`]). Exact hits on the limit surface itself come from the
//! reference intersector, [`crate::exact`].

pub mod mesh;
pub mod ray;
pub mod scene;
pub mod triangle;

pub use mesh::MeshBvh;
pub use ray::{Hit, Intersect, Ray, Ray64};
pub use scene::{SceneBvh, SceneHit};
pub use triangle::intersect_triangle;
