//! Tests of the whole coder: streams encoded, cut and decoded again.

use qm_lift::Layout;
use qm_tree::ZeroTree;

use crate::budget::bit_budget;
use crate::output::{Decoded, Encoded};
use crate::params::{BaseBits, Coef, Contexts, MAX_BASE_BITS, Weighting};
use crate::passes::{Checkpoint, decode, decode_resuming, encode, encode_prefix};

fn layout(level: u32) -> Layout {
    Layout::new(qm_lift::synthetic::cube(), level).unwrap()
}

/// Coefficients that decay with level like a smooth surface's, with noise.
fn coefs(tree: &ZeroTree, seed: u64) -> Vec<Coef> {
    let mut x = seed;
    (0..tree.len())
        .map(|k| {
            let scale = 1i64 << (14 - 2 * tree.levels()[k] as i64).max(1);
            std::array::from_fn(|_| {
                x ^= x << 13;
                x ^= x >> 7;
                x ^= x << 17;
                ((x % (2 * scale as u64 + 1)) as i64 - scale) as i32
            })
        })
        .collect()
}

/// Base values like quantized positions: 16 bits, some negative.
fn base(tree: &ZeroTree, seed: u64) -> Vec<Coef> {
    let mut x = seed;
    (0..tree.base_vertices())
        .map(|_| {
            std::array::from_fn(|_| {
                x ^= x << 13;
                x ^= x >> 7;
                x ^= x << 17;
                (x % 70_000) as i32 - 2000
            })
        })
        .collect()
}

/// Base values from their high parts and a decoder's low bits.
fn join_base(values: &[Coef], dec: &Decoded, bits: u32) -> Vec<Coef> {
    if dec.base_low.is_empty() {
        return values.to_vec();
    }
    values
        .iter()
        .zip(&dec.base_low)
        .map(|(v, low)| std::array::from_fn(|c| ((v[c] >> bits) << bits) + low[c]))
        .collect()
}

fn sq_error(a: &[Coef], b: &[Coef]) -> f64 {
    a.iter()
        .zip(b)
        .flat_map(|(x, y)| (0..3).map(move |c| ((x[c] - y[c]) as f64).powi(2)))
        .sum()
}

#[test]
fn lossless_after_all_passes() {
    let layout = layout(4);
    let mut tree = ZeroTree::new(&layout);
    for weighting in [
        Weighting::default(),
        Weighting::LEVELS.with_normal_bits(2),
        Weighting {
            bits_per_level: 0,
            normal_bits: 0,
        },
    ] {
        for contexts in [Contexts::Tree, Contexts::Neighbours] {
            let c = coefs(&tree, 99);
            let enc = encode(&tree, &c, None, weighting, contexts, None);
            assert_eq!(enc.params.contexts, contexts);
            let dec = decode(&mut tree, enc.params, &enc.bytes, None);
            assert!(!dec.truncated);
            assert_eq!(dec.passes, enc.params.planes);
            assert_eq!(dec.coefs(), c);
            assert!(dec.base_low.is_empty());
        }
    }
}

