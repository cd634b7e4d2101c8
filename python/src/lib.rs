//! Python bindings of limitray (`limitray._limitray`; the public API is the `limitray` package
//! in `python/limitray/`, which checks and converts arguments and builds the result dicts).
//!
//! Every method copies its inputs out of the numpy arrays, releases the GIL for the work
//! (`Python::detach`), and returns new arrays. Errors carry the library's messages (what the
//! CLI prints after `error: `): `OSError` for files, `ValueError` for everything else.

use limitray::bvh::Ray64;
use limitray::dice::{dice, DiceOptions, DiceRate, Displacement};
use limitray::error::{Error, ErrorKind};
use limitray::exact::{ExactTrace, ExactTracer};
use limitray::grid::GridMesh;
use limitray::mesh::obj::read_obj;
use limitray::mesh::{BoundaryInterpolation, ControlMesh, CreaseMethod, FVarMode, Options, Scheme};
use limitray::patch::approx::Approximation;
use limitray::patch::uv::UvSurface;
use limitray::patch::{LoopSurface, PatchOptions, PatchTable};
use limitray::refine::Refiner;
use limitray::FaceCoord;
use numpy::ndarray::Array2;
use numpy::{
    IntoPyArray, PyArray1, PyArray2, PyReadonlyArray1, PyReadonlyArray2, PyUntypedArrayMethods,
};
use pyo3::exceptions::{PyOSError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::collections::HashMap;
use std::path::Path;
use std::sync::{Arc, Mutex, OnceLock};

/// The Python exception for a library error, with the library's message.
fn py_err(e: Error) -> PyErr {
    match e.kind {
        ErrorKind::Io => PyOSError::new_err(e.to_string()),
        _ => PyValueError::new_err(e.to_string()),
    }
}

fn usage(message: String) -> PyErr {
    PyValueError::new_err(message)
}

/// The samples `(face[i], k[i], u[i], v[i])` of `eval` and `uv`: one length, indices that fit
/// `u32`, finite parameters; errors name the sample.
fn face_coords(
    face: &PyReadonlyArray1<'_, i64>,
    k: &PyReadonlyArray1<'_, i64>,
    u: &PyReadonlyArray1<'_, f64>,
    v: &PyReadonlyArray1<'_, f64>,
) -> PyResult<Vec<FaceCoord>> {
    let (face, k, u, v) = (
        face.as_slice()?,
        k.as_slice()?,
        u.as_slice()?,
        v.as_slice()?,
    );
    let n = face.len();
    if k.len() != n || u.len() != n || v.len() != n {
        return Err(usage(format!(
            "face, k, u and v have different lengths ({n}, {}, {}, {})",
            k.len(),
            u.len(),
            v.len()
        )));
    }
    (0..n)
        .map(|i| {
            let index = |x: i64| {
                u32::try_from(x).map_err(|_| usage(format!("sample {i}: invalid index '{x}'")))
            };
            if !u[i].is_finite() || !v[i].is_finite() {
                return Err(usage(format!(
                    "sample {i}: invalid parameter '{}'",
                    if u[i].is_finite() { v[i] } else { u[i] }
                )));
            }
            Ok(FaceCoord::new(index(face[i])?, index(k[i])?, u[i], v[i]))
        })
        .collect()
}

/// Largest number of segments on one edge when dicing (the CLI's `--max-rate` default).
const MAX_RATE: u32 = 256;

/// A control mesh with its subdivision options and patch table.
#[pyclass(frozen, module = "limitray._limitray")]
struct Surface {
    mesh: ControlMesh,
    options: Options,
    table: Arc<PatchTable>,
    /// The reference intersector, built by the first exact query.
    exact: OnceLock<ExactTracer>,
    max_level: usize,
    warnings: Vec<String>,
    /// BVHs of the diced surface, by uniform rate.
    /// The grid cores built so far, by rate and whether they store shading normals.
    bvhs: Mutex<HashMap<(u32, bool), Arc<GridMesh>>>,
    /// Displacement of the diced surface along its limit normal.
    displace: Option<Displacement>,
    /// Limit texture coordinates, built by the first query.
    uv: OnceLock<Option<UvSurface>>,
}

fn options_for(
    mesh: &ControlMesh,
    chaikin: bool,
    boundary: Option<&str>,
    smooth_triangles: bool,
) -> PyResult<Options> {
    let mut o = mesh.options;
    if chaikin {
        o.crease_method = CreaseMethod::Chaikin;
    }
    if smooth_triangles {
        o.smooth_triangles = true;
    }
    if let Some(b) = boundary {
        o.boundary = match b {
            "none" => BoundaryInterpolation::None,
            "edge" => BoundaryInterpolation::EdgeOnly,
            "corner" => BoundaryInterpolation::EdgeAndCorner,
            other => {
                return Err(usage(format!(
                    "boundary '{other}' is not one of 'none', 'edge', 'corner'"
                )))
            }
        };
    }
    Ok(o)
}

fn matrix<'py, T: numpy::Element>(
    py: Python<'py>,
    rows: usize,
    cols: usize,
    data: Vec<T>,
) -> Bound<'py, PyArray2<T>> {
    Array2::from_shape_vec((rows, cols), data)
        .expect("rows × cols elements")
        .into_pyarray(py)
}

