// The path tracer on the GPU: a port of src/render/ (integrator.rs, camera.rs, sampling.rs,
// material.rs, light.rs, env.rs, rng.rs) with the same counter-based RNG, the same sample
// dimensions, the same sampling and the same materials, operation for operation where the CPU
// code uses only + − × ÷ sqrt (those are bitwise on lavapipe); sin, cos, atan2, acos differ
// from Rust's by a few ulps, so paths agree statistically, and mostly exactly.
//
// Needs exact.wgsl, bvh.wgsl, sampling.wgsl and material.wgsl in the same module. Params: user0 = first pixel of the dispatch,
// user1 = word offset of the render block, user2..user3 = sample range [s0, s1),
// ray_count = pixels in the dispatch.
//
// Render block (words from R = user1): a header (H_*) of absolute offsets to its records,
// all laid out in src/gpu/layout.rs and packed by src/gpu/render.rs (`pack_world`).

@group(0) @binding(9) var<storage, read_write> acc: array<f32>;
@group(0) @binding(10) var<storage, read_write> prim: array<u32>;

// +∞ (not a constant expression: WGSL constants must be finite; user4 is 0).
fn inf() -> f32 {
    return bitcast<f32>(0x7f800000u | P.user4);
}

fn hdr(i: u32) -> u32 {
    return gw(P.user1 + i);
}

fn v3(i: u32) -> vec3<f32> {
    return vec3<f32>(gf(i), gf(i + 1u), gf(i + 2u));
}

// ---------------------------------------------------------------------------------------------
// light.rs. Quads (QUAD_*) and mesh lights (MESHL_*: world-space triangles and an area
// distribution).

fn quad_intersect(q: u32, o: vec3<f32>, d: vec3<f32>, tmax: f32) -> f32 {
    let corner = v3(q + QUAD_CORNER);
    let e1 = v3(q + QUAD_EDGE1);
    let e2 = v3(q + QUAD_EDGE2);
    let n = cross3(e1, e2);
    let denom = dot3(d, n);
    if (denom == 0.0) {
        return -1.0;
    }
    let t = dot3(corner - o, n) / denom;
    if (!(t > 0.0 && t < tmax)) {
        return -1.0;
    }
    let w = (o + d * t) - corner;
    let nn = dot3(n, n);
    let a = dot3(cross3(w, e2), n) / nn;
    let b = dot3(cross3(e1, w), n) / nn;
    if (a >= 0.0 && a <= 1.0 && b >= 0.0 && b <= 1.0) {
        return t;
    }
    return -1.0;
}

struct QuadHit {
    hit: bool,
    t: f32,
    i: u32,
}

fn intersect_quads(o: vec3<f32>, d: vec3<f32>, tmax: f32) -> QuadHit {
    var best = QuadHit(false, 0.0, 0u);
    var tm = tmax;
    let n = hdr(H_NQUADS);
    let base = hdr(H_QUADS);
    for (var i = 0u; i < n; i++) {
        let t = quad_intersect(base + QUAD_WORDS * i, o, d, tm);
        if (t > 0.0) {
            tm = t;
            best = QuadHit(true, t, i);
        }
    }
    return best;
}

fn select_pmf(slot: u32) -> f32 {
    let d = hdr(H_SELECT);
    if (slot < dist_n(d)) {
        return dist_pmf(d, slot);
    }
    return 0.0;
}

// Slots: quads, then mesh lights, then the environment.
fn pdf_area_light(slot: u32, area: f32, dist: f32, cos_l: f32) -> f32 {
    let c = abs(cos_l);
    if (c <= 0.0) {
        return 0.0;
    }
    return select_pmf(slot) * dist * dist / (c * area);
}

fn pdf_env(wi: vec3<f32>) -> f32 {
    if (hdr(H_ENV_KIND) == ENV_NONE) {
        return 0.0;
    }
    return select_pmf(hdr(H_NQUADS) + hdr(H_NMESHL)) * env_pdf(wi);
}

