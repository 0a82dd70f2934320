//! Where the bits of a stream go ([`bit_budget`]): the encoder run with a
//! coder that also adds up `-log2 p` of every symbol under its adaptive
//! context at coding time, by symbol class ([`BitBudget`], [`Cost`]).

use qm_tree::ZeroTree;

use crate::coder::{Coder, Sym};
use crate::contexts::LEVEL_CLASSES;
use crate::params::{BaseBits, Coef, Contexts, Weighting};
use crate::passes::{code_passes, plan};
use crate::range::{BitWriter, Context, Truncated};

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

/// Encodes like [`encode`](crate::encode) and returns the bit budget after each pass (the
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
        budgets.push(t.budget.clone());
        true
    });
    budgets
}
