// Ray queries on the GPU: the same grid meshes and scene CWBVH, the same conservative box tests
// and the same watertight triangle test as the CPU (src/grid, src/bvh/{scene,triangle}.rs), operation for
// operation in the same order and without fused multiply-add, so that on an IEEE device whose
// + − × ÷ round like Rust's f32 (lavapipe does) every hit is bitwise the CPU's.
//
// Needs the prelude (src/gpu/layout.rs: every record layout, `struct Params`) and exact.wgsl
// (edge_exact) before it. The including kernel declares nothing of its own in group 0 bindings
// 0..=GEO_CHUNKS.
//
// Geometry lives in one space of u32 words split over GEO_CHUNKS storage bindings of
// 2^chunk_shift words each (a large scene exceeds one binding): word i is word
// i & (2^shift − 1) of chunk i >> shift. The records of the space (grid mesh records, obvhs's
// CwBvhNode as it is, exact child boxes, leaf-ordered triangles, the top level, instances) are
// described once, in src/gpu/layout.rs; their offsets are in `Params`.

@group(0) @binding(0) var<uniform> P: Params;
@group(0) @binding(1) var<storage, read> g0: array<u32>;
@group(0) @binding(2) var<storage, read> g1: array<u32>;
@group(0) @binding(3) var<storage, read> g2: array<u32>;
@group(0) @binding(4) var<storage, read> g3: array<u32>;
@group(0) @binding(5) var<storage, read> g4: array<u32>;
@group(0) @binding(6) var<storage, read> g5: array<u32>;
@group(0) @binding(7) var<storage, read> g6: array<u32>;
@group(0) @binding(8) var<storage, read> g7: array<u32>;

// Chunks in use, fixed when the pipeline is created (one chunk: no chunk arithmetic).
override GEO_USED: u32 = GEO_CHUNKS;

fn gw(i: u32) -> u32 {
    if (GEO_USED == 1u) {
        return g0[i];
    }
    let c = i >> P.chunk_shift;
    let o = i & ((1u << P.chunk_shift) - 1u);
    switch c {
        case 0u: { return g0[o]; }
        case 1u: { return g1[o]; }
        case 2u: { return g2[o]; }
        case 3u: { return g3[o]; }
        case 4u: { return g4[o]; }
        case 5u: { return g5[o]; }
        case 6u: { return g6[o]; }
        default: { return g7[o]; }
    }
}

fn gf(i: u32) -> f32 {
    return bitcast<f32>(gw(i));
}

// x, bit for bit, through an integer operation the compiler cannot see through (P.user4 is
// always 0): keeps a product from being fused into the following addition, and a sum from
// being simplified algebraically (WGSL has no `precise`, and naga's SPIR-V carries no
// NoContraction, so drivers may fuse and simplify; Rust rounds every operation).
fn nf(x: f32) -> f32 {
    return bitcast<f32>(bitcast<u32>(x) ^ P.user4);
}

fn nf3(v: vec3<f32>) -> vec3<f32> {
    return vec3<f32>(nf(v.x), nf(v.y), nf(v.z));
}

// ---------------------------------------------------------------------------------------------
// Prepared rays (PreparedRay::new).

struct PRay {
    o: vec3<f32>,
    d: vec3<f32>,
    inv: vec3<f32>,
    k: vec3<u32>,
    s: vec3<f32>,
    tmin: f32,
    tmax: f32,
    oct_inv4: u32,
    ok: bool,
}

fn finite(x: f32) -> bool {
    return (bitcast<u32>(x) & 0x7f800000u) != 0x7f800000u;
}

fn sign_negative(x: f32) -> bool {
    return (bitcast<u32>(x) & 0x80000000u) != 0u;
}

