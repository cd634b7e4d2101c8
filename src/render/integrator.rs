//! The CPU path tracer: unidirectional paths with next-event estimation and multiple
//! importance sampling (power heuristic) for quad lights, emissive meshes and the environment,
//! Russian roulette after [`RR_START`] bounces, rayon over 16×16 tiles.
//!
//! Determinism: every random number comes from [`PathRng`] (a hash of seed, pixel, sample and
//! dimension), every pixel's samples are summed in sample order in `f32`, and tiles are
//! assembled in a fixed order; the image therefore does not depend on the number of threads or
//! on scheduling. Loops are bounded by `max_depth` and by the number of quad lights, as the
//! GPU kernels need.
//!
//! Path semantics: a path scatters at most `max_depth` times. Vertex `b` (0 = the camera ray's
//! hit) adds light sampled towards a light (NEE) and, through its BSDF-sampled ray, the
//! emission found by that ray; both are paths of `b + 1` scattering events. With
//! `max_depth = 0` only emitters and the environment seen directly are rendered. Because the
//! random stream of a path does not depend on `max_depth`, raising `max_depth` only ever adds
//! terms to each sample.

use super::film::{tiles, Film, PixelValue, Tile};
use super::light::LightId;
use super::material::Material;
use super::rng::{dims, PathRng};
use super::sampling::{power_heuristic, Frame};
use super::world::World;
use crate::bvh::{Ray, SceneHit};
use glam::Vec3;
use rayon::prelude::*;

/// Tile edge length in pixels.
pub const TILE: u32 = 16;
/// Russian roulette starts at this bounce.
pub const RR_START: u32 = 3;

/// Offsets `p` along `n` (unit, pointing to the side the new ray leaves on) far enough that a
/// ray from the result does not hit the surface `p` lies on: a fixed number of float steps
/// (ulps) per component, which scales with the magnitude of `p`, and a small absolute offset
/// near the origin where ulps are tiny (after Wächter and Binder, "A Fast and Robust Method
/// for Avoiding Self-Intersection", Ray Tracing Gems, 2019).
pub fn offset_origin(p: Vec3, n: Vec3) -> Vec3 {
    const ORIGIN: f32 = 1.0 / 32.0;
    const FLOAT_SCALE: f32 = 1.0 / 65536.0;
    const INT_SCALE: f32 = 256.0;
    let comp = |p: f32, n: f32| -> f32 {
        if p.abs() < ORIGIN {
            return p + FLOAT_SCALE * n;
        }
        let of = (INT_SCALE * n) as i32;
        let bits = p.to_bits() as i32;
        let moved = if p < 0.0 {
            bits.wrapping_sub(of)
        } else {
            bits.wrapping_add(of)
        };
        f32::from_bits(moved as u32)
    };
    Vec3::new(comp(p.x, n.x), comp(p.y, n.y), comp(p.z, n.z))
}

/// What the camera ray's first hit contributes to the AOVs.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct FirstHit {
    /// Shading normal facing the camera.
    pub normal: Vec3,
    /// Material albedo.
    pub albedo: Vec3,
}

/// The closest thing a ray meets.
enum Closest {
    Mesh(SceneHit),
    Quad(f32, u32),
}

/// Local shading geometry at a surface hit.
struct Shading {
    p: Vec3,
    ng: Vec3,
    frame: Frame,
    etap: f32,
}

impl World {
    fn closest(&self, o: Vec3, d: Vec3) -> Option<Closest> {
        let mesh = self.scene.intersect(&Ray::new(o.to_array(), d.to_array()));
        let tmax = mesh.map_or(f32::INFINITY, |h| h.hit.t);
        match self.lights.intersect_quads(o, d, tmax) {
            Some((t, i)) => Some(Closest::Quad(t, i)),
            None => mesh.map(Closest::Mesh),
        }
    }

    fn occluded(&self, o: Vec3, d: Vec3, tmax: f32) -> bool {
        if self.lights.intersect_quads(o, d, tmax).is_some() {
            return true;
        }
        let ray = Ray {
            origin: o.to_array(),
            dir: d.to_array(),
            tmin: 0.0,
            tmax,
        };
        self.scene.occluded(&ray)
    }

    /// World-space hit point from the triangle's corners and barycentrics (more accurate than
    /// `o + t·d` far from the origin).
    fn hit_point(&self, h: &SceneHit) -> Vec3 {
        let mesh = self.scene.mesh(self.scene.instance_mesh(h.instance));
        let [a, b, c] = mesh.corners(h.hit.leaf).map(Vec3::from);
        let (b1, b2) = (h.hit.b1, h.hit.b2);
        let p = a * (1.0 - b1 - b2) + b * b1 + c * b2;
        self.transforms[h.instance as usize].transform_point3(p)
    }

