//! Closest-hit queries on the GPU (`kernels/trace.wgsl`): bitwise the CPU's
//! [`GridMesh::intersect`] and [`SceneBvh::intersect`] on a device whose basic arithmetic rounds
//! like Rust's `f32` (lavapipe). The kernel returns `(instance, leaf, t, b1, b2)`; the hit
//! record is completed on the host by the same code as the CPU path.

use super::geometry::{GpuGeometry, PackedScene};
use super::layout::{
    kernels, module_source, GEO_CHUNKS, HIT_B1, HIT_B2, HIT_INSTANCE, HIT_ITERS, HIT_LEAF,
    HIT_STATUS, HIT_T, HIT_WORDS, RAY_DIR, RAY_TMAX, RAY_TMIN, RAY_WORDS, STATUS_HIT,
    STATUS_OVERFLOW,
};
use super::GpuContext;
use crate::bvh::{Hit, Ray, SceneBvh, SceneHit};
use crate::error::{Error, ErrorKind, Result};
use crate::grid::GridMesh;
use wgpu::util::DeviceExt;

pub use super::layout::{Params, WORKGROUP};

impl Params {
    /// The geometry part of the parameters.
    pub fn new(packed: &PackedScene, geo: &GpuGeometry, max_iter: u32) -> Params {
        Params {
            chunk_shift: geo.chunk_shift,
            mode: packed.mode,
            mesh_off: packed.mesh_off,
            top_node_off: packed.top_node_off,
            top_node_count: packed.top_node_count,
            top_index_off: packed.top_index_off,
            inst_off: packed.inst_off,
            top_box_off: packed.top_box_off,
            ray_count: 0,
            max_iter,
            box_scale: 1.0 + 2.0 * crate::bvh::triangle::GAMMA3,
            user0: 0,
            user1: 0,
            user2: 0,
            user3: 0,
            user4: 0,
        }
    }
}

/// Options of the GPU queries.
#[derive(Clone, Copy, Debug)]
pub struct TraceOptions {
    /// Largest number of rays per dispatch; dispatches are sized to take about
    /// [`TARGET_DISPATCH_S`] each (a dispatch cannot be cancelled).
    pub tile_rays: usize,
    /// Traversal loop iterations allowed per ray before it is reported as overflowed.
    pub max_iter: u32,
    /// Upper bound on the words of one geometry chunk (default: what a binding holds).
    pub max_chunk_words: Option<u64>,
}

impl Default for TraceOptions {
    fn default() -> Self {
        TraceOptions {
            tile_rays: 1 << 18,
            max_iter: 1 << 20,
            max_chunk_words: None,
        }
    }
}

/// A compute-stage storage-buffer entry of a bind group layout.
pub(crate) fn storage_entry(binding: u32, read_only: bool) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::COMPUTE,
        ty: wgpu::BindingType::Buffer {
            ty: wgpu::BufferBindingType::Storage { read_only },
            has_dynamic_offset: false,
            min_binding_size: None,
        },
        count: None,
    }
}

/// The bind group layout of a kernel: the uniform at 0, the geometry chunks at 1..=8, then
/// `extra` storage buffers (`true`: read-only) from binding 9 on.
pub fn layout(ctx: &GpuContext, extra: &[bool]) -> wgpu::BindGroupLayout {
    let storage = storage_entry;
    let mut entries = vec![wgpu::BindGroupLayoutEntry {
        binding: 0,
        visibility: wgpu::ShaderStages::COMPUTE,
        ty: wgpu::BindingType::Buffer {
            ty: wgpu::BufferBindingType::Uniform,
            has_dynamic_offset: false,
            min_binding_size: None,
        },
        count: None,
    }];
    for c in 0..GEO_CHUNKS as u32 {
        entries.push(storage(1 + c, true));
    }
    for (i, &ro) in extra.iter().enumerate() {
        entries.push(storage(1 + GEO_CHUNKS as u32 + i as u32, ro));
    }
    ctx.device
        .create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("limitray"),
            entries: &entries,
        })
}

