//! Argument groups shared by several subcommands: the mesh (a file or a generated grid), the
//! subdivision rules, the dicing options, the worker threads and the output path.

use crate::dice::{DiceOptions, DiceRate};
use crate::error::{Error, ErrorKind, Result};
use crate::mesh::obj::read_obj;
use crate::mesh::{
    generate, BoundaryInterpolation, ControlMesh, CreaseMethod, FVarMode, Options, Scheme,
};
use crate::patch::approx::Approximation;
use crate::patch::PatchOptions;
use std::path::{Path, PathBuf};

/// Boundary interpolation on the command line.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum Boundary {
    /// No boundary interpolation (boundary faces become holes).
    None,
    /// Boundary edges sharp, corners of one face smooth.
    Edge,
    /// Boundary edges sharp, corners of one face sharp.
    Corner,
}

impl From<Boundary> for BoundaryInterpolation {
    fn from(b: Boundary) -> Self {
        match b {
            Boundary::None => BoundaryInterpolation::None,
            Boundary::Edge => BoundaryInterpolation::EdgeOnly,
            Boundary::Corner => BoundaryInterpolation::EdgeAndCorner,
        }
    }
}

/// Subdivision scheme on the command line.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, clap::ValueEnum)]
pub enum SchemeArg {
    /// Catmull-Clark (any polygons).
    #[default]
    Catmark,
    /// Loop (triangles only).
    Loop,
}

impl From<SchemeArg> for Scheme {
    fn from(s: SchemeArg) -> Self {
        match s {
            SchemeArg::Catmark => Scheme::Catmark,
            SchemeArg::Loop => Scheme::Loop,
        }
    }
}

/// The surface of a Loop mesh on the command line (`--surface`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, clap::ValueEnum)]
pub enum SurfaceArg {
    /// The exact limit surface.
    #[default]
    Exact,
    /// PN triangles from the limit positions and normals (C0).
    Pn,
    /// Walton-Meek G1 triangles from boundary data.
    Wm,
    /// Paper 002's G1 Gregory triangles (Loop); paper 004's Gregory patches (Catmull-Clark).
    Gregory,
}

impl From<SurfaceArg> for Approximation {
    fn from(s: SurfaceArg) -> Self {
        match s {
            SurfaceArg::Exact => Approximation::Exact,
            SurfaceArg::Pn => Approximation::Pn,
            SurfaceArg::Wm => Approximation::Wm,
            SurfaceArg::Gregory => Approximation::Gregory,
        }
    }
}

/// Rule overrides: `--scheme`, `--chaikin`, `--boundary`, `--smooth-triangles`, `--fvar`.
#[derive(clap::Args, Clone, Debug, Default)]
pub struct RuleArgs {
    /// Subdivision scheme (default catmark: an OBJ file does not name its scheme).
    #[arg(long, value_enum)]
    pub scheme: Option<SchemeArg>,
    /// Use Chaikin's crease rule instead of the uniform one.
    #[arg(long)]
    pub chaikin: bool,
    /// Boundary interpolation (default: the mesh's tag, else corner = edge-and-corner).
    #[arg(long, value_enum)]
    pub boundary: Option<Boundary>,
    /// OpenSubdiv's smooth-triangle rule (`TRI_SUB_SMOOTH`, tag `t smoothtriangles 0/0/1
    /// smooth`): edge points next to triangles weight the triangles' face points more.
    #[arg(long)]
    pub smooth_triangles: bool,
    /// Face-varying (texture coordinate) interpolation: none, corners-only, corners-plus1
    /// (default, USD's), corners-plus2, boundaries or all (OpenSubdiv Far's own default).
    #[arg(long, value_name = "MODE", value_parser = parse_fvar)]
    pub fvar: Option<FVarMode>,
}

/// Parses `--fvar MODE`.
fn parse_fvar(s: &str) -> std::result::Result<FVarMode, String> {
    FVarMode::from_name(s).ok_or_else(|| {
        let names: Vec<&str> = FVarMode::NAMES.iter().map(|(_, n)| *n).collect();
        format!("unknown mode '{s}' (one of {})", names.join(", "))
    })
}

impl RuleArgs {
    /// The mesh's options with these overrides applied.
    pub fn options(&self, mesh: &ControlMesh) -> Options {
        let mut o = mesh.options;
        if let Some(s) = self.scheme {
            o.scheme = s.into();
        }
        if self.chaikin {
            o.crease_method = CreaseMethod::Chaikin;
        }
        if let Some(b) = self.boundary {
            o.boundary = b.into();
        }
        if self.smooth_triangles {
            o.smooth_triangles = true;
        }
        if let Some(f) = self.fvar {
            o.fvar = f;
        }
        o
    }
}

/// Reads an OBJ control mesh and prints its warnings on stderr.
pub fn load(path: &Path) -> Result<ControlMesh> {
    let mesh = read_obj(path)?;
    for w in &mesh.warnings {
        eprintln!("warning: {w}");
    }
    Ok(mesh)
}

