//! Wavefront OBJ reading and writing with OpenSubdiv's tag syntax.
//!
//! # What is read
//!
//! * `v x y z [w]`: a position (`w` and any further components are ignored).
//! * `vt u [v [w]]`: a texture coordinate, kept in [`ControlMesh::uvs`] (`v` defaults to 0).
//! * `vn x y z`: accepted and ignored.
//! * `f a b c …`: a face of any number of corners, each `v`, `v/vt`, `v//vn` or `v/vt/vn`.
//!   Indices are 1-based; negative indices count back from the last `v` (or `vt`, `vn`) read
//!   so far (`-1` is the latest). Texture indices are kept in [`ControlMesh::face_uvs`] only
//!   when every face-vertex of the file has one.
//! * `t NAME nint/nfloat[/nstring] ints… floats… strings…`: OpenSubdiv's tags, with 0-based
//!   vertex and face indices: `crease` (the ints are pairs of vertices; one sharpness for all
//!   pairs or one per pair), `corner`, `hole`, `interpolateboundary` (0 none, 1 edge and
//!   corner, 2 edge only), `creasemethod` (`chaikin`, `normal` or `uniform`) and
//!   `smoothtriangles` (`smooth` or `catmark`, see [`crate::mesh::Options::smooth_triangles`]).
//!   The hierarchical edits `vertexedit` (positions, vertex sharpness), `edgeedit` (edge
//!   sharpness) and `faceedit` (holes) are read into [`ControlMesh::edits`] (see
//!   [`super::edit`]); the face-varying tags are recognised and ignored with a warning.
//! * `ec s a b`: Embree's edge-crease extension: sharpness `s` on the edge between vertices `a`
//!   and `b`, which are 1-based like `f` indices (negative ones relative to the vertices read
//!   so far).
//! * `o`, `g`, `s`, `usemtl` and `mtllib` are ignored; other statements are ignored with a
//!   warning. `#` starts a comment anywhere on a line. A UTF-8 byte-order mark at the start
//!   is skipped.
//!
//! A crease or corner tag that repeats an edge or vertex already tagged gives a warning;
//! the later sharpness is used, as OpenSubdiv (which sets the sharpness tag by tag) does.
//!
//! Text that is not an OBJ file is an error rather than an empty mesh: a NUL byte (binary
//! data), no `v` and no `f` statement at all, more statements that are not OBJ keywords than
//! statements that are, or no face.
//!
//! Sharpness values at or above [`super::SHARPNESS_INFINITE`] are infinitely sharp; they are
//! kept as written. Syntax errors are [`ErrorKind::Parse`] errors that name the file, line and
//! statement; the parsed mesh is then checked with [`ControlMesh::validate`], whose errors name
//! the line of the offending element.

use super::{
    BoundaryInterpolation, ControlMesh, CreaseMethod, EdgeCrease, Provenance, VertexCorner,
};
use crate::error::{Error, ErrorKind, Result};
use std::collections::HashMap;
use std::io::Write;
use std::path::Path;

/// How many warnings one kind of ignored statement may produce before further ones are only
/// counted.
const WARNINGS_PER_KIND: usize = 5;

/// Statements of the OBJ format (free-form geometry, display and grouping) that are not read
/// but make a file recognisably OBJ.
const OTHER_OBJ_KEYWORDS: [&str; 28] = [
    "l",
    "p",
    "vp",
    "cstype",
    "deg",
    "bmat",
    "step",
    "curv",
    "curv2",
    "surf",
    "parm",
    "trim",
    "hole",
    "scrv",
    "sp",
    "end",
    "con",
    "mg",
    "lod",
    "usemap",
    "maplib",
    "shadow_obj",
    "trace_obj",
    "ctech",
    "stech",
    "bevel",
    "c_interp",
    "d_interp",
];

/// Longest token quoted in a message, in characters.
const QUOTE_CHARS: usize = 40;

/// Parses OBJ text. `file` names the source in error messages and warnings.
///
/// See the [module documentation](self) for the statements understood. The result has been
/// checked with [`ControlMesh::validate`].
pub fn parse_obj(text: &str, file: Option<&str>) -> Result<ControlMesh> {
    let mut p = Parser::new(file);
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    if let Some(k) = text.find('\0') {
        let line = text[..k].matches('\n').count() + 1;
        return Err(p.err(
            line,
            "file",
            "contains a NUL byte: this is binary data, not an OBJ file",
        ));
    }
    for (i, raw) in text.lines().enumerate() {
        let line = i.saturating_add(1);
        let content = match raw.find('#') {
            Some(k) => &raw[..k],
            None => raw,
        };
        let tokens: Vec<&str> = content.split_whitespace().collect();
        if let Some((&keyword, args)) = tokens.split_first() {
            p.statement(line, keyword, args)?;
        }
    }
    let mesh = p.finish()?;
    mesh.validate()?;
    Ok(mesh)
}

/// Reads and parses an OBJ file.
pub fn read_obj(path: &Path) -> Result<ControlMesh> {
    let name = path.display().to_string();
    let bytes = std::fs::read(path)
        .map_err(|e| Error::new(ErrorKind::Io, e.to_string()).in_file(name.clone()))?;
    // Bytes that are not UTF-8 (Latin-1 comments, binary data) become U+FFFD; in a statement
    // they then fail as unknown keywords or invalid numbers, with their line.
    let text = String::from_utf8_lossy(&bytes);
    parse_obj(&text, Some(&name))
}

