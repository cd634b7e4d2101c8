// Exact emulation, with integer arithmetic only, of the CPU's f64 fallback of the watertight
// triangle test (src/bvh/triangle.rs):
//
//     edge_exact(a, b, c, d) == ((a as f64) * (b as f64) - (c as f64) * (d as f64)) as f32
//
// bit for bit, for finite normal or zero f32 inputs (subnormal inputs are read exactly too, but a
// device that flushes them on the way in cannot be helped). The two products are exact 48-bit
// integers; their difference is formed exactly in 96 bits (plus a sticky bit when the exponents
// are more than 47 apart), rounded to 53 bits (ties to even: the f64 subtraction), then to f32
// (ties to even, subnormal results and overflow to infinity included: the `as f32`).

fn shl96(v: vec3<u32>, n: u32) -> vec3<u32> {
    if (n >= 96u) {
        return vec3<u32>(0u);
    }
    var x = v;
    var k = n;
    if (k >= 64u) {
        x = vec3<u32>(0u, 0u, x.x);
        k -= 64u;
    } else if (k >= 32u) {
        x = vec3<u32>(0u, x.x, x.y);
        k -= 32u;
    }
    if (k == 0u) {
        return x;
    }
    return vec3<u32>(x.x << k, (x.y << k) | (x.x >> (32u - k)), (x.z << k) | (x.y >> (32u - k)));
}

fn shr96(v: vec3<u32>, n: u32) -> vec3<u32> {
    if (n >= 96u) {
        return vec3<u32>(0u);
    }
    var x = v;
    var k = n;
    if (k >= 64u) {
        x = vec3<u32>(x.z, 0u, 0u);
        k -= 64u;
    } else if (k >= 32u) {
        x = vec3<u32>(x.y, x.z, 0u);
        k -= 32u;
    }
    if (k == 0u) {
        return x;
    }
    return vec3<u32>((x.x >> k) | (x.y << (32u - k)), (x.y >> k) | (x.z << (32u - k)), x.z >> k);
}

// True if any of the bits [0, n) of v is set.
fn low_nonzero96(v: vec3<u32>, n: u32) -> bool {
    if (n == 0u) {
        return false;
    }
    if (n >= 96u) {
        return any(v != vec3<u32>(0u));
    }
    // v minus its bits [n, 96).
    let hi = shl96(shr96(v, n), n);
    return any(v != hi);
}

fn bit96(v: vec3<u32>, n: u32) -> bool {
    if (n >= 96u) {
        return false;
    }
    let w = select(select(v.x, v.y, n >= 32u), v.z, n >= 64u);
    return ((w >> (n & 31u)) & 1u) != 0u;
}

// Index of the highest set bit; -1 for zero.
fn lead96(v: vec3<u32>) -> i32 {
    if (v.z != 0u) {
        return 64 + i32(firstLeadingBit(v.z));
    }
    if (v.y != 0u) {
        return 32 + i32(firstLeadingBit(v.y));
    }
    if (v.x != 0u) {
        return i32(firstLeadingBit(v.x));
    }
    return -1;
}

fn add96(a: vec3<u32>, b: vec3<u32>) -> vec3<u32> {
    let x = a.x + b.x;
    let c0 = select(0u, 1u, x < a.x);
    let y1 = a.y + b.y;
    let c1a = select(0u, 1u, y1 < a.y);
    let y = y1 + c0;
    let c1b = select(0u, 1u, y < y1);
    let z = a.z + b.z + c1a + c1b;
    return vec3<u32>(x, y, z);
}

// a - b for a >= b.
fn sub96(a: vec3<u32>, b: vec3<u32>) -> vec3<u32> {
    let x = a.x - b.x;
    let br0 = select(0u, 1u, a.x < b.x);
    let y1 = a.y - b.y;
    let br1a = select(0u, 1u, a.y < b.y);
    let y = y1 - br0;
    let br1b = select(0u, 1u, y1 < br0);
    let z = a.z - b.z - br1a - br1b;
    return vec3<u32>(x, y, z);
}

fn less96(a: vec3<u32>, b: vec3<u32>) -> bool {
    if (a.z != b.z) {
        return a.z < b.z;
    }
    if (a.y != b.y) {
        return a.y < b.y;
    }
    return a.x < b.x;
}

// v / 2^k rounded to nearest, ties to even; `sticky` says the exact value is a little above v.
fn round_shift96(v: vec3<u32>, k: u32, sticky: bool) -> vec3<u32> {
    if (k == 0u) {
        return v;
    }
    let r = shr96(v, k);
    let guard = bit96(v, k - 1u);
    let rest = sticky || low_nonzero96(v, k - 1u);
    if (guard && (rest || (r.x & 1u) != 0u)) {
        return add96(r, vec3<u32>(1u, 0u, 0u));
    }
    return r;
}

