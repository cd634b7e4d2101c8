//! 8-bit RGB PNG writing, through the `image` crate and [`Output`] (checked path, atomic
//! replacement).

use super::output::Output;
use crate::error::{Error, ErrorKind, Result};
use std::io::Write;
use std::path::Path;

/// Writes `width × height` row-major RGB8 pixels (`rgb.len() == 3 · width · height`) as a PNG
/// (`-`: standard output); an existing file is replaced only by a complete one.
pub fn write_rgb8(path: &Path, width: u32, height: u32, rgb: Vec<u8>) -> Result<()> {
    let mut out = Output::create(path)?;
    write_rgb8_to(&mut out, width, height, rgb)?;
    out.commit()
}

/// [`write_rgb8`] into an output opened before the work started; the caller commits it.
pub fn write_rgb8_to(out: &mut Output, width: u32, height: u32, rgb: Vec<u8>) -> Result<()> {
    let err = |name: &str, e: String| Error::new(ErrorKind::Io, e).in_file(name.to_string());
    let img = image::RgbImage::from_raw(width, height, rgb)
        .ok_or_else(|| err(out.name(), "image size mismatch".to_string()))?;
    let mut bytes = std::io::Cursor::new(Vec::new());
    img.write_to(&mut bytes, image::ImageFormat::Png)
        .map_err(|e| err(out.name(), e.to_string()))?;
    let r = out.write_all(bytes.get_ref());
    r.map_err(|e| err(out.name(), e.to_string()))
}
