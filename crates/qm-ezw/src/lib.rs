//! Embedded zerotree coding of mesh wavelet coefficients.
//!
//! [`encode`] turns the coefficients of a [`ZeroTree`] forest into an
//! embedded bit-plane stream (EZW passes with halving thresholds, zerotree
//! symbols and refinement bits), every symbol through an adaptive binary
//! arithmetic coder ([`BitWriter`]). [`decode`] reads any prefix of such a
//! stream back ([`BitReader`]) and returns the best reconstruction that
//! prefix allows, over a forest that grows only as far as the prefix
//! reaches ([`ZeroTree::partial`]). Main types: [`StreamParams`] (what a
//! decoder must be told), [`Weighting`], [`Encoded`], [`Decoded`].
//!
//! The modules, by step: `params` (what encoder and decoder agree on, and
//! the weighting's math), `passes` (planning and running the passes, the
//! checkpoints), `walk` (one pass over the trees and the reconstruction),
//! `contexts` (the adaptive contexts, the neighbours' counts), `coder`
//! (the bits as the scan sees them), `output` (what coding gives),
//! `budget` (where the bits go) and `range` (the binary range coder).

mod budget;
mod coder;
mod contexts;
mod output;
mod params;
mod passes;
mod range;
#[cfg(test)]
mod tests;
mod walk;

pub use budget::{BitBudget, Cost, bit_budget};
pub use contexts::LEVEL_CLASSES;
pub use output::{Decoded, Encoded, Nonzero, Progress};
pub use params::{BaseBits, Coef, Contexts, MAX_BASE_BITS, StreamParams, Weighting};
pub use passes::{Checkpoint, decode, decode_resuming, encode, encode_prefix};
pub use qm_tree::{self, ZeroTree};
pub use range::{BitReader, BitWriter, Context, ReaderSnapshot, SLOWEST, Truncated};