// |x| of an f32 as `m · 2^e` with an integer m < 2^24.
struct Unpacked {
    s: u32,
    e: i32,
    m: u32,
}

fn unpack_f32(x: f32) -> Unpacked {
    let b = bitcast<u32>(x);
    let be = (b >> 23u) & 0xffu;
    let f = b & 0x7fffffu;
    if (be == 0u) {
        return Unpacked(b >> 31u, -149, f);
    }
    return Unpacked(b >> 31u, i32(be) - 150, f | 0x800000u);
}

// The exact 48-bit product of two 24-bit integers, as (low word, high word).
fn mul24(a: u32, b: u32) -> vec2<u32> {
    let a0 = a & 0xffffu;
    let a1 = a >> 16u;
    let b0 = b & 0xffffu;
    let b1 = b >> 16u;
    let p00 = a0 * b0;
    let mid = a1 * b0 + a0 * b1;
    let p11 = a1 * b1;
    let lo = p00 + (mid << 16u);
    let carry = select(0u, 1u, lo < p00);
    return vec2<u32>(lo, p11 + (mid >> 16u) + carry);
}

fn edge_exact(a: f32, b: f32, c: f32, d: f32) -> f32 {
    let ua = unpack_f32(a);
    let ub = unpack_f32(b);
    let uc = unpack_f32(c);
    let ud = unpack_f32(d);
    // P = a·b, Q = c·d; D = P − Q = (−1)^sp |P| + (−1)^sq |Q| with sq the flipped sign of Q.
    let pm = mul24(ua.m, ub.m);
    let qm = mul24(uc.m, ud.m);
    let sp = ua.s ^ ub.s;
    let sq = (uc.s ^ ud.s) ^ 1u;
    let pz = pm.x == 0u && pm.y == 0u;
    let qz = qm.x == 0u && qm.y == 0u;
    if (pz && qz) {
        // (±0) − (±0): −0 only for (−0) − (+0).
        return bitcast<f32>(select(0u, 0x80000000u, sp == 1u && sq == 1u));
    }
    let pe = ua.e + ub.e;
    let qe = uc.e + ud.e;
    // X: the operand with the larger exponent (or the only non-zero one), placed at bit 47.
    var xm = pm;
    var xe = pe;
    var xs = sp;
    var ym = qm;
    var ye = qe;
    var ys = sq;
    if (pz || (!qz && qe > pe)) {
        xm = qm;
        xe = qe;
        xs = sq;
        ym = pm;
        ye = pe;
        ys = sp;
    }
    let x = shl96(vec3<u32>(xm.x, xm.y, 0u), 47u);
    var y = vec3<u32>(0u);
    var sticky = false;
    if (!(ym.x == 0u && ym.y == 0u)) {
        let g = xe - ye;
        let y0 = vec3<u32>(ym.x, ym.y, 0u);
        if (g <= 47) {
            y = shl96(y0, u32(47 - g));
        } else {
            let n = u32(min(g - 47, 200));
            y = shr96(y0, n);
            sticky = low_nonzero96(y0, n);
        }
    }
    var r: vec3<u32>;
    var s = xs;
    if (xs == ys) {
        r = add96(x, y);
    } else if (sticky) {
        // X − (Y + ε), 0 < ε < 1: (X − Y − 1) + (1 − ε). X > Y here (exponent gap > 47).
        r = sub96(sub96(x, y), vec3<u32>(1u, 0u, 0u));
    } else if (less96(x, y)) {
        r = sub96(y, x);
        s = ys;
    } else {
        r = sub96(x, y);
    }
    if (!sticky && all(r == vec3<u32>(0u))) {
        return 0.0; // exact cancellation of non-zero values: +0
    }
    // Round to f64 (53 bits).
    var e = xe - 47;
    let l = lead96(r);
    if (l > 52) {
        let k = u32(l - 52);
        r = round_shift96(r, k, sticky);
        e += i32(k);
    }
    // Round to f32 (24 bits, or the subnormal quantum 2^-149).
    let l2 = lead96(r);
    let k2 = max(l2 - 23, -149 - e);
    var m: u32;
    if (k2 > 0) {
        m = round_shift96(r, u32(k2), false).x;
    } else {
        m = shl96(r, u32(-k2)).x;
    }
    let q = e + k2;
    var bits: u32;
    if (m == 0u) {
        bits = 0u;
    } else if (q + 149 >= 255) {
        bits = 0x7f800000u;
    } else {
        bits = min((u32(q + 149) << 23u) + m, 0x7f800000u);
    }
    return bitcast<f32>(bits | (s << 31u));
}
