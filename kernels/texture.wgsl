// Texture maps of the GPU path tracer (src/texture/mod.rs, src/texture/noise.rs,
// src/texture/image.rs, src/render/texturing.rs): procedural noise of the object-space point
// and trilinear lookups in the CPU's own mip pyramids, records packed by src/gpu/texture.rs.
// Needs bvh.wgsl (gw, gf, finite) in the same module.

// ---------------------------------------------------------------------------------------------
// noise.rs. The lattice hash is 64-bit integer arithmetic, emulated on (lo, hi) word pairs,
// so each lattice point gets the CPU's gradient; the blend is in f32 (the CPU's in f64).

// High word of a 32 × 32-bit product, from 16-bit halves.
fn mul_hi32(a: u32, b: u32) -> u32 {
    let al = a & 0xffffu;
    let ah = a >> 16u;
    let bl = b & 0xffffu;
    let bh = b >> 16u;
    let p0 = al * bl;
    let p1 = al * bh;
    let p2 = ah * bl;
    let mid = (p0 >> 16u) + (p1 & 0xffffu) + (p2 & 0xffffu);
    return ah * bh + (p1 >> 16u) + (p2 >> 16u) + (mid >> 16u);
}

// Low 64 bits of a 64 × 64-bit product (u64::wrapping_mul).
fn mul64(a: vec2<u32>, b: vec2<u32>) -> vec2<u32> {
    return vec2<u32>(a.x * b.x, mul_hi32(a.x, b.x) + a.x * b.y + a.y * b.x);
}

// `a >> s` for 0 < s < 32.
fn shr64(a: vec2<u32>, s: u32) -> vec2<u32> {
    return vec2<u32>((a.x >> s) | (a.y << (32u - s)), a.y >> s);
}

// An i32 sign-extended to 64 bits (`x as i64 as u64`).
fn wide(x: i32) -> vec2<u32> {
    return vec2<u32>(bitcast<u32>(x), select(0u, 0xffffffffu, x < 0));
}

// The gradient of lattice point (x, y, z): one of the 12 cube-edge midpoints, chosen by the
// CPU's hash; index r: (±1, ±1, 0) for r < 4, (±1, 0, ±1) for r < 8, (0, ±1, ±1) after,
// bit 0 the first sign and bit 1 the second.
fn noise_gradient(x: i32, y: i32, z: i32) -> vec3<f32> {
    var h = mul64(wide(x), vec2<u32>(0x7f4a7c15u, 0x9e3779b9u))
        ^ mul64(wide(y), vec2<u32>(0x27d4eb4fu, 0xc2b2ae3du))
        ^ mul64(wide(z), vec2<u32>(0x9e3779f9u, 0x165667b1u));
    h = h ^ shr64(h, 31u);
    h = mul64(h, vec2<u32>(0x1ce4e5b9u, 0xbf58476du));
    h = h ^ shr64(h, 29u);
    // h mod 12 = (hi · 2³² + lo) mod 12, and 2³² mod 12 = 4.
    let r = ((h.y % 12u) * 4u + h.x % 12u) % 12u;
    let a = select(1.0, -1.0, (r & 1u) != 0u);
    let b = select(1.0, -1.0, (r & 2u) != 0u);
    let g = r >> 2u;
    if (g == 0u) {
        return vec3<f32>(a, b, 0.0);
    }
    if (g == 1u) {
        return vec3<f32>(a, 0.0, b);
    }
    return vec3<f32>(0.0, a, b);
}

// Gradient noise at p (noise::noise's value).
fn noise3(p: vec3<f32>) -> f32 {
    let cell = floor(p);
    let f = p - cell;
    let c = vec3<i32>(cell);
    let w = f * f * f * (f * (f * 6.0 - 15.0) + 10.0);
    var value = 0.0;
    for (var corner = 0u; corner < 8u; corner++) {
        let b = vec3<u32>(corner & 1u, (corner >> 1u) & 1u, (corner >> 2u) & 1u);
        let g = noise_gradient(c.x + i32(b.x), c.y + i32(b.y), c.z + i32(b.z));
        let d = f - vec3<f32>(b);
        let ramp = g.x * d.x + g.y * d.y + g.z * d.z;
        let wt = select(1.0 - w, w, b == vec3<u32>(1u));
        value += wt.x * wt.y * wt.z * ramp;
    }
    return value;
}