impl Surface {
    fn exact_tracer(&self) -> Result<&ExactTracer, Error> {
        if let Some(t) = self.exact.get() {
            return Ok(t);
        }
        let t = ExactTracer::new(self.table.clone(), &self.mesh)?;
        Ok(self.exact.get_or_init(|| t))
    }

    /// The grid core at `rate`, with its vertices' shading normals or built for tracing alone
    /// (`GridMesh::dice_geometry`: the same hits, their shading normal the geometric one).
    fn bvh(&self, rate: u32, shading_normals: bool) -> Result<Arc<GridMesh>, Error> {
        let mut cache = self
            .bvhs
            .lock()
            .map_err(|_| Error::new(ErrorKind::Usage, "BVH cache poisoned by a panic"))?;
        if let Some(b) = cache.get(&(rate, shading_normals)) {
            return Ok(b.clone());
        }
        // Diced straight into the grid core: `GridMesh::build` of `dice`'s mesh, bit for bit
        // (tests/grid.rs), without the diced mesh in between.
        let opts = self.dice_options(rate);
        let b = Arc::new(if shading_normals {
            GridMesh::dice(&self.table, &self.mesh, &opts)?
        } else {
            GridMesh::dice_geometry(&self.table, &self.mesh, &opts)?
        });
        cache.insert((rate, shading_normals), b.clone());
        Ok(b)
    }
}

impl Surface {
    fn dice_options(&self, rate: u32) -> DiceOptions {
        DiceOptions {
            rate: DiceRate::Uniform(rate),
            max_rate: MAX_RATE,
            displace: self.displace.clone(),
        }
    }
}

fn check_rate(rate: u32) -> PyResult<()> {
    if rate == 0 || rate > MAX_RATE {
        return Err(usage(format!("rate {rate} must be in 1..={MAX_RATE}")));
    }
    Ok(())
}

