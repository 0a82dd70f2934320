//! Colours: coded beside the geometry, back exactly at the last byte, and
//! with the geometry at every cut.

use qm_lift::SemiRegularMesh;
use qm_lift::synthetic::bumpy_sphere as sphere;

use crate::colour::Colours;
use crate::container::{COLOUR, FINER_COLOUR, Limits};
use crate::decode::{DecodeOptions, Decoder, decompress};
use crate::encode::{EncodeOptions, compress, compress_coloured};
use crate::levels::LevelChoice;

/// A smooth colour field over the mesh with a little noise.
fn colours(mesh: &SemiRegularMesh) -> Vec<[u8; 3]> {
    field(mesh, true)
}

/// A smooth colour field over the mesh, with a little noise or without.
fn field(mesh: &SemiRegularMesh, noisy: bool) -> Vec<[u8; 3]> {
    (mesh.positions().iter().enumerate())
        .map(|(s, p)| {
            let noise = if noisy {
                (s as u64).wrapping_mul(0x9e37_79b9_7f4a_7c15) >> 61
            } else {
                4
            };
            let wave = |a: f64, b: f64| (128.0 + 100.0 * (a * p.x + b * p.y + p.z).sin()) as i64;
            [wave(3.0, 1.0), wave(-2.0, 2.5), wave(0.5, -4.0)]
                .map(|c| (c + noise as i64 - 4).clamp(0, 255) as u8)
        })
        .collect()
}

/// Mean squared error per channel between two colour lists.
fn mse(a: &[[u8; 3]], b: &[[u8; 3]]) -> f64 {
    let sum: f64 = (a.iter().zip(b))
        .flat_map(|(x, y)| (0..3).map(move |k| (x[k] as f64 - y[k] as f64).powi(2)))
        .sum();
    sum / (3 * a.len()) as f64
}

#[test]
fn colours_come_back_exactly_with_the_same_geometry() {
    for level in [0, 2, 4] {
        let mesh = sphere(level);
        let rgb = colours(&mesh);
        let plain = compress(&mesh, &EncodeOptions::DEFAULT).unwrap();
        let c =
            compress_coloured(&mesh, Colours::new(&rgb), &EncodeOptions::DEFAULT, None).unwrap();
        let d = decompress(&c.bytes, &DecodeOptions::FINEST).unwrap();
        assert_eq!(d.header.flags & COLOUR, COLOUR);
        assert_eq!(d.values, plain.quantized, "level {level}: geometry");
        assert_eq!(
            d.colours.as_deref(),
            Some(&rgb[..]),
            "level {level}: colours"
        );
        assert!(c.bytes.len() > plain.bytes.len());
        // The geometry's pass ends, moved by the colour bytes before them.
        assert_eq!(c.pass_ends.len(), plain.pass_ends.len());
        assert!(c.pass_ends.windows(2).all(|w| w[0] <= w[1]));
        // A file without colours has none.
        let d = decompress(&plain.bytes, &DecodeOptions::FINEST).unwrap();
        assert!(d.colours.is_none());
    }
}

/// Every cut decodes geometry and colour together: the geometry as the
/// geometry-only file decodes its part of the cut, the colours closer and
/// closer to the input as the cut grows (at run ends, where a stream's
/// part is whole up to a pass end of its own).
#[test]
fn every_cut_gives_geometry_and_colour() {
    let mesh = sphere(4);
    let rgb = colours(&mesh);
    let plain = compress(&mesh, &EncodeOptions::DEFAULT).unwrap();
    let c = compress_coloured(&mesh, Colours::new(&rgb), &EncodeOptions::DEFAULT, None).unwrap();
    let header = decompress(&c.bytes, &DecodeOptions::FINEST).unwrap().header;
    let runs = header.colour.clone().unwrap().runs;
    assert!(runs.len() > 1, "interleaved: {runs:?}");
    let start = c.header_bytes + c.base_bytes;
    let plain_start = plain.header_bytes + plain.base_bytes;
    let mut errors = Vec::new();
    let mut ends = vec![0usize];
    for run in &runs {
        let last = *ends.last().unwrap();
        ends.push(last + run[0] as usize);
        ends.push(last + (run[0] + run[1]) as usize);
    }
    ends.dedup();
    let stream_len = c.bytes.len() - start;
    let cuts = (0..stream_len)
        .step_by(stream_len / 40 + 1)
        .chain(ends.iter().copied());
    for cut in cuts {
        let d = decompress(&c.bytes[..start + cut], &DecodeOptions::FINEST).unwrap();
        let (geometry, _) = crate::colour::split(&runs, &c.bytes[start..start + cut]);
        let mut file = plain.bytes[..plain_start].to_vec();
        file.extend_from_slice(&geometry);
        let g = decompress(&file, &DecodeOptions::FINEST).unwrap();
        assert_eq!(d.values, g.values, "cut {cut}: the geometry of its part");
        let colours = d.colours.unwrap();
        assert_eq!(colours.len(), rgb.len());
        if ends.contains(&cut) {
            errors.push(mse(&colours, &rgb));
        }
    }
    assert_eq!(*errors.last().unwrap(), 0.0);
    for w in errors.windows(2) {
        assert!(w[1] <= w[0] * 1.05 + 1e-9, "colour error rose: {errors:?}");
    }
    assert!(
        errors[0] > 100.0,
        "a cut before the colour is grey: {errors:?}"
    );
}

