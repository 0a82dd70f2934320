//! The decoder builds only the levels a prefix reaches: against one with
//! every level built from the start, it gives the same meshes, levels and
//! estimates, bit for bit, for every cut, option and way of feeding it.

use qm_lift::glam::DVec3;
use qm_lift::synthetic::{bumpy_sphere, bumpy_split_octahedron, refined};
use qm_lift::{BaseMesh, SemiRegularMesh};

use crate::container::Limits;
use crate::decode::{DecodeOptions, Decoder, Decompressed, decompress, decompress_with};
use crate::encode::{EncodeOptions, compress};
use crate::levels::LevelChoice;
use crate::stream::StreamDecoder;

/// The quads `faces` on the points `corners`, refined `level` times and
/// moved by a smooth relief of two scales.
fn relief((corners, faces): (Vec<DVec3>, Vec<[u32; 4]>), level: u32) -> SemiRegularMesh {
    let base = BaseMesh::new(corners.len() as u32, faces).unwrap();
    refined(
        base,
        |v| corners[v as usize],
        level,
        |p| {
            let wave = DVec3::new(
                (3.0 * p.y + 1.0).sin(),
                (5.0 * p.z + 2.0).sin(),
                (4.0 * p.x + 3.0).sin(),
            );
            let ripple = 0.01 * (19.0 * p.x + 23.0 * p.y + 7.0 * p.z).sin();
            p + 0.05 * wave + DVec3::Z * ripple
        },
    )
}

/// A closed cube-based sphere, a grid with a boundary and a hole, a torus
/// (genus one) and a split octahedron (corners of valence 3 and 4).
fn meshes() -> Vec<(&'static str, SemiRegularMesh)> {
    vec![
        ("sphere", bumpy_sphere(5)),
        ("holed grid", relief(qm_shapes::holed_grid(), 4)),
        ("torus", relief(qm_shapes::torus_quads(8, 5, 1.0, 0.35), 3)),
        ("split octahedron", bumpy_split_octahedron(3)),
    ]
}

/// [`decompress`] by a decoder with every level built before it starts.
fn eager(bytes: &[u8], options: &DecodeOptions) -> Decompressed {
    let bytes = &bytes[..options
        .max_bytes
        .map_or(bytes.len(), |m| m.min(bytes.len()))];
    let mut decoder = Decoder::new(bytes, &options.limits).unwrap();
    decoder.build_every_level();
    decompress_with(decoder, bytes, options)
}

/// Cuts from the base alone to the whole file: the first bytes one by one
/// in steps, then halving distances to the end.
fn cuts(bytes: &[u8]) -> Vec<usize> {
    let start = Decoder::new(bytes, &Limits::DEFAULT)
        .unwrap()
        .stream_start();
    let n = bytes.len() - start;
    let mut cuts: Vec<usize> = (0..6).map(|k| start + k * 7).collect();
    cuts.extend((0..10).map(|k| start + (n >> (9 - k))));
    cuts.retain(|&c| c <= bytes.len());
    cuts
}

/// The same decode, field by field: the mesh bit for bit, the estimate to
/// the last bit (NaN for unknown gaps included).
fn assert_same(lazy: &Decompressed, eager: &Decompressed, what: &str) {
    assert_eq!(lazy.level, eager.level, "{what}");
    assert_eq!(
        (lazy.passes, lazy.truncated, lazy.decoded_stream_bytes),
        (eager.passes, eager.truncated, eager.decoded_stream_bytes),
        "{what}"
    );
    let bits = |e: &crate::Estimate| {
        let mut b = vec![e.remaining.to_bits(), e.diagonal.to_bits()];
        b.extend(e.gaps.iter().map(|g| g.to_bits()));
        b
    };
    assert_eq!(bits(&lazy.estimate), bits(&eager.estimate), "{what}");
    let (lp, lq) = lazy.level_mesh();
    let (ep, eq) = eager.level_mesh();
    assert_eq!(lq, eq, "{what}: quads");
    let to_bits = |p: &[DVec3]| -> Vec<[u64; 3]> {
        p.iter().map(|p| p.to_array().map(f64::to_bits)).collect()
    };
    assert_eq!(to_bits(&lp), to_bits(&ep), "{what}: positions");
    assert!(lazy.layout.level() >= lazy.level && lazy.layout.level() <= eager.layout.level());
    assert_eq!(lazy.values.len(), lazy.layout.sample_count(), "{what}");
}