/// Writes positions and faces as OBJ: one `v` line per position, with each coordinate written
/// in the shortest form that reads back to the same `f64`, and one `f` line per face with
/// 1-based indices. `face_offsets[f]..face_offsets[f + 1]` indexes `face_verts` for face `f`.
///
/// Offsets that decrease or run past `face_verts` give an [`std::io::ErrorKind::InvalidInput`]
/// error.
pub fn write_obj<W: Write + ?Sized>(
    w: &mut W,
    positions: &[[f64; 3]],
    face_offsets: &[u32],
    face_verts: &[u32],
) -> std::io::Result<()> {
    let mut o = ObjWriter::new(w);
    o.vertices("v", positions)?;
    o.faces(face_offsets, face_verts, false)
}

/// The one OBJ writer: statements in OBJ's order (comments, vertex data, faces, tags), numbers
/// in the shortest form that reads back to the same value (`{:?}`), indices 1-based.
pub struct ObjWriter<'a, W: Write + ?Sized> {
    w: &'a mut W,
}

impl<'a, W: Write + ?Sized> ObjWriter<'a, W> {
    /// A writer over `w`.
    pub fn new(w: &'a mut W) -> Self {
        ObjWriter { w }
    }

    /// One `# line` comment per line of `text`.
    pub fn comment(&mut self, text: &str) -> std::io::Result<()> {
        for line in text.lines() {
            writeln!(self.w, "# {line}")?;
        }
        Ok(())
    }

    /// One `tag x y …` line per row (`v`, `vn`, `vt`).
    pub fn vertices<T: std::fmt::Debug, const N: usize>(
        &mut self,
        tag: &str,
        rows: &[[T; N]],
    ) -> std::io::Result<()> {
        for r in rows {
            self.w.write_all(tag.as_bytes())?;
            for x in r {
                write!(self.w, " {x:?}")?;
            }
            self.w.write_all(b"\n")?;
        }
        Ok(())
    }

    /// One `f` line per face: `face_offsets[f]..face_offsets[f + 1]` indexes `face_verts`.
    /// With `attributes`, each corner is written `i/i/i` (texture coordinate and normal of the
    /// same index as the vertex). Offsets that decrease or run past `face_verts` give an
    /// [`std::io::ErrorKind::InvalidInput`] error.
    pub fn faces(
        &mut self,
        face_offsets: &[u32],
        face_verts: &[u32],
        attributes: bool,
    ) -> std::io::Result<()> {
        for pair in face_offsets.windows(2) {
            let (a, b) = (pair[0] as usize, pair[1] as usize);
            let face = face_verts.get(a..b).ok_or_else(|| {
                std::io::Error::new(
                    std::io::ErrorKind::InvalidInput,
                    format!(
                        "face offsets {a}..{b} do not fit {} face-vertices",
                        face_verts.len()
                    ),
                )
            })?;
            self.w.write_all(b"f")?;
            for &v in face {
                let i = u64::from(v) + 1;
                if attributes {
                    write!(self.w, " {i}/{i}/{i}")?;
                } else {
                    write!(self.w, " {i}")?;
                }
            }
            self.w.write_all(b"\n")?;
        }
        Ok(())
    }

    /// One `f v/vt …` line per face, with `face_uvs` (parallel to `face_verts`) the texture
    /// coordinate of each corner. Offsets as in [`Self::faces`].
    pub fn faces_with_uvs(
        &mut self,
        face_offsets: &[u32],
        face_verts: &[u32],
        face_uvs: &[u32],
    ) -> std::io::Result<()> {
        if face_uvs.len() != face_verts.len() {
            return Err(std::io::Error::new(
                std::io::ErrorKind::InvalidInput,
                format!(
                    "{} texture corners for {} face-vertices",
                    face_uvs.len(),
                    face_verts.len()
                ),
            ));
        }
        for pair in face_offsets.windows(2) {
            let (a, b) = (pair[0] as usize, pair[1] as usize);
            let (Some(vs), Some(ts)) = (face_verts.get(a..b), face_uvs.get(a..b)) else {
                return Err(std::io::Error::new(
                    std::io::ErrorKind::InvalidInput,
                    format!(
                        "face offsets {a}..{b} do not fit {} face-vertices",
                        face_verts.len()
                    ),
                ));
            };
            self.w.write_all(b"f")?;
            for (&v, &t) in vs.iter().zip(ts) {
                write!(self.w, " {}/{}", u64::from(v) + 1, u64::from(t) + 1)?;
            }
            self.w.write_all(b"\n")?;
        }
        Ok(())
    }

    /// OpenSubdiv's tags of `m`: `t crease 2/1 a b s`, `t corner 1/1 v s`, `t hole 1/0 f`.
    pub fn tags(&mut self, m: &ControlMesh) -> std::io::Result<()> {
        for c in &m.creases {
            writeln!(self.w, "t crease 2/1 {} {} {:?}", c.v0, c.v1, c.sharpness)?;
        }
        for c in &m.corners {
            writeln!(self.w, "t corner 1/1 {} {:?}", c.vertex, c.sharpness)?;
        }
        for h in &m.holes {
            writeln!(self.w, "t hole 1/0 {h}")?;
        }
        for e in &m.edits {
            self.edit(e)?;
        }
        Ok(())
    }

