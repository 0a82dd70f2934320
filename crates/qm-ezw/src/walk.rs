//! One pass of the scan over the trees ([`State::pass`]), the same on both
//! sides: the coder's and the decoder's knowledge of every node (which
//! coordinates are significant, their signs, the bits known of their
//! magnitudes, which subtrees are open), and the reconstruction from it.
//!
//! A pass (one per plane, from the top) goes through the levels coarse to
//! fine; at each level it codes first the *subordinate* bits, then the
//! *dominant* ones:
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
//! **Growing trees.** A pass reaches level `l + 1` only through a level-`l`
//! subtree that is open, and a subtree opens only when a coordinate below
//! it is significant: a zerotree root covers all its descendants, so the
//! finer levels of a short prefix are never visited. The decoder therefore
//! walks a [`ZeroTree::partial`] forest and grows it ([`Trees::Growing`])
//! when a pass first opens a subtree on its last level built; the nodes,
//! their order and every context are those of the complete forest, so the
//! bits are the same. The coder has every coefficient and walks the
//! complete forest ([`Trees::Whole`]).
//!
//! **Reconstruction.** An unresolved coefficient is put at the centre of its
//! uncertainty interval, so more bits never make the expected error larger
//! (the paper's rising error came from doing otherwise).

use qm_tree::{NO_PARENT, Neighbours, ZeroTree};

use crate::coder::{Coder, Oracle, Sym};
use crate::contexts::{
    Around, LEVEL_CLASSES, Models, NEIGHBOUR_OPEN, NEIGHBOUR_SIG, NEIGHBOUR_SIGN, level_class,
};
use crate::output::{Nonzero, Progress};
use crate::params::{Coef, Contexts, MAX_BASE_BITS, StreamParams};
use crate::range::Truncated;

/// The forest a pass walks: complete and borrowed (coding), or growing
/// as the pass reaches levels not built yet (decoding).
pub(crate) enum Trees<'a> {
    Whole(&'a ZeroTree),
    Growing(&'a mut ZeroTree),
}

impl Trees<'_> {
    #[inline]
    fn get(&self) -> &ZeroTree {
        match self {
            Trees::Whole(tree) => tree,
            Trees::Growing(tree) => tree,
        }
    }

    /// Adds a level: a pass asks only for the children of nodes above the
    /// finest level, which a whole forest has built.
    fn grow(&mut self) {
        match self {
            Trees::Whole(_) => unreachable!("a whole forest has every level"),
            Trees::Growing(tree) => tree.grow(),
        }
    }
}

/// What coder and decoder both know about each node.
#[derive(Clone)]
pub(crate) struct State {
    pub(crate) params: StreamParams,
    /// The forest's finest level `L` (the weights' and contexts' level).
    pub(crate) max_level: u32,
    /// The levels of the forest the node arrays are sized for, and the
    /// numbering of [`Self::around`] (see [`Self::fit`]).
    pub(crate) depth: u32,
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
    pub(crate) progress: Progress,
}

impl State {
    pub(crate) fn new(tree: &ZeroTree, params: StreamParams) -> Self {
        let n = tree.len();
        let base_values = if params.base_bits > 0 {
            (params.base_values as usize).min(tree.base_vertices())
        } else {
            0
        };
        State {
            params,
            max_level: tree.max_level(),
            depth: tree.depth(),
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

    /// Makes the node arrays cover `tree`, a forest grown from the one the
    /// state was made for (the same nodes first): new nodes know nothing
    /// yet, and what the neighbours show moves to the finer numbering.
    pub(crate) fn fit(&mut self, tree: &ZeroTree) {
        let n = tree.len();
        if self.sig.len() < n {
            self.sig.resize(n, 0);
            self.neg.resize(n, 0);
            self.open.resize(n, false);
        }
        if self.depth < tree.depth() {
            if !self.around.is_empty() {
                let to = tree.numbering();
                let from = to.at_level(self.depth);
                let mut around = vec![0; tree.base_vertices() + n];
                for (s, &a) in self.around.iter().enumerate() {
                    if a != 0 {
                        around[from.refine(s as u32, to) as usize] = a;
                    }
                }
                self.around = around;
            }
            self.depth = tree.depth();
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
    pub(crate) fn pass<C: Coder, O: Oracle>(
        &mut self,
        trees: &mut Trees,
        pass: u32,
        coder: &mut C,
        oracle: &mut O,
    ) -> Result<(), Truncated> {
        self.fit(trees.get());
        let plane = self.params.planes as i32 - 1 - pass as i32;
        self.progress.base = false;
        self.progress.levels = 0;
        self.progress.fresh.clear();
        self.progress.fresh.resize(self.max_level as usize, [0; 3]);
        self.base_pass(plane, coder, oracle)?;
        self.progress.base = true;
        let before: Vec<usize> = self.refine_lists.iter().map(Vec::len).collect();
        self.dominant(trees, plane, &before, coder, oracle)?;
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
        trees: &mut Trees,
        plane: i32,
        refine_before: &[usize],
        coder: &mut C,
        oracle: &mut O,
    ) -> Result<(), Truncated> {
        let mut frontier = std::mem::take(&mut self.frontier);
        let mut next = std::mem::take(&mut self.next);
        frontier.clear();
        frontier.extend(0..trees.get().roots() as u32);
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
            let tree = trees.get();
            let (levels, kinds, parents) = (tree.levels(), tree.kinds(), tree.parents());
            // Whether the children of this level are built; if not, `next`
            // gathers the open nodes, whose children come once they are.
            let built = tree.depth() > depth;
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
                if !tree.has_children(k) {
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
                if built {
                    next.extend(tree.children(k).map(|c| c as u32));
                } else {
                    next.push(k as u32);
                }
            }
            if !built && !next.is_empty() {
                trees.grow();
                let tree = trees.get();
                self.fit(tree);
                let open = next.len();
                for i in 0..open {
                    next.extend(tree.children(next[i] as usize).map(|c| c as u32));
                }
                next.drain(..open);
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
    pub(crate) fn reconstruct(&self) -> Vec<Nonzero> {
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

    /// How many low bits of every base value are unknown.
    pub(crate) fn base_unknown(&self) -> Vec<[u8; 3]> {
        (self.base_low.chunks_exact(3))
            .map(|c| [c[0], c[1], c[2]])
            .collect()
    }

    /// Centre of every base value's low bits (zeros without base bits).
    pub(crate) fn reconstruct_base(&self) -> Vec<Coef> {
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
