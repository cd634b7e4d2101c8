//! Feature-adaptive patches of the limit surface: bicubic B-spline patches ([`bspline`]),
//! regular patches with one semi-sharp crease ([`single_crease`], paper 000), the recognition
//! of regular faces ([`regular`]), local neighbourhoods for adaptive refinement ([`local`]) and
//! the patch table with exact evaluation ([`table`]), where quads at smooth
//! extraordinary vertices are evaluated in constant time ([`stam`]); for the Loop scheme, the
//! box-spline patch ([`loop_box`]) and exact on-demand evaluation ([`loop_surface`]).

pub mod approx;
pub mod bezier;
pub mod bspline;
pub mod local;
pub mod loop_box;
pub mod loop_surface;
pub mod quartic;
pub mod regular;
pub mod single_crease;
pub mod stam;
pub mod table;
pub mod uv;

pub use bspline::{Basis, ControlGrid, Mat4, PatchPoint};
pub use loop_surface::LoopSurface;
pub use single_crease::{CreaseCurve, SingleCreasePatch};
pub use table::{PatchOptions, PatchTable, Sample};
