// Test kernel of edge_exact (exact.wgsl): 4 f32 in, 1 u32 (f32 bits) out per case.

@group(0) @binding(0) var<storage, read> cases: array<f32>;
@group(0) @binding(1) var<storage, read_write> results: array<u32>;

@compute @workgroup_size(WORKGROUP)
fn exact_main(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = gid.x;
    if (i >= arrayLength(&results)) {
        return;
    }
    let b = 4u * i;
    results[i] = bitcast<u32>(edge_exact(cases[b], cases[b + 1u], cases[b + 2u], cases[b + 3u]));
}
