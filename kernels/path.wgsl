// The path tracer on the GPU: a port of src/render/ (integrator.rs, camera.rs, sampling.rs,
// material.rs, light.rs, env.rs, rng.rs) with the same counter-based RNG, the same sample
// dimensions, the same sampling and the same materials, operation for operation where the CPU
// code uses only + − × ÷ sqrt (those are bitwise on lavapipe); sin, cos, atan2, acos differ
// from Rust's by a few ulps, so paths agree statistically, and mostly exactly.
//
// Needs exact.wgsl and bvh.wgsl before it. Params: user0 = first pixel of the dispatch,
// user1 = word offset of the render block, user2..user3 = sample range [s0, s1),
// ray_count = pixels in the dispatch.
//
// Render block (words from R = user1): see src/gpu/render.rs (`pack_render`).

@group(0) @binding(9) var<storage, read_write> acc: array<f32>;
@group(0) @binding(10) var<storage, read_write> prim: array<u32>;

const PI: f32 = 3.14159265358979323846;
const DELTA_ALPHA: f32 = 1e-3;
const RR_START: u32 = 3u;
const NONE: u32 = 0xffffffffu;
// Accumulator floats per pixel: sum rgb, alpha, normal xyz, albedo xyz, 2 unused.
const ACC: u32 = 12u;

// Header words of the render block.
const H_WIDTH: u32 = 0u;
const H_HEIGHT: u32 = 1u;
const H_MAX_DEPTH: u32 = 3u;
const H_SEED: u32 = 4u;
const H_MAT: u32 = 5u;
const H_INST_MAT: u32 = 6u;
const H_NQUADS: u32 = 7u;
const H_QUADS: u32 = 8u;
const H_NMESHL: u32 = 9u;
const H_MESHL: u32 = 10u;
const H_INST_LIGHT: u32 = 11u;
const H_ENV_KIND: u32 = 12u;
const H_ENV: u32 = 13u;
const H_SELECT: u32 = 14u;
const H_INST_XF: u32 = 15u;
const H_MESH_EXTRA: u32 = 16u;
const H_CAMERA: u32 = 20u;

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
// glam's Vec3 arithmetic, in its order.

fn dot3(a: vec3<f32>, b: vec3<f32>) -> f32 {
    return (a.x * b.x + a.y * b.y) + a.z * b.z;
}

fn cross3(a: vec3<f32>, b: vec3<f32>) -> vec3<f32> {
    return vec3<f32>(a.y * b.z - b.y * a.z, a.z * b.x - b.z * a.x, a.x * b.y - b.x * a.y);
}

fn length3(a: vec3<f32>) -> f32 {
    return sqrt(dot3(a, a));
}

// glam's normalize: v · (1 / |v|).
fn normalize3(a: vec3<f32>) -> vec3<f32> {
    return a * (1.0 / length3(a));
}

fn finite3(a: vec3<f32>) -> bool {
    return finite(a.x) && finite(a.y) && finite(a.z);
}

fn normalize_or_zero(a: vec3<f32>) -> vec3<f32> {
    let r = 1.0 / length3(a);
    if (finite(r) && r > 0.0) {
        return a * r;
    }
    return vec3<f32>(0.0);
}

// src/bvh/mesh.rs normalize: v / |v| (zero stays zero).
fn normalize_div(v: vec3<f32>) -> vec3<f32> {
    let l = sqrt((v.x * v.x + v.y * v.y) + v.z * v.z);
    if (l > 0.0) {
        return vec3<f32>(v.x / l, v.y / l, v.z / l);
    }
    return v;
}

// f32::max / f32::min: a NaN operand yields the other one.
fn fmax(a: f32, b: f32) -> f32 {
    if (a != a) {
        return b;
    }
    if (b != b) {
        return a;
    }
    return select(b, a, a > b);
}

fn fmin(a: f32, b: f32) -> f32 {
    if (a != a) {
        return b;
    }
    if (b != b) {
        return a;
    }
    return select(b, a, a < b);
}

fn fclamp(x: f32, lo: f32, hi: f32) -> f32 {
    var r = x;
    if (r < lo) {
        r = lo;
    }
    if (r > hi) {
        r = hi;
    }
    return r;
}

fn max_element(a: vec3<f32>) -> f32 {
    return fmax(fmax(a.x, a.y), a.z);
}

