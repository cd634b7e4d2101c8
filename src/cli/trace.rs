//! `limitray trace`: line-oriented ray queries (`ox oy oz dx dy dz` in, `hit t face k u v nx ny
//! nz` (plus a refined flag with `--exact`) or `miss` out) on the CPU or, with `--backend gpu`, on a Vulkan adapter.

use super::args::{load, DiceArgs, RuleArgs};
use super::dice::dice_mesh;
use crate::bvh::exact::refine_hit;
use crate::bvh::{MeshBvh, Ray, Ray64};
use crate::error::{Error, ErrorKind, Result};
use crate::patch::PatchTable;
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
    /// Refine each hit onto the exact limit surface (Newton, f64).
    #[arg(long)]
    pub exact: bool,
    #[command(flatten)]
    pub backend: BackendArgs,
}

/// Runs `limitray trace` on standard input and output.
pub fn run(args: &TraceCmd) -> Result<()> {
    let m = load(&args.mesh)?;
    let (table, d) = dice_mesh(&m, args.rules.options(&m), &args.dice)?;
    let bvh = MeshBvh::build(d);
    let (input, output) = (std::io::stdin().lock(), std::io::stdout().lock());
    match args.backend.backend {
        Backend::Cpu => trace(&bvh, &table, args.exact, input, output),
        #[cfg(feature = "gpu")]
        Backend::Gpu => {
            let ctx = crate::gpu::GpuContext::new(args.backend.adapter.as_deref())?;
            trace_with(&table, args.exact, input, output, |rays| {
                crate::gpu::trace_mesh(&ctx, &bvh, rays, crate::gpu::TraceOptions::default())
            })
        }
        #[cfg(not(feature = "gpu"))]
        Backend::Gpu => Err(Error::new(
            ErrorKind::Usage,
            "this limitray was built without the `gpu` feature",
        )),
    }
}

/// A ray line `ox oy oz dx dy dz`: its `f32` rounding (for the diced mesh's BVH; each number
/// parsed to `f32` directly, so that it is the correctly rounded value) and the ray as given
/// in `f64` (for the exact intersector). Every number must be finite in `f32`.
fn parse_ray(line: &str) -> std::result::Result<(Ray, Ray64), String> {
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
        x[i] = t
            .parse::<f32>()
            .ok()
            .filter(|v| v.is_finite())
            .ok_or_else(bad)?;
        x64[i] = t.parse::<f64>().map_err(|_| bad())?;
    }
    if x[3] == 0.0 && x[4] == 0.0 && x[5] == 0.0 {
        return Err("ray direction is zero".into());
    }
    Ok((
        Ray::new([x[0], x[1], x[2]], [x[3], x[4], x[5]]),
        Ray64::new([x64[0], x64[1], x64[2]], [x64[3], x64[4], x64[5]]),
    ))
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

/// A parsed input line: blank, a ray (its `f32` rounding and itself), or why it is bad.
type Parsed = std::result::Result<Option<(Ray, Ray64)>, String>;

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
        let rays: Vec<(Ray, Ray64)> = batch
            .iter()
            .filter_map(|(_, p)| p.as_ref().ok().copied().flatten())
            .collect();
        let f32_rays: Vec<Ray> = rays.iter().map(|r| r.0).collect();
        let results = hits(&f32_rays)?;
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
                    match exact.then(|| refine_hit(table, &ray.1, &h)) {
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