struct LightSample {
    ok: bool,
    wi: vec3<f32>,
    point: vec3<f32>,
    normal: vec3<f32>,
    dist: f32,
    li: vec3<f32>,
    pdf: f32,
}

fn no_light() -> LightSample {
    return LightSample(false, vec3<f32>(0.0), vec3<f32>(0.0), vec3<f32>(0.0), 0.0, vec3<f32>(0.0), 0.0);
}

fn sample_light(p: vec3<f32>, u_sel: f32, u1: f32, u2: f32) -> LightSample {
    let sel = hdr(H_SELECT);
    if (dist_n(sel) == 0u) {
        return no_light();
    }
    let s = dist_sample(sel, u_sel);
    if (s.p <= 0.0) {
        return no_light();
    }
    let nq = hdr(H_NQUADS);
    let nm = hdr(H_NMESHL);
    if (s.i < nq) {
        let q = hdr(H_QUADS) + QUAD_WORDS * s.i;
        let normal = v3(q + QUAD_NORMAL);
        let point = (v3(q + QUAD_CORNER) + v3(q + QUAD_EDGE1) * u1) + v3(q + QUAD_EDGE2) * u2;
        let dd = point - p;
        let dist = length3(dd);
        if (!(dist > 0.0 && finite(dist))) {
            return no_light();
        }
        let wi = dd / dist;
        let cos_l = -dot3(wi, normal);
        if (cos_l <= 0.0) {
            return no_light();
        }
        let pdf = s.p * dist * dist / (cos_l * gf(q + QUAD_AREA));
        return LightSample(true, wi, point, normal, dist, v3(q + QUAD_RADIANCE), pdf);
    }
    if (s.i < nq + nm) {
        let ml = hdr(H_MESHL) + MESHL_WORDS * (s.i - nq);
        let ts = dist_sample(gw(ml + MESHL_DIST), u1);
        let tri = gw(ml + MESHL_TRIS) + TRI_WORDS * ts.i;
        let t0 = v3(tri);
        let t1 = v3(tri + 3u);
        let t2 = v3(tri + 6u);
        let bb = uniform_triangle(ts.rem, u2);
        let point = (t0 * (1.0 - bb.x - bb.y) + t1 * bb.x) + t2 * bb.y;
        let ng = normalize_or_zero(cross3(t1 - t0, t2 - t0));
        let dd = point - p;
        let dist = length3(dd);
        if (!(dist > 0.0 && finite(dist))) {
            return no_light();
        }
        let wi = dd / dist;
        let cos_l = abs(-dot3(wi, ng));
        if (cos_l <= 0.0) {
            return no_light();
        }
        var normal = -ng;
        if (dot3(ng, wi) < 0.0) {
            normal = ng;
        }
        let pdf = s.p * dist * dist / (cos_l * gf(ml + MESHL_AREA));
        return LightSample(true, wi, point, normal, dist, v3(ml + MESHL_RADIANCE), pdf);
    }
    if (hdr(H_ENV_KIND) == ENV_NONE) {
        return no_light();
    }
    let es = env_sample(u1, u2);
    if (es.pdf <= 0.0) {
        return no_light();
    }
    return LightSample(true, es.wi, vec3<f32>(0.0), vec3<f32>(0.0), inf(), es.li, es.pdf * s.p);
}

// ---------------------------------------------------------------------------------------------
// integrator.rs

fn offset_comp(p: f32, n: f32) -> f32 {
    if (abs(p) < 1.0 / 32.0) {
        return p + (1.0 / 65536.0) * n;
    }
    let off = i32(256.0 * n);
    let bits = bitcast<i32>(p);
    var moved = bits + off;
    if (p < 0.0) {
        moved = bits - off;
    }
    return bitcast<f32>(moved);
}

fn offset_origin(p: vec3<f32>, n: vec3<f32>) -> vec3<f32> {
    return vec3<f32>(offset_comp(p.x, n.x), offset_comp(p.y, n.y), offset_comp(p.z, n.z));
}

fn side(n: vec3<f32>, w: vec3<f32>) -> vec3<f32> {
    if (dot3(w, n) >= 0.0) {
        return n;
    }
    return -n;
}

