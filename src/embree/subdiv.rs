//! A [`ControlMesh`] as Embree subdivision geometry (`RTC_GEOMETRY_TYPE_SUBDIVISION`).
//!
//! Mapping of the tags (measured against OpenSubdiv, see `../shared/DESIGN.md`):
//!
//! | limitray / OpenSubdiv              | Embree                                   |
//! |------------------------------------|------------------------------------------|
//! | `t crease s a b`                   | edge crease `(a, b)`, weight `s`         |
//! | `t corner s v`                     | vertex crease `v`, weight `s`            |
//! | `t hole f`                         | hole buffer entry `f`                    |
//! | sharpness ≥ 10                     | weight `+inf`                            |
//! | boundary edge-and-corner (default) | `RTC_SUBDIVISION_MODE_PIN_CORNERS`       |
//! | boundary edge-only                 | `RTC_SUBDIVISION_MODE_SMOOTH_BOUNDARY`   |
//! | boundary none                      | `RTC_SUBDIVISION_MODE_NO_BOUNDARY`       |
//!
//! Embree always applies Chaikin's rule to creases of varying sharpness (there is no switch),
//! so compare with limitray's [`CreaseMethod::Chaikin`](crate::mesh::CreaseMethod) mode.
//! The tessellation rate is uniform (`rtcSetGeometryTessellationRate`): `R` segments per edge
//! of a quad. Embree's rate `R` corresponds to limitray's `DiceRate::Uniform(R)` (which halves
//! it on n-gon sub-faces) on n-gons too: on catmark_nonquads, the mean `|Δt|` between the two
//! on n-gon faces is smallest at equal rates (7.1e-4 at 8/8, against 1.3e-3 at 8/16 and
//! 4.6e-3 at 8/4; quads 4.5e-5 at 8/8).

use super::{ffi, Device, Geometry, Scene, SceneBuilder, SceneOptions};
use crate::error::{Error, ErrorKind, Result};
use crate::mesh::{BoundaryInterpolation, ControlMesh, SHARPNESS_INFINITE};

/// Most vertices per face Embree's subdivision geometry accepts (its documented range is 3–15).
pub const MAX_FACE_SIZE: usize = 15;

/// Most faces around one vertex: Embree's one-ring arrays hold 64 faces
/// (`MAX_RING_FACE_VALENCE`); catmark_pole360 (valence 360) corrupts its heap.
pub const MAX_VERTEX_VALENCE: usize = 64;

/// Checks the limits of Embree's subdivision geometry ([`MAX_FACE_SIZE`],
/// [`MAX_VERTEX_VALENCE`]) so that unsupported meshes get an error instead of memory corruption.
pub fn check_embree_limits(mesh: &ControlMesh) -> Result<()> {
    use crate::mesh::Element;
    for f in 0..mesh.num_faces() {
        let n = mesh.face(f).len();
        if n > MAX_FACE_SIZE {
            return Err(mesh.error_at(
                ErrorKind::Usage,
                Element::Face(f),
                format!("Embree's subdivision geometry supports faces of at most {MAX_FACE_SIZE} vertices; this one has {n}"),
            ));
        }
    }
    let mut valence = vec![0usize; mesh.num_vertices()];
    for &v in &mesh.face_verts {
        valence[v as usize] += 1;
    }
    if let Some((v, &n)) = valence
        .iter()
        .enumerate()
        .find(|(_, &n)| n > MAX_VERTEX_VALENCE)
    {
        return Err(mesh.error_at(
            ErrorKind::Usage,
            Element::Vertex(v),
            format!("Embree's subdivision geometry supports at most {MAX_VERTEX_VALENCE} faces around a vertex; this one has {n}"),
        ));
    }
    Ok(())
}

/// Largest tessellation rate accepted (Embree itself clamps grids far below this).
pub const MAX_RATE: f32 = 4096.0;

/// Embree's subdivision mode for a boundary interpolation rule.
pub fn subdivision_mode(boundary: BoundaryInterpolation) -> u32 {
    match boundary {
        BoundaryInterpolation::EdgeAndCorner => ffi::RTC_SUBDIVISION_MODE_PIN_CORNERS,
        BoundaryInterpolation::EdgeOnly => ffi::RTC_SUBDIVISION_MODE_SMOOTH_BOUNDARY,
        BoundaryInterpolation::None => ffi::RTC_SUBDIVISION_MODE_NO_BOUNDARY,
    }
}

/// Embree's crease weight for a RenderMan sharpness (≥ 10 is infinitely sharp).
pub fn crease_weight(sharpness: f32) -> f32 {
    if sharpness >= SHARPNESS_INFINITE {
        f32::INFINITY
    } else {
        sharpness
    }
}

/// Checks a tessellation rate: finite, in `[1, MAX_RATE]`.
pub fn check_rate(rate: f32) -> Result<()> {
    if rate.is_finite() && (1.0..=MAX_RATE).contains(&rate) {
        Ok(())
    } else {
        Err(Error::new(
            ErrorKind::Usage,
            format!("tessellation rate {rate} must be between 1 and {MAX_RATE}"),
        ))
    }
}

