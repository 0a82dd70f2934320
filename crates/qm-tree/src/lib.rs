//! Zerotrees over the wavelet coefficients of a semi-regular quad mesh.
//!
//! Paper section 3.3, Figs. 5-6, after Khodakovsky et al.'s primal zerotrees:
//! scaling values live on vertices, but every wavelet coefficient belongs to
//! an edge or a face of the next coarser mesh, and those have a tree
//! structure. In face-local grid units, with `h = 2^(L-l)` the spacing of
//! level `l`:
//!
//! - a **face point** (the centre of a coarse face) is the parent of the four
//!   face points of its four sub-faces, at `(x +- h/2, y +- h/2)`;
//! - an **edge point** (the midpoint of a coarse edge) is the parent of the
//!   two midpoints of its halves, plus one interior edge of the same
//!   orientation from each incident coarse face. A coarse face's four spokes
//!   (centre to side midpoints) are its interior edges; side `k` takes the
//!   spoke towards side `k + 1`, which runs parallel to side `k`. The rule is
//!   invariant under rotating a face's frame, so both faces of a base edge
//!   agree. A boundary edge has one incident face and so three children
//!   (paper Fig. 6).
//!
//! Roots are the level-1 coefficients: one per base edge, one per base face.
//! Each coefficient belongs to exactly one tree. [`ZeroTree`] stores the forest
//! in breadth-first order, so a node's children are contiguous, every parent
//! comes before its children, and levels come one after another: the order
//! the coder scans in.
//!
//! **Partial forests.** The rules above are the same at every scale (a
//! point's children depend on where it lies relative to its spacing `h`,
//! not on `L`), so the first `d` levels of the forest of level `L` are the
//! forest of level `d`, node for node: the same order, kinds, parents and
//! children. A decoder that has read only a prefix of a stream needs just
//! those: [`ZeroTree::partial`] builds them, numbering their samples as a
//! level-`d` layout does ([`ZeroTree::numbering`]), and [`ZeroTree::grow`]
//! adds a level when the stream reaches it. Node indices stay what they
//! were; sample ids move to the finer numbering ([`Numbering::refine`]).
//!
//! **Neighbours.** Besides its tree, a coefficient has neighbours on its own
//! level, which a coder can use as context ([`ZeroTree::neighbours`]): the
//! level-`l` coefficients at the grid offsets `(+-h, 0)` and `(0, +-h)` from
//! it, the nearest ones (those offsets that land on a coefficient of the
//! same level, not on a coarser sample). A face point has four, the edge
//! points of its quad's sides; an edge point two, the face points of the
//! quads on either side of its edge (one on a boundary). They are computed
//! from the sample id when asked for, from the layout's numbering (edge
//! interiors, then face interiors row-major), so the tree keeps no table
//! of them. Wider neighbourhoods made the coder's contexts worse, not
//! better (docs/decisions/010-neighbour-contexts.md). The relation is
//! mutual.

use qm_lift::{BaseMesh, Layout, Numbering, Place};

pub use qm_lift;

/// What a coefficient sits on.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Kind {
    /// The midpoint of a coarser edge.
    Edge,
    /// The centre of a coarser face.
    Face,
}

/// Marker for "no parent".
pub const NO_PARENT: u32 = u32::MAX;

/// The forest of coefficient trees of one layout, in breadth-first order.
#[derive(Clone, Debug)]
pub struct ZeroTree {
    samples: Vec<u32>,
    levels: Vec<u8>,
    kinds: Vec<Kind>,
    parents: Vec<u32>,
    first_child: Vec<u32>,
    child_counts: Vec<u8>,
    level_starts: Vec<usize>,
    /// The finest level of the forest, `L`.
    max_level: u32,
    /// The levels built, `1 ..= depth` (all of them, `L`, unless built by
    /// [`ZeroTree::partial`]); sample ids are in that level's numbering.
    depth: u32,
    /// The base mesh, whose numbering of the samples locates a node's
    /// neighbours (for [`Self::neighbours`]).
    base: BaseMesh,
}

