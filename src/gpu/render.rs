//! Path tracing on the GPU (`kernels/path.wgsl`): the CPU renderer's paths (same RNG, same
//! sample dimensions, same sampling and materials), one invocation per pixel, samples added in
//! sample order.

use super::trace::{layout, BVH_WGSL};
use super::GpuContext;
use crate::error::Result;

const PATH_WGSL: [&str; 3] = [
    include_str!("../../kernels/sampling.wgsl"),
    include_str!("../../kernels/material.wgsl"),
    include_str!("../../kernels/path.wgsl"),
];

/// The path-tracing kernels.
pub struct PathKernels {
    /// Bind group layout: geometry, then the accumulators (9) and the primary-hit records (10).
    pub layout: wgpu::BindGroupLayout,
    /// `path_main`: adds samples to the pixels' accumulators.
    pub path: wgpu::ComputePipeline,
    /// `primary_main`: the centre ray of each pixel.
    pub primary: wgpu::ComputePipeline,
}

impl PathKernels {
    /// Compiles the kernels for geometry in `geo_used` chunks.
    pub fn new(ctx: &GpuContext, geo_used: usize) -> Result<PathKernels> {
        let layout = layout(ctx, &[false, false]);
        let src = [BVH_WGSL.as_slice(), PATH_WGSL.as_slice()]
            .concat()
            .join("\n");
        let c = [("GEO_USED", geo_used as f64)];
        let path = ctx.compute_pipeline("path", &src, "path_main", &layout, &c)?;
        let primary = ctx.compute_pipeline("primary", &src, "primary_main", &layout, &c)?;
        Ok(PathKernels {
            layout,
            path,
            primary,
        })
    }
}

use super::geometry::{GpuGeometry, PackedScene};
use super::trace::{bind_group, Params, RawHit, TARGET_DISPATCH_S};
use crate::error::{Error, ErrorKind};
use crate::render::env::Environment;
use crate::render::film::{PixelValue, Tile};
use crate::render::material::{Fresnel, Material};
use crate::render::sampling::{Distribution1D, Distribution2D};
use crate::render::{Film, World};
use wgpu::util::DeviceExt;

/// Header words of the render block (see `kernels/path.wgsl`).
const HEADER_WORDS: usize = 40;
/// Floats per pixel accumulator.
const ACC: usize = 12;
/// Words per primary-hit record.
const PRIM: usize = 8;
/// Pixels per accumulator chunk.
const CHUNK_PIXELS: usize = 1 << 14;

fn f(x: f32) -> u32 {
    x.to_bits()
}

fn push_v3(w: &mut Vec<u32>, v: glam::Vec3) {
    w.extend_from_slice(&[f(v.x), f(v.y), f(v.z)]);
}

fn here(w: &[u32]) -> Result<u32> {
    u32::try_from(w.len())
        .map_err(|_| Error::new(ErrorKind::Gpu, "scene too large for the GPU backend"))
}

fn push_dist(w: &mut Vec<u32>, d: &Distribution1D) -> Result<u32> {
    let at = here(w)?;
    w.push(d.pmf.len() as u32);
    w.push(f(d.total));
    w.extend(d.cdf.iter().map(|&x| f(x)));
    w.extend(d.pmf.iter().map(|&x| f(x)));
    Ok(at)
}

fn push_dist2(w: &mut Vec<u32>, d: &Distribution2D) -> Result<u32> {
    let rows = push_dist(w, &d.rows)?;
    let cols: Vec<u32> = d
        .cols
        .iter()
        .map(|c| push_dist(w, c))
        .collect::<Result<_>>()?;
    let at = here(w)?;
    w.extend_from_slice(&[d.width as u32, d.height as u32, rows]);
    w.extend_from_slice(&cols);
    Ok(at)
}

