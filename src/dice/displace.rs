//! Displacement along the limit normal (paper 001 §5, §6.4): `P' = P + h n`, with the
//! height `h` from procedural noise of the limit point or from an image addressed by the
//! surface's texture coordinates, evaluated at each diced vertex from its exact limit
//! sample. Crack-freedom is structural: the dicer evaluates a vertex on a shared edge once and
//! copies its displaced `f32` position into every domain that holds it, so both sides of an
//! edge see the same bits. The shading normal is the displaced surface's own, from the limit
//! surface's first and second derivatives and the height's gradient.

use crate::error::{Error, ErrorKind, Result};
use crate::patch::Sample;
use crate::texture::noise::noise;
use crate::vec3::{add, cross, dot, norm, scale, sub};

/// A scalar displacement along the limit normal.
#[derive(Clone, Debug, PartialEq)]
pub enum Displacement {
    /// `amplitude · noise(frequency · P)` ([`noise`], within ±1.1), `P` the limit point in
    /// object space.
    Noise {
        /// Height scale (object units).
        amplitude: f64,
        /// Spatial frequency (lattice cells per object unit).
        frequency: f64,
    },
    /// `scale · image(s, t)`: the mean of the image's channels (linear values; 8- and 16-bit
    /// files read as `[0, 1]`) at the point's limit texture coordinates (the (sub-)face's own
    /// `(u, v)` on a mesh without them), bilinear at full resolution.
    #[cfg(feature = "render")]
    Map {
        /// The image.
        texture: std::sync::Arc<crate::texture::image::ImageTexture>,
        /// Height of a texel value of 1 (object units).
        scale: f64,
        /// The file, for messages and cache keys.
        file: std::path::PathBuf,
    },
}

/// The texture coordinates of a diced point: `(s, t)` and their derivatives in `u`, `v`.
pub type StFrame = ([f64; 2], [f64; 2], [f64; 2]);

impl Displacement {
    /// Parses `noise:AMPLITUDE:FREQUENCY` or `map:FILE:SCALE` (the `--displace` and scene
    /// syntax; a relative FILE is read from the working folder).
    pub fn parse(spec: &str) -> Result<Self> {
        Self::parse_in(spec, std::path::Path::new(""))
    }

    /// [`Self::parse`] with a relative map file resolved against `base` (a scene's folder).
    pub fn parse_in(spec: &str, base: &std::path::Path) -> Result<Self> {
        let bad = |m: String| {
            Err(Error::new(
                ErrorKind::Usage,
                format!("displacement {spec:?}: {m}"),
            ))
        };
        if let Some(rest) = spec.strip_prefix("map:") {
            let Some((file, s)) = rest.rsplit_once(':') else {
                return bad("expected map:FILE:SCALE".into());
            };
            let Ok(scale) = s.parse::<f64>() else {
                return bad("SCALE must be a number".into());
            };
            if !scale.is_finite() || scale.abs() > crate::numeric::MAX_COORD {
                return bad(format!("scale {scale} is not a finite size"));
            }
            if file.is_empty() {
                return bad("FILE is empty".into());
            }
            #[cfg(feature = "render")]
            {
                let file = base.join(file);
                let texture = crate::texture::image::ImageTexture::open(
                    &file,
                    crate::texture::image::ColorSpace::Linear,
                )?;
                return Ok(Displacement::Map {
                    texture: std::sync::Arc::new(texture),
                    scale,
                    file,
                });
            }
            #[cfg(not(feature = "render"))]
            {
                let _ = base;
                return bad("image maps need limitray built with the `render` feature".into());
            }
        }
        let parts: Vec<&str> = spec.split(':').collect();
        match parts.as_slice() {
            ["noise", a, f] => {
                let (Ok(amplitude), Ok(frequency)) = (a.parse::<f64>(), f.parse::<f64>()) else {
                    return bad("AMPLITUDE and FREQUENCY must be numbers".into());
                };
                if !amplitude.is_finite() || amplitude.abs() > crate::numeric::MAX_COORD {
                    return bad(format!("amplitude {amplitude} is not a finite size"));
                }
                if !(frequency.is_finite() && frequency > 0.0 && frequency <= 1e6) {
                    return bad(format!("frequency {frequency} is outside (0, 1e6]"));
                }
                Ok(Displacement::Noise {
                    amplitude,
                    frequency,
                })
            }
            _ => bad("expected noise:AMPLITUDE:FREQUENCY or map:FILE:SCALE".into()),
        }
    }

