//! The film: beauty and AOV buffers, filled tile by tile.
//!
//! AOVs (arbitrary output variables), all from the camera ray's first hit:
//! - `N` (world-space shading normal, facing the camera) and `albedo`: averaged over all
//!   samples of the pixel (misses count as zero), which anti-aliases them like the beauty;
//! - `Z` (distance from the camera to the first hit, `inf` for a miss), `faceid` (base face,
//!   `-1` for a miss) and `level` (patch subdivision level, `-1` for a miss): from one ray
//!   through the pixel centre and the lens centre, so that they are never blends of
//!   unrelated values.

/// A rectangle of pixels `[x0, x1) × [y0, y1)`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Tile {
    /// Left column.
    pub x0: u32,
    /// Top row.
    pub y0: u32,
    /// One past the right column.
    pub x1: u32,
    /// One past the bottom row.
    pub y1: u32,
}

impl Tile {
    /// Number of pixels.
    pub fn len(&self) -> usize {
        ((self.x1 - self.x0) * (self.y1 - self.y0)) as usize
    }

    /// Whether the tile has no pixels.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
}

/// Tiles of `size × size` pixels covering a `width × height` image, row by row.
pub fn tiles(width: u32, height: u32, size: u32) -> Vec<Tile> {
    let size = size.max(1);
    let mut out = Vec::new();
    let mut y0 = 0;
    while y0 < height {
        let y1 = (y0 + size).min(height);
        let mut x0 = 0;
        while x0 < width {
            let x1 = (x0 + size).min(width);
            out.push(Tile { x0, y0, x1, y1 });
            x0 = x1;
        }
        y0 = y1;
    }
    out
}

/// What one pixel ends up with.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PixelValue {
    /// Mean radiance and alpha (fraction of samples whose camera ray hit geometry).
    pub rgba: [f32; 4],
    /// Mean first-hit shading normal.
    pub normal: [f32; 3],
    /// Mean first-hit albedo.
    pub albedo: [f32; 3],
    /// Camera distance of the centre ray's first hit (`inf` on a miss).
    pub z: f32,
    /// Base face of the centre ray's first hit (`-1` on a miss).
    pub face: f32,
    /// Patch level of the centre ray's first hit (`-1` on a miss).
    pub level: f32,
}

impl Default for PixelValue {
    fn default() -> Self {
        PixelValue {
            rgba: [0.0; 4],
            normal: [0.0; 3],
            albedo: [0.0; 3],
            z: f32::INFINITY,
            face: -1.0,
            level: -1.0,
        }
    }
}

/// Beauty and AOV planes, row-major, `y` downwards.
#[derive(Clone, Debug, PartialEq)]
pub struct Film {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// Per-pixel values.
    pub pixels: Vec<PixelValue>,
}

/// Bytes a `width × height` render holds at its peak: the tiles' pixel values and the film
/// (two [`PixelValue`]s a pixel), and, while the EXR is written, its 13 `f32` planes, the
/// encoder's copy and the encoded file (156 bytes a pixel at worst).
pub fn estimate_bytes(width: u32, height: u32) -> f64 {
    width as f64 * height as f64 * (2.0 * std::mem::size_of::<PixelValue>() as f64 + 156.0)
}

impl Film {
    /// A film with every pixel at its default (black, transparent, miss).
    pub fn new(width: u32, height: u32) -> Film {
        Film {
            width,
            height,
            pixels: vec![PixelValue::default(); (width as usize) * (height as usize)],
        }
    }

    /// Stores a tile's pixels (row-major within the tile).
    pub fn put_tile(&mut self, tile: &Tile, values: &[PixelValue]) {
        let tw = (tile.x1 - tile.x0) as usize;
        for (i, v) in values.iter().enumerate() {
            let x = tile.x0 as usize + i % tw;
            let y = tile.y0 as usize + i / tw;
            if x < self.width as usize && y < self.height as usize {
                self.pixels[y * self.width as usize + x] = *v;
            }
        }
    }

    /// Mean of the beauty's R, G, B over all pixels.
    pub fn mean_rgb(&self) -> [f64; 3] {
        let mut s = [0.0f64; 3];
        for p in &self.pixels {
            for c in 0..3 {
                s[c] += p.rgba[c] as f64;
            }
        }
        let n = self.pixels.len().max(1) as f64;
        [s[0] / n, s[1] / n, s[2] / n]
    }

    /// One plane as a vector, for writers.
    pub fn plane(&self, f: impl Fn(&PixelValue) -> f32) -> Vec<f32> {
        self.pixels.iter().map(f).collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tiles_cover_once() {
        let t = tiles(37, 20, 16);
        assert_eq!(t.len(), 3 * 2);
        let total: usize = t.iter().map(|t| t.len()).sum();
        assert_eq!(total, 37 * 20);
        assert_eq!(
            t[2],
            Tile {
                x0: 32,
                y0: 0,
                x1: 37,
                y1: 16
            }
        );
        assert!(tiles(0, 5, 16).is_empty());
    }

    #[test]
    fn put_tile_places_pixels() {
        let mut f = Film::new(5, 3);
        let tile = Tile {
            x0: 3,
            y0: 1,
            x1: 5,
            y1: 3,
        };
        let mut v = vec![PixelValue::default(); 4];
        v[3].rgba = [1.0, 2.0, 3.0, 1.0];
        f.put_tile(&tile, &v);
        assert_eq!(f.pixels[2 * 5 + 4].rgba, [1.0, 2.0, 3.0, 1.0]);
        assert_eq!(f.mean_rgb()[1], 2.0 / 15.0);
    }
}
