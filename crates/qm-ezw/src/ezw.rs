//! Embedded zerotree coding of vector coefficients in bit planes.
//!
//! **Weighting.** A level-`l` detail moves a patch of about `4^(L-l)` finest
//! samples, so its effect on the L2 error is about `2^(L-l)` times its own.
//! Coefficients are compared on that scale: the level-`l` coefficient's bit
//! `b` is coded in the pass of plane `b + (L - l)`. Each pass thus spends its
//! bits where they remove the most error, and since the shift is an integer
//! number of bits the last pass still leaves every coefficient exact.
//! [`Weighting::normal_bits`] adds weight to the first coordinate alone: with
//! details in local frames (`qm_lift::frames`) that is the normal component,
//! which moves the surface, while the tangential ones mostly slide samples
//! along it; measured on remeshed models, 2 bits gained about 2 dB at equal
//! bytes over coding the three alike.
//!
//! **Base values.** The level-0 values (base vertex positions after
//! lifting, world axes) weigh `s0 = bits_per_level * L + 1` bits: one more
//! than a level-0 coefficient would, since a base value is a scaling
//! function that moves its whole neighbourhood one way
//! ([`BASE_EXTRA_BITS`]), and no normal bits. The stream can carry their low
//! `k` bits ([`encode`] with [`BaseBits`]), at most those whose weighted
//! plane `b + s0` is a pass (`planes - s0`, [`Weighting::max_base_bits`]),
//! and the caller stores only `value >> k`; `qm-codec` asks for the bits that
//! are noise to its base prediction. Bit `b` of every base value is coded
//! in the pass of plane `b + s0`, at its very start (level 0 is coarser than
//! every detail level), vertex by vertex, with one adaptive context per
//! coordinate and bit (they are close to even). A cut stream thus holds
//! each base value to the precision of the details around it, instead of
//! all of them exactly up front; unknown low bits are reconstructed at the
//! centre of what is left, as unresolved coefficients are.
//!
//! **Passes.** Plane `P` runs from `T0 = floor(log2 max weighted |c|)` down
//! to 0, one pass per plane (the paper's halving thresholds; its garbled T0
//! formula becomes this). A pass goes through the levels coarse to fine; at
//! each level it codes first the *subordinate* bits, then the *dominant* ones:
//! - *subordinate*: one refinement bit for every coordinate of the level that
//!   was already significant before the pass;
//! - *dominant*: the trees are scanned breadth first, coarse to fine. A node
//!   is visited when it is a root or its parent's subtree has been opened.
//!   For a visited node, each not yet significant coordinate gets a
//!   significance bit (and a sign bit when it becomes significant, EZW's
//!   POS/NEG); then, if the node's subtree is still closed, one bit says
//!   whether any coordinate below it is significant at this plane. A 0 is
//!   EZW's zerotree root (ZTR) and the subtree is skipped; a 1 opens it for
//!   good (set partitioning as in SPIHT, so it is never coded again) and the
//!   children are visited in this same pass. A node with insignificant
//!   coordinates and an open subtree is EZW's isolated zero.
//!
//! All three coordinates share the tree: one pass refines all three (world
//! x, y, z, or normal and tangents).
//!
//! **Contexts.** Significance bits are modelled by node kind, level, the
//! coordinate, whether the parent is significant in it, how many of the
//! node's other coordinates are, and how many of its earlier siblings are;
//! signs by the parent's sign; zerotree bits by kind, level and the node's
//! own significance; refinement bits by coordinate and whether this is the
//! first refinement. With [`Contexts::Neighbours`] (the default) the
//! coefficient's neighbours on its own level (`ZeroTree::neighbours`: the
//! nearest points of its level on the surface, a face point's four edge
//! points and an edge point's two face points, rather than up its tree) add to
//! three of these: how many of them are significant in the coordinate (0 to
//! 3 or more) to the significance bits, whether the signs of those lean
//! positive or negative to the sign bits, and how many of them have opened
//! their subtrees (0 to 2 or more) to the zerotree bits. Both sides keep
//! these counts up to date as coordinates become significant and subtrees
//! open, so a context costs no search. Detail is spatially clustered (a
//! crease, an ear, a rough patch of a scan), which a tree alone sees only
//! through the parent and the siblings (docs/decisions/010-neighbour-contexts.md;
//! `docs/contexts.md` has what it costs in speed).
//!
//! **Reconstruction.** An unresolved coefficient is put at the centre of its
//! uncertainty interval, so more bits never make the expected error larger
//! (the paper's rising error came from doing otherwise).

use qm_tree::{NO_PARENT, Neighbours, ZeroTree};

use crate::range::{BitReader, BitWriter, Context, ReaderSnapshot, Truncated};

/// A coefficient: three integer coordinates.
pub type Coef = [i32; 3];

/// How coefficients are weighted across levels and coordinates.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Weighting {
    /// Extra bits of weight per level coarser than the finest (1 = the L2
    /// norm of the basis functions; 0 = all levels alike).
    pub bits_per_level: u32,
    /// Extra bits of weight of the first coordinate: with details in local
    /// frames (normal first) this codes the normal component that many
    /// passes ahead of the tangential ones.
    pub normal_bits: u32,
}