/// A decoder fed longer and longer cuts, resuming, at the level it
/// chooses, gives what decompressing each cut gives, colours and all.
#[test]
fn incremental_decoding_with_colours_equals_decompress() {
    let mesh = sphere(4);
    let rgb = colours(&mesh);
    let c = compress_coloured(&mesh, Colours::new(&rgb), &EncodeOptions::DEFAULT, None).unwrap();
    let mut decoder = Decoder::new(&c.bytes, &Limits::DEFAULT).unwrap();
    let start = decoder.stream_start();
    let options = DecodeOptions::DEFAULT;
    let mut values = Vec::new();
    for cut in (start..=c.bytes.len()).step_by(97).chain([c.bytes.len()]) {
        let (status, _) =
            decoder.decode_choosing(&c.bytes[start..cut], &options, &mut values, true);
        let d = decompress(&c.bytes[..cut], &options).unwrap();
        assert_eq!(status.level, d.level, "cut {cut}");
        let colours = decoder.colours().unwrap();
        assert_eq!(Some(colours), d.colours.as_deref(), "cut {cut}");
        assert_eq!(colours.len(), d.level_mesh().0.len(), "cut {cut}");
        assert_eq!(status.decoded_bytes, d.decoded_stream_bytes, "cut {cut}");
    }
    let d = decompress(&c.bytes, &options.with_level(LevelChoice::Fixed(2))).unwrap();
    assert_eq!(d.colours.as_ref().unwrap().len(), d.level_mesh().0.len());
}

/// A budget cuts the interleaved file; colours from the wrong mesh are a
/// setting error.
#[test]
fn budgets_and_wrong_colour_counts() {
    let mesh = sphere(3);
    let rgb = colours(&mesh);
    let options = EncodeOptions::DEFAULT.with_max_bytes(Some(1500));
    let c = compress_coloured(&mesh, Colours::new(&rgb), &options, None).unwrap();
    assert!(c.bytes.len() <= 1500);
    let d = decompress(&c.bytes, &DecodeOptions::FINEST).unwrap();
    assert_eq!(d.colours.unwrap().len(), rgb.len());
    let e = compress_coloured(
        &mesh,
        Colours::new(&rgb[1..]),
        &EncodeOptions::DEFAULT,
        None,
    )
    .unwrap_err();
    assert!(e.to_string().contains("colours"), "{e}");
}

/// A stream decoder fed a coloured file in pieces keeps asking for bytes
/// until the colours are whole too, and ends with them exact.
#[test]
fn a_stream_decoder_waits_for_the_last_colour_byte() {
    let mesh = sphere(3);
    let rgb = colours(&mesh);
    let c = compress_coloured(&mesh, Colours::new(&rgb), &EncodeOptions::DEFAULT, None).unwrap();
    let mut decoder = crate::StreamDecoder::new(DecodeOptions::FINEST);
    for piece in c.bytes.chunks(211) {
        assert!(decoder.wants_more());
        decoder.push(piece).unwrap();
        if decoder.ready() {
            decoder.refine().unwrap();
            let mesh = decoder.mesh().unwrap();
            assert_eq!(mesh.colours().unwrap().len(), mesh.vertex_count());
        }
    }
    assert!(!decoder.wants_more());
    assert_eq!(decoder.mesh().unwrap().colours(), Some(&rgb[..]));
}

