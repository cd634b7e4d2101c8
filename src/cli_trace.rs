//! The `dice`, `trace` and `accuracy` subcommands: diced meshes as OBJ, line-oriented ray
//! queries (`ox oy oz dx dy dz` in, `hit t face k u v nx ny nz` (plus a refined flag with
//! `--exact`) or `miss` out), and the
//! accuracy table of diced hits against the exact limit surface.

use crate::bvh::exact::refine_hit;
use crate::bvh::{MeshBvh, Ray};
use crate::dice::{dice, DiceOptions, DiceRate, DicedMesh};
use crate::error::{Error, ErrorKind, Result};
use crate::mesh::ControlMesh;
use crate::patch::{PatchOptions, PatchTable};
use rayon::prelude::*;
use std::io::{BufRead, Write};

/// Dicing options of the command line.
#[derive(clap::Args, Clone, Debug)]
pub struct DiceArgs {
    /// Uniform rate: segments per base-face edge (halved on n-gon sub-faces).
    #[arg(long, default_value_t = 4)]
    pub rate: u32,
    /// Dice by object-space micro-edge length instead of a uniform rate.
    #[arg(long)]
    pub edge_length: Option<f64>,
    /// Largest number of segments on one edge.
    #[arg(long, default_value_t = 256)]
    pub max_rate: u32,
    /// Maximum isolation level of the patch table.
    #[arg(long, default_value_t = crate::patch::table::DEFAULT_MAX_LEVEL)]
    pub max_level: usize,
}

impl DiceArgs {
    /// The dicing options these arguments ask for.
    pub fn options(&self) -> DiceOptions {
        DiceOptions {
            rate: match self.edge_length {
                Some(l) => DiceRate::EdgeLength(l),
                None => DiceRate::Uniform(self.rate),
            },
            max_rate: self.max_rate,
        }
    }
}

/// Builds the patch table and dices `mesh` under `options`.
pub fn dice_mesh(
    mesh: &ControlMesh,
    options: crate::mesh::Options,
    args: &DiceArgs,
) -> Result<(PatchTable, DicedMesh)> {
    let table = PatchTable::with_options(
        mesh,
        options,
        PatchOptions {
            max_level: args.max_level,
            ..PatchOptions::default()
        },
    )?;
    if args.edge_length.is_none() && args.rate > args.max_rate.max(1) {
        eprintln!(
            "warning: rate {} is above --max-rate {}; {} segments per edge are used",
            args.rate,
            args.max_rate,
            args.max_rate.max(1)
        );
    }
    let d = dice(&table, mesh, &args.options())?;
    Ok((table, d))
}

/// Writes a diced mesh as OBJ: `v`, `vn`, `vt` (the vertex's `(u, v)` in its face), and `f`
/// with 1-based `v/vt/vn` indices; a comment line per vertex is not written (the face and
/// sub-face of each vertex are in `limitray::dice::DicedMesh::params`).
pub fn write_diced(w: &mut impl Write, d: &DicedMesh) -> std::io::Result<()> {
    writeln!(
        w,
        "# limitray diced limit surface: {} vertices, {} triangles",
        d.positions.len(),
        d.triangles.len()
    )?;
    for p in &d.positions {
        writeln!(w, "v {:?} {:?} {:?}", p[0], p[1], p[2])?;
    }
    for n in &d.normals {
        writeln!(w, "vn {:?} {:?} {:?}", n[0], n[1], n[2])?;
    }
    for p in &d.params {
        // Written at the f32 precision of the diced vertices.
        writeln!(w, "vt {:?} {:?}", p.u as f32, p.v as f32)?;
    }
    for t in &d.triangles {
        let [a, b, c] = t.map(|i| i + 1);
        writeln!(w, "f {a}/{a}/{a} {b}/{b}/{b} {c}/{c}/{c}")?;
    }
    Ok(())
}

fn parse_ray(line: &str) -> std::result::Result<Ray, String> {
    let toks: Vec<&str> = line.split_whitespace().collect();
    if toks.len() != 6 {
        return Err(format!(
            "expected 'ox oy oz dx dy dz', found {} fields",
            toks.len()
        ));
    }
    let mut x = [0f32; 6];
    for (i, t) in toks.iter().enumerate() {
        x[i] = t
            .parse::<f32>()
            .ok()
            .filter(|v| v.is_finite())
            .ok_or_else(|| format!("invalid number '{t}'"))?;
    }
    if x[3] == 0.0 && x[4] == 0.0 && x[5] == 0.0 {
        return Err("ray direction is zero".into());
    }
    Ok(Ray::new([x[0], x[1], x[2]], [x[3], x[4], x[5]]))
}