impl Default for Weighting {
    fn default() -> Self {
        Weighting::LEVELS
    }
}

impl Weighting {
    /// One bit per level, coordinates alike.
    pub const LEVELS: Weighting = Weighting {
        bits_per_level: 1,
        normal_bits: 0,
    };

    /// Sets the normal weight.
    pub const fn with_normal_bits(mut self, bits: u32) -> Self {
        self.normal_bits = bits;
        self
    }

    /// Weight in bits of coordinate `coord` of a level-`level` coefficient.
    #[inline]
    fn shift(self, level: u32, coord: usize, max_level: u32) -> u32 {
        self.bits_per_level * (max_level - level) + if coord == 0 { self.normal_bits } else { 0 }
    }

    /// Weight in bits of the level-0 (base) values, `s0 = bits_per_level
    /// * L + 1`: they are in world axes, so no coordinate gets the normal
    /// bits, and a base value moves its whole neighbourhood one way (a
    /// scaling function, not a zero-mean wavelet), which is worth one bit
    /// more than a level-0 detail would be ([`BASE_EXTRA_BITS`]).
    pub fn base_shift(self, max_level: u32) -> u32 {
        self.bits_per_level * max_level + BASE_EXTRA_BITS
    }

    /// The most low bits of every base value a stream of `planes` planes
    /// can carry: those whose weighted plane `b + s0` has a pass, that is
    /// `clamp(planes - s0, 0, MAX_BASE_BITS)`.
    pub fn max_base_bits(self, planes: u32, max_level: u32) -> u32 {
        planes
            .saturating_sub(self.base_shift(max_level))
            .min(MAX_BASE_BITS)
    }
}

/// Weight in bits of a base value beyond that of a level-0 detail (see
/// [`Weighting::base_shift`]): a base value moves its whole neighbourhood
/// one way. At equal bytes 0 loses at high rates and 2 gains less than 1
/// (docs/decisions/009-base-value-bits.md).
pub const BASE_EXTRA_BITS: u32 = 1;

/// Most low bits of a base value the stream carries (the rest of a 32-bit
/// value stays in the base section; quantized values have at most 24 bits).
pub const MAX_BASE_BITS: u32 = 30;

/// Which contexts model the bits (see the module docs).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
#[non_exhaustive]
pub enum Contexts {
    /// Tree contexts only: the parent, the node's other coordinates and its
    /// earlier siblings (for comparisons; the `.qm` format uses
    /// [`Contexts::Neighbours`]).
    Tree,
    /// The tree contexts and the same-level neighbours.
    #[default]
    Neighbours,
}

impl std::fmt::Display for Contexts {
    /// `tree` or `neighbours`.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Contexts::Tree => "tree",
            Contexts::Neighbours => "neighbours",
        })
    }
}

/// What the decoder must know to follow the encoder: stored in the header.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct StreamParams {
    /// Number of bit planes (passes) of a complete stream: `T0 + 1`, or 0
    /// when every coefficient is zero.
    pub planes: u32,
    /// Passes actually coded (at most `planes`).
    pub passes: u32,
    /// Level weighting.
    pub weighting: Weighting,
    /// Low bits of each base value coded in the stream (at most
    /// [`Weighting::max_base_bits`] of `planes`), or 0 when the base values
    /// are all elsewhere.
    pub base_bits: u32,
    /// How many base vertices, the first ones, have those low bits in the
    /// stream; the caller makes the others' values some other way
    /// (`qm-codec` predicts a level-0 split base's edge midpoints and
    /// centres from its corners).
    pub base_values: u32,
    /// The context model.
    pub contexts: Contexts,
}

/// Result of encoding.
#[derive(Clone, Debug)]
pub struct Encoded {
    /// The arithmetic-coded stream.
    pub bytes: Vec<u8>,
    /// Parameters for the decoder.
    pub params: StreamParams,
    /// Bytes needed to decode the first `k + 1` passes, for each pass `k`.
    pub pass_ends: Vec<usize>,
}

/// Result of decoding a (possibly cut) stream.
#[derive(Clone, Debug)]
pub struct Decoded {
    /// The reconstructed coordinates that are not zero, one entry each
    /// (every other coordinate is zero), level by level in the order they
    /// became significant, not in node order: a short cut has few, so they
    /// are kept sparse; [`Decoded::coefs`] and [`Decoded::scatter`] spread
    /// them.
    pub nonzero: Vec<Nonzero>,
    /// The number of nodes.
    pub nodes: usize,
    /// Reconstructed low [`StreamParams::base_bits`] bits of each base
    /// value (in `0 .. 2^base_bits`, the centre of what is known), to add
    /// to its high part `(value >> base_bits) << base_bits`; empty when the
    /// stream carries no base bits.
    pub base_low: Vec<Coef>,
    /// Passes decoded completely.
    pub passes: u32,
    /// Whether the stream ended before the passes asked for were complete.
    pub truncated: bool,
    /// Stream bytes read.
    pub bytes_read: usize,
    /// When truncated: how far the pass after the complete ones got.
    pub progress: Progress,
}

/// How far a pass got before the stream ended (what an estimate of the
/// remaining error needs beyond the complete passes).
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Progress {
    /// Whether the pass coded its bits of the base values.
    pub base: bool,
    /// Detail levels, from level 1 on, whose bits of the pass were all
    /// coded.
    pub levels: u32,
    /// Per detail level (index 0 is level 1) and coordinate: how many
    /// coordinates became significant in the pass.
    pub fresh: Vec<[u32; 3]>,
}

