//! Embedded zerotree coding of mesh wavelet coefficients.
//!
//! [`encode`] turns the coefficients of a [`ZeroTree`] forest into an
//! embedded bit-plane stream (EZW passes with halving thresholds, zerotree
//! symbols and refinement bits), every symbol through an adaptive binary
//! arithmetic coder ([`BitWriter`]). [`decode`] reads any prefix of such a
//! stream back ([`BitReader`]) and returns the best reconstruction that prefix
//! allows. Main types: [`StreamParams`] (what a decoder must be told),
//! [`Weighting`], [`Encoded`], [`Decoded`].

mod ezw;
mod range;

pub use ezw::{
    BaseBits, BitBudget, Checkpoint, Coef, Contexts, Cost, Decoded, Encoded, LEVEL_CLASSES,
    MAX_BASE_BITS, Nonzero, Progress, StreamParams, Weighting, bit_budget, decode, decode_resuming,
    encode,
};
pub use qm_tree::{self, ZeroTree};
pub use range::{BitReader, BitWriter, Context, ReaderSnapshot, Truncated};
