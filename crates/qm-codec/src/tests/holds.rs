//! Holds in encoded streams: no measured cut decodes worse than a shorter
//! one, and a byte budget sends only bytes that are decoded.

use crate::compressed::Compressed;
use crate::container::{self, Limits};
use crate::decode::Decoder;
use crate::encode::{EncodeOptions, compress};
use crate::holds::{Probes, RISE, cuts, errors, find};

/// Largest rise of each error over the smallest before it, as a factor.
fn worst_rise(errors: &[f64]) -> f64 {
    let mut best = f64::INFINITY;
    let mut worst = 1.0f64;
    for &e in errors {
        worst = worst.max(e / best);
        best = best.min(e);
    }
    worst
}

/// A stream whose cuts get worse for a while (the sphere's do, by far
/// more than [`RISE`]) gets holds, and then no cut the encoder measures
/// is worse than a shorter one by more than [`RISE`]; cuts inside a
/// hold decode exactly as its start; the stream is the same.
#[test]
fn with_holds_no_cut_is_worse_than_a_shorter_one() {
    let mesh = qm_lift::synthetic::bumpy_sphere(4);
    let probes = Probes::on_surface(&mesh);
    let plain = compress(&mesh, &EncodeOptions::DEFAULT.with_holds(false)).unwrap();
    let held = compress(&mesh, &EncodeOptions::DEFAULT).unwrap();
    let stream = |c: &Compressed| c.bytes[c.header_bytes + c.base_bytes..].to_vec();
    assert_eq!(stream(&plain), stream(&held));
    // At the cuts the encoder measures (every byte at first, then
    // log-spaced).
    let start = plain.header_bytes + plain.base_bytes;
    let ends: Vec<usize> = plain.pass_ends.iter().map(|e| e - start).collect();
    let measured = cuts(stream(&plain).len(), mesh.positions().len(), &ends);
    let before = worst_rise(&errors(&plain, &probes, &measured));
    let after = worst_rise(&errors(&held, &probes, &measured));
    assert!(before > 1.05, "the sphere's cuts rise by {before}");
    assert!(after <= RISE, "held cuts still rise by {after}");
    let header = container::read(&held.bytes, &Limits::NONE).unwrap().header;
    assert!(!header.holds.is_empty());
    // What the holds measured, mapped through them, is what a decoder of
    // the held stream measures at every cut (the colour's curve takes
    // it); a cut not measured is not known.
    let (holds, known) = find(&plain, &probes);
    assert_eq!(holds, header.holds);
    let fresh = errors(&held, &probes, &measured);
    for (&cut, &error) in measured.iter().zip(&fresh) {
        assert_eq!(known.error_at(&holds, cut), Some(error), "cut {cut}");
    }
    let between = (measured.windows(2))
        .find(|w| w[1] > w[0] + 1 && container::hold_cut(&holds, w[0] + 1) == w[0] + 1)
        .map(|w| w[0] + 1)
        .expect("a cut not measured, outside the holds");
    assert_eq!(known.error_at(&holds, between), None);
    let mut decoder = Decoder::new(&held.bytes, &Limits::NONE).unwrap();
    let (mut inside, mut start) = (Vec::new(), Vec::new());
    let s = stream(&held);
    for &[from, to] in &header.holds {
        decoder.decode_into(&s[..from as usize], None, None, &mut start);
        decoder.decode_into(&s[..to as usize - 1], None, None, &mut inside);
        assert_eq!(inside, start);
    }
}

/// A byte budget that ends inside a hold ends at its start instead,
/// and holds past the budget are dropped: every byte sent is decoded,
/// to what the whole stream's decoder makes of that cut.
#[test]
fn a_budget_sends_only_bytes_that_are_decoded() {
    let mesh = qm_lift::synthetic::bumpy_sphere(4);
    let full = compress(&mesh, &EncodeOptions::DEFAULT).unwrap();
    let read = |bytes: &[u8]| container::read(bytes, &Limits::NONE).unwrap().header;
    let holds = read(&full.bytes).holds;
    let [from, to] = *holds.iter().max_by_key(|h| h[1] - h[0]).unwrap();
    assert!(to - from > 64 && holds.len() > 2, "{holds:?}");
    let start = full.header_bytes + full.base_bytes;
    let budget = start + (from + to) as usize / 2;
    let cut = compress(&mesh, &EncodeOptions::DEFAULT.with_max_bytes(Some(budget))).unwrap();
    let header = read(&cut.bytes);
    let n = cut.bytes.len() - (cut.header_bytes + cut.base_bytes);
    assert!(cut.bytes.len() < budget && n == from as usize, "{n}");
    assert_eq!(header.hold_cut(n), n);
    assert!(header.holds.len() < holds.len());
    assert!(header.holds.iter().all(|&[f, _]| (f as usize) < n));
    let decode = |bytes: &[u8]| {
        let mut d = Decoder::new(bytes, &Limits::NONE).unwrap();
        let mut values = Vec::new();
        d.decode_into(&bytes[d.stream_start()..], None, None, &mut values);
        values
    };
    assert_eq!(decode(&cut.bytes), decode(&full.bytes[..start + n]));
}