/// Colours whose floor the caller measured (what the samples miss of the
/// surface's colour) end at the first pass whose error against the samples
/// is a quarter of it: the higher the floor, the sooner; the geometry is
/// the same.
#[test]
fn a_measured_floor_ends_the_colour_stream() {
    let mesh = sphere(4);
    let rgb = colours(&mesh);
    let plain = compress(&mesh, &EncodeOptions::DEFAULT).unwrap();
    let whole =
        compress_coloured(&mesh, Colours::new(&rgb), &EncodeOptions::DEFAULT, None).unwrap();
    let d = decompress(&whole.bytes, &DecodeOptions::FINEST).unwrap();
    assert_eq!(d.colours.as_deref(), Some(&rgb[..]));
    let mut last = (d.header.colour.unwrap().passes, whole.bytes.len());
    for missed in [4.0, 16.0, 64.0] {
        let given = Colours::new(&rgb).with_missed(missed);
        let c = compress_coloured(&mesh, given, &EncodeOptions::DEFAULT, None).unwrap();
        let d = decompress(&c.bytes, &DecodeOptions::FINEST).unwrap();
        assert_eq!(d.values, plain.quantized, "floor {missed}: geometry");
        let colour = d.header.colour.as_ref().unwrap();
        let error = mse(d.colours.as_ref().unwrap(), &rgb);
        assert!(error <= missed / 4.0, "floor {missed}: {error}");
        assert!(
            colour.passes < last.0 && c.bytes.len() < last.1,
            "floor {missed}: {} passes, {} bytes after {last:?}",
            colour.passes,
            c.bytes.len()
        );
        last = (colour.passes, c.bytes.len());
    }
    // A floor no higher than rounding: the samples hold the colour as well
    // as 8 bits can, and come back exactly.
    for missed in [0.0, 1.0 / 12.0] {
        let given = Colours::new(&rgb).with_missed(missed);
        let c = compress_coloured(&mesh, given, &EncodeOptions::DEFAULT, None).unwrap();
        let d = decompress(&c.bytes, &DecodeOptions::FINEST).unwrap();
        assert_eq!(d.colours.as_deref(), Some(&rgb[..]), "floor {missed}");
    }
}

/// Colours at levels finer than the geometry's: the geometry is the
/// geometry-only file's, the colours come back as a texture at the last
/// byte (exactly, or within a quarter of what the samples miss where the
/// stream stops there), every cut decodes with a texture no finer than the colour
/// reached, and the mesh's own colours stay one per vertex.
#[test]
fn colours_finer_than_the_geometry_come_back_as_a_texture() {
    let mesh = sphere(2);
    let plain = compress(&mesh, &EncodeOptions::DEFAULT).unwrap();
    for (finer, noisy) in [(1u32, true), (2, true), (2, false)] {
        let fine = sphere(2 + finer);
        assert_eq!(fine.layout().base(), mesh.layout().base());
        let rgb = field(&fine, noisy);
        let c =
            compress_coloured(&mesh, Colours::new(&rgb), &EncodeOptions::DEFAULT, None).unwrap();
        let d = decompress(&c.bytes, &DecodeOptions::FINEST).unwrap();
        assert_eq!(d.header.flags & FINER_COLOUR, FINER_COLOUR);
        assert_eq!(d.header.colour.as_ref().unwrap().finer as u32, finer);
        assert_eq!(d.values, plain.quantized, "finer {finer}: geometry");
        assert_eq!(d.level, 2);
        assert_eq!(d.colours.as_ref().unwrap().len(), d.level_mesh().0.len());
        let atlas = d.texture.as_ref().expect("a texture");
        assert_eq!(atlas.level, 2 + finer);
        // Each sample's texel: exact where the stream holds every pass;
        // the stream ends sooner where its error is a quarter of what the
        // samples miss (here, their noise and finest waves).
        let layout = fine.layout();
        let n = layout.n() as u32;
        let mut back = vec![[0u8; 3]; rgb.len()];
        for f in 0..layout.face_count() {
            for j in 0..=n {
                for i in 0..=n {
                    let [u, v] = atlas.texcoord(f, 2 + finer, i, j);
                    let x = (u * atlas.width as f32) as usize;
                    let y = (v * atlas.height as f32) as usize;
                    let s = layout.sample(f, i as usize, j as usize) as usize;
                    back[s] = atlas.texels[y * atlas.width as usize + x];
                }
            }
        }
        let colour = d.header.colour.as_ref().unwrap();
        let error = mse(&back, &rgb);
        if noisy {
            assert!(colour.passes < colour.planes, "finer {finer}");
            assert!(error > 0.0 && error < 2.0, "finer {finer}: {error}");
        } else {
            assert_eq!(colour.passes, colour.planes);
            assert_eq!(back, rgb);
        }
        // Cuts: each decodes, its texture at most the colour's level and
        // finer than the mesh.
        let start = c.header_bytes + c.base_bytes;
        let mut textured = 0;
        for cut in (start..c.bytes.len()).step_by((c.bytes.len() - start) / 30 + 1) {
            let d = decompress(&c.bytes[..cut], &DecodeOptions::DEFAULT).unwrap();
            assert_eq!(d.colours.as_ref().unwrap().len(), d.level_mesh().0.len());
            if let Some(atlas) = &d.texture {
                assert!(atlas.level > d.level && atlas.level <= 2 + finer);
                textured += 1;
            }
        }
        assert!(textured > 0);
    }
    // Colours at the geometry's level make no texture, even for a coarser
    // mesh: such files decode as they did.
    let c = compress_coloured(
        &mesh,
        Colours::new(&colours(&mesh)),
        &EncodeOptions::DEFAULT,
        None,
    )
    .unwrap();
    for level in [LevelChoice::Finest, LevelChoice::Fixed(0)] {
        let d = decompress(&c.bytes, &DecodeOptions::DEFAULT.with_level(level)).unwrap();
        assert_eq!(d.header.flags & FINER_COLOUR, 0);
        assert!(d.texture.is_none());
    }
}