    /// One hierarchical edit as a tag of its own (`t vertexedit`, `edgeedit` or `faceedit`;
    /// see [`super::edit`]).
    fn edit(&mut self, e: &super::HierarchicalEdit) -> std::io::Result<()> {
        use super::{EditKind, EditOp};
        let op = |op: EditOp| match op {
            EditOp::Set => "set",
            EditOp::Add => "add",
            EditOp::Subtract => "subtract",
        };
        let mut path: Vec<u32> = vec![e.face];
        path.extend(&e.path);
        path.extend(e.element());
        let (name, floats, strings): (&str, Vec<f64>, String) = match e.kind {
            EditKind::Position { op: o, value, .. } => {
                ("vertexedit", value.to_vec(), format!("{} P value", op(o)))
            }
            EditKind::VertexSharpness { op: o, value, .. } => (
                "vertexedit",
                vec![value as f64],
                format!("{} P sharpness", op(o)),
            ),
            EditKind::EdgeSharpness { op: o, value, .. } => (
                "edgeedit",
                vec![value as f64],
                format!("{} P sharpness", op(o)),
            ),
            EditKind::Hole => ("faceedit", Vec::new(), "hole".to_string()),
        };
        write!(
            self.w,
            "t {name} {}/{}/{} {}",
            path.len() + 1,
            floats.len(),
            strings.split(' ').count(),
            path.len()
        )?;
        for i in &path {
            write!(self.w, " {i}")?;
        }
        for x in &floats {
            write!(self.w, " {x:?}")?;
        }
        writeln!(self.w, " {strings}")
    }
}

/// A token for a message: quoted, and shortened when long.
fn quote(token: &str) -> String {
    let mut chars = token.chars();
    let head: String = chars.by_ref().take(QUOTE_CHARS).collect();
    if chars.next().is_some() {
        format!("'{head}…'")
    } else {
        format!("'{head}'")
    }
}

/// What an OBJ index refers to, for resolving and for messages.
#[derive(Clone, Copy)]
enum IndexKind {
    Vertex,
    Texture,
    Normal,
}

impl IndexKind {
    fn noun(self) -> &'static str {
        match self {
            IndexKind::Vertex => "vertex",
            IndexKind::Texture => "texture",
            IndexKind::Normal => "normal",
        }
    }
}

/// Parser state: what has been read so far.
struct Parser {
    file: Option<String>,
    mesh: ControlMesh,
    /// Number of `vn` lines read.
    normals: usize,
    /// Face-vertices read with a texture index, and without.
    with_uv: usize,
    without_uv: usize,
    /// Line of the first face-vertex with a texture index, and of the first without.
    first_with_uv: Option<usize>,
    first_without_uv: Option<usize>,
    /// Whether a `v` line with more than four numbers has been warned about.
    extra_components_warned: bool,
    /// How many statements of each ignored kind were met so far.
    ignored: HashMap<String, usize>,
    /// Statements with an OBJ keyword, and without (with the line and keyword of the first).
    known: usize,
    unknown: usize,
    first_unknown: Option<(usize, String)>,
    /// Edges (lower vertex first) and vertices already tagged: entry index and line.
    creased: HashMap<(u32, u32), (usize, usize)>,
    cornered: HashMap<u32, (usize, usize)>,
}

impl Parser {
    fn new(file: Option<&str>) -> Self {
        let mut mesh = ControlMesh {
            face_offsets: vec![0],
            ..ControlMesh::default()
        };
        mesh.provenance = Provenance {
            file: file.map(str::to_string),
            ..Provenance::default()
        };
        Parser {
            file: file.map(str::to_string),
            mesh,
            normals: 0,
            with_uv: 0,
            without_uv: 0,
            first_with_uv: None,
            first_without_uv: None,
            extra_components_warned: false,
            ignored: HashMap::new(),
            known: 0,
            unknown: 0,
            first_unknown: None,
            creased: HashMap::new(),
            cornered: HashMap::new(),
        }
    }

    /// A parse error at `line` in statement `element`.
    fn err(&self, line: usize, element: &str, message: impl Into<String>) -> Error {
        let mut e = Error::new(ErrorKind::Parse, message)
            .at_line(line)
            .element(element);
        if let Some(f) = &self.file {
            e = e.in_file(f.clone());
        }
        e
    }

    /// `file:line: ` (or `line N: `) for warnings.
    fn loc(&self, line: usize) -> String {
        match &self.file {
            Some(f) => format!("{f}:{line}: "),
            None => format!("line {line}: "),
        }
    }

    fn warn(&mut self, line: usize, message: impl AsRef<str>) {
        let w = format!("{}{}", self.loc(line), message.as_ref());
        self.mesh.warnings.push(w);
    }

    /// Warns about an ignored statement, at most [`WARNINGS_PER_KIND`] times per kind.
    fn warn_ignored(&mut self, line: usize, kind: &str, message: impl AsRef<str>) {
        let n = self.ignored.entry(kind.to_string()).or_insert(0);
        *n += 1;
        if *n <= WARNINGS_PER_KIND {
            self.warn(line, message);
        }
    }

    /// 1-based line number as stored in the provenance.
    fn line32(&self, line: usize, element: &str) -> Result<u32> {
        u32::try_from(line).map_err(|_| self.err(line, element, "too many lines in the file"))
    }

