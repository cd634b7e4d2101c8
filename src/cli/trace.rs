//! `limitray trace`: line-oriented ray queries (`ox oy oz dx dy dz` in, `hit t face k u v nx ny
//! nz` or `miss` out) on the CPU or, with `--backend gpu`, on a Vulkan adapter; with `--exact`,
//! the reference intersector's certified first hit on the exact limit surface, in `f64`.

use super::args::{load, DiceArgs, RuleArgs};
use super::dice::dice_grid;
use crate::bvh::{Ray, Ray64};
use crate::coord::FaceCoord;
use crate::error::{Error, ErrorKind, Result};
use crate::exact::{ExactTrace, ExactTracer};
use crate::grid::GridMesh;
use crate::mesh::Scheme;
use crate::patch::uv::UvSurface;
use crate::patch::{LoopSurface, PatchTable};
use std::io::{BufRead, Write};
use std::path::PathBuf;

/// Where rays are traced.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, clap::ValueEnum)]
pub enum Backend {
    /// The CPU (rayon).
    #[default]
    Cpu,
    /// A Vulkan adapter through wgpu (lavapipe on machines without a GPU).
    Gpu,
}

/// Backend options of the command line.
#[derive(clap::Args, Clone, Debug, Default)]
pub struct BackendArgs {
    /// Trace on the CPU or on a Vulkan adapter (wgpu compute).
    #[arg(long, value_enum, default_value_t = Backend::Cpu)]
    pub backend: Backend,
    /// GPU adapter: a case-insensitive substring of its name (default: $LIMITRAY_ADAPTER,
    /// else a real GPU before a CPU implementation). `limitray gpu-info` lists them.
    #[arg(long)]
    pub adapter: Option<String>,
}

/// Arguments of `limitray trace`.
#[derive(clap::Args, Clone, Debug)]
pub struct TraceCmd {
    /// OBJ file with OpenSubdiv tags.
    pub mesh: PathBuf,
    #[command(flatten)]
    pub rules: RuleArgs,
    #[command(flatten)]
    pub dice: DiceArgs,
    /// Trace the exact limit surface with the reference intersector (f64, certified first
    /// hit, independent of the dicing options; CPU only): `hit t face k u v nx ny nz err
    /// sharp grazing` with 17 significant digits, `miss`, or `miss graze ERR`.
    #[arg(long)]
    pub exact: bool,
    /// Append the hit's limit texture coordinates `s t` to every hit line (the mesh's
    /// face-varying `vt` in the `--fvar` mode; Catmull-Clark meshes with texture coordinates).
    #[arg(long)]
    pub uv: bool,
    #[command(flatten)]
    pub backend: BackendArgs,
}

/// Runs `limitray trace` on standard input and output.
pub fn run(args: &TraceCmd) -> Result<()> {
    let m = load(&args.mesh)?;
    let (input, output) = (std::io::stdin().lock(), std::io::stdout().lock());
    let uv = if args.uv {
        let o = args.rules.options(&m);
        let file = || args.mesh.display().to_string();
        if m.face_uvs.is_empty() {
            return Err(Error::new(
                ErrorKind::Usage,
                "--uv: the mesh has no texture coordinates (no `vt` in its faces)",
            )
            .in_file(file()));
        }
        let mesh = crate::mesh::ControlMesh {
            options: o,
            ..m.clone()
        };
        UvSurface::new(&mesh, o.fvar).map_err(|e| e.in_file(file()))?
    } else {
        None
    };
    let uv = uv.as_ref();
    if args.exact {
        if args.backend.backend == Backend::Gpu {
            return Err(Error::new(
                ErrorKind::Usage,
                "--exact runs the reference intersector on the CPU; drop --backend gpu",
            ));
        }
        if args.dice.displace.is_some() {
            return Err(Error::new(
                ErrorKind::Usage,
                "--exact traces the exact limit surface, which --displace leaves: drop one",
            ));
        }
        let table =
            PatchTable::with_options(&m, args.rules.options(&m), args.dice.patch_options())?;
        let tracer = ExactTracer::new(std::sync::Arc::new(table), &m)?;
        return trace_lines(input, output, true, |rays| {
            let r64: Vec<Ray64> = rays.iter().map(|r| r.1).collect();
            with_uv(
                tracer.trace_batch(&r64).iter().map(exact_line).collect(),
                uv,
            )
        });
    }
    let options = args.rules.options(&m);
    let scheme = options.scheme;
    let (bvh, _) = dice_grid(&m, options, &args.dice)?;
    match args.backend.backend {
        Backend::Cpu => trace_with(input, output, |rays| {
            let f32_rays: Vec<Ray> = rays.iter().map(|r| r.0).collect();
            let lines = bvh
                .intersect_batch(&f32_rays)
                .iter()
                .map(|h| diced_line(h.as_ref(), scheme))
                .collect();
            with_uv(lines, uv)
        }),
        #[cfg(feature = "gpu")]
        Backend::Gpu => {
            let ctx = crate::gpu::GpuContext::new(args.backend.adapter.as_deref())?;
            trace_with(input, output, |rays| {
                let f32_rays: Vec<Ray> = rays.iter().map(|r| r.0).collect();
                let hits = crate::gpu::trace_mesh(
                    &ctx,
                    &bvh,
                    &f32_rays,
                    crate::gpu::TraceOptions::default(),
                )?;
                with_uv(
                    hits.iter()
                        .map(|h| diced_line(h.as_ref(), scheme))
                        .collect(),
                    uv,
                )
            })
        }
        #[cfg(not(feature = "gpu"))]
        Backend::Gpu => Err(Error::new(
            ErrorKind::Usage,
            "this limitray was built without the `gpu` feature",
        )),
    }
}