// ---------------------------------------------------------------------------------------------
// image.rs. A texture record at word t (TEX_*), its levels at t + TEX_LEVEL0 (LVL_*).

fn wrap01(v: f32) -> f32 {
    if (finite(v)) {
        return v - floor(v);
    }
    return 0.0;
}

fn texel(base: u32, i: u32) -> vec3<f32> {
    return vec3<f32>(gf(base + 3u * i), gf(base + 3u * i + 1u), gf(base + 3u * i + 2u));
}

// Level::bilinear: between texel centres, repeat wrapping, row 0 at the top.
fn level_bilinear(lv: u32, st: vec2<f32>) -> vec3<f32> {
    let w = gw(lv + LVL_WIDTH);
    let h = gw(lv + LVL_HEIGHT);
    let base = gw(lv + LVL_TEXELS);
    let x = wrap01(st.x) * f32(w) - 0.5;
    let y = (1.0 - wrap01(st.y)) * f32(h) - 0.5;
    let x0 = floor(x);
    let y0 = floor(y);
    let fx = x - x0;
    let fy = y - y0;
    var i0 = w - 1u;
    if (x0 >= 0.0) {
        i0 = min(u32(x0), w - 1u);
    }
    var j0 = h - 1u;
    if (y0 >= 0.0) {
        j0 = min(u32(y0), h - 1u);
    }
    let i1 = select(i0 + 1u, 0u, i0 + 1u == w);
    let j1 = select(j0 + 1u, 0u, j0 + 1u == h);
    let a = texel(base, j0 * w + i0);
    let b = texel(base, j0 * w + i1);
    let c = texel(base, j1 * w + i0);
    let d = texel(base, j1 * w + i1);
    let top = a + (b - a) * fx;
    let bottom = c + (d - c) * fx;
    return top + (bottom - top) * fy;
}

// ImageTexture::lookup: trilinear between the two levels around
// λ = log2(footprint · max(width, height)); a footprint that is not positive and finite, or
// λ ≤ 0, reads level 0.
fn image_lookup(t: u32, st: vec2<f32>, footprint: f32) -> vec3<f32> {
    let n = gw(t + TEX_LEVELS);
    let l0 = t + TEX_LEVEL0;
    let fb = bitcast<u32>(footprint);
    if (!(fb > 0u && fb < 0x7f800000u)) {
        return level_bilinear(l0, st);
    }
    let lambda = log2(footprint * f32(max(gw(l0 + LVL_WIDTH), gw(l0 + LVL_HEIGHT))));
    if (lambda <= 0.0) {
        return level_bilinear(l0, st);
    }
    let last = n - 1u;
    if (lambda >= f32(last)) {
        return level_bilinear(l0 + LVL_WORDS * last, st);
    }
    let lf = floor(lambda);
    let f = lambda - lf;
    let li = u32(lf);
    let a = level_bilinear(l0 + LVL_WORDS * li, st);
    if (f == 0.0) {
        return a;
    }
    let b = level_bilinear(l0 + LVL_WORDS * (li + 1u), st);
    return a + (b - a) * f;
}

// Texture::rgb: noise of the object-space point p, or the image at st.
fn texture_rgb(t: u32, st: vec2<f32>, p: vec3<f32>, footprint: f32) -> vec3<f32> {
    if (gw(t + TEX_KIND) == TEX_NOISE) {
        return vec3<f32>(0.5 + 0.5 * noise3(p * gf(t + TEX_FREQUENCY)));
    }
    return image_lookup(t, st, footprint);
}

// Texture::scalar: the mean of the channels.
fn texture_scalar(t: u32, st: vec2<f32>, p: vec3<f32>, footprint: f32) -> f32 {
    let c = texture_rgb(t, st, p, footprint);
    return (c.x + c.y + c.z) / 3.0;
}
