//! limitray's own diced triangles as an Embree triangle geometry (`RTC_GEOMETRY_TYPE_TRIANGLE`),
//! triangle `i` of the [`DicedMesh`] being Embree primitive `i`, with the same corner order
//! (Embree's hit `u`, `v` are then the barycentric weights of corners 1 and 2, like
//! [`crate::bvh::Hit::b1`], [`crate::bvh::Hit::b2`]).

use super::{ffi, Device, Geometry, Scene, SceneBuilder, SceneOptions};
use crate::dice::DicedMesh;
use crate::error::{Error, ErrorKind, Result};

/// Builds (and commits) the triangle geometry of `diced`.
pub fn triangle_geometry(device: &Device, diced: &DicedMesh) -> Result<Geometry> {
    if diced.triangles.is_empty() {
        return Err(Error::new(
            ErrorKind::Usage,
            "the diced mesh has no triangles",
        ));
    }
    let nv = diced.positions.len();
    if let Some(t) = diced
        .triangles
        .iter()
        .find(|t| t.iter().any(|&i| i as usize >= nv))
    {
        return Err(Error::new(
            ErrorKind::Usage,
            format!("diced triangle {t:?} indexes beyond {nv} vertices"),
        ));
    }
    let mut g = Geometry::new(device, ffi::RTC_GEOMETRY_TYPE_TRIANGLE)?;
    let verts: Vec<f32> = diced.positions.iter().flatten().copied().collect();
    g.set_buffer(
        ffi::RTC_BUFFER_TYPE_VERTEX,
        0,
        ffi::RTC_FORMAT_FLOAT3,
        3,
        &verts,
    )?;
    let idx: Vec<u32> = diced.triangles.iter().flatten().copied().collect();
    g.set_buffer(
        ffi::RTC_BUFFER_TYPE_INDEX,
        0,
        ffi::RTC_FORMAT_UINT3,
        3,
        &idx,
    )?;
    g.commit()?;
    Ok(g)
}

/// A committed scene holding only the triangles of `diced` (geometry id 0).
pub fn triangle_scene(device: &Device, diced: &DicedMesh, options: SceneOptions) -> Result<Scene> {
    let g = triangle_geometry(device, diced)?;
    let mut b = SceneBuilder::new(device, options)?;
    b.attach(g)?;
    b.commit()
}