fn prepare_ray(o: vec3<f32>, d: vec3<f32>, tmin: f32, tmax: f32) -> PRay {
    var r: PRay;
    r.ok = finite(d.x) && finite(d.y) && finite(d.z) && !(d.x == 0.0 && d.y == 0.0 && d.z == 0.0)
        && finite(o.x) && finite(o.y) && finite(o.z);
    let a = abs(d);
    var kz = 2u;
    if (a.x > a.y) {
        if (a.x > a.z) {
            kz = 0u;
        }
    } else if (a.y > a.z) {
        kz = 1u;
    }
    var kx = (kz + 1u) % 3u;
    var ky = (kx + 1u) % 3u;
    var dv = d;
    if (dv[kz] < 0.0) {
        let t = kx;
        kx = ky;
        ky = t;
    }
    r.o = o;
    r.d = d;
    r.inv = vec3<f32>(1.0 / d.x, 1.0 / d.y, 1.0 / d.z);
    r.k = vec3<u32>(kx, ky, kz);
    let dkz = dv[kz];
    r.s = vec3<f32>(dv[kx] / dkz, dv[ky] / dkz, 1.0 / dkz);
    r.tmin = tmin;
    r.tmax = tmax;
    // obvhs's ray_get_octant_inv4.
    r.oct_inv4 = select(0x04040404u, 0u, d.x < 0.0) | select(0x02020202u, 0u, d.y < 0.0)
        | select(0x01010101u, 0u, d.z < 0.0);
    return r;
}

// ---------------------------------------------------------------------------------------------
// The watertight triangle test (intersect_prepared).

struct TriHit {
    hit: bool,
    t: f32,
    b1: f32,
    b2: f32,
}

fn intersect_triangle(r: PRay, a: vec3<f32>, b: vec3<f32>, c: vec3<f32>, tmax: f32) -> TriHit {
    var out = TriHit(false, 0.0, 0.0, 0.0);
    let kx = r.k.x;
    let ky = r.k.y;
    let kz = r.k.z;
    var at = vec3<f32>(a.x - r.o.x, a.y - r.o.y, a.z - r.o.z);
    var bt = vec3<f32>(b.x - r.o.x, b.y - r.o.y, b.z - r.o.z);
    var ct = vec3<f32>(c.x - r.o.x, c.y - r.o.y, c.z - r.o.z);
    let ax = at[kx] - r.s.x * at[kz];
    let ay = at[ky] - r.s.y * at[kz];
    let bx = bt[kx] - r.s.x * bt[kz];
    let by = bt[ky] - r.s.y * bt[kz];
    let cx = ct[kx] - r.s.x * ct[kz];
    let cy = ct[ky] - r.s.y * ct[kz];
    // Unfused products: a shared edge's edge functions must stay exact negatives of each other
    // (watertightness) on devices that would fuse them into an FMA.
    var u = nf(cx * by) - nf(cy * bx);
    var v = nf(ax * cy) - nf(ay * cx);
    var w = nf(bx * ay) - nf(by * ax);
    if (u == 0.0 || v == 0.0 || w == 0.0) {
        u = edge_exact(cx, by, cy, bx);
        v = edge_exact(ax, cy, ay, cx);
        w = edge_exact(bx, ay, by, ax);
    }
    if ((u < 0.0 || v < 0.0 || w < 0.0) && (u > 0.0 || v > 0.0 || w > 0.0)) {
        return out;
    }
    let det = (u + v) + w;
    if (det == 0.0) {
        return out;
    }
    let az = r.s.z * at[kz];
    let bz = r.s.z * bt[kz];
    let cz = r.s.z * ct[kz];
    let t_scaled = (u * az + v * bz) + w * cz;
    var ts = t_scaled;
    var ad = det;
    if (det < 0.0) {
        ts = -t_scaled;
        ad = -det;
    }
    if (ts < r.tmin * ad || ts > tmax * ad) {
        return out;
    }
    let rcp = 1.0 / det;
    let t = t_scaled * rcp;
    if (t < r.tmin || t > tmax) {
        return out;
    }
    out.hit = true;
    out.t = t;
    out.b1 = v * rcp;
    out.b2 = w * rcp;
    return out;
}

// ---------------------------------------------------------------------------------------------
// The instances' CWBVH nodes (obvhs's CwBvhNode, NODE_WORDS words) and the node test
// (node_hitmask).

fn byte_of(lo: u32, hi: u32, c: u32) -> u32 {
    let w = select(lo, hi, c >= 4u);
    return (w >> ((c & 3u) * 8u)) & 0xffu;
}

// The conservative slab test (PreparedRay::hits_box) of one child box whose lower corner's x is
// at word `lo` (y and z `stride` words apart) and whose upper corner is `hi` words after it:
// (entry, exit) distances, the box met where entry <= exit. A NaN slab distance keeps the
// bound (the SSE max/min).
fn slab(lo: u32, hi: u32, stride: u32, r: PRay, tmax: f32) -> vec2<f32> {
    var near = r.tmin;
    var far = tmax;
    for (var a = 0u; a < 3u; a++) {
        var nn = gf(lo + stride * a);
        var ff = gf(lo + hi + stride * a);
        if (sign_negative(r.inv[a])) {
            let t = nn;
            nn = ff;
            ff = t;
        }
        let tn = (nn - r.o[a]) * r.inv[a];
        let tf = ((ff - r.o[a]) * r.inv[a]) * P.box_scale;
        if (tn > near) {
            near = tn;
        }
        if (tf < far) {
            far = tf;
        }
    }
    return vec2<f32>(near, far);
}