/// A mesh file or `--grid N` (the benchmarks' generated N × N grid).
#[derive(clap::Args, Clone, Debug, Default)]
pub struct MeshSource {
    /// OBJ file with OpenSubdiv tags (or use --grid).
    #[arg(required_unless_present = "grid", conflicts_with = "grid")]
    pub mesh: Option<PathBuf>,
    /// Use the generated N x N grid (`limitray::mesh::generate::grid`) instead of an OBJ file.
    #[arg(long, value_name = "N")]
    pub grid: Option<usize>,
}

impl MeshSource {
    /// The mesh and its display name (`grid N` for a generated grid).
    pub fn load(&self) -> Result<(String, ControlMesh)> {
        match (&self.mesh, self.grid) {
            (Some(path), None) => Ok((path.display().to_string(), load(path)?)),
            (None, Some(n)) => {
                if n == 0 {
                    return Err(Error::new(ErrorKind::Usage, "--grid must be at least 1"));
                }
                Ok((format!("grid {n}"), generate::try_grid(n)?))
            }
            _ => Err(Error::new(
                ErrorKind::Usage,
                "give either a mesh file or --grid N",
            )),
        }
    }
}

/// Dicing options of the command line.
#[derive(clap::Args, Clone, Debug)]
pub struct DiceArgs {
    /// Uniform rate: segments per base-face edge (halved on n-gon sub-faces).
    #[arg(long, default_value_t = 4)]
    pub rate: u32,
    /// Dice by object-space micro-edge length instead of a uniform rate.
    #[arg(long)]
    pub edge_length: Option<f64>,
    /// Largest number of segments on one edge.
    #[arg(long, default_value_t = 256)]
    pub max_rate: u32,
    /// Maximum isolation level of the patch table.
    #[arg(long, default_value_t = crate::patch::table::DEFAULT_MAX_LEVEL)]
    pub max_level: usize,
    /// The surface: exact, or paper 002's pn, wm or gregory approximation of a Loop mesh
    /// (gregory on a Catmull-Clark mesh: paper 004's Gregory patches).
    #[arg(long, value_enum, default_value_t = SurfaceArg::Exact)]
    pub surface: SurfaceArg,
    /// Displace the surface along its limit normal: `noise:AMPLITUDE:FREQUENCY` (gradient
    /// noise of the limit point; crack-free: shared edge vertices are displaced once).
    #[arg(long, value_parser = parse_displacement)]
    pub displace: Option<crate::dice::Displacement>,
}

/// `--displace SPEC` ([`crate::dice::Displacement::parse`]).
pub(crate) fn parse_displacement(
    spec: &str,
) -> std::result::Result<crate::dice::Displacement, String> {
    crate::dice::Displacement::parse(spec).map_err(|e| e.to_string())
}

impl Default for DiceArgs {
    fn default() -> Self {
        DiceArgs {
            rate: 4,
            edge_length: None,
            max_rate: 256,
            max_level: crate::patch::table::DEFAULT_MAX_LEVEL,
            surface: SurfaceArg::Exact,
            displace: None,
        }
    }
}

impl DiceArgs {
    /// The patch-table options these arguments ask for.
    pub fn patch_options(&self) -> PatchOptions {
        PatchOptions {
            max_level: self.max_level,
            surface: self.surface.into(),
            ..PatchOptions::default()
        }
    }

    /// The dicing options these arguments ask for.
    pub fn options(&self) -> DiceOptions {
        DiceOptions {
            rate: match self.edge_length {
                Some(l) => DiceRate::EdgeLength(l),
                None => DiceRate::Uniform(self.rate),
            },
            max_rate: self.max_rate,
            displace: self.displace.clone(),
        }
    }
}

/// `--threads T` (0: every core).
#[derive(clap::Args, Clone, Copy, Debug, Default)]
pub struct ThreadArgs {
    /// Worker threads (0: all available).
    #[arg(long, default_value_t = 0)]
    pub threads: usize,
}

impl ThreadArgs {
    /// The number of threads asked for, 0 resolved to the machine's parallelism.
    pub fn count(&self) -> usize {
        crate::harness::thread_count(self.threads)
    }

    /// A rayon pool of [`Self::count`] threads.
    pub fn pool(&self) -> Result<rayon::ThreadPool> {
        crate::harness::pool(self.threads)
    }
}

/// An output file checked and opened before the work starts (`-`: standard output), written
/// atomically through [`crate::io::output::Output`] and committed by [`finish_output`].
pub fn open_output(path: &Path) -> Result<crate::io::output::Output> {
    crate::io::output::Output::create(path)
}

/// Writes through `write` into `out` and commits it (the target is replaced only on success).
pub fn finish_output(
    mut out: crate::io::output::Output,
    path: &Path,
    write: impl FnOnce(&mut crate::io::output::Output) -> std::io::Result<()>,
) -> Result<()> {
    write(&mut out).map_err(|e| {
        Error::new(ErrorKind::Io, e.to_string()).in_file(path.display().to_string())
    })?;
    out.commit()
}
