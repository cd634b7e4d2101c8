// Sampling for the GPU path tracer (kernels/path.wgsl): glam's Vec3 arithmetic in its order,
// the counter-based RNG (src/render/rng.rs), warps and distributions (sampling.rs) and the
// environment (env.rs). Needs bvh.wgsl and path.wgsl in the same module.

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

// Distribution1D at word d: n (DIST_N), total, cdf[n + 1] (from DIST_CDF), pmf[n].
struct Sample1D {
    i: u32,
    p: f32,
    rem: f32,
}

fn dist_n(d: u32) -> u32 {
    return gw(d + DIST_N);
}

fn dist_pmf(d: u32, i: u32) -> f32 {
    return gf(d + DIST_CDF + 1u + dist_n(d) + i);
}

fn dist_sample(d: u32, u: f32) -> Sample1D {
    let n = dist_n(d);
    let cdf = d + DIST_CDF;
    let pmf = cdf + n + 1u;
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

// Distribution2D at word d (DIST2_*): width, height, rows (offset), cols offsets[height].
struct Sample2D {
    uv: vec2<f32>,
    pdf: f32,
}

fn dist2_sample(d: u32, u1: f32, u2: f32) -> Sample2D {
    let w = gw(d + DIST2_WIDTH);
    let h = gw(d + DIST2_HEIGHT);
    let ry = dist_sample(gw(d + DIST2_ROWS), u1);
    let rx = dist_sample(gw(d + DIST2_COLS + ry.i), u2);
    let pdf = ry.p * rx.p * f32(w * h);
    return Sample2D(
        vec2<f32>((f32(rx.i) + rx.rem) / f32(w), (f32(ry.i) + ry.rem) / f32(h)),
        pdf,
    );
}

fn dist2_pdf_cell(d: u32, x: u32, y: u32) -> f32 {
    let w = gw(d + DIST2_WIDTH);
    let h = gw(d + DIST2_HEIGHT);
    return dist_pmf(gw(d + DIST2_ROWS), y) * dist_pmf(gw(d + DIST2_COLS + y), x) * f32(w * h);
}

// ---------------------------------------------------------------------------------------------
// env.rs. ENV_CONSTANT: rgb. ENV_MAP: an ENV_MAP_WORDS record (ENV_*).

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
    let w = gw(e + ENV_WIDTH);
    let h = gw(e + ENV_HEIGHT);
    let x = min(u32(uv.x * f32(w)), w - 1u);
    let y = min(u32(uv.y * f32(h)), h - 1u);
    return vec2<u32>(x, y);
}

fn env_eval(dir: vec3<f32>) -> vec3<f32> {
    let kind = hdr(H_ENV_KIND);
    let e = hdr(H_ENV);
    if (kind == ENV_CONSTANT) {
        return v3(e);
    }
    let uv = dir_to_uv(rot_y(dir, -gf(e + ENV_ROTATE)));
    let xy = env_texel(e, uv);
    return v3(gw(e + ENV_TEXELS) + 3u * (xy.y * gw(e + ENV_WIDTH) + xy.x));
}

fn env_pdf(dir: vec3<f32>) -> f32 {
    let kind = hdr(H_ENV_KIND);
    let e = hdr(H_ENV);
    if (kind == ENV_CONSTANT) {
        return 1.0 / (4.0 * PI);
    }
    let uv = dir_to_uv(rot_y(dir, -gf(e + ENV_ROTATE)));
    let xy = env_texel(e, uv);
    let st = sin(PI * uv.y);
    if (st <= 0.0) {
        return 0.0;
    }
    return dist2_pdf_cell(gw(e + ENV_DIST), xy.x, xy.y) / (2.0 * PI * PI * st);
}

struct EnvSample {
    wi: vec3<f32>,
    li: vec3<f32>,
    pdf: f32,
}

fn env_sample(u1: f32, u2: f32) -> EnvSample {
    let kind = hdr(H_ENV_KIND);
    let e = hdr(H_ENV);
    if (kind == ENV_CONSTANT) {
        return EnvSample(uniform_sphere(u1, u2), v3(e), 1.0 / (4.0 * PI));
    }
    let s = dist2_sample(gw(e + ENV_DIST), u1, u2);
    let d = rot_y(uv_to_dir(s.uv.x, s.uv.y), gf(e + ENV_ROTATE));
    return EnvSample(d, env_eval(d), env_pdf(d));
}