/// The neighbours of a node (at most four), as a slice of sample ids.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Neighbours {
    ids: [u32; 4],
    len: u8,
}

impl std::ops::Deref for Neighbours {
    type Target = [u32];

    fn deref(&self) -> &[u32] {
        &self.ids[..self.len as usize]
    }
}

/// Grid offsets of a coefficient's neighbours, in units of its level's
/// spacing `h` (see the module docs).
const NEIGHBOUR_OFFSETS: [(i32, i32); 4] = [(-1, 0), (1, 0), (0, -1), (0, 1)];

impl ZeroTree {
    /// Builds the forest of `layout`'s coefficients (all samples but the
    /// base vertices) in one breadth-first pass: each node's face-local
    /// grid position gives its children directly (see `children_of`).
    pub fn new(layout: &Layout) -> Self {
        let side = layout.n() + 1;
        Self::build(layout.base(), layout.level(), layout.level(), |f, x, y| {
            layout.face_grid(f as usize)[y * side + x]
        })
    }

    /// The first `depth` levels of the forest of `base` refined `level`
    /// times (see the module docs), their samples numbered as a layout of
    /// level `depth` numbers them; `depth` is taken in `1 ..= level` (0
    /// for a level-0 forest, which has no nodes). Costs time and memory in
    /// proportion to the samples of level `depth`, not `level`.
    pub fn partial(base: &BaseMesh, level: u32, depth: u32) -> Self {
        let depth = depth.clamp(level.min(1), level);
        let numbering = Numbering::new(base, depth);
        Self::build(base, level, depth, |f, x, y| {
            grid_sample(base, numbering, f, x as i32, y as i32)
        })
    }

    /// Adds the next level to a partial forest (nothing once complete):
    /// node indices stay, sample ids move to the finer level's numbering.
    pub fn grow(&mut self) {
        if !self.is_complete() {
            *self = Self::partial(&self.base, self.max_level, self.depth + 1);
        }
    }

    /// The forest of `base` refined `max_level` times, its levels up to
    /// `depth` (grid coordinates and sample ids, `id(face, x, y)`, those of
    /// a level-`depth` layout).
    fn build(
        base: &BaseMesh,
        max_level: u32,
        depth: u32,
        id: impl Fn(u32, usize, usize) -> u32,
    ) -> Self {
        let n = 1usize << depth;
        let count = (base.sample_count(depth) - base.vertex_count() as u64) as usize;
        let mut tree = ZeroTree {
            samples: Vec::new(),
            levels: Vec::new(),
            kinds: Vec::new(),
            parents: Vec::new(),
            first_child: Vec::new(),
            child_counts: Vec::new(),
            level_starts: vec![0],
            max_level,
            depth,
            base: base.clone(),
        };
        if depth == 0 {
            return tree;
        }
        // Every array has one entry per node: filled in place, not pushed.
        tree.samples.reserve_exact(count);
        tree.levels = vec![0; count];
        tree.kinds.reserve_exact(count);
        tree.parents = vec![NO_PARENT; count];
        // Grid position of each node: face, then `x | y << 16`.
        let mut at: Vec<(u32, u32)> = Vec::with_capacity(count);
        let pack = |x: usize, y: usize| (x | y << 16) as u32;
        let c = n / 2;
        for f in 0..base.faces().len() as u32 {
            tree.samples.push(id(f, c, c));
            tree.kinds.push(Kind::Face);
            at.push((f, pack(c, c)));
            for k in 0..4u8 {
                if base.owns(f, k) {
                    let (i, j) = qm_lift::side_point(n as i32, k, c as i32, 0);
                    let (i, j) = (i as usize, j as usize);
                    tree.samples.push(id(f, i, j));
                    tree.kinds.push(Kind::Edge);
                    at.push((f, pack(i, j)));
                }
            }
        }
        let roots = tree.samples.len();
        tree.levels[..roots].fill(1);
        let mut level_end = vec![0usize; depth as usize + 1];
        let mut kids = [(0u32, 0usize, 0usize); 4];
        let mut next = 0;
        while next < tree.samples.len() {
            let level = tree.levels[next];
            level_end[level as usize] = next + 1;
            if level as u32 == depth {
                // The rest is the last level built: no children here.
                level_end[level as usize] = tree.samples.len();
                break;
            }
            let kind = tree.kinds[next];
            let first = tree.samples.len();
            tree.first_child.push(first as u32);
            let (f, xy) = at[next];
            let (x, y) = ((xy & 0xffff) as usize, (xy >> 16) as usize);
            let h = 1 << (depth - level as u32);
            let count = Self::children_of(base, n, kind, f, x, y, h, &mut kids);
            tree.child_counts.push(count as u8);
            tree.parents[first..first + count].fill(next as u32);
            tree.levels[first..first + count].fill(level + 1);
            for &(g, x, y) in &kids[..count] {
                tree.samples.push(id(g, x, y));
                tree.kinds.push(kind);
                // The last level's nodes have no children to find.
                if level as u32 + 1 < depth {
                    at.push((g, pack(x, y)));
                }
            }
            next += 1;
        }
        // Levels never decrease along the breadth-first order.
        let mut end = 0;
        for &e in &level_end[1..] {
            end = end.max(e);
            tree.level_starts.push(end);
        }
        tree
    }

