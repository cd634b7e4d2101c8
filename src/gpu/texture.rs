//! Texture maps for the GPU path tracer (`kernels/texture.wgsl`): each distinct texture once
//! in the render block (noise: its frequency; images: every level of the CPU's own mip
//! pyramid, texel for texel), each material's three map slots, and per mesh the texture
//! coordinates of its vertices.
//!
//! Texture coordinates: the CPU evaluates the exact limit texture coordinates at each hit;
//! the GPU reads them at the triangle's three vertices, evaluated exactly the same way (the
//! limit of the face-varying values, or the (sub-)face's own `(u, v)` on a mesh without
//! them) and interpolates them with the hit's barycentrics. Each block belongs to one face,
//! so a UV seam is a block boundary and the interpolation never crosses one. The two differ
//! by the curvature of the texture map over one triangle, a fraction of a texel at the
//! dicing rates that resolve the surface (`tests/gpu_render.rs` measures it).

use super::layout::*;
use super::render::here;
use crate::error::Result;
use crate::grid::GridMesh;
use crate::patch::uv::UvSurface;
use crate::render::texturing::MaterialTextures;
use crate::render::World;
use crate::texture::Texture;

/// Appends `t`'s record (and an image's texels); returns its offset.
fn push_texture(w: &mut Vec<u32>, t: &Texture) -> Result<u32> {
    match t {
        Texture::Noise { frequency } => {
            let at = here(w)?;
            let mut head = [0u32; TEX_LEVEL0];
            head[TEX_KIND] = TEX_NOISE;
            head[TEX_FREQUENCY] = (*frequency as f32).to_bits();
            w.extend_from_slice(&head);
            Ok(at)
        }
        Texture::Image(img) => {
            let mut levels = Vec::with_capacity(img.levels());
            for i in 0..img.levels() {
                let (width, height, texels) = img.level(i);
                let off = here(w)?;
                w.extend(texels.iter().flatten().map(|x| x.to_bits()));
                let mut rec = [0u32; LVL_WORDS];
                rec[LVL_WIDTH] = width as u32;
                rec[LVL_HEIGHT] = height as u32;
                rec[LVL_TEXELS] = off;
                levels.push(rec);
            }
            let at = here(w)?;
            let mut head = [0u32; TEX_LEVEL0];
            head[TEX_KIND] = TEX_IMAGE;
            head[TEX_LEVELS] = levels.len() as u32;
            w.extend_from_slice(&head);
            w.extend(levels.into_iter().flatten());
            here(w)?;
            Ok(at)
        }
    }
}

/// Packs the materials' maps, each distinct texture (the same image shared by several
/// materials, or the same noise) once; returns per material the offsets of its albedo,
/// roughness and emission maps (`NONE` where it has none).
pub fn pack_material_maps(w: &mut Vec<u32>, maps: &[MaterialTextures]) -> Result<Vec<[u32; 3]>> {
    let mut seen: Vec<(Texture, u32)> = Vec::new();
    let mut slot = |w: &mut Vec<u32>, t: &Option<Texture>| -> Result<u32> {
        let Some(t) = t else { return Ok(NONE) };
        let same = |a: &Texture, b: &Texture| match (a, b) {
            (Texture::Image(x), Texture::Image(y)) => std::sync::Arc::ptr_eq(x, y),
            _ => a == b,
        };
        if let Some(&(_, at)) = seen.iter().find(|(s, _)| same(s, t)) {
            return Ok(at);
        }
        let at = push_texture(w, t)?;
        seen.push((t.clone(), at));
        Ok(at)
    };
    maps.iter()
        .map(|m| {
            Ok([
                slot(w, &m.albedo)?,
                slot(w, &m.roughness)?,
                slot(w, &m.emission)?,
            ])
        })
        .collect()
}

/// The texture coordinates at `(face, k, u, v)`: the limit texture coordinates, or `(u, v)`
/// without them (or where they cannot be evaluated), as the CPU's hits read them.
fn st_at(uv: Option<&UvSurface>, face: u32, k: u32, at: [f32; 2]) -> [f32; 2] {
    match UvSurface::at_hit(uv, face, k, at) {
        (_, Some(Ok(s))) => [s.st[0] as f32, s.st[1] as f32],
        (c, _) => [c.u as f32, c.v as f32],
    }
}

/// Appends the texture coordinates of `m`'s block vertices (in the order of its normals) and
/// of its loose triangles' corners; returns their offsets.
fn push_st(w: &mut Vec<u32>, m: &GridMesh, uv: Option<&UvSurface>) -> Result<(u32, u32)> {
    let mut st = vec![0u32; 2 * m.normals.len()];
    for b in &m.blocks {
        let width = b.cols as usize + 1;
        for y in 0..=b.rows as usize {
            for x in 0..width {
                let i = b.normal() as usize + y * width + x;
                let s = st_at(uv, b.face, b.k, b.uv(x, y));
                st[2 * i] = s[0].to_bits();
                st[2 * i + 1] = s[1].to_bits();
            }
        }
    }
    let at = here(w)?;
    w.extend_from_slice(&st);
    let loose_at = here(w)?;
    for l in &m.loose {
        for c in l.uv {
            let s = st_at(uv, l.face, l.k, c);
            w.extend_from_slice(&[s[0].to_bits(), s[1].to_bits()]);
        }
    }
    here(w)?;
    Ok((at, loose_at))
}

/// Per mesh of `world`: the offsets of its vertices' texture coordinates and of its loose
/// corners' (`NONE` for a mesh none of whose instances has an image map).
pub fn pack_mesh_st(w: &mut Vec<u32>, world: &World) -> Result<Vec<(u32, u32)>> {
    let mut out = Vec::with_capacity(world.scene.meshes.len());
    for (mi, m) in world.scene.meshes.iter().enumerate() {
        // The first instance of this mesh whose material reads texture coordinates.
        let user = world.scene.instances.iter().enumerate().find(|(i, inst)| {
            inst.mesh as usize == mi
                && world.instance_maps[*i].is_some()
                && world.textures[world.instance_material[*i] as usize].uses_uv()
        });
        out.push(match user {
            Some((i, _)) => {
                let uv = world.instance_maps[i]
                    .as_ref()
                    .and_then(|x| x.uv.as_deref());
                push_st(w, m, uv)?
            }
            None => (NONE, NONE),
        });
    }
    Ok(out)
}
