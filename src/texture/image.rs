//! Image textures: PNG, JPEG and OpenEXR files as mip pyramids of linear RGB `f32` texels,
//! looked up with trilinear filtering.
//!
//! Conventions:
//! - **Colour.** Texels are linear RGB. 8- and 16-bit PNG/JPEG samples are read as `v / 255`
//!   or `v / 65535` and then, for [`ColorSpace::Srgb`], decoded with the exact sRGB transfer
//!   function (`c / 12.92` below `0.04045`, else `((c + 0.055) / 1.055)^2.4`);
//!   [`ColorSpace::Linear`] keeps them (data maps: roughness, displacement). EXR files are
//!   linear: their values are used as they are, whatever the colour space. Alpha is ignored;
//!   grey images give `R = G = B`.
//! - **Coordinates.** `(s, t)` wrap (repeat) in both directions. `t = 0` is the *bottom* row of
//!   the image and `t = 1` the top (the OBJ / RenderMan `vt` convention), so the texel in column
//!   `i` and row `j`, counted from the top of the file, has its centre at
//!   `((i + 0.5) / w, 1 − (j + 0.5) / h)`.
//! - **Mip pyramid.** Level 0 is the file; each next level has `max(1, w / 2) × max(1, h / 2)`
//!   texels, down to 1 × 1. A level is a separable box filter of the one above: output texel `i`
//!   of a row of `n` texels shrunk to `m` covers the interval `[i · n/m, (i + 1) · n/m)` of
//!   input texels and averages them weighted by their overlap with it. For even `n` that is
//!   the plain 2 × 2 box; for odd `n` each output covers `2 + 1/m` input texels, the texel
//!   straddling two outputs giving a share to each (for `n = 5`: weights `0.4, 0.4, 0.2` and
//!   `0.2, 0.4, 0.4`; for `n = 3 → 1`: a third each). Every input texel's weights sum to
//!   `m / n`, so each level keeps the mean of the level above exactly (up to the rounding of
//!   its texels to `f32`; the sums are taken in `f64`) for any size.
//! - **Filtering.** [`ImageTexture::lookup`] takes a filter width in texture-coordinate units,
//!   picks the level `λ = log2(footprint · max(w, h))` and blends bilinear lookups (between
//!   texel centres, wrapping) in the two levels around it.

use crate::error::{Error, ErrorKind, Result};
use std::io::{BufReader, Read};
use std::path::Path;

/// How the samples of an 8- or 16-bit image file are to be read.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ColorSpace {
    /// sRGB-encoded colour (photographs, painted colour maps): decoded to linear.
    Srgb,
    /// Linear data (roughness, displacement, normal maps): kept as `v / max`.
    Linear,
}

impl ColorSpace {
    /// The linear value of an encoded sample `c` (nominally in `[0, 1]`): the exact sRGB
    /// transfer function for [`ColorSpace::Srgb`] (computed in `f64`), `c` itself for
    /// [`ColorSpace::Linear`].
    pub fn decode(self, c: f32) -> f32 {
        self.decode_f64(c as f64) as f32
    }

    fn decode_f64(self, c: f64) -> f64 {
        match self {
            ColorSpace::Linear => c,
            ColorSpace::Srgb => {
                if c < 0.04045 {
                    c / 12.92
                } else {
                    ((c + 0.055) / 1.055).powf(2.4)
                }
            }
        }
    }
}

/// One level of the pyramid: row-major texels, row 0 at the top of the image.
#[derive(Clone, Debug, PartialEq)]
struct Level {
    width: usize,
    height: usize,
    texels: Vec<[f32; 3]>,
}

impl Level {
    /// Bilinear lookup between texel centres with repeat wrapping.
    #[inline]
    fn bilinear(&self, st: [f32; 2]) -> [f32; 3] {
        let (w, h) = (self.width, self.height);
        // Column coordinate with texel centres at integers; row coordinate counted from the top.
        let x = wrap01(st[0]) * w as f32 - 0.5;
        let y = (1.0 - wrap01(st[1])) * h as f32 - 0.5;
        let (x0, y0) = (x.floor(), y.floor());
        let (fx, fy) = (x - x0, y - y0);
        // x0 ∈ [−1, w − 1]; −1 is the last column (wrapping), likewise for rows.
        let i0 = if x0 < 0.0 {
            w - 1
        } else {
            (x0 as usize).min(w - 1)
        };
        let j0 = if y0 < 0.0 {
            h - 1
        } else {
            (y0 as usize).min(h - 1)
        };
        let i1 = if i0 + 1 == w { 0 } else { i0 + 1 };
        let j1 = if j0 + 1 == h { 0 } else { j0 + 1 };
        let t = &self.texels;
        let (a, b) = (t[j0 * w + i0], t[j0 * w + i1]);
        let (c, d) = (t[j1 * w + i0], t[j1 * w + i1]);
        let mut out = [0.0; 3];
        for k in 0..3 {
            let top = a[k] + (b[k] - a[k]) * fx;
            let bottom = c[k] + (d[k] - c[k]) * fx;
            out[k] = top + (bottom - top) * fy;
        }
        out
    }