#[pymethods]
impl Surface {
    /// Reads an OBJ file (with OpenSubdiv tags) and builds the patch table.
    #[new]
    #[pyo3(signature = (path, scheme="catmark", chaikin=false, boundary=None, max_level=10, smooth_triangles=false, surface="exact", displace=None, fvar=None))]
    #[allow(clippy::too_many_arguments)]
    fn new(
        py: Python<'_>,
        path: std::path::PathBuf,
        scheme: &str,
        chaikin: bool,
        boundary: Option<&str>,
        max_level: usize,
        smooth_triangles: bool,
        surface: &str,
        displace: Option<&str>,
        fvar: Option<&str>,
    ) -> PyResult<Surface> {
        let displace = displace
            .map(Displacement::parse)
            .transpose()
            .map_err(py_err)?;
        let fvar = fvar
            .map(|f| {
                FVarMode::from_name(f).ok_or_else(|| {
                    let names: Vec<&str> = FVarMode::NAMES.iter().map(|(_, n)| *n).collect();
                    usage(format!("fvar '{f}' is not one of {}", names.join(", ")))
                })
            })
            .transpose()?;
        let scheme = match scheme {
            "catmark" => Scheme::Catmark,
            "loop" => Scheme::Loop,
            other => {
                return Err(usage(format!(
                    "scheme '{other}' is not one of 'catmark', 'loop'"
                )))
            }
        };
        let surface: Approximation = surface.parse().map_err(py_err)?;
        let boundary = boundary.map(str::to_owned);
        py.detach(move || -> PyResult<Surface> {
            let mesh = read_obj(Path::new(&path)).map_err(py_err)?;
            let mut options = options_for(&mesh, chaikin, boundary.as_deref(), smooth_triangles)?;
            options.scheme = scheme;
            if let Some(f) = fvar {
                options.fvar = f;
            }
            let table = PatchTable::with_options(
                &mesh,
                options,
                PatchOptions {
                    max_level,
                    surface,
                    ..PatchOptions::default()
                },
            )
            .map_err(py_err)?;
            Ok(Surface {
                warnings: mesh.warnings.clone(),
                mesh,
                options,
                table: Arc::new(table),
                exact: OnceLock::new(),
                max_level,
                bvhs: Mutex::new(HashMap::new()),
                displace,
                uv: OnceLock::new(),
            })
        })
    }

    /// Warnings of the mesh reader (what the CLI prints as `warning: …`).
    #[getter]
    fn warnings(&self) -> Vec<String> {
        self.warnings.clone()
    }

    /// Number of base faces.
    #[getter]
    fn num_faces(&self) -> usize {
        self.table.num_faces()
    }

    /// Maximum isolation level of the patch table.
    #[getter]
    fn max_level(&self) -> usize {
        self.max_level
    }

    /// Sub-faces of each base face (1 for a quad, n for an n-gon).
    fn sub_faces<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<i64>> {
        let v: Vec<i64> = (0..self.table.num_faces())
            .map(|f| self.table.sub_faces(f) as i64)
            .collect();
        v.into_pyarray(py)
    }