/// With base values in the stream, the last pass gives them back
/// exactly too, for every number of base bits from none to all.
#[test]
fn base_bits_are_lossless() {
    let mut tree = ZeroTree::new(&layout(4));
    let b = base(&tree, 7);
    let flat = Weighting {
        bits_per_level: 0,
        normal_bits: 0,
    };
    let zeros = vec![[0; 3]; tree.len()];
    // (coefficients, weighting, expected base bits): the top weighted
    // plane is 11 (level-1 magnitudes below 4096) + 3 * bits_per_level
    // (+ normal bits), s0 = 4 * bits_per_level + 1; zero coefficients
    // leave no plane at all.
    for (c, weighting, bits) in [
        (coefs(&tree, 3), Weighting::default(), 10),
        (coefs(&tree, 3), Weighting::LEVELS.with_normal_bits(2), 12),
        (coefs(&tree, 3), flat, 11),
        (
            coefs(&tree, 3),
            Weighting {
                bits_per_level: 2,
                normal_bits: 0,
            },
            9,
        ),
        (zeros, Weighting::default(), 0),
    ] {
        let enc = encode_all_bits(&tree, &c, &b, weighting);
        assert_eq!(enc.params.base_bits, bits, "{weighting:?}");
        let dec = decode(&mut tree, enc.params, &enc.bytes, None);
        assert_eq!(dec.coefs(), c);
        assert_eq!(join_base(&b, &dec, bits), b, "{weighting:?}");
        // The high parts alone cost nothing in the stream: the same
        // stream as without base bits plus the low bits.
        let without = encode(&tree, &c, None, weighting, Contexts::default(), None);
        assert_eq!(without.params.planes, enc.params.planes);
        assert!(without.bytes.len() <= enc.bytes.len());
        assert_eq!(bits == 0, without.bytes == enc.bytes);
        // Fewer bits on request, and the rest of the stream unchanged.
        for most in [0, 1, bits / 2] {
            let base = Some(BaseBits {
                values: &b,
                most,
                whole: false,
                rounded: false,
            });
            let fewer = encode(&tree, &c, base, weighting, Contexts::default(), None);
            assert_eq!(fewer.params.base_bits, most.min(bits));
            let dec = decode(&mut tree, fewer.params, &fewer.bytes, None);
            assert_eq!(dec.coefs(), c);
            assert_eq!(join_base(&b, &dec, most.min(bits)), b);
            assert!(fewer.bytes.len() <= enc.bytes.len());
        }
    }
}

/// With `whole`, the planes reach the base values' top bit even when the
/// details are small, so every bit of every value is in the stream.
#[test]
fn whole_base_values_get_planes_of_their_own() {
    let l = layout(3);
    let mut tree = ZeroTree::new(&l);
    // Small details (colours' are), base values below 2^11.
    let c: Vec<Coef> = coefs(&tree, 5).iter().map(|v| v.map(|x| x % 3)).collect();
    let b: Vec<Coef> = base(&tree, 9)
        .iter()
        .map(|v| v.map(|x| x.rem_euclid(2048)))
        .collect();
    let weighting = Weighting::default();
    for whole in [false, true] {
        let base = Some(BaseBits {
            values: &b,
            most: 11,
            whole,
            rounded: false,
        });
        let enc = encode(&tree, &c, base, weighting, Contexts::default(), None);
        let dec = decode(&mut tree, enc.params, &enc.bytes, None);
        assert_eq!(dec.coefs(), c);
        if whole {
            assert_eq!(enc.params.base_bits, 11);
            assert_eq!(enc.params.planes, weighting.base_shift(3) + 11);
            assert_eq!(dec.base_low, b, "every value whole from the stream");
        } else {
            assert!(enc.params.base_bits < 11, "the details' planes alone");
        }
    }
}

/// Encodes `c` with all of `b`'s low bits the stream has passes for,
/// default contexts, every pass.
fn encode_all_bits(tree: &ZeroTree, c: &[Coef], b: &[Coef], weighting: Weighting) -> Encoded {
    encode(tree, c, all_bits(b), weighting, Contexts::default(), None)
}

/// All the low bits the stream has passes for.
fn all_bits(b: &[Coef]) -> Option<BaseBits<'_>> {
    Some(BaseBits {
        values: b,
        most: MAX_BASE_BITS,
        whole: false,
        rounded: false,
    })
}

/// Rounded base values: the stream carries `v + 2^(k-1)`'s low bits, the
/// caller keeps `(v + 2^(k-1)) >> k`; the last pass gives `v` back, and
/// with no pass decoded the centre of the cell, less the half, is `v`
/// rounded to a multiple of `2^k`, exact for multiples of it.
#[test]
fn rounded_base_values_come_back_and_round() {
    let mut tree = ZeroTree::new(&layout(4));
    let mut b = base(&tree, 7);
    b[0] = [0, 1 << 12, -(1 << 11)];
    let c = coefs(&tree, 3);
    let base = Some(BaseBits {
        values: &b,
        most: MAX_BASE_BITS,
        whole: false,
        rounded: true,
    });
    let enc = encode(
        &tree,
        &c,
        base,
        Weighting::default(),
        Contexts::default(),
        None,
    );
    let k = enc.params.base_bits;
    assert!(k > 2);
    let half = 1 << (k - 1);
    let join = |dec: &Decoded| -> Vec<Coef> {
        b.iter()
            .zip(&dec.base_low)
            .map(|(v, low)| std::array::from_fn(|i| (((v[i] + half) >> k) << k) + low[i] - half))
            .collect()
    };
    let dec = decode(&mut tree, enc.params, &enc.bytes, None);
    assert_eq!(dec.coefs(), c);
    assert_eq!(join(&dec), b);
    let none = decode(&mut tree, enc.params, &enc.bytes, Some(0));
    let rounded = join(&none);
    assert_eq!(rounded[0], b[0]);
    for (r, v) in rounded.iter().zip(&b) {
        assert!((0..3).all(|i| (r[i] - v[i]).abs() <= half), "{r:?} {v:?}");
    }
}

