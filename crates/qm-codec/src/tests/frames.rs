//! The encoder's choice of frames, on whole encodings.

use qm_lift::synthetic::bumpy_sphere as sphere;

use crate::compressed::Compressed;
use crate::decode::{DecodeOptions, decompress};
use crate::encode::{EncodeOptions, compress};
use crate::frames::{AUTO_CUTS, Frames, auto_search, cut_error, last_auto_kind, sample_normals};

/// Each frame source is written into the header and decodes losslessly;
/// the automatic choice is, byte for byte, the candidate the documented
/// rule picks from the errors of their cuts along the normal. This
/// sphere prefers level 4 to 3 and then level 5 to 4, so the search past
/// level 4 is exercised (at 5 levels the same sphere keeps 4).
#[test]
fn frame_sources_round_trip_and_auto_keeps_the_closest_one() {
    let mesh = sphere(7);
    // Without holds: the choice is made before them, on the bare streams.
    let options = EncodeOptions::DEFAULT.with_holds(false);
    let with = |frames| compress(&mesh, &options.with_frame_source(frames)).unwrap();
    let (from3, from4, auto) = (
        with(Frames::ParentsFrom(3)),
        with(Frames::ParentsFrom(4)),
        with(Frames::Auto),
    );
    for (c, kind) in [(&from3, 1), (&from4, 2), (&with(Frames::Off), 0)] {
        let d = decompress(&c.bytes, &DecodeOptions::default()).unwrap();
        assert_eq!(d.header.frames, kind);
        assert_eq!(d.values, c.quantized);
    }
    assert_ne!(from3.bytes, from4.bytes);
    let normals = sample_normals(mesh.layout(), &from3.quantized);
    let budgets = AUTO_CUTS.map(|k| from3.bytes.len() >> k);
    let error = |c: &Compressed| cut_error(c, &normals, &budgets).unwrap();
    // The search (tested on its own in `auto_search_looks_past_a_small_step`)
    // over the streams of each frame source, scored by their cuts.
    assert!(
        error(&from4) < error(&from3),
        "the test mesh no longer tries levels past 4"
    );
    let chosen = auto_search(
        from3.clone(),
        last_auto_kind(mesh.layout().level()),
        |kind| Ok(with(Frames::ParentsFrom(kind + 2))),
        |c| Ok(error(c)),
    )
    .unwrap();
    assert_eq!(auto.bytes, chosen.bytes);
    assert_ne!(auto.bytes, from4.bytes, "the search no longer goes past 4");
    for level in [0, 2, 14] {
        let options = EncodeOptions::DEFAULT.with_frame_source(Frames::ParentsFrom(level));
        assert!(compress(&mesh, &options).is_err(), "parents from {level}");
    }
}