    fn statement(&mut self, line: usize, keyword: &str, args: &[&str]) -> Result<()> {
        let is_obj = matches!(
            keyword,
            "v" | "vt" | "vn" | "f" | "t" | "ec" | "o" | "g" | "s" | "usemtl" | "mtllib"
        ) || OTHER_OBJ_KEYWORDS.contains(&keyword);
        if is_obj {
            self.known += 1;
        } else {
            self.unknown += 1;
            if self.first_unknown.is_none() {
                self.first_unknown = Some((line, keyword.to_string()));
            }
        }
        match keyword {
            "v" => self.vertex(line, args),
            "vt" => self.texcoord(line, args),
            "vn" => self.normal(line, args),
            "f" => self.face(line, args),
            "t" => self.tag(line, args),
            "ec" => self.edge_crease(line, args),
            "o" | "g" | "s" | "usemtl" | "mtllib" => Ok(()),
            _ => {
                let msg = format!("unknown statement {} ignored", quote(keyword));
                self.warn_ignored(line, keyword, msg);
                Ok(())
            }
        }
    }

    /// Parses a finite floating-point number.
    fn number(&self, line: usize, element: &str, token: &str) -> Result<f64> {
        let x: f64 = token
            .parse()
            .map_err(|_| self.err(line, element, format!("invalid number {}", quote(token))))?;
        if !x.is_finite() {
            return Err(self.err(
                line,
                element,
                format!("number {} is not finite", quote(token)),
            ));
        }
        Ok(x)
    }

    /// Parses all of `args` as finite numbers; there must be at least `min` of them.
    fn numbers(&self, line: usize, element: &str, args: &[&str], min: usize) -> Result<Vec<f64>> {
        if args.len() < min {
            return Err(self.err(
                line,
                element,
                format!("expected {min} numbers, found {}", args.len()),
            ));
        }
        args.iter().map(|t| self.number(line, element, t)).collect()
    }

    fn vertex(&mut self, line: usize, args: &[&str]) -> Result<()> {
        let xs = self.numbers(line, "v", args, 3)?;
        if xs.len() > 4 && !self.extra_components_warned {
            self.extra_components_warned = true;
            self.warn(
                line,
                format!(
                    "v: {} numbers given; only the first 3 are used (further such lines not reported)",
                    xs.len()
                ),
            );
        }
        let l = self.line32(line, "v")?;
        self.mesh.positions.push([xs[0], xs[1], xs[2]]);
        self.mesh.provenance.vertex_lines.push(l);
        Ok(())
    }

    fn texcoord(&mut self, line: usize, args: &[&str]) -> Result<()> {
        let xs = self.numbers(line, "vt", args, 1)?;
        if xs.len() > 3 {
            return Err(self.err(
                line,
                "vt",
                format!("expected at most 3 numbers, found {}", xs.len()),
            ));
        }
        self.mesh
            .uvs
            .push([xs[0], xs.get(1).copied().unwrap_or(0.0)]);
        Ok(())
    }

    fn normal(&mut self, line: usize, args: &[&str]) -> Result<()> {
        let xs = self.numbers(line, "vn", args, 3)?;
        if xs.len() > 3 {
            return Err(self.err(
                line,
                "vn",
                format!("expected 3 numbers, found {}", xs.len()),
            ));
        }
        self.normals += 1;
        Ok(())
    }

    /// Resolves a 1-based (or negative, relative) OBJ index to a 0-based one. Positive indices
    /// past the elements read so far are kept; [`ControlMesh::validate`] checks the range.
    fn obj_index(&self, line: usize, element: &str, token: &str, kind: IndexKind) -> Result<u32> {
        let count = match kind {
            IndexKind::Vertex => self.mesh.positions.len(),
            IndexKind::Texture => self.mesh.uvs.len(),
            IndexKind::Normal => self.normals,
        };
        let noun = kind.noun();
        let i: i64 = token.parse().map_err(|_| {
            self.err(
                line,
                element,
                format!("invalid {noun} index {}", quote(token)),
            )
        })?;
        if i == 0 {
            return Err(self.err(
                line,
                element,
                format!("{noun} index 0 is invalid (OBJ indices start at 1)"),
            ));
        }
        let resolved = if i > 0 {
            i - 1
        } else {
            let c = i64::try_from(count).unwrap_or(i64::MAX);
            let r = c.saturating_add(i);
            if r < 0 {
                let what = match kind {
                    IndexKind::Vertex => "vertex",
                    IndexKind::Texture => "texture coordinate",
                    IndexKind::Normal => "normal",
                };
                return Err(self.err(
                    line,
                    element,
                    format!(
                        "relative index {i} refers before the first {what} ({count} read so far)"
                    ),
                ));
            }
            r
        };
        u32::try_from(resolved)
            .map_err(|_| self.err(line, element, format!("{noun} index {i} is too large")))
    }