/// Each base bit goes in the pass of its weighted plane: after `p`
/// passes a base value is known down to bit `planes - p - s0`, and the
/// rest is at the centre of what is left.
#[test]
fn base_bits_arrive_with_their_planes() {
    let mut tree = ZeroTree::new(&layout(3));
    let b = base(&tree, 8);
    let c = coefs(&tree, 9);
    let weighting = Weighting::LEVELS.with_normal_bits(2);
    let enc = encode_all_bits(&tree, &c, &b, weighting);
    let (planes, k) = (enc.params.planes, enc.params.base_bits);
    let s0 = weighting.base_shift(3);
    assert_eq!(k, planes - s0);
    for p in 0..=planes {
        let dec = decode(&mut tree, enc.params, &enc.bytes, Some(p));
        let low = (planes - p).saturating_sub(s0).min(k);
        let got = join_base(&b, &dec, k);
        for (v, g) in b.iter().zip(&got) {
            for i in 0..3 {
                let known = (v[i] >> low) << low;
                let half = if low > 0 { 1 << (low - 1) } else { 0 };
                assert_eq!(g[i], known + half, "pass {p}");
            }
        }
    }
}

#[test]
fn all_zero_coefficients_cost_nothing() {
    let mut tree = ZeroTree::new(&layout(3));
    let enc = encode(
        &tree,
        &vec![[0; 3]; tree.len()],
        None,
        Weighting::default(),
        Contexts::default(),
        None,
    );
    assert_eq!(enc.params.planes, 0);
    let dec = decode(&mut tree, enc.params, &enc.bytes, None);
    assert!(dec.coefs().iter().all(|c| *c == [0; 3]));
}

#[test]
fn prefixes_decode_and_error_never_rises() {
    let mut tree = ZeroTree::new(&layout(4));
    let c = coefs(&tree, 5);
    let b = base(&tree, 6);
    let flat = Weighting {
        bits_per_level: 0,
        normal_bits: 0,
    };
    // Base values weigh as much as the coefficients here: with the level
    // weighting, a base value counts 2^L times a finest detail.
    let models = [Contexts::Tree, Contexts::Neighbours];
    let runs = [None, all_bits(&b)]
        .into_iter()
        .flat_map(|b| models.map(|m| (b, m)));
    for (base, contexts) in runs {
        let enc = encode(&tree, &c, base, flat, contexts, None);
        let k = enc.params.base_bits;
        let mut last = f64::INFINITY;
        for cut in (0..=enc.bytes.len())
            .step_by(enc.bytes.len() / 60 + 1)
            .chain([enc.bytes.len()])
        {
            let dec = decode(&mut tree, enc.params, &enc.bytes[..cut], None);
            let err = sq_error(&dec.coefs(), &c) + sq_error(&join_base(&b, &dec, k), &b);
            assert!(err <= last, "cut {cut}: {err} > {last}");
            last = err;
        }
        assert_eq!(last, 0.0);
    }
}