// Mat3A · v with columns at word c: ((X·x + Y·y) + Z·z).
fn mat3_mul(c: u32, v: vec3<f32>) -> vec3<f32> {
    return (v3(c) * v.x + v3(c + 3u) * v.y) + v3(c + 6u) * v.z;
}

struct SurfaceHit {
    inst: u32,
    t: f32,
    p: vec3<f32>,
    ng: vec3<f32>,
    ns: vec3<f32>,
    // Object-space point (procedural maps).
    po: vec3<f32>,
    // Texture coordinates (interpolated from the vertices': src/gpu/texture.rs), and
    // sqrt(texture area / world area) over the triangle (0 without texture coordinates).
    st: vec2<f32>,
    st_scale: f32,
}

// The world-space hit record (SceneBvh::hit_record and World::hit_point).
fn surface(h: SceneResult) -> SurfaceHit {
    let ib = P.inst_off + INSTANCE_WORDS * h.inst;
    let m = gw(ib + INST_MESH);
    let rec = P.mesh_off + MESH_WORDS * m;
    let extra = hdr(H_MESH_EXTRA) + MESH_EXTRA_WORDS * m;
    let normals = gw(extra + MX_NORMALS);
    let loose = gw(extra + MX_LOOSE_NORMALS);
    let lc = leaf_corners(rec, h.leaf, normals, loose);
    let a = lc.p[0];
    let b = lc.p[1];
    let c = lc.p[2];
    let b0 = 1.0 - h.b1 - h.b2;
    let e1 = b - a;
    let e2 = c - a;
    let ng = normalize_div(vec3<f32>(
        e1.y * e2.z - e1.z * e2.y,
        e1.z * e2.x - e1.x * e2.z,
        e1.x * e2.y - e1.y * e2.x,
    ));
    let n0 = v3(lc.n[0]);
    let n1 = v3(lc.n[1]);
    let n2 = v3(lc.n[2]);
    var ns = normalize_div((b0 * n0 + h.b1 * n1) + h.b2 * n2);
    if (!finite3(ns)) {
        ns = ng;
    }
    let xf = hdr(H_INST_XF) + XF_WORDS * h.inst;
    let po = (a * (1.0 - h.b1 - h.b2) + b * h.b1) + c * h.b2;
    let p = mat3_mul(xf + XF_MATRIX, po) + v3(xf + XF_TRANSLATION);
    // Texture coordinates: the corners' records sit where their normals do (2 words for 3).
    var st = vec2<f32>(0.0);
    var st_scale = 0.0;
    let st_grid = gw(extra + MX_ST);
    if (st_grid != NONE) {
        var base = st_grid;
        var first = normals;
        if ((h.leaf & LEAF_LOOSE) != 0u) {
            base = gw(extra + MX_LOOSE_ST);
            first = loose;
        }
        var s: array<vec2<f32>, 3>;
        for (var i = 0u; i < 3u; i++) {
            let at = base + 2u * ((lc.n[i] - first) / 3u);
            s[i] = vec2<f32>(gf(at), gf(at + 1u));
        }
        st = (s[0] * b0 + s[1] * h.b1) + s[2] * h.b2;
        let d1 = s[1] - s[0];
        let d2 = s[2] - s[0];
        let st_area = abs(d1.x * d2.y - d1.y * d2.x);
        let w1 = mat3_mul(xf + XF_MATRIX, e1);
        let w2 = mat3_mul(xf + XF_MATRIX, e2);
        let area = length3(cross3(w1, w2));
        if (area > 0.0 && finite(area)) {
            st_scale = sqrt(st_area / area);
        }
    }
    return SurfaceHit(
        h.inst,
        h.t,
        p,
        normalize_div(mat3_mul(xf + XF_NORMAL, ng)),
        normalize_div(mat3_mul(xf + XF_NORMAL, ns)),
        po,
        st,
        st_scale,
    );
}

fn occluded(o: vec3<f32>, d: vec3<f32>, tmax: f32) -> bool {
    if (intersect_quads(o, d, tmax).hit) {
        return true;
    }
    return intersect_world(o, d, 0.0, tmax, true).hit;
}

