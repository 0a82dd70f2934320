use qm_io::{Asset, Image, ImageSource, Material, PolyMesh, SplitMix64, TexCoords, Texture};
use qm_shapes::uv_sphere;

use super::*;
use crate::distance::distance;

fn v(x: f64, y: f64) -> DVec3 {
    DVec3::new(x, y, 0.0)
}

/// The unit square in z = 0 as two triangles, red, green, blue and a dim
/// grey at its corners.
fn coloured_square() -> Asset {
    let mut asset = Asset::default();
    asset.mesh = PolyMesh::from_faces(
        vec![v(0.0, 0.0), v(1.0, 0.0), v(1.0, 1.0), v(0.0, 1.0)],
        &[[0u32, 1, 2], [0, 2, 3]],
    );
    asset.colors = Some(vec![
        [1.0, 0.0, 0.0, 1.0],
        [0.0, 1.0, 0.0, 1.0],
        [0.0, 0.0, 1.0, 1.0],
        [0.2, 0.4, 0.6, 1.0],
    ]);
    asset
}

/// Texel `(i, j)` of the 4x4 test image.
fn texel(i: u8, j: u8) -> [u8; 3] {
    [60 * i, 60 * j, 17 + 20 * (i + 2 * j)]
}

/// The unit square as one quad, textured with a 4x4 image `repeat` times
/// across, the image's top at y = 1; `factor` its material's base colour.
fn textured_square(repeat: f32, factor: [f32; 4]) -> Asset {
    let mut rgba = Vec::new();
    for j in 0..4 {
        for i in 0..4 {
            rgba.extend(texel(i, j));
            rgba.push(255);
        }
    }
    let mut asset = Asset::default();
    asset.mesh = PolyMesh::from_faces(
        vec![v(0.0, 0.0), v(1.0, 0.0), v(1.0, 1.0), v(0.0, 1.0)],
        &[[0u32, 1, 2, 3]],
    );
    asset.tex_coords = Some(TexCoords {
        values: vec![[0.0, repeat], [repeat, repeat], [repeat, 0.0], [0.0, 0.0]],
        corners: vec![0, 1, 2, 3],
    });
    asset.materials = vec![Material {
        name: "checks".into(),
        base_color: factor,
        base_color_texture: Some(Texture {
            source: ImageSource::File("checks.png".into()),
            image: Some(Image {
                width: 4,
                height: 4,
                rgba,
            }),
        }),
    }];
    asset
}

#[test]
fn vertex_colours_are_interpolated_at_the_closest_point() {
    let asset = coloured_square();
    let surface = ColourSurface::new(&asset).unwrap().expect("coloured");
    let cases = [
        // In triangle 0: weights 0.4 red, 0.4 green, 0.2 blue.
        (DVec3::new(0.6, 0.2, 0.0), [102, 102, 51]),
        // In triangle 1: 0.25 red, 0.25 blue, 0.5 grey (0.2, 0.4, 0.6).
        (DVec3::new(0.25, 0.75, 0.0), [89, 51, 140]),
        (DVec3::new(1.0, 0.0, 0.0), [0, 255, 0]),
        // Off the surface: above the first point, and beside the edge
        // x = 1, whose closest point (1, 0.2) is 0.8 green, 0.2 blue.
        (DVec3::new(0.6, 0.2, 5.0), [102, 102, 51]),
        (DVec3::new(2.0, 0.2, -1.0), [0, 204, 51]),
    ];
    for (p, expected) in cases {
        assert_eq!(surface.colour_at(p), expected, "at {p}");
    }
    let points: Vec<DVec3> = cases.iter().map(|c| c.0).collect();
    let expected: Vec<[u8; 3]> = cases.iter().map(|c| c.1).collect();
    assert_eq!(surface.colours_at(&points), expected);
}

#[test]
fn a_texture_gives_its_texels_at_their_centres() {
    let asset = textured_square(1.0, [1.0; 4]);
    let surface = ColourSurface::new(&asset).unwrap().expect("textured");
    // Position (x, y) is texture coordinate (x, 1 - y): texel (i, j) has
    // its centre at x = (i + 0.5) / 4, y = 1 - (j + 0.5) / 4.
    for j in 0..4u8 {
        for i in 0..4u8 {
            let p = v((f64::from(i) + 0.5) / 4.0, 1.0 - (f64::from(j) + 0.5) / 4.0);
            assert_eq!(surface.colour_at(p), texel(i, j), "texel {i} {j}");
        }
    }
    // Half way between the centres of texels (0, 0) and (1, 0), and on the
    // image's left edge, half way to texel (3, 0) wrapped around.
    let mean = |a: [u8; 3], b: [u8; 3]| {
        std::array::from_fn(|c| ((f64::from(a[c]) + f64::from(b[c])) / 2.0).round() as u8)
    };
    assert_eq!(
        surface.colour_at(v(0.25, 0.875)),
        mean(texel(0, 0), texel(1, 0))
    );
    assert_eq!(
        surface.colour_at(v(0.0, 0.875)),
        mean(texel(3, 0), texel(0, 0))
    );

    // Twice across: the right half repeats the image. A factor scales it.
    let asset = textured_square(2.0, [1.0, 0.5, 1.0, 1.0]);
    let surface = ColourSurface::new(&asset).unwrap().expect("textured");
    for i in 0..4u8 {
        let x = 0.5 + (f64::from(i) + 0.5) / 8.0;
        let [r, g, b] = texel(i, 3);
        assert_eq!(surface.colour_at(v(x, 0.5 / 8.0)), [r, g / 2, b], "{i}");
    }
}