/// A ray line `ox oy oz dx dy dz` as given, in `f64`; unless `exact`, every number must also
/// be finite in `f32` (the diced mesh's BVH traces the rounding, each number parsed to `f32`
/// directly so that it is the correctly rounded value).
fn parse_ray(line: &str, exact: bool) -> std::result::Result<(Ray, Ray64), String> {
    let toks: Vec<&str> = line.split_whitespace().collect();
    if toks.len() != 6 {
        return Err(format!(
            "expected 'ox oy oz dx dy dz', found {} fields",
            toks.len()
        ));
    }
    let mut x = [0f32; 6];
    let mut x64 = [0f64; 6];
    for (i, t) in toks.iter().enumerate() {
        let bad = || format!("invalid number '{t}'");
        x64[i] = t
            .parse::<f64>()
            .ok()
            .filter(|v| v.is_finite())
            .ok_or_else(bad)?;
        if !exact {
            x[i] = t
                .parse::<f32>()
                .ok()
                .filter(|v| v.is_finite())
                .ok_or_else(bad)?;
        }
    }
    let zero = if exact {
        x64[3] == 0.0 && x64[4] == 0.0 && x64[5] == 0.0
    } else {
        x[3] == 0.0 && x[4] == 0.0 && x[5] == 0.0
    };
    if zero {
        return Err("ray direction is zero".into());
    }
    Ok((
        Ray::new([x[0], x[1], x[2]], [x[3], x[4], x[5]]),
        Ray64::new([x64[0], x64[1], x64[2]], [x64[3], x64[4], x64[5]]),
    ))
}

/// `lines` with, under `--uv`, the limit texture coordinates `s t` of each hit appended (read
/// back from the line's `face k u v`, which every hit line prints round-trippably).
fn with_uv(lines: Vec<String>, uv: Option<&UvSurface>) -> Result<Vec<String>> {
    let Some(uv) = uv else {
        return Ok(lines);
    };
    lines
        .into_iter()
        .map(|l| {
            if !l.starts_with("hit ") {
                return Ok(l);
            }
            let f: Vec<&str> = l.split_whitespace().collect();
            let num = |i: usize| f[i].parse::<f64>().unwrap_or(f64::NAN);
            let at = FaceCoord::new(
                f[2].parse().unwrap_or(u32::MAX),
                f[3].parse().unwrap_or(u32::MAX),
                num(4).clamp(0.0, 1.0),
                num(5).clamp(0.0, 1.0),
            );
            let s = uv.eval(at)?;
            Ok(format!("{l} {:?} {:?}", s.st[0], s.st[1]))
        })
        .collect()
}

/// The output line of a diced hit or miss.
fn diced_line(h: Option<&crate::bvh::Hit>, scheme: Scheme) -> String {
    match h {
        None => "miss".into(),
        Some(h) if scheme == Scheme::Loop => {
            // A Loop triangle is diced as three sub-quads: report the triangle's own (u, v).
            let ([u, v], _) = LoopSurface::sub_quad_uv(h.k as usize, h.u as f64, h.v as f64);
            format!(
                "hit {:?} {} 0 {:?} {:?} {:?} {:?} {:?}",
                h.t, h.face, u, v, h.ns[0], h.ns[1], h.ns[2]
            )
        }
        Some(h) => format!(
            "hit {:?} {} {} {:?} {:?} {:?} {:?} {:?}",
            h.t, h.face, h.k, h.u, h.v, h.ns[0], h.ns[1], h.ns[2]
        ),
    }
}

