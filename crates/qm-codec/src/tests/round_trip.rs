//! Round trips: what is encoded comes back, cut by cut, at every level.

use qm_lift::Quantizer;
use qm_lift::synthetic::bumpy_sphere as sphere;

use crate::container::Limits;
use crate::decode::{DecodeOptions, Decoder, decompress};
use crate::encode::{EncodeOptions, compress};
use crate::levels::LevelChoice;

/// Level 0: a split base on flat triangles is sent as its corners (the
/// midpoints and centres snapped, a step or two away); a split base off
/// them, and a base that is no split, keep every value whole in the
/// base section, as before the flag; all come back exactly.
#[test]
fn level_0_bases_implied_only_where_flat() {
    let cases = [
        (qm_lift::synthetic::flat_split_octahedron(), true),
        (qm_lift::synthetic::bumpy_split_octahedron(0), false),
        (sphere(0), false),
    ];
    for (i, (mesh, flat)) in cases.into_iter().enumerate() {
        let c = compress(&mesh, &EncodeOptions::DEFAULT).unwrap();
        let d = decompress(&c.bytes, &DecodeOptions::default()).unwrap();
        assert_eq!(d.values, c.quantized, "case {i}");
        assert_eq!(d.header.implied(), flat, "case {i}");
        let q = Quantizer::fit(mesh.positions(), 16).unwrap();
        let exact = q.quantize_all(mesh.positions());
        let moved = exact
            .iter()
            .zip(&c.quantized)
            .flat_map(|(a, b)| (0..3).map(move |k| (a[k] - b[k]).abs()))
            .max()
            .unwrap();
        if flat {
            assert!((1..=2).contains(&moved), "case {i}: moved {moved}");
            assert!(d.header.planes > 0 && d.header.stream_params().base_bits > 0);
        } else {
            assert_eq!(moved, 0, "case {i}");
            assert_eq!((d.header.planes, d.header.flags), (0, 0), "case {i}");
        }
    }
}

#[test]
fn lossless_at_the_last_pass() {
    let mesh = sphere(4);
    let c = compress(&mesh, &EncodeOptions::DEFAULT).unwrap();
    let d = decompress(&c.bytes, &DecodeOptions::default()).unwrap();
    assert_eq!(d.values, c.quantized);
    assert!(!d.truncated);
    assert_eq!(d.passes, d.header.planes as u32);
}

/// A decoder fed longer and longer cuts, resuming from its checkpoints,
/// gives what decompressing each cut gives.
#[test]
fn incremental_decoding_equals_decompress() {
    let c = compress(&sphere(4), &EncodeOptions::DEFAULT).unwrap();
    let mut decoder = Decoder::new(&c.bytes, &Limits::DEFAULT).unwrap();
    let start = decoder.stream_start();
    let mut values = Vec::new();
    for cut in (start..=c.bytes.len()).step_by(97).chain([c.bytes.len()]) {
        let status = decoder.decode_into(&c.bytes[start..cut], None, None, &mut values);
        let d = decompress(&c.bytes[..cut], &DecodeOptions::FINEST).unwrap();
        assert_eq!(values, d.values, "cut {cut}");
        assert_eq!((status.passes, status.truncated), (d.passes, d.truncated));
    }
    assert_eq!(values, c.quantized);
}

/// The base values' low bits arrive with the passes of their weight:
/// after `p` passes each is within half the weight of its first unknown
/// bit of the true level-0 value (what the whole stream gives), a bound that halves with every pass that carries base bits.
/// (One value can move away: one at the centre of its interval is off
/// by a quarter of it once the next bit is known.)
#[test]
fn base_values_sharpen_pass_by_pass() {
    let mesh = sphere(4);
    let stream = compress(&mesh, &EncodeOptions::DEFAULT).unwrap();
    let whole = decompress(
        &stream.bytes,
        &DecodeOptions::default().with_level(LevelChoice::Fixed(0)),
    );
    let mut truth = whole.unwrap().values;
    let mut decoder = Decoder::new(&stream.bytes, &Limits::DEFAULT).unwrap();
    truth.truncate(decoder.header().base_vertices as usize);
    let h = decoder.header().clone();
    let k = h.stream_params().base_bits;
    let s0 = h.stream_params().weighting.base_shift(h.level as u32);
    assert!(k > 3 && k <= h.planes as u32 - s0, "{k} base bits");
    let stream_bytes = &stream.bytes[decoder.stream_start()..];
    let mut values = Vec::new();
    let mut worst = i32::MAX;
    for p in 0..=h.planes as u32 {
        decoder.decode_into(stream_bytes, Some(p), Some(0), &mut values);
        worst = (values.iter().zip(&truth))
            .flat_map(|(v, t)| (0..3).map(move |c| (v[c] - t[c]).abs()))
            .max()
            .unwrap();
        let unknown = (h.planes as u32 - p).saturating_sub(s0).min(k);
        assert!(worst <= (1 << unknown) / 2, "pass {p}: off by {worst}");
        assert!(p > 0 || worst > 1 << (k - 3), "pass 0 knows no low bit");
    }
    assert_eq!(worst, 0);
}

#[test]
fn byte_budget_and_coarser_levels() {
    let mesh = sphere(4);
    let budget = EncodeOptions::DEFAULT.with_max_bytes(Some(600));
    assert_eq!(
        compress(&mesh, &budget.with_holds(false))
            .unwrap()
            .bytes
            .len(),
        600
    );
    // With holds the file may end sooner: at a hold's start, and without
    // the header bytes of holds past the budget.
    let c = compress(&mesh, &budget).unwrap();
    assert!((500..=600).contains(&c.bytes.len()), "{}", c.bytes.len());
    let d = decompress(
        &c.bytes,
        &DecodeOptions::default().with_level(LevelChoice::Fixed(2)),
    )
    .unwrap();
    assert!(d.truncated);
    let (positions, quads) = d.level_mesh();
    assert_eq!(quads.len(), 6 * 16);
    assert_eq!(positions.len(), 6 * 16 + 2);
    assert!(compress(&mesh, &EncodeOptions::DEFAULT.with_max_bytes(Some(10))).is_err());
}