// ---------------------------------------------------------------------------------------------
// rng.rs

fn pcg_hash(x: u32) -> u32 {
    let state = x * 747796405u + 2891336453u;
    let word = ((state >> ((state >> 28u) + 4u)) ^ state) * 277803737u;
    return (word >> 22u) ^ word;
}

fn to_unit(bits: u32) -> f32 {
    return f32(bits >> 8u) * (1.0 / 16777216.0);
}

fn rng_key(seed: u32, pixel: u32, sample: u32) -> u32 {
    return pcg_hash(pcg_hash(pcg_hash(seed) ^ pixel) ^ sample);
}

fn rnd(key: u32, dim: u32) -> f32 {
    return to_unit(pcg_hash(key ^ dim));
}

const D_PIXEL_X: u32 = 0u;
const D_PIXEL_Y: u32 = 1u;
const D_LENS_U: u32 = 2u;
const D_LENS_V: u32 = 3u;
const D_BOUNCE_BASE: u32 = 4u;
const D_PER_BOUNCE: u32 = 8u;
const D_LIGHT_SELECT: u32 = 0u;
const D_LIGHT_U: u32 = 1u;
const D_LIGHT_V: u32 = 2u;
const D_BSDF_LOBE: u32 = 3u;
const D_BSDF_U: u32 = 4u;
const D_BSDF_V: u32 = 5u;
const D_RR: u32 = 6u;

fn bdim(key: u32, bounce: u32, j: u32) -> f32 {
    return rnd(key, D_BOUNCE_BASE + bounce * D_PER_BOUNCE + j);
}

// ---------------------------------------------------------------------------------------------
// sampling.rs

struct Frame {
    t: vec3<f32>,
    b: vec3<f32>,
    n: vec3<f32>,
}

fn frame_new(n: vec3<f32>) -> Frame {
    let sign = select(-1.0, 1.0, n.z >= 0.0);
    let a = -1.0 / (sign + n.z);
    let b = n.x * n.y * a;
    let t = vec3<f32>(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x);
    let bt = vec3<f32>(b, sign + n.y * n.y * a, -n.y);
    return Frame(t, bt, n);
}

fn to_local(f: Frame, v: vec3<f32>) -> vec3<f32> {
    return vec3<f32>(dot3(v, f.t), dot3(v, f.b), dot3(v, f.n));
}

fn to_world(f: Frame, v: vec3<f32>) -> vec3<f32> {
    return (f.t * v.x + f.b * v.y) + f.n * v.z;
}

fn concentric_disk(u1: f32, u2: f32) -> vec2<f32> {
    let a = 2.0 * u1 - 1.0;
    let b = 2.0 * u2 - 1.0;
    if (a == 0.0 && b == 0.0) {
        return vec2<f32>(0.0);
    }
    var r: f32;
    var phi: f32;
    if (abs(a) > abs(b)) {
        r = a;
        phi = (PI / 4.0) * (b / a);
    } else {
        r = b;
        phi = PI / 2.0 - (PI / 4.0) * (a / b);
    }
    return vec2<f32>(r * cos(phi), r * sin(phi));
}

fn cosine_hemisphere(u1: f32, u2: f32) -> vec3<f32> {
    let p = concentric_disk(u1, u2);
    let z = sqrt(fmax(1.0 - p.x * p.x - p.y * p.y, 0.0));
    return vec3<f32>(p.x, p.y, z);
}

fn uniform_sphere(u1: f32, u2: f32) -> vec3<f32> {
    let z = 1.0 - 2.0 * u1;
    let r = sqrt(fmax(1.0 - z * z, 0.0));
    let phi = 2.0 * PI * u2;
    return vec3<f32>(r * cos(phi), r * sin(phi), z);
}

fn uniform_triangle(u1: f32, u2: f32) -> vec2<f32> {
    let s = sqrt(u1);
    return vec2<f32>(s * (1.0 - u2), s * u2);
}

fn power_heuristic(a: f32, b: f32) -> f32 {
    let a2 = a * a;
    let b2 = b * b;
    if (a2 + b2 > 0.0 && finite(a2)) {
        return a2 / (a2 + b2);
    } else if (finite(a2)) {
        return 0.0;
    }
    return 1.0;
}

// Distribution1D at word d: n, total, cdf[n + 1], pmf[n].
struct Sample1D {
    i: u32,
    p: f32,
    rem: f32,
}

