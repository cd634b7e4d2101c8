//! Textures: procedural noise ([`noise`]) for tests and displacement, and image textures
//! (`image`, feature `render`: PNG, JPEG and OpenEXR files as filtered mip pyramids), behind
//! one [`Texture`] that shading and displacement look up.
//!
//! A texture is named by a string, in scenes and on the command line:
//! - `noise:FREQUENCY`: `0.5 + 0.5 · noise(FREQUENCY · P)`, `P` the object-space point (3D
//!   gradient noise, values within about `[-0.05, 1.05]`), grey, no texture coordinates needed;
//! - anything else is an image file (PNG, JPEG, EXR), addressed by the mesh's face-varying
//!   texture coordinates, or by the (sub-)face's own `(u, v)` on a mesh without them.

#[cfg(feature = "render")]
pub mod image;
pub mod noise;

use crate::error::{Error, ErrorKind, Result};
#[cfg(feature = "render")]
use std::sync::Arc;

/// What a texture string names, before any file is read.
#[derive(Clone, Debug, PartialEq)]
pub enum TextureSpec {
    /// Procedural noise (`noise:FREQUENCY`).
    Noise {
        /// Lattice cells per object unit.
        frequency: f64,
    },
    /// An image file (resolved against the caller's folder).
    File(std::path::PathBuf),
}

impl TextureSpec {
    /// Parses `noise:FREQUENCY` or a file name (relative names are joined to `base`).
    pub fn parse(spec: &str, base: &std::path::Path) -> Result<TextureSpec> {
        if let Some(f) = spec.strip_prefix("noise:") {
            let frequency: f64 = f.parse().map_err(|_| {
                Error::new(
                    ErrorKind::Usage,
                    format!("texture {spec:?}: FREQUENCY must be a number"),
                )
            })?;
            if !(frequency.is_finite() && frequency > 0.0 && frequency <= 1e6) {
                return Err(Error::new(
                    ErrorKind::Usage,
                    format!("texture {spec:?}: frequency {frequency} is outside (0, 1e6]"),
                ));
            }
            return Ok(TextureSpec::Noise { frequency });
        }
        if spec.is_empty() {
            return Err(Error::new(ErrorKind::Usage, "empty texture file name"));
        }
        Ok(TextureSpec::File(base.join(spec)))
    }
}

/// A texture ready for lookups.
#[derive(Clone, Debug, PartialEq)]
pub enum Texture {
    /// Procedural noise of the object-space point.
    Noise {
        /// Lattice cells per object unit.
        frequency: f64,
    },
    /// A filtered image.
    #[cfg(feature = "render")]
    Image(Arc<image::ImageTexture>),
}

impl Texture {
    /// Opens what `spec` names; images are decoded in `space` (sRGB for colours, linear for
    /// data such as roughness and heights; EXR is always linear).
    #[cfg(feature = "render")]
    pub fn open(spec: &TextureSpec, space: image::ColorSpace) -> Result<Texture> {
        match spec {
            TextureSpec::Noise { frequency } => Ok(Texture::Noise {
                frequency: *frequency,
            }),
            TextureSpec::File(path) => Ok(Texture::Image(Arc::new(image::ImageTexture::open(
                path, space,
            )?))),
        }
    }

    /// Whether lookups read texture coordinates (images) rather than the point (noise).
    pub fn uses_uv(&self) -> bool {
        !matches!(self, Texture::Noise { .. })
    }

    /// The colour at texture coordinates `st` (images, with a filter `footprint` wide in
    /// texture-coordinate units) or at the object-space point `p` (noise).
    pub fn rgb(&self, st: [f32; 2], p: [f64; 3], footprint: f32) -> [f32; 3] {
        match self {
            Texture::Noise { frequency } => {
                let _ = (st, footprint);
                let x = (0.5 + 0.5 * noise::noise(p.map(|c| c * frequency)).0) as f32;
                [x; 3]
            }
            #[cfg(feature = "render")]
            Texture::Image(t) => {
                let _ = p;
                t.lookup(st, footprint)
            }
        }
    }

    /// The mean of [`Self::rgb`]'s channels.
    pub fn scalar(&self, st: [f32; 2], p: [f64; 3], footprint: f32) -> f32 {
        let c = self.rgb(st, p, footprint);
        (c[0] + c[1] + c[2]) / 3.0
    }

    /// Bytes held (the image's pyramid).
    pub fn bytes(&self) -> usize {
        match self {
            Texture::Noise { .. } => 0,
            #[cfg(feature = "render")]
            Texture::Image(t) => t.bytes(),
        }
    }
}