// The node test (wide_hitmask): PreparedRay::hits_box over the exact f32 child boxes that the
// CPU traverses (BOX_WORDS words at `bx`: lo[axis][child], then hi[axis][child]), with the max/min of
// the SSE version (a NaN distance keeps the bound). Child order and masks from the node at `n`.
fn node_hitmask(n: u32, bx: u32, r: PRay, tmax: f32) -> u32 {
    let meta_lo = gw(n + NODE_META);
    let meta_hi = gw(n + NODE_META + 1u);
    // get_child_and_index_bits, one 32-bit half at a time (no bit crosses a byte that matters).
    let oct = r.oct_inv4;
    let inner_lo = (meta_lo & (meta_lo << 1u)) & 0x10101010u;
    let inner_hi = (meta_hi & (meta_hi << 1u)) & 0x10101010u;
    let imask_lo = (inner_lo >> 4u) * 0xffu;
    let imask_hi = (inner_hi >> 4u) * 0xffu;
    let bidx_lo = (meta_lo ^ (oct & imask_lo)) & 0x1f1f1f1fu;
    let bidx_hi = (meta_hi ^ (oct & imask_hi)) & 0x1f1f1f1fu;
    let cbits_lo = (meta_lo >> 5u) & 0x07070707u;
    let cbits_hi = (meta_hi >> 5u) & 0x07070707u;
    var mask = 0u;
    for (var c = 0u; c < NODE_CHILDREN; c++) {
        if (byte_of(meta_lo, meta_hi, c) == 0u) {
            continue;
        }
        let se = slab(bx + c, BOX_HI, NODE_CHILDREN, r, tmax);
        if (se.x <= se.y) {
            mask |= byte_of(cbits_lo, cbits_hi, c) << byte_of(bidx_lo, bidx_hi, c);
        }
    }
    return mask;
}

// ---------------------------------------------------------------------------------------------
// Traversal: obvhs's traverse! macro (the same child order), one node step at a time, shared by
// the mesh level and the top level, closest and any hit.
//
// The stack has TRAVERSAL_STACK entries. The CPU's has 64 and grows past that, so it never
// drops an entry; here a push that fills the stack flags `overflow`, the ray is reported with
// STATUS_OVERFLOW and the host turns that into an error: never a silently wrong answer.

struct Walk {
    stack: array<vec2<u32>, TRAVERSAL_STACK>,
    sp: u32,
    // obvhs's current_group and primitive_group: (base index, hit bits).
    cur: vec2<u32>,
    prim: vec2<u32>,
}

fn walk_new() -> Walk {
    var w: Walk;
    w.sp = 0u;
    w.cur = vec2<u32>(0u, 0x80000000u);
    w.prim = vec2<u32>(0u, 0u);
    return w;
}

// Iterations used so far by this invocation, and whether a bound was exceeded.
var<private> iters: u32;
var<private> overflow: bool;

// Counts one loop iteration; false (and `overflow`) past the bound.
fn walk_iter() -> bool {
    iters += 1u;
    if (iters > P.max_iter) {
        overflow = true;
        return false;
    }
    return true;
}