    /// The neighbours of node `k` on its own level, as sample ids (see the
    /// module docs). The relation is mutual: `k`'s sample is among the
    /// neighbours of each of them.
    #[inline]
    pub fn neighbours(&self, k: usize) -> Neighbours {
        let numbering = self.numbering();
        let h = 1u32 << (self.depth - self.levels[k] as u32);
        let n = numbering.n();
        let mut found = Neighbours::default();
        let mut push = |id: u32| {
            found.ids[found.len as usize] = id;
            found.len += 1;
        };
        match numbering.place(self.samples[k]) {
            Place::Face { face, i: x, j: y } => {
                // A level-`l` coordinate is an odd multiple of `h`, so every
                // offset stays within the face, on a side at worst; those
                // whose coordinates are both multiples of `2h` land on a
                // coarser sample. Away from the sides, the two tests come
                // down to which coordinate is odd, a shortcut that pays on
                // a decode (docs/decisions/010-neighbour-contexts.md).
                if x > h && x + h < n && y > h && y + h < n {
                    if x & h != 0 {
                        push(numbering.face_sample(face, x, y - h));
                        push(numbering.face_sample(face, x, y + h));
                    }
                    if y & h != 0 {
                        push(numbering.face_sample(face, x - h, y));
                        push(numbering.face_sample(face, x + h, y));
                    }
                } else {
                    let (x, y, h) = (x as i32, y as i32, h as i32);
                    for (dx, dy) in NEIGHBOUR_OFFSETS {
                        let (i, j) = (x + dx * h, y + dy * h);
                        if (i | j) & h != 0 {
                            push(self.sample_at(face, i, j));
                        }
                    }
                }
            }
            Place::Edge { edge, along } => {
                // The face points at depth `h` in the faces on either side.
                let edge = &self.base.edges()[edge as usize];
                for (side, t) in [(edge.sides[0], along), (edge.sides[1], n - along)] {
                    if side.exists() {
                        let (i, j) = qm_lift::side_point(n as i32, side.side, t as i32, h as i32);
                        push(self.sample_at(side.face, i, j));
                    }
                }
            }
            Place::Vertex(_) => {}
        }
        found
    }

    /// How the samples are numbered: as a layout of the levels built
    /// numbers them (the tree's own layout's numbering when complete).
    #[inline]
    pub fn numbering(&self) -> Numbering {
        Numbering::new(&self.base, self.depth)
    }

    /// The id of point `(i, j)` of face `f`, inside it or on a side (not a
    /// corner).
    fn sample_at(&self, f: u32, i: i32, j: i32) -> u32 {
        grid_sample(&self.base, self.numbering(), f, i, j)
    }