/// The bit budget adds up to the stream it models, base bits included,
/// pass by pass.
#[test]
fn bit_budget_matches_the_stream() {
    let tree = ZeroTree::new(&layout(4));
    let (c, b) = (coefs(&tree, 23), base(&tree, 24));
    let weighting = Weighting::LEVELS.with_normal_bits(2);
    let enc = encode_all_bits(&tree, &c, &b, weighting);
    let budgets = bit_budget(
        &tree,
        &c,
        all_bits(&b),
        weighting,
        Contexts::default(),
        None,
    );
    assert_eq!(budgets.len(), enc.pass_ends.len());
    // Tolerance: the range coder's flush, a few bytes; the base bits
    // alone are far more, so leaving them out would show.
    let slack = 8.0;
    assert!(budgets.last().unwrap().base.bits / 8.0 > 2.0 * slack);
    for (budget, &end) in budgets.iter().zip(&enc.pass_ends) {
        let mut bits = budget.base.bits;
        for c in budget
            .significance
            .iter()
            .chain(&budget.refinement)
            .flatten()
        {
            bits += c.bits;
        }
        bits += budget
            .sign
            .iter()
            .chain(&budget.zerotree)
            .map(|c| c.bits)
            .sum::<f64>();
        let modelled = bits / 8.0;
        assert!(
            (modelled - end as f64).abs() <= slack,
            "{modelled} B against {end} B"
        );
    }
}

/// Decoding longer and longer cuts from checkpoints gives exactly what
/// decoding each cut from the start gives, and skips work.
#[test]
fn resuming_equals_decoding_from_scratch() {
    let mut tree = ZeroTree::new(&layout(4));
    let c = coefs(&tree, 21);
    let b = base(&tree, 22);
    let enc = encode(
        &tree,
        &c,
        all_bits(&b),
        Weighting::LEVELS.with_normal_bits(2),
        Contexts::default(),
        None,
    );
    assert!(enc.params.base_bits > 0);
    let mut checkpoint = None;
    let mut resumed = 0;
    let n = enc.bytes.len();
    for cut in (0..=n).step_by(n / 97 + 1).chain([n, n]) {
        let data = &enc.bytes[..cut];
        let fresh = decode(&mut tree, enc.params, data, None);
        let from = checkpoint.take();
        if let Some(c) = &from {
            resumed += (Checkpoint::passes(c) > 0) as usize;
        }
        let (got, next) = decode_resuming(&mut tree, enc.params, data, None, from);
        assert_eq!(got.coefs(), fresh.coefs(), "cut {cut}");
        assert_eq!(got.base_low, fresh.base_low, "cut {cut}");
        assert_eq!((got.passes, got.truncated), (fresh.passes, fresh.truncated));
        checkpoint = next;
    }
    assert!(resumed > 50, "checkpoints used {resumed} times");
    // A checkpoint of another stream, or past a pass limit, is ignored.
    let other = encode(
        &tree,
        &coefs(&tree, 22),
        None,
        Weighting::default(),
        Contexts::default(),
        None,
    );
    let fresh = decode(&mut tree, other.params, &other.bytes, None);
    let (got, _) = decode_resuming(
        &mut tree,
        other.params,
        &other.bytes,
        None,
        checkpoint.clone(),
    );
    assert_eq!(got.coefs(), fresh.coefs());
    let fresh = decode(&mut tree, enc.params, &enc.bytes, Some(3));
    let (got, _) = decode_resuming(&mut tree, enc.params, &enc.bytes, Some(3), checkpoint);
    assert_eq!(got.coefs(), fresh.coefs());
}

#[test]
fn fewer_passes_are_a_prefix_of_more() {
    let mut tree = ZeroTree::new(&layout(3));
    let c = coefs(&tree, 11);
    let full = encode(
        &tree,
        &c,
        None,
        Weighting::default(),
        Contexts::default(),
        None,
    );
    let four = encode(
        &tree,
        &c,
        None,
        Weighting::default(),
        Contexts::default(),
        Some(4),
    );
    assert_eq!(four.params.passes, 4);
    let a = decode(&mut tree, four.params, &four.bytes, None);
    let b = decode(&mut tree, full.params, &full.bytes, Some(4));
    assert_eq!(a.coefs(), b.coefs());
    assert_eq!(a.passes, 4);
    assert!(full.pass_ends.windows(2).all(|w| w[0] <= w[1]));
}