/// The scene's geometry words followed by the render block (camera, materials, lights,
/// environment, shading normals, instance transforms); returns the words and the block's
/// offset.
pub fn pack_world(world: &World) -> Result<(PackedScene, u32)> {
    let mut packed = PackedScene::from_scene(&world.scene)?;
    let w = &mut packed.words;
    let r = here(w)? as usize;
    w.resize(r + HEADER_WORDS, 0);
    let mut hdr = [0u32; HEADER_WORDS];
    let st = &world.settings;
    let cam = &world.camera;
    hdr[0] = cam.width;
    hdr[1] = cam.height;
    hdr[2] = st.spp;
    hdr[3] = st.max_depth;
    hdr[4] = st.seed;
    // Materials.
    hdr[5] = here(w)?;
    for m in &world.materials {
        let mut rec = [0u32; 12];
        match *m {
            Material::Diffuse { albedo } => {
                rec[0] = 0;
                rec[1..4].copy_from_slice(&[f(albedo.x), f(albedo.y), f(albedo.z)]);
            }
            Material::Conductor { fresnel, alpha } => {
                match fresnel {
                    Fresnel::Conductor { eta, k } => {
                        rec[0] = 1;
                        rec[1..4].copy_from_slice(&[f(eta.x), f(eta.y), f(eta.z)]);
                        rec[4..7].copy_from_slice(&[f(k.x), f(k.y), f(k.z)]);
                    }
                    Fresnel::Schlick { f0 } => {
                        rec[0] = 2;
                        rec[1..4].copy_from_slice(&[f(f0.x), f(f0.y), f(f0.z)]);
                    }
                }
                rec[7] = f(alpha);
            }
            Material::Dielectric { ior, alpha } => {
                rec[0] = 3;
                rec[1] = f(ior);
                rec[7] = f(alpha);
            }
            Material::Emissive { radiance } => {
                rec[0] = 4;
                rec[1..4].copy_from_slice(&[f(radiance.x), f(radiance.y), f(radiance.z)]);
            }
        }
        w.extend_from_slice(&rec);
    }
    let ninst = world.scene.num_instances();
    if world.instance_material.len() != ninst || world.transforms.len() != ninst {
        return Err(Error::new(
            ErrorKind::Gpu,
            "world has a material and a transform per instance only partly",
        ));
    }
    if world
        .instance_material
        .iter()
        .any(|&m| m as usize >= world.materials.len())
    {
        return Err(Error::new(ErrorKind::Gpu, "instance material out of range"));
    }
    hdr[6] = here(w)?;
    w.extend_from_slice(&world.instance_material);
    // Quad lights.
    let l = &world.lights;
    hdr[7] = l.quads.len() as u32;
    hdr[8] = here(w)?;
    for q in &l.quads {
        push_v3(w, q.corner);
        push_v3(w, q.edge1);
        push_v3(w, q.edge2);
        push_v3(w, q.normal);
        w.push(f(q.area));
        push_v3(w, q.radiance);
    }
    // Mesh lights: triangles and distributions first, then the records.
    let mut recs = Vec::new();
    for m in &l.meshes {
        let tris = here(w)?;
        for t in &m.triangles {
            for v in t {
                push_v3(w, *v);
            }
        }
        let dist = push_dist(w, &m.dist)?;
        recs.push((m, tris, dist));
    }
    hdr[9] = l.meshes.len() as u32;
    hdr[10] = here(w)?;
    for (m, tris, dist) in recs {
        w.extend_from_slice(&[m.instance, f(m.area)]);
        push_v3(w, m.radiance);
        w.extend_from_slice(&[m.triangles.len() as u32, tris, dist]);
    }
    hdr[11] = here(w)?;
    for i in 0..ninst {
        w.push(
            l.instance_light
                .get(i)
                .copied()
                .flatten()
                .unwrap_or(u32::MAX),
        );
    }
    // Environment.
    match &l.env {
        None => hdr[12] = 0,
        Some(Environment::Constant(c)) => {
            hdr[12] = 1;
            hdr[13] = here(w)?;
            push_v3(w, *c);
        }
        Some(Environment::Map { map, rotate }) => {
            hdr[12] = 2;
            let texels = here(w)?;
            for t in &map.texels {
                push_v3(w, *t);
            }
            let dist = push_dist2(w, &map.dist)?;
            hdr[13] = here(w)?;
            w.extend_from_slice(&[
                map.width as u32,
                map.height as u32,
                f(*rotate),
                texels,
                dist,
            ]);
        }
    }
    hdr[14] = push_dist(w, &l.select)?;
    // Instance transforms: object-to-world (hit points), normal matrix (normals).
    hdr[15] = here(w)?;
    for (i, xf) in world.transforms.iter().enumerate() {
        let m = xf.matrix3;
        for c in [m.x_axis, m.y_axis, m.z_axis, xf.translation] {
            w.extend_from_slice(&[f(c.x), f(c.y), f(c.z)]);
        }
        let n = world.scene.instances[i].normal_matrix;
        for c in [n.x_axis, n.y_axis, n.z_axis] {
            w.extend_from_slice(&[f(c.x), f(c.y), f(c.z)]);
        }
        w.extend_from_slice(&[0, 0, 0]);
    }
    // Per mesh: the limit normals at the corners of each leaf-ordered triangle.
    let mut normals = Vec::new();
    for m in &world.scene.meshes {
        normals.push(here(w)?);
        for &tri in &m.tri_index {
            for &v in &m.diced.triangles[tri as usize] {
                let n = m.diced.normals[v as usize];
                w.extend_from_slice(&[f(n[0]), f(n[1]), f(n[2])]);
            }
        }
    }
    hdr[16] = here(w)?;
    for n in normals {
        w.extend_from_slice(&[n, 0, 0, 0]);
    }
    // Camera.
    let mut c = 20;
    for v in [cam.position, cam.forward, cam.right, cam.up] {
        hdr[c..c + 3].copy_from_slice(&[f(v.x), f(v.y), f(v.z)]);
        c += 3;
    }
    hdr[32] = f(cam.tan_half_fov);
    hdr[33] = f(cam.aperture);
    hdr[34] = f(cam.focus_distance);
    here(w)?;
    w[r..r + HEADER_WORDS].copy_from_slice(&hdr);
    Ok((packed, r as u32))
}

