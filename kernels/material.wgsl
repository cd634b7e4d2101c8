// Materials of the GPU path tracer (src/render/material.rs): diffuse, GGX conductor (complex
// IOR or Schlick), smooth and rough dielectric, emissive. Needs sampling.wgsl, texture.wgsl
// and path.wgsl.

// ---------------------------------------------------------------------------------------------
// material.rs. A material record at word m (MAT_WORDS words): kind (M_*), parameters (MAT_*)
// and its maps; loaded into a Mat with its maps applied at the hit (texturing.rs).

struct Mat {
    kind: u32,
    // Albedo, eta, f0 or radiance; the IOR in x for a dielectric.
    color: vec3<f32>,
    // Conductor k.
    k: vec3<f32>,
    alpha: f32,
}

fn mat_load(m: u32) -> Mat {
    return Mat(gw(m + MAT_KIND), v3(m + MAT_COLOR), v3(m + MAT_K), gf(m + MAT_ALPHA));
}

fn mat_kind(m: Mat) -> u32 {
    return m.kind;
}

fn mat_alpha(m: Mat) -> f32 {
    return m.alpha;
}

// Where a material's maps are read (texturing.rs Lookup): texture coordinates, the
// object-space point and the filter width in texture units.
struct TexLookup {
    st: vec2<f32>,
    p: vec3<f32>,
    footprint: f32,
}

// MaterialTextures::apply: the material at word m with its maps read at `at`.
fn mat_textured(m: u32, at: TexLookup) -> Mat {
    var mat = mat_load(m);
    let albedo = gw(m + MAT_ALBEDO_MAP);
    let roughness = gw(m + MAT_ROUGHNESS_MAP);
    let emission = gw(m + MAT_EMISSION_MAP);
    if (mat.kind == M_DIFFUSE && albedo != NONE) {
        let c = mat.color * texture_rgb(albedo, at.st, at.p, at.footprint);
        mat.color = clamp(c, vec3<f32>(0.0), vec3<f32>(1.0));
    }
    if ((mat.kind == M_CONDUCTOR || mat.kind == M_SCHLICK || mat.kind == M_DIELECTRIC)
        && roughness != NONE) {
        let r = fclamp(texture_scalar(roughness, at.st, at.p, at.footprint), 0.0, 1.0);
        mat.alpha = r * r;
    }
    if (mat.kind == M_EMISSIVE && emission != NONE) {
        let c = texture_rgb(emission, at.st, at.p, at.footprint);
        mat.color = mat.color * max(c, vec3<f32>(0.0));
    }
    return mat;
}

// Whether the material at word m has a map.
fn mat_has_maps(m: u32) -> bool {
    return gw(m + MAT_ALBEDO_MAP) != NONE || gw(m + MAT_ROUGHNESS_MAP) != NONE
        || gw(m + MAT_EMISSION_MAP) != NONE;
}

fn mat_is_delta(m: Mat) -> bool {
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

fn fresnel_eval(m: Mat, cos_i: f32) -> vec3<f32> {
    if (mat_kind(m) == M_CONDUCTOR) {
        let eta = m.color;
        let k = m.k;
        return vec3<f32>(
            fresnel_conductor(cos_i, eta.x, k.x),
            fresnel_conductor(cos_i, eta.y, k.y),
            fresnel_conductor(cos_i, eta.z, k.z),
        );
    }
    let f0 = m.color;
    let mm = fclamp(1.0 - cos_i, 0.0, 1.0);
    let m2 = mm * mm;
    let m5 = m2 * m2 * mm;
    return f0 + (vec3<f32>(1.0) - f0) * m5;
}

fn mat_albedo(m: Mat) -> vec3<f32> {
    let k = mat_kind(m);
    if (k == M_DIFFUSE) {
        return m.color;
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

fn mat_eval(m: Mat, wo: vec3<f32>, wi: vec3<f32>, etap: f32) -> Eval {
    let zero = Eval(vec3<f32>(0.0), 0.0);
    if (wo.z <= 0.0) {
        return zero;
    }
    let k = mat_kind(m);
    if (k == M_DIFFUSE) {
        if (wi.z <= 0.0) {
            return zero;
        }
        return Eval(m.color * (1.0 / PI), wi.z * (1.0 / PI));
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

fn mat_sample(m: Mat, wo: vec3<f32>, etap: f32, u_lobe: f32, u1: f32, u2: f32) -> BsdfSample {
    if (wo.z <= 0.0) {
        return no_sample();
    }
    let k = mat_kind(m);
    if (k == M_DIFFUSE) {
        let wi = cosine_hemisphere(u1, u2);
        if (wi.z <= 0.0) {
            return no_sample();
        }
        return BsdfSample(true, wi, m.color, wi.z * (1.0 / PI), false);
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