// One step of the walk, after the caller has consumed the leaf hits in `w.prim`: visits the
// nearest child of the current group (nodes at `node_off`, their boxes at `box_off`), leaving
// that node's leaf hits in `w.prim`, or pops the stack. False when the walk is over.
fn walk_step(w: ptr<function, Walk>, node_off: u32, box_off: u32, r: PRay, tmax: f32) -> bool {
    (*w).prim = vec2<u32>(0u, 0u);
    if (((*w).cur.y & 0xff000000u) != 0u) {
        let hits = (*w).cur.y;
        let off = firstLeadingBit(hits);
        let base = (*w).cur.x;
        (*w).cur.y &= ~(1u << off);
        if (((*w).cur.y & 0xff000000u) != 0u) {
            let sp = (*w).sp;
            (*w).stack[sp] = (*w).cur;
            if (sp == TRAVERSAL_STACK - 1u) {
                overflow = true;
            }
            (*w).sp = min(sp + 1u, TRAVERSAL_STACK - 1u);
        }
        let slot = (off - 24u) ^ (r.oct_inv4 & 0xffu);
        let rel = countOneBits(hits & ~(0xffffffffu << slot));
        let ni = base + rel;
        let node = node_off + NODE_WORDS * ni;
        let hm = node_hitmask(node, box_off + BOX_WORDS * ni, r, tmax);
        let imask = (gw(node + NODE_IMASK) >> 24u) & 0xffu;
        (*w).cur.x = gw(node + NODE_CHILD_BASE);
        (*w).prim.x = gw(node + NODE_PRIM_BASE);
        (*w).cur.y = (hm & 0xff000000u) | imask;
        (*w).prim.y = hm & 0x00ffffffu;
    } else {
        (*w).cur = vec2<u32>(0u, 0u);
    }
    if ((*w).prim.y == 0u && ((*w).cur.y & 0xff000000u) == 0u) {
        if ((*w).sp == 0u) {
            return false;
        }
        (*w).sp -= 1u;
        (*w).cur = (*w).stack[(*w).sp];
    }
    return true;
}

struct MeshHit {
    hit: bool,
    leaf: u32,
    t: f32,
    b1: f32,
    b2: f32,
}

// ---------------------------------------------------------------------------------------------
// Grid meshes (src/grid): four and eight boxes at once (node::test4_scalar, test8_scalar), the
// front-to-back order (node::front_to_back), the top level's walk (top::Top::walk), a block's implicit hierarchy
// (GridMesh::walk_block) and the window test (window::window_scalar), each in the CPU's order.

struct Box4Hit {
    mask: u32,
    near: vec4<f32>,
}

// The four boxes of the Box4 at word `bx` (lo[axis][child], then hi) met within `tmax`, and
// their entry distances.
fn test4(bx: u32, r: PRay, tmax: f32) -> Box4Hit {
    var out: Box4Hit;
    out.mask = 0u;
    for (var c = 0u; c < 4u; c++) {
        let se = slab(bx + c, BOX4_HI, 4u, r, tmax);
        if (se.x <= se.y) {
            out.mask |= 1u << c;
        }
        out.near[c] = se.x;
    }
    return out;
}

struct Order4 {
    c: array<u32, 4>,
    n: u32,
}

struct Box8Hit {
    mask: u32,
    near: array<f32, 8>,
}

// The eight boxes of the Box8 at word `bx` met within `tmax`, and their entry distances.
fn test8(bx: u32, r: PRay, tmax: f32) -> Box8Hit {
    var out: Box8Hit;
    out.mask = 0u;
    for (var c = 0u; c < TOP_WIDTH; c++) {
        let se = slab(bx + c, BOX_HI, TOP_WIDTH, r, tmax);
        if (se.x <= se.y) {
            out.mask |= 1u << c;
        }
        out.near[c] = se.x;
    }
    return out;
}

struct Order8 {
    c: array<u32, 8>,
    n: u32,
}

// front_to_back over the eight children of a Box8Hit.
fn front_to_back8(h: Box8Hit) -> Order8 {
    var o: Order8;
    o.n = 0u;
    var near = h.near;
    for (var c = 0u; c < TOP_WIDTH; c++) {
        if ((h.mask & (1u << c)) == 0u) {
            continue;
        }
        var i = o.n;
        while (i > 0u && near[c] < near[o.c[i - 1u]]) {
            o.c[i] = o.c[i - 1u];
            i -= 1u;
        }
        o.c[i] = c;
        o.n += 1u;
    }
    return o;
}

// The children in `mask`, nearest first, ties by child index (insertion in index order).
fn front_to_back(mask: u32, near: vec4<f32>) -> Order4 {
    var o: Order4;
    o.n = 0u;
    for (var c = 0u; c < 4u; c++) {
        if ((mask & (1u << c)) == 0u) {
            continue;
        }
        var i = o.n;
        while (i > 0u && near[c] < near[o.c[i - 1u]]) {
            o.c[i] = o.c[i - 1u];
            i -= 1u;
        }
        o.c[i] = c;
        o.n += 1u;
    }
    return o;
}