/// A decoded coordinate that is not zero.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Nonzero {
    /// The node.
    pub node: u32,
    /// The coordinate (0, 1 or 2).
    pub coord: u8,
    /// Its value.
    pub value: i32,
}

impl Decoded {
    /// Every coefficient, in node order.
    pub fn coefs(&self) -> Vec<Coef> {
        let mut coefs = vec![[0; 3]; self.nodes];
        for e in &self.nonzero {
            coefs[e.node as usize][e.coord as usize] = e.value;
        }
        coefs
    }

    /// Writes the coordinates that are not zero into `by_sample`, at the
    /// sample of their node (`samples`, as [`ZeroTree::samples`] gives);
    /// the others keep what they hold.
    pub fn scatter(&self, samples: &[u32], by_sample: &mut [Coef]) {
        for e in &self.nonzero {
            by_sample[samples[e.node as usize] as usize][e.coord as usize] = e.value;
        }
    }
}

/// Base values whose low bits a stream is to carry.
#[derive(Clone, Copy, Debug)]
pub struct BaseBits<'a> {
    /// The level-0 values, one per base vertex.
    pub values: &'a [Coef],
    /// The most low bits of each to carry; the stream carries fewer when
    /// it has no pass for them ([`Weighting::max_base_bits`]).
    pub most: u32,
}

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
    let mut writer = BitWriter::new();
    let mut pass_ends = Vec::new();
    let plan = plan(tree, coefs, base, weighting, contexts, max_passes);
    let params = code_passes(tree, coefs, base, plan, &mut writer, |w| {
        pass_ends.push(w.len_needed())
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
/// `after_pass` after each; the stream parameters.
fn code_passes<C: Coder>(
    tree: &ZeroTree,
    coefs: &[Coef],
    base: Option<BaseBits<'_>>,
    (params, below): (StreamParams, Vec<i32>),
    coder: &mut C,
    mut after_pass: impl FnMut(&C),
) -> StreamParams {
    let mut oracle = Truth {
        coefs,
        below: &below,
        base: base.map_or(&[], |b| b.values),
    };
    let mut state = State::new(tree, params);
    for pass in 0..params.passes {
        let coded = state.pass(tree, pass, coder, &mut oracle);
        debug_assert!(coded.is_ok());
        after_pass(coder);
    }
    params
}

/// The stream parameters of `coefs` and the highest weighted plane below
/// each node.
fn plan(
    tree: &ZeroTree,
    coefs: &[Coef],
    base: Option<BaseBits<'_>>,
    weighting: Weighting,
    contexts: Contexts,
    max_passes: Option<u32>,
) -> (StreamParams, Vec<i32>) {
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
pub fn decode(
    tree: &ZeroTree,
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

    /// Whether decoding `data` with `params` can start here.
    fn continues(&self, params: StreamParams, data: &[u8], passes: u32) -> bool {
        self.state.params == params && self.passes <= passes && data.starts_with(&self.prefix)
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
/// checkpoint is an earlier one, or `from` itself.
pub fn decode_resuming(
    tree: &ZeroTree,
    params: StreamParams,
    data: &[u8],
    max_passes: Option<u32>,
    from: Option<Checkpoint>,
) -> (Decoded, Option<Checkpoint>) {
    run_decoder(tree, params, data, max_passes, from, true)
}

/// The decoding loop; checkpoints (state copies) only when `keep` is set.
fn run_decoder(
    tree: &ZeroTree,
    params: StreamParams,
    data: &[u8],
    max_passes: Option<u32>,
    from: Option<Checkpoint>,
    keep: bool,
) -> (Decoded, Option<Checkpoint>) {
    let passes = max_passes.map_or(params.passes, |p| p.min(params.passes));
    let from = from.filter(|c| c.continues(params, data, passes));
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
        if state.pass(tree, pass, &mut reader, &mut Unknown).is_err() {
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

/// Encoder or decoder, seen from the scan. `sym` says what the bit is (a
/// [`BitBudget`] slot); only the measuring coder looks at it.
trait Coder {
    fn code(&mut self, ctx: &mut Context, bit: bool, sym: Sym) -> Result<bool, Truncated>;
}

impl Coder for BitWriter {
    #[inline]
    fn code(&mut self, ctx: &mut Context, bit: bool, _: Sym) -> Result<bool, Truncated> {
        self.encode(ctx, bit);
        Ok(bit)
    }
}

impl Coder for BitReader<'_> {
    #[inline]
    fn code(&mut self, ctx: &mut Context, _: bool, _: Sym) -> Result<bool, Truncated> {
        self.decode(ctx)
    }
}

/// What a coded bit is: its [`BitBudget`] slot.
#[derive(Clone, Copy)]
enum Sym {
    Significance(usize, usize),
    Sign(usize),
    Zerotree(usize),
    Refinement(usize, usize),
    Base,
}

/// Symbols coded and their cost under the adaptive models at coding time.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Cost {
    /// Binary symbols coded.
    pub symbols: u64,
    /// Sum of `-log2 p` of the coded symbols.
    pub bits: f64,
}

impl Cost {
    fn add(&mut self, bits: f64) {
        self.symbols += 1;
        self.bits += bits;
    }
}

/// Where the bits of a stream go, by symbol class. Level classes: 0 is the
/// finest level, 1 and 2 the next coarser, 3 all coarser ones.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct BitBudget {
    /// Significance bits by level class and coordinate.
    pub significance: [[Cost; 3]; LEVEL_CLASSES],
    /// Sign bits by coordinate.
    pub sign: [Cost; 3],
    /// Zerotree (subtree significance) bits by level class.
    pub zerotree: [Cost; LEVEL_CLASSES],
    /// Refinement bits by level class and coordinate.
    pub refinement: [[Cost; 3]; LEVEL_CLASSES],
    /// Low bits of the base values coded in the stream.
    pub base: Cost,
}

/// An encoder that also adds up the cost of every symbol.
struct Tally {
    writer: BitWriter,
    budget: BitBudget,
}

impl Coder for Tally {
    fn code(&mut self, ctx: &mut Context, bit: bool, sym: Sym) -> Result<bool, Truncated> {
        let cost = ctx.cost(bit);
        let b = &mut self.budget;
        match sym {
            Sym::Significance(class, c) => b.significance[class][c].add(cost),
            Sym::Sign(c) => b.sign[c].add(cost),
            Sym::Zerotree(class) => b.zerotree[class].add(cost),
            Sym::Refinement(class, c) => b.refinement[class][c].add(cost),
            Sym::Base => b.base.add(cost),
        }
        self.writer.code(ctx, bit, sym)
    }
}

/// Encodes like [`encode`] and returns the bit budget after each pass (the
/// bits to code the first `k + 1` passes at index `k`).
pub fn bit_budget(
    tree: &ZeroTree,
    coefs: &[Coef],
    base: Option<BaseBits<'_>>,
    weighting: Weighting,
    contexts: Contexts,
    max_passes: Option<u32>,
) -> Vec<BitBudget> {
    let mut tally = Tally {
        writer: BitWriter::new(),
        budget: BitBudget::default(),
    };
    let mut budgets = Vec::new();
    let plan = plan(tree, coefs, base, weighting, contexts, max_passes);
    code_passes(tree, coefs, base, plan, &mut tally, |t| {
        budgets.push(t.budget.clone())
    });
    budgets
}

/// The true data behind the bits: the encoder has it, the decoder does not.
trait Oracle {
    fn magnitude(&self, node: usize, coord: usize) -> u32;
    fn negative(&self, node: usize, coord: usize) -> bool;
    fn below(&self, node: usize) -> i32;
    /// Bit `bit` of coordinate `index % 3` of base value `index / 3`.
    fn base_bit(&self, index: usize, bit: u32) -> bool;
}

struct Truth<'a> {
    coefs: &'a [Coef],
    below: &'a [i32],
    base: &'a [Coef],
}

impl Oracle for Truth<'_> {
    #[inline]
    fn magnitude(&self, node: usize, coord: usize) -> u32 {
        self.coefs[node][coord].unsigned_abs()
    }
    #[inline]
    fn negative(&self, node: usize, coord: usize) -> bool {
        self.coefs[node][coord] < 0
    }
    #[inline]
    fn below(&self, node: usize) -> i32 {
        self.below[node]
    }
    #[inline]
    fn base_bit(&self, index: usize, bit: u32) -> bool {
        (self.base[index / 3][index % 3] >> bit) & 1 != 0
    }
}

struct Unknown;

impl Oracle for Unknown {
    fn magnitude(&self, _: usize, _: usize) -> u32 {
        0
    }
    fn negative(&self, _: usize, _: usize) -> bool {
        false
    }
    fn below(&self, _: usize) -> i32 {
        -1
    }
    fn base_bit(&self, _: usize, _: u32) -> bool {
        false
    }
}

/// Level classes of the contexts and of [`BitBudget`].
pub const LEVEL_CLASSES: usize = 4;

/// Coarse level class: 0 = finest level, 1, 2, 3 = three or more above it.
#[inline]
fn level_class(level: u32, max_level: u32) -> usize {
    ((max_level - level) as usize).min(LEVEL_CLASSES - 1)
}

/// Values of the neighbour part of a significance context (significant
/// neighbours 0, 1, 2, 3 or more), of a sign context (no lean, positive,
/// negative) and of a zerotree context (open neighbours 0, 1, 2 or more);
/// always 0 with [`Contexts::Tree`].
const NEIGHBOUR_SIG: usize = 4;
const NEIGHBOUR_SIGN: usize = 3;
const NEIGHBOUR_OPEN: usize = 3;

#[derive(Clone)]
struct Models {
    /// [kind][level class][coord][parent state 3][own sig 3][siblings 3]
    /// [neighbours NEIGHBOUR_SIG]
    significance: Vec<Context>,
    /// [coord][parent sign state 3][neighbours NEIGHBOUR_SIGN]
    sign: Vec<Context>,
    /// [kind][level class][own sig count 4][neighbours NEIGHBOUR_OPEN]
    zerotree: Vec<Context>,
    /// [coord][first refinement?]
    refine: [Context; 6],
    /// Base value bits: [coord][bit]
    base: Vec<Context>,
}

impl Models {
    fn new() -> Self {
        Models {
            significance: vec![
                Context::default();
                2 * LEVEL_CLASSES * 3 * 3 * 3 * 3 * NEIGHBOUR_SIG
            ],
            sign: vec![Context::default(); 3 * 3 * NEIGHBOUR_SIGN],
            zerotree: vec![Context::default(); 2 * LEVEL_CLASSES * 4 * NEIGHBOUR_OPEN],
            refine: [Context::default(); 6],
            base: vec![Context::default(); 3 * MAX_BASE_BITS as usize],
        }
    }
}

/// What a sample's neighbours show, kept up to date by coder and decoder
/// alike ([`Contexts::Neighbours`]), in 14 bits: for each coordinate `c`,
/// how many of the neighbours significant in it are positive (2 bits at
/// `4c`) and how many negative (2 bits at `4c + 2`); then how many have
/// opened their subtrees (2 bits at 12). Each count stops at 3, which
/// loses nothing: a sample has at most four neighbours, so a count of 4
/// leaves the other at 0, and the contexts tell 3 from 4 neither in the
/// significant nor in the open ones. Zero: nothing known yet.
#[derive(Clone, Copy)]
struct Around(u16);

impl Around {
    /// Adds one to the 2-bit count at `shift`, up to 3.
    #[inline]
    fn with_one_more(self, shift: usize) -> Self {
        if (self.0 >> shift) & 3 == 3 {
            self
        } else {
            Around(self.0 + (1 << shift))
        }
    }

    /// A neighbour's coordinate `c` became significant, negative or not.
    #[inline]
    fn with_significant(self, c: usize, negative: bool) -> Self {
        self.with_one_more(4 * c + 2 * negative as usize)
    }

    /// A neighbour opened its subtree.
    #[inline]
    fn with_open(self) -> Self {
        self.with_one_more(12)
    }

    /// The neighbours significant in coordinate `c`: positive, negative.
    #[inline]
    fn counts(self, c: usize) -> (u16, u16) {
        ((self.0 >> (4 * c)) & 3, (self.0 >> (4 * c + 2)) & 3)
    }

    /// The neighbour part of a significance context of coordinate `c`.
    #[inline]
    fn significance(self, c: usize) -> usize {
        let (positive, negative) = self.counts(c);
        ((positive + negative) as usize).min(NEIGHBOUR_SIG - 1)
    }

    /// The neighbour part of a sign context of coordinate `c`: whether the
    /// significant neighbours' signs lean positive (1) or negative (2).
    #[inline]
    fn sign(self, c: usize) -> usize {
        let (positive, negative) = self.counts(c);
        match positive.cmp(&negative) {
            std::cmp::Ordering::Equal => 0,
            std::cmp::Ordering::Greater => 1,
            std::cmp::Ordering::Less => 2,
        }
    }

    /// The neighbour part of a zerotree context.
    #[inline]
    fn open(self) -> usize {
        ((self.0 >> 12) as usize & 3).min(NEIGHBOUR_OPEN - 1)
    }
}

/// What coder and decoder both know about each node.
#[derive(Clone)]
struct State {
    params: StreamParams,
    max_level: u32,
    /// Bit `c` set: coordinate `c` is significant.
    sig: Vec<u8>,
    /// Bit `c` set: coordinate `c` is negative.
    neg: Vec<u8>,
    /// Whether the node's subtree has been opened.
    open: Vec<bool>,
    /// What each sample's neighbours show ([`Around`], by sample id;
    /// zeroed, so untouched pages cost nothing; empty with
    /// [`Contexts::Tree`]).
    around: Vec<u16>,
    /// Per level, significant coordinates in the order they became so, with
    /// what is known of their magnitudes.
    refine_lists: Vec<Vec<Significant>>,
    models: Models,
    frontier: Vec<u32>,
    next: Vec<u32>,
    /// Known low bits of each base coordinate (vertex-major, three per
    /// vertex; empty without base bits).
    base_known: Vec<u32>,
    /// The lowest bit known of each base coordinate (`base_bits`: none).
    base_low: Vec<u8>,
    /// How far the pass being coded has got.
    progress: Progress,
}

impl State {
    fn new(tree: &ZeroTree, params: StreamParams) -> Self {
        let n = tree.len();
        let base_values = if params.base_bits > 0 {
            (params.base_values as usize).min(tree.base_vertices())
        } else {
            0
        };
        State {
            params,
            max_level: tree.max_level(),
            sig: vec![0; n],
            neg: vec![0; n],
            open: vec![false; n],
            around: match params.contexts {
                Contexts::Tree => Vec::new(),
                Contexts::Neighbours => vec![0; tree.base_vertices() + n],
            },
            refine_lists: vec![Vec::new(); tree.max_level() as usize],
            models: Models::new(),
            frontier: Vec::new(),
            next: Vec::new(),
            base_known: vec![0; 3 * base_values],
            base_low: vec![params.base_bits as u8; 3 * base_values],
            progress: Progress::default(),
        }
    }

    /// Updates what node `k`'s neighbours know of it (nothing with
    /// [`Contexts::Tree`], which keeps no counts); `known` keeps the
    /// neighbours once found, for the node's next update in the same visit.
    #[inline]
    fn tell_neighbours(
        &mut self,
        tree: &ZeroTree,
        k: usize,
        known: &mut Option<Neighbours>,
        update: impl Fn(Around) -> Around,
    ) {
        if self.around.is_empty() {
            return;
        }
        for &s in known.get_or_insert_with(|| tree.neighbours(k)).iter() {
            let a = &mut self.around[s as usize];
            *a = update(Around(*a)).0;
        }
    }

    /// What node `k`'s neighbours show (nothing with [`Contexts::Tree`]).
    #[inline]
    fn around(&self, tree: &ZeroTree, k: usize) -> Around {
        Around(
            self.around
                .get(tree.samples()[k] as usize)
                .map_or(0, |&a| a),
        )
    }

    /// Bit plane of coordinate `coord` of a level-`level` coefficient coded
    /// in global plane `plane`.
    #[inline]
    fn own_plane(&self, plane: i32, level: u32, coord: usize) -> i32 {
        plane - self.params.weighting.shift(level, coord, self.max_level) as i32
    }

    /// One pass; `pass` 0 is the top plane. Level by level, coarse to fine:
    /// first the refinement bits of the level's coefficients that were
    /// significant before the pass, then its significance and zerotree bits.
    /// (Against the classic order, all refinement after the whole dominant
    /// phase, this moves the small error rises inside a pass around without
    /// removing them; see `docs/passes.md`.)
    fn pass<C: Coder, O: Oracle>(
        &mut self,
        tree: &ZeroTree,
        pass: u32,
        coder: &mut C,
        oracle: &mut O,
    ) -> Result<(), Truncated> {
        let plane = self.params.planes as i32 - 1 - pass as i32;
        self.progress.base = false;
        self.progress.levels = 0;
        self.progress.fresh.clear();
        self.progress.fresh.resize(self.max_level as usize, [0; 3]);
        self.base_pass(plane, coder, oracle)?;
        self.progress.base = true;
        let before: Vec<usize> = self.refine_lists.iter().map(Vec::len).collect();
        self.dominant(tree, plane, &before, coder, oracle)?;
        self.progress.levels = self.max_level;
        Ok(())
    }

    /// Bit `plane - s0` of every base coordinate, if the stream carries it:
    /// level 0 is coarser than every detail level, so its bits of a plane
    /// come first.
    fn base_pass<C: Coder, O: Oracle>(
        &mut self,
        plane: i32,
        coder: &mut C,
        oracle: &mut O,
    ) -> Result<(), Truncated> {
        let b = plane - self.params.weighting.base_shift(self.max_level) as i32;
        if !(0..self.params.base_bits as i32).contains(&b) {
            return Ok(());
        }
        let known = self.base_known.iter_mut().zip(&mut self.base_low);
        for (i, (known, low)) in known.enumerate() {
            let ctx = &mut self.models.base[(i % 3) * MAX_BASE_BITS as usize + b as usize];
            if coder.code(ctx, oracle.base_bit(i, b as u32), Sym::Base)? {
                *known |= 1 << b;
            }
            *low = b as u8;
        }
        Ok(())
    }

    fn dominant<C: Coder, O: Oracle>(
        &mut self,
        tree: &ZeroTree,
        plane: i32,
        refine_before: &[usize],
        coder: &mut C,
        oracle: &mut O,
    ) -> Result<(), Truncated> {
        let levels = tree.levels();
        let kinds = tree.kinds();
        let parents = tree.parents();
        let mut frontier = std::mem::take(&mut self.frontier);
        let mut next = std::mem::take(&mut self.next);
        frontier.clear();
        frontier.extend(0..tree.roots() as u32);
        let mut result = Ok(());
        // Breadth first: the frontier holds the visited nodes of one level.
        let mut depth = 1;
        'levels: while !frontier.is_empty() {
            if let Err(e) = self.refine(
                depth,
                plane,
                refine_before[depth as usize - 1],
                coder,
                oracle,
            ) {
                result = Err(e);
                break 'levels;
            }
            depth += 1;
            next.clear();
            for &k in &frontier {
                let k = k as usize;
                let level = levels[k] as u32;
                let kind = kinds[k] as usize;
                let class = level_class(level, self.max_level);
                // What the node's neighbours show (only they change it), and
                // the neighbours themselves, once an update needs them.
                let around = self.around(tree, k);
                let mut known = None;
                if self.sig[k] != 0b111 {
                    let parent = parents[k];
                    for c in 0..3 {
                        let b = self.own_plane(plane, level, c);
                        if b < 0 || self.sig[k] & (1 << c) != 0 {
                            continue;
                        }
                        let parent_state = if parent == NO_PARENT {
                            0
                        } else if self.sig[parent as usize] & (1 << c) != 0 {
                            2
                        } else {
                            1
                        };
                        let own = (self.sig[k].count_ones() as usize).min(2);
                        let siblings = if parent == NO_PARENT {
                            0
                        } else {
                            let first = tree.children(parent as usize).start;
                            (first..k)
                                .filter(|&s| self.sig[s] & (1 << c) != 0)
                                .count()
                                .min(2)
                        };
                        let ctx = (((((kind * LEVEL_CLASSES + class) * 3 + c) * 3 + parent_state)
                            * 3
                            + own)
                            * 3
                            + siblings)
                            * NEIGHBOUR_SIG
                            + around.significance(c);
                        let truth = oracle.magnitude(k, c) >> b != 0;
                        match coder.code(
                            &mut self.models.significance[ctx],
                            truth,
                            Sym::Significance(class, c),
                        ) {
                            Ok(true) => {}
                            Ok(false) => continue,
                            Err(e) => {
                                result = Err(e);
                                break 'levels;
                            }
                        }
                        let sign_ctx = (c * 3
                            + match parent {
                                NO_PARENT => 0,
                                p if self.sig[p as usize] & (1 << c) == 0 => 0,
                                p if self.neg[p as usize] & (1 << c) != 0 => 2,
                                _ => 1,
                            })
                            * NEIGHBOUR_SIGN
                            + around.sign(c);
                        let negative = match coder.code(
                            &mut self.models.sign[sign_ctx],
                            oracle.negative(k, c),
                            Sym::Sign(c),
                        ) {
                            Ok(n) => n,
                            Err(e) => {
                                result = Err(e);
                                break 'levels;
                            }
                        };
                        self.sig[k] |= 1 << c;
                        self.progress.fresh[level as usize - 1][c] += 1;
                        if negative {
                            self.neg[k] |= 1 << c;
                        }
                        self.tell_neighbours(tree, k, &mut known, |a| {
                            a.with_significant(c, negative)
                        });
                        self.refine_lists[level as usize - 1].push(Significant {
                            node: k as u32,
                            coord: c as u8,
                            low: b as u8,
                            mag: 1 << b,
                        });
                    }
                }
                let children = tree.children(k);
                if children.is_empty() {
                    continue;
                }
                if !self.open[k] {
                    let around = around.open();
                    let ctx = ((kind * LEVEL_CLASSES + class) * 4
                        + self.sig[k].count_ones() as usize)
                        * NEIGHBOUR_OPEN
                        + around;
                    match coder.code(
                        &mut self.models.zerotree[ctx],
                        oracle.below(k) >= plane,
                        Sym::Zerotree(class),
                    ) {
                        Ok(true) => {
                            self.open[k] = true;
                            self.tell_neighbours(tree, k, &mut known, Around::with_open);
                        }
                        Ok(false) => continue,
                        Err(e) => {
                            result = Err(e);
                            break 'levels;
                        }
                    }
                }
                next.extend(children.map(|c| c as u32));
            }
            self.progress.levels = depth - 1;
            std::mem::swap(&mut frontier, &mut next);
        }
        self.frontier = frontier;
        self.next = next;
        result
    }

    /// Refinement bits of the first `count` significant coordinates of `level`.
    fn refine<C: Coder, O: Oracle>(
        &mut self,
        level: u32,
        plane: i32,
        count: usize,
        coder: &mut C,
        oracle: &mut O,
    ) -> Result<(), Truncated> {
        let planes: [i32; 3] = std::array::from_fn(|c| self.own_plane(plane, level, c));
        if planes.iter().all(|&b| b < 0) {
            // Every coordinate of this level is exact.
            return Ok(());
        }
        let class = level_class(level, self.max_level);
        let models = &mut self.models.refine;
        for e in &mut self.refine_lists[level as usize - 1][..count] {
            let (k, c) = (e.node as usize, e.coord as usize);
            let b = planes[c];
            if b < 0 {
                continue;
            }
            let first = (e.low as i32 == b + 1) as usize;
            let truth = (oracle.magnitude(k, c) >> b) & 1 != 0;
            if coder.code(&mut models[c * 2 + first], truth, Sym::Refinement(class, c))? {
                e.mag |= 1 << b;
            }
            e.low = b as u8;
        }
        Ok(())
    }

    /// Centre of the uncertainty interval of every significant coordinate
    /// (the others are zero).
    fn reconstruct(&self) -> Vec<Nonzero> {
        let mut nonzero = Vec::with_capacity(self.refine_lists.iter().map(Vec::len).sum());
        let significant = self.refine_lists.iter().flatten();
        nonzero.extend(significant.map(|e| {
            let m = centre(e.mag, e.low) as i32;
            let negative = self.neg[e.node as usize] & (1 << e.coord) != 0;
            Nonzero {
                node: e.node,
                coord: e.coord,
                value: if negative { -m } else { m },
            }
        }));
        nonzero
    }

    /// Centre of every base value's low bits (zeros without base bits).
    fn reconstruct_base(&self) -> Vec<Coef> {
        let mut low = vec![[0; 3]; self.base_known.len() / 3];
        for (i, (&known, &bit)) in self.base_known.iter().zip(&self.base_low).enumerate() {
            low[i / 3][i % 3] = centre(known, bit) as i32;
        }
        low
    }
}

/// Centre of the values whose bits from `low` up are `known`.
#[inline]
fn centre(known: u32, low: u8) -> u32 {
    known + if low > 0 { 1 << (low - 1) } else { 0 }
}

/// A significant coordinate and the bits known of its magnitude.
#[derive(Clone, Copy)]
struct Significant {
    node: u32,
    coord: u8,
    /// Lowest bit plane known.
    low: u8,
    /// Magnitude bits known so far.
    mag: u32,
}

#[cfg(test)]
mod tests {
    use super::*;
    use qm_lift::Layout;

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

    /// The packed neighbour counts give the contexts the plain counts
    /// would, for every way up to four neighbours can become significant
    /// and open, in any coordinate.
    #[test]
    fn packed_neighbour_counts_match_plain_counts() {
        // Each of four neighbours: significant positive, negative, or not,
        // in coordinate `c`; open or not.
        for c in 0..3 {
            for states in 0..(3u32.pow(4) * 16) {
                let (mut around, mut positive, mut negative, mut open) = (Around(0), 0, 0, 0);
                for n in 0..4 {
                    match states / 3u32.pow(n) % 3 {
                        1 => {
                            around = around.with_significant(c, false);
                            positive += 1;
                        }
                        2 => {
                            around = around.with_significant(c, true);
                            negative += 1;
                        }
                        _ => {}
                    }
                    if (states / 81) & (1 << n) != 0 {
                        around = around.with_open();
                        open += 1;
                    }
                }
                let significant = positive + negative;
                assert_eq!(around.significance(c), significant.min(NEIGHBOUR_SIG - 1));
                let lean = match positive.cmp(&negative) {
                    std::cmp::Ordering::Equal => 0,
                    std::cmp::Ordering::Greater => 1,
                    std::cmp::Ordering::Less => 2,
                };
                assert_eq!(around.sign(c), lean, "{positive} +, {negative} -");
                assert_eq!(around.open(), open.min(NEIGHBOUR_OPEN - 1));
                // The other coordinates know nothing of it.
                for d in (0..3).filter(|&d| d != c) {
                    assert_eq!((around.significance(d), around.sign(d)), (0, 0));
                }
            }
        }
    }

    #[test]
    fn lossless_after_all_passes() {
        let layout = layout(4);
        let tree = ZeroTree::new(&layout);
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
                let dec = decode(&tree, enc.params, &enc.bytes, None);
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
        let tree = ZeroTree::new(&layout(4));
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
            let dec = decode(&tree, enc.params, &enc.bytes, None);
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
                let base = Some(BaseBits { values: &b, most });
                let fewer = encode(&tree, &c, base, weighting, Contexts::default(), None);
                assert_eq!(fewer.params.base_bits, most.min(bits));
                let dec = decode(&tree, fewer.params, &fewer.bytes, None);
                assert_eq!(dec.coefs(), c);
                assert_eq!(join_base(&b, &dec, most.min(bits)), b);
                assert!(fewer.bytes.len() <= enc.bytes.len());
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
        })
    }

    /// Each base bit goes in the pass of its weighted plane: after `p`
    /// passes a base value is known down to bit `planes - p - s0`, and the
    /// rest is at the centre of what is left.
    #[test]
    fn base_bits_arrive_with_their_planes() {
        let tree = ZeroTree::new(&layout(3));
        let b = base(&tree, 8);
        let c = coefs(&tree, 9);
        let weighting = Weighting::LEVELS.with_normal_bits(2);
        let enc = encode_all_bits(&tree, &c, &b, weighting);
        let (planes, k) = (enc.params.planes, enc.params.base_bits);
        let s0 = weighting.base_shift(3);
        assert_eq!(k, planes - s0);
        for p in 0..=planes {
            let dec = decode(&tree, enc.params, &enc.bytes, Some(p));
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
        let tree = ZeroTree::new(&layout(3));
        let enc = encode(
            &tree,
            &vec![[0; 3]; tree.len()],
            None,
            Weighting::default(),
            Contexts::default(),
            None,
        );
        assert_eq!(enc.params.planes, 0);
        let dec = decode(&tree, enc.params, &enc.bytes, None);
        assert!(dec.coefs().iter().all(|c| *c == [0; 3]));
    }

    #[test]
    fn prefixes_decode_and_error_never_rises() {
        let tree = ZeroTree::new(&layout(4));
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
                let dec = decode(&tree, enc.params, &enc.bytes[..cut], None);
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
        let tree = ZeroTree::new(&layout(4));
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
            let fresh = decode(&tree, enc.params, data, None);
            let from = checkpoint.take();
            if let Some(c) = &from {
                resumed += (Checkpoint::passes(c) > 0) as usize;
            }
            let (got, next) = decode_resuming(&tree, enc.params, data, None, from);
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
        let fresh = decode(&tree, other.params, &other.bytes, None);
        let (got, _) = decode_resuming(&tree, other.params, &other.bytes, None, checkpoint.clone());
        assert_eq!(got.coefs(), fresh.coefs());
        let fresh = decode(&tree, enc.params, &enc.bytes, Some(3));
        let (got, _) = decode_resuming(&tree, enc.params, &enc.bytes, Some(3), checkpoint);
        assert_eq!(got.coefs(), fresh.coefs());
    }

    #[test]
    fn fewer_passes_are_a_prefix_of_more() {
        let tree = ZeroTree::new(&layout(3));
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
        let a = decode(&tree, four.params, &four.bytes, None);
        let b = decode(&tree, full.params, &full.bytes, Some(4));
        assert_eq!(a.coefs(), b.coefs());
        assert_eq!(a.passes, 4);
        assert!(full.pass_ends.windows(2).all(|w| w[0] <= w[1]));
    }
}
