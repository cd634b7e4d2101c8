//! The front end: a [`Surface`] is a control mesh with its subdivision rules and its exact
//! limit surface, ready to evaluate, dice and trace. It threads the pipeline's stages
//! (mesh → patch table → dicing → BVH) together so that a user never has to.
//!
//! ```
//! use limitray::{FaceCoord, Ray, Ray64, Surface, SurfaceOptions};
//! use limitray::dice::{DiceOptions, DiceRate};
//!
//! // A cube (vertex i at the corners of [-1, 1]^3), counter-clockwise faces seen from outside.
//! let p: Vec<[f64; 3]> = (0..8)
//!     .map(|i| [(i & 1) as f64 * 2.0 - 1.0, ((i >> 1) & 1) as f64 * 2.0 - 1.0, ((i >> 2) & 1) as f64 * 2.0 - 1.0])
//!     .collect();
//! let faces = [0, 2, 3, 1, 4, 5, 7, 6, 0, 1, 5, 4, 2, 6, 7, 3, 0, 4, 6, 2, 1, 3, 7, 5];
//! let mesh = limitray::mesh::MeshBuilder::new().positions(p).faces(&[4; 6], &faces).build()?;
//! let surface = Surface::new(mesh, SurfaceOptions::default())?;
//!
//! // The exact limit surface at the centre of face 0 (z = -1): after one Catmull-Clark step the
//! // face point (z = -1) is a regular vertex with edge neighbours at z = -3/4 and diagonal
//! // neighbours (the corners' vertex points) at z = -5/9; the limit mask (16 v + 4 Σ e + Σ d) / 36
//! // gives z = -68/81, on the axis.
//! let s = surface.eval(FaceCoord::quad(0, 0.5, 0.5)).expect("face 0 has a surface");
//! assert!((s.p[2] + 68.0 / 81.0).abs() < 1e-12 && s.p[0].abs() < 1e-12 && s.p[1].abs() < 1e-12);
//! // Its exact normal there points out of the cube, along -z (by symmetry).
//! let n = surface.limit_normal(FaceCoord::quad(0, 0.5, 0.5)).expect("a regular point");
//! assert!((n[2] + 1.0).abs() < 1e-12 && n[0].abs() < 1e-12 && n[1].abs() < 1e-12);
//!
//! // Dice it into crack-free triangles and trace a ray from the centre: it always hits.
//! let traced = surface.bvh(&DiceOptions { rate: DiceRate::Uniform(8), ..DiceOptions::default() })?;
//! let hit = traced.intersect(&Ray::new([0.0; 3], [0.3, 0.2, 1.0])).expect("closed surface");
//!
//! // Built for tracing alone (no shading normals stored): the same hit, its shading normal the
//! // geometric one; the exact limit normal from its (face, k, u, v) is within a few degrees
//! // of the hit triangle's (an 8 × 8 dicing of a face of the rounded cube).
//! let geo = surface.bvh_geometry(&DiceOptions { rate: DiceRate::Uniform(8), ..DiceOptions::default() })?;
//! let g = geo.intersect(&Ray::new([0.0; 3], [0.3, 0.2, 1.0])).expect("closed surface");
//! assert_eq!((g.t, g.face, g.k, g.u, g.v, g.ng, g.ns), (hit.t, hit.face, hit.k, hit.u, hit.v, hit.ng, hit.ng));
//! let n = surface.limit_normal(FaceCoord::new(g.face, g.k, g.u as f64, g.v as f64)).unwrap();
//! let dot = n[0] * g.ng[0] as f64 + n[1] * g.ng[1] as f64 + n[2] * g.ng[2] as f64;
//! assert!(dot > 0.995); // 4.7° here; 0.995 is 5.7°
//!
//! // The reference intersector: the certified first hit on the exact limit surface, in f64,
//! // whatever the dicing.
//! let exact = surface.intersect_exact(&Ray64::new([0.0; 3], [0.3, 0.2, 1.0]))?;
//! let x = exact.hit.expect("closed surface");
//! assert!((hit.t as f64 - x.t).abs() < 1e-2 && x.err < 1e-12 && !x.grazing);
//! # Ok::<(), limitray::Error>(())
//! ```

use crate::bvh::Ray64;
use crate::bvh::{Hit, Ray};
use crate::coord::FaceCoord;
use crate::dice::{dice, DiceOptions, DicedMesh};
use crate::error::Result;
use crate::exact::{ExactTrace, ExactTracer};
use crate::grid::GridMesh;
use crate::mesh::obj::read_obj;
use crate::mesh::{BoundaryInterpolation, ControlMesh, CreaseMethod, Options};
use crate::patch::uv::{UvSample, UvSurface};
use crate::patch::{PatchOptions, PatchTable, Sample};
use std::path::Path;
use std::sync::Arc;

