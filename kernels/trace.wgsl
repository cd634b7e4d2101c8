// Closest hits of a batch of rays (`limitray trace --backend gpu`, GpuTracer::trace).
// Needs exact.wgsl and bvh.wgsl before it.
//
// rays: 8 f32 per ray: ox oy oz tmin dx dy dz tmax.
// hits: 8 u32 per ray: status (0 miss, 1 hit, 2 overflow), instance, leaf, t, b1, b2 (f32 bits),
//       iterations, 0.

@group(0) @binding(9) var<storage, read> rays: array<f32>;
@group(0) @binding(10) var<storage, read_write> hits: array<u32>;

@compute @workgroup_size(64)
fn trace_main(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = gid.x + gid.y * P.user0;
    if (i >= P.ray_count) {
        return;
    }
    iters = 0u;
    overflow = false;
    let b = 8u * i;
    let o = vec3<f32>(rays[b], rays[b + 1u], rays[b + 2u]);
    let d = vec3<f32>(rays[b + 4u], rays[b + 5u], rays[b + 6u]);
    let h = intersect_world(o, d, rays[b + 3u], rays[b + 7u], false);
    var status = select(0u, 1u, h.hit);
    if (overflow) {
        status = 2u;
    }
    hits[b] = status;
    hits[b + 1u] = h.inst;
    hits[b + 2u] = h.leaf;
    hits[b + 3u] = bitcast<u32>(h.t);
    hits[b + 4u] = bitcast<u32>(h.b1);
    hits[b + 5u] = bitcast<u32>(h.b2);
    hits[b + 6u] = iters;
    hits[b + 7u] = 0u;
}