struct PathResult {
    l: vec3<f32>,
    first: bool,
    normal: vec3<f32>,
    albedo: vec3<f32>,
}

fn trace_path(o0: vec3<f32>, d0: vec3<f32>, key: u32) -> PathResult {
    let max_depth = min(hdr(H_MAX_DEPTH), 1024u);
    var res = PathResult(vec3<f32>(0.0), false, vec3<f32>(0.0), vec3<f32>(0.0));
    var l = vec3<f32>(0.0);
    var beta = vec3<f32>(1.0);
    var o = o0;
    var d = d0;
    var prev_pdf = 0.0;
    var prev_delta = true;
    let nq = hdr(H_NQUADS);
    // The path's footprint cone (texture filtering, integrator.rs): width at the ray's origin
    // and spread (radians per unit length).
    var cone_width = 0.0;
    var cone_spread = 1.0 / (f32(hdr(H_HEIGHT)) / (2.0 * gf(P.user1 + H_CAMERA + CAM_TAN_HALF_FOV)));
    for (var bounce = 0u; bounce <= max_depth; bounce++) {
        let mh = intersect_world(o, d, 0.0, inf(), false);
        var tmax = inf();
        if (mh.hit) {
            tmax = mh.t;
        }
        let qh = intersect_quads(o, d, tmax);
        if (!mh.hit && !qh.hit) {
            if (hdr(H_ENV_KIND) != ENV_NONE) {
                let le = env_eval(d);
                var w = 1.0;
                if (!prev_delta) {
                    w = power_heuristic(prev_pdf, pdf_env(d));
                }
                l += beta * le * w;
            }
            break;
        }
        if (qh.hit) {
            let q = hdr(H_QUADS) + QUAD_WORDS * qh.i;
            let cos_l = -dot3(d, v3(q + QUAD_NORMAL));
            if (cos_l > 0.0) {
                var w = 1.0;
                if (!prev_delta) {
                    w = power_heuristic(prev_pdf, pdf_area_light(qh.i, gf(q + QUAD_AREA), qh.t, cos_l));
                }
                l += beta * v3(q + QUAD_RADIANCE) * w;
            }
            break;
        }
        let h = surface(mh);
        let maddr = hdr(H_MAT) + MAT_WORDS * gw(hdr(H_INST_MAT) + h.inst);
        let width = cone_width + cone_spread * h.t * length3(d);
        var mat: Mat;
        if (mat_has_maps(maddr)) {
            mat = mat_textured(maddr, TexLookup(h.st, h.po, width * h.st_scale));
        } else {
            mat = mat_load(maddr);
        }
        let wo = -d;
        if (mat_kind(mat) == M_EMISSIVE) {
            if (bounce == 0u) {
                res.first = true;
                res.normal = side(h.ns, wo);
                res.albedo = mat_albedo(mat);
            }
            var w = 1.0;
            let li = gw(hdr(H_INST_LIGHT) + h.inst);
            if (li != NONE && !prev_delta) {
                let cos_l = dot3(d, h.ng);
                let ml = hdr(H_MESHL) + MESHL_WORDS * li;
                w = power_heuristic(prev_pdf, pdf_area_light(nq + li, gf(ml + MESHL_AREA), h.t, cos_l));
            }
            l += beta * mat.color * w;
            break;
        }
        // Shading geometry.
        let front = dot3(wo, h.ng) >= 0.0;
        var ng = h.ng;
        var ns = h.ns;
        if (!front) {
            ng = -h.ng;
            ns = -h.ns;
        }
        if (dot3(wo, ns) <= 0.0) {
            ns = ng;
        }
        var etap = 1.0;
        if (mat_kind(mat) == M_DIELECTRIC) {
            let ior = mat.color.x;
            etap = select(1.0 / ior, ior, front);
        }
        let frame = frame_new(ns);
        if (bounce == 0u) {
            res.first = true;
            res.normal = frame.n;
            res.albedo = mat_albedo(mat);
        }
        if (bounce == max_depth) {
            break;
        }
        let wo_l = to_local(frame, wo);

        // Next-event estimation.
        if (!mat_is_delta(mat)) {
            let ls = sample_light(
                h.p,
                bdim(key, bounce, D_LIGHT_SELECT),
                bdim(key, bounce, D_LIGHT_U),
                bdim(key, bounce, D_LIGHT_V),
            );
            if (ls.ok) {
                let wi_l = to_local(frame, ls.wi);
                let ev = mat_eval(mat, wo_l, wi_l, etap);
                let geo_ok = (wi_l.z > 0.0) == (dot3(ls.wi, ng) > 0.0);
                if (geo_ok && max_element(ev.f) > 0.0) {
                    let origin = offset_origin(h.p, side(ng, ls.wi));
                    var visible: bool;
                    if (finite(ls.dist)) {
                        var aim = ls.point;
                        if (!(ls.normal.x == 0.0 && ls.normal.y == 0.0 && ls.normal.z == 0.0)) {
                            aim = offset_origin(ls.point, ls.normal);
                        }
                        visible = !occluded(origin, aim - origin, 1.0 - 1e-4);
                    } else {
                        visible = !occluded(origin, ls.wi, inf());
                    }
                    if (visible) {
                        let w = power_heuristic(ls.pdf, ev.pdf);
                        let c = beta * ev.f * ls.li * (abs(wi_l.z) * w / ls.pdf);
                        if (finite3(c)) {
                            l += c;
                        }
                    }
                }
            }
        }

        // Continue by BSDF sampling.
        let bs = mat_sample(
            mat,
            wo_l,
            etap,
            bdim(key, bounce, D_BSDF_LOBE),
            bdim(key, bounce, D_BSDF_U),
            bdim(key, bounce, D_BSDF_V),
        );
        if (!bs.ok) {
            break;
        }
        let wi = to_world(frame, bs.wi);
        if ((bs.wi.z > 0.0) != (dot3(wi, ng) > 0.0)) {
            break;
        }
        beta *= bs.weight;
        if (!finite3(beta) || max_element(beta) <= 0.0) {
            break;
        }
        if (bounce + 1u >= RR_START) {
            let p = fmin(max_element(beta), 1.0);
            if (bdim(key, bounce, D_RR) >= p) {
                break;
            }
            beta = vec3<f32>(beta.x / p, beta.y / p, beta.z / p);
        }
        prev_pdf = bs.pdf;
        prev_delta = bs.delta;
        cone_width = width;
        if (!bs.delta) {
            cone_spread += BOUNCE_SPREAD;
        }
        o = offset_origin(h.p, side(ng, wi));
        d = wi;
    }
    res.l = l;
    return res;
}