    /// Limit positions and first derivatives at `(face, k, u, v)`; flat arrays of `9 N` f64
    /// (`p`, `du`, `dv` per sample).
    fn eval<'py>(
        &self,
        py: Python<'py>,
        face: PyReadonlyArray1<'py, i64>,
        k: PyReadonlyArray1<'py, i64>,
        u: PyReadonlyArray1<'py, f64>,
        v: PyReadonlyArray1<'py, f64>,
    ) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let at = face_coords(&face, &k, &u, &v)?;
        let n = at.len();
        let out = py.detach(|| -> PyResult<Vec<f64>> {
            let mut out = Vec::with_capacity(9 * n);
            for (i, &at) in at.iter().enumerate() {
                let s = if self.options.scheme == Scheme::Loop {
                    self.table.eval_triangle(at)
                } else {
                    self.table.eval(at)
                }
                .map_err(|e| usage(format!("sample {i}: {e}")))?;
                out.extend_from_slice(&s.p);
                out.extend_from_slice(&s.du);
                out.extend_from_slice(&s.dv);
            }
            Ok(out)
        })?;
        Ok(matrix(py, n, 9, out))
    }

    /// Limit texture coordinates at `(face, k, u, v)`: an `N × 6` array of f64 (`s t`, then
    /// their derivatives in `u` and in `v`); an error for a mesh without texture coordinates.
    fn uv<'py>(
        &self,
        py: Python<'py>,
        face: PyReadonlyArray1<'py, i64>,
        k: PyReadonlyArray1<'py, i64>,
        u: PyReadonlyArray1<'py, f64>,
        v: PyReadonlyArray1<'py, f64>,
    ) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let at = face_coords(&face, &k, &u, &v)?;
        let n = at.len();
        let uv = match self.uv.get() {
            Some(s) => s,
            None => {
                let mesh = ControlMesh {
                    options: self.options,
                    ..self.mesh.clone()
                };
                let s = UvSurface::new(&mesh, self.options.fvar).map_err(py_err)?;
                self.uv.get_or_init(|| s)
            }
        };
        let Some(uv) = uv else {
            return Err(usage(
                "the mesh has no texture coordinates (no `vt` in its faces)".into(),
            ));
        };
        let mut out = Vec::with_capacity(6 * n);
        for (i, &at) in at.iter().enumerate() {
            self.table
                .eval(at)
                .map_err(|e| usage(format!("sample {i}: {e}")))?;
            let s = uv.eval(at).map_err(|e| usage(format!("sample {i}: {e}")))?;
            out.extend_from_slice(&s.st);
            out.extend_from_slice(&s.du);
            out.extend_from_slice(&s.dv);
        }
        Ok(matrix(py, n, 6, out))
    }

    /// Closest hits of rays on the limit surface diced at `rate`: a dict of arrays (see the
    /// package's `Surface.trace`).
    #[pyo3(signature = (origins, directions, rate=16, exact=false, shading_normals=true))]
    fn trace<'py>(
        &self,
        py: Python<'py>,
        origins: PyReadonlyArray2<'py, f64>,
        directions: PyReadonlyArray2<'py, f64>,
        rate: u32,
        exact: bool,
        shading_normals: bool,
    ) -> PyResult<Bound<'py, PyDict>> {
        check_rate(rate)?;
        if exact && self.displace.is_some() {
            return Err(usage(
                "exact=True traces the exact limit surface, which displace leaves: drop one"
                    .to_string(),
            ));
        }
        let shape = origins.shape().to_vec();
        if shape.len() != 2 || shape[1] != 3 || directions.shape() != shape.as_slice() {
            return Err(usage(format!(
                "origins and directions must both be (N, 3); found {:?} and {:?}",
                origins.shape(),
                directions.shape()
            )));
        }
        let o = origins.as_slice()?.to_vec();
        let d = directions.as_slice()?.to_vec();
        let n = shape[0];
        let res = py.detach(|| -> PyResult<TraceOut> {
            // The rays as given (f64, for the reference intersector) and their f32 rounding
            // (for the diced surface's BVH, like the CLI).
            let mut rays64 = Vec::with_capacity(n);
            let mut rays = Vec::with_capacity(n);
            for i in 0..n {
                let (oi, di) = (&o[3 * i..3 * i + 3], &d[3 * i..3 * i + 3]);
                let finite = |x: f64| {
                    if exact {
                        x.is_finite()
                    } else {
                        (x as f32).is_finite()
                    }
                };
                if let Some(x) = oi.iter().chain(di).find(|&&x| !finite(x)) {
                    return Err(usage(format!("ray {i}: invalid number '{x}'")));
                }
                let ray = Ray64::new([oi[0], oi[1], oi[2]], [di[0], di[1], di[2]]);
                let rounded = ray.to_f32();
                let zero = if exact {
                    ray.dir == [0.0; 3]
                } else {
                    rounded.dir == [0.0; 3]
                };
                if zero {
                    return Err(usage(format!("ray {i}: ray direction is zero")));
                }
                rays64.push(ray);
                rays.push(rounded);
            }
            let mut out = TraceOut::with_capacity(n);
            if exact {
                let tracer = self.exact_tracer().map_err(py_err)?;
                for x in tracer.trace_batch(&rays64) {
                    out.push_exact(&x);
                }
                return Ok(out);
            }
            let bvh = self.bvh(rate, shading_normals).map_err(py_err)?;
            for h in bvh.intersect_batch(&rays) {
                match h {
                    None => out.miss(),
                    // A Loop triangle is diced as three sub-quads: its hits report the
                    // triangle's own (u, v) and k = 0, as `limitray trace` does.
                    Some(h) if self.options.scheme == Scheme::Loop => {
                        let ([u, v], _) =
                            LoopSurface::sub_quad_uv(h.k as usize, h.u as f64, h.v as f64);
                        out.push(h.t as f64, h.face, 0, u, v, h.ns.map(|c| c as f64))
                    }
                    Some(h) => out.push(
                        h.t as f64,
                        h.face,
                        h.k,
                        h.u as f64,
                        h.v as f64,
                        h.ns.map(|c| c as f64),
                    ),
                }
            }
            Ok(out)
        })?;
        let dict = PyDict::new(py);
        dict.set_item("hit", res.hit.into_pyarray(py))?;
        dict.set_item("t", res.t.into_pyarray(py))?;
        dict.set_item("face", res.face.into_pyarray(py))?;
        dict.set_item("k", res.k.into_pyarray(py))?;
        dict.set_item("u", res.u.into_pyarray(py))?;
        dict.set_item("v", res.v.into_pyarray(py))?;
        dict.set_item("n", matrix(py, n, 3, res.n))?;
        if exact {
            dict.set_item("err", res.err.into_pyarray(py))?;
            dict.set_item("sharp", res.sharp.into_pyarray(py))?;
            dict.set_item("grazing", res.grazing.into_pyarray(py))?;
        }
        Ok(dict)
    }

    /// Uniform refinement to `level` (what `limitray refine` writes): positions (V, 3) f64,
    /// face offsets (F + 1) and face vertices, holes left out; with `limit`, the exact limit
    /// positions of the level's vertices.
    #[pyo3(signature = (level, limit=false))]
    #[allow(clippy::type_complexity)]
    fn refine<'py>(
        &self,
        py: Python<'py>,
        level: usize,
        limit: bool,
    ) -> PyResult<(
        Bound<'py, PyArray2<f64>>,
        Bound<'py, PyArray1<i64>>,
        Bound<'py, PyArray1<i64>>,
        Vec<String>,
    )> {
        let (pos, offsets, verts, warnings) = py.detach(|| -> PyResult<_> {
            let r = Refiner::with_options(&self.mesh, self.options, level).map_err(py_err)?;
            let mut pos = r.refine_positions(&self.mesh.positions, level);
            let lvl = &r.levels[level];
            if limit {
                pos = match self.table.loop_surface() {
                    Some(loop_surface) => loop_surface
                        .limit_positions(lvl, level, &pos)
                        .map_err(py_err)?,
                    None => limitray::refine::limit::limit_positions(
                        lvl,
                        &pos,
                        self.options.crease_method,
                    ),
                };
            }
            let mut offsets = vec![0i64];
            let mut verts = Vec::new();
            for f in 0..lvl.num_faces() {
                if !lvl.face_hole[f] {
                    verts.extend(lvl.topo.face_vertices(f).iter().map(|&v| v as i64));
                    offsets.push(verts.len() as i64);
                }
            }
            let flat: Vec<f64> = pos.iter().flatten().copied().collect();
            Ok((flat, offsets, verts, r.warnings.clone()))
        })?;
        let nv = pos.len() / 3;
        Ok((
            matrix(py, nv, 3, pos),
            offsets.into_pyarray(py),
            verts.into_pyarray(py),
            warnings,
        ))
    }

    /// The limit surface diced at a uniform `rate` (what `limitray dice --rate` writes):
    /// positions (V, 3) f32, normals (V, 3) f32, triangles (T, 3), and each vertex's face, k,
    /// u, v.
    #[pyo3(signature = (rate=16))]
    #[allow(clippy::type_complexity)]
    fn dice<'py>(
        &self,
        py: Python<'py>,
        rate: u32,
    ) -> PyResult<(
        Bound<'py, PyArray2<f32>>,
        Bound<'py, PyArray2<f32>>,
        Bound<'py, PyArray2<i64>>,
        Bound<'py, PyDict>,
    )> {
        check_rate(rate)?;
        let d = py
            .detach(|| dice(&self.table, &self.mesh, &self.dice_options(rate)))
            .map_err(py_err)?;
        let nv = d.positions.len();
        let nt = d.triangles.len();
        let pos: Vec<f32> = d.positions.iter().flatten().copied().collect();
        let nrm: Vec<f32> = d.normals.iter().flatten().copied().collect();
        let tri: Vec<i64> = d.triangles.iter().flatten().map(|&i| i as i64).collect();
        let params = PyDict::new(py);
        let ints = |f: fn(&FaceCoord) -> u32| -> Vec<i64> {
            d.params.iter().map(|p| f(p) as i64).collect()
        };
        let reals = |f: fn(&FaceCoord) -> f64| -> Vec<f64> { d.params.iter().map(f).collect() };
        params.set_item("face", ints(|p| p.face).into_pyarray(py))?;
        params.set_item("k", ints(|p| p.k).into_pyarray(py))?;
        params.set_item("u", reals(|p| p.u).into_pyarray(py))?;
        params.set_item("v", reals(|p| p.v).into_pyarray(py))?;
        Ok((
            matrix(py, nv, 3, pos),
            matrix(py, nv, 3, nrm),
            matrix(py, nt, 3, tri),
            params,
        ))
    }
}