fn dist_n(d: u32) -> u32 {
    return gw(d);
}

fn dist_pmf(d: u32, i: u32) -> f32 {
    return gf(d + 3u + gw(d) + i);
}

fn dist_sample(d: u32, u: f32) -> Sample1D {
    let n = gw(d);
    let cdf = d + 2u;
    let pmf = d + 3u + n;
    var lo = 0u;
    var hi = n;
    for (var k = 0u; k < 40u && hi - lo > 1u; k++) {
        let mid = (lo + hi) / 2u;
        if (gf(cdf + mid) <= u) {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    var i = lo;
    for (var k = 0u; k < n && i + 1u < n && gf(pmf + i) <= 0.0; k++) {
        i += 1u;
    }
    let p = gf(pmf + i);
    var rem = 0.0;
    if (p > 0.0) {
        rem = fclamp((u - gf(cdf + i)) / p, 0.0, 1.0 - 0x1p-24);
    }
    return Sample1D(i, p, rem);
}

// Distribution2D at word d: width, height, rows (offset), cols offsets[height].
struct Sample2D {
    uv: vec2<f32>,
    pdf: f32,
}

fn dist2_sample(d: u32, u1: f32, u2: f32) -> Sample2D {
    let w = gw(d);
    let h = gw(d + 1u);
    let ry = dist_sample(gw(d + 2u), u1);
    let rx = dist_sample(gw(d + 3u + ry.i), u2);
    let pdf = ry.p * rx.p * f32(w * h);
    return Sample2D(
        vec2<f32>((f32(rx.i) + rx.rem) / f32(w), (f32(ry.i) + ry.rem) / f32(h)),
        pdf,
    );
}

fn dist2_pdf_cell(d: u32, x: u32, y: u32) -> f32 {
    let w = gw(d);
    let h = gw(d + 1u);
    return dist_pmf(gw(d + 2u), y) * dist_pmf(gw(d + 3u + y), x) * f32(w * h);
}

// ---------------------------------------------------------------------------------------------
// env.rs. Constant: rgb. Map: width, height, rotate, texels (offset), dist2 (offset).

fn dir_to_uv(d: vec3<f32>) -> vec2<f32> {
    var u = 0.5 + atan2(d.x, -d.z) * (0.5 / PI);
    if (u >= 1.0) {
        u -= 1.0;
    }
    if (u < 0.0) {
        u += 1.0;
    }
    let v = acos(fclamp(d.y, -1.0, 1.0)) * (1.0 / PI);
    return vec2<f32>(u, v);
}

fn uv_to_dir(u: f32, v: f32) -> vec3<f32> {
    let theta = PI * v;
    let phi = 2.0 * PI * (u - 0.5);
    let st = sin(theta);
    return vec3<f32>(st * sin(phi), cos(theta), -st * cos(phi));
}

fn rot_y(d: vec3<f32>, angle: f32) -> vec3<f32> {
    let s = sin(angle);
    let c = cos(angle);
    return vec3<f32>(c * d.x + s * d.z, d.y, c * d.z - s * d.x);
}

fn env_texel(e: u32, uv: vec2<f32>) -> vec2<u32> {
    let w = gw(e);
    let h = gw(e + 1u);
    let x = min(u32(uv.x * f32(w)), w - 1u);
    let y = min(u32(uv.y * f32(h)), h - 1u);
    return vec2<u32>(x, y);
}

fn env_eval(dir: vec3<f32>) -> vec3<f32> {
    let kind = hdr(H_ENV_KIND);
    let e = hdr(H_ENV);
    if (kind == 1u) {
        return v3(e);
    }
    let uv = dir_to_uv(rot_y(dir, -gf(e + 2u)));
    let xy = env_texel(e, uv);
    return v3(gw(e + 3u) + 3u * (xy.y * gw(e) + xy.x));
}

fn env_pdf(dir: vec3<f32>) -> f32 {
    let kind = hdr(H_ENV_KIND);
    let e = hdr(H_ENV);
    if (kind == 1u) {
        return 1.0 / (4.0 * PI);
    }
    let uv = dir_to_uv(rot_y(dir, -gf(e + 2u)));
    let xy = env_texel(e, uv);
    let st = sin(PI * uv.y);
    if (st <= 0.0) {
        return 0.0;
    }
    return dist2_pdf_cell(gw(e + 4u), xy.x, xy.y) / (2.0 * PI * PI * st);
}

struct EnvSample {
    wi: vec3<f32>,
    li: vec3<f32>,
    pdf: f32,
}

fn env_sample(u1: f32, u2: f32) -> EnvSample {
    let kind = hdr(H_ENV_KIND);
    let e = hdr(H_ENV);
    if (kind == 1u) {
        return EnvSample(uniform_sphere(u1, u2), v3(e), 1.0 / (4.0 * PI));
    }
    let s = dist2_sample(gw(e + 4u), u1, u2);
    let d = rot_y(uv_to_dir(s.uv.x, s.uv.y), gf(e + 2u));
    return EnvSample(d, env_eval(d), env_pdf(d));
}

// ---------------------------------------------------------------------------------------------
// material.rs. Material at word m (12 words): kind, then parameters.

const M_DIFFUSE: u32 = 0u;
const M_CONDUCTOR: u32 = 1u;
const M_SCHLICK: u32 = 2u;
const M_DIELECTRIC: u32 = 3u;
const M_EMISSIVE: u32 = 4u;

fn mat_kind(m: u32) -> u32 {
    return gw(m);
}

fn mat_alpha(m: u32) -> f32 {
    return gf(m + 7u);
}

fn mat_is_delta(m: u32) -> bool {
    let k = mat_kind(m);
    return (k == M_CONDUCTOR || k == M_SCHLICK || k == M_DIELECTRIC) && mat_alpha(m) < DELTA_ALPHA;
}

fn reflect3(w: vec3<f32>, m: vec3<f32>) -> vec3<f32> {
    return m * (2.0 * dot3(w, m)) - w;
}

struct Refracted {
    ok: bool,
    w: vec3<f32>,
}

fn refract3(w: vec3<f32>, m: vec3<f32>, etap: f32) -> Refracted {
    let cos_i = dot3(w, m);
    let sin2_i = fmax(1.0 - cos_i * cos_i, 0.0);
    let sin2_t = sin2_i / (etap * etap);
    if (sin2_t >= 1.0) {
        return Refracted(false, vec3<f32>(0.0));
    }
    let cos_t = sqrt(1.0 - sin2_t);
    return Refracted(true, -w / etap + m * (cos_i / etap - cos_t));
}

fn fresnel_dielectric(cos_i: f32, etap: f32) -> f32 {
    let c = fclamp(cos_i, 0.0, 1.0);
    let sin2_t = (1.0 - c * c) / (etap * etap);
    if (sin2_t >= 1.0) {
        return 1.0;
    }
    let cos_t = sqrt(1.0 - sin2_t);
    let r_par = (etap * c - cos_t) / (etap * c + cos_t);
    let r_perp = (c - etap * cos_t) / (c + etap * cos_t);
    return 0.5 * (r_par * r_par + r_perp * r_perp);
}

fn fresnel_conductor(cos_i: f32, eta: f32, k: f32) -> f32 {
    let c = fclamp(cos_i, 0.0, 1.0);
    let c2 = c * c;
    let s2 = 1.0 - c2;
    let eta2 = eta * eta;
    let k2 = k * k;
    let t0 = eta2 - k2 - s2;
    let a2b2 = sqrt(fmax(t0 * t0 + 4.0 * eta2 * k2, 0.0));
    let t1 = a2b2 + c2;
    let a = sqrt(fmax(0.5 * (a2b2 + t0), 0.0));
    let t2 = 2.0 * c * a;
    let rs = (t1 - t2) / (t1 + t2);
    let t3 = c2 * a2b2 + s2 * s2;
    let t4 = t2 * s2;
    let rp = rs * (t3 - t4) / (t3 + t4);
    return fclamp(0.5 * (rp + rs), 0.0, 1.0);
}

fn fresnel_eval(m: u32, cos_i: f32) -> vec3<f32> {
    if (mat_kind(m) == M_CONDUCTOR) {
        let eta = v3(m + 1u);
        let k = v3(m + 4u);
        return vec3<f32>(
            fresnel_conductor(cos_i, eta.x, k.x),
            fresnel_conductor(cos_i, eta.y, k.y),
            fresnel_conductor(cos_i, eta.z, k.z),
        );
    }
    let f0 = v3(m + 1u);
    let mm = fclamp(1.0 - cos_i, 0.0, 1.0);
    let m2 = mm * mm;
    let m5 = m2 * m2 * mm;
    return f0 + (vec3<f32>(1.0) - f0) * m5;
}

fn mat_albedo(m: u32) -> vec3<f32> {
    let k = mat_kind(m);
    if (k == M_DIFFUSE) {
        return v3(m + 1u);
    }
    if (k == M_CONDUCTOR || k == M_SCHLICK) {
        return fresnel_eval(m, 1.0);
    }
    if (k == M_DIELECTRIC) {
        return vec3<f32>(1.0);
    }
    return vec3<f32>(0.0);
}

fn ggx_d(m: vec3<f32>, alpha: f32) -> f32 {
    if (m.z <= 0.0) {
        return 0.0;
    }
    let a2 = alpha * alpha;
    let t = m.z * m.z * (a2 - 1.0) + 1.0;
    return a2 / (PI * t * t);
}

fn ggx_lambda(w: vec3<f32>, alpha: f32) -> f32 {
    let c2 = w.z * w.z;
    if (c2 <= 0.0) {
        return inf();
    }
    let s2 = fmax(1.0 - c2, 0.0);
    let tan2 = s2 / c2;
    return 0.5 * (sqrt(1.0 + alpha * alpha * tan2) - 1.0);
}

fn ggx_g1(w: vec3<f32>, alpha: f32) -> f32 {
    return 1.0 / (1.0 + ggx_lambda(w, alpha));
}

fn ggx_g2(wo: vec3<f32>, wi: vec3<f32>, alpha: f32) -> f32 {
    return 1.0 / (1.0 + ggx_lambda(wo, alpha) + ggx_lambda(wi, alpha));
}

fn vndf_pdf(wo: vec3<f32>, m: vec3<f32>, alpha: f32) -> f32 {
    if (wo.z <= 0.0) {
        return 0.0;
    }
    return ggx_g1(wo, alpha) * fmax(dot3(wo, m), 0.0) * ggx_d(m, alpha) / wo.z;
}

fn vndf_sample(wo: vec3<f32>, alpha: f32, u1: f32, u2: f32) -> vec3<f32> {
    let vh = normalize3(vec3<f32>(alpha * wo.x, alpha * wo.y, wo.z));
    let lensq = vh.x * vh.x + vh.y * vh.y;
    var t1 = vec3<f32>(1.0, 0.0, 0.0);
    if (lensq > 0.0) {
        t1 = vec3<f32>(-vh.y, vh.x, 0.0) * (1.0 / sqrt(lensq));
    }
    let t2 = cross3(vh, t1);
    let r = sqrt(u1);
    let phi = 2.0 * PI * u2;
    let p1 = r * cos(phi);
    let p2a = r * sin(phi);
    let s = 0.5 * (1.0 + vh.z);
    let p2 = (1.0 - s) * sqrt(fmax(1.0 - p1 * p1, 0.0)) + s * p2a;
    let pz = sqrt(fmax(1.0 - p1 * p1 - p2 * p2, 0.0));
    let nh = (t1 * p1 + t2 * p2) + vh * pz;
    return normalize3(vec3<f32>(alpha * nh.x, alpha * nh.y, fmax(nh.z, 1e-7)));
}

struct Eval {
    f: vec3<f32>,
    pdf: f32,
}

fn rough_dielectric_eval(wo: vec3<f32>, wi: vec3<f32>, etap: f32, alpha: f32) -> Eval {
    let zero = Eval(vec3<f32>(0.0), 0.0);
    if (wi.z > 0.0) {
        let m = normalize3(wo + wi);
        let wom = dot3(wo, m);
        if (wom <= 0.0) {
            return zero;
        }
        let f = fresnel_dielectric(wom, etap);
        let val = ggx_d(m, alpha) * ggx_g2(wo, wi, alpha) * f / (4.0 * wo.z * wi.z);
        let pdf = vndf_pdf(wo, m, alpha) / (4.0 * wom) * f;
        return Eval(vec3<f32>(val), pdf);
    }
    if (wi.z == 0.0) {
        return zero;
    }
    let h = wi * etap + wo;
    if (dot3(h, h) <= 0.0) {
        return zero;
    }
    var m = normalize3(h);
    if (m.z < 0.0) {
        m = -m;
    }
    let wom = dot3(wo, m);
    let wim = dot3(wi, m);
    if (wom <= 0.0 || wim >= 0.0) {
        return zero;
    }
    let f = fresnel_dielectric(wom, etap);
    let s = wim + wom / etap;
    let denom = s * s;
    if (denom <= 0.0) {
        return zero;
    }
    let val = ggx_d(m, alpha) * ggx_g2(wo, wi, alpha) * (1.0 - f)
        * abs(wim * wom / (wi.z * wo.z * denom)) / (etap * etap);
    let pdf = vndf_pdf(wo, m, alpha) * (1.0 - f) * abs(wim) / denom;
    return Eval(vec3<f32>(val), pdf);
}

fn mat_eval(m: u32, wo: vec3<f32>, wi: vec3<f32>, etap: f32) -> Eval {
    let zero = Eval(vec3<f32>(0.0), 0.0);
    if (wo.z <= 0.0) {
        return zero;
    }
    let k = mat_kind(m);
    if (k == M_DIFFUSE) {
        if (wi.z <= 0.0) {
            return zero;
        }
        return Eval(v3(m + 1u) * (1.0 / PI), wi.z * (1.0 / PI));
    }
    if (k == M_CONDUCTOR || k == M_SCHLICK) {
        let alpha = mat_alpha(m);
        if (alpha < DELTA_ALPHA || wi.z <= 0.0) {
            return zero;
        }
        let h = wo + wi;
        if (dot3(h, h) <= 0.0) {
            return zero;
        }
        let mm = normalize3(h);
        let wom = fmax(dot3(wo, mm), 0.0);
        let d = ggx_d(mm, alpha);
        let g = ggx_g2(wo, wi, alpha);
        let f = fresnel_eval(m, wom) * (d * g / (4.0 * wo.z * wi.z));
        var pdf = 0.0;
        if (wom > 0.0) {
            pdf = vndf_pdf(wo, mm, alpha) / (4.0 * wom);
        }
        return Eval(f, pdf);
    }
    if (k == M_DIELECTRIC) {
        let alpha = mat_alpha(m);
        if (alpha < DELTA_ALPHA) {
            return zero;
        }
        return rough_dielectric_eval(wo, wi, etap, alpha);
    }
    return zero;
}

struct BsdfSample {
    ok: bool,
    wi: vec3<f32>,
    weight: vec3<f32>,
    pdf: f32,
    delta: bool,
}

fn no_sample() -> BsdfSample {
    return BsdfSample(false, vec3<f32>(0.0), vec3<f32>(0.0), 0.0, false);
}

fn rough_dielectric_sample(wo: vec3<f32>, etap: f32, alpha: f32, u_lobe: f32, u1: f32, u2: f32) -> BsdfSample {
    let m = vndf_sample(wo, alpha, u1, u2);
    let wom = dot3(wo, m);
    if (wom <= 0.0) {
        return no_sample();
    }
    let f = fresnel_dielectric(wom, etap);
    let g1 = ggx_g1(wo, alpha);
    let pm = vndf_pdf(wo, m, alpha);
    if (u_lobe < f) {
        let wi = reflect3(wo, m);
        if (wi.z <= 0.0) {
            return no_sample();
        }
        let w = ggx_g2(wo, wi, alpha) / g1;
        return BsdfSample(true, wi, vec3<f32>(w), pm / (4.0 * wom) * f, false);
    }
    let rr = refract3(wo, m, etap);
    if (!rr.ok) {
        return no_sample();
    }
    let wi = rr.w;
    if (wi.z >= 0.0) {
        return no_sample();
    }
    let wim = dot3(wi, m);
    let s = wim + wom / etap;
    let denom = s * s;
    if (denom <= 0.0) {
        return no_sample();
    }
    let w = ggx_g2(wo, wi, alpha) / g1 / (etap * etap);
    return BsdfSample(true, wi, vec3<f32>(w), pm * (1.0 - f) * abs(wim) / denom, false);
}

fn mat_sample(m: u32, wo: vec3<f32>, etap: f32, u_lobe: f32, u1: f32, u2: f32) -> BsdfSample {
    if (wo.z <= 0.0) {
        return no_sample();
    }
    let k = mat_kind(m);
    if (k == M_DIFFUSE) {
        let wi = cosine_hemisphere(u1, u2);
        if (wi.z <= 0.0) {
            return no_sample();
        }
        return BsdfSample(true, wi, v3(m + 1u), wi.z * (1.0 / PI), false);
    }
    if (k == M_CONDUCTOR || k == M_SCHLICK) {
        let alpha = mat_alpha(m);
        if (alpha < DELTA_ALPHA) {
            return BsdfSample(true, vec3<f32>(-wo.x, -wo.y, wo.z), fresnel_eval(m, wo.z), 0.0, true);
        }
        let mm = vndf_sample(wo, alpha, u1, u2);
        let wom = dot3(wo, mm);
        if (wom <= 0.0) {
            return no_sample();
        }
        let wi = reflect3(wo, mm);
        if (wi.z <= 0.0) {
            return no_sample();
        }
        let g1 = ggx_g1(wo, alpha);
        let weight = fresnel_eval(m, wom) * (ggx_g2(wo, wi, alpha) / g1);
        return BsdfSample(true, wi, weight, vndf_pdf(wo, mm, alpha) / (4.0 * wom), false);
    }
    if (k == M_DIELECTRIC) {
        let alpha = mat_alpha(m);
        if (alpha < DELTA_ALPHA) {
            let f = fresnel_dielectric(wo.z, etap);
            if (u_lobe < f) {
                return BsdfSample(true, vec3<f32>(-wo.x, -wo.y, wo.z), vec3<f32>(1.0), 0.0, true);
            }
            let rr = refract3(wo, vec3<f32>(0.0, 0.0, 1.0), etap);
            if (!rr.ok) {
                return no_sample();
            }
            return BsdfSample(true, rr.w, vec3<f32>(1.0 / (etap * etap)), 0.0, true);
        }
        return rough_dielectric_sample(wo, etap, alpha, u_lobe, u1, u2);
    }
    return no_sample();
}

// ---------------------------------------------------------------------------------------------
// light.rs. Quad (16 words): corner, edge1, edge2, normal, area, radiance.
// Mesh light (8 words): instance, area, radiance, triangle count, triangles (offset; 9 f32
// each, world space), distribution (offset).

fn quad_intersect(q: u32, o: vec3<f32>, d: vec3<f32>, tmax: f32) -> f32 {
    let corner = v3(q);
    let e1 = v3(q + 3u);
    let e2 = v3(q + 6u);
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
        let t = quad_intersect(base + 16u * i, o, d, tm);
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
    if (hdr(H_ENV_KIND) == 0u) {
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
        let q = hdr(H_QUADS) + 16u * s.i;
        let normal = v3(q + 9u);
        let point = (v3(q) + v3(q + 3u) * u1) + v3(q + 6u) * u2;
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
        let pdf = s.p * dist * dist / (cos_l * gf(q + 12u));
        return LightSample(true, wi, point, normal, dist, v3(q + 13u), pdf);
    }
    if (s.i < nq + nm) {
        let ml = hdr(H_MESHL) + 8u * (s.i - nq);
        let ts = dist_sample(gw(ml + 7u), u1);
        let tri = gw(ml + 6u) + 9u * ts.i;
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
        let pdf = s.p * dist * dist / (cos_l * gf(ml + 1u));
        return LightSample(true, wi, point, normal, dist, v3(ml + 2u), pdf);
    }
    if (hdr(H_ENV_KIND) == 0u) {
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
}

// The world-space hit record (SceneBvh::hit_record and World::hit_point).
fn surface(h: SceneResult) -> SurfaceHit {
    let ib = P.inst_off + 16u * h.inst;
    let m = gw(ib);
    let rec = P.mesh_off + 8u * m;
    let v = gw(rec + 2u) + 9u * h.leaf;
    let a = v3(v);
    let b = v3(v + 3u);
    let c = v3(v + 6u);
    let b0 = 1.0 - h.b1 - h.b2;
    let e1 = b - a;
    let e2 = c - a;
    let ng = normalize_div(vec3<f32>(
        e1.y * e2.z - e1.z * e2.y,
        e1.z * e2.x - e1.x * e2.z,
        e1.x * e2.y - e1.y * e2.x,
    ));
    let nb = gw(hdr(H_MESH_EXTRA) + 4u * m) + 9u * h.leaf;
    let n0 = v3(nb);
    let n1 = v3(nb + 3u);
    let n2 = v3(nb + 6u);
    var ns = normalize_div((b0 * n0 + h.b1 * n1) + h.b2 * n2);
    if (!finite3(ns)) {
        ns = ng;
    }
    let xf = hdr(H_INST_XF) + 24u * h.inst;
    let p = mat3_mul(xf, (a * (1.0 - h.b1 - h.b2) + b * h.b1) + c * h.b2) + v3(xf + 9u);
    return SurfaceHit(
        h.inst,
        h.t,
        p,
        normalize_div(mat3_mul(xf + 12u, ng)),
        normalize_div(mat3_mul(xf + 12u, ns)),
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
    for (var bounce = 0u; bounce <= max_depth; bounce++) {
        let mh = intersect_world(o, d, 0.0, inf(), false);
        var tmax = inf();
        if (mh.hit) {
            tmax = mh.t;
        }
        let qh = intersect_quads(o, d, tmax);
        if (!mh.hit && !qh.hit) {
            if (hdr(H_ENV_KIND) != 0u) {
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
            let q = hdr(H_QUADS) + 16u * qh.i;
            let cos_l = -dot3(d, v3(q + 9u));
            if (cos_l > 0.0) {
                var w = 1.0;
                if (!prev_delta) {
                    w = power_heuristic(prev_pdf, pdf_area_light(qh.i, gf(q + 12u), qh.t, cos_l));
                }
                l += beta * v3(q + 13u) * w;
            }
            break;
        }
        let h = surface(mh);
        let mat = hdr(H_MAT) + 12u * gw(hdr(H_INST_MAT) + h.inst);
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
                let ml = hdr(H_MESHL) + 8u * li;
                w = power_heuristic(prev_pdf, pdf_area_light(nq + li, gf(ml + 1u), h.t, cos_l));
            }
            l += beta * v3(mat + 1u) * w;
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
            let ior = gf(mat + 1u);
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
    let position = v3(c);
    let forward = v3(c + 3u);
    let right = v3(c + 6u);
    let up = v3(c + 9u);
    let tan_half = gf(c + 12u);
    let aperture = gf(c + 13u);
    let focus_distance = gf(c + 14u);
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
@compute @workgroup_size(64)
fn path_main(@builtin(global_invocation_id) gid: vec3<u32>) {
    if (gid.x >= P.ray_count) {
        return;
    }
    let pixel = P.user0 + gid.x;
    let width = hdr(H_WIDTH);
    let x = pixel % width;
    let y = pixel / width;
    let seed = hdr(H_SEED);
    let a = ACC * gid.x;
    var sum = vec3<f32>(acc[a], acc[a + 1u], acc[a + 2u]);
    var alpha = acc[a + 3u];
    var normal = vec3<f32>(acc[a + 4u], acc[a + 5u], acc[a + 6u]);
    var albedo = vec3<f32>(acc[a + 7u], acc[a + 8u], acc[a + 9u]);
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
    acc[a] = sum.x;
    acc[a + 1u] = sum.y;
    acc[a + 2u] = sum.z;
    acc[a + 3u] = alpha;
    acc[a + 4u] = normal.x;
    acc[a + 5u] = normal.y;
    acc[a + 6u] = normal.z;
    acc[a + 7u] = albedo.x;
    acc[a + 8u] = albedo.y;
    acc[a + 9u] = albedo.z;
    acc[a + 10u] = select(acc[a + 10u], 1.0, overflow);
}

// The centre ray of each pixel of the dispatch (the AOV ray): status (0 miss, 1 mesh hit,
// 2 overflow, 3 a quad light in front), instance, leaf, t, b1, b2 (bits), 8 words per pixel.
@compute @workgroup_size(64)
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
    var status = select(0u, 1u, h.hit);
    var tmax = inf();
    if (h.hit) {
        tmax = h.t;
    }
    if (intersect_quads(r.o, r.d, tmax).hit) {
        status = 3u;
    }
    if (overflow) {
        status = 2u;
    }
    let a = 8u * gid.x;
    prim[a] = status;
    prim[a + 1u] = h.inst;
    prim[a + 2u] = h.leaf;
    prim[a + 3u] = bitcast<u32>(h.t);
    prim[a + 4u] = bitcast<u32>(h.b1);
    prim[a + 5u] = bitcast<u32>(h.b2);
}
