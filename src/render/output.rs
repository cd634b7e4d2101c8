//! The renderer's outputs: the film as an OpenEXR file with AOVs and as tone-mapped 8-bit sRGB
//! PNG previews (through [`crate::io`]).
//!
//! EXR channels, all 32-bit float, one layer:
//!
//! | channel | meaning |
//! |---|---|
//! | `R G B A` | mean radiance; alpha = fraction of samples whose camera ray hit geometry |
//! | `Z` | camera distance of the first hit (`inf` for a miss) |
//! | `N.X N.Y N.Z` | first-hit world-space shading normal (facing the camera), sample mean |
//! | `albedo.R albedo.G albedo.B` | first-hit albedo, sample mean |
//! | `faceid` | base face of the first hit (`-1` for a miss) |
//! | `level` | patch subdivision level of the first hit (`-1` for a miss) |
//!
//! Tone curve of the previews: the radiance is multiplied by `2^exposure`, mapped per channel
//! with the ACES filmic fit of Narkowicz (2015), `x(2.51x + 0.03) / (x(2.43x + 0.59) + 0.14)`,
//! clamped to `[0, 1]`, encoded with the sRGB transfer function and rounded to 8 bits. Alpha is
//! not written (the preview is opaque).

use super::film::Film;
use crate::error::Result;
use crate::io::output::Output;
use std::path::Path;

/// The channel names written by [`write_film`], in the order of the table above.
pub const CHANNELS: [&str; 13] = [
    "R", "G", "B", "A", "Z", "N.X", "N.Y", "N.Z", "albedo.R", "albedo.G", "albedo.B", "faceid",
    "level",
];

fn film_planes(film: &Film) -> Vec<(&'static str, Vec<f32>)> {
    vec![
        ("R", film.plane(|p| p.rgba[0])),
        ("G", film.plane(|p| p.rgba[1])),
        ("B", film.plane(|p| p.rgba[2])),
        ("A", film.plane(|p| p.rgba[3])),
        ("Z", film.plane(|p| p.z)),
        ("N.X", film.plane(|p| p.normal[0])),
        ("N.Y", film.plane(|p| p.normal[1])),
        ("N.Z", film.plane(|p| p.normal[2])),
        ("albedo.R", film.plane(|p| p.albedo[0])),
        ("albedo.G", film.plane(|p| p.albedo[1])),
        ("albedo.B", film.plane(|p| p.albedo[2])),
        ("faceid", film.plane(|p| p.face)),
        ("level", film.plane(|p| p.level)),
    ]
}

/// Writes the film's beauty and AOVs (see the module documentation for the channels).
pub fn write_film(path: &Path, film: &Film) -> Result<()> {
    let mut out = Output::create(path)?;
    write_film_to(&mut out, film)?;
    out.commit()
}

/// [`write_film`] into an output opened (and so checked) before the render; the caller
/// commits it.
pub fn write_film_to(out: &mut Output, film: &Film) -> Result<()> {
    let (w, h) = (film.width as usize, film.height as usize);
    crate::io::exr::write_planes_to(out, w, h, film_planes(film))
}

/// The ACES filmic approximation (Narkowicz 2015), clamped to `[0, 1]`.
pub fn aces(x: f32) -> f32 {
    let x = if x.is_finite() { x.max(0.0) } else { 0.0 };
    let v = x * (2.51 * x + 0.03) / (x * (2.43 * x + 0.59) + 0.14);
    v.clamp(0.0, 1.0)
}

/// The sRGB transfer function for linear values in `[0, 1]`.
pub fn srgb_encode(x: f32) -> f32 {
    if x <= 0.003_130_8 {
        12.92 * x
    } else {
        1.055 * x.powf(1.0 / 2.4) - 0.055
    }
}

/// The 8-bit sRGB value of one linear radiance channel at `exposure` stops.
pub fn tone_map(x: f32, exposure: f32) -> u8 {
    let v = srgb_encode(aces(x * exposure.exp2()));
    (v * 255.0 + 0.5).clamp(0.0, 255.0) as u8
}

/// Writes the film's beauty as a tone-mapped sRGB PNG.
pub fn write_preview(path: &Path, film: &Film, exposure: f32) -> Result<()> {
    let mut out = Output::create(path)?;
    write_preview_to(&mut out, film, exposure)?;
    out.commit()
}

/// [`write_preview`] into an output opened before the render; the caller commits it.
pub fn write_preview_to(out: &mut Output, film: &Film, exposure: f32) -> Result<()> {
    let mut buf = Vec::with_capacity(film.pixels.len() * 3);
    for p in &film.pixels {
        for c in 0..3 {
            buf.push(tone_map(p.rgba[c], exposure));
        }
    }
    crate::io::png::write_rgb8_to(out, film.width, film.height, buf)
}

/// Colours of patch levels 0, 1, 2, … in [`write_levels_preview`] (the last repeats).
pub const LEVEL_COLOURS: [[f32; 3]; 8] = [
    [0.20, 0.45, 0.90],
    [0.20, 0.75, 0.35],
    [0.95, 0.85, 0.20],
    [0.95, 0.55, 0.15],
    [0.90, 0.25, 0.20],
    [0.80, 0.30, 0.75],
    [0.55, 0.35, 0.95],
    [0.95, 0.95, 0.95],
];

/// Writes the papers' coloured-levels view: each pixel's patch level (the `level` AOV) as a
/// colour from [`LEVEL_COLOURS`], shaded by the tone-mapped beauty so the shapes stay
/// readable; misses are black.
pub fn write_levels_preview(path: &Path, film: &Film, exposure: f32) -> Result<()> {
    let mut out = Output::create(path)?;
    write_levels_preview_to(&mut out, film, exposure)?;
    out.commit()
}

/// [`write_levels_preview`] into an output opened before the render; the caller commits it.
pub fn write_levels_preview_to(out: &mut Output, film: &Film, exposure: f32) -> Result<()> {
    let mut buf = Vec::with_capacity(film.pixels.len() * 3);
    for p in &film.pixels {
        if p.level < 0.0 {
            buf.extend_from_slice(&[0, 0, 0]);
            continue;
        }
        let c = LEVEL_COLOURS[(p.level as usize).min(LEVEL_COLOURS.len() - 1)];
        let lum = 0.2126 * p.rgba[0] + 0.7152 * p.rgba[1] + 0.0722 * p.rgba[2];
        let shade = 0.35 + 0.65 * srgb_encode(aces(lum * exposure.exp2()));
        for ch in c {
            buf.push((srgb_encode(ch * shade) * 255.0 + 0.5).clamp(0.0, 255.0) as u8);
        }
    }
    crate::io::png::write_rgb8_to(out, film.width, film.height, buf)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn curve() {
        assert_eq!(tone_map(0.0, 0.0), 0);
        assert_eq!(tone_map(1e9, 0.0), 255);
        assert_eq!(tone_map(f32::NAN, 0.0), 0);
        // ACES(0.18) ≈ 0.267 → sRGB ≈ 0.555 → 141.
        assert_eq!(tone_map(0.18, 0.0), 141);
        assert!(tone_map(0.18, 1.0) > tone_map(0.18, 0.0));
    }
}