/// Columns of the trace result.
struct TraceOut {
    hit: Vec<bool>,
    t: Vec<f64>,
    face: Vec<i64>,
    k: Vec<i64>,
    u: Vec<f64>,
    v: Vec<f64>,
    n: Vec<f64>,
    /// With `exact`: the error bound relative to the diagonal (the CLI's tenth `trace
    /// --exact` field; for a grazing miss the distance of the undecided region, else NaN).
    err: Vec<f64>,
    /// With `exact`: the hit is on an infinitely sharp feature.
    sharp: Vec<bool>,
    /// With `exact`: undecided pieces within `err` of the ray (a grazing hit or miss).
    grazing: Vec<bool>,
}

impl TraceOut {
    fn with_capacity(n: usize) -> TraceOut {
        TraceOut {
            hit: Vec::with_capacity(n),
            t: Vec::with_capacity(n),
            face: Vec::with_capacity(n),
            k: Vec::with_capacity(n),
            u: Vec::with_capacity(n),
            v: Vec::with_capacity(n),
            n: Vec::with_capacity(3 * n),
            err: Vec::with_capacity(n),
            sharp: Vec::with_capacity(n),
            grazing: Vec::with_capacity(n),
        }
    }

    fn miss(&mut self) {
        self.hit.push(false);
        self.t.push(f64::INFINITY);
        self.face.push(-1);
        self.k.push(-1);
        self.u.push(f64::NAN);
        self.v.push(f64::NAN);
        self.n.extend_from_slice(&[f64::NAN; 3]);
    }

    fn push_exact(&mut self, x: &ExactTrace) {
        match &x.hit {
            Some(h) => {
                self.push(h.t, h.face, h.k, h.u, h.v, h.n);
                self.err.push(h.err);
                self.sharp.push(h.sharp);
                self.grazing.push(h.grazing);
            }
            None => {
                self.miss();
                self.err.push(x.graze.unwrap_or(f64::NAN));
                self.sharp.push(false);
                self.grazing.push(x.graze.is_some());
            }
        }
    }

    fn push(&mut self, t: f64, face: u32, k: u32, u: f64, v: f64, n: [f64; 3]) {
        self.hit.push(true);
        self.t.push(t);
        self.face.push(face as i64);
        self.k.push(k as i64);
        self.u.push(u);
        self.v.push(v);
        self.n.extend_from_slice(&n);
    }
}

/// The compiled part of the `limitray` package.
#[pymodule]
fn _limitray(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<Surface>()?;
    m.add(
        "DEFAULT_MAX_LEVEL",
        limitray::patch::table::DEFAULT_MAX_LEVEL,
    )?;
    Ok(())
}
