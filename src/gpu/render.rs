//! Path tracing on the GPU (`kernels/path.wgsl`): the CPU renderer's paths (same RNG, same
//! sample dimensions, same sampling and materials), one invocation per pixel, samples added in
//! sample order.

use super::layout::*;
use super::trace::layout;
use super::GpuContext;
use crate::error::Result;

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
    /// Compiles the kernels for geometry in `geo_used` chunks and mesh walks of at most
    /// `grid_stack` stack entries ([`PackedScene::grid_stack`]).
    pub fn new(ctx: &GpuContext, geo_used: usize, grid_stack: u32) -> Result<PathKernels> {
        let layout = layout(ctx, &[false, false]);
        let src = module_source(kernels::PATH_MODULE, grid_stack);
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

/// Pixels per accumulator chunk.
const CHUNK_PIXELS: usize = 1 << 14;

fn f(x: f32) -> u32 {
    x.to_bits()
}

fn push_v3(w: &mut Vec<u32>, v: glam::Vec3) {
    w.extend_from_slice(&[f(v.x), f(v.y), f(v.z)]);
}

/// Writes `v` at word `at` of a record.
fn put_v3(rec: &mut [u32], at: usize, v: glam::Vec3) {
    rec[at..at + 3].copy_from_slice(&[f(v.x), f(v.y), f(v.z)]);
}

/// The next word's offset, or an error when the render block outgrows 32-bit offsets.
pub(super) fn here(w: &[u32]) -> Result<u32> {
    u32::try_from(w.len())
        .map_err(|_| Error::new(ErrorKind::Gpu, "scene too large for the GPU backend"))
}

fn push_dist(w: &mut Vec<u32>, d: &Distribution1D) -> Result<u32> {
    let at = here(w)?;
    let mut head = [0u32; DIST_CDF];
    head[DIST_N] = d.pmf.len() as u32;
    head[DIST_TOTAL] = f(d.total);
    w.extend_from_slice(&head);
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
    let mut head = [0u32; DIST2_COLS];
    head[DIST2_WIDTH] = d.width as u32;
    head[DIST2_HEIGHT] = d.height as u32;
    head[DIST2_ROWS] = rows;
    w.extend_from_slice(&head);
    w.extend_from_slice(&cols);
    Ok(at)
}

/// The scene's geometry words followed by the render block (camera, texture maps, materials,
/// lights, environment, shading normals, texture coordinates, instance transforms); returns
/// the words and the block's offset.
pub fn pack_world(world: &World) -> Result<(PackedScene, u32)> {
    let mut packed = PackedScene::from_scene(&world.scene)?;
    let w = &mut packed.words;
    let r = here(w)? as usize;
    w.resize(r + HEADER_WORDS, 0);
    let mut hdr = [0u32; HEADER_WORDS];
    let st = &world.settings;
    let cam = &world.camera;
    hdr[H_WIDTH] = cam.width;
    hdr[H_HEIGHT] = cam.height;
    hdr[H_SPP] = st.spp;
    hdr[H_MAX_DEPTH] = st.max_depth;
    hdr[H_SEED] = st.seed;
    // Texture maps, then the materials.
    if world.textures.len() != world.materials.len() {
        return Err(Error::new(
            ErrorKind::Gpu,
            "world has texture maps for only some materials",
        ));
    }
    let maps = super::texture::pack_material_maps(w, &world.textures)?;
    hdr[H_MAT] = here(w)?;
    for (m, maps) in world.materials.iter().zip(maps) {
        let mut rec = [0u32; MAT_WORDS];
        rec[MAT_ALBEDO_MAP] = maps[0];
        rec[MAT_ROUGHNESS_MAP] = maps[1];
        rec[MAT_EMISSION_MAP] = maps[2];
        match *m {
            Material::Diffuse { albedo } => {
                rec[MAT_KIND] = M_DIFFUSE;
                put_v3(&mut rec, MAT_COLOR, albedo);
            }
            Material::Conductor { fresnel, alpha } => {
                match fresnel {
                    Fresnel::Conductor { eta, k } => {
                        rec[MAT_KIND] = M_CONDUCTOR;
                        put_v3(&mut rec, MAT_COLOR, eta);
                        put_v3(&mut rec, MAT_K, k);
                    }
                    Fresnel::Schlick { f0 } => {
                        rec[MAT_KIND] = M_SCHLICK;
                        put_v3(&mut rec, MAT_COLOR, f0);
                    }
                }
                rec[MAT_ALPHA] = f(alpha);
            }
            Material::Dielectric { ior, alpha } => {
                rec[MAT_KIND] = M_DIELECTRIC;
                rec[MAT_COLOR] = f(ior);
                rec[MAT_ALPHA] = f(alpha);
            }
            Material::Emissive { radiance } => {
                rec[MAT_KIND] = M_EMISSIVE;
                put_v3(&mut rec, MAT_COLOR, radiance);
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
    hdr[H_INST_MAT] = here(w)?;
    w.extend_from_slice(&world.instance_material);
    // Quad lights.
    let l = &world.lights;
    hdr[H_NQUADS] = l.quads.len() as u32;
    hdr[H_QUADS] = here(w)?;
    for q in &l.quads {
        let mut rec = [0u32; QUAD_WORDS];
        put_v3(&mut rec, QUAD_CORNER, q.corner);
        put_v3(&mut rec, QUAD_EDGE1, q.edge1);
        put_v3(&mut rec, QUAD_EDGE2, q.edge2);
        put_v3(&mut rec, QUAD_NORMAL, q.normal);
        rec[QUAD_AREA] = f(q.area);
        put_v3(&mut rec, QUAD_RADIANCE, q.radiance);
        w.extend_from_slice(&rec);
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
    hdr[H_NMESHL] = l.meshes.len() as u32;
    hdr[H_MESHL] = here(w)?;
    for (m, tris, dist) in recs {
        let mut rec = [0u32; MESHL_WORDS];
        rec[MESHL_INSTANCE] = m.instance;
        rec[MESHL_AREA] = f(m.area);
        put_v3(&mut rec, MESHL_RADIANCE, m.radiance);
        rec[MESHL_TRI_COUNT] = m.triangles.len() as u32;
        rec[MESHL_TRIS] = tris;
        rec[MESHL_DIST] = dist;
        w.extend_from_slice(&rec);
    }
    hdr[H_INST_LIGHT] = here(w)?;
    for i in 0..ninst {
        w.push(l.instance_light.get(i).copied().flatten().unwrap_or(NONE));
    }
    // Environment.
    match &l.env {
        None => hdr[H_ENV_KIND] = ENV_NONE,
        Some(Environment::Constant(c)) => {
            hdr[H_ENV_KIND] = ENV_CONSTANT;
            hdr[H_ENV] = here(w)?;
            push_v3(w, *c);
        }
        Some(Environment::Map { map, rotate }) => {
            hdr[H_ENV_KIND] = ENV_MAP;
            let texels = here(w)?;
            for t in &map.texels {
                push_v3(w, *t);
            }
            let dist = push_dist2(w, &map.dist)?;
            hdr[H_ENV] = here(w)?;
            let mut rec = [0u32; ENV_MAP_WORDS];
            rec[ENV_WIDTH] = map.width as u32;
            rec[ENV_HEIGHT] = map.height as u32;
            rec[ENV_ROTATE] = f(*rotate);
            rec[ENV_TEXELS] = texels;
            rec[ENV_DIST] = dist;
            w.extend_from_slice(&rec);
        }
    }
    hdr[H_SELECT] = push_dist(w, &l.select)?;
    // Instance transforms: object-to-world (hit points), normal matrix (normals).
    hdr[H_INST_XF] = here(w)?;
    for (i, xf) in world.transforms.iter().enumerate() {
        let mut rec = [0u32; XF_WORDS];
        let m = xf.matrix3;
        for (j, c) in [m.x_axis, m.y_axis, m.z_axis].into_iter().enumerate() {
            put_v3(&mut rec, XF_MATRIX + 3 * j, c.into());
        }
        put_v3(&mut rec, XF_TRANSLATION, xf.translation.into());
        let n = world.scene.instances[i].normal_matrix;
        for (j, c) in [n.x_axis, n.y_axis, n.z_axis].into_iter().enumerate() {
            put_v3(&mut rec, XF_NORMAL + 3 * j, c.into());
        }
        w.extend_from_slice(&rec);
    }
    // Per mesh: the unit limit normals of its blocks' vertices and of its loose triangles'
    // corners, decoded as the CPU's hit records decode them.
    let mut normals = Vec::new();
    let decoded = |w: &mut Vec<u32>, code: u32| {
        let n = crate::oct::oct_decode(code);
        w.extend_from_slice(&[f(n[0]), f(n[1]), f(n[2])]);
    };
    for m in &world.scene.meshes {
        if !m.shading_normals {
            return Err(Error::new(
                ErrorKind::Usage,
                "the GPU renderer shades with the grid meshes' normals: a mesh was built \
                 without them (GridMesh::dice_geometry)",
            ));
        }
        let at = here(w)?;
        for &code in &m.normals {
            decoded(w, code);
        }
        let loose_at = here(w)?;
        for l in &m.loose {
            for &code in &l.n {
                decoded(w, code);
            }
        }
        normals.push((at, loose_at));
    }
    let st = super::texture::pack_mesh_st(w, world)?;
    hdr[H_MESH_EXTRA] = here(w)?;
    for ((n, l), (s, ls)) in normals.into_iter().zip(st) {
        let mut rec = [0u32; MESH_EXTRA_WORDS];
        rec[MX_NORMALS] = n;
        rec[MX_LOOSE_NORMALS] = l;
        rec[MX_ST] = s;
        rec[MX_LOOSE_ST] = ls;
        w.extend_from_slice(&rec);
    }
    // Camera.
    let c = &mut hdr[H_CAMERA..H_CAMERA + CAM_WORDS];
    put_v3(c, CAM_POSITION, cam.position);
    put_v3(c, CAM_FORWARD, cam.forward);
    put_v3(c, CAM_RIGHT, cam.right);
    put_v3(c, CAM_UP, cam.up);
    c[CAM_TAN_HALF_FOV] = f(cam.tan_half_fov);
    c[CAM_APERTURE] = f(cam.aperture);
    c[CAM_FOCUS_DISTANCE] = f(cam.focus_distance);
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
        let kernels = PathKernels::new(ctx, geo.used_chunks, packed.grid_stack)?;
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
        let acc_size = (n as usize * ACC_WORDS * 4) as u64;
        let prim_size = (n as usize * HIT_WORDS * 4) as u64;
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
                pass.dispatch_workgroups(n.div_ceil(WORKGROUP), 1, 1);
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

    /// The centre ray of every pixel (the CPU renderer's AOV ray), row by row: status
    /// [`STATUS_MISS`], [`STATUS_HIT`] or [`STATUS_QUAD_LIGHT`] (a quad light in front of the
    /// mesh).
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
            for r in prim.chunks_exact(HIT_WORDS) {
                let h = RawHit {
                    iterations: 0,
                    ..RawHit::from_words(r)
                };
                if h.status == STATUS_OVERFLOW {
                    return Err(gpu_err("a primary ray exceeded the GPU traversal bound"));
                }
                out.push(h);
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
            for (i, a) in acc.chunks_exact(ACC_WORDS).enumerate() {
                if a[ACC_OVERFLOW] != 0.0 {
                    return Err(gpu_err("a path exceeded the GPU traversal bound"));
                }
                let (rgb, n, al) = (ACC_RGB, ACC_NORMAL, ACC_ALBEDO);
                let mut v = PixelValue {
                    rgba: [
                        a[rgb] * inv,
                        a[rgb + 1] * inv,
                        a[rgb + 2] * inv,
                        a[ACC_ALPHA] * inv,
                    ],
                    normal: [a[n] * inv, a[n + 1] * inv, a[n + 2] * inv],
                    albedo: [a[al] * inv, a[al + 1] * inv, a[al + 2] * inv],
                    ..PixelValue::default()
                };
                let ph = &prim[p0 + i];
                if ph.status == STATUS_HIT {
                    let hit = world
                        .scene
                        .hit_record(ph.instance, ph.leaf, ph.t, ph.b1, ph.b2)
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