// The running answer of a mesh query: the best hit so far (lowest diced-mesh id on equal t).
struct GridBest {
    hit: bool,
    leaf: u32,
    id: u32,
    t: f32,
    b1: f32,
    b2: f32,
    tmax: f32,
    stop: bool,
}

// Corner `i` of the loose triangle record at word `v`.
fn loose_corner(v: u32, i: u32) -> vec3<f32> {
    return vec3<f32>(gf(v + 3u * i), gf(v + 3u * i + 1u), gf(v + 3u * i + 2u));
}

// Vertex (x, y) of the block whose coordinates start at `vert`, `w` vertices per row.
fn block_vertex(vert: u32, w: u32, x: u32, y: u32) -> vec3<f32> {
    let i = vert + 3u * y * w + x;
    return vec3<f32>(gf(i), gf(i + w), gf(i + 2u * w));
}

// Window (wx, wy) of block record `blk` (block index `bi`): the eight triangles of its 2×2
// quads in lane order (quad row, quad column, half), the closest within tmax (lowest lane on
// equal t), then merged into `b` as GridMesh::intersect does.
fn grid_window(b: ptr<function, GridBest>, blk: u32, bi: u32, wx: u32, wy: u32, r: PRay,
               anyhit: bool) {
    let dims = gw(blk + BLK_DIMS);
    let cols = dims & 0xffu;
    let rows = (dims >> 8u) & 0xffu;
    let vert = gw(blk + BLK_VERT);
    let w = cols + 1u;
    let qx = min(cols - 2u * wx, 2u);
    let qy = min(rows - 2u * wy, 2u);
    var found = false;
    var lane = 0u;
    var bt = 0.0;
    var bb1 = 0.0;
    var bb2 = 0.0;
    for (var l = 0u; l < 8u; l++) {
        let ly = l / 4u;
        let lx = (l / 2u) % 2u;
        let h = l % 2u;
        if (lx >= qx || ly >= qy) {
            continue;
        }
        let x = 2u * wx + lx;
        let y = 2u * wy + ly;
        let pa = block_vertex(vert, w, x, y);
        let pc = block_vertex(vert, w, x + 1u, y + 1u);
        var pb: vec3<f32>;
        var pd: vec3<f32>;
        if (h == 0u) {
            pb = block_vertex(vert, w, x + 1u, y);
            pd = pc;
        } else {
            pb = pc;
            pd = block_vertex(vert, w, x, y + 1u);
        }
        var limit = (*b).tmax;
        if (found) {
            limit = bt;
        }
        let th = intersect_triangle(r, pa, pb, pd, limit);
        if (th.hit && (!found || th.t < bt)) {
            found = true;
            lane = l;
            bt = th.t;
            bb1 = th.b1;
            bb2 = th.b2;
        }
    }
    if (!found) {
        return;
    }
    if (anyhit) {
        (*b).hit = true;
        (*b).stop = true;
        return;
    }
    let x = 2u * wx + (lane / 2u) % 2u;
    let y = 2u * wy + lane / 4u;
    let h = lane % 2u;
    let id = gw(blk + BLK_TRI0) + y * gw(blk + BLK_TRI_STRIDE) + 2u * x + h;
    if (!(*b).hit || bt < (*b).t || (bt == (*b).t && id < (*b).id)) {
        (*b).hit = true;
        (*b).leaf = (bi << 7u) | (y << 4u) | (x << 1u) | h;
        (*b).id = id;
        (*b).t = bt;
        (*b).b1 = bb1;
        (*b).b2 = bb2;
        (*b).tmax = bt;
    }
}

// Block `bi` of mesh record `rec`: its root, then (blocks of more than 4×4 quads) the
// quadrants, front to back, the windows met within the running tmax.
fn grid_block(b: ptr<function, GridBest>, rec: u32, bi: u32, r: PRay, anyhit: bool) {
    let blk = gw(rec + MESH_BLOCK_OFF) + BLK_WORDS * bi;
    let dims = gw(blk + BLK_DIMS);
    let two_level = (dims & 0xffu) > GRID_BLOCK / 2u || ((dims >> 8u) & 0xffu) > GRID_BLOCK / 2u;
    var top = test4(blk + BLK_ROOT, r, (*b).tmax);
    var order = front_to_back(top.mask, top.near);
    for (var i = 0u; i < order.n; i++) {
        let c = order.c[i];
        if (top.near[c] > (*b).tmax) {
            continue;
        }
        if (!two_level) {
            grid_window(b, blk, bi, c % 2u, c / 2u, r, anyhit);
            if ((*b).stop) {
                return;
            }
            continue;
        }
        var q = test4(gw(blk + BLK_BOXES) + BOX4_WORDS * c, r, (*b).tmax);
        var order2 = front_to_back(q.mask, q.near);
        for (var j = 0u; j < order2.n; j++) {
            let c2 = order2.c[j];
            if (q.near[c2] > (*b).tmax) {
                continue;
            }
            grid_window(b, blk, bi, 2u * (c % 2u) + c2 % 2u, 2u * (c / 2u) + c2 / 2u, r, anyhit);
            if ((*b).stop) {
                return;
            }
        }
    }
}

