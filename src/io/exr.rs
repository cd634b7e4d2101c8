//! OpenEXR reading and writing of named `f32` planes, through the `exr` crate: one layer, ZIP
//! compression in scan lines of 16, lines in increasing order (so that the same planes always
//! give the same bytes). The renderer's channel set is [`crate::render::output`]'s.

use crate::error::{Error, ErrorKind, Result};
use ::exr::prelude::*;
use std::path::Path;

fn io_error(path: &Path, e: impl std::fmt::Display) -> Error {
    Error::new(ErrorKind::Io, e.to_string()).in_file(path.display().to_string())
}

/// Writes named `f32` planes (row-major, `width × height` each) as one EXR layer.
pub fn write_planes(
    path: &Path,
    width: usize,
    height: usize,
    planes: Vec<(&str, Vec<f32>)>,
) -> Result<()> {
    if width == 0 || height == 0 {
        return Err(io_error(path, "cannot write an empty image"));
    }
    let mut list = ::exr::prelude::SmallVec::<[AnyChannel<FlatSamples>; 4]>::new();
    for (name, data) in planes {
        if data.len() != width * height {
            return Err(io_error(path, format!("channel {name} has the wrong size")));
        }
        list.push(AnyChannel::new(name, FlatSamples::F32(data)));
    }
    let layer = Layer::new(
        (width, height),
        LayerAttributes::default(),
        Encoding::SMALL_LOSSLESS,
        AnyChannels::sort(list),
    );
    Image::from_layer(layer)
        .write()
        .to_file(path)
        .map_err(|e| io_error(path, e))
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

/// Reads every channel of the first layer (largest resolution level, no deep data).
pub fn read_channels(path: &Path) -> Result<ExrChannels> {
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