    /// Children of the level-`l` node at `(x, y)` of face `f`, `h = 2^(L-l)`,
    /// as `(face, x, y)`, in the order the module docs define: a face point's
    /// four sub-face centres; an edge point's spokes from its incident coarse
    /// faces (the one below or left first, then across a base edge by face
    /// index) with its two halves after the spoke of the face that owns it.
    #[inline]
    #[allow(clippy::too_many_arguments)]
    fn children_of(
        base: &BaseMesh,
        n: usize,
        kind: Kind,
        f: u32,
        x: usize,
        y: usize,
        h: usize,
        kids: &mut [(u32, usize, usize); 4],
    ) -> usize {
        let q = h / 2;
        if kind == Kind::Face {
            *kids = [
                (f, x - q, y - q),
                (f, x + q, y - q),
                (f, x - q, y + q),
                (f, x + q, y + q),
            ];
            return 4;
        }
        let horizontal = x & h != 0;
        let side = match (horizontal, x, y) {
            (true, _, 0) => 0u8,
            (true, _, y) if y == n => 2,
            (false, 0, _) => 3,
            (false, x, _) if x == n => 1,
            (true, _, _) => {
                *kids = [
                    (f, x - q, y - h),
                    (f, x + q, y + h),
                    (f, x - q, y),
                    (f, x + q, y),
                ];
                return 4;
            }
            (false, _, _) => {
                *kids = [
                    (f, x - h, y + q),
                    (f, x + h, y - q),
                    (f, x, y - q),
                    (f, x, y + q),
                ];
                return 4;
            }
        };
        // On base edge `side` of `f`: a spoke from each incident face, by face
        // index, and the halves from the owner, right after its spoke.
        let spoke = |g: u32, k: u8, x: usize, y: usize| match k {
            0 => (g, x + q, y + h),
            1 => (g, x - h, y + q),
            2 => (g, x - q, y - h),
            _ => (g, x + h, y - q),
        };
        let halves = |g: u32, k: u8, x: usize, y: usize| {
            if k & 1 == 0 {
                [(g, x - q, y), (g, x + q, y)]
            } else {
                [(g, x, y - q), (g, x, y + q)]
            }
        };
        let mut incident = [(f, side, x, y); 2];
        let mut faces = 1;
        let other = base.across(f, side);
        if other.exists() {
            let (t, _) = qm_lift::side_coords(n as i32, side, x as i32, y as i32);
            let (gx, gy) = qm_lift::side_point(n as i32, other.side, n as i32 - t, 0);
            incident[1] = (other.face, other.side, gx as usize, gy as usize);
            if other.face < f {
                incident.swap(0, 1);
            }
            faces = 2;
        }
        let mut count = 0;
        for &(g, k, x, y) in &incident[..faces] {
            kids[count] = spoke(g, k, x, y);
            count += 1;
            if base.owns(g, k) {
                let [a, b] = halves(g, k, x, y);
                kids[count] = a;
                kids[count + 1] = b;
                count += 2;
            }
        }
        count
    }

    /// Number of coefficients (nodes) built.
    pub fn len(&self) -> usize {
        self.samples.len()
    }

    /// Whether there are no coefficients (a level-0 layout).
    pub fn is_empty(&self) -> bool {
        self.samples.is_empty()
    }

    /// The number of trees: nodes `0 .. roots()` are the roots.
    pub fn roots(&self) -> usize {
        self.level_starts.get(1).copied().unwrap_or(0)
    }

    /// Finest level `L` of the forest, built or not.
    pub fn max_level(&self) -> u32 {
        self.max_level
    }

    /// The levels built: nodes of levels `1 ..= depth()` are there
    /// ([`Self::max_level`] unless the forest is [`Self::partial`]).
    pub fn depth(&self) -> u32 {
        self.depth
    }

    /// Whether every level is built.
    pub fn is_complete(&self) -> bool {
        self.depth == self.max_level
    }

    /// Whether node `k` has children in the forest (built or not): every
    /// node above the finest level has.
    #[inline]
    pub fn has_children(&self, k: usize) -> bool {
        (self.levels[k] as u32) < self.max_level
    }

