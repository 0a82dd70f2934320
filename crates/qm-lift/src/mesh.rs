//! Semi-regular meshes and the quantization of their samples.

use glam::DVec3;
use serde::{Deserialize, Serialize};

use crate::layout::Layout;
use crate::{Error, Result};

/// A quantized sample or coefficient: three integer coordinates.
pub type Coord = [i32; 3];

/// Fewest quantization bits per coordinate.
pub const MIN_BITS: u32 = 4;
/// Most quantization bits per coordinate (lifting stays inside `i32`).
pub const MAX_BITS: u32 = 24;
/// Default quantization bits per coordinate.
pub const DEFAULT_BITS: u32 = 16;

/// A base quad mesh whose faces are refined to regular `(2^L + 1)^2` grids,
/// with one position per sample (see [`Layout`] for where each sample lives).
#[derive(Clone, Debug)]
pub struct SemiRegularMesh {
    layout: Layout,
    positions: Vec<DVec3>,
}

impl SemiRegularMesh {
    /// Pairs a layout with its sample positions.
    pub fn new(layout: Layout, positions: Vec<DVec3>) -> Result<Self> {
        if positions.len() != layout.sample_count() {
            return Err(Error::SizeMismatch {
                what: "sample positions",
                expected: layout.sample_count(),
                found: positions.len(),
            });
        }
        if positions.iter().any(|p| !p.is_finite()) {
            return Err(Error::NonFinite);
        }
        Ok(SemiRegularMesh { layout, positions })
    }

    /// Builds a semi-regular mesh from per-face grids of input vertex ids:
    /// `grids[f * (n+1)^2 + j * (n+1) + i]` names the input vertex at `(i, j)`
    /// of base face `f`. Returns the mesh and, for each sample, the input
    /// vertex it came from.
    pub fn from_face_grids(
        layout: Layout,
        grids: &[u32],
        input: &[DVec3],
    ) -> Result<(Self, Vec<u32>)> {
        let side = layout.n() + 1;
        let expected = layout.face_count() * side * side;
        if grids.len() != expected {
            return Err(Error::SizeMismatch {
                what: "face grids",
                expected,
                found: grids.len(),
            });
        }
        let mut source = vec![u32::MAX; layout.sample_count()];
        for f in 0..layout.face_count() {
            let ids = &grids[f * side * side..(f + 1) * side * side];
            for (&sample, &vertex) in layout.face_grid(f).iter().zip(ids) {
                if vertex as usize >= input.len() {
                    return Err(Error::SizeMismatch {
                        what: "input vertex index",
                        expected: input.len(),
                        found: vertex as usize,
                    });
                }
                let slot = &mut source[sample as usize];
                if *slot != u32::MAX && *slot != vertex {
                    return Err(Error::InconsistentGrid { sample });
                }
                *slot = vertex;
            }
        }
        let positions = source.iter().map(|&v| input[v as usize]).collect();
        Ok((SemiRegularMesh::new(layout, positions)?, source))
    }

    /// The sample layout.
    pub fn layout(&self) -> &Layout {
        &self.layout
    }

    /// Sample positions, indexed by sample id.
    pub fn positions(&self) -> &[DVec3] {
        &self.positions
    }

    /// The mesh `finer` levels finer: the same base and points, every
    /// finer sample placed inside its quad of this mesh's finest grid on
    /// the two flat triangles a renderer draws for it, split along the
    /// diagonal from grid corner `(i, j)` to `(i + 1, j + 1)` (corners 0
    /// and 2 of [`Layout::quads`]): where a texture mapped by grid
    /// position shows each point. Numbered as [`Layout::new`] numbers
    /// that level; fails where that level is beyond what a layout allows.
    pub fn refined(&self, finer: u32) -> Result<SemiRegularMesh> {
        let layout = Layout::new(self.layout.base().clone(), self.layout.level() + finer)?;
        let (n, scale) = (self.layout.n(), 1usize << finer);
        // A point `x` of the fine grid: the coarse cell it lies in and where.
        let cell = |x: usize| {
            let a = (x / scale).min(n - 1);
            (a, x as f64 / scale as f64 - a as f64)
        };
        let mut positions = vec![DVec3::ZERO; layout.sample_count()];
        for f in 0..layout.face_count() {
            let at = |i: usize, j: usize| self.positions[self.layout.sample(f, i, j) as usize];
            for j in 0..=n * scale {
                let (b, t) = cell(j);
                for i in 0..=n * scale {
                    let (a, s) = cell(i);
                    let (p0, p2) = (at(a, b), at(a + 1, b + 1));
                    positions[layout.sample(f, i, j) as usize] = if s >= t {
                        p0 + s * (at(a + 1, b) - p0) + t * (p2 - at(a + 1, b))
                    } else {
                        p0 + s * (p2 - at(a, b + 1)) + t * (at(a, b + 1) - p0)
                    };
                }
            }
        }
        SemiRegularMesh::new(layout, positions)
    }

