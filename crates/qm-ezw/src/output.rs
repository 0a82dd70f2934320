//! What coding gives: the stream with its parameters and pass ends
//! ([`Encoded`]), and a decoded prefix's coefficients, base value low bits
//! and progress ([`Decoded`], [`Nonzero`], [`Progress`]).

use crate::params::{Coef, StreamParams};

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
    /// The number of nodes of the forest as the decoding left it (a
    /// partial forest grows only as far as the stream reached).
    pub nodes: usize,
    /// Reconstructed low [`StreamParams::base_bits`] bits of each base
    /// value (in `0 .. 2^base_bits`, the centre of what is known), to add
    /// to its high part `(value >> base_bits) << base_bits`; empty when the
    /// stream carries no base bits.
    pub base_low: Vec<Coef>,
    /// How many low bits of each base value are still unknown: the value
    /// lies in the `2^u` values from `base_low - 2^(u-1)` on (`u > 0`), of
    /// which `base_low` is the centre; a caller that knows more about the
    /// values (a range) can reconstruct better.
    pub base_unknown: Vec<[u8; 3]>,
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
    /// Every coefficient of the forest's [`Self::nodes`], in node order.
    pub fn coefs(&self) -> Vec<Coef> {
        let mut coefs = vec![[0; 3]; self.nodes];
        for e in &self.nonzero {
            coefs[e.node as usize][e.coord as usize] = e.value;
        }
        coefs
    }

    /// Writes the coordinates that are not zero into `by_sample`, at the
    /// sample of their node (`samples`, as [`qm_tree::ZeroTree::samples`] gives);
    /// the others keep what they hold.
    pub fn scatter(&self, samples: &[u32], by_sample: &mut [Coef]) {
        for e in &self.nonzero {
            by_sample[samples[e.node as usize] as usize][e.coord as usize] = e.value;
        }
    }
}