/// A stream decoder's mesh gives the texture too, and its textured
/// triangles are its own triangles over vertices split where base quads
/// meet: one vertex per mesh vertex and base quad.
#[test]
fn a_stream_decoders_mesh_is_textured_over_split_vertices() {
    let mesh = sphere(2);
    let rgb = colours(&sphere(4));
    let c = compress_coloured(&mesh, Colours::new(&rgb), &EncodeOptions::DEFAULT, None).unwrap();
    for level in [0, 1, 2] {
        let options = DecodeOptions::DEFAULT.with_level(LevelChoice::Fixed(level));
        let mut decoder = crate::StreamDecoder::new(options);
        decoder.push(&c.bytes).unwrap();
        decoder.refine().unwrap();
        let m = decoder.mesh().unwrap();
        let atlas = m.texture().expect("colour finer than the mesh");
        assert_eq!(atlas.level, 4);
        let t = m.textured(&atlas);
        assert_eq!(decoder.texture(), Some((&atlas, &t)), "the kept texture");
        let own: Vec<u32> = t
            .triangles
            .iter()
            .map(|&k| t.vertices[k as usize])
            .collect();
        assert_eq!(own, m.triangles(), "level {level}");
        let faces = decoder.decoder().unwrap().layout().face_count();
        let mut pairs = std::collections::HashSet::new();
        let per_face = m.quads().len() / faces;
        for (q, quad) in m.quads().iter().enumerate() {
            for &v in quad {
                pairs.insert((v, q / per_face));
            }
        }
        assert_eq!(t.vertices.len(), pairs.len(), "level {level}");
    }
}

/// A stream decoder keeps its texture while refinements advance the
/// geometry alone: an unchanged version is the texture of the last
/// refinement, and every refinement's texture is what decompressing its
/// bytes gives, over the mesh's own triangles.
#[test]
fn a_stream_decoders_texture_keeps_its_version_while_it_stays() {
    let mesh = sphere(2);
    let rgb = field(&sphere(4), false);
    let c = compress_coloured(&mesh, Colours::new(&rgb), &EncodeOptions::DEFAULT, None).unwrap();
    let mut decoder = crate::StreamDecoder::new(DecodeOptions::DEFAULT);
    let mut last = (decoder.texture_version(), None);
    let mut versions = std::collections::HashSet::new();
    for chunk in c.bytes.chunks(61) {
        decoder.push(chunk).unwrap();
        if decoder.decoder().is_none() || !decoder.refine().unwrap() {
            continue;
        }
        let n = decoder.bytes_received();
        let options = DecodeOptions::DEFAULT.with_max_bytes(Some(n));
        let native = decompress(&c.bytes, &options).unwrap().texture;
        let kept = decoder.texture().map(|(atlas, _)| atlas.clone());
        assert_eq!(kept, native, "at {n} bytes");
        if let Some((atlas, t)) = decoder.texture() {
            assert_eq!(t, &decoder.mesh().unwrap().textured(atlas), "at {n} bytes");
        }
        if decoder.texture_version() == last.0 {
            assert_eq!(kept, last.1, "kept at {n} bytes");
        }
        last = (decoder.texture_version(), kept);
        versions.insert(last.0);
    }
    assert!(versions.len() > 3, "{versions:?}");
}

/// The stream decoder's kept texture leaves it `Send` and `Sync`, as the
/// bindings that share it across threads need (this fails to compile
/// otherwise).
#[test]
fn a_stream_decoder_is_send_and_sync() {
    fn shared<T: Send + Sync>() {}
    shared::<crate::StreamDecoder>();
}