    fn shading(&self, h: &SceneHit, wo: Vec3, mat: &Material) -> Shading {
        let ng0 = Vec3::from(h.hit.ng);
        let ns0 = Vec3::from(h.hit.ns);
        let front = wo.dot(ng0) >= 0.0;
        let (ng, mut ns) = if front { (ng0, ns0) } else { (-ng0, -ns0) };
        if wo.dot(ns) <= 0.0 {
            ns = ng;
        }
        let etap = match *mat {
            Material::Dielectric { ior, .. } => {
                if front {
                    ior
                } else {
                    1.0 / ior
                }
            }
            _ => 1.0,
        };
        Shading {
            p: self.hit_point(h),
            ng,
            frame: Frame::new(ns),
            etap,
        }
    }

    /// Radiance along one camera sample's path, and its first hit.
    pub fn trace_path(&self, o: Vec3, d: Vec3, rng: &PathRng) -> (Vec3, Option<FirstHit>) {
        let max_depth = self.settings.max_depth;
        let mut l = Vec3::ZERO;
        let mut beta = Vec3::ONE;
        let mut first = None;
        let (mut o, mut d) = (o, d);
        // Density of the BSDF sample that made the current ray, and whether it was a delta lobe
        // (the camera ray counts as delta: no light sampling competes with it).
        let mut prev_pdf = 0.0f32;
        let mut prev_delta = true;
        // The path's footprint cone (texture filtering): width at the ray's origin and spread.
        let (mut cone_width, mut cone_spread) = (0.0f32, 1.0 / self.camera.pixels_per_radian());
        for bounce in 0..=max_depth {
            let Some(hit) = self.closest(o, d) else {
                if let Some(env) = &self.lights.env {
                    let le = env.eval(d);
                    let w = if prev_delta {
                        1.0
                    } else {
                        power_heuristic(prev_pdf, self.lights.pdf_env(d))
                    };
                    l += beta * le * w;
                }
                break;
            };
            let h = match hit {
                Closest::Quad(t, i) => {
                    let q = &self.lights.quads[i as usize];
                    let cos_l = -d.dot(q.normal);
                    if cos_l > 0.0 {
                        let w = if prev_delta {
                            1.0
                        } else {
                            power_heuristic(
                                prev_pdf,
                                self.lights.pdf_area_light(LightId::Quad(i), t, cos_l),
                            )
                        };
                        l += beta * q.radiance * w;
                    }
                    break;
                }
                Closest::Mesh(h) => h,
            };
            let mi = self.instance_material[h.instance as usize] as usize;
            let width = cone_width + cone_spread * h.hit.t * d.length();
            let textured;
            let mat = match &self.instance_maps[h.instance as usize] {
                Some(maps) => {
                    let (corners, uvs) = self.scene.triangle(h.instance, h.hit.leaf);
                    let at = maps.lookup(&h.hit, self.hit_point(&h), width, corners, uvs);
                    textured = self.textures[mi].apply(self.materials[mi], &at);
                    &textured
                }
                None => &self.materials[mi],
            };
            let wo = -d;
            if let Material::Emissive { radiance } = *mat {
                if bounce == 0 {
                    first = Some(FirstHit {
                        normal: facing(Vec3::from(h.hit.ns), wo),
                        albedo: mat.albedo(),
                    });
                }
                let w = match self.lights.instance_light[h.instance as usize] {
                    Some(li) if !prev_delta => {
                        let cos_l = d.dot(Vec3::from(h.hit.ng));
                        power_heuristic(
                            prev_pdf,
                            self.lights
                                .pdf_area_light(LightId::Mesh(li), h.hit.t, cos_l),
                        )
                    }
                    _ => 1.0,
                };
                l += beta * radiance * w;
                break;
            }
            let s = self.shading(&h, wo, mat);
            if bounce == 0 {
                first = Some(FirstHit {
                    normal: s.frame.n,
                    albedo: mat.albedo(),
                });
            }
            if bounce == max_depth {
                break;
            }
            let wo_l = s.frame.to_local(wo);

            // Next-event estimation.
            if !mat.is_delta() {
                let dim = |j| rng.get(dims::bounce(bounce, j));
                if let Some(ls) = self.lights.sample(
                    s.p,
                    dim(dims::LIGHT_SELECT),
                    dim(dims::LIGHT_U),
                    dim(dims::LIGHT_V),
                ) {
                    let wi_l = s.frame.to_local(ls.wi);
                    let (f, bsdf_pdf) = mat.eval(wo_l, wi_l, s.etap);
                    let geo_ok = (wi_l.z > 0.0) == (ls.wi.dot(s.ng) > 0.0);
                    if geo_ok && f.max_element() > 0.0 {
                        let origin = offset_origin(s.p, side(s.ng, ls.wi));
                        let visible = if ls.dist.is_finite() {
                            let target = if ls.normal == Vec3::ZERO {
                                ls.point
                            } else {
                                offset_origin(ls.point, ls.normal)
                            };
                            !self.occluded(origin, target - origin, 1.0 - 1e-4)
                        } else {
                            !self.occluded(origin, ls.wi, f32::INFINITY)
                        };
                        if visible {
                            let w = power_heuristic(ls.pdf, bsdf_pdf);
                            let c = beta * f * ls.li * (wi_l.z.abs() * w / ls.pdf);
                            if c.is_finite() {
                                l += c;
                            }
                        }
                    }
                }
            }

            // Continue the path by BSDF sampling.
            let dim = |j| rng.get(dims::bounce(bounce, j));
            let Some(bs) = mat.sample(
                wo_l,
                s.etap,
                dim(dims::BSDF_LOBE),
                dim(dims::BSDF_U),
                dim(dims::BSDF_V),
            ) else {
                break;
            };
            let wi = s.frame.to_world(bs.wi);
            if (bs.wi.z > 0.0) != (wi.dot(s.ng) > 0.0) {
                break;
            }
            beta *= bs.weight;
            if !beta.is_finite() || beta.max_element() <= 0.0 {
                break;
            }
            if bounce + 1 >= RR_START {
                let p = beta.max_element().min(1.0);
                if dim(dims::RR) >= p {
                    break;
                }
                beta /= p;
            }
            prev_pdf = bs.pdf;
            prev_delta = bs.delta;
            cone_width = width;
            if !bs.delta {
                cone_spread += super::texturing::BOUNCE_SPREAD;
            }
            o = offset_origin(s.p, side(s.ng, wi));
            d = wi;
        }
        (l, first)
    }