    /// Number of base vertices: the level-0 values, which are not nodes
    /// (sample ids `0..base_vertices`).
    pub fn base_vertices(&self) -> usize {
        self.base.vertex_count() as usize
    }

    /// Node range of level `l` (`1 ..= depth()`).
    pub fn level_range(&self, l: u32) -> std::ops::Range<usize> {
        self.level_starts[l as usize - 1]..self.level_starts[l as usize]
    }

    /// Sample id of each node, in [`Self::numbering`].
    pub fn samples(&self) -> &[u32] {
        &self.samples
    }

    /// Level (`1 ..= depth()`) of each node.
    pub fn levels(&self) -> &[u8] {
        &self.levels
    }

    /// Kind of each node.
    pub fn kinds(&self) -> &[Kind] {
        &self.kinds
    }

    /// Parent of each node, [`NO_PARENT`] for roots.
    pub fn parents(&self) -> &[u32] {
        &self.parents
    }

    /// Children of node `k`: a contiguous node range; empty on the finest
    /// level, and on the last level built of a partial forest
    /// ([`Self::has_children`] tells them apart).
    #[inline]
    pub fn children(&self, k: usize) -> std::ops::Range<usize> {
        match self.first_child.get(k) {
            Some(&first) => first as usize..first as usize + self.child_counts[k] as usize,
            // The last level built.
            None => self.samples.len()..self.samples.len(),
        }
    }

    /// Gathers per-sample values into node order.
    pub fn gather<T: Copy>(&self, by_sample: &[T]) -> Vec<T> {
        self.samples
            .iter()
            .map(|&s| by_sample[s as usize])
            .collect()
    }

    /// Scatters node-ordered values back to their samples.
    pub fn scatter<T: Copy>(&self, by_node: &[T], by_sample: &mut [T]) {
        for (&s, &v) in self.samples.iter().zip(by_node) {
            by_sample[s as usize] = v;
        }
    }
}

/// The id, in `numbering`, of point `(i, j)` of face `f`'s grid, inside it
/// or on a side (not a corner).
#[inline]
fn grid_sample(base: &BaseMesh, numbering: Numbering, f: u32, i: i32, j: i32) -> u32 {
    let n = numbering.n() as i32;
    if (1..n).contains(&i) && (1..n).contains(&j) {
        return numbering.face_sample(f, i as u32, j as u32);
    }
    let side = match (i, j) {
        (_, 0) => 0u8,
        (i, _) if i == n => 1,
        (_, j) if j == n => 2,
        _ => 3,
    };
    let (t, _) = qm_lift::side_coords(n, side, i, j);
    numbering.side_sample(base, f, side, t as u32)
}

#[cfg(test)]
mod tests {
    use super::*;
    use qm_lift::BaseMesh;
    use qm_lift::synthetic::cube;

    fn holed_grid() -> BaseMesh {
        BaseMesh::new(16, qm_shapes::holed_grid().1).unwrap()
    }

    /// Every coefficient is in exactly one tree, parents precede children,
    /// and children are one level finer and of the parent's kind.
    fn check_forest(layout: &Layout) -> ZeroTree {
        let tree = ZeroTree::new(layout);
        let v = layout.base().vertex_count() as usize;
        assert_eq!(tree.len(), layout.sample_count() - v);
        let mut seen = vec![0u32; layout.sample_count()];
        for &s in tree.samples() {
            seen[s as usize] += 1;
        }
        assert!(
            seen[..v].iter().all(|&c| c == 0),
            "base vertices are not coefficients"
        );
        assert!(
            seen[v..].iter().all(|&c| c == 1),
            "each coefficient exactly once"
        );
        // Level and kind from grid coordinates: a level-l point has spacing
        // h = 2^(L-l), and a face point has both coordinates odd multiples of h.
        let big_l = layout.level();
        for f in 0..layout.face_count() {
            for j in 0..=layout.n() {
                for i in 0..=layout.n() {
                    let s = layout.sample(f, i, j) as usize;
                    let Some(k) = tree.samples().iter().position(|&x| x as usize == s) else {
                        continue;
                    };
                    let tz = |x: usize| if x == 0 { big_l } else { x.trailing_zeros() };
                    let level = big_l - tz(i).min(tz(j));
                    assert_eq!(tree.levels()[k] as u32, level, "sample {s}");
                    let odd = |x: usize| (x >> (big_l - level)) & 1 == 1;
                    let kind = if odd(i) && odd(j) {
                        Kind::Face
                    } else {
                        Kind::Edge
                    };
                    assert_eq!(tree.kinds()[k], kind, "sample {s}");
                }
            }
        }
        for k in 0..tree.len() {
            for c in tree.children(k) {
                assert_eq!(tree.parents()[c] as usize, k);
                assert_eq!(tree.levels()[c], tree.levels()[k] + 1);
                assert_eq!(tree.kinds()[c], tree.kinds()[k]);
            }
        }
        assert_eq!(
            tree.roots(),
            layout.base().edges().len() + layout.face_count()
        );
        tree
    }

