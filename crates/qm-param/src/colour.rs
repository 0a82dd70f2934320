//! The colour of a surface at any point, and how far apart two surfaces'
//! colours are.
//!
//! [`ColourSurface`] answers "what colour is the point of this asset's
//! surface closest to `p`": the closest point comes from the exact search
//! that [`distance()`](crate::distance()) uses (the same fan of each face into
//! triangles), with the triangle it lies in and its barycentric coordinates
//! `(w0, w1, w2)` there. The colour of that point, by the first rule that
//! applies to its face:
//!
//! 1. **Textured face** (its material has a decoded base colour image and
//!    every corner of the triangle has texture coordinates): the corners'
//!    coordinates interpolated, `uv = w0 uv0 + w1 uv1 + w2 uv2`, the image
//!    sampled there bilinearly between the four nearest texel centres (texel
//!    `(i, j)` has its centre at `((i + 0.5) / width, (j + 0.5) / height)`,
//!    `(0, 0)` the image's top-left corner as the readers give it; wrapping
//!    repeats the image), times the material's base colour factor. Vertex
//!    colours are not applied on a textured face.
//! 2. **Vertex colours**: `w0 c0 + w1 c1 + w2 c2`.
//! 3. Otherwise the material's base colour factor, or mid grey (sRGB 0.5)
//!    for a face without material.
//!
//! All of it is done on sRGB-encoded values, as files store them (the
//! readers convert glTF's linear colours to sRGB): interpolating in sRGB
//! rather than in linear light is what a renderer does with an 8-bit sRGB
//! texture sampled without sRGB decoding, and between two nearby colours the
//! difference is small. Alpha is ignored. The result is rounded to 8 bits a
//! channel.
//!
//! [`colour_distance`] compares two assets' colours as [`distance()`](crate::distance())
//! compares their surfaces, at the very same area-uniform samples: a sample
//! on `A` has its own colour (interpolated on `A` at the sample), `B`'s
//! colour is taken at `B`'s point closest to it, and the one-sided figure is
//! the RMS of the 8-bit differences over the three channels; symmetrically
//! from `B`, and the symmetric figure is the larger RMS of the two sides, as
//! for the geometry. `psnr_db = 20 log10(255 / rms)`.

use std::borrow::Cow;

use qm_io::{Asset, Image, Material};
use qm_lift::glam::DVec3;
use rayon::prelude::*;
use serde::Serialize;

use crate::closest::Closest;
use crate::distance::{DistanceOptions, Side, Triangles, fold_samples, scaled};
use crate::{Error, Result};

/// Mid grey, the colour of a face with neither colours nor material.
const GREY: [f64; 3] = [0.5; 3];

/// The colour of an asset's surface at the point closest to any point: the
/// rules are in the module docs (`qm_param::colour`). Borrows the asset.
pub struct ColourSurface<'a> {
    asset: &'a Asset,
    closest: Closest,
    /// Where the search is moved to, at `scale`.
    origin: DVec3,
    /// The power of two the mesh is held at.
    scale: f64,
    /// The fanned triangles' vertices, and their faces and fan positions, as
    /// [`Triangles`] numbers them.
    triangles: Vec<[u32; 3]>,
    fans: Vec<[u32; 2]>,
    /// The corner index (over all faces) of each face's first corner.
    first_corners: Vec<u32>,
}

impl<'a> ColourSurface<'a> {
    /// The coloured surface of `asset`, or `None` when the asset has no
    /// appearance ([`ColourSurface::has_appearance`]): no vertex colours and
    /// no decoded base colour texture, so that every point would have its
    /// material's flat colour.
    ///
    /// Fails, as [`Surface::new`](crate::distance::Surface::new) does, for a
    /// mesh with no face of positive area, a face that refers to a missing
    /// vertex or a used vertex that is not finite, and with
    /// [`Error::Appearance`] for an appearance that does not fit the mesh.
    pub fn new(asset: &'a Asset) -> Result<Option<Self>> {
        if !Self::has_appearance(asset) {
            return Ok(None);
        }
        let scale = qm_lift::unit_scale(&asset.mesh.positions);
        let mesh = held_at(&asset.mesh, scale);
        let triangles = Triangles::new(&mesh, Side::A)?;
        let origin = triangles.bbox_center();
        Self::on(asset, &triangles, origin, scale, None).map(Some)
    }

    /// Whether `asset` has vertex colours, or a material with a decoded base
    /// colour image and texture coordinates to map it (read the asset with
    /// [`AssetOptions::images`](qm_io::AssetOptions::images) set). Materials'
    /// flat colours alone do not count: most OBJ files name a default grey
    /// material.
    pub fn has_appearance(asset: &Asset) -> bool {
        let textured =
            asset.tex_coords.is_some() && asset.materials.iter().any(|m| image_of(m).is_some());
        asset.colors.is_some() || textured
    }