    /// The next level of the pyramid (see the module documentation for the filter).
    fn downsample(&self) -> Level {
        let (w, h) = (self.width, self.height);
        let (w2, h2) = ((w / 2).max(1), (h / 2).max(1));
        let tx = box_taps(w, w2);
        let ty = box_taps(h, h2);
        let mut texels = Vec::with_capacity(w2 * h2);
        // One row of the vertical pass, summed in f64 (reused for every output row).
        let mut row = vec![[0.0f64; 3]; w];
        for taps in &ty {
            row.iter_mut().for_each(|v| *v = [0.0; 3]);
            for &(j, wy) in taps {
                let src = &self.texels[j * w..(j + 1) * w];
                for (acc, t) in row.iter_mut().zip(src) {
                    for k in 0..3 {
                        acc[k] += wy * t[k] as f64;
                    }
                }
            }
            for taps in &tx {
                let mut acc = [0.0f64; 3];
                for &(i, wx) in taps {
                    for k in 0..3 {
                        acc[k] += wx * row[i][k];
                    }
                }
                texels.push([acc[0] as f32, acc[1] as f32, acc[2] as f32]);
            }
        }
        Level {
            width: w2,
            height: h2,
            texels,
        }
    }
}

/// Wraps a coordinate into `[0, 1]` (repeat); a non-finite one reads as 0.
#[inline]
fn wrap01(v: f32) -> f32 {
    if v.is_finite() {
        v - v.floor()
    } else {
        0.0
    }
}

/// The box filter shrinking `n` samples to `m`: for each output, `(input index, weight)` with
/// the weight the overlap of the input texel with the output's interval `[i·n/m, (i+1)·n/m)`,
/// divided by that interval's length `n/m`. Exact integer overlaps in units of `1/m` texel.
fn box_taps(n: usize, m: usize) -> Vec<Vec<(usize, f64)>> {
    let (n64, m64) = (n as u64, m as u64);
    (0..m64)
        .map(|i| {
            let (a, b) = (i * n64, (i + 1) * n64);
            (a / m64..=(b - 1) / m64)
                .map(|k| {
                    let lo = a.max(k * m64);
                    let hi = b.min((k + 1) * m64);
                    (k as usize, (hi - lo) as f64 / n64 as f64)
                })
                .collect()
        })
        .collect()
}

/// An image texture: a mip pyramid of linear RGB `f32` levels, level 0 the image itself.
/// See the module documentation for colour, coordinate and filtering conventions.
#[derive(Clone, Debug, PartialEq)]
pub struct ImageTexture {
    levels: Vec<Level>,
}

/// File formats [`ImageTexture::open`] reads.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Format {
    Png,
    Jpeg,
    Exr,
}

fn file_error(kind: ErrorKind, path: &Path, e: impl std::fmt::Display) -> Error {
    Error::new(kind, e.to_string()).in_file(path.display().to_string())
}

/// The error kind of an `image` crate error: reading, the memory limit, or bad contents.
fn image_error(path: &Path, what: &str, e: ::image::ImageError) -> Error {
    let kind = match e {
        ::image::ImageError::IoError(_) => ErrorKind::Io,
        ::image::ImageError::Limits(_) => ErrorKind::Usage,
        _ => ErrorKind::Parse,
    };
    file_error(kind, path, format!("cannot decode the {what} image: {e}"))
}

/// The format of `path`, from its first bytes (PNG, JPEG and EXR signatures), else from its
/// extension.
fn detect(path: &Path) -> Result<Format> {
    let file = std::fs::File::open(path).map_err(|e| file_error(ErrorKind::Io, path, e))?;
    let mut head = Vec::with_capacity(8);
    file.take(8)
        .read_to_end(&mut head)
        .map_err(|e| file_error(ErrorKind::Io, path, e))?;
    if head.starts_with(b"\x89PNG\r\n\x1a\n") {
        return Ok(Format::Png);
    }
    if head.starts_with(&[0xff, 0xd8, 0xff]) {
        return Ok(Format::Jpeg);
    }
    if head.starts_with(&[0x76, 0x2f, 0x31, 0x01]) {
        return Ok(Format::Exr);
    }
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(|e| e.to_ascii_lowercase());
    match ext.as_deref() {
        Some("png") => Ok(Format::Png),
        Some("jpg" | "jpeg") => Ok(Format::Jpeg),
        Some("exr") => Ok(Format::Exr),
        _ => Err(file_error(
            ErrorKind::Parse,
            path,
            "not a PNG, JPEG or OpenEXR image (unknown contents and extension)",
        )),
    }
}

/// Bytes the pyramid of a `width × height` image holds: 12 per texel of level 0 and at most a
/// third more for the other levels.
fn pyramid_bytes(width: usize, height: usize) -> f64 {
    width as f64 * height as f64 * 12.0 * 4.0 / 3.0
}