#[test]
fn flat_materials_and_grey_fill_faces_without_colour() {
    // A textured material with no decoded image is no appearance.
    let mut asset = textured_square(1.0, [0.2, 0.4, 0.6, 1.0]);
    if let Some(texture) = &mut asset.materials[0].base_color_texture {
        texture.image = None;
    }
    assert!(!ColourSurface::has_appearance(&asset));
    assert!(ColourSurface::new(&asset).unwrap().is_none());
    assert!(ColourSurface::new(&Asset::default()).unwrap().is_none());

    // Two materials, one textured: the other face has its flat colour.
    let mut asset = textured_square(1.0, [1.0; 4]);
    asset.mesh.positions.extend([v(2.0, 0.0), v(2.0, 1.0)]);
    asset.mesh.push_face(&[1, 4, 5, 2]);
    let uv = asset.tex_coords.as_mut().unwrap();
    uv.corners.extend([TexCoords::NONE; 4]);
    asset.materials.push(Material {
        name: "flat".into(),
        base_color: [0.2, 0.4, 0.6, 1.0],
        base_color_texture: None,
    });
    asset.face_materials = Some(vec![0, 1]);
    let surface = ColourSurface::new(&asset).unwrap().expect("textured");
    assert_eq!(surface.colour_at(v(1.5, 0.5)), [51, 102, 153]);
    asset.face_materials = None;
    asset.materials.truncate(1);
    let surface = ColourSurface::new(&asset).unwrap().expect("textured");
    // Material 0 without coordinates on that face: its factor, white.
    assert_eq!(surface.colour_at(v(1.5, 0.5)), [255; 3]);
}

#[test]
fn bad_meshes_and_appearances_are_errors() {
    let mut asset = coloured_square();
    asset.mesh = PolyMesh::new();
    asset.mesh.positions = vec![DVec3::ZERO; 4];
    assert_eq!(
        ColourSurface::new(&asset).err(),
        Some(Error::NoFaces {
            mesh: Some(Side::A)
        })
    );
    let mut asset = coloured_square();
    asset.mesh.positions[2].x = f64::NAN;
    assert!(matches!(
        ColourSurface::new(&asset),
        Err(Error::NonFinite { vertex: 2, .. })
    ));
    let mut asset = coloured_square();
    asset.colors.as_mut().unwrap().pop();
    let e = ColourSurface::new(&asset).err().unwrap();
    assert!(e.to_string().contains("3 colours for 4 vertices"), "{e}");
    let mut asset = textured_square(1.0, [1.0; 4]);
    asset.face_materials = Some(vec![1]);
    assert!(matches!(
        ColourSurface::new(&asset),
        Err(Error::Appearance { .. })
    ));
    let mut asset = textured_square(1.0, [1.0; 4]);
    if let Some(Texture {
        image: Some(image), ..
    }) = &mut asset.materials[0].base_color_texture
    {
        image.rgba.pop();
    }
    assert!(matches!(
        ColourSurface::new(&asset),
        Err(Error::Appearance { .. })
    ));
}

/// A sphere whose vertex colours vary with position, in whole 8-bit steps
/// between 0 and 245, plus `shift` steps.
fn coloured_sphere(shift: u8) -> Asset {
    let mut asset = Asset::default();
    asset.mesh = uv_sphere(12, 20, 1.0);
    let colours = asset
        .mesh
        .positions
        .iter()
        .map(|p| {
            let c = |x: f64| f32::from(((x + 1.0) * 122.0).round() as u8 + shift) / 255.0;
            [c(p.x), c(p.y), c(p.z), 1.0]
        })
        .collect();
    asset.colors = Some(colours);
    asset
}