    fn face(&mut self, line: usize, args: &[&str]) -> Result<()> {
        if args.is_empty() {
            return Err(self.err(line, "f", "face has no vertices"));
        }
        let l = self.line32(line, "f")?;
        let mut verts = Vec::with_capacity(args.len());
        let mut uvs = Vec::with_capacity(args.len());
        let mut missing_uv = 0usize;
        for token in args {
            let mut parts = token.split('/');
            let v = parts.next().unwrap_or("");
            let t = parts.next();
            let n = parts.next();
            if parts.next().is_some() {
                return Err(self.err(
                    line,
                    "f",
                    format!(
                        "face-vertex {} has more than 3 parts (expected v, v/vt, v//vn or v/vt/vn)",
                        quote(token)
                    ),
                ));
            }
            if v.is_empty() {
                return Err(self.err(
                    line,
                    "f",
                    format!("face-vertex {} has no vertex index", quote(token)),
                ));
            }
            verts.push(self.obj_index(line, "f", v, IndexKind::Vertex)?);
            match t {
                Some("") if n.is_none() => {
                    return Err(self.err(
                        line,
                        "f",
                        format!("face-vertex {} has an empty texture index", quote(token)),
                    ));
                }
                Some("") | None => missing_uv += 1,
                Some(t) => uvs.push(self.obj_index(line, "f", t, IndexKind::Texture)?),
            }
            if let Some(n) = n {
                if n.is_empty() {
                    return Err(self.err(
                        line,
                        "f",
                        format!("face-vertex {} has an empty normal index", quote(token)),
                    ));
                }
                self.obj_index(line, "f", n, IndexKind::Normal)?;
            }
        }
        let total = self.mesh.face_verts.len().saturating_add(verts.len());
        let end =
            u32::try_from(total).map_err(|_| self.err(line, "f", "too many face-vertices"))?;
        if !uvs.is_empty() {
            self.first_with_uv.get_or_insert(line);
        }
        if missing_uv > 0 {
            self.first_without_uv.get_or_insert(line);
        }
        self.with_uv += uvs.len();
        self.without_uv += missing_uv;
        self.mesh.face_verts.extend_from_slice(&verts);
        self.mesh.face_uvs.extend_from_slice(&uvs);
        self.mesh.face_offsets.push(end);
        self.mesh.provenance.face_lines.push(l);
        Ok(())
    }

    /// Parses a sharpness: a number that is not negative and not NaN (infinity is allowed).
    fn sharpness(&self, line: usize, element: &str, token: &str) -> Result<f32> {
        let s: f32 = token
            .parse()
            .map_err(|_| self.err(line, element, format!("invalid number {}", quote(token))))?;
        if s.is_nan() || s < 0.0 {
            return Err(self.err(
                line,
                element,
                format!("sharpness {} is invalid (must be ≥ 0)", quote(token)),
            ));
        }
        Ok(s)
    }

    /// Parses a 0-based index of a tag.
    fn tag_index(&self, line: usize, element: &str, token: &str, noun: &str) -> Result<u32> {
        let i: i64 = token.parse().map_err(|_| {
            self.err(
                line,
                element,
                format!("invalid {noun} index {}", quote(token)),
            )
        })?;
        if i < 0 {
            return Err(self.err(
                line,
                element,
                format!("{noun} index {i} is negative (tag indices are 0-based)"),
            ));
        }
        u32::try_from(i)
            .map_err(|_| self.err(line, element, format!("{noun} index {i} is too large")))
    }

    fn tag(&mut self, line: usize, args: &[&str]) -> Result<()> {
        let Some((&name, rest)) = args.split_first() else {
            return Err(self.err(line, "t", "missing tag name"));
        };
        let element = format!("tag {name}");
        let el = element.as_str();
        let Some((&counts, values)) = rest.split_first() else {
            return Err(self.err(line, el, "missing count field nint/nfloat[/nstring]"));
        };
        let fields: Vec<&str> = counts.split('/').collect();
        if !(2..=3).contains(&fields.len()) {
            return Err(self.err(
                line,
                el,
                format!(
                    "count field {} is not of the form nint/nfloat[/nstring]",
                    quote(counts)
                ),
            ));
        }
        let mut n = [0usize; 3];
        for (k, f) in fields.iter().enumerate() {
            n[k] = f.parse().map_err(|_| {
                self.err(
                    line,
                    el,
                    format!(
                        "invalid count {} in count field {}",
                        quote(f),
                        quote(counts)
                    ),
                )
            })?;
        }
        let [nint, nfloat, nstring] = n;
        let expected = nint
            .checked_add(nfloat)
            .and_then(|s| s.checked_add(nstring));
        if expected != Some(values.len()) {
            return Err(self.err(
                line,
                el,
                format!(
                    "count field {} announces {nint} ints, {nfloat} floats and {nstring} strings, \
                     but {} values follow",
                    quote(counts),
                    values.len()
                ),
            ));
        }
        let (ints, rest) = values.split_at(nint);
        let (floats, strings) = rest.split_at(nfloat);
        match name {
            "crease" => self.tag_crease(line, el, ints, floats, strings),
            "corner" => self.tag_corner(line, el, ints, floats, strings),
            "hole" => self.tag_hole(line, el, ints, floats, strings),
            "interpolateboundary" => {
                self.unused(line, el, &[floats, strings]);
                let [v] = ints else {
                    return Err(self.err(
                        line,
                        el,
                        format!("expected 1 int, found {}", ints.len()),
                    ));
                };
                self.mesh.options.boundary = match v.parse::<i64>() {
                    Ok(0) => BoundaryInterpolation::None,
                    Ok(1) => BoundaryInterpolation::EdgeAndCorner,
                    Ok(2) => BoundaryInterpolation::EdgeOnly,
                    _ => {
                        return Err(self.err(
                            line,
                            el,
                            format!(
                            "invalid value {} (expected 0 none, 1 edge and corner, 2 edge only)",
                            quote(v)
                        ),
                        ))
                    }
                };
                Ok(())
            }
            "creasemethod" => {
                self.unused(line, el, &[ints, floats]);
                let choice = ["chaikin", "normal", "uniform"];
                self.mesh.options.crease_method =
                    match self.one_of(line, el, strings, "crease method", &choice)? {
                        "chaikin" => CreaseMethod::Chaikin,
                        _ => CreaseMethod::Uniform,
                    };
                Ok(())
            }
            "vertexedit" | "edgeedit" | "faceedit" => {
                self.tag_edit(line, el, name, ints, floats, strings)
            }
            "smoothtriangles" => {
                self.unused(line, el, &[ints, floats]);
                let choice = ["smooth", "catmark"];
                self.mesh.options.smooth_triangles =
                    self.one_of(line, el, strings, "triangle rule", &choice)? == "smooth";
                Ok(())
            }
            "facevaryinginterpolateboundary" | "facevaryingpropagatecorners" => {
                let msg = format!("{el}: not supported, ignored");
                self.warn_ignored(line, el, msg);
                Ok(())
            }
            _ => {
                let msg = format!("unknown tag {} ignored", quote(name));
                self.warn_ignored(line, el, msg);
                Ok(())
            }
        }
    }

