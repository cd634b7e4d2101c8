//! Displacement along the limit normal (paper 001 §5, §6.4): `P' = P + h(P) n`, with the
//! height `h` from procedural noise, evaluated at each diced vertex from its exact limit
//! sample. Crack-freedom is structural: the dicer evaluates a vertex on a shared edge once and
//! copies its displaced `f32` position into every domain that holds it, so both sides of an
//! edge see the same bits. The shading normal is the displaced surface's own, from the limit
//! surface's first and second derivatives and the height's gradient.

use crate::error::{Error, ErrorKind, Result};
use crate::patch::Sample;
use crate::texture::noise::noise;
use crate::vec3::{add, cross, dot, norm, scale, sub};

/// A scalar displacement along the limit normal.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Displacement {
    /// `amplitude · noise(frequency · P)` ([`noise`], within ±1.1), `P` the limit point in
    /// object space.
    Noise {
        /// Height scale (object units).
        amplitude: f64,
        /// Spatial frequency (lattice cells per object unit).
        frequency: f64,
    },
}

impl Displacement {
    /// Parses `noise:AMPLITUDE:FREQUENCY` (the `--displace` and scene syntax). `map:FILE:SCALE`
    /// (an image addressed by face-varying UVs) is not available yet and is refused by name.
    pub fn parse(spec: &str) -> Result<Self> {
        let bad = |m: String| {
            Err(Error::new(
                ErrorKind::Usage,
                format!("displacement {spec:?}: {m}"),
            ))
        };
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
            ["map", ..] => bad(
                "image displacement maps are not supported yet (textures need face-varying UVs); \
                 use noise:AMPLITUDE:FREQUENCY"
                    .into(),
            ),
            _ => bad("expected noise:AMPLITUDE:FREQUENCY".into()),
        }
    }

    /// The largest height in magnitude: how far the displaced surface may leave the limit
    /// surface.
    pub fn bound(&self) -> f64 {
        match *self {
            Displacement::Noise { amplitude, .. } => 1.1 * amplitude.abs(),
        }
    }

    /// Height at `p` and its gradient in object space.
    pub fn height(&self, p: [f64; 3]) -> (f64, [f64; 3]) {
        match *self {
            Displacement::Noise {
                amplitude,
                frequency,
            } => {
                let (v, g) = noise(p.map(|x| x * frequency));
                (amplitude * v, g.map(|x| x * amplitude * frequency))
            }
        }
    }

    /// The displaced point and its unit normal from the limit sample `s` whose unit normal is
    /// `n`. Where the limit's second derivatives are not finite (at some extraordinary
    /// vertices), the normal's own derivatives are taken as zero.
    pub fn apply(&self, s: &Sample, n: [f64; 3]) -> ([f64; 3], [f64; 3]) {
        let (h, g) = self.height(s.p);
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
        let pu = add(add(s.du, scale(n, dot(g, s.du))), scale(nu, h));
        let pv = add(add(s.dv, scale(n, dot(g, s.dv))), scale(nv, h));
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
            "map:a.png:1",
            "bump",
        ] {
            let e = Displacement::parse(bad).unwrap_err();
            assert_eq!(e.kind, ErrorKind::Usage, "{bad}");
            assert!(e.to_string().contains(bad), "{bad}: {e}");
        }
    }
}