/// Reads rays from `input` and writes one line per input line: `hit t face k u v nx ny nz`
/// (the normal is the limit-surface shading normal), `miss`, or nine `nan` fields for a bad
/// line, invalid UTF-8 included (with `stdin:LINE: …` on stderr and an error at the end). With
/// `exact`, each hit is refined onto the exact limit surface (`f64`, Newton) and that is
/// printed, followed by a tenth field: `1` for a refined hit, `0` for a hit that could not be
/// refined (the diced hit is printed then). Input is read and answered in batches of
/// [`TRACE_BATCH`] lines, so memory does not grow with the input.
pub fn trace(
    bvh: &MeshBvh,
    table: &PatchTable,
    exact: bool,
    input: impl BufRead,
    output: impl Write,
) -> Result<()> {
    trace_with(table, exact, input, output, |rays| {
        Ok(bvh.intersect_batch(rays))
    })
}

/// Lines answered per batch by [`trace`].
pub const TRACE_BATCH: usize = 1 << 16;

/// A parsed input line: blank, a ray, or why it is bad.
type Parsed = std::result::Result<Option<Ray>, String>;

/// [`trace`] with the closest hits of the parsed rays computed by `hits` (one result per ray,
/// in order, called once per batch): the GPU backend plugs in here.
pub fn trace_with(
    table: &PatchTable,
    exact: bool,
    input: impl BufRead,
    mut output: impl Write,
    mut hits: impl FnMut(&[Ray]) -> Result<Vec<Option<crate::bvh::Hit>>>,
) -> Result<()> {
    let io = |e: std::io::Error| Error::new(ErrorKind::Io, e.to_string());
    let mut bad = 0;
    let mut batch: Vec<(usize, Parsed)> = Vec::new();
    let mut answer = |batch: &mut Vec<(usize, Parsed)>, output: &mut dyn Write| -> Result<()> {
        let rays: Vec<Ray> = batch
            .iter()
            .filter_map(|(_, p)| p.as_ref().ok().copied().flatten())
            .collect();
        let results = hits(&rays)?;
        if results.len() != rays.len() {
            return Err(Error::new(
                ErrorKind::Usage,
                "one hit result per ray expected",
            ));
        }
        let mut next = results.into_iter().zip(rays.iter());
        for (number, p) in batch.drain(..) {
            match p {
                Ok(None) => writeln!(output).map_err(io)?,
                Err(m) => {
                    bad += 1;
                    eprintln!("stdin:{number}: {m}");
                    writeln!(output, "nan nan nan nan nan nan nan nan nan").map_err(io)?;
                }
                Ok(Some(_)) => {
                    let (h, ray) = next.next().expect("one result per ray");
                    let Some(h) = h else {
                        writeln!(output, "miss").map_err(io)?;
                        continue;
                    };
                    match exact.then(|| refine_hit(table, ray, &h)) {
                        Some(Some(x)) => writeln!(
                            output,
                            "hit {:?} {} {} {:?} {:?} {:?} {:?} {:?} 1",
                            x.t, x.face, x.k, x.u, x.v, x.n[0], x.n[1], x.n[2]
                        ),
                        unrefined => writeln!(
                            output,
                            "hit {:?} {} {} {:?} {:?} {:?} {:?} {:?}{}",
                            h.t,
                            h.face,
                            h.k,
                            h.u,
                            h.v,
                            h.ns[0],
                            h.ns[1],
                            h.ns[2],
                            if unrefined.is_some() { " 0" } else { "" }
                        ),
                    }
                    .map_err(io)?;
                }
            }
        }
        Ok(())
    };
    for item in crate::lines::lines(input) {
        let (number, line) = item.map_err(io)?;
        let parsed = match line {
            Err(m) => Err(m),
            Ok(l) if l.trim().is_empty() => Ok(None),
            Ok(l) => parse_ray(&l).map(Some),
        };
        batch.push((number, parsed));
        if batch.len() >= TRACE_BATCH {
            answer(&mut batch, &mut output)?;
        }
    }
    answer(&mut batch, &mut output)?;
    output.flush().map_err(io)?;
    if bad > 0 {
        return Err(
            Error::new(ErrorKind::Parse, format!("{bad} invalid ray line(s)")).in_file("stdin"),
        );
    }
    Ok(())
}