/// A world on the device with the path-tracing kernels.
pub struct GpuRenderer<'a> {
    ctx: &'a GpuContext,
    packed: PackedScene,
    render_off: u32,
    geo: GpuGeometry,
    kernels: PathKernels,
    width: u32,
    height: u32,
    spp: u32,
}

fn gpu_err(m: impl Into<String>) -> Error {
    Error::new(ErrorKind::Gpu, m)
}

impl<'a> GpuRenderer<'a> {
    /// Uploads `world` and compiles the kernels; `max_chunk_words` as in
    /// [`super::TraceOptions`].
    pub fn new(ctx: &'a GpuContext, world: &World, max_chunk_words: Option<u64>) -> Result<Self> {
        let (packed, render_off) = pack_world(world)?;
        let geo = GpuGeometry::upload(ctx, &packed, max_chunk_words)?;
        let kernels = PathKernels::new(ctx, geo.used_chunks)?;
        Ok(GpuRenderer {
            ctx,
            packed,
            render_off,
            geo,
            kernels,
            width: world.camera.width,
            height: world.camera.height,
            spp: world.settings.spp,
        })
    }

    fn params(&self) -> Params {
        let mut p = Params::new(&self.packed, &self.geo, 1 << 22);
        p.user1 = self.render_off;
        p
    }