    /// Warns when a tag carries values it does not use.
    /// The tag's one string argument (unquoted), which must be one of `choice`.
    fn one_of<'a>(
        &self,
        line: usize,
        el: &str,
        strings: &[&'a str],
        what: &str,
        choice: &[&'static str],
    ) -> Result<&'static str> {
        let [s] = strings else {
            return Err(self.err(
                line,
                el,
                format!("expected 1 string, found {}", strings.len()),
            ));
        };
        let s: &'a str = unquote(s);
        choice.iter().copied().find(|&c| c == s).ok_or_else(|| {
            let expected = match choice {
                [a, b] => format!("{a} or {b}"),
                [rest @ .., last] => format!("{} or {last}", rest.join(", ")),
                [] => String::new(),
            };
            self.err(
                line,
                el,
                format!("unknown {what} {} (expected {expected})", quote(s)),
            )
        })
    }

    fn unused(&mut self, line: usize, el: &str, unused: &[&[&str]]) {
        if unused.iter().any(|v| !v.is_empty()) {
            self.warn(line, format!("{el}: unused values ignored"));
        }
    }

    /// Sharpness values of a tag: one for all `n` entries, or one per entry.
    fn tag_sharpness(
        &self,
        line: usize,
        el: &str,
        floats: &[&str],
        n: usize,
        per: &str,
    ) -> Result<Vec<f32>> {
        if floats.len() != 1 && floats.len() != n {
            return Err(self.err(
                line,
                el,
                format!(
                    "expected 1 sharpness for all or one per {per} ({n}), found {}",
                    floats.len()
                ),
            ));
        }
        floats.iter().map(|t| self.sharpness(line, el, t)).collect()
    }

    fn tag_crease(
        &mut self,
        line: usize,
        el: &str,
        ints: &[&str],
        floats: &[&str],
        strings: &[&str],
    ) -> Result<()> {
        self.unused(line, el, &[strings]);
        if ints.is_empty() || !ints.len().is_multiple_of(2) {
            return Err(self.err(
                line,
                el,
                format!(
                    "expected pairs of vertex indices, found {} ints",
                    ints.len()
                ),
            ));
        }
        let pairs = ints.len() / 2;
        let sharp = self.tag_sharpness(line, el, floats, pairs, "pair")?;
        let l = self.line32(line, el)?;
        for (k, pair) in ints.chunks_exact(2).enumerate() {
            let v0 = self.tag_index(line, el, pair[0], "vertex")?;
            let v1 = self.tag_index(line, el, pair[1], "vertex")?;
            let sharpness = if sharp.len() == 1 { sharp[0] } else { sharp[k] };
            self.push_crease(line, el, EdgeCrease { v0, v1, sharpness }, l);
        }
        Ok(())
    }

    /// Adds a crease, warning when its edge is tagged already (the later value is used).
    fn push_crease(&mut self, line: usize, el: &str, c: EdgeCrease, l: u32) {
        let key = (c.v0.min(c.v1), c.v0.max(c.v1));
        let index = self.mesh.creases.len();
        if let Some((earlier, at)) = self.creased.insert(key, (index, line)) {
            let before = self.mesh.creases[earlier].sharpness;
            self.warn(
                line,
                format!(
                    "{el}: the edge between vertices {} and {} (0-based) is already tagged \
                     with sharpness {before} at line {at}; the later sharpness {} is used, \
                     as in OpenSubdiv",
                    key.0, key.1, c.sharpness
                ),
            );
        }
        self.mesh.creases.push(c);
        self.mesh.provenance.crease_lines.push(l);
    }

