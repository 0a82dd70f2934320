//! A texture atlas of a file's colours where they are finer than the mesh
//! decoded: one square tile per base quad, its texels the colour samples
//! of the quad's grid at the atlas's level (a texel centre on each sample),
//! ringed by a gutter that repeats the tile's edge so that bilinear
//! filtering, and the first mipmaps, do not bleed in a neighbour's colours.
//!
//! A vertex of the mesh at a coarser level sits on one of those samples, so
//! its texture coordinate follows from its base quad and grid position
//! alone: no texture coordinate is coded (as MPEG V-DMC derives them from
//! its base mesh's parametrization).

/// Texels of the gutter around each tile.
pub const GUTTER: u32 = 2;

/// A texture atlas: 8-bit sRGB texels, rows from the top.
#[derive(Clone, Debug, PartialEq, Eq)]
#[non_exhaustive]
pub struct Atlas {
    /// Width in texels.
    pub width: u32,
    /// Height in texels.
    pub height: u32,
    /// The texels, `width * height`, row by row from the top.
    pub texels: Vec<[u8; 3]>,
    /// The level of the colour samples on the texels: a tile holds `(2^level
    /// + 1)^2` of them, besides its gutter.
    pub level: u32,
    /// Tiles in a row.
    columns: u32,
}

impl Atlas {
    /// An atlas of `faces` tiles at `level`, each tile's texel `(i, j)` of
    /// its `(2^level + 1)^2` (`i` to the right, `j` down) the colour
    /// `colour(face, i, j)`.
    pub fn new(faces: usize, level: u32, colour: impl Fn(usize, u32, u32) -> [u8; 3]) -> Self {
        let side = (1u32 << level) + 1;
        let tile = side + 2 * GUTTER;
        let columns = ((faces as f64).sqrt().ceil() as u32).max(1);
        let rows = (faces as u32).div_ceil(columns).max(1);
        let (width, height) = (columns * tile, rows * tile);
        let mut texels = vec![[0u8; 3]; width as usize * height as usize];
        for f in 0..faces {
            let (x0, y0) = ((f as u32 % columns) * tile, (f as u32 / columns) * tile);
            for y in 0..tile {
                // The gutter repeats the nearest texel of the tile's own.
                let j = y.saturating_sub(GUTTER).min(side - 1);
                let row = (y0 + y) as usize * width as usize;
                for x in 0..tile {
                    let i = x.saturating_sub(GUTTER).min(side - 1);
                    texels[row + (x0 + x) as usize] = colour(f, i, j);
                }
            }
        }
        Atlas {
            width,
            height,
            texels,
            level,
            columns,
        }
    }

    /// The texture coordinate of grid point `(i, j)` of base face `face` at
    /// `level` (at most the atlas's): `(0, 0)` at the image's top-left
    /// corner, `(1, 1)` at its bottom-right, as glTF has them (OBJ's `vt`
    /// is `(u, 1 - v)`).
    ///
    /// # Panics
    ///
    /// If `level` is finer than the atlas's.
    pub fn texcoord(&self, face: usize, level: u32, i: u32, j: u32) -> [f32; 2] {
        assert!(
            level <= self.level,
            "level {level} above the atlas's {}",
            self.level
        );
        let s = 1u32 << (self.level - level);
        let tile = (1u32 << self.level) + 1 + 2 * GUTTER;
        let (c, r) = (face as u32 % self.columns, face as u32 / self.columns);
        let x = c * tile + GUTTER + i * s;
        let y = r * tile + GUTTER + j * s;
        [
            ((x as f64 + 0.5) / self.width as f64) as f32,
            ((y as f64 + 0.5) / self.height as f64) as f32,
        ]
    }

    /// The texture coordinates of the corners of the mesh of `faces` base
    /// quads at `level`, four a quad in the order of
    /// [`qm_lift::Layout::quads`]. Panics as [`Self::texcoord`] does.
    pub fn corner_texcoords(&self, faces: usize, level: u32) -> Vec<[f32; 2]> {
        let cells = 1u32 << level;
        let mut out = Vec::with_capacity(faces * (cells * cells * 4) as usize);
        for f in 0..faces {
            for b in 0..cells {
                for a in 0..cells {
                    for (i, j) in [(a, b), (a + 1, b), (a + 1, b + 1), (a, b + 1)] {
                        out.push(self.texcoord(f, level, i, j));
                    }
                }
            }
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn texels_sit_on_their_samples_and_gutters_repeat_edges() {
        let colour = |f: usize, i: u32, j: u32| [f as u8, i as u8, j as u8];
        let atlas = Atlas::new(5, 2, colour);
        assert_eq!((atlas.width, atlas.height), (3 * 9, 2 * 9));
        for f in 0..5 {
            for j in 0..=4 {
                for i in 0..=4 {
                    let [u, v] = atlas.texcoord(f, 2, i, j);
                    let x = (u * atlas.width as f32).floor() as usize;
                    let y = (v * atlas.height as f32).floor() as usize;
                    // On the texel's centre.
                    assert!((x as f32 + 0.5 - u * atlas.width as f32).abs() < 1e-3);
                    assert!((y as f32 + 0.5 - v * atlas.height as f32).abs() < 1e-3);
                    assert_eq!(atlas.texels[y * atlas.width as usize + x], colour(f, i, j));
                    // Its neighbours within the gutter: the same tile.
                    for (dx, dy) in [(-1i32, 0i32), (1, 0), (0, -1), (0, 1)] {
                        let (nx, ny) = (x as i32 + dx, y as i32 + dy);
                        let t = atlas.texels[ny as usize * atlas.width as usize + nx as usize];
                        assert_eq!(t[0], f as u8, "no bleeding from another face");
                    }
                }
            }
        }
        // A coarser level's grid points are the atlas's every other.
        assert_eq!(atlas.texcoord(3, 1, 1, 2), atlas.texcoord(3, 2, 2, 4));
        let corners = atlas.corner_texcoords(5, 1);
        assert_eq!(corners.len(), 5 * 4 * 4);
        assert_eq!(corners[4 * 4 + 2], atlas.texcoord(1, 1, 1, 1));
    }
}