// Closest hit in grid mesh record `m` (GridMesh::intersect): lowest diced-mesh id on equal t.
// With `anyhit`, the first hit found ends the walk (GridMesh::occluded).
fn intersect_mesh(m: u32, r: PRay, anyhit: bool) -> MeshHit {
    let rec = P.mesh_off + MESH_WORDS * m;
    let root = gw(rec + MESH_ROOT);
    if (root == TOP_EMPTY || !r.ok) {
        return MeshHit(false, 0u, 0.0, 0.0, 0.0);
    }
    let top_off = gw(rec + MESH_TOP_OFF);
    let nblocks = gw(rec + MESH_NBLOCKS);
    var b = GridBest(false, 0u, 0u, 0.0, 0.0, 0.0, r.tmax, false);
    var stack: array<vec2<u32>, GRID_STACK>;
    stack[0] = vec2<u32>(root, bitcast<u32>(r.tmin));
    var sp = 1u;
    while (sp > 0u) {
        if (!walk_iter()) {
            break;
        }
        sp -= 1u;
        let e = stack[sp];
        if (bitcast<f32>(e.y) > b.tmax) {
            continue;
        }
        if ((e.x & TOP_LEAF) != 0u) {
            let prim = e.x & ~TOP_LEAF;
            if (prim < nblocks) {
                grid_block(&b, rec, prim, r, anyhit);
            } else {
                let st = gw(rec + MESH_STRIP_OFF) + STRIP_WORDS * (prim - nblocks);
                let first = gw(st);
                let count = gw(st + 1u);
                for (var li = first; li < first + count; li++) {
                    let v = gw(rec + MESH_LOOSE_OFF) + LOOSE_WORDS * li;
                    let th = intersect_triangle(r, loose_corner(v, 0u), loose_corner(v, 1u),
                        loose_corner(v, 2u), b.tmax);
                    if (th.hit) {
                        let id = gw(v + LOOSE_ID);
                        if (anyhit) {
                            b.hit = true;
                            b.stop = true;
                            break;
                        } else if (!b.hit || th.t < b.t || (th.t == b.t && id < b.id)) {
                            b = GridBest(true, LEAF_LOOSE | li, id, th.t, th.b1, th.b2, th.t,
                                false);
                        }
                    }
                }
            }
            if (b.stop) {
                break;
            }
            continue;
        }
        let node = top_off + TOP_WORDS * e.x;
        var h = test8(node, r, b.tmax);
        if (h.mask == 0u) {
            continue;
        }
        var order = front_to_back8(h);
        // Far to near: the nearest is popped first.
        for (var k = order.n; k > 0u; k--) {
            let c = order.c[k - 1u];
            if (sp == GRID_STACK) {
                overflow = true;
                break;
            }
            stack[sp] = vec2<u32>(gw(node + TOP_CHILD + c), bitcast<u32>(h.near[c]));
            sp += 1u;
        }
        if (overflow) {
            break;
        }
    }
    return MeshHit(b.hit, b.leaf, b.t, b.b1, b.b2);
}

struct SceneResult {
    hit: bool,
    inst: u32,
    leaf: u32,
    t: f32,
    b1: f32,
    b2: f32,
}

