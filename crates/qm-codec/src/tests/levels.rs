//! The decoder's level choice and error estimate on cut streams.

use qm_lift::synthetic::bumpy_sphere;

use crate::container::Limits;
use crate::decode::{DecodeOptions, Decoder, decompress};
use crate::encode::{EncodeOptions, compress};
use crate::levels::{DEFAULT_TOLERANCE_DB, LevelChoice};

fn sphere_file(level: u32) -> Vec<u8> {
    compress(&bumpy_sphere(level), &EncodeOptions::DEFAULT)
        .unwrap()
        .bytes
}

/// Cuts from the base alone to the whole file, the stream halving
/// from one to the one before.
fn cuts(bytes: &[u8], count: usize) -> Vec<usize> {
    let start = Decoder::new(bytes, &Limits::DEFAULT)
        .unwrap()
        .stream_start();
    let mut cuts: Vec<usize> = (0..count)
        .map(|k| start + ((bytes.len() - start) >> (count - 1 - k)))
        .collect();
    cuts.insert(0, start);
    cuts
}

#[test]
fn gaps_shrink_towards_the_finest_level_and_the_rest_with_bytes() {
    let bytes = sphere_file(5);
    let mut last_remaining = f64::INFINITY;
    let mut coarser = 0;
    for cut in cuts(&bytes, 12) {
        let d = decompress(&bytes, &DecodeOptions::DEFAULT.with_max_bytes(Some(cut))).unwrap();
        let e = &d.estimate;
        assert!(e.diagonal > 2.0 && e.diagonal < 2.6, "{}", e.diagonal);
        if cut == bytes.len() {
            assert_eq!((d.level, e.remaining), (5, 0.0), "complete: lossless");
            continue;
        }
        assert_eq!(e.gaps.len(), 6);
        assert_eq!(e.gaps[5], 0.0);
        assert!(e.gaps.windows(2).all(|w| w[0] >= w[1]), "{:?}", e.gaps);
        assert!(e.gaps[0] > e.gaps[4], "{:?}", e.gaps);
        assert!(
            e.remaining >= 0.0 && e.remaining <= last_remaining * 1.1,
            "cut {cut}: {} after {last_remaining}, {} passes",
            e.remaining,
            d.passes
        );
        last_remaining = e.remaining;
        // The level taken is the coarsest within the tolerance.
        assert_eq!(d.level, e.coarsest_within(DEFAULT_TOLERANCE_DB));
        let within = 10f64.powf(DEFAULT_TOLERANCE_DB / 20.0);
        assert!(e.error(d.level) <= e.remaining * within * 1.0001);
        if d.level > 0 {
            assert!(e.error(d.level - 1) > e.remaining * within);
        }
        coarser += usize::from(d.level < 5);
    }
    assert!(coarser >= 3, "short cuts choose coarser levels");
}

#[test]
fn the_remaining_error_falls_with_the_passes() {
    for bytes in [sphere_file(5), sphere_file(3)] {
        let passes = Decoder::new(&bytes, &Limits::DEFAULT)
            .unwrap()
            .header()
            .passes;
        let remaining = |p| {
            let options = DecodeOptions::DEFAULT.with_passes(Some(p));
            decompress(&bytes, &options).unwrap().estimate.remaining
        };
        let all: Vec<f64> = (0..=u32::from(passes)).map(remaining).collect();
        // A pass may reveal a coarse level larger than its bound said,
        // which raises the finer levels' bounds: two passes always fall.
        assert!(
            all.windows(3).all(|w| w[2] < w[0] || w[2] == 0.0),
            "{all:?}"
        );
        assert!(all.windows(2).all(|w| w[1] <= 1.25 * w[0]), "{all:?}");
        assert_eq!(all.last(), Some(&0.0));
    }
}

#[test]
fn the_automatic_mesh_is_the_fixed_level_decode() {
    let bytes = sphere_file(4);
    for cut in cuts(&bytes, 6) {
        let options = DecodeOptions::DEFAULT.with_max_bytes(Some(cut));
        let auto = decompress(&bytes, &options).unwrap();
        let fixed =
            decompress(&bytes, &options.with_level(LevelChoice::Fixed(auto.level))).unwrap();
        assert_eq!(auto.level_mesh(), fixed.level_mesh(), "cut {cut}");
        assert_eq!(auto.estimate, fixed.estimate, "cut {cut}");
        let finest = decompress(&bytes, &options.with_level(LevelChoice::Finest)).unwrap();
        assert_eq!(finest.level, 4);
        assert_eq!(finest.estimate.remaining, auto.estimate.remaining);
        assert_eq!(finest.passes, auto.passes);
    }
}

#[test]
fn a_triangle_cap_lowers_the_level() {
    let bytes = sphere_file(4);
    for (cap, level) in [(1, 0), (12, 0), (47, 0), (48, 1), (200, 2), (1 << 20, 4)] {
        let options = DecodeOptions::DEFAULT
            .with_level(LevelChoice::Finest)
            .with_max_triangles(Some(cap));
        let d = decompress(&bytes, &options).unwrap();
        assert_eq!(d.level, level, "cap {cap}");
        let auto = decompress(&bytes, &options.with_level(LevelChoice::Auto)).unwrap();
        assert!(auto.level <= level);
    }
}

/// An error goal stops at the first pass end that meets it and uses no
/// byte past it.
#[test]
fn an_error_goal_uses_the_first_pass_that_meets_it() {
    let bytes = sphere_file(4);
    let whole = decompress(&bytes, &DecodeOptions::DEFAULT).unwrap();
    let diagonal = whole.estimate.diagonal;
    let mut last_used = 0;
    for db in [40.0, 55.0, 70.0, 85.0] {
        let goal = diagonal / 10f64.powf(db / 20.0);
        let d = decompress(&bytes, &DecodeOptions::DEFAULT.with_max_error(Some(goal))).unwrap();
        assert!(d.estimate.remaining <= goal, "{db} dB");
        assert!(!d.truncated);
        let used = d.header_bytes + d.base_bytes + d.decoded_stream_bytes;
        assert!(used < bytes.len() && used >= last_used, "{db} dB: {used}");
        last_used = used;
        // That many bytes decode the same passes; one pass fewer misses.
        let cut = decompress(&bytes, &DecodeOptions::DEFAULT.with_max_bytes(Some(used))).unwrap();
        assert_eq!(cut.passes, d.passes);
        if d.passes > 0 {
            let fewer = DecodeOptions::DEFAULT.with_passes(Some(d.passes - 1));
            assert!(decompress(&bytes, &fewer).unwrap().estimate.remaining > goal);
        }
    }
}