/// Every cut, with the level chosen every way a caller can (the bytes'
/// level, the finest, fixed levels, a triangle cap, an error goal, a pass
/// limit), decodes as with every level built; short cuts build fewer
/// levels; the whole stream gives the quantized mesh exactly.
#[test]
fn building_only_the_levels_reached_changes_no_decode() {
    for (name, mesh) in meshes() {
        let c = compress(&mesh, &EncodeOptions::DEFAULT).unwrap();
        let finest = mesh.layout().level();
        let triangles_at = |l: u32| 2 * mesh.layout().face_count() as u64 * (1 << (2 * l));
        let middle = decompress(
            &c.bytes,
            &DecodeOptions::DEFAULT.with_max_bytes(Some(c.bytes.len() / 3)),
        )
        .unwrap();
        let choices = [
            DecodeOptions::DEFAULT,
            DecodeOptions::FINEST,
            DecodeOptions::DEFAULT.with_level(LevelChoice::Fixed(0)),
            DecodeOptions::DEFAULT.with_level(LevelChoice::Fixed(finest - 1)),
            DecodeOptions::DEFAULT.with_level(LevelChoice::Fixed(finest + 1)),
            DecodeOptions::DEFAULT.with_max_triangles(Some(triangles_at(finest - 1) + 1)),
            DecodeOptions::DEFAULT.with_max_error(Some(middle.estimate.error(middle.level))),
            DecodeOptions::DEFAULT.with_passes(Some(3)),
            DecodeOptions::DEFAULT.with_tolerance_db(1.0),
        ];
        let mut coarse_layouts = 0;
        for cut in cuts(&c.bytes) {
            for (k, options) in choices.iter().enumerate() {
                let options = options.with_max_bytes(Some(cut));
                let lazy = decompress(&c.bytes, &options).unwrap();
                let what = format!("{name}, cut {cut}, options {k}");
                assert_same(&lazy, &eager(&c.bytes, &options), &what);
                // Level 0 needs the levels the stream reached and those
                // the estimate measures (two at least), not the finest.
                coarse_layouts += usize::from(k == 2 && lazy.layout.level() < finest);
            }
        }
        assert!(
            coarse_layouts >= 5,
            "{name}: {coarse_layouts} cuts built fewer levels"
        );
        let whole = decompress(&c.bytes, &DecodeOptions::DEFAULT).unwrap();
        assert_eq!(whole.values, c.quantized, "{name}: lossless");
        assert_eq!(whole.layout.level(), finest);
    }
}

/// A stream decoder fed in pieces of growing size, its options changed on
/// the way (to a level finer than built, and back), shows after each
/// refinement what the decoder with every level built makes of the bytes
/// received; its index buffers follow the layout as it grows.
#[test]
fn a_stream_decoder_grows_as_the_bytes_arrive() {
    for (name, mesh) in meshes() {
        let c = compress(&mesh, &EncodeOptions::DEFAULT).unwrap();
        let finest = mesh.layout().level();
        let mut decoder = StreamDecoder::new(DecodeOptions::DEFAULT);
        // The header and base in pieces, then a few stream bytes, then
        // pieces half as large again each time.
        let start = Decoder::new(&c.bytes, &Limits::DEFAULT)
            .unwrap()
            .stream_start();
        let mut ends: Vec<usize> = (1..=4).map(|k| (start + 4) * k / 4).collect();
        while ends.last() < Some(&c.bytes.len()) {
            let at = *ends.last().unwrap();
            ends.push((at + 16 + (at - start) / 2).min(c.bytes.len()));
        }
        let (mut at, mut built) = (0, Vec::new());
        for (step, end) in ends.into_iter().enumerate() {
            let ready = decoder.push(&c.bytes[at..end]).unwrap();
            at = end;
            if !ready {
                continue;
            }
            let fixed = |l| DecodeOptions::DEFAULT.with_level(LevelChoice::Fixed(l));
            let options = match step % 4 {
                _ if built.is_empty() => fixed(0),
                2 => fixed(finest),
                3 => fixed(1),
                _ => DecodeOptions::DEFAULT,
            };
            decoder.set_options(options);
            decoder.refine().unwrap();
            let mesh = decoder.mesh().unwrap();
            let want = eager(&c.bytes, &options.with_max_bytes(Some(at)));
            let what = format!("{name}, {at} bytes, step {step}");
            assert_eq!(mesh.level(), want.level, "{what}");
            assert_eq!(
                mesh.error().to_bits(),
                want.estimate.error(want.level).to_bits()
            );
            let (positions, quads) = want.level_mesh();
            assert_eq!(mesh.quads(), &quads[..], "{what}");
            assert_eq!(mesh.positions(), positions, "{what}");
            built.push(decoder.decoder().unwrap().layout().level());
        }
        assert!(built.windows(2).all(|w| w[0] <= w[1]), "{name}: {built:?}");
        assert_eq!(built.last(), Some(&finest));
        assert!(built[0] < finest, "{name}: {built:?}");
    }
}