/// Refuses an empty image, and checks `decode_bytes` (what decoding holds at its peak) plus the
/// pyramid against the memory limit `limit`, before any pixel is decoded.
fn check_size(
    path: &Path,
    what: &str,
    width: usize,
    height: usize,
    decode_bytes: f64,
    limit: u64,
) -> Result<()> {
    if width == 0 || height == 0 {
        return Err(file_error(
            ErrorKind::Parse,
            path,
            format!("the {what} image is empty ({width} × {height} pixels)"),
        ));
    }
    crate::memory::check_with(
        limit,
        &format!(
            "reading the {width} × {height} {what} texture {}",
            path.display()
        ),
        decode_bytes + pyramid_bytes(width, height),
        "use a smaller image",
    )
}

/// Level 0 of an EXR file, after checking its header against the memory limit.
fn read_exr(path: &Path, limit: u64) -> Result<Level> {
    let meta = ::exr::meta::MetaData::read_from_file(path, false).map_err(|e| {
        file_error(
            ErrorKind::Parse,
            path,
            format!("cannot read the EXR header: {e}"),
        )
    })?;
    let (width, height) = meta.headers.first().map_or((0, 0), |h| h.layer_size.into());
    // `read_rgb` holds the decoded channels and its RGB copy (12 bytes a texel) together.
    let decode: f64 = meta
        .headers
        .iter()
        .map(|h| {
            let (w, h2) = (h.layer_size.0 as u64, h.layer_size.1 as u64);
            crate::io::exr::read_bytes(w, h2, h.channels.list.len() as u64)
        })
        .sum::<f64>()
        + width as f64 * height as f64 * 12.0;
    check_size(path, "EXR", width, height, decode, limit)?;
    let (width, height, texels) = crate::io::exr::read_rgb(path)?;
    if width == 0 || height == 0 || texels.len() != width * height {
        return Err(file_error(
            ErrorKind::Parse,
            path,
            format!("the EXR image is empty or inconsistent ({width} × {height} pixels)"),
        ));
    }
    Ok(Level {
        width,
        height,
        texels,
    })
}

/// Level 0 of a PNG or JPEG file, after checking its size against the memory limit.
fn read_8_16(path: &Path, format: Format, space: ColorSpace, limit: u64) -> Result<Level> {
    use ::image::{DynamicImage, ImageDecoder, ImageFormat, ImageReader, Limits};
    let (image_format, what) = match format {
        Format::Png => (ImageFormat::Png, "PNG"),
        _ => (ImageFormat::Jpeg, "JPEG"),
    };
    let file = std::fs::File::open(path).map_err(|e| file_error(ErrorKind::Io, path, e))?;
    let mut reader = ImageReader::with_format(BufReader::new(file), image_format);
    // The crate's own default (512 MiB) gives way to the project's budget, checked below.
    let mut limits = Limits::no_limits();
    limits.max_alloc = Some(limit);
    reader.limits(limits);
    let decoder = reader
        .into_decoder()
        .map_err(|e| image_error(path, what, e))?;
    let (w, h) = decoder.dimensions();
    let (width, height) = (w as usize, h as usize);
    check_size(
        path,
        what,
        width,
        height,
        decoder.total_bytes() as f64,
        limit,
    )?;
    let image = DynamicImage::from_decoder(decoder).map_err(|e| image_error(path, what, e))?;
    let lut8 = || decode_table(space, u8::MAX as usize);
    let lut16 = || decode_table(space, u16::MAX as usize);
    let texels = match image {
        DynamicImage::ImageLuma8(b) => convert(b.as_raw(), 1, &lut8()),
        DynamicImage::ImageLumaA8(b) => convert(b.as_raw(), 2, &lut8()),
        DynamicImage::ImageRgb8(b) => convert(b.as_raw(), 3, &lut8()),
        DynamicImage::ImageRgba8(b) => convert(b.as_raw(), 4, &lut8()),
        DynamicImage::ImageLuma16(b) => convert(b.as_raw(), 1, &lut16()),
        DynamicImage::ImageLumaA16(b) => convert(b.as_raw(), 2, &lut16()),
        DynamicImage::ImageRgb16(b) => convert(b.as_raw(), 3, &lut16()),
        DynamicImage::ImageRgba16(b) => convert(b.as_raw(), 4, &lut16()),
        // PNG and JPEG decode to the formats above; anything else goes through 16 bits.
        other => convert(other.to_rgb16().as_raw(), 3, &lut16()),
    };
    if texels.len() != width * height {
        return Err(file_error(
            ErrorKind::Parse,
            path,
            format!(
                "decoded {} pixels for a {width} × {height} image",
                texels.len()
            ),
        ));
    }
    Ok(Level {
        width,
        height,
        texels,
    })
}

/// The linear value of every sample value `0..=max`.
fn decode_table(space: ColorSpace, max: usize) -> Vec<f32> {
    (0..=max)
        .map(|v| space.decode_f64(v as f64 / max as f64) as f32)
        .collect()
}