/// Builds (and commits) the subdivision geometry of `mesh` with `boundary` interpolation and a
/// uniform tessellation `rate`. The mesh is validated first; positions are rounded to `f32`.
pub fn subdivision_geometry(
    device: &Device,
    mesh: &ControlMesh,
    boundary: BoundaryInterpolation,
    rate: f32,
) -> Result<Geometry> {
    subdivision_geometry_with_mode(device, mesh, subdivision_mode(boundary), rate)
}

/// [`subdivision_geometry`] with an explicit `RTC_SUBDIVISION_MODE_*` (for experiments).
pub fn subdivision_geometry_with_mode(
    device: &Device,
    mesh: &ControlMesh,
    mode: u32,
    rate: f32,
) -> Result<Geometry> {
    build(device, mesh, mode, rate, None)
}

/// [`subdivision_geometry`] displaced by Embree itself (`rtcSetGeometryDisplacementFunction`)
/// by limitray's noise displacement ([`crate::dice::Displacement::Noise`]):
/// `amplitude · noise(frequency · P)` along the unit limit normal, `P` the limit point Embree
/// evaluates. Embree applies it to its grid vertices during the scene build, so the build time
/// includes it (the peer of `dice --displace noise:…`).
pub fn subdivision_geometry_noise(
    device: &Device,
    mesh: &ControlMesh,
    boundary: BoundaryInterpolation,
    rate: f32,
    amplitude: f64,
    frequency: f64,
) -> Result<Geometry> {
    let noise = Some([amplitude, frequency]);
    build(device, mesh, subdivision_mode(boundary), rate, noise)
}

/// Embree's displacement callback for [`subdivision_geometry_noise`].
///
/// # Safety
/// Embree calls it with `n` valid points and the geometry's user data, a `[f64; 2]`
/// (amplitude, frequency) that the geometry owns.
unsafe extern "C" fn displace_noise(args: *const ffi::RTCDisplacementFunctionNArguments) {
    // SAFETY: see the function's contract.
    let a = unsafe { &*args };
    let [amplitude, frequency] = unsafe { *(a.geometry_user_ptr as *const [f64; 2]) };
    for i in 0..a.n as usize {
        // SAFETY: index within the n points.
        unsafe {
            let n = [*a.ng_x.add(i), *a.ng_y.add(i), *a.ng_z.add(i)].map(f64::from);
            let len = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
            if !(len > 0.0 && len.is_finite()) {
                continue;
            }
            let p = [*a.p_x.add(i), *a.p_y.add(i), *a.p_z.add(i)].map(f64::from);
            let h = amplitude * crate::texture::noise::noise(p.map(|c| c * frequency)).0 / len;
            *a.p_x.add(i) = (p[0] + h * n[0]) as f32;
            *a.p_y.add(i) = (p[1] + h * n[1]) as f32;
            *a.p_z.add(i) = (p[2] + h * n[2]) as f32;
        }
    }
}

fn build(
    device: &Device,
    mesh: &ControlMesh,
    mode: u32,
    rate: f32,
    noise: Option<[f64; 2]>,
) -> Result<Geometry> {
    mesh.validate()?;
    check_embree_limits(mesh)?;
    check_rate(rate)?;
    if mesh.num_faces() == 0 {
        return Err(Error::new(ErrorKind::Usage, "the mesh has no faces"));
    }
    let mut g = Geometry::new(device, ffi::RTC_GEOMETRY_TYPE_SUBDIVISION)?;
    let sizes: Vec<u32> = mesh.face_offsets.windows(2).map(|w| w[1] - w[0]).collect();
    g.set_buffer(
        ffi::RTC_BUFFER_TYPE_FACE,
        0,
        ffi::RTC_FORMAT_UINT,
        1,
        &sizes,
    )?;
    g.set_buffer(
        ffi::RTC_BUFFER_TYPE_INDEX,
        0,
        ffi::RTC_FORMAT_UINT,
        1,
        &mesh.face_verts,
    )?;
    let verts: Vec<f32> = mesh
        .positions
        .iter()
        .flat_map(|p| p.map(|c| c as f32))
        .collect();
    g.set_buffer(
        ffi::RTC_BUFFER_TYPE_VERTEX,
        0,
        ffi::RTC_FORMAT_FLOAT3,
        3,
        &verts,
    )?;

    let creases: Vec<_> = mesh.creases.iter().filter(|c| c.sharpness > 0.0).collect();
    let idx: Vec<u32> = creases.iter().flat_map(|c| [c.v0, c.v1]).collect();
    let w: Vec<f32> = creases.iter().map(|c| crease_weight(c.sharpness)).collect();
    g.set_buffer(
        ffi::RTC_BUFFER_TYPE_EDGE_CREASE_INDEX,
        0,
        ffi::RTC_FORMAT_UINT2,
        2,
        &idx,
    )?;
    g.set_buffer(
        ffi::RTC_BUFFER_TYPE_EDGE_CREASE_WEIGHT,
        0,
        ffi::RTC_FORMAT_FLOAT,
        1,
        &w,
    )?;

    let corners: Vec<_> = mesh.corners.iter().filter(|c| c.sharpness > 0.0).collect();
    let idx: Vec<u32> = corners.iter().map(|c| c.vertex).collect();
    let w: Vec<f32> = corners.iter().map(|c| crease_weight(c.sharpness)).collect();
    g.set_buffer(
        ffi::RTC_BUFFER_TYPE_VERTEX_CREASE_INDEX,
        0,
        ffi::RTC_FORMAT_UINT,
        1,
        &idx,
    )?;
    g.set_buffer(
        ffi::RTC_BUFFER_TYPE_VERTEX_CREASE_WEIGHT,
        0,
        ffi::RTC_FORMAT_FLOAT,
        1,
        &w,
    )?;

    let mut holes = mesh.holes.clone();
    holes.sort_unstable();
    holes.dedup();
    g.set_buffer(
        ffi::RTC_BUFFER_TYPE_HOLE,
        0,
        ffi::RTC_FORMAT_UINT,
        1,
        &holes,
    )?;

    // SAFETY: valid geometry of the subdivision type.
    unsafe {
        ffi::rtcSetGeometrySubdivisionMode(g.raw(), 0, mode);
        ffi::rtcSetGeometryTessellationRate(g.raw(), rate);
    }
    if let Some(params) = noise {
        g.set_displacement(Box::new(params), displace_noise);
    }
    device.check("subdivision parameters")?;
    g.commit()?;
    Ok(g)
}