    /// Renders one pixel.
    pub fn render_pixel(&self, x: u32, y: u32) -> PixelValue {
        let st = &self.settings;
        let pixel = y.wrapping_mul(self.camera.width).wrapping_add(x);
        let mut sum = Vec3::ZERO;
        let mut alpha = 0.0f32;
        let mut normal = Vec3::ZERO;
        let mut albedo = Vec3::ZERO;
        for s in 0..st.spp {
            let rng = PathRng::new(st.seed, pixel, s);
            let (o, d) = self.camera.ray(
                x as f32 + rng.get(dims::PIXEL_X),
                y as f32 + rng.get(dims::PIXEL_Y),
                rng.get(dims::LENS_U),
                rng.get(dims::LENS_V),
            );
            let (l, first) = self.trace_path(o, d, &rng);
            sum += l;
            if let Some(f) = first {
                alpha += 1.0;
                normal += f.normal;
                albedo += f.albedo;
            }
        }
        let inv = 1.0 / st.spp.max(1) as f32;
        let mut v = PixelValue {
            rgba: [sum.x * inv, sum.y * inv, sum.z * inv, alpha * inv],
            normal: (normal * inv).to_array(),
            albedo: (albedo * inv).to_array(),
            ..PixelValue::default()
        };
        // Centre ray for Z, faceid and level.
        let (o, d) = self.camera.ray(x as f32 + 0.5, y as f32 + 0.5, 0.5, 0.5);
        if let Some(Closest::Mesh(h)) = self.closest(o, d) {
            v.z = h.hit.t;
            v.face = h.hit.face as f32;
            v.level = h.hit.level as f32;
        }
        v
    }

    fn render_tile(&self, t: &Tile) -> Vec<PixelValue> {
        let mut out = Vec::with_capacity(t.len());
        for y in t.y0..t.y1 {
            for x in t.x0..t.x1 {
                out.push(self.render_pixel(x, y));
            }
        }
        out
    }

    /// Renders the whole image on the current rayon pool; `progress` is called once per
    /// finished tile with the number of tiles (from any thread).
    pub fn render(&self, progress: &(dyn Fn(usize) + Sync)) -> Film {
        let (w, h) = (self.camera.width, self.camera.height);
        let ts = tiles(w, h, TILE);
        let n = ts.len();
        let results: Vec<Vec<PixelValue>> = ts
            .par_iter()
            .map(|t| {
                let r = self.render_tile(t);
                progress(n);
                r
            })
            .collect();
        let mut film = Film::new(w, h);
        for (t, r) in ts.iter().zip(&results) {
            film.put_tile(t, r);
        }
        film
    }
}

/// `n` or `-n`, whichever points to the side of `w`.
#[inline]
fn side(n: Vec3, w: Vec3) -> Vec3 {
    if w.dot(n) >= 0.0 {
        n
    } else {
        -n
    }
}

/// `n` turned to face `w`.
#[inline]
fn facing(n: Vec3, w: Vec3) -> Vec3 {
    side(n, w)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn offset_moves_off_the_surface() {
        for p in [
            Vec3::new(1.0, -2.0, 3.0),
            Vec3::new(1e5, -1e5, 0.001),
            Vec3::new(0.0, 0.0, 0.0),
        ] {
            let n = Vec3::new(0.3, -0.4, 0.866).normalize();
            let q = offset_origin(p, n);
            assert!((q - p).dot(n) > 0.0, "{p} -> {q}");
            assert!((q - p).length() < 1e-3 * p.length().max(1.0));
            let q2 = offset_origin(p, -n);
            assert!((q2 - p).dot(n) < 0.0);
        }
    }
}