    fn tag_corner(
        &mut self,
        line: usize,
        el: &str,
        ints: &[&str],
        floats: &[&str],
        strings: &[&str],
    ) -> Result<()> {
        self.unused(line, el, &[strings]);
        if ints.is_empty() {
            return Err(self.err(line, el, "expected at least 1 vertex index, found 0"));
        }
        let sharp = self.tag_sharpness(line, el, floats, ints.len(), "vertex")?;
        let l = self.line32(line, el)?;
        for (k, t) in ints.iter().enumerate() {
            let vertex = self.tag_index(line, el, t, "vertex")?;
            let sharpness = if sharp.len() == 1 { sharp[0] } else { sharp[k] };
            let index = self.mesh.corners.len();
            if let Some((earlier, at)) = self.cornered.insert(vertex, (index, line)) {
                let before = self.mesh.corners[earlier].sharpness;
                self.warn(
                    line,
                    format!(
                        "{el}: vertex {vertex} (0-based) is already tagged with sharpness \
                     {before} at line {at}; the later sharpness {sharpness} is used, as in \
                         OpenSubdiv"
                    ),
                );
            }
            self.mesh.corners.push(VertexCorner { vertex, sharpness });
            self.mesh.provenance.corner_lines.push(l);
        }
        Ok(())
    }

    fn tag_hole(
        &mut self,
        line: usize,
        el: &str,
        ints: &[&str],
        floats: &[&str],
        strings: &[&str],
    ) -> Result<()> {
        self.unused(line, el, &[floats, strings]);
        let l = self.line32(line, el)?;
        for t in ints {
            let face = self.tag_index(line, el, t, "face")?;
            self.mesh.holes.push(face);
            self.mesh.provenance.hole_lines.push(l);
        }
        Ok(())
    }

    /// Hbr's hierarchical edit tags. The ints are paths, each `length face sub… [element]`
    /// where `length` counts the face, the sub-face indices and (for vertex and edge edits)
    /// the corner or edge index. The strings are triples `set|add|subtract VARIABLE value|sharpness`
    /// (`faceedit` takes `hole`); the floats give each path the operations' values in turn
    /// (3 for a position, 1 for a sharpness). Hbr's own files sometimes carry more floats than
    /// the paths use: the first ones are used, as Hbr does, with a warning.
    fn tag_edit(
        &mut self,
        line: usize,
        el: &str,
        name: &str,
        ints: &[&str],
        floats: &[&str],
        strings: &[&str],
    ) -> Result<()> {
        use super::edit::{EditKind, EditOp, HierarchicalEdit};
        let l = self.line32(line, el)?;
        // The paths.
        let mut paths: Vec<(u32, Vec<u32>, Option<u32>)> = Vec::new();
        let mut i = 0;
        while i < ints.len() {
            let len = self.tag_index(line, el, ints[i], "path length")? as usize;
            let has_element = name != "faceedit";
            let min = 1 + has_element as usize;
            if len < min || i + 1 + len > ints.len() {
                return Err(self.err(
                    line,
                    el,
                    format!(
                        "path {} of length {} {}",
                        paths.len() + 1,
                        len,
                        if len < min {
                            format!("is too short (at least {min})")
                        } else {
                            format!("runs past the {} ints", ints.len())
                        }
                    ),
                ));
            }
            let body = &ints[i + 1..i + 1 + len];
            let face = self.tag_index(line, el, body[0], "face")?;
            let subs_end = if has_element { len - 1 } else { len };
            let subs = body[1..subs_end]
                .iter()
                .map(|t| self.tag_index(line, el, t, "sub-face"))
                .collect::<Result<Vec<u32>>>()?;
            let element = if has_element {
                Some(self.tag_index(line, el, body[len - 1], "element")?)
            } else {
                None
            };
            paths.push((face, subs, element));
            i += 1 + len;
        }
        // The operations.
        enum Op {
            Position(EditOp),
            Sharpness(EditOp),
            Hole,
        }
        let mut ops = Vec::new();
        if name == "faceedit" {
            for s in strings {
                match unquote(s) {
                    "hole" => ops.push(Op::Hole),
                    other => {
                        let msg = format!(
                            "{el}: face edit {} ignored (only hole is supported)",
                            quote(other)
                        );
                        self.warn_ignored(line, el, msg);
                    }
                }
            }
        } else {
            if !strings.len().is_multiple_of(3) {
                return Err(self.err(
                    line,
                    el,
                    format!(
                        "expected strings in triples (set|add|subtract, variable, value|sharpness), found {}",
                        strings.len()
                    ),
                ));
            }
            for t in strings.chunks_exact(3) {
                let op = match unquote(t[0]) {
                    "set" => EditOp::Set,
                    "add" => EditOp::Add,
                    "subtract" => EditOp::Subtract,
                    other => {
                        return Err(self.err(
                            line,
                            el,
                            format!(
                                "unknown operation {} (expected set, add or subtract)",
                                quote(other)
                            ),
                        ))
                    }
                };
                let (var, what) = (unquote(t[1]), unquote(t[2]));
                match (name, var, what) {
                    ("vertexedit", "P", "value") => ops.push(Op::Position(op)),
                    (_, _, "sharpness") => ops.push(Op::Sharpness(op)),
                    _ => {
                        // The values' layout depends on a primvar this reader does not know.
                        let msg = format!(
                            "{el}: edits of {} {} are not supported (positions and sharpness \
                             are); the tag is ignored",
                            quote(var),
                            quote(what)
                        );
                        self.warn_ignored(line, el, msg);
                        return Ok(());
                    }
                }
            }
        }
        let width: usize = ops
            .iter()
            .map(|o| match o {
                Op::Position(_) => 3,
                Op::Sharpness(_) => 1,
                Op::Hole => 0,
            })
            .sum();
        let needed = width * paths.len();
        if floats.len() < needed {
            return Err(self.err(
                line,
                el,
                format!(
                    "{} paths with {width} values each need {needed} floats, found {}",
                    paths.len(),
                    floats.len()
                ),
            ));
        }
        if floats.len() > needed {
            self.warn(
                line,
                format!(
                    "{el}: {} floats given, the first {needed} used",
                    floats.len()
                ),
            );
        }
        let values = floats[..needed]
            .iter()
            .map(|t| {
                let x: f64 = t
                    .parse()
                    .map_err(|_| self.err(line, el, format!("invalid number {}", quote(t))))?;
                if x.is_finite() {
                    Ok(x)
                } else {
                    Err(self.err(line, el, format!("value {} is not finite", quote(t))))
                }
            })
            .collect::<Result<Vec<f64>>>()?;
        let mut next = values.iter().copied();
        for (face, path, element) in paths {
            for op in &ops {
                let x = element.unwrap_or(0);
                let kind = match *op {
                    Op::Position(op) => {
                        let value = [(); 3].map(|_| next.next().unwrap_or(0.0));
                        EditKind::Position {
                            corner: x,
                            op,
                            value,
                        }
                    }
                    Op::Sharpness(op) => {
                        let value = next.next().unwrap_or(0.0) as f32;
                        if op == EditOp::Set && value < 0.0 {
                            return Err(self.err(
                                line,
                                el,
                                format!("sharpness {value} is invalid (must be ≥ 0)"),
                            ));
                        }
                        if name == "edgeedit" {
                            EditKind::EdgeSharpness { edge: x, op, value }
                        } else {
                            EditKind::VertexSharpness {
                                corner: x,
                                op,
                                value,
                            }
                        }
                    }
                    Op::Hole => EditKind::Hole,
                };
                self.mesh.edits.push(HierarchicalEdit {
                    face,
                    path: path.clone(),
                    kind,
                });
                self.mesh.provenance.edit_lines.push(l);
            }
        }
        Ok(())
    }

