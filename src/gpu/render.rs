//! Path tracing on the GPU (`kernels/path.wgsl`): the CPU renderer's paths (same RNG, same
//! sample dimensions, same sampling and materials), one invocation per pixel, samples added in
//! sample order.

use super::trace::{layout, BVH_WGSL};
use super::GpuContext;
use crate::error::Result;

const PATH_WGSL: &str = include_str!("../../kernels/path.wgsl");

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
        let src = format!("{}\n{}\n{}", BVH_WGSL[0], BVH_WGSL[1], PATH_WGSL);
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
