//! The exact edge function of `kernels/exact.wgsl` and its CPU reference, exposed for tests.

use super::GpuContext;
use crate::error::Result;
use wgpu::util::DeviceExt;

/// The CPU path's fallback edge function: `a·b − c·d` in `f64`, rounded to `f32`
/// (`src/bvh/triangle.rs`).
pub fn edge_reference(a: f32, b: f32, c: f32, d: f32) -> f32 {
    ((a as f64) * (b as f64) - (c as f64) * (d as f64)) as f32
}

/// Evaluates the kernel's `edge_exact(a, b, c, d)` on the device for each case.
pub fn edge_exact_gpu(ctx: &GpuContext, cases: &[[f32; 4]]) -> Result<Vec<f32>> {
    if cases.is_empty() {
        return Ok(Vec::new());
    }
    let groups = (cases.len() as u32).div_ceil(super::layout::WORKGROUP);
    if cases.len() > u32::MAX as usize || groups > ctx.limits.max_compute_workgroups_per_dimension {
        return Err(crate::Error::new(
            crate::ErrorKind::Usage,
            format!("{} cases are too many for one dispatch", cases.len()),
        ));
    }
    let entry = super::trace::storage_entry;
    let layout = ctx
        .device
        .create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("exact test"),
            entries: &[entry(0, true), entry(1, false)],
        });
    let src = super::layout::module_source(super::layout::kernels::EXACT_TEST_MODULE, 1);
    let pipeline = ctx.compute_pipeline("exact_test", &src, "exact_main", &layout, &[])?;
    let input = ctx
        .device
        .create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("cases"),
            contents: bytemuck::cast_slice(cases),
            usage: wgpu::BufferUsages::STORAGE,
        });
    let size = (cases.len() * 4) as u64;
    let out = ctx.device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("results"),
        size,
        usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
        mapped_at_creation: false,
    });
    let read = ctx.device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("results readback"),
        size,
        usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    let bg = ctx.device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("exact test"),
        layout: &layout,
        entries: &[
            wgpu::BindGroupEntry {
                binding: 0,
                resource: input.as_entire_binding(),
            },
            wgpu::BindGroupEntry {
                binding: 1,
                resource: out.as_entire_binding(),
            },
        ],
    });
    let mut enc = ctx
        .device
        .create_command_encoder(&wgpu::CommandEncoderDescriptor { label: None });
    {
        let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("exact test"),
            timestamp_writes: None,
        });
        pass.set_pipeline(&pipeline);
        pass.set_bind_group(0, &bg, &[]);
        pass.dispatch_workgroups(groups, 1, 1);
    }
    enc.copy_buffer_to_buffer(&out, 0, &read, 0, size);
    ctx.queue.submit([enc.finish()]);
    let bytes = ctx.read_buffer(&read, size)?;
    Ok(bytemuck::cast_slice::<u8, f32>(&bytes).to_vec())
}
