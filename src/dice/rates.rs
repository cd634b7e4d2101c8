//! How many segments each control edge and each n-gon spoke gets: uniform, by world-space
//! length, or by projected size in pixels from a camera (paper 001 §7).
//!
//! A rate belongs to an edge, not to a face, so both faces that share the edge see the same
//! samples. Edges of n-gons get an even rate: each of the two sub-faces along the edge takes
//! half of it.

use super::{face_edge_param, DiceOptions};
use crate::coord::FaceCoord;
use crate::error::{Error, ErrorKind, Result};
use crate::patch::PatchTable;
use crate::refine::Level;
use crate::vec3::norm;
use rayon::prelude::*;

/// How densely to dice.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum DiceRate {
    /// `R` segments per base-face edge (halved on n-gon sub-face edges, at least 1).
    Uniform(u32),
    /// Target object-space length of a micro-edge.
    EdgeLength(f64),
    /// Screen-space rate from a camera.
    Screen(ScreenRate),
}

/// A camera's view, for screen-space dicing rates.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ScreenRate {
    /// Camera position in the mesh's object space.
    pub eye: [f64; 3],
    /// Pixels per radian at the image centre, `image_height / (2 tan(fov_y / 2))`, times the
    /// instance's largest scale factor.
    pub pixels_per_radian: f64,
    /// Target length of a micro-edge in pixels.
    pub pixels_per_edge: f64,
}

/// Segments per control edge and per n-gon spoke.
#[derive(Clone, Debug)]
pub struct Rates {
    /// Per edge of the base level.
    pub edge: Vec<u32>,
    /// Per face-vertex slot of an n-gon (spoke `k` joins the midpoint of edge `k` to the
    /// centre); unused for quads.
    pub spoke: Vec<u32>,
}

/// Turns the sampled points of a curve into a (fractional) segment count.
type Measure = Box<dyn Fn(&[[f64; 3]]) -> f64 + Sync>;

/// Samples per curve when measuring lengths.
const MEASURE_SEGMENTS: usize = 8;

/// Computes the rates of every edge and spoke of `level` (the base level of the table's mesh),
/// measured on the limit surface (without `opts.displace`: [`super::dice`] measures the
/// displaced surface).
pub fn edge_rates(table: &PatchTable, level: &Level, opts: &DiceOptions) -> Result<Rates> {
    rates_for(table, level, opts, None)
}

/// Most samples of one displaced curve when measuring it.
const MAX_DISPLACED_SEGMENTS: usize = 256;