struct CamRay {
    o: vec3<f32>,
    d: vec3<f32>,
}

// camera.rs Camera::ray.
fn camera_ray(px: f32, py: f32, lu: f32, lv: f32) -> CamRay {
    let c = P.user1 + H_CAMERA;
    let position = v3(c + CAM_POSITION);
    let forward = v3(c + CAM_FORWARD);
    let right = v3(c + CAM_RIGHT);
    let up = v3(c + CAM_UP);
    let tan_half = gf(c + CAM_TAN_HALF_FOV);
    let aperture = gf(c + CAM_APERTURE);
    let focus_distance = gf(c + CAM_FOCUS_DISTANCE);
    let w = f32(hdr(H_WIDTH));
    let h = f32(hdr(H_HEIGHT));
    let aspect = w / h;
    let sx = (2.0 * px / w - 1.0) * tan_half * aspect;
    let sy = (1.0 - 2.0 * py / h) * tan_half;
    let d = normalize3((forward + right * sx) + up * sy);
    if (aperture <= 0.0) {
        return CamRay(position, d);
    }
    let k = focus_distance / dot3(d, forward);
    // nf3: NIR may otherwise simplify (position + x) − position to x (inexact float
    // algebra is allowed on SPIR-V without NoContraction); Rust rounds the sum first.
    let focus = nf3(position + d * k);
    let disk = concentric_disk(lu, lv);
    let origin = nf3((position + right * (disk.x * aperture)) + up * (disk.y * aperture));
    return CamRay(origin, normalize3(focus - origin));
}

