//! The adaptive contexts of the bits ([`Models`]) and what a
//! coefficient's neighbours show ([`Around`]).
//!
//! Significance bits are modelled by node kind, level, the
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

use crate::params::MAX_BASE_BITS;
use crate::range::Context;

/// Level classes of the contexts and of [`BitBudget`](crate::BitBudget).
pub const LEVEL_CLASSES: usize = 4;

/// Coarse level class: 0 = finest level, 1, 2, 3 = three or more above it.
#[inline]
pub(crate) fn level_class(level: u32, max_level: u32) -> usize {
    ((max_level - level) as usize).min(LEVEL_CLASSES - 1)
}

/// Values of the neighbour part of a significance context (significant
/// neighbours 0, 1, 2, 3 or more), of a sign context (no lean, positive,
/// negative) and of a zerotree context (open neighbours 0, 1, 2 or more);
/// always 0 with [`Contexts::Tree`].
pub(crate) const NEIGHBOUR_SIG: usize = 4;
pub(crate) const NEIGHBOUR_SIGN: usize = 3;
pub(crate) const NEIGHBOUR_OPEN: usize = 3;

#[derive(Clone)]
pub(crate) struct Models {
    /// [kind][level class][coord][parent state 3][own sig 3][siblings 3]
    /// [neighbours NEIGHBOUR_SIG]
    pub(crate) significance: Vec<Context>,
    /// [coord][parent sign state 3][neighbours NEIGHBOUR_SIGN]
    pub(crate) sign: Vec<Context>,
    /// [kind][level class][own sig count 4][neighbours NEIGHBOUR_OPEN]
    pub(crate) zerotree: Vec<Context>,
    /// [coord][first refinement?]
    pub(crate) refine: [Context; 6],
    /// Base value bits: [coord][bit]
    pub(crate) base: Vec<Context>,
}

impl Models {
    pub(crate) fn new() -> Self {
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
pub(crate) struct Around(pub(crate) u16);

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
    pub(crate) fn with_significant(self, c: usize, negative: bool) -> Self {
        self.with_one_more(4 * c + 2 * negative as usize)
    }

    /// A neighbour opened its subtree.
    #[inline]
    pub(crate) fn with_open(self) -> Self {
        self.with_one_more(12)
    }

    /// The neighbours significant in coordinate `c`: positive, negative.
    #[inline]
    pub(crate) fn counts(self, c: usize) -> (u16, u16) {
        ((self.0 >> (4 * c)) & 3, (self.0 >> (4 * c + 2)) & 3)
    }

    /// The neighbour part of a significance context of coordinate `c`.
    #[inline]
    pub(crate) fn significance(self, c: usize) -> usize {
        let (positive, negative) = self.counts(c);
        ((positive + negative) as usize).min(NEIGHBOUR_SIG - 1)
    }

    /// The neighbour part of a sign context of coordinate `c`: whether the
    /// significant neighbours' signs lean positive (1) or negative (2).
    #[inline]
    pub(crate) fn sign(self, c: usize) -> usize {
        let (positive, negative) = self.counts(c);
        match positive.cmp(&negative) {
            std::cmp::Ordering::Equal => 0,
            std::cmp::Ordering::Greater => 1,
            std::cmp::Ordering::Less => 2,
        }
    }

    /// The neighbour part of a zerotree context.
    #[inline]
    pub(crate) fn open(self) -> usize {
        ((self.0 >> 12) as usize & 3).min(NEIGHBOUR_OPEN - 1)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

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
}