    #[test]
    fn closed_cube_counts_per_level() {
        let layout = Layout::new(cube(), 4).unwrap();
        let tree = check_forest(&layout);
        for l in 1..=4u32 {
            let range = tree.level_range(l);
            // Level l: one face point per level-(l-1) face, one edge point per edge.
            let faces = 6 * 4usize.pow(l - 1);
            let edges = 2 * faces;
            assert_eq!(range.len(), faces + edges, "level {l}");
            assert!(range.clone().all(|k| tree.levels()[k] as u32 == l));
            let internal = if l < 4 { 4 } else { 0 };
            assert!(range.clone().all(|k| tree.children(k).len() == internal));
        }
    }

    #[test]
    fn boundary_edges_have_three_children() {
        let layout = Layout::new(holed_grid(), 3).unwrap();
        let tree = check_forest(&layout);
        let boundary_roots = (0..tree.roots())
            .filter(|&k| tree.kinds()[k] == Kind::Edge && tree.children(k).len() == 3)
            .count();
        assert_eq!(boundary_roots, layout.base().boundary_edge_count());
    }

    /// The neighbours found by walking the grid: the same-level points at
    /// `(+-h, 0)` and `(0, +-h)`, across face sides by the layout's own
    /// lookup, as node indices.
    fn walked_neighbours(layout: &Layout, tree: &ZeroTree, k: usize) -> Vec<usize> {
        let s = tree.samples()[k];
        let node = |s: u32| tree.samples().iter().position(|&x| x == s);
        let n = layout.n() as i32;
        let h = 1i32 << (tree.max_level() - tree.levels()[k] as u32);
        let mut found = Vec::new();
        for f in 0..layout.face_count() {
            for j in 0..=n {
                for i in 0..=n {
                    if layout.sample(f, i as usize, j as usize) != s {
                        continue;
                    }
                    for (dx, dy) in NEIGHBOUR_OFFSETS {
                        let Some(t) = layout.sample_beyond(f, i + dx * h, j + dy * h) else {
                            continue;
                        };
                        match node(t) {
                            Some(m)
                                if tree.levels()[m] == tree.levels()[k] && !found.contains(&m) =>
                            {
                                found.push(m);
                            }
                            _ => {}
                        }
                    }
                }
            }
        }
        found.sort();
        found
    }