/// A number for JSON: `null` where it is not finite (JSON has no NaN or infinity).
fn json_num(x: f64, precision: usize) -> String {
    if x.is_finite() {
        format!("{x:.precision$e}")
    } else {
        "null".to_string()
    }
}

/// One row of the accuracy table per rate, as JSON lines.
pub fn accuracy_table(
    mesh: &ControlMesh,
    options: crate::mesh::Options,
    args: &DiceArgs,
    rates: &[u32],
    rays: usize,
    seed: u64,
) -> Result<Vec<String>> {
    let diag = mesh.diagonal();
    let mut out = Vec::new();
    for &r in rates {
        let a = DiceArgs {
            rate: r,
            edge_length: None,
            ..args.clone()
        };
        let (table, d) = dice_mesh(mesh, options, &a)?;
        let tris = d.triangles.len();
        let bvh = MeshBvh::build(d);
        let acc = crate::probe::accuracy(&table, &bvh, rays, diag, seed);
        let ratio = if acc.max_bound_ratio.is_finite() {
            format!("{:.3}", acc.max_bound_ratio)
        } else {
            "null".to_string()
        };
        out.push(format!(
            "{{\"rate\":{r},\"rate_used\":{},\"triangles\":{tris},\"rays\":{},\"unrefined\":{},\"max_surface_rel\":{},\"mean_surface_rel\":{},\"max_param_rel\":{},\"mean_param_rel\":{},\"max_bound_ratio\":{ratio}}}",
            r.min(args.max_rate.max(1)),
            acc.samples,
            acc.unrefined,
            json_num(acc.max_surface / diag, 3),
            json_num(acc.mean_surface / diag, 3),
            json_num(acc.max_param / diag, 3),
            json_num(acc.mean_param / diag, 3),
        ));
    }
    Ok(out)
}

/// Options of `limitray bench-trace`.
#[derive(clap::Args, Clone, Debug)]
pub struct TraceBenchArgs {
    /// OBJ file with OpenSubdiv tags (or `--grid N`).
    pub mesh: Option<std::path::PathBuf>,
    /// Use the generated N×N grid (`limitray::mesh::generate::grid`) instead of a file.
    #[arg(long)]
    pub grid: Option<usize>,
    /// Uniform dicing rate.
    #[arg(long, default_value_t = 4)]
    pub rate: u32,
    /// Rays per measurement (coherent and incoherent each).
    #[arg(long, default_value_t = 1_000_000)]
    pub rays: usize,
    /// Worker threads (0: all).
    #[arg(long, default_value_t = 0)]
    pub threads: usize,
    /// Repetitions; the median is reported.
    #[arg(long, default_value_t = 5)]
    pub reps: usize,
}

/// Camera rays (coherent) looking at `bounds` from outside, `n` of them on a square grid.
pub fn camera_rays(bounds: [[f32; 3]; 2], n: usize) -> Vec<Ray> {
    let c: [f32; 3] = std::array::from_fn(|i| 0.5 * (bounds[0][i] + bounds[1][i]));
    let ext: [f32; 3] = std::array::from_fn(|i| bounds[1][i] - bounds[0][i]);
    let r = 0.5 * (ext[0] * ext[0] + ext[1] * ext[1] + ext[2] * ext[2]).sqrt();
    let eye = [c[0] + 1.3 * r, c[1] + 1.7 * r, c[2] + 2.1 * r];
    let fwd = crate::bvh::mesh::normalize([c[0] - eye[0], c[1] - eye[1], c[2] - eye[2]]);
    let right = crate::bvh::mesh::normalize([fwd[1], -fwd[0], 0.0]);
    let up = [
        right[1] * fwd[2] - right[2] * fwd[1],
        right[2] * fwd[0] - right[0] * fwd[2],
        right[0] * fwd[1] - right[1] * fwd[0],
    ];
    let side = (n as f64).sqrt().ceil() as usize;
    let half = 0.45f32; // tan of half the field of view
    (0..side * side)
        .take(n)
        .map(|i| {
            let (x, y) = ((i % side) as f32, (i / side) as f32);
            let sx = (2.0 * (x + 0.5) / side as f32 - 1.0) * half;
            let sy = (1.0 - 2.0 * (y + 0.5) / side as f32) * half;
            Ray::new(
                eye,
                std::array::from_fn(|k| fwd[k] + sx * right[k] + sy * up[k]),
            )
        })
        .collect()
}