    /// Runs `pipeline` over pixels `[p0, p0 + n)` for each sample range in `ranges`, with
    /// the accumulators starting at zero; returns the accumulators and the primary records.
    fn run(
        &self,
        pipeline: &wgpu::ComputePipeline,
        p0: u32,
        n: u32,
        mut next_range: impl FnMut(f64) -> Option<(u32, u32)>,
    ) -> Result<(Vec<f32>, Vec<u32>)> {
        let ctx = self.ctx;
        let acc_size = (n as usize * ACC * 4) as u64;
        let prim_size = (n as usize * PRIM * 4) as u64;
        let storage = wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC;
        let acc = ctx.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("accumulators"),
            size: acc_size,
            usage: storage | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let prim = ctx.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("primary hits"),
            size: prim_size,
            usage: storage,
            mapped_at_creation: false,
        });
        let mut params = self.params();
        params.user0 = p0;
        params.ray_count = n;
        let pbuf = ctx
            .device
            .create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some("params"),
                contents: bytemuck::bytes_of(&params),
                usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            });
        let bg = bind_group(ctx, &self.kernels.layout, &pbuf, &self.geo, &[&acc, &prim]);
        let mut last = 0.0;
        while let Some((s0, s1)) = next_range(last) {
            params.user2 = s0;
            params.user3 = s1;
            ctx.queue
                .write_buffer(&pbuf, 0, bytemuck::bytes_of(&params));
            let mut enc = ctx
                .device
                .create_command_encoder(&wgpu::CommandEncoderDescriptor { label: None });
            {
                let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor {
                    label: Some("path"),
                    timestamp_writes: None,
                });
                pass.set_pipeline(pipeline);
                pass.set_bind_group(0, &bg, &[]);
                pass.dispatch_workgroups(n.div_ceil(super::trace::WORKGROUP), 1, 1);
            }
            let t0 = std::time::Instant::now();
            ctx.queue.submit([enc.finish()]);
            ctx.wait()?;
            ctx.check()?;
            last = t0.elapsed().as_secs_f64();
        }
        let read = |src: &wgpu::Buffer, size: u64| -> Result<Vec<u8>> {
            let rb = ctx.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("readback"),
                size,
                usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            });
            let mut enc = ctx
                .device
                .create_command_encoder(&wgpu::CommandEncoderDescriptor { label: None });
            enc.copy_buffer_to_buffer(src, 0, &rb, 0, size);
            ctx.queue.submit([enc.finish()]);
            ctx.read_buffer(&rb, size)
        };
        let a = read(&acc, acc_size)?;
        let p = read(&prim, prim_size)?;
        Ok((
            bytemuck::cast_slice::<u8, f32>(&a).to_vec(),
            bytemuck::cast_slice::<u8, u32>(&p).to_vec(),
        ))
    }

    /// The centre ray of every pixel (the CPU renderer's AOV ray), row by row: status 0 miss,
    /// 1 mesh hit, 3 a quad light in front of the mesh.
    pub fn primary(&self) -> Result<Vec<RawHit>> {
        let npix = self.width as usize * self.height as usize;
        let mut out = Vec::with_capacity(npix);
        let mut p0 = 0;
        while p0 < npix {
            let n = (npix - p0).min(CHUNK_PIXELS);
            let mut once = true;
            let (_, prim) = self.run(&self.kernels.primary, p0 as u32, n as u32, |_| {
                std::mem::take(&mut once).then_some((0, 0))
            })?;
            for r in prim.chunks_exact(PRIM) {
                if r[0] == 2 {
                    return Err(gpu_err("a primary ray exceeded the GPU traversal bound"));
                }
                out.push(RawHit {
                    status: r[0],
                    instance: r[1],
                    leaf: r[2],
                    t: f32::from_bits(r[3]),
                    b1: f32::from_bits(r[4]),
                    b2: f32::from_bits(r[5]),
                    iterations: 0,
                });
            }
            p0 += n;
        }
        Ok(out)
    }

    /// Renders the image: what [`World::render`] computes, on the device. `progress` gets the
    /// fraction done.
    pub fn render(&self, world: &World, progress: &dyn Fn(f64)) -> Result<Film> {
        let (w, h) = (self.width, self.height);
        let npix = w as usize * h as usize;
        let spp = self.spp;
        let prim = self.primary()?;
        let mut values = Vec::with_capacity(npix);
        let mut p0 = 0;
        let mut per = 1u32;
        let total = npix as f64 * spp.max(1) as f64;
        let mut done = 0.0;
        while p0 < npix {
            let n = (npix - p0).min(CHUNK_PIXELS);
            let mut s = 0u32;
            let (acc, _) = self.run(&self.kernels.path, p0 as u32, n as u32, |secs| {
                if s > 0 {
                    done += n as f64 * per as f64;
                    progress(done / total);
                    // Samples per dispatch towards TARGET_DISPATCH_S (at most doubling).
                    let want = per as f64 * TARGET_DISPATCH_S / secs.max(1e-4);
                    per = (want as u32).clamp(1, per.saturating_mul(2));
                }
                if s >= spp {
                    return None;
                }
                let s1 = s.saturating_add(per).min(spp);
                let r = (s, s1);
                per = s1 - s;
                s = s1;
                Some(r)
            })?;
            let inv = 1.0 / spp.max(1) as f32;
            for (i, a) in acc.chunks_exact(ACC).enumerate() {
                if a[10] != 0.0 {
                    return Err(gpu_err("a path exceeded the GPU traversal bound"));
                }
                let mut v = PixelValue {
                    rgba: [a[0] * inv, a[1] * inv, a[2] * inv, a[3] * inv],
                    normal: [a[4] * inv, a[5] * inv, a[6] * inv],
                    albedo: [a[7] * inv, a[8] * inv, a[9] * inv],
                    ..PixelValue::default()
                };
                let ph = &prim[p0 + i];
                if ph.status == 1 {
                    let hit = world
                        .scene
                        .hit_record(ph.instance, ph.leaf as usize, ph.t, ph.b1, ph.b2)
                        .hit;
                    v.z = hit.t;
                    v.face = hit.face as f32;
                    v.level = hit.level as f32;
                }
                values.push(v);
            }
            p0 += n;
        }
        let mut film = Film::new(w, h);
        film.put_tile(
            &Tile {
                x0: 0,
                y0: 0,
                x1: w,
                y1: h,
            },
            &values,
        );
        Ok(film)
    }
}
