//! What an encoder and its decoder agree on: how coefficients are weighted
//! ([`Weighting`]), which contexts model the bits ([`Contexts`]), the
//! parameters a decoder is told ([`StreamParams`]) and the base values
//! whose low bits a stream carries ([`BaseBits`]).
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
//! along it; `qm-codec` gives it 2 bits
//! (docs/decisions/027-normal-weight-bits.md).
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
    pub(crate) fn shift(self, level: u32, coord: usize, max_level: u32) -> u32 {
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

/// Which contexts model the bits (the `contexts` module describes them).
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

/// Base values whose low bits a stream is to carry.
#[derive(Clone, Copy, Debug)]
pub struct BaseBits<'a> {
    /// The level-0 values, one per base vertex.
    pub values: &'a [Coef],
    /// The most low bits of each to carry; the stream carries fewer when
    /// it has no pass for them ([`Weighting::max_base_bits`]), unless
    /// `whole` is set.
    pub most: u32,
    /// Make the stream's planes reach bit `most - 1` of the base values,
    /// so that it carries all `most` low bits whatever the details need:
    /// for values below `2^most` (non-negative), whose high parts are then
    /// all zero and need no storing (`qm-codec`'s colours).
    pub whole: bool,
    /// Carry the low bits of each value plus half the step of the stream's
    /// `k = base_bits` (`v + 2^(k-1)`), so that the caller's high part
    /// `(v + 2^(k-1)) >> k` is the value rounded, not floored: with no low
    /// bit known, a decoder's centre of the cell, minus that half, is the
    /// nearest multiple of `2^k` (format version 5 on for geometry). A CAD
    /// part's coordinates at its bounding box are multiples of it.
    pub rounded: bool,
}