/// Interleaved samples with `channels` per pixel (1: grey, 2: grey + alpha, 3: RGB, 4: RGBA)
/// to linear RGB through `lut`; alpha is dropped, grey copied to R, G and B.
fn convert<T: Copy + Into<usize>>(samples: &[T], channels: usize, lut: &[f32]) -> Vec<[f32; 3]> {
    samples
        .chunks_exact(channels)
        .map(|p| {
            if channels < 3 {
                let g = lut[p[0].into()];
                [g, g, g]
            } else {
                [lut[p[0].into()], lut[p[1].into()], lut[p[2].into()]]
            }
        })
        .collect()
}

impl ImageTexture {
    /// Reads a PNG or JPEG (any pixel format, 8 or 16 bits; decoded per `space`) or an
    /// OpenEXR file (`R`, `G`, `B` or `Y`; always linear) and builds its pyramid. The format
    /// is chosen by the file's signature, else by its extension. The decoded size is checked
    /// against the memory budget ([`crate::memory`]) before the pixels are decoded; an empty
    /// image is refused. Errors name the file.
    pub fn open(path: &Path, space: ColorSpace) -> Result<ImageTexture> {
        Self::open_with_limit(path, space, crate::memory::limit())
    }

    /// [`ImageTexture::open`] against an explicit memory limit in bytes.
    fn open_with_limit(path: &Path, space: ColorSpace, limit: u64) -> Result<ImageTexture> {
        let level0 = match detect(path)? {
            Format::Exr => read_exr(path, limit)?,
            format => read_8_16(path, format, space, limit)?,
        };
        Ok(Self::from_level(level0))
    }

    /// A texture of `width × height` linear RGB texels, row-major with row 0 at the top of
    /// the image (t = 1), for tests and procedural textures.
    ///
    /// # Panics
    /// If `width` or `height` is 0 or `texels.len() != width · height`.
    pub fn from_rgb(width: usize, height: usize, texels: Vec<[f32; 3]>) -> ImageTexture {
        assert!(
            width > 0 && height > 0,
            "empty texture ({width} × {height})"
        );
        assert_eq!(
            texels.len(),
            width * height,
            "texel count of a {width} × {height} texture"
        );
        Self::from_level(Level {
            width,
            height,
            texels,
        })
    }

    fn from_level(level0: Level) -> ImageTexture {
        let mut levels = vec![level0];
        loop {
            let last = &levels[levels.len() - 1];
            if last.width == 1 && last.height == 1 {
                break;
            }
            let next = last.downsample();
            levels.push(next);
        }
        ImageTexture { levels }
    }

    /// Width of level 0 in texels.
    pub fn width(&self) -> usize {
        self.levels[0].width
    }

    /// Height of level 0 in texels.
    pub fn height(&self) -> usize {
        self.levels[0].height
    }

    /// Number of pyramid levels, `1 + floor(log2(max(width, height)))`.
    pub fn levels(&self) -> usize {
        self.levels.len()
    }

    /// Level `i` of the pyramid (`i < levels()`): width, height and its texels, row by row
    /// from the top of the image (what the GPU path tracer uploads).
    pub fn level(&self, i: usize) -> (usize, usize, &[[f32; 3]]) {
        let l = &self.levels[i];
        (l.width, l.height, &l.texels)
    }

    /// Bytes held by the texture (texel arrays and level table).
    pub fn bytes(&self) -> usize {
        std::mem::size_of::<Self>()
            + self.levels.capacity() * std::mem::size_of::<Level>()
            + self
                .levels
                .iter()
                .map(|l| l.texels.capacity() * std::mem::size_of::<[f32; 3]>())
                .sum::<usize>()
    }

    /// The linear RGB colour at `st` filtered over `footprint` (the filter width in
    /// texture-coordinate units; `1 / width` is one texel of level 0): bilinear lookups in the
    /// two levels around `λ = log2(footprint · max(width, height))`, clamped to
    /// `[0, levels − 1]`, blended linearly. A footprint ≤ 0 or NaN reads level 0. Coordinates
    /// wrap; non-finite ones read as 0.
    pub fn lookup(&self, st: [f32; 2], footprint: f32) -> [f32; 3] {
        let last = self.levels.len() - 1;
        let base = &self.levels[0];
        let lambda = (footprint * base.width.max(base.height) as f32).log2();
        // NaN (footprint NaN or < 0) and λ ≤ 0 (including −∞ for footprint 0) read level 0.
        if lambda.is_nan() || lambda <= 0.0 {
            return base.bilinear(st);
        }
        if lambda >= last as f32 {
            return self.levels[last].bilinear(st);
        }
        let l0 = lambda.floor();
        let f = lambda - l0;
        let l0 = l0 as usize;
        let a = self.levels[l0].bilinear(st);
        if f == 0.0 {
            return a;
        }
        let b = self.levels[l0 + 1].bilinear(st);
        [
            a[0] + (b[0] - a[0]) * f,
            a[1] + (b[1] - a[1]) * f,
            a[2] + (b[2] - a[2]) * f,
        ]
    }

