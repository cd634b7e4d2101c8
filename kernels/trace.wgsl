// Closest hits of a batch of rays (`limitray trace --backend gpu`, GpuTracer::trace).
// Needs the prelude, exact.wgsl and bvh.wgsl before it.
//
// rays: RAY_WORDS f32 per ray: origin, tmin (RAY_TMIN), direction (RAY_DIR), tmax (RAY_TMAX).
// hits: HIT_WORDS u32 per ray: status (STATUS_MISS, STATUS_HIT or STATUS_OVERFLOW), instance,
//       leaf, t, b1, b2 (f32 bits), iterations (HIT_*).

@group(0) @binding(9) var<storage, read> rays: array<f32>;
@group(0) @binding(10) var<storage, read_write> hits: array<u32>;

@compute @workgroup_size(WORKGROUP)
fn trace_main(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = gid.x + gid.y * P.user0;
    if (i >= P.ray_count) {
        return;
    }
    iters = 0u;
    overflow = false;
    let b = RAY_WORDS * i;
    let o = vec3<f32>(rays[b], rays[b + 1u], rays[b + 2u]);
    let dd = b + RAY_DIR;
    let d = vec3<f32>(rays[dd], rays[dd + 1u], rays[dd + 2u]);
    let h = intersect_world(o, d, rays[b + RAY_TMIN], rays[b + RAY_TMAX], false);
    var status = select(STATUS_MISS, STATUS_HIT, h.hit);
    if (overflow) {
        status = STATUS_OVERFLOW;
    }
    let k = HIT_WORDS * i;
    for (var j = 0u; j < HIT_WORDS; j++) {
        hits[k + j] = 0u;
    }
    hits[k + HIT_STATUS] = status;
    hits[k + HIT_INSTANCE] = h.inst;
    hits[k + HIT_LEAF] = h.leaf;
    hits[k + HIT_T] = bitcast<u32>(h.t);
    hits[k + HIT_B1] = bitcast<u32>(h.b1);
    hits[k + HIT_B2] = bitcast<u32>(h.b2);
    hits[k + HIT_ITERS] = iters;
}
