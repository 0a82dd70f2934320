//! The stream's passes: planning them ([`plan`]: the planes, and the
//! highest weighted plane below each node), coding them ([`encode`]) and
//! decoding any prefix of them ([`decode`]), resuming from a
//! [`Checkpoint`] at the last complete pass ([`decode_resuming`]).
//!
//! Plane `P` runs from `T0 = floor(log2 max weighted |c|)` down to 0, one
//! pass per plane (the paper's halving thresholds; its garbled T0 formula
//! becomes this); what a pass codes is the tree walk of [`crate::walk`].

use qm_tree::ZeroTree;

use crate::coder::{Coder, Truth, Unknown};
use crate::output::{Decoded, Encoded, Progress};
use crate::params::{BaseBits, Coef, Contexts, MAX_BASE_BITS, StreamParams, Weighting};
use crate::range::{BitReader, BitWriter, ReaderSnapshot};
use crate::walk::{State, Trees};

/// Encodes node-ordered `coefs` of `tree`, at most `max_passes` passes,
/// and, when `base` is given, the low [`StreamParams::base_bits`] bits of
/// its values; the rest of them (`value >> base_bits`) is for the caller
/// to store.
pub fn encode(
    tree: &ZeroTree,
    coefs: &[Coef],
    base: Option<BaseBits<'_>>,
    weighting: Weighting,
    contexts: Contexts,
    max_passes: Option<u32>,
) -> Encoded {
    encode_prefix(
        tree,
        coefs,
        base,
        weighting,
        contexts,
        max_passes,
        usize::MAX,
    )
}

/// [`encode`], but only as far as the first `bytes` bytes of its stream:
/// passes are coded until that many bytes are final (or `max_passes` are
/// coded), and the first `bytes` bytes are those [`encode`] gives with the
/// same arguments (what follows them is a flush, not the stream's). The
/// parameters are [`encode`]'s, the pass ends those of the passes coded.
/// Cheaper than a whole stream where only a prefix is measured.
pub fn encode_prefix(
    tree: &ZeroTree,
    coefs: &[Coef],
    base: Option<BaseBits<'_>>,
    weighting: Weighting,
    contexts: Contexts,
    max_passes: Option<u32>,
    bytes: usize,
) -> Encoded {
    let mut writer = BitWriter::new();
    let mut pass_ends = Vec::new();
    let plan = plan(tree, coefs, base, weighting, contexts, max_passes);
    let params = code_passes(tree, coefs, base, plan, &mut writer, |w| {
        pass_ends.push(w.len_needed());
        w.len_final() < bytes
    });
    let bytes = writer.finish();
    for end in &mut pass_ends {
        *end = (*end).min(bytes.len());
    }
    Encoded {
        bytes,
        params,
        pass_ends,
    }
}

/// Codes the passes of a planned stream through `coder`, calling
/// `after_pass` after each and going on while it says so; the stream
/// parameters.
pub(crate) fn code_passes<C: Coder>(
    tree: &ZeroTree,
    coefs: &[Coef],
    base: Option<BaseBits<'_>>,
    (params, below): (StreamParams, Vec<i32>),
    coder: &mut C,
    mut after_pass: impl FnMut(&C) -> bool,
) -> StreamParams {
    // Rounded base values carry their low bits plus half the step.
    let half = (params.base_bits > 0).then(|| 1i32 << (params.base_bits - 1));
    let shifted: Option<Vec<Coef>> = match (base, half) {
        (Some(b), Some(half)) if b.rounded => {
            Some(b.values.iter().map(|v| v.map(|x| x + half)).collect())
        }
        _ => None,
    };
    let mut oracle = Truth {
        coefs,
        below: &below,
        base: shifted.as_deref().unwrap_or(base.map_or(&[], |b| b.values)),
    };
    let mut state = State::new(tree, params);
    for pass in 0..params.passes {
        let coded = state.pass(&mut Trees::Whole(tree), pass, coder, &mut oracle);
        debug_assert!(coded.is_ok());
        if !after_pass(coder) {
            break;
        }
    }
    params
}

/// The stream parameters of `coefs` and the highest weighted plane below
/// each node.
pub(crate) fn plan(
    tree: &ZeroTree,
    coefs: &[Coef],
    base: Option<BaseBits<'_>>,
    weighting: Weighting,
    contexts: Contexts,
    max_passes: Option<u32>,
) -> (StreamParams, Vec<i32>) {
    assert!(tree.is_complete(), "the coder walks the complete forest");
    assert_eq!(coefs.len(), tree.len(), "one coefficient per tree node");
    if let Some(base) = base {
        assert!(
            base.values.len() <= tree.base_vertices(),
            "at most one value per base vertex"
        );
    }
    let big_l = tree.max_level();
    let levels = tree.levels();
    let weighted_top = |k: usize| -> i32 {
        (0..3)
            .map(|c| match coefs[k][c].unsigned_abs() {
                0 => -1,
                m => (31 - m.leading_zeros() + weighting.shift(levels[k] as u32, c, big_l)) as i32,
            })
            .max()
            .unwrap_or(-1)
    };
    // Highest weighted plane below each node.
    let mut below = vec![-1i32; tree.len()];
    for k in (0..tree.len()).rev() {
        below[k] = tree
            .children(k)
            .map(|c| weighted_top(c).max(below[c]))
            .max()
            .unwrap_or(-1);
    }
    let top = (0..tree.roots())
        .map(|k| weighted_top(k).max(below[k]))
        .max()
        .unwrap_or(-1);
    // Without details (level 0) the planes are those of the base bits.
    let planes = match base {
        Some(b) if tree.is_empty() && !b.values.is_empty() && b.most > 0 => {
            weighting.base_shift(big_l) + b.most.min(MAX_BASE_BITS)
        }
        Some(b) if b.whole && !b.values.is_empty() && b.most > 0 => {
            let whole = weighting.base_shift(big_l) + b.most.min(MAX_BASE_BITS);
            whole.max((top + 1) as u32)
        }
        _ => (top + 1) as u32,
    };
    let passes = max_passes.map_or(planes, |p| p.min(planes));
    let params = StreamParams {
        planes,
        passes,
        weighting,
        base_bits: base.map_or(0, |b| weighting.max_base_bits(planes, big_l).min(b.most)),
        base_values: base.map_or(0, |b| b.values.len() as u32),
        contexts,
    };
    (params, below)
}