/// A bind group over `params`, the geometry and `extra` buffers (bindings from 9 on).
pub fn bind_group(
    ctx: &GpuContext,
    layout: &wgpu::BindGroupLayout,
    params: &wgpu::Buffer,
    geo: &GpuGeometry,
    extra: &[&wgpu::Buffer],
) -> wgpu::BindGroup {
    let mut entries = vec![wgpu::BindGroupEntry {
        binding: 0,
        resource: params.as_entire_binding(),
    }];
    for (c, b) in geo.chunks.iter().enumerate() {
        entries.push(wgpu::BindGroupEntry {
            binding: 1 + c as u32,
            resource: b.as_entire_binding(),
        });
    }
    for (i, b) in extra.iter().enumerate() {
        entries.push(wgpu::BindGroupEntry {
            binding: 1 + GEO_CHUNKS as u32 + i as u32,
            resource: b.as_entire_binding(),
        });
    }
    ctx.device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("limitray"),
        layout,
        entries: &entries,
    })
}

/// What the kernel found for one ray.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RawHit {
    /// [`STATUS_MISS`](super::layout::STATUS_MISS), [`STATUS_HIT`] or [`STATUS_OVERFLOW`]
    /// (traversal bound exceeded); primary hits also
    /// [`STATUS_QUAD_LIGHT`](super::layout::STATUS_QUAD_LIGHT).
    pub status: u32,
    /// Instance (0 for a single mesh).
    pub instance: u32,
    /// Leaf-ordered triangle of the instance's mesh.
    pub leaf: u32,
    /// Ray parameter.
    pub t: f32,
    /// Barycentric weight of corner 1.
    pub b1: f32,
    /// Barycentric weight of corner 2.
    pub b2: f32,
    /// Traversal loop iterations used.
    pub iterations: u32,
}

impl RawHit {
    /// The hit in a record of [`HIT_WORDS`] words (trace results, primary hits).
    pub fn from_words(h: &[u32]) -> RawHit {
        RawHit {
            status: h[HIT_STATUS],
            instance: h[HIT_INSTANCE],
            leaf: h[HIT_LEAF],
            t: f32::from_bits(h[HIT_T]),
            b1: f32::from_bits(h[HIT_B1]),
            b2: f32::from_bits(h[HIT_B2]),
            iterations: h[HIT_ITERS],
        }
    }
}

/// A scene on the device with the closest-hit kernel.
pub struct GpuTracer<'a> {
    ctx: &'a GpuContext,
    packed: PackedScene,
    geo: GpuGeometry,
    pipeline: wgpu::ComputePipeline,
    layout: wgpu::BindGroupLayout,
    opts: TraceOptions,
}

impl<'a> GpuTracer<'a> {
    /// Uploads `packed` and compiles the kernel.
    pub fn new(ctx: &'a GpuContext, packed: PackedScene, opts: TraceOptions) -> Result<Self> {
        let geo = GpuGeometry::upload(ctx, &packed, opts.max_chunk_words)?;
        let layout = layout(ctx, &[true, false]);
        let src = module_source(kernels::TRACE_MODULE, packed.grid_stack);
        let pipeline = ctx.compute_pipeline(
            "trace",
            &src,
            "trace_main",
            &layout,
            &[("GEO_USED", geo.used_chunks as f64)],
        )?;
        Ok(GpuTracer {
            ctx,
            packed,
            geo,
            pipeline,
            layout,
            opts,
        })
    }

    /// Geometry chunks in use.
    pub fn used_chunks(&self) -> usize {
        self.geo.used_chunks
    }