    /// The largest channel value in magnitude (of the file's own texels, level 0): what
    /// bounds a displacement read from the image.
    pub fn max_abs(&self) -> f32 {
        self.levels[0]
            .texels
            .iter()
            .flatten()
            .fold(0.0f32, |m, x| m.max(x.abs()))
    }

    /// The mean of the three channels of [`ImageTexture::lookup`] (a grey image gives its
    /// grey value), for displacement and roughness maps.
    pub fn lookup_scalar(&self, st: [f32; 2], footprint: f32) -> f32 {
        let c = self.lookup(st, footprint);
        (c[0] + c[1] + c[2]) / 3.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::PathBuf;

    /// A fresh directory for one test's files.
    fn temp_dir(name: &str) -> PathBuf {
        let dir =
            std::env::temp_dir().join(format!("limitray-texture-{}-{name}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        dir
    }

    /// Deterministic pseudo-random values in [0, 1).
    fn random_texels(n: usize, seed: u64) -> Vec<[f32; 3]> {
        let mut s = seed.wrapping_mul(0x9e37_79b9_7f4a_7c15) | 1;
        let mut next = || {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            (s >> 40) as f32 / (1u64 << 24) as f32
        };
        (0..n).map(|_| [next(), next(), next()]).collect()
    }

    fn mean(level: &Level) -> [f64; 3] {
        let mut m = [0.0f64; 3];
        for t in &level.texels {
            for k in 0..3 {
                m[k] += t[k] as f64;
            }
        }
        m.map(|v| v / level.texels.len() as f64)
    }

    fn close(a: [f32; 3], b: [f32; 3], tol: f32) -> bool {
        (0..3).all(|k| (a[k] - b[k]).abs() <= tol)
    }

    #[test]
    fn srgb_decode() {
        // The reference values are the formula evaluated in f64 and rounded to f32; `decode`
        // computes in f64 and rounds once, so they agree to one f32 ulp (tolerance 1e-7 at
        // values ≤ 1; 0 and 1 are exact).
        let s = ColorSpace::Srgb;
        assert_eq!(s.decode(0.0), 0.0);
        assert_eq!(s.decode(1.0), 1.0);
        assert!((s.decode(0.5) - 0.214_041_14).abs() < 1e-7);
        // Below the knee the curve is linear: 0.04 / 12.92.
        assert!((s.decode(0.04) - 0.003_095_975_2).abs() < 1e-9);
        // Linear keeps values.
        assert_eq!(ColorSpace::Linear.decode(0.5), 0.5);
        // The 8-bit table agrees with the function.
        let lut = decode_table(s, 255);
        assert_eq!(lut[0], 0.0);
        assert_eq!(lut[255], 1.0);
        assert!((lut[128] - s.decode(128.0 / 255.0)).abs() < 1e-7);
    }

    #[test]
    fn bilinear_centres_midpoints_and_wrapping() {
        let (w, h) = (4, 3);
        let texels = random_texels(w * h, 1);
        let tex = ImageTexture::from_rgb(w, h, texels.clone());
        // Texel centres: (i + 0.5)/w and 1 − (j + 0.5)/h are rounded to f32, so the fractional
        // weights are a few 1e-7 instead of 0; texels are ≤ 1, so 1e-6 absolute covers it.
        for j in 0..h {
            for i in 0..w {
                let st = [
                    (i as f32 + 0.5) / w as f32,
                    1.0 - (j as f32 + 0.5) / h as f32,
                ];
                let v = tex.lookup(st, 0.0);
                assert!(close(v, texels[j * w + i], 1e-6), "texel {i} {j}");
                // Repeat wrapping: s + 1, t − 1 read the same (up to the same rounding).
                let v2 = tex.lookup([st[0] + 1.0, st[1] - 1.0], 0.0);
                assert!(close(v, v2, 1e-6));
            }
        }
        // Midpoint between the centres of texels (0, 0) and (1, 0): their average.
        let mid = tex.lookup([1.0 / w as f32, 1.0 - 0.5 / h as f32], 0.0);
        let avg = [0, 1, 2].map(|k| 0.5 * (texels[0][k] + texels[1][k]));
        assert!(close(mid, avg, 1e-6));
        // s = 0 lies between the last column and the first (wrapping).
        let edge = tex.lookup([0.0, 1.0 - 0.5 / h as f32], 0.0);
        let avg = [0, 1, 2].map(|k| 0.5 * (texels[0][k] + texels[w - 1][k]));
        assert!(close(edge, avg, 1e-6));
        // Negative and large coordinates wrap too.
        let a = tex.lookup([0.3, 0.6], 0.0);
        assert!(close(a, tex.lookup([-0.7, -2.4], 0.0), 1e-5));
        assert!(close(a, tex.lookup([3.3, 5.6], 0.0), 1e-5));
        // Non-finite coordinates read as 0 and do not panic.
        let nan = tex.lookup([f32::NAN, f32::INFINITY], f32::NAN);
        assert_eq!(nan, tex.lookup([0.0, 0.0], 0.0));
    }

    #[test]
    fn t_is_up() {
        // Row 0 of the file (the top) is red, row 1 blue; t = 0.75 is the top row's centre.
        let tex = ImageTexture::from_rgb(1, 2, vec![[1.0, 0.0, 0.0], [0.0, 0.0, 1.0]]);
        assert_eq!(tex.lookup([0.5, 0.75], 0.0), [1.0, 0.0, 0.0]);
        assert_eq!(tex.lookup([0.5, 0.25], 0.0), [0.0, 0.0, 1.0]);
        assert_eq!(tex.lookup_scalar([0.5, 0.75], 0.0), 1.0 / 3.0);
    }

    #[test]
    fn constant_and_mean_preserving_pyramid() {
        // A constant stays constant at every level: the weights of each output sum to 1 in
        // f64 (error ~1e-16) and the result is rounded once to f32, so it is exact.
        let c = [0.3f32, 0.6, 0.9];
        let tex = ImageTexture::from_rgb(7, 5, vec![c; 35]);
        assert_eq!(tex.levels(), 3);
        for l in &tex.levels {
            assert!(l.texels.iter().all(|&t| t == c));
        }
        for fp in [
            -1.0,
            0.0,
            0.01,
            0.2,
            0.3,
            1.0,
            100.0,
            f32::INFINITY,
            f32::NAN,
        ] {
            for st in [[0.0, 0.0], [0.31, 0.77], [0.99, 0.5]] {
                assert!(close(tex.lookup(st, fp), c, 1e-6), "footprint {fp}");
            }
        }
        // Power-of-two sizes: the mean of every level equals level 0's to 1e-6 relative (each
        // level rounds its texels to f32 once, relative error 6e-8 per texel; the means are
        // summed in f64). Odd sizes: the filter preserves the mean too (module doc), so the
        // same tolerance holds for 5 × 3 and 7 × 5.
        for (w, h) in [(16, 8), (4, 32), (5, 3), (7, 5), (1, 9)] {
            let tex = ImageTexture::from_rgb(w, h, random_texels(w * h, (w * h) as u64));
            let expected = 1 + (w.max(h) as f64).log2().floor() as usize;
            assert_eq!(tex.levels(), expected, "{w} × {h}");
            let last = &tex.levels[tex.levels() - 1];
            assert_eq!((last.width, last.height), (1, 1));
            let m0 = mean(&tex.levels[0]);
            for (i, l) in tex.levels.iter().enumerate() {
                let m = mean(l);
                for k in 0..3 {
                    assert!(
                        (m[k] - m0[k]).abs() <= 1e-6 * m0[k],
                        "{w} × {h} level {i}: {} vs {}",
                        m[k],
                        m0[k]
                    );
                }
            }
        }
        // 5 → 2: weights 0.4, 0.4, 0.2 | 0.2, 0.4, 0.4; 3 → 1: thirds; even sizes: halves.
        assert_eq!(
            box_taps(5, 2),
            vec![
                vec![(0, 0.4), (1, 0.4), (2, 0.2)],
                vec![(2, 0.2), (3, 0.4), (4, 0.4)]
            ]
        );
        assert_eq!(
            box_taps(3, 1),
            vec![vec![(0, 1.0 / 3.0), (1, 1.0 / 3.0), (2, 1.0 / 3.0)]]
        );
        assert_eq!(
            box_taps(4, 2),
            vec![vec![(0, 0.5), (1, 0.5)], vec![(2, 0.5), (3, 0.5)]]
        );
        assert_eq!(box_taps(1, 1), vec![vec![(0, 1.0)]]);
    }

    #[test]
    fn trilinear_level_selection() {
        let (w, h) = (8, 8);
        let tex = ImageTexture::from_rgb(w, h, random_texels(w * h, 7));
        let st = [0.37, 0.61];
        let at = |l: usize| tex.levels[l].bilinear(st);
        // One texel of level 0 (λ = 0), and below: level 0 exactly.
        for fp in [1.0 / 8.0, 0.01, 0.0, -3.0, f32::NAN] {
            assert_eq!(tex.lookup(st, fp), at(0));
        }
        // Whole levels: λ = 1, 2; beyond the top: the 1 × 1 level (the mean).
        assert_eq!(tex.lookup(st, 2.0 / 8.0), at(1));
        assert_eq!(tex.lookup(st, 4.0 / 8.0), at(2));
        assert_eq!(tex.lookup(st, 1.0), at(3));
        assert_eq!(tex.lookup(st, 1e9), at(3));
        // λ = 1.5: the average of levels 1 and 2 (the f32 log2 of 2^1.5 and the blend round
        // to a few ulps: 1e-6 absolute for values ≤ 1).
        let v = tex.lookup(st, 2f32.powf(1.5) / 8.0);
        let (a, b) = (at(1), at(2));
        assert!(close(v, [0, 1, 2].map(|k| 0.5 * (a[k] + b[k])), 1e-6));
        assert!((tex.lookup_scalar(st, 0.0) - (at(0).iter().sum::<f32>() / 3.0)).abs() < 1e-7);
        // Memory: 12 bytes per texel, 64 + 16 + 4 + 1 texels, plus the tables.
        assert!(tex.bytes() >= 85 * 12 && tex.bytes() < 85 * 12 + 512);
        assert_eq!((tex.width(), tex.height()), (8, 8));
    }

    #[test]
    fn png_round_trips() {
        let dir = temp_dir("png");
        // 8-bit RGB: every value decodes through the same table as `decode`, exactly.
        let (w, h) = (5u32, 3u32);
        let raw: Vec<u8> = (0..w * h * 3).map(|i| (i * 17 % 256) as u8).collect();
        let p = dir.join("rgb8.png");
        ::image::RgbImage::from_raw(w, h, raw.clone())
            .unwrap()
            .save(&p)
            .unwrap();
        for space in [ColorSpace::Srgb, ColorSpace::Linear] {
            let tex = ImageTexture::open(&p, space).unwrap();
            assert_eq!((tex.width(), tex.height(), tex.levels()), (5, 3, 3));
            for (i, t) in tex.levels[0].texels.iter().enumerate() {
                let expect =
                    [0, 1, 2].map(|k| space.decode_f64(raw[3 * i + k] as f64 / 255.0) as f32);
                assert_eq!(*t, expect);
            }
        }
        // 16-bit grey: R = G = B = v / 65535 (Linear), exactly.
        let grey: Vec<u16> = (0..12).map(|i| (i * 5000 + 123) as u16).collect();
        let p = dir.join("grey16.png");
        ::image::ImageBuffer::<::image::Luma<u16>, Vec<u16>>::from_raw(4, 3, grey.clone())
            .unwrap()
            .save(&p)
            .unwrap();
        let tex = ImageTexture::open(&p, ColorSpace::Linear).unwrap();
        assert_eq!((tex.width(), tex.height()), (4, 3));
        for (i, t) in tex.levels[0].texels.iter().enumerate() {
            let g = (grey[i] as f64 / 65535.0) as f32;
            assert_eq!(*t, [g, g, g]);
        }
        // Row 0 of the file is the top: t just below 1 at the first column's centre.
        let top = tex.lookup([0.125, 1.0 - 0.5 / 3.0], 0.0);
        assert!((top[0] - (grey[0] as f32 / 65535.0)).abs() < 1e-6);
        // A PNG named .jpg is read as PNG (the signature wins over the extension).
        let q = dir.join("really-a-png.jpg");
        std::fs::copy(&p, &q).unwrap();
        assert_eq!(ImageTexture::open(&q, ColorSpace::Linear).unwrap(), tex);
        std::fs::remove_dir_all(&dir).ok();
    }

    #[test]
    fn jpeg_round_trip() {
        let dir = temp_dir("jpeg");
        // A smooth gradient (JPEG is lossy and subsamples chroma, so sharp colour edges
        // would not survive); quality 100.
        let (w, h) = (16u32, 16u32);
        let mut raw = Vec::new();
        for y in 0..h {
            for x in 0..w {
                raw.extend([(x * 15) as u8, (y * 15) as u8, ((x + y) * 7 + 20) as u8]);
            }
        }
        let p = dir.join("grad.jpg");
        let mut bytes = Vec::new();
        ::image::codecs::jpeg::JpegEncoder::new_with_quality(&mut bytes, 100)
            .encode_image(&::image::RgbImage::from_raw(w, h, raw.clone()).unwrap())
            .unwrap();
        std::fs::write(&p, &bytes).unwrap();
        // Quality 100 leaves quantisation errors of a step or two of 255 on smooth data;
        // 4/255 allows for that plus the chroma subsampling of a gradient. Linear: the
        // decoded values directly; sRGB: the decode has slope ≤ 2.4, so 10/255.
        for (space, tol) in [
            (ColorSpace::Linear, 4.0 / 255.0),
            (ColorSpace::Srgb, 10.0 / 255.0),
        ] {
            let tex = ImageTexture::open(&p, space).unwrap();
            assert_eq!((tex.width(), tex.height()), (16, 16));
            let mut worst = 0.0f32;
            for (i, t) in tex.levels[0].texels.iter().enumerate() {
                for k in 0..3 {
                    let e = space.decode(raw[3 * i + k] as f32 / 255.0);
                    worst = worst.max((t[k] - e).abs());
                }
            }
            assert!(worst <= tol, "{space:?}: worst error {worst}");
        }
        std::fs::remove_dir_all(&dir).ok();
    }

    #[test]
    fn exr_round_trip() {
        let dir = temp_dir("exr");
        let (w, h) = (3, 2);
        let r: Vec<f32> = (0..6).map(|i| i as f32 * 0.5).collect();
        let g: Vec<f32> = (0..6).map(|i| 10.0 - i as f32).collect();
        let b = vec![0.25f32; 6];
        let p = dir.join("rgb.exr");
        crate::io::exr::write_planes(
            &p,
            w,
            h,
            vec![("R", r.clone()), ("G", g.clone()), ("B", b.clone())],
        )
        .unwrap();
        // EXR values are linear whatever the colour space, and exact (f32 planes).
        for space in [ColorSpace::Srgb, ColorSpace::Linear] {
            let tex = ImageTexture::open(&p, space).unwrap();
            assert_eq!((tex.width(), tex.height(), tex.levels()), (3, 2, 2));
            for i in 0..6 {
                assert_eq!(tex.levels[0].texels[i], [r[i], g[i], b[i]]);
            }
        }
        // A Y-only EXR is grey.
        let p = dir.join("y.exr");
        crate::io::exr::write_planes(&p, w, h, vec![("Y", r.clone())]).unwrap();
        let tex = ImageTexture::open(&p, ColorSpace::Srgb).unwrap();
        assert_eq!(tex.levels[0].texels[5], [2.5, 2.5, 2.5]);
        std::fs::remove_dir_all(&dir).ok();
    }

    #[test]
    fn errors_name_the_file() {
        let dir = temp_dir("errors");
        let has_path = |e: &Error, p: &Path| e.to_string().contains(&p.display().to_string());
        // Missing.
        let p = dir.join("missing.png");
        let e = ImageTexture::open(&p, ColorSpace::Srgb).unwrap_err();
        assert!(has_path(&e, &p), "{e}");
        assert_eq!(e.kind, ErrorKind::Io);
        // Garbage named .png.
        let p = dir.join("garbage.png");
        std::fs::write(&p, b"this is not an image at all, just some bytes").unwrap();
        let e = ImageTexture::open(&p, ColorSpace::Srgb).unwrap_err();
        assert!(has_path(&e, &p), "{e}");
        // Empty file, and unknown contents with an unknown extension.
        for name in ["empty.png", "empty.jpg", "empty.exr", "empty.bin"] {
            let p = dir.join(name);
            std::fs::write(&p, b"").unwrap();
            let e = ImageTexture::open(&p, ColorSpace::Srgb).unwrap_err();
            assert!(has_path(&e, &p), "{e}");
        }
        // Truncated PNG and JPEG: a valid file cut in half.
        let (w, h) = (32u32, 32u32);
        let raw: Vec<u8> = random_texels((w * h) as usize, 3)
            .iter()
            .flat_map(|t| t.map(|v| (v * 255.0) as u8))
            .collect();
        let img = ::image::RgbImage::from_raw(w, h, raw).unwrap();
        let full = dir.join("full.png");
        img.save(&full).unwrap();
        let bytes = std::fs::read(&full).unwrap();
        let p = dir.join("truncated.png");
        std::fs::write(&p, &bytes[..bytes.len() / 2]).unwrap();
        let e = ImageTexture::open(&p, ColorSpace::Srgb).unwrap_err();
        assert!(has_path(&e, &p), "{e}");
        let mut jpeg = Vec::new();
        ::image::codecs::jpeg::JpegEncoder::new_with_quality(&mut jpeg, 90)
            .encode_image(&img)
            .unwrap();
        let p = dir.join("truncated.jpg");
        std::fs::write(&p, &jpeg[..jpeg.len() / 3]).unwrap();
        // A JPEG decoder may fill a cut-off scan rather than fail; it must not panic, and an
        // error must name the file.
        if let Err(e) = ImageTexture::open(&p, ColorSpace::Srgb) {
            assert!(has_path(&e, &p), "{e}");
        }
        // Truncated EXR.
        let exr = dir.join("full.exr");
        crate::io::exr::write_planes(&exr, 8, 8, vec![("Y", vec![0.5; 64])]).unwrap();
        let bytes = std::fs::read(&exr).unwrap();
        let p = dir.join("truncated.exr");
        std::fs::write(&p, &bytes[..bytes.len() / 2]).unwrap();
        let e = ImageTexture::open(&p, ColorSpace::Srgb).unwrap_err();
        assert!(has_path(&e, &p), "{e}");
        // Over the memory limit: refused before decoding, naming the file.
        for f in [&full, &exr] {
            let e = ImageTexture::open_with_limit(f, ColorSpace::Srgb, 1000).unwrap_err();
            assert!(has_path(&e, f), "{e}");
            assert_eq!(e.kind, ErrorKind::Usage);
        }
        // An empty image is refused with a clear message.
        let e = check_size(&full, "PNG", 0, 0, 0.0, u64::MAX).unwrap_err();
        assert!(
            has_path(&e, &full) && e.to_string().contains("empty"),
            "{e}"
        );
        std::fs::remove_dir_all(&dir).ok();
    }
}
