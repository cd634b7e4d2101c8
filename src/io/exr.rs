//! OpenEXR reading and writing of named `f32` planes, through the `exr` crate: one layer, ZIP
//! compression in scan lines of 16, lines in increasing order (so that the same planes always
//! give the same bytes). The renderer's channel set is [`crate::render::output`]'s. Files are
//! written through [`Output`] (checked path, atomic replacement).

use super::output::Output;
use crate::error::{Error, ErrorKind, Result};
use ::exr::prelude::*;
use std::io::Write;
use std::path::{Path, PathBuf};

fn io_error(path: &Path, e: impl std::fmt::Display) -> Error {
    Error::new(ErrorKind::Io, e.to_string()).in_file(path.display().to_string())
}

/// Encodes named `f32` planes (row-major, `width × height` each) as one EXR layer, in
/// memory. `name` labels errors.
pub fn encode_planes(
    name: &Path,
    width: usize,
    height: usize,
    planes: Vec<(&str, Vec<f32>)>,
) -> Result<Vec<u8>> {
    if width == 0 || height == 0 {
        return Err(io_error(name, "cannot write an empty image"));
    }
    let mut list = ::exr::prelude::SmallVec::<[AnyChannel<FlatSamples>; 4]>::new();
    for (channel, data) in planes {
        if data.len() != width * height {
            return Err(io_error(
                name,
                format!("channel {channel} has the wrong size"),
            ));
        }
        list.push(AnyChannel::new(channel, FlatSamples::F32(data)));
    }
    let layer = Layer::new(
        (width, height),
        LayerAttributes::default(),
        Encoding::SMALL_LOSSLESS,
        AnyChannels::sort(list),
    );
    let mut bytes = std::io::Cursor::new(Vec::new());
    Image::from_layer(layer)
        .write()
        .to_buffered(&mut bytes)
        .map_err(|e| io_error(name, e))?;
    Ok(bytes.into_inner())
}

/// Writes named `f32` planes (row-major, `width × height` each) as one EXR layer to `path`
/// (`-`: standard output) through [`Output`]: an existing file is replaced only by a complete
/// one, and never touched when writing fails.
pub fn write_planes(
    path: &Path,
    width: usize,
    height: usize,
    planes: Vec<(&str, Vec<f32>)>,
) -> Result<()> {
    let mut out = Output::create(path)?;
    write_planes_to(&mut out, width, height, planes)?;
    out.commit()
}

/// [`write_planes`] into an output opened (and so checked) before the work started; the
/// caller commits it.
pub fn write_planes_to(
    out: &mut Output,
    width: usize,
    height: usize,
    planes: Vec<(&str, Vec<f32>)>,
) -> Result<()> {
    let name = PathBuf::from(out.name());
    let bytes = encode_planes(&name, width, height, planes)?;
    out.write_all(&bytes).map_err(|e| io_error(&name, e))
}

/// Bytes [`read_channels`] needs for a layer of `width × height` with `channels` channels:
/// the decoded samples (at most 4 bytes each) and their `f32` copies.
pub fn read_bytes(width: u64, height: u64, channels: u64) -> f64 {
    width as f64 * height as f64 * channels.max(1) as f64 * 8.0
}

/// Checks the header's data windows against the memory budget before any pixel is decoded
/// (a corrupt or hostile header can claim 10^6 × 10^6 pixels).
fn check_header(path: &Path) -> Result<()> {
    let meta = ::exr::meta::MetaData::read_from_file(path, false).map_err(|e| io_error(path, e))?;
    let mut total = 0.0;
    for h in meta.headers.iter() {
        let (w, hgt) = (h.layer_size.0 as u64, h.layer_size.1 as u64);
        total += read_bytes(w, hgt, h.channels.list.len() as u64);
    }
    let first = meta.headers.first().map_or((0, 0), |h| h.layer_size.into());
    crate::memory::check(
        &format!(
            "reading the {} × {} EXR image {}",
            first.0,
            first.1,
            path.display()
        ),
        total,
        "use a smaller image",
    )
}

/// All channels of the first layer of an EXR file, converted to `f32`.
#[derive(Clone, Debug, PartialEq)]
pub struct ExrChannels {
    /// Width in pixels.
    pub width: usize,
    /// Height in pixels.
    pub height: usize,
    /// `(name, row-major samples)` in the file's (alphabetical) order.
    pub channels: Vec<(String, Vec<f32>)>,
}

impl ExrChannels {
    /// The samples of channel `name`.
    pub fn get(&self, name: &str) -> Option<&[f32]> {
        self.channels
            .iter()
            .find(|(n, _)| n == name)
            .map(|(_, v)| v.as_slice())
    }
}

/// Reads every channel of the first layer (largest resolution level, no deep data). The
/// header is checked against the memory budget ([`crate::memory`]) first.
pub fn read_channels(path: &Path) -> Result<ExrChannels> {
    check_header(path)?;
    let image = read()
        .no_deep_data()
        .largest_resolution_level()
        .all_channels()
        .first_valid_layer()
        .all_attributes()
        .from_file(path)
        .map_err(|e| io_error(path, e))?;
    let layer = image.layer_data;
    let size = layer.size;
    let channels = layer
        .channel_data
        .list
        .iter()
        .map(|c| {
            (
                c.name.to_string(),
                c.sample_data.values_as_f32().collect::<Vec<f32>>(),
            )
        })
        .collect();
    Ok(ExrChannels {
        width: size.0,
        height: size.1,
        channels,
    })
}

/// Reads an RGB image (channels `R`, `G`, `B`, or a single `Y` as grey) for an environment
/// map: `(width, height, row-major texels)`.
pub fn read_rgb(path: &Path) -> Result<(usize, usize, Vec<[f32; 3]>)> {
    let ch = read_channels(path)?;
    let (r, g, b) = match (ch.get("R"), ch.get("G"), ch.get("B"), ch.get("Y")) {
        (Some(r), Some(g), Some(b), _) => (r, g, b),
        (_, _, _, Some(y)) => (y, y, y),
        _ => {
            return Err(io_error(
                path,
                "EXR has neither R, G, B channels nor a Y channel",
            ))
        }
    };
    let texels = (0..ch.width * ch.height)
        .map(|i| [r[i], g[i], b[i]])
        .collect();
    Ok((ch.width, ch.height, texels))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trip_planes() {
        let dir = std::env::temp_dir().join(format!("limitray-exr-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let p = dir.join("t.exr");
        let r: Vec<f32> = (0..6).map(|i| i as f32 * 0.5).collect();
        let g = vec![f32::INFINITY; 6];
        write_planes(
            &p,
            3,
            2,
            vec![("R", r.clone()), ("G", g.clone()), ("B", r.clone())],
        )
        .unwrap();
        let back = read_channels(&p).unwrap();
        assert_eq!((back.width, back.height), (3, 2));
        assert_eq!(back.get("R").unwrap(), r.as_slice());
        assert_eq!(back.get("G").unwrap(), g.as_slice());
        let (w, h, t) = read_rgb(&p).unwrap();
        assert_eq!((w, h, t[5]), (3, 2, [2.5, f32::INFINITY, 2.5]));
        assert!(read_channels(&dir.join("missing.exr")).is_err());
        assert!(write_planes(&p, 2, 2, vec![("R", vec![0.0; 3])]).is_err());
        std::fs::remove_dir_all(&dir).ok();
    }
}
