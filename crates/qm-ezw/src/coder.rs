//! The scan's view of the coding: a [`Coder`] codes or decodes one bit in
//! its context (the encoder's [`BitWriter`], the decoder's [`BitReader`],
//! or the bit counter of [`crate::budget`]), and an [`Oracle`] tells the
//! true data behind the bits ([`Truth`] on the encoder's side, [`Unknown`]
//! on the decoder's, which reads the bits instead).

use crate::params::Coef;
use crate::range::{BitReader, BitWriter, Context, Truncated};

/// Encoder or decoder, seen from the scan. `sym` says what the bit is (a
/// [`BitBudget`] slot); only the measuring coder looks at it.
pub(crate) trait Coder {
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
pub(crate) enum Sym {
    Significance(usize, usize),
    Sign(usize),
    Zerotree(usize),
    Refinement(usize, usize),
    Base,
}

/// The true data behind the bits: the encoder has it, the decoder does not.
pub(crate) trait Oracle {
    fn magnitude(&self, node: usize, coord: usize) -> u32;
    fn negative(&self, node: usize, coord: usize) -> bool;
    fn below(&self, node: usize) -> i32;
    /// Bit `bit` of coordinate `index % 3` of base value `index / 3`.
    fn base_bit(&self, index: usize, bit: u32) -> bool;
}

pub(crate) struct Truth<'a> {
    pub(crate) coefs: &'a [Coef],
    pub(crate) below: &'a [i32],
    pub(crate) base: &'a [Coef],
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

pub(crate) struct Unknown;

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