    /// The surface of `asset` over `triangles` (its mesh fanned at `scale`),
    /// its search moved by `-origin`; `side` names the asset in errors.
    fn on(
        asset: &'a Asset,
        triangles: &Triangles,
        origin: DVec3,
        scale: f64,
        side: Option<Side>,
    ) -> Result<Self> {
        let first_corners = check_appearance(asset, side)?;
        Ok(ColourSurface {
            asset,
            closest: triangles.closest_indexed(origin),
            origin,
            scale,
            triangles: triangles.triangles.clone(),
            fans: triangles.fans.clone(),
            first_corners,
        })
    }

    /// The 8-bit sRGB colour of the surface point closest to `p`.
    pub fn colour_at(&self, p: DVec3) -> [u8; 3] {
        to_8_bits(self.colour_moved(p * self.scale - self.origin))
    }

    /// [`ColourSurface::colour_at`] for every point, in parallel; the result
    /// does not depend on the number of threads.
    pub fn colours_at(&self, points: &[DVec3]) -> Vec<[u8; 3]> {
        points.par_iter().map(|&p| self.colour_at(p)).collect()
    }

    /// The material of face `face`, if any.
    fn material(&self, face: usize) -> Option<&'a Material> {
        material_of(self.asset, face)
    }

    /// For fanned triangle `t` of a textured face: its material, the
    /// material's image and the texture coordinates of its corners.
    fn textured(&self, t: usize) -> Option<(&'a Material, &'a Image, [[f32; 2]; 3])> {
        let [face, k] = self.fans[t].map(|x| x as usize);
        let material = self.material(face)?;
        let image = image_of(material)?;
        let uv = self.asset.tex_coords.as_ref()?;
        Some((
            material,
            image,
            fan_texcoords(uv, self.first_corners[face] as usize, k)?,
        ))
    }

    /// Texels of decoded texture images that the surface shows
    /// ([`texels`]).
    pub fn texels(&self) -> f64 {
        texels(self.asset)
    }

    /// The colour (0..1) at the point closest to `p`, given moved and
    /// scaled as the search is.
    fn colour_moved(&self, p: DVec3) -> [f64; 3] {
        let found = self.closest.locate(p);
        self.colour_on(found.triangle, found.barycentric)
    }

    /// The colour (0..1) at barycentric coordinates `w` of fanned triangle
    /// `t`.
    fn colour_on(&self, t: usize, w: [f64; 3]) -> [f64; 3] {
        if let Some((material, image, [a, b, c])) = self.textured(t) {
            let at =
                |i: usize| w[0] * f64::from(a[i]) + w[1] * f64::from(b[i]) + w[2] * f64::from(c[i]);
            let texel = bilinear(image, at(0), at(1));
            return std::array::from_fn(|i| texel[i] * f64::from(material.base_color[i]));
        }
        let material = self.material(self.fans[t][0] as usize);
        if let Some(colours) = &self.asset.colors {
            let [a, b, c] = self.triangles[t].map(|v| colours[v as usize]);
            return std::array::from_fn(|i| {
                w[0] * f64::from(a[i]) + w[1] * f64::from(b[i]) + w[2] * f64::from(c[i])
            });
        }
        material.map_or(GREY, |m| [0, 1, 2].map(|i| f64::from(m.base_color[i])))
    }
}

/// The material of face `face` of `asset`, if any.
fn material_of(asset: &Asset, face: usize) -> Option<&Material> {
    match &asset.face_materials {
        Some(list) => asset.materials.get(*list.get(face)? as usize),
        None => asset.materials.first(),
    }
}

/// Texels of decoded texture images that `asset`'s surface shows: over
/// the faces with a decoded base colour image and texture coordinates at
/// their corners (rule 1 of the module docs), each fanned triangle's area
/// in texture space times its image's texel count (an image repeated over
/// the surface counts each time). 0 without a texture. The colour a
/// remesh can carry is as fine as this many samples spread over the
/// surface.
pub fn texels(asset: &Asset) -> f64 {
    let Some(uv) = &asset.tex_coords else {
        return 0.0;
    };
    let mut first = 0;
    let mut sum = 0.0;
    for (f, face) in asset.mesh.faces().enumerate() {
        if let Some(image) = material_of(asset, f).and_then(image_of) {
            let texels = image.width as f64 * image.height as f64;
            for k in 0..face.len().saturating_sub(2) {
                if let Some([a, b, c]) = fan_texcoords(uv, first, k) {
                    let d = |p: [f32; 2]| [f64::from(p[0] - a[0]), f64::from(p[1] - a[1])];
                    let ([x1, y1], [x2, y2]) = (d(b), d(c));
                    sum += 0.5 * (x1 * y2 - x2 * y1).abs() * texels;
                }
            }
        }
        first += face.len();
    }
    sum
}