    /// The neighbours computed from the sample numbering are those found by
    /// walking the grid, and on a closed cube every face point has its 4
    /// edge points and every edge point the 2 face points beside it, across
    /// base edges and around the irregular corners too; the relation is
    /// mutual. On the holed grid an edge point on the boundary has one.
    #[test]
    fn neighbours_are_the_nearest_points_of_the_level() {
        for (base, level) in [(cube(), 1), (cube(), 2), (cube(), 4), (holed_grid(), 3)] {
            let layout = Layout::new(base, level).unwrap();
            let tree = ZeroTree::new(&layout);
            let mut lonely = 0;
            for k in 0..tree.len() {
                let nb = tree.neighbours(k);
                let node_of = |s: u32| tree.samples().iter().position(|&x| x == s).unwrap();
                let mut nodes: Vec<usize> = nb.iter().map(|&s| node_of(s)).collect();
                for (a, &m) in nodes.iter().enumerate() {
                    assert_eq!(tree.levels()[m], tree.levels()[k]);
                    assert_ne!(tree.kinds()[m], tree.kinds()[k]);
                    assert!(!nodes[..a].contains(&m), "node {k} lists {m} twice");
                    assert!(
                        tree.neighbours(m).contains(&tree.samples()[k]),
                        "{k} -> {m}"
                    );
                }
                nodes.sort();
                assert_eq!(nodes, walked_neighbours(&layout, &tree, k), "node {k}");
                let want = match tree.kinds()[k] {
                    Kind::Face => 4,
                    Kind::Edge => 2,
                };
                if layout.base().boundary_edge_count() == 0 {
                    assert_eq!(nb.len(), want, "node {k}");
                } else if nb.len() < want {
                    assert_eq!((tree.kinds()[k], nb.len()), (Kind::Edge, 1));
                    lonely += 1;
                }
            }
            // Each boundary base edge has 2^(l-1) edge points at level l.
            let per_edge: usize = (1..=level).map(|l| 1usize << (l - 1)).sum();
            assert_eq!(lonely, layout.base().boundary_edge_count() * per_edge);
        }
    }

    /// The first `d` levels of a forest, built alone and grown a level at a
    /// time, are the complete forest's first `d` levels node for node: the
    /// same levels, kinds, parents, children and neighbours, at the same
    /// points (their ids refined to the complete numbering).
    #[test]
    fn partial_forests_are_the_first_levels_of_the_complete_one() {
        for (base, level) in [(cube(), 4), (holed_grid(), 3)] {
            let complete = ZeroTree::new(&Layout::new(base.clone(), level).unwrap());
            let mut grown = ZeroTree::partial(&base, level, 0);
            assert_eq!(grown.depth(), 1, "at least the roots");
            for depth in 1..=level {
                let tree = ZeroTree::partial(&base, level, depth);
                assert_eq!(tree.len(), complete.level_range(depth).end, "depth {depth}");
                assert_eq!(tree.roots(), complete.roots());
                assert_eq!(tree.is_complete(), depth == level);
                let fine = |s: u32| tree.numbering().refine(s, complete.numbering());
                for k in 0..tree.len() {
                    assert_eq!(tree.levels()[k], complete.levels()[k], "node {k}");
                    assert_eq!(tree.kinds()[k], complete.kinds()[k], "node {k}");
                    assert_eq!(tree.parents()[k], complete.parents()[k], "node {k}");
                    assert_eq!(fine(tree.samples()[k]), complete.samples()[k], "node {k}");
                    assert_eq!(tree.has_children(k), complete.has_children(k));
                    if (tree.levels()[k] as u32) < depth {
                        assert_eq!(tree.children(k), complete.children(k), "node {k}");
                    } else {
                        assert!(tree.children(k).is_empty(), "node {k}: not built");
                    }
                    let near: Vec<u32> = tree.neighbours(k).iter().map(|&s| fine(s)).collect();
                    assert_eq!(near, &complete.neighbours(k)[..], "node {k}");
                }
                assert_eq!(grown.samples(), tree.samples(), "grown to {depth}");
                assert_eq!(grown.parents(), tree.parents(), "grown to {depth}");
                grown.grow();
            }
            assert_eq!(grown.depth(), level, "a complete forest stops growing");
        }
    }

    #[test]
    fn gather_scatter_round_trip() {
        let layout = Layout::new(cube(), 2).unwrap();
        let tree = ZeroTree::new(&layout);
        let values: Vec<u32> = (0..layout.sample_count() as u32).collect();
        let nodes = tree.gather(&values);
        let mut back = vec![u32::MAX; values.len()];
        tree.scatter(&nodes, &mut back);
        assert_eq!(&back[8..], &values[8..]);
    }
}