/// [`edge_rates`] with measured rates taken on the displaced surface: each curve is sampled
/// finely enough to follow the displacement (four samples per noise lattice cell or per texel
/// along it, at least [`MEASURE_SEGMENTS`], at most [`MAX_DISPLACED_SEGMENTS`]), so the
/// length the displacement adds raises the rate. Uniform rates are the caller's choice and
/// stay.
pub(super) fn rates_for(
    table: &PatchTable,
    level: &Level,
    opts: &DiceOptions,
    displacer: Option<&super::DisplacedSurface>,
) -> Result<Rates> {
    let topo = &level.topo;
    let max_rate = opts.max_rate.max(1);
    let live = |f: usize| !level.face_hole[f];
    let ngon_edge: Vec<bool> = (0..topo.num_edges())
        .map(|e| {
            topo.edge_face_list(e as u32)
                .iter()
                .any(|&f| live(f as usize) && topo.face_size(f as usize) != 4)
        })
        .collect();
    let even = |r: u32, e: usize| {
        if ngon_edge[e] {
            (r + (r & 1)).max(2)
        } else {
            r
        }
    };
    // How a measured curve becomes a segment count.
    let measure: Option<Measure> = match opts.rate {
        DiceRate::Uniform(r) => {
            if r == 0 {
                return Err(Error::new(
                    ErrorKind::Usage,
                    "dicing rate must be at least 1",
                ));
            }
            None
        }
        DiceRate::EdgeLength(l) => {
            if !(l > 0.0 && l.is_finite()) {
                return Err(Error::new(
                    ErrorKind::Usage,
                    format!("edge length must be positive, got {l}"),
                ));
            }
            Some(Box::new(move |pts: &[[f64; 3]]| {
                pts.windows(2).map(|w| dist(w[0], w[1])).sum::<f64>() / l
            }))
        }
        DiceRate::Screen(s) => {
            if !(s.pixels_per_edge > 0.0
                && s.pixels_per_edge.is_finite()
                && s.pixels_per_radian > 0.0
                && s.pixels_per_radian.is_finite())
            {
                return Err(Error::new(
                    ErrorKind::Usage,
                    "screen rate needs positive pixels per edge and pixels per radian",
                ));
            }
            Some(Box::new(move |pts: &[[f64; 3]]| {
                let mut pixels = 0.0;
                for w in pts.windows(2) {
                    let mid = [
                        0.5 * (w[0][0] + w[1][0]),
                        0.5 * (w[0][1] + w[1][1]),
                        0.5 * (w[0][2] + w[1][2]),
                    ];
                    let d = dist(mid, s.eye).max(1e-9 * (1.0 + norm(s.eye)));
                    pixels += dist(w[0], w[1]) / d * s.pixels_per_radian;
                }
                pixels / s.pixels_per_edge
            }))
        }
    };
    let to_rate = |x: f64| -> u32 {
        if x.is_finite() {
            (x.ceil().max(1.0) as u64).min(max_rate as u64) as u32
        } else {
            max_rate
        }
    };
    let curve = |f: usize, points: &dyn Fn(f64) -> (u32, f64, f64)| -> Result<Vec<[f64; 3]>> {
        let plain = (0..=MEASURE_SEGMENTS)
            .map(|i| {
                let (k, u, v) = points(i as f64 / MEASURE_SEGMENTS as f64);
                table.position(FaceCoord::new(f as u32, k, u, v))
            })
            .collect::<Result<Vec<_>>>()?;
        let Some(d) = displacer else {
            return Ok(plain);
        };
        let cells = d.detail_along(f as u32, &plain, points)?;
        let n = ((4.0 * cells).ceil() as usize).clamp(MEASURE_SEGMENTS, MAX_DISPLACED_SEGMENTS);
        (0..=n)
            .map(|i| {
                let (k, u, v) = points(i as f64 / n as f64);
                let q = super::eval_point(table, Some(d), f as u32, k, u, v)?;
                Ok(q.p.map(f64::from))
            })
            .collect()
    };
    let edge: Vec<u32> = (0..topo.num_edges())
        .into_par_iter()
        .map(|e| -> Result<u32> {
            let Some(&f) = topo
                .edge_face_list(e as u32)
                .iter()
                .find(|&&f| live(f as usize))
            else {
                return Ok(1);
            };
            let r = match (&measure, opts.rate) {
                (None, DiceRate::Uniform(r)) => r.min(max_rate),
                (Some(m), _) => {
                    let f = f as usize;
                    let n = topo.face_size(f);
                    let mi = (0..n)
                        .find(|&i| topo.face_edge(f, i) == e as u32)
                        .expect("edge of its face");
                    to_rate(m(&curve(f, &|t| face_edge_param(n, mi, t))?))
                }
                (None, _) => unreachable!("measured rates have a measure"),
            };
            Ok(even(r, e))
        })
        .collect::<Result<_>>()?;
    let mut spoke = vec![1u32; topo.face_verts.len()];
    for f in 0..topo.num_faces() {
        let n = topo.face_size(f);
        if n == 4 || !live(f) {
            continue;
        }
        for k in 0..n {
            let slot = topo.face_offsets[f] as usize + k;
            spoke[slot] = match (&measure, opts.rate) {
                (None, DiceRate::Uniform(r)) => (r.min(max_rate) / 2).max(1),
                (Some(m), _) => to_rate(m(&curve(f, &|t| (k as u32, 1.0, t))?)),
                (None, _) => unreachable!("measured rates have a measure"),
            };
        }
    }
    Ok(Rates { edge, spoke })
}

fn dist(a: [f64; 3], b: [f64; 3]) -> f64 {
    norm([a[0] - b[0], a[1] - b[1], a[2] - b[2]])
}