/// Decodes up to `max_passes` passes from `data`, which may be cut anywhere.
///
/// `tree` may be a [`ZeroTree::partial`] forest: it grows as the passes
/// reach its last level (and no further), and the result is what the
/// complete forest gives, node for node (a complete one never changes).
pub fn decode(
    tree: &mut ZeroTree,
    params: StreamParams,
    data: &[u8],
    max_passes: Option<u32>,
) -> Decoded {
    run_decoder(tree, params, data, max_passes, None, false).0
}

/// A decoder's state at the end of a complete pass, from which a longer cut
/// of the same stream can be decoded without redoing the passes before it.
#[derive(Clone)]
pub struct Checkpoint {
    state: State,
    reader: ReaderSnapshot,
    passes: u32,
    /// The stream bytes the state depends on (to check that a later call
    /// continues the same stream).
    prefix: Vec<u8>,
}

impl std::fmt::Debug for Checkpoint {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Checkpoint")
            .field("passes", &self.passes)
            .field("bytes", &self.prefix.len())
            .finish()
    }
}

impl Checkpoint {
    /// Complete passes behind this checkpoint.
    pub fn passes(&self) -> u32 {
        self.passes
    }

    /// Whether decoding `data` with `params` over `tree` can start here.
    fn continues(&self, tree: &ZeroTree, params: StreamParams, data: &[u8], passes: u32) -> bool {
        self.state.params == params
            && self.state.max_level == tree.max_level()
            && self.state.depth <= tree.depth()
            && self.passes <= passes
            && data.starts_with(&self.prefix)
    }
}

/// [`decode`], starting from `from` when it is a checkpoint of the same
/// stream (otherwise from the start), and returning a checkpoint at the last
/// complete pass for the next, longer cut. The result is the same as
/// [`decode`]'s on the same arguments.
///
/// A checkpoint costs a copy of the decoder's state, so one is taken only
/// before a pass that looks like the last one the data holds (fewer bytes
/// left than the previous pass used); when that guess is wrong the returned
/// checkpoint is an earlier one, or `from` itself. `tree` grows as in
/// [`decode`]; a checkpoint taken with a smaller forest resumes on the
/// grown one.
pub fn decode_resuming(
    tree: &mut ZeroTree,
    params: StreamParams,
    data: &[u8],
    max_passes: Option<u32>,
    from: Option<Checkpoint>,
) -> (Decoded, Option<Checkpoint>) {
    run_decoder(tree, params, data, max_passes, from, true)
}

/// The decoding loop; checkpoints (state copies) only when `keep` is set.
fn run_decoder(
    tree: &mut ZeroTree,
    params: StreamParams,
    data: &[u8],
    max_passes: Option<u32>,
    from: Option<Checkpoint>,
    keep: bool,
) -> (Decoded, Option<Checkpoint>) {
    let passes = max_passes.map_or(params.passes, |p| p.min(params.passes));
    let from = from.filter(|c| c.continues(tree, params, data, passes));
    let (mut state, mut reader, mut done, mut saved) = match from {
        Some(c) => (
            c.state.clone(),
            BitReader::resume(data, c.reader),
            c.passes,
            Some(c),
        ),
        None => (State::new(tree, params), BitReader::new(data), 0, None),
    };
    let mut truncated = false;
    let mut last_pass_bytes = 0;
    // A checkpoint after `done` passes, unless `saved` is as far already.
    let save = |saved: &mut Option<Checkpoint>, state: &State, reader: &BitReader, done: u32| {
        if !keep || saved.as_ref().is_some_and(|c| c.passes >= done) {
            return;
        }
        if let Some(snapshot) = reader.snapshot() {
            *saved = Some(Checkpoint {
                state: state.clone(),
                reader: snapshot,
                passes: done,
                prefix: data[..snapshot.bytes_read()].to_vec(),
            });
        }
    };
    let first = done;
    for pass in first..passes {
        let start = reader.position();
        let left = data.len().saturating_sub(start);
        if done > 0 && left < last_pass_bytes {
            save(&mut saved, &state, &reader, done);
        }
        let coded = state.pass(&mut Trees::Growing(tree), pass, &mut reader, &mut Unknown);
        if coded.is_err() {
            truncated = true;
            break;
        }
        last_pass_bytes = reader.position() - start;
        done += 1;
    }
    if !truncated {
        save(&mut saved, &state, &reader, done);
    }
    let decoded = Decoded {
        nonzero: state.reconstruct(),
        nodes: tree.len(),
        base_low: state.reconstruct_base(),
        base_unknown: state.base_unknown(),
        passes: done,
        truncated,
        bytes_read: reader.position(),
        progress: if truncated {
            state.progress.clone()
        } else {
            Progress::default()
        },
    };
    (decoded, saved)
}