    /// Whether the height reads texture coordinates (an image map).
    pub fn uses_uv(&self) -> bool {
        !matches!(self, Displacement::Noise { .. })
    }

    /// Identifies the displacement by its bits (file name, scale, amplitude, frequency): two
    /// equal keys displace alike.
    pub fn key(&self) -> String {
        match self {
            Displacement::Noise {
                amplitude,
                frequency,
            } => format!("noise:{:x}:{:x}", amplitude.to_bits(), frequency.to_bits()),
            #[cfg(feature = "render")]
            Displacement::Map { scale, file, .. } => {
                format!("map:{}:{:x}", file.display(), scale.to_bits())
            }
        }
    }

    /// The largest height in magnitude: how far the displaced surface may leave the limit
    /// surface.
    pub fn bound(&self) -> f64 {
        match self {
            Displacement::Noise { amplitude, .. } => 1.1 * amplitude.abs(),
            #[cfg(feature = "render")]
            Displacement::Map { texture, scale, .. } => scale.abs() * texture.max_abs() as f64,
        }
    }

    /// Height at `p` and its gradient in object space (noise; a map's height needs texture
    /// coordinates: [`Self::height_at`]).
    pub fn height(&self, p: [f64; 3]) -> (f64, [f64; 3]) {
        match self {
            Displacement::Noise {
                amplitude,
                frequency,
            } => {
                let (v, g) = noise(p.map(|x| x * frequency));
                (amplitude * v, g.map(|x| x * amplitude * frequency))
            }
            #[cfg(feature = "render")]
            Displacement::Map { .. } => (0.0, [0.0; 3]),
        }
    }

    /// Height at the limit sample `s` and its derivatives along `u` and `v`; `st` is the
    /// point's texture frame (needed by maps, ignored by noise).
    pub fn height_at(&self, s: &Sample, st: Option<StFrame>) -> (f64, f64, f64) {
        #[cfg(not(feature = "render"))]
        let _ = st;
        match self {
            Displacement::Noise { .. } => {
                let (h, g) = self.height(s.p);
                (h, dot(g, s.du), dot(g, s.dv))
            }
            #[cfg(feature = "render")]
            Displacement::Map { texture, scale, .. } => {
                let (st, su, sv) = st.unwrap_or(([0.0; 2], [1.0, 0.0], [0.0, 1.0]));
                let at = |x: f64, y: f64| {
                    texture.lookup_scalar([x as f32, y as f32], 0.0) as f64 * scale
                };
                let h = at(st[0], st[1]);
                // Central differences one texel wide: the bilinear image's slope.
                let (ds, dt) = (1.0 / texture.width() as f64, 1.0 / texture.height() as f64);
                let hs = (at(st[0] + ds, st[1]) - at(st[0] - ds, st[1])) / (2.0 * ds);
                let ht = (at(st[0], st[1] + dt) - at(st[0], st[1] - dt)) / (2.0 * dt);
                (h, hs * su[0] + ht * su[1], hs * sv[0] + ht * sv[1])
            }
        }
    }

    /// The displaced point and its unit normal from the limit sample `s` whose unit normal is
    /// `n`. Where the limit's second derivatives are not finite (at some extraordinary
    /// vertices), the normal's own derivatives are taken as zero.
    pub fn apply(&self, s: &Sample, n: [f64; 3]) -> ([f64; 3], [f64; 3]) {
        self.apply_at(s, n, None)
    }