/// Incoherent rays: from random points on a sphere around `bounds` to random points inside.
pub fn random_rays(bounds: [[f32; 3]; 2], n: usize, seed: u64) -> Vec<Ray> {
    let mut rng = crate::bench::SplitMix64(seed);
    let c: [f32; 3] = std::array::from_fn(|i| 0.5 * (bounds[0][i] + bounds[1][i]));
    let ext: [f32; 3] = std::array::from_fn(|i| bounds[1][i] - bounds[0][i]);
    let r = 0.5 * (ext[0] * ext[0] + ext[1] * ext[1] + ext[2] * ext[2]).sqrt();
    let dirs = crate::probe::sphere_dirs(n, seed ^ 0x5eed);
    dirs.into_iter()
        .map(|d| {
            let o = [
                c[0] + 1.5 * r * d[0],
                c[1] + 1.5 * r * d[1],
                c[2] + 1.5 * r * d[2],
            ];
            let t: [f32; 3] =
                std::array::from_fn(|k| bounds[0][k] + ext[k] * rng.next_f64() as f32);
            Ray::new(o, [t[0] - o[0], t[1] - o[1], t[2] - o[2]])
        })
        .collect()
}

/// Runs `limitray bench-trace`: dicing, BVH build, and closest-hit rays/s, as one JSON line.
pub fn trace_bench(args: &TraceBenchArgs) -> Result<String> {
    let mesh = match (&args.mesh, args.grid) {
        (Some(p), None) => crate::mesh::obj::read_obj(p)?,
        (None, Some(n)) => crate::mesh::generate::try_grid(n)?,
        _ => {
            return Err(Error::new(
                ErrorKind::Usage,
                "give exactly one of MESH or --grid N",
            ))
        }
    };
    let threads = if args.threads == 0 {
        std::thread::available_parallelism().map_or(1, |n| n.get())
    } else {
        args.threads
    };
    let pool = crate::threads::pool(threads)?;
    pool.install(|| {
        let t0 = std::time::Instant::now();
        let table = PatchTable::new(&mesh, PatchOptions::default())?;
        let t1 = std::time::Instant::now();
        let d = dice(
            &table,
            &mesh,
            &DiceOptions {
                rate: DiceRate::Uniform(args.rate),
                max_rate: 1024,
            },
        )?;
        let t2 = std::time::Instant::now();
        let tris = d.triangles.len();
        let bvh = MeshBvh::build(d);
        let t3 = std::time::Instant::now();
        let bounds = bvh.bounds();
        let sets = [
            ("coherent", camera_rays(bounds, args.rays)),
            ("incoherent", random_rays(bounds, args.rays, 11)),
        ];
        let mut fields = vec![
            format!("\"triangles\":{tris}"),
            format!("\"threads\":{threads}"),
            format!("\"table_ms\":{:.1}", (t1 - t0).as_secs_f64() * 1e3),
            format!("\"dice_ms\":{:.1}", (t2 - t1).as_secs_f64() * 1e3),
            format!("\"bvh_ms\":{:.1}", (t3 - t2).as_secs_f64() * 1e3),
            format!("\"bvh_nodes\":{}", bvh.cwbvh.nodes.len()),
            format!("\"widened_planes\":{}", bvh.widened_planes),
            format!(
                "\"bytes_per_triangle\":{:.1}",
                bvh.bytes() as f64 / tris.max(1) as f64
            ),
        ];
        for (name, rays) in &sets {
            let mut times = Vec::new();
            let mut hits = 0;
            for _ in 0..args.reps.max(1) {
                let t = std::time::Instant::now();
                let h = bvh.intersect_batch(rays);
                times.push(t.elapsed().as_secs_f64());
                hits = h.iter().filter(|x| x.is_some()).count();
            }
            times.sort_by(f64::total_cmp);
            let med = times[times.len() / 2];
            fields.push(format!(
                "\"{name}_mrays_per_s\":{:.3}",
                rays.len() as f64 / med / 1e6
            ));
            fields.push(format!("\"{name}_hits\":{hits}"));
        }
        // Any-hit (shadow) queries on the incoherent rays.
        let rays = &sets[1].1;
        let mut times = Vec::new();
        for _ in 0..args.reps.max(1) {
            let t = std::time::Instant::now();
            let n = rays
                .par_iter()
                .with_min_len(256)
                .filter(|r| bvh.occluded(r))
                .count();
            times.push(t.elapsed().as_secs_f64());
            std::hint::black_box(n);
        }
        times.sort_by(f64::total_cmp);
        fields.push(format!(
            "\"incoherent_anyhit_mrays_per_s\":{:.3}",
            rays.len() as f64 / times[times.len() / 2] / 1e6
        ));
        Ok(format!("{{{}}}", fields.join(",")))
    })
}
