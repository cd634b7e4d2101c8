//! The line-oriented `limitray eval` tool: `face u v` or `face k u v` in, nine numbers out.
//! Under `--scheme loop` every face is one triangle and `u v` is OpenSubdiv's triangle
//! parameter (`u, v ≥ 0`, `u + v ≤ 1`).

use super::args::{load, RuleArgs, SurfaceArg};
use crate::coord::FaceCoord;
use crate::error::{Error, ErrorKind, Result};
use crate::mesh::Scheme;
use crate::patch::{PatchOptions, PatchTable, Sample};
use std::io::{BufRead, Write};
use std::path::PathBuf;

/// Arguments of `limitray eval`.
#[derive(clap::Args, Clone, Debug)]
pub struct EvalCmd {
    /// OBJ file with OpenSubdiv tags.
    pub mesh: PathBuf,
    #[command(flatten)]
    pub rules: RuleArgs,
    /// Maximum isolation level of the patch table.
    #[arg(long, default_value_t = crate::patch::table::DEFAULT_MAX_LEVEL)]
    pub max_level: usize,
    /// The surface of a Loop mesh: exact, or paper 002's pn, wm or gregory approximation.
    #[arg(long, value_enum, default_value_t = SurfaceArg::Exact)]
    pub surface: SurfaceArg,
}

/// Runs `limitray eval` on standard input and output.
pub fn run_cmd(args: &EvalCmd) -> Result<()> {
    let m = load(&args.mesh)?;
    let options = args.rules.options(&m);
    let (stdin, stdout) = (std::io::stdin().lock(), std::io::stdout().lock());
    let table = PatchTable::with_options(
        &m,
        options,
        PatchOptions {
            max_level: args.max_level,
            surface: args.surface.into(),
            ..PatchOptions::default()
        },
    )?;
    if options.scheme == Scheme::Loop {
        return run(|at| table.eval_triangle(at), stdin, stdout);
    }
    run(|at| table.eval(at), stdin, stdout)
}

fn parse_sample(line: &str) -> std::result::Result<FaceCoord, String> {
    let toks: Vec<&str> = line.split_whitespace().collect();
    let int = |t: &str| t.parse::<u32>().map_err(|_| format!("invalid index '{t}'"));
    let num = |t: &str| {
        t.parse::<f64>()
            .ok()
            .filter(|x| x.is_finite())
            .ok_or_else(|| format!("invalid parameter '{t}'"))
    };
    match toks.len() {
        3 => Ok(FaceCoord::quad(int(toks[0])?, num(toks[1])?, num(toks[2])?)),
        4 => Ok(FaceCoord::new(
            int(toks[0])?,
            int(toks[1])?,
            num(toks[2])?,
            num(toks[3])?,
        )),
        n => Err(format!(
            "expected 'face u v' or 'face k u v', found {n} fields"
        )),
    }
}

/// Reads samples from `input`, writes one line per input line to `output` (nine `nan` for a bad
/// sample, invalid UTF-8 included, with a `stdin:LINE:` message on stderr). Streams: one line
/// in memory at a time ([`crate::lines`]). Returns an error at the end if any line was bad.
pub fn run(
    eval: impl Fn(FaceCoord) -> Result<Sample>,
    input: impl BufRead,
    mut output: impl Write,
) -> Result<()> {
    let mut bad = 0usize;
    let io = |e: std::io::Error| Error::new(ErrorKind::Io, e.to_string());
    for item in crate::lines::lines(input) {
        let (number, line) = item.map_err(io)?;
        if line.as_ref().is_ok_and(|l| l.trim().is_empty()) {
            writeln!(output).map_err(io)?;
            continue;
        }
        let res = line
            .and_then(|l| parse_sample(&l))
            .map_err(|m| Error::new(ErrorKind::Parse, m))
            .and_then(&eval);
        match res {
            Ok(s) => {
                let f = |x: f64| format!("{x:?}");
                writeln!(
                    output,
                    "{} {} {} {} {} {} {} {} {}",
                    f(s.p[0]),
                    f(s.p[1]),
                    f(s.p[2]),
                    f(s.du[0]),
                    f(s.du[1]),
                    f(s.du[2]),
                    f(s.dv[0]),
                    f(s.dv[1]),
                    f(s.dv[2])
                )
                .map_err(io)?;
            }
            Err(e) => {
                bad += 1;
                eprintln!("stdin:{number}: {e}");
                writeln!(output, "nan nan nan nan nan nan nan nan nan").map_err(io)?;
            }
        }
    }
    output.flush().map_err(io)?;
    if bad > 0 {
        return Err(
            Error::new(ErrorKind::Parse, format!("{bad} invalid sample line(s)")).in_file("stdin"),
        );
    }
    Ok(())
}