    /// Splits into layout and positions.
    pub fn into_parts(self) -> (Layout, Vec<DVec3>) {
        (self.layout, self.positions)
    }
}

/// Uniform quantization of positions onto a cube grid around their bounding
/// box: one step for all three axes so shapes keep their proportions.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Quantizer {
    /// Bits per coordinate.
    pub bits: u32,
    /// Lower corner of the bounding box.
    pub origin: [f64; 3],
    /// Length of one quantization step.
    pub step: f64,
}

impl Quantizer {
    /// The quantizer for `bits` bits over the bounding box of `points`.
    pub fn fit(points: &[DVec3], bits: u32) -> Result<Self> {
        if !(MIN_BITS..=MAX_BITS).contains(&bits) {
            return Err(Error::BadBits { bits });
        }
        if points.iter().any(|p| !p.is_finite()) {
            return Err(Error::NonFinite);
        }
        let (lo, hi) = bounding_box(points);
        let extent = (hi - lo).max_element();
        let levels = ((1u64 << bits) - 1) as f64;
        let step = if extent > 0.0 { extent / levels } else { 1.0 };
        Ok(Quantizer {
            bits,
            origin: lo.to_array(),
            step,
        })
    }

    /// Grid coordinates of `p`, each in `0 .. 2^bits`.
    pub fn quantize(&self, p: DVec3) -> [i32; 3] {
        let max = ((1i64 << self.bits) - 1) as f64;
        let q = ((p - DVec3::from(self.origin)) / self.step)
            .round()
            .clamp(DVec3::ZERO, DVec3::splat(max));
        [q.x as i32, q.y as i32, q.z as i32]
    }

    /// Position of grid coordinates `q` (need not be integral).
    pub fn dequantize(&self, q: [f64; 3]) -> DVec3 {
        DVec3::from(self.origin) + DVec3::from(q) * self.step
    }

    /// Quantizes every point.
    pub fn quantize_all(&self, points: &[DVec3]) -> Vec<[i32; 3]> {
        points.iter().map(|&p| self.quantize(p)).collect()
    }
}

/// Axis-aligned bounding box `(min, max)`; zero for an empty slice.
pub fn bounding_box(points: &[DVec3]) -> (DVec3, DVec3) {
    if points.is_empty() {
        return (DVec3::ZERO, DVec3::ZERO);
    }
    points
        .iter()
        .fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(lo, hi), &p| {
            (lo.min(p), hi.max(p))
        })
}

/// A number of bytes for people: `512 B`, `1.5 KiB`, `230 MiB`, `3.3 GiB`
/// (powers of 1024), for the memory limits of every layer.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ByteSize(pub u64);

impl std::fmt::Display for ByteSize {
    // Integers only: float formatting would add 9 KB to the browser
    // decoder's gzipped wasm.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        const UNITS: [&str; 5] = ["B", "KiB", "MiB", "GiB", "TiB"];
        let bytes = u128::from(self.0);
        let mut unit = 0;
        while unit + 1 < UNITS.len() && bytes >= 1024u128.pow(unit as u32 + 1) {
            unit += 1;
        }
        let size = 1024u128.pow(unit as u32);
        // Tenths, rounded half up.
        let tenths = (bytes * 10 + size / 2) / size;
        if unit == 0 || tenths >= 1000 || tenths % 10 == 0 {
            write!(f, "{} {}", (tenths + 5) / 10, UNITS[unit])
        } else {
            write!(f, "{}.{} {}", tenths / 10, tenths % 10, UNITS[unit])
        }
    }
}

/// The extents (as powers of two) within which meshes are worked on as
/// they are: every ordinary unit. Outside, squared lengths and areas can
/// overflow or fall to subnormals and zero (at 1e160 a remesh grid's cell
/// count overflowed; at 1e-80 no face had a positive area).
const UNSCALED_LOG2: std::ops::RangeInclusive<f64> = -20.0..=20.0;