/// How a [`Surface`] subdivides its control mesh. `None` fields take the mesh's own tags
/// (`t creasemethod`, `t interpolateboundary`), else OpenSubdiv's defaults (uniform crease
/// rule, edge-and-corner boundaries).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SurfaceOptions {
    /// Crease rule override.
    pub crease_method: Option<CreaseMethod>,
    /// Boundary interpolation override.
    pub boundary: Option<BoundaryInterpolation>,
    /// Deepest feature-adaptive isolation level of the patch table.
    pub max_level: usize,
    /// Single-crease patches (paper 000) for faces with one semi-sharp crease.
    pub single_crease: bool,
    /// Subdivision scheme override (the mesh's own, Catmull-Clark unless set, otherwise).
    pub scheme: Option<crate::mesh::Scheme>,
    /// The surface of a Loop mesh: exact, or one of paper 002's approximations.
    pub surface: crate::patch::approx::Approximation,
    /// Face-varying interpolation of the texture coordinates override (the mesh's own,
    /// corners-plus1 unless set, otherwise).
    pub fvar: Option<crate::mesh::FVarMode>,
}

impl Default for SurfaceOptions {
    fn default() -> Self {
        SurfaceOptions {
            crease_method: None,
            boundary: None,
            max_level: crate::patch::table::DEFAULT_MAX_LEVEL,
            single_crease: true,
            scheme: None,
            surface: crate::patch::approx::Approximation::Exact,
            fvar: None,
        }
    }
}

/// A control mesh and its exact Catmull-Clark limit surface.
#[derive(Debug)]
pub struct Surface {
    mesh: ControlMesh,
    table: Arc<PatchTable>,
    warnings: Vec<String>,
    /// The reference intersector, built by the first exact query.
    exact: std::sync::OnceLock<ExactTracer>,
    /// The limit texture coordinates, built by the first query.
    uv: std::sync::OnceLock<Option<UvSurface>>,
}

impl Surface {
    /// The limit surface of `mesh` under `options`. Fails on invalid topology or tags (the
    /// error names the element).
    pub fn new(mesh: ControlMesh, options: SurfaceOptions) -> Result<Surface> {
        let mut rules: Options = mesh.options;
        if let Some(c) = options.crease_method {
            rules.crease_method = c;
        }
        if let Some(b) = options.boundary {
            rules.boundary = b;
        }
        if let Some(scheme) = options.scheme {
            rules.scheme = scheme;
        }
        if let Some(f) = options.fvar {
            rules.fvar = f;
        }
        let table = PatchTable::with_options(
            &mesh,
            rules,
            PatchOptions {
                max_level: options.max_level,
                single_crease: options.single_crease,
                surface: options.surface,
            },
        )?;
        let warnings = mesh.warnings.iter().map(|w| w.to_string()).collect();
        let mesh = ControlMesh {
            options: rules,
            ..mesh
        };
        Ok(Surface {
            mesh,
            table: Arc::new(table),
            warnings,
            exact: std::sync::OnceLock::new(),
            uv: std::sync::OnceLock::new(),
        })
    }

    /// Reads an OBJ file with OpenSubdiv's tags ([`crate::mesh::obj::read_obj`]) and builds its
    /// surface. Errors name the file, line and element.
    pub fn from_obj(path: impl AsRef<Path>, options: SurfaceOptions) -> Result<Surface> {
        Surface::new(read_obj(path.as_ref())?, options)
    }

    /// What the input carried that was ignored or repaired (unknown statements, unsupported
    /// tags …): returned for the caller to show, never printed.
    pub fn warnings(&self) -> &[String] {
        &self.warnings
    }

    /// The control mesh.
    pub fn mesh(&self) -> &ControlMesh {
        &self.mesh
    }

    /// The feature-adaptive patch table.
    pub fn patch_table(&self) -> &PatchTable {
        &self.table
    }

    /// Number of base faces.
    pub fn num_faces(&self) -> usize {
        self.table.num_faces()
    }

    /// Sub-faces of base face `face` (1 for a quad, `n` for an n-gon; 0 when out of range).
    pub fn sub_faces(&self, face: u32) -> usize {
        if (face as usize) < self.num_faces() {
            self.table.sub_faces(face as usize)
        } else {
            0
        }
    }

    /// Whether base face `face` is part of the limit surface: false for holes (tagged, or made
    /// by `interpolateboundary none`) and for faces out of range.
    pub fn has_limit_surface(&self, face: u32) -> bool {
        self.sub_faces(face) > 0 && self.table.eval(FaceCoord::quad(face, 0.5, 0.5)).is_ok()
    }

    /// The limit surface at `at`: position and first derivatives. `None` where there is no
    /// surface: a hole, or `at` outside the domain (see [`Self::try_eval`] for the reason).
    pub fn eval(&self, at: FaceCoord) -> Option<Sample> {
        self.table.eval(at).ok()
    }