// Adds samples [user2, user3) of each pixel of the dispatch to its accumulator, in sample order.
@compute @workgroup_size(WORKGROUP)
fn path_main(@builtin(global_invocation_id) gid: vec3<u32>) {
    if (gid.x >= P.ray_count) {
        return;
    }
    let pixel = P.user0 + gid.x;
    let width = hdr(H_WIDTH);
    let x = pixel % width;
    let y = pixel / width;
    let seed = hdr(H_SEED);
    let a = ACC_WORDS * gid.x;
    let an = a + ACC_NORMAL;
    let aa = a + ACC_ALBEDO;
    var sum = vec3<f32>(acc[a + ACC_RGB], acc[a + ACC_RGB + 1u], acc[a + ACC_RGB + 2u]);
    var alpha = acc[a + ACC_ALPHA];
    var normal = vec3<f32>(acc[an], acc[an + 1u], acc[an + 2u]);
    var albedo = vec3<f32>(acc[aa], acc[aa + 1u], acc[aa + 2u]);
    iters = 0u;
    overflow = false;
    for (var s = P.user2; s < P.user3; s++) {
        let key = rng_key(seed, pixel, s);
        let r = camera_ray(
            f32(x) + rnd(key, D_PIXEL_X),
            f32(y) + rnd(key, D_PIXEL_Y),
            rnd(key, D_LENS_U),
            rnd(key, D_LENS_V),
        );
        let pr = trace_path(r.o, r.d, key);
        sum += pr.l;
        if (pr.first) {
            alpha += 1.0;
            normal += pr.normal;
            albedo += pr.albedo;
        }
        // The iteration bound is per path.
        iters = 0u;
    }
    acc[a + ACC_RGB] = sum.x;
    acc[a + ACC_RGB + 1u] = sum.y;
    acc[a + ACC_RGB + 2u] = sum.z;
    acc[a + ACC_ALPHA] = alpha;
    acc[an] = normal.x;
    acc[an + 1u] = normal.y;
    acc[an + 2u] = normal.z;
    acc[aa] = albedo.x;
    acc[aa + 1u] = albedo.y;
    acc[aa + 2u] = albedo.z;
    acc[a + ACC_OVERFLOW] = select(acc[a + ACC_OVERFLOW], 1.0, overflow);
}

// The centre ray of each pixel of the dispatch (the AOV ray): a hit record (HIT_*) per pixel,
// with STATUS_QUAD_LIGHT when a quad light is in front of any mesh.
@compute @workgroup_size(WORKGROUP)
fn primary_main(@builtin(global_invocation_id) gid: vec3<u32>) {
    if (gid.x >= P.ray_count) {
        return;
    }
    let pixel = P.user0 + gid.x;
    let width = hdr(H_WIDTH);
    let x = pixel % width;
    let y = pixel / width;
    iters = 0u;
    overflow = false;
    let r = camera_ray(f32(x) + 0.5, f32(y) + 0.5, 0.5, 0.5);
    let h = intersect_world(r.o, r.d, 0.0, inf(), false);
    var status = select(STATUS_MISS, STATUS_HIT, h.hit);
    var tmax = inf();
    if (h.hit) {
        tmax = h.t;
    }
    if (intersect_quads(r.o, r.d, tmax).hit) {
        status = STATUS_QUAD_LIGHT;
    }
    if (overflow) {
        status = STATUS_OVERFLOW;
    }
    let a = HIT_WORDS * gid.x;
    prim[a + HIT_STATUS] = status;
    prim[a + HIT_INSTANCE] = h.inst;
    prim[a + HIT_LEAF] = h.leaf;
    prim[a + HIT_T] = bitcast<u32>(h.t);
    prim[a + HIT_B1] = bitcast<u32>(h.b1);
    prim[a + HIT_B2] = bitcast<u32>(h.b2);
}