/// The power of two that brings the largest extent of the bounding box of
/// `points` near 1, or 1 when it is within 2^-20 to 2^20 already (or the
/// box is empty, a point or not finite). The remesher, the distance and
/// the encoder's holds work on meshes of far units at that scale:
/// multiplying by a power of two is exact both ways, unless it underflows.
pub fn unit_scale(points: &[DVec3]) -> f64 {
    let (lo, hi) = bounding_box(points);
    // Halves: the extent of a box over the whole f64 range overflows.
    let half = (hi * 0.5 - lo * 0.5).max_element();
    if !half.is_finite() || half <= 0.0 {
        return 1.0;
    }
    let log2 = half.log2() + 1.0;
    if UNSCALED_LOG2.contains(&log2) {
        return 1.0;
    }
    (-log2.round()).clamp(-1020.0, 1020.0).exp2()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn refined_meshes_keep_their_points_and_interpolate_between() {
        let mesh = crate::synthetic::bumpy_sphere(2);
        let same = mesh.refined(0).unwrap();
        assert_eq!(same.positions(), mesh.positions());
        let fine = mesh.refined(2).unwrap();
        let (coarse, finer) = (mesh.layout(), fine.layout());
        assert_eq!(finer.level(), 4);
        for f in 0..coarse.face_count() {
            for j in 0..4 {
                for i in 0..4 {
                    let p = |i, j| mesh.positions()[coarse.sample(f, i, j) as usize];
                    let q = |i, j| fine.positions()[finer.sample(f, i, j) as usize];
                    assert_eq!(q(4 * i, 4 * j), p(i, j));
                    // On the diagonal, the edges, and inside each triangle.
                    let middle = p(i, j).lerp(p(i + 1, j + 1), 0.5);
                    assert!(q(4 * i + 2, 4 * j + 2).distance(middle) < 1e-12);
                    let quarter = p(i, j).lerp(p(i + 1, j), 0.25);
                    assert!(q(4 * i + 1, 4 * j).distance(quarter) < 1e-12);
                    let side = p(i, j).lerp(p(i, j + 1), 0.75);
                    assert!(q(4 * i, 4 * j + 3).distance(side) < 1e-12);
                    // Inside the triangles a-b-c (below the diagonal) and
                    // a-c-d (above it), by their barycentric weights.
                    let (a, b, c, d) = (p(i, j), p(i + 1, j), p(i + 1, j + 1), p(i, j + 1));
                    let below = 0.25 * a + 0.5 * b + 0.25 * c;
                    assert!(q(4 * i + 3, 4 * j + 1).distance(below) < 1e-12);
                    let above = 0.5 * a + 0.25 * c + 0.25 * d;
                    assert!(q(4 * i + 1, 4 * j + 2).distance(above) < 1e-12);
                }
            }
        }
        assert!(mesh.refined(crate::MAX_LEVEL).is_err());
    }

    #[test]
    fn byte_sizes_read_as_people_write_them() {
        let text = |n| ByteSize(n).to_string();
        assert_eq!(text(1), "1 B");
        assert_eq!(text(1023), "1023 B");
        assert_eq!(text(1536), "1.5 KiB");
        assert_eq!(text(230 << 20), "230 MiB");
        assert_eq!(text(1 << 30), "1 GiB");
        assert_eq!(text(3_330_000_000), "3.1 GiB");
    }

    #[test]
    fn unit_scales_are_powers_of_two_for_far_units_only() {
        let box_of = |s: f64| [DVec3::ZERO, DVec3::new(s, s / 2.0, 0.0)];
        assert_eq!(unit_scale(&box_of(1.0)), 1.0);
        assert_eq!(unit_scale(&box_of(1e5)), 1.0);
        assert_eq!(unit_scale(&box_of(1e-6)), 1.0);
        assert_eq!(unit_scale(&box_of(2f64.powi(300))), 2f64.powi(-300));
        assert_eq!(unit_scale(&box_of(2f64.powi(-300))), 2f64.powi(300));
        assert_eq!(unit_scale(&box_of(1e307)), 2f64.powi(-1020));
        assert_eq!(
            unit_scale(&[DVec3::splat(-1e308), DVec3::splat(1e308)]),
            2f64.powi(-1020)
        );
        assert_eq!(unit_scale(&[]), 1.0);
        assert_eq!(unit_scale(&[DVec3::ZERO, DVec3::X * f64::NAN]), 1.0);
    }

    #[test]
    fn quantization_spans_the_longest_axis() {
        let pts = [DVec3::new(-1.0, 0.0, 2.0), DVec3::new(3.0, 1.0, 2.5)];
        let q = Quantizer::fit(&pts, 8).unwrap();
        assert_eq!(q.quantize(pts[0]), [0, 0, 0]);
        assert_eq!(q.quantize(pts[1])[0], 255);
        let back = q.dequantize([255.0, 0.0, 0.0]);
        assert!((back.x - 3.0).abs() < 1e-12);
        assert!(Quantizer::fit(&pts, 40).is_err());
        assert!(Quantizer::fit(&[DVec3::new(f64::NAN, 0.0, 0.0)], 8).is_err());
    }
}
