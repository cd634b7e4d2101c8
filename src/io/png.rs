//! 8-bit RGB PNG writing, through the `image` crate.

use crate::error::{Error, ErrorKind, Result};
use std::path::Path;

/// Writes `width × height` row-major RGB8 pixels (`rgb.len() == 3 · width · height`) as a PNG.
pub fn write_rgb8(path: &Path, width: u32, height: u32, rgb: Vec<u8>) -> Result<()> {
    let img = image::RgbImage::from_raw(width, height, rgb).ok_or_else(|| {
        Error::new(ErrorKind::Io, "image size mismatch").in_file(path.display().to_string())
    })?;
    img.save_with_format(path, image::ImageFormat::Png)
        .map_err(|e| Error::new(ErrorKind::Io, e.to_string()).in_file(path.display().to_string()))
}