/// A stream coded only as far as a prefix has that prefix byte for byte,
/// with base bits too, costs fewer passes the shorter the prefix, and
/// decodes there as the whole stream does.
#[test]
fn a_prefix_coded_alone_is_the_whole_streams_prefix() {
    let coded = ZeroTree::new(&layout(4));
    let mut tree = coded.clone();
    let c = coefs(&tree, 23);
    let b = base(&tree, 5);
    let bits = Some(BaseBits {
        values: &b,
        most: 9,
        whole: false,
        rounded: true,
    });
    let prefix = |bytes| {
        let (w, n) = (Weighting::default(), Contexts::Neighbours);
        encode_prefix(&coded, &c, bits, w, n, None, bytes)
    };
    let full = prefix(usize::MAX);
    let mut passes = Vec::new();
    for bytes in [
        0,
        1,
        7,
        full.bytes.len() / 9,
        full.bytes.len() / 2,
        full.bytes.len(),
    ] {
        let part = prefix(bytes);
        assert!(part.bytes.len() >= bytes);
        assert_eq!(
            part.bytes[..bytes],
            full.bytes[..bytes],
            "prefix of {bytes} bytes"
        );
        assert_eq!(part.params.planes, full.params.planes);
        let a = decode(&mut tree, part.params, &part.bytes[..bytes], None);
        let w = decode(&mut tree, full.params, &full.bytes[..bytes], None);
        assert_eq!((a.coefs(), a.base_low), (w.coefs(), w.base_low));
        passes.push(part.pass_ends.len());
    }
    assert!(passes.windows(2).all(|w| w[0] <= w[1]), "{passes:?}");
    assert!(passes[3] < passes[5], "{passes:?}");
    assert_eq!(passes[5], full.pass_ends.len());
}

/// A decoder that starts from the roots alone ([`ZeroTree::partial`]) and
/// grows its forest as the passes reach finer levels decodes every cut,
/// from scratch or resuming, exactly as one with the complete forest, node
/// for node; short cuts leave the finer levels unbuilt.
#[test]
fn a_growing_forest_decodes_what_the_complete_one_does() {
    let layout = layout(4);
    let mut complete = ZeroTree::new(&layout);
    let (c, b) = (coefs(&complete, 31), base(&complete, 32));
    for contexts in [Contexts::Tree, Contexts::Neighbours] {
        let weighting = Weighting::LEVELS.with_normal_bits(2);
        let enc = encode(&complete, &c, all_bits(&b), weighting, contexts, None);
        let mut resumed = ZeroTree::partial(layout.base(), 4, 1);
        let mut checkpoint = None;
        let mut depths = Vec::new();
        let n = enc.bytes.len();
        for cut in (0..=n).step_by(n / 61 + 1).chain([n]) {
            let data = &enc.bytes[..cut];
            let want = decode(&mut complete, enc.params, data, None);
            let mut fresh = ZeroTree::partial(layout.base(), 4, 1);
            let got = decode(&mut fresh, enc.params, data, None);
            let (again, next) =
                decode_resuming(&mut resumed, enc.params, data, None, checkpoint.take());
            checkpoint = next;
            for got in [&got, &again] {
                assert_eq!(got.nonzero, want.nonzero, "cut {cut}, {contexts}");
                assert_eq!(got.base_low, want.base_low, "cut {cut}");
                assert_eq!((got.passes, got.truncated), (want.passes, want.truncated));
                assert_eq!(
                    (got.bytes_read, &got.progress),
                    (want.bytes_read, &want.progress)
                );
            }
            // The forest holds the levels the walk reached: after complete
            // passes, none below the deepest significant coefficient (a
            // subtree opens only over one).
            let deepest = got
                .nonzero
                .iter()
                .map(|e| complete.levels()[e.node as usize]);
            if !got.truncated {
                assert!(
                    fresh.depth() <= deepest.max().unwrap_or(1) as u32,
                    "cut {cut}"
                );
            }
            assert_eq!(got.nodes, fresh.len());
            depths.push(fresh.depth());
        }
        assert_eq!(depths.first(), Some(&1), "no bytes: the roots alone");
        assert!(depths.contains(&2) && depths.contains(&3), "{depths:?}");
        assert_eq!(depths.last(), Some(&4));
    }
}