    /// The exact unit limit normal at `at` (`∂P/∂u × ∂P/∂v` normalised, outward for
    /// counter-clockwise faces): a hit's exact shading normal from its `(face, k, u, v)`, for
    /// a grid mesh built without shading normals ([`GridMesh::dice_geometry`]). `None` where
    /// there is no surface, or where the parametric normal vanishes (a degenerate point).
    pub fn limit_normal(&self, at: FaceCoord) -> Option<[f64; 3]> {
        let s = self.eval(at)?;
        let n = crate::vec3::cross(s.du, s.dv);
        let l = crate::vec3::norm(n);
        (l > 0.0 && l.is_finite()).then(|| n.map(|x| x / l))
    }

    /// Under the Loop scheme, the surface at `(face, 0, u, v)` in OpenSubdiv's triangle
    /// parameter (as `limitray eval --scheme loop`); [`Self::eval`] takes the three sub-quad
    /// domains each triangle is diced as (and its hits report), like an n-gon's sub-faces.
    pub fn eval_triangle(&self, at: FaceCoord) -> Result<Sample> {
        self.table.eval_triangle(at)
    }

    /// [`Self::eval`] with the reason when there is no surface at `at`.
    pub fn try_eval(&self, at: FaceCoord) -> Result<Sample> {
        self.table.eval(at)
    }

    /// Crack-free triangles on the limit surface (vertices exact limit points).
    pub fn dice(&self, options: &DiceOptions) -> Result<DicedMesh> {
        dice(&self.table, &self.mesh, options)
    }

    /// The limit texture coordinates at `at` and their derivatives in `u` and `v`: the limit of
    /// the mesh's face-varying values in its [`crate::mesh::FVarMode`]
    /// ([`crate::patch::uv`]). `None` for a mesh without texture coordinates; an error where
    /// `at` has no surface, or for Loop meshes.
    pub fn uv(&self, at: FaceCoord) -> Result<Option<UvSample>> {
        let uv = match self.uv.get() {
            Some(u) => u,
            None => {
                let u = UvSurface::new(&self.mesh, self.mesh.options.fvar)?;
                self.uv.get_or_init(|| u)
            }
        };
        if uv.is_some() {
            // Holes and points outside the domain answer as the surface does.
            self.table.eval(at)?;
        }
        uv.as_ref().map(|u| u.eval(at)).transpose()
    }

    /// The reference intersector of the surface (built on first use, then kept): certified
    /// first hits on the exact limit surface, independent of any dicing.
    pub fn exact_tracer(&self) -> Result<&ExactTracer> {
        if let Some(t) = self.exact.get() {
            return Ok(t);
        }
        let t = ExactTracer::new(self.table.clone(), &self.mesh)?;
        Ok(self.exact.get_or_init(|| t))
    }

    /// The first hit of `ray` (given in `f64`, `t ≥ 0`) on the exact limit surface, with its
    /// error bound, from the reference intersector ([`crate::exact`]).
    pub fn intersect_exact(&self, ray: &Ray64) -> Result<ExactTrace> {
        Ok(self.exact_tracer()?.trace(ray))
    }

    /// The diced surface in the grid tracing core ([`crate::grid`]), ready for watertight ray
    /// queries.
    pub fn bvh(&self, options: &DiceOptions) -> Result<TracedSurface> {
        Ok(TracedSurface {
            bvh: GridMesh::dice(&self.table, &self.mesh, options)?,
        })
    }

    /// [`Self::bvh`] built for tracing alone ([`GridMesh::dice_geometry`]): the same hits,
    /// whose shading normal is then the geometric one, for less build time and memory;
    /// [`Self::limit_normal`] gives a hit's exact normal.
    pub fn bvh_geometry(&self, options: &DiceOptions) -> Result<TracedSurface> {
        Ok(TracedSurface {
            bvh: GridMesh::dice_geometry(&self.table, &self.mesh, options)?,
        })
    }
}

/// A [`Surface`] diced into grid blocks under a BVH ([`GridMesh`]): watertight ray queries (no
/// ray from inside a closed surface leaks).
#[derive(Debug)]
pub struct TracedSurface {
    bvh: GridMesh,
}

impl TracedSurface {
    /// The grid core.
    pub fn grid(&self) -> &GridMesh {
        &self.bvh
    }

    /// The closest hit of `ray` on the diced surface.
    pub fn intersect(&self, ray: &Ray) -> Option<Hit> {
        self.bvh.intersect(ray)
    }

    /// Whether `ray` hits anything (any-hit query).
    pub fn occluded(&self, ray: &Ray) -> bool {
        self.bvh.occluded(ray)
    }

    /// Closest hits of many rays, in parallel.
    pub fn intersect_batch(&self, rays: &[Ray]) -> Vec<Option<Hit>> {
        self.bvh.intersect_batch(rays)
    }
}