/// The texture coordinates of fanned triangle `k` (corners 0, `k + 1`, `k +
/// 2`) of the face whose first corner is `first`, where all three have them.
fn fan_texcoords(uv: &qm_io::TexCoords, first: usize, k: usize) -> Option<[[f32; 2]; 3]> {
    let [a, b, c] = [first, first + k + 1, first + k + 2].map(|c| uv.get(c));
    Some([a?, b?, c?])
}

/// The decoded base colour image of a material, if any.
fn image_of(material: &Material) -> Option<&Image> {
    material.base_color_texture.as_ref()?.image.as_ref()
}

/// `mesh` at `scale` (borrowed when the scale is 1).
fn held_at(mesh: &qm_io::PolyMesh, scale: f64) -> Cow<'_, qm_io::PolyMesh> {
    if scale == 1.0 {
        Cow::Borrowed(mesh)
    } else {
        Cow::Owned(scaled(mesh, scale))
    }
}

/// Checks that `asset`'s appearance fits its mesh, and returns the corner
/// index of each face's first corner.
fn check_appearance(asset: &Asset, side: Option<Side>) -> Result<Vec<u32>> {
    let problem = |problem: String| Error::Appearance {
        mesh: side,
        problem,
    };
    let mesh = &asset.mesh;
    if let Some(colours) = &asset.colors
        && colours.len() != mesh.positions.len()
    {
        return Err(problem(format!(
            "{} colours for {} vertices",
            colours.len(),
            mesh.positions.len()
        )));
    }
    let mut first_corners = Vec::with_capacity(mesh.face_count());
    let mut corners = 0u64;
    for face in mesh.faces() {
        first_corners.push(u32::try_from(corners).map_err(|_| problem("too many corners".into()))?);
        corners += face.len() as u64;
    }
    if let Some(uv) = &asset.tex_coords
        && uv.corners.len() as u64 != corners
    {
        return Err(problem(format!(
            "texture coordinates for {} corners, the faces have {corners}",
            uv.corners.len()
        )));
    }
    if let Some(list) = &asset.face_materials {
        if list.len() != mesh.face_count() {
            return Err(problem(format!(
                "materials for {} faces, the mesh has {}",
                list.len(),
                mesh.face_count()
            )));
        }
        if let Some((face, m)) = list
            .iter()
            .enumerate()
            .find(|&(_, &m)| m as usize >= asset.materials.len())
        {
            return Err(problem(format!(
                "face {face} has material {m}, of {} materials",
                asset.materials.len()
            )));
        }
    }
    for material in &asset.materials {
        if let Some(image) = image_of(material) {
            let pixels = u64::from(image.width) * u64::from(image.height);
            if pixels == 0 || image.rgba.len() as u64 != 4 * pixels {
                return Err(problem(format!(
                    "the image of material {:?} is {}x{} pixels but holds {} bytes",
                    material.name,
                    image.width,
                    image.height,
                    image.rgba.len()
                )));
            }
        }
    }
    Ok(first_corners)
}

/// The image's colour (0..1) at `(u, v)`, bilinear between the four nearest
/// texel centres, the image repeated.
fn bilinear(image: &Image, u: f64, v: f64) -> [f64; 3] {
    let (width, height) = (i64::from(image.width), i64::from(image.height));
    let x = u * width as f64 - 0.5;
    let y = v * height as f64 - 0.5;
    let (x0, y0) = (x.floor(), y.floor());
    let (fx, fy) = (x - x0, y - y0);
    // `as` saturates (and takes NaN to 0); the remainder wraps.
    let (x0, y0) = (x0 as i64, y0 as i64);
    let texel = |i: i64, j: i64| {
        let (i, j) = (i.rem_euclid(width) as usize, j.rem_euclid(height) as usize);
        let at = 4 * (j * image.width as usize + i);
        let rgba = &image.rgba[at..at + 3];
        [0, 1, 2].map(|c| f64::from(rgba[c]) / 255.0)
    };
    let (a, b) = (texel(x0, y0), texel(x0.wrapping_add(1), y0));
    let (c, d) = (
        texel(x0, y0.wrapping_add(1)),
        texel(x0.wrapping_add(1), y0.wrapping_add(1)),
    );
    std::array::from_fn(|k| {
        let top = a[k] + (b[k] - a[k]) * fx;
        let bottom = c[k] + (d[k] - c[k]) * fx;
        top + (bottom - top) * fy
    })
}

/// A colour in 0..1 rounded to 8 bits a channel (NaN to 0).
fn to_8_bits(colour: [f64; 3]) -> [u8; 3] {
    colour.map(|c| (c.clamp(0.0, 1.0) * 255.0).round() as u8)
}