/// The output line of the reference intersector's answer: `hit t face k u v nx ny nz err
/// sharp grazing` (reals with 17 significant digits, flags 0 or 1), `miss` (certain) or
/// `miss graze ERR` (the ray comes within ERR of the surface, relative to the diagonal,
/// where no crossing could be decided).
pub fn exact_line(x: &ExactTrace) -> String {
    match (&x.hit, x.graze) {
        (Some(h), _) => format!(
            "hit {:.16e} {} {} {:.16e} {:.16e} {:.16e} {:.16e} {:.16e} {:.3e} {} {}",
            h.t,
            h.face,
            h.k,
            h.u,
            h.v,
            h.n[0],
            h.n[1],
            h.n[2],
            h.err,
            h.sharp as u8,
            h.grazing as u8
        ),
        (None, Some(g)) => format!("miss graze {g:.3e}"),
        (None, None) => "miss".into(),
    }
}

/// Reads rays from `input` and writes one line per input line: `hit t face k u v nx ny nz`
/// (the normal is the limit-surface shading normal), `miss`, or nine `nan` fields for a bad
/// line, invalid UTF-8 included (with `stdin:LINE: …` on stderr and an error at the end).
/// Input is read and answered in batches of [`TRACE_BATCH`] lines, so memory does not grow
/// with the input.
pub fn trace(bvh: &GridMesh, input: impl BufRead, output: impl Write) -> Result<()> {
    trace_scheme(bvh, Scheme::Catmark, input, output)
}

/// [`trace`] of a mesh subdivided with `scheme`: under Loop, hits report the triangle's
/// `(u, v)` (and `k` = 0) instead of its sub-quad's.
pub fn trace_scheme(
    bvh: &GridMesh,
    scheme: Scheme,
    input: impl BufRead,
    output: impl Write,
) -> Result<()> {
    trace_with(input, output, |rays| {
        let f32_rays: Vec<Ray> = rays.iter().map(|r| r.0).collect();
        Ok(bvh
            .intersect_batch(&f32_rays)
            .iter()
            .map(|h| diced_line(h.as_ref(), scheme))
            .collect())
    })
}

/// [`trace`] with the reference intersector: the rays as given in `f64`, each answered by
/// [`exact_line`].
pub fn trace_exact(tracer: &ExactTracer, input: impl BufRead, output: impl Write) -> Result<()> {
    trace_lines(input, output, true, |rays| {
        let r64: Vec<Ray64> = rays.iter().map(|r| r.1).collect();
        Ok(tracer.trace_batch(&r64).iter().map(exact_line).collect())
    })
}

/// Lines answered per batch by [`trace`].
pub const TRACE_BATCH: usize = 1 << 16;

/// A parsed input line: blank, a ray (its `f32` rounding and itself), or why it is bad.
type Parsed = std::result::Result<Option<(Ray, Ray64)>, String>;

/// [`trace`] with the answer lines of the parsed rays computed by `answer` (one line per ray,
/// in order, called once per batch): the GPU backend plugs in here.
pub fn trace_with(
    input: impl BufRead,
    output: impl Write,
    answer: impl FnMut(&[(Ray, Ray64)]) -> Result<Vec<String>>,
) -> Result<()> {
    trace_lines(input, output, false, answer)
}

fn trace_lines(
    input: impl BufRead,
    mut output: impl Write,
    exact: bool,
    mut lines_of: impl FnMut(&[(Ray, Ray64)]) -> Result<Vec<String>>,
) -> Result<()> {
    let io = |e: std::io::Error| Error::new(ErrorKind::Io, e.to_string());
    let mut bad = 0;
    let mut batch: Vec<(usize, Parsed)> = Vec::new();
    let mut answer = |batch: &mut Vec<(usize, Parsed)>, output: &mut dyn Write| -> Result<()> {
        let rays: Vec<(Ray, Ray64)> = batch
            .iter()
            .filter_map(|(_, p)| p.as_ref().ok().copied().flatten())
            .collect();
        let results = lines_of(&rays)?;
        if results.len() != rays.len() {
            return Err(Error::new(ErrorKind::Usage, "one answer per ray expected"));
        }
        let mut next = results.into_iter();
        for (number, p) in batch.drain(..) {
            match p {
                Ok(None) => writeln!(output).map_err(io)?,
                Err(m) => {
                    bad += 1;
                    eprintln!("stdin:{number}: {m}");
                    writeln!(output, "nan nan nan nan nan nan nan nan nan").map_err(io)?;
                }
                Ok(Some(_)) => {
                    let line = next.next().expect("one answer per ray");
                    writeln!(output, "{line}").map_err(io)?;
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
            Ok(l) => parse_ray(&l, exact).map(Some),
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