/// A committed scene holding only the subdivision geometry of `mesh` (geometry id 0).
pub fn subdivision_scene(
    device: &Device,
    mesh: &ControlMesh,
    boundary: BoundaryInterpolation,
    rate: f32,
    options: SceneOptions,
) -> Result<Scene> {
    subdivision_scene_noise(device, mesh, boundary, rate, options, None)
}

/// [`subdivision_scene`], displaced by `noise` (amplitude, frequency) when given
/// ([`subdivision_geometry_noise`]).
pub fn subdivision_scene_noise(
    device: &Device,
    mesh: &ControlMesh,
    boundary: BoundaryInterpolation,
    rate: f32,
    options: SceneOptions,
    noise: Option<(f64, f64)>,
) -> Result<Scene> {
    let g = match noise {
        Some((a, f)) => subdivision_geometry_noise(device, mesh, boundary, rate, a, f)?,
        None => subdivision_geometry(device, mesh, boundary, rate)?,
    };
    let mut b = SceneBuilder::new(device, options)?;
    b.attach(g)?;
    b.commit()
}

/// Maps Embree's per-face `(u, v)` of a hit on (or an `rtcInterpolate` argument for) a base
/// face with `n` vertices to limitray's ptex parameters `(k, u, v)`.
///
/// - Quads: the same parameterisation, `k = 0` (measured on a single quad: Embree's `(0,0)`,
///   `(1,0)`, `(1,1)`, `(0,1)` are vertices 0, 1, 2, 3, as in the ptex convention).
/// - Other faces: Embree packs sub-face `k` (the quad at corner `k` after one Catmull-Clark
///   step, oriented as limitray's sub-face `k`) into `u ∈ [2 (k mod 4) + 0.5, 2 (k mod 4) + 1.5]`,
///   `v ∈ [2 ⌊k / 4⌋ + 0.5, 2 ⌊k / 4⌋ + 1.5]`; the local parameters are what is left after
///   subtracting the cell's lower corner. (Measured with `rtcInterpolate` against
///   [`crate::patch::PatchTable::eval`] on triangles, pentagons and larger n-gons; see
///   `tests/embree.rs`.)
pub fn embree_uv_to_ptex(n: usize, u: f32, v: f32) -> (usize, f64, f64) {
    let (u, v) = (u as f64, v as f64);
    if n == 4 {
        return (0, u.clamp(0.0, 1.0), v.clamp(0.0, 1.0));
    }
    let cu = (u * 0.5).floor().clamp(0.0, 3.0);
    let cv = (v * 0.5).floor().max(0.0);
    let k = ((4.0 * cv + cu) as usize).min(n.saturating_sub(1));
    let (cu, cv) = ((k % 4) as f64, (k / 4) as f64);
    let lu = (u - 2.0 * cu - 0.5).clamp(0.0, 1.0);
    let lv = (v - 2.0 * cv - 0.5).clamp(0.0, 1.0);
    (k, lu, lv)
}

/// The inverse of [`embree_uv_to_ptex`]: Embree's `(u, v)` for ptex `(k, u, v)` on a base face
/// with `n` vertices.
pub fn ptex_to_embree_uv(n: usize, k: usize, u: f64, v: f64) -> (f32, f32) {
    if n == 4 {
        return (u as f32, v as f32);
    }
    let (cu, cv) = ((k % 4) as f64, (k / 4) as f64);
    ((2.0 * cu + 0.5 + u) as f32, (2.0 * cv + 0.5 + v) as f32)
}