#[test]
fn batches_are_the_same_on_any_number_of_threads() {
    let asset = coloured_sphere(0);
    let surface = ColourSurface::new(&asset).unwrap().expect("coloured");
    let mut rng = SplitMix64::new(11);
    let points: Vec<DVec3> = (0..4000)
        .map(|_| DVec3::new(rng.next_f64(), rng.next_f64(), rng.next_f64()) * 3.0 - 1.5)
        .collect();
    let on = |threads| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| surface.colours_at(&points))
    };
    let one = on(1);
    assert_eq!(one, on(2));
    let singly: Vec<[u8; 3]> = points.iter().map(|&p| surface.colour_at(p)).collect();
    assert_eq!(one, singly);
    // The colours vary: a constant answer would pass the above too.
    assert!(one.iter().any(|c| *c != one[0]));
}

fn options(samples: usize) -> DistanceOptions {
    DistanceOptions::DEFAULT.with_samples(samples)
}

#[test]
fn identical_colours_are_at_infinite_psnr() {
    let a = coloured_sphere(0);
    let report = colour_distance(&a, &a.clone(), &options(20_000))
        .unwrap()
        .expect("both coloured");
    assert_eq!(report.rms, 0.0);
    assert_eq!(report.psnr_db, f64::INFINITY);
    // The samples are those of the geometric distance.
    let geometry = distance(&a.mesh, &a.mesh, &options(20_000)).unwrap();
    assert_eq!(report.a_to_b.samples, geometry.a_to_b.samples);
    let json: serde_json::Value = serde_json::to_value(report).unwrap();
    assert!(json["psnr_db"].is_null());
}

#[test]
fn colours_shifted_by_ten_are_at_rms_ten() {
    let a = coloured_sphere(0);
    let expected_psnr = 20.0 * 25.5f64.log10();
    // On the same mesh, compared in place: exact.
    let b = coloured_sphere(10);
    let report = colour_distance(&a, &b, &options(20_000)).unwrap().unwrap();
    assert!((report.rms - 10.0).abs() < 1e-9, "{report:?}");
    assert!((report.psnr_db - expected_psnr).abs() < 1e-9, "{report:?}");
    // The same surface in another mesh (an unused vertex more), so B's
    // colours come from projections: the same within rounding.
    let mut b = coloured_sphere(10);
    b.mesh.positions.push(DVec3::splat(9.0));
    b.colors.as_mut().unwrap().push([0.0, 0.0, 0.0, 1.0]);
    let report = colour_distance(&a, &b, &options(20_000)).unwrap().unwrap();
    for side in [report.a_to_b, report.b_to_a] {
        assert!((side.rms - 10.0).abs() < 0.05, "{report:?}");
        assert!((side.psnr_db - expected_psnr).abs() < 0.05, "{report:?}");
    }
    assert_eq!(report.rms, report.a_to_b.rms.max(report.b_to_a.rms));
    // Without appearance on one side there is nothing to compare.
    b.colors = None;
    assert_eq!(colour_distance(&a, &b, &options(1000)).unwrap(), None);
    assert_eq!(colour_distance(&a, &b, &options(0)), Err(Error::NoSamples));
}

#[test]
fn a_colour_metric_sees_a_recoloured_half() {
    // B is A's square with its corners' colours as A's, but the far corner
    // dark: every sample in triangle 1 differs, by an amount that grows
    // towards that corner, and none in triangle 0 does.
    let a = coloured_square();
    let mut b = coloured_square();
    b.mesh.positions.push(DVec3::splat(7.0));
    b.colors.as_mut().unwrap()[3] = [0.0, 0.0, 0.0, 1.0];
    b.colors.as_mut().unwrap().push([0.0; 4]);
    let report = colour_distance(&a, &b, &options(40_000)).unwrap().unwrap();
    // Mean of w^2 over a triangle for one corner's weight w is 1/6, so the
    // RMS over the channels is 255 sqrt(mean over the square) =
    // 255 sqrt((0.2^2 + 0.4^2 + 0.6^2) / 3 / 6 / 2).
    let expected = 255.0 * ((0.04f64 + 0.16 + 0.36) / 36.0).sqrt();
    assert!(
        (report.rms - expected).abs() < 0.02 * expected,
        "{report:?} {expected}"
    );
}

#[test]
fn texels_count_the_image_as_often_as_the_surface_shows_it() {
    // 16 texels once, four times, a quarter of them; none untextured.
    for (repeat, expected) in [(1.0, 16.0), (2.0, 64.0), (0.5, 4.0)] {
        let asset = textured_square(repeat, [1.0; 4]);
        assert_eq!(texels(&asset), expected, "repeat {repeat}");
    }
    assert_eq!(texels(&coloured_square()), 0.0);
    let mut unmapped = textured_square(1.0, [1.0; 4]);
    unmapped.tex_coords.as_mut().unwrap().corners[2] = TexCoords::NONE;
    assert_eq!(texels(&unmapped), 0.0, "both triangles lose a corner");
}