// glam's Affine3A::transform_point3a / transform_vector3a: ((x·X + y·Y) + z·Z) (+ T).
fn inst_vec(base: u32, v: vec3<f32>, point: bool) -> vec3<f32> {
    let xa = vec3<f32>(gf(base), gf(base + 1u), gf(base + 2u));
    let ya = vec3<f32>(gf(base + 3u), gf(base + 4u), gf(base + 5u));
    let za = vec3<f32>(gf(base + 6u), gf(base + 7u), gf(base + 8u));
    var res = vec3<f32>(xa.x * v.x, xa.y * v.x, xa.z * v.x);
    res = vec3<f32>(res.x + ya.x * v.y, res.y + ya.y * v.y, res.z + ya.z * v.y);
    res = vec3<f32>(res.x + za.x * v.z, res.y + za.y * v.z, res.z + za.z * v.z);
    if (point) {
        let ta = vec3<f32>(gf(base + 9u), gf(base + 10u), gf(base + 11u));
        res = vec3<f32>(res.x + ta.x, res.y + ta.y, res.z + ta.z);
    }
    return res;
}

// Closest hit of a world ray (SceneBvh::intersect, or GridMesh::intersect in mode 0); with
// `any`, the first hit found (SceneBvh::occluded).
fn intersect_world(o: vec3<f32>, d: vec3<f32>, tmin: f32, tmax0: f32, anyhit: bool) -> SceneResult {
    var best = SceneResult(false, 0u, 0u, 0.0, 0.0, 0.0);
    let r = prepare_ray(o, d, tmin, tmax0);
    if (P.mode == 0u) {
        let h = intersect_mesh(0u, r, anyhit);
        return SceneResult(h.hit, 0u, h.leaf, h.t, h.b1, h.b2);
    }
    if (P.top_node_count == 0u || !r.ok) {
        return best;
    }
    var tmax = tmax0;
    var w = walk_new();
    loop {
        if (!walk_iter()) {
            break;
        }
        while (w.prim.y != 0u && !overflow) {
            let l = firstLeadingBit(w.prim.y);
            w.prim.y &= ~(1u << l);
            let i = gw(P.top_index_off + w.prim.x + l);
            let ib = P.inst_off + INSTANCE_WORDS * i;
            let m = gw(ib + INST_MESH);
            let oo = inst_vec(ib + INST_XFORM, o, true);
            let od = inst_vec(ib + INST_XFORM, d, false);
            let h = intersect_mesh(m, prepare_ray(oo, od, tmin, tmax), anyhit);
            if (h.hit && (!best.hit || h.t < best.t || (h.t == best.t && i < best.inst))) {
                best = SceneResult(true, i, h.leaf, h.t, h.b1, h.b2);
                if (anyhit) {
                    return best;
                }
                tmax = h.t;
            }
        }
        if (overflow) {
            break;
        }
        if (!walk_step(&w, P.top_node_off, P.top_box_off, r, tmax)) {
            break;
        }
    }
    return best;
}

// The corners of the triangle at hit location `leaf` (Hit::leaf) of mesh record `rec`, and
// where their unit normals are in the render block (`normals`: the mesh's MX_NORMALS, `loose`:
// its MX_LOOSE_NORMALS), in the order of the hit's barycentrics (GridMesh::corners).
struct LeafCorners {
    p: array<vec3<f32>, 3>,
    n: array<u32, 3>,
}

fn leaf_corners(rec: u32, leaf: u32, normals: u32, loose: u32) -> LeafCorners {
    var out: LeafCorners;
    if ((leaf & LEAF_LOOSE) != 0u) {
        let li = leaf & ~LEAF_LOOSE;
        let v = gw(rec + MESH_LOOSE_OFF) + LOOSE_WORDS * li;
        for (var i = 0u; i < 3u; i++) {
            out.p[i] = loose_corner(v, i);
            out.n[i] = loose + TRI_WORDS * li + 3u * i;
        }
        return out;
    }
    let blk = gw(rec + MESH_BLOCK_OFF) + BLK_WORDS * (leaf >> 7u);
    let y = (leaf >> 4u) & 7u;
    let x = (leaf >> 1u) & 7u;
    let w = (gw(blk + BLK_DIMS) & 0xffu) + 1u;
    var cx = array<u32, 3>(x, x + 1u, x + 1u);
    var cy = array<u32, 3>(y, y, y + 1u);
    if ((leaf & 1u) == 1u) {
        cx = array<u32, 3>(x, x + 1u, x);
        cy = array<u32, 3>(y, y + 1u, y + 1u);
    }
    let vert = gw(blk + BLK_VERT);
    let n0 = gw(blk + BLK_NORMAL);
    for (var i = 0u; i < 3u; i++) {
        out.p[i] = block_vertex(vert, w, cx[i], cy[i]);
        out.n[i] = normals + 3u * (n0 + cy[i] * w + cx[i]);
    }
    return out;
}