    /// Embree's `ec s a b`: sharpness, then two 1-based (or negative, relative) vertex indices.
    fn edge_crease(&mut self, line: usize, args: &[&str]) -> Result<()> {
        let [s, a, b] = args else {
            return Err(self.err(
                line,
                "ec",
                format!(
                    "expected sharpness and 2 vertex indices (3 values), found {}",
                    args.len()
                ),
            ));
        };
        let sharpness = self.sharpness(line, "ec", s)?;
        let v0 = self.obj_index(line, "ec", a, IndexKind::Vertex)?;
        let v1 = self.obj_index(line, "ec", b, IndexKind::Vertex)?;
        let l = self.line32(line, "ec")?;
        self.push_crease(line, "ec", EdgeCrease { v0, v1, sharpness }, l);
        Ok(())
    }

    /// Refuses text that is not an OBJ mesh (see the module documentation).
    fn check_is_obj(&self) -> Result<()> {
        let unknown = match &self.first_unknown {
            Some((line, k)) => format!(" (the first, at line {line}, is {})", quote(k)),
            None => String::new(),
        };
        let line = self.first_unknown.as_ref().map_or(1, |(l, _)| *l);
        if self.mesh.positions.is_empty() && self.mesh.num_faces() == 0 {
            return Err(self.err(
                line,
                "file",
                format!(
                    "not an OBJ mesh: no 'v' or 'f' statement in {} statements{unknown}",
                    self.known + self.unknown
                ),
            ));
        }
        if self.unknown > self.known {
            return Err(self.err(
                line,
                "file",
                format!(
                    "not an OBJ mesh: {} of {} statements are not OBJ statements{unknown}",
                    self.unknown,
                    self.known + self.unknown
                ),
            ));
        }
        if self.mesh.num_faces() == 0 {
            return Err(self.err(
                self.mesh
                    .provenance
                    .vertex_lines
                    .last()
                    .map_or(1, |&l| l as usize),
                "file",
                format!(
                    "no faces: {} vertices but no 'f' statement, so there is no surface",
                    self.mesh.positions.len()
                ),
            ));
        }
        Ok(())
    }

    fn finish(mut self) -> Result<ControlMesh> {
        self.check_is_obj()?;
        if self.with_uv > 0 && self.without_uv > 0 {
            let line = self.first_without_uv.unwrap_or(0);
            let with = self.first_with_uv.unwrap_or(0);
            self.warn(
                line,
                format!(
                    "f: this face has no texture indices but others do (first at line {with}); \
                     texture indices are ignored",
                ),
            );
            self.mesh.face_uvs.clear();
        }
        let mut kinds: Vec<(String, usize)> = self
            .ignored
            .iter()
            .filter(|(_, &n)| n > WARNINGS_PER_KIND)
            .map(|(k, &n)| (k.clone(), n))
            .collect();
        kinds.sort();
        for (kind, n) in kinds {
            let msg = match &self.file {
                Some(f) => format!(
                    "{f}: {} more '{kind}' statements ignored",
                    n - WARNINGS_PER_KIND
                ),
                None => format!("{} more '{kind}' statements ignored", n - WARNINGS_PER_KIND),
            };
            self.mesh.warnings.push(msg);
        }
        Ok(self.mesh)
    }
}

/// Strips one pair of surrounding double quotes from a tag string.
fn unquote(s: &str) -> &str {
    s.strip_prefix('"')
        .and_then(|t| t.strip_suffix('"'))
        .unwrap_or(s)
}