    /// [`Self::apply`] with the point's texture frame (for maps).
    pub fn apply_at(&self, s: &Sample, n: [f64; 3], st: Option<StFrame>) -> ([f64; 3], [f64; 3]) {
        let (h, h_u, h_v) = self.height_at(s, st);
        let p = add(s.p, scale(n, h));
        let big = cross(s.du, s.dv);
        let len = norm(big);
        // Derivative of the unit normal along a parameter: the part of d(du × dv) across n,
        // over |du × dv|.
        let dn = |d: [f64; 3]| -> [f64; 3] {
            let r = sub(d, scale(n, dot(d, n)));
            let r = scale(r, 1.0 / len);
            if len > 0.0 && r.iter().all(|x| x.is_finite()) {
                r
            } else {
                [0.0; 3]
            }
        };
        let nu = dn(add(cross(s.duu, s.dv), cross(s.du, s.duv)));
        let nv = dn(add(cross(s.duv, s.dv), cross(s.du, s.dvv)));
        let pu = add(add(s.du, scale(n, h_u)), scale(nu, h));
        let pv = add(add(s.dv, scale(n, h_v)), scale(nv, h));
        let m = cross(pu, pv);
        let l = norm(m);
        let shading = if l > 0.0 && l.is_finite() {
            let m = scale(m, 1.0 / l);
            // Keep the limit normal's side (a fold of the displaced surface flips `m`).
            if dot(m, n) < 0.0 {
                scale(m, -1.0)
            } else {
                m
            }
        } else {
            n
        };
        (p, shading)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A plane z = 0 displaced by noise: the point moves along +z by the height, and the
    /// normal is the height field's, (−∂h/∂x, −∂h/∂y, 1) normalised.
    #[test]
    fn plane_displaced_by_noise() {
        let d = Displacement::parse("noise:0.3:2.5").unwrap();
        for (x, y) in [(0.1, 0.2), (1.37, -0.4), (-2.0, 3.3)] {
            let s = Sample {
                p: [x, y, 0.0],
                du: [1.0, 0.0, 0.0],
                dv: [0.0, 1.0, 0.0],
                ..Sample::default()
            };
            let (p, n) = d.apply(&s, [0.0, 0.0, 1.0]);
            let (h, g) = d.height(s.p);
            assert_eq!(p, [x, y, h]);
            let want = [-g[0], -g[1], 1.0];
            let l = norm(want);
            for a in 0..3 {
                assert!((n[a] - want[a] / l).abs() < 1e-15, "{n:?} vs {want:?}");
            }
        }
    }

    /// An image map on the plane z = 0 with `(s, t) = (x, y)`: a ramp of 8 texels whose
    /// centres hold `i / 8` rises with slope 1 in `s` between texel centres (bilinear), so the
    /// height is `scale · (s − 1/16)` and the normal `(−scale, 0, 1)` normalised; a texture
    /// frame scaled by 2 in `u` doubles the slope along `u`. 1e-6 for the f32 texels.
    #[cfg(feature = "render")]
    #[test]
    fn plane_displaced_by_a_map() {
        let texels = (0..8).map(|i| [i as f32 / 8.0; 3]).collect();
        let texture = crate::texture::image::ImageTexture::from_rgb(8, 1, texels);
        let scale = 0.5;
        let d = Displacement::Map {
            texture: std::sync::Arc::new(texture),
            scale,
            file: "ramp".into(),
        };
        for (x, stretch) in [(0.3, 1.0), (0.45, 1.0), (0.3, 2.0)] {
            let s = Sample {
                p: [x, 0.2, 0.0],
                du: [1.0, 0.0, 0.0],
                dv: [0.0, 1.0, 0.0],
                ..Sample::default()
            };
            let frame = ([x, 0.2], [stretch, 0.0], [0.0, 1.0]);
            let (h, hu, hv) = d.height_at(&s, Some(frame));
            assert!((h - scale * (x - 1.0 / 16.0)).abs() < 1e-6, "{h}");
            assert!(
                (hu - scale * stretch).abs() < 1e-5 && hv.abs() < 1e-9,
                "{hu} {hv}"
            );
            let (p, n) = d.apply_at(&s, [0.0, 0.0, 1.0], Some(frame));
            assert_eq!(p, [x, 0.2, h]);
            let want = [-hu, 0.0, 1.0];
            let l = norm(want);
            for a in 0..3 {
                assert!((n[a] - want[a] / l).abs() < 1e-12, "{n:?}");
            }
        }
        assert!((d.bound() - scale * 7.0 / 8.0).abs() < 1e-7);
    }

    #[test]
    fn specs() {
        assert_eq!(
            Displacement::parse("noise:0.05:4").unwrap(),
            Displacement::Noise {
                amplitude: 0.05,
                frequency: 4.0
            }
        );
        for bad in [
            "noise:0.1",
            "noise:x:1",
            "noise:0.1:0",
            "noise:inf:1",
            "map:a.png",
            "map:a.png:x",
            "map::1",
            "bump",
        ] {
            let e = Displacement::parse(bad).unwrap_err();
            assert_eq!(e.kind, ErrorKind::Usage, "{bad}");
            assert!(e.to_string().contains(bad), "{bad}: {e}");
        }
    }
}