    /// Closest hits of `rays`, tile by tile.
    pub fn trace_raw(&self, rays: &[Ray]) -> Result<Vec<RawHit>> {
        let ctx = self.ctx;
        let tile = self.opts.tile_rays.clamp(WORKGROUP as usize, 1 << 22);
        let tile = tile.min(rays.len().max(1));
        let ray_bytes = (tile * RAY_WORDS * 4) as u64;
        let hit_bytes = (tile * HIT_WORDS * 4) as u64;
        let ray_buf = ctx.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("rays"),
            size: ray_bytes,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let hit_buf = ctx.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("hits"),
            size: hit_bytes,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });
        let read_buf = ctx.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("hits readback"),
            size: hit_bytes,
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let mut params = Params::new(&self.packed, &self.geo, self.opts.max_iter);
        let param_buf = ctx
            .device
            .create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some("params"),
                contents: bytemuck::bytes_of(&params),
                usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            });
        let bg = bind_group(
            ctx,
            &self.layout,
            &param_buf,
            &self.geo,
            &[&ray_buf, &hit_buf],
        );
        let mut out = Vec::with_capacity(rays.len());
        // Dispatches grow or shrink towards TARGET_DISPATCH_S each (a dispatch cannot be
        // cancelled, and a long one can trip a driver watchdog).
        let mut n = tile.min(4096);
        let mut done = 0;
        while done < rays.len() {
            let part = &rays[done..(done + n).min(rays.len())];
            done += part.len();
            let t0 = std::time::Instant::now();
            let mut data = vec![0f32; part.len() * RAY_WORDS];
            for (r, w) in part.iter().zip(data.chunks_exact_mut(RAY_WORDS)) {
                w[..3].copy_from_slice(&r.origin);
                w[RAY_TMIN] = r.tmin;
                w[RAY_DIR..RAY_DIR + 3].copy_from_slice(&r.dir);
                w[RAY_TMAX] = r.tmax;
            }
            ctx.queue
                .write_buffer(&ray_buf, 0, bytemuck::cast_slice(&data));
            params.ray_count = part.len() as u32;
            ctx.queue
                .write_buffer(&param_buf, 0, bytemuck::bytes_of(&params));
            let mut enc = ctx
                .device
                .create_command_encoder(&wgpu::CommandEncoderDescriptor { label: None });
            {
                let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor {
                    label: Some("trace"),
                    timestamp_writes: None,
                });
                pass.set_pipeline(&self.pipeline);
                pass.set_bind_group(0, &bg, &[]);
                pass.dispatch_workgroups((part.len() as u32).div_ceil(WORKGROUP), 1, 1);
            }
            let size = (part.len() * HIT_WORDS * 4) as u64;
            enc.copy_buffer_to_buffer(&hit_buf, 0, &read_buf, 0, size);
            ctx.queue.submit([enc.finish()]);
            let bytes = ctx.read_buffer(&read_buf, size)?;
            n = next_tile(part.len(), t0.elapsed().as_secs_f64(), tile);
            let w: &[u32] = bytemuck::cast_slice(&bytes);
            out.extend(w.chunks_exact(HIT_WORDS).map(RawHit::from_words));
        }
        Ok(out)
    }
}

/// Seconds a dispatch should take.
pub const TARGET_DISPATCH_S: f64 = 0.25;

/// The size of the next dispatch after one of `n` items took `secs`, at most `cap`.
pub fn next_tile(n: usize, secs: f64, cap: usize) -> usize {
    let rate = n as f64 / secs.max(1e-4);
    let want = (rate * TARGET_DISPATCH_S) as usize;
    want.clamp(WORKGROUP as usize, (2 * n).max(WORKGROUP as usize))
        .min(cap)
        .max(1)
}

fn overflow_error(n: usize) -> Error {
    Error::new(
        ErrorKind::Gpu,
        format!("{n} ray(s) exceeded the GPU traversal bound (iterations or stack depth)"),
    )
}

/// An error if any ray of `raw` overflowed the traversal bound.
fn check_overflow(raw: &[RawHit]) -> Result<()> {
    match raw.iter().filter(|h| h.status == STATUS_OVERFLOW).count() {
        0 => Ok(()),
        n => Err(overflow_error(n)),
    }
}

/// Closest hits of `rays` on one mesh: the answers of [`GridMesh::intersect`].
pub fn trace_mesh(
    ctx: &GpuContext,
    bvh: &GridMesh,
    rays: &[Ray],
    opts: TraceOptions,
) -> Result<Vec<Option<Hit>>> {
    let tracer = GpuTracer::new(ctx, PackedScene::from_mesh(bvh)?, opts)?;
    let raw = tracer.trace_raw(rays)?;
    check_overflow(&raw)?;
    Ok(raw
        .iter()
        .map(|h| (h.status == STATUS_HIT).then(|| bvh.hit_at(h.leaf, h.t, h.b1, h.b2)))
        .collect())
}

/// Closest hits of `rays` in a scene: the answers of [`SceneBvh::intersect`].
pub fn trace_scene(
    ctx: &GpuContext,
    scene: &SceneBvh,
    rays: &[Ray],
    opts: TraceOptions,
) -> Result<Vec<Option<SceneHit>>> {
    let tracer = GpuTracer::new(ctx, PackedScene::from_scene(scene)?, opts)?;
    let raw = tracer.trace_raw(rays)?;
    check_overflow(&raw)?;
    Ok(raw
        .iter()
        .map(|h| {
            (h.status == STATUS_HIT).then(|| scene.hit_record(h.instance, h.leaf, h.t, h.b1, h.b2))
        })
        .collect())
}