/// The colour difference from the samples of one surface to the other.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct ColourSide {
    /// Root mean square difference of the 8-bit channels (0..255), over the
    /// samples and the three channels.
    pub rms: f64,
    /// `20 log10(255 / rms)`, infinite when `rms` is 0.
    pub psnr_db: f64,
    /// Number of samples taken.
    pub samples: usize,
}

/// What [`colour_distance`] measures. An infinite `psnr_db` (equal colours)
/// is written as `null` by serde_json.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct ColourReport {
    /// The larger of the two one-sided RMS differences, in 8-bit units.
    pub rms: f64,
    /// `20 log10(255 / rms)`.
    pub psnr_db: f64,
    /// Samples on `A`, colours compared with `B`'s at the closest points.
    pub a_to_b: ColourSide,
    /// Samples on `B`, colours compared with `A`'s.
    pub b_to_a: ColourSide,
}

/// Compares the colours of the surfaces of `a` and `b` (module docs), at the
/// samples [`distance()`](crate::distance()) takes with the same `options`.
/// `None` when either asset has no appearance
/// ([`ColourSurface::has_appearance`]).
///
/// Fails as [`distance()`](crate::distance()) does (a mesh without a face of
/// positive area, a missing vertex, a used vertex that is not finite, no
/// samples), and with [`Error::Appearance`] for an appearance that does not
/// fit its mesh.
pub fn colour_distance(
    a: &Asset,
    b: &Asset,
    options: &DistanceOptions,
) -> Result<Option<ColourReport>> {
    if options.samples == 0 {
        return Err(Error::NoSamples);
    }
    if !ColourSurface::has_appearance(a) || !ColourSurface::has_appearance(b) {
        return Ok(None);
    }
    // As `distance()`: both at A's power-of-two scale, around a common
    // origin, so the samples are the same.
    let scale = qm_lift::unit_scale(&a.mesh.positions);
    let (mesh_a, mesh_b) = (held_at(&a.mesh, scale), held_at(&b.mesh, scale));
    let ta = Triangles::new(&mesh_a, Side::A)?;
    let tb = Triangles::new(&mesh_b, Side::B)?;
    let origin = 0.5 * (ta.bbox_center() + tb.bbox_center());
    let ca = ColourSurface::on(a, &ta, origin, scale, Some(Side::A))?;
    let cb = ColourSurface::on(b, &tb, origin, scale, Some(Side::B))?;
    // On one mesh a sample's closest point is itself: compared in place,
    // without the rounding of a projection.
    let same = a.mesh == b.mesh;
    let (a_to_b, b_to_a) = rayon::join(
        || one_sided(&ta, &ca, &cb, same, origin, options),
        || one_sided(&tb, &cb, &ca, same, origin, options),
    );
    let rms = a_to_b.rms.max(b_to_a.rms);
    Ok(Some(ColourReport {
        rms,
        psnr_db: colour_psnr(rms),
        a_to_b,
        b_to_a,
    }))
}

/// Colour PSNR over 8-bit RGB of an RMS error in levels, `20 log10(255 /
/// rms)` (infinite at 0).
pub fn colour_psnr(rms: f64) -> f64 {
    if rms > 0.0 {
        20.0 * (255.0 / rms).log10()
    } else {
        f64::INFINITY
    }
}

/// Colour differences from the samples of `from` (the triangles of
/// `own`'s mesh) to `other`.
fn one_sided(
    from: &Triangles,
    own: &ColourSurface,
    other: &ColourSurface,
    same: bool,
    origin: DVec3,
    options: &DistanceOptions,
) -> ColourSide {
    // Integer sums: exact, so the order of the partial sums cannot matter.
    let (count, squares) = fold_samples(
        from,
        origin,
        options,
        |(count, squares): &mut (u64, u64), sample| {
            let mine = own.colour_on(sample.triangle, sample.barycentric);
            let theirs = if same {
                other.colour_on(sample.triangle, sample.barycentric)
            } else {
                other.colour_moved(sample.point)
            };
            let (mine, theirs) = (to_8_bits(mine), to_8_bits(theirs));
            *count += 1;
            *squares += (0..3)
                .map(|c| u64::from(mine[c].abs_diff(theirs[c])).pow(2))
                .sum::<u64>();
        },
        |x, y| (x.0 + y.0, x.1 + y.1),
    );
    let rms = if count > 0 {
        (squares as f64 / (3 * count) as f64).sqrt()
    } else {
        0.0
    };
    ColourSide {
        rms,
        psnr_db: colour_psnr(rms),
        samples: count as usize,
    }
}

#[cfg(test)]
mod tests;
