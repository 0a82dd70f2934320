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
    max_level: u32,
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
        let big_l = layout.level();
        let samples = layout.sample_count();
        let base = layout.base();
        let n = layout.n();
        let count = samples - base.vertex_count() as usize;
        if big_l == 0 {
            return ZeroTree {
                samples: Vec::new(),
                levels: Vec::new(),
                kinds: Vec::new(),
                parents: Vec::new(),
                first_child: Vec::new(),
                child_counts: Vec::new(),
                level_starts: vec![0],
                max_level: big_l,
                base: base.clone(),
            };
        }
        // Every array has one entry per node: filled in place, not pushed.
        let mut tree = ZeroTree {
            samples: Vec::with_capacity(count),
            levels: vec![0; count],
            kinds: Vec::with_capacity(count),
            parents: vec![NO_PARENT; count],
            // Only nodes above the finest level have children: these two
            // arrays stop there (breadth-first, the finest level comes last).
            first_child: Vec::new(),
            child_counts: Vec::new(),
            level_starts: vec![0],
            max_level: big_l,
            base: base.clone(),
        };
        // Grid position of each node: face, then `x | y << 16`.
        let mut at: Vec<(u32, u32)> = Vec::with_capacity(count);
        let pack = |x: usize, y: usize| (x | y << 16) as u32;
        let c = n / 2;
        for f in 0..layout.face_count() {
            let grid = layout.face_grid(f);
            tree.samples.push(grid[c * (n + 1) + c]);
            tree.kinds.push(Kind::Face);
            at.push((f as u32, pack(c, c)));
            for k in 0..4u8 {
                if base.owns(f as u32, k) {
                    let (i, j) = qm_lift::side_point(n as i32, k, c as i32, 0);
                    let (i, j) = (i as usize, j as usize);
                    tree.samples.push(grid[j * (n + 1) + i]);
                    tree.kinds.push(Kind::Edge);
                    at.push((f as u32, pack(i, j)));
                }
            }
        }
        let roots = tree.samples.len();
        tree.levels[..roots].fill(1);
        let mut level_end = vec![0usize; big_l as usize + 1];
        let mut kids = [(0u32, 0usize, 0usize); 4];
        let mut next = 0;
        while next < tree.samples.len() {
            let level = tree.levels[next];
            level_end[level as usize] = next + 1;
            if level as u32 == big_l {
                // The rest is the finest level: no children.
                level_end[level as usize] = tree.samples.len();
                break;
            }
            let kind = tree.kinds[next];
            let first = tree.samples.len();
            tree.first_child.push(first as u32);
            let (f, xy) = at[next];
            let (x, y) = ((xy & 0xffff) as usize, (xy >> 16) as usize);
            let h = 1 << (big_l - level as u32);
            let count = Self::children_of(layout, kind, f, x, y, h, &mut kids);
            tree.child_counts.push(count as u8);
            tree.parents[first..first + count].fill(next as u32);
            tree.levels[first..first + count].fill(level + 1);
            for &(g, x, y) in &kids[..count] {
                tree.samples
                    .push(layout.face_grid(g as usize)[y * (n + 1) + x]);
                tree.kinds.push(kind);
                // The finest nodes have no children to find.
                if level as u32 + 1 < big_l {
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
        let h = 1u32 << (self.max_level - self.levels[k] as u32);
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

    /// How the layout numbers the samples.
    #[inline]
    fn numbering(&self) -> Numbering {
        Numbering::new(&self.base, self.max_level)
    }

    /// The id of point `(i, j)` of face `f`, inside it or on a side (not a
    /// corner).
    fn sample_at(&self, f: u32, i: i32, j: i32) -> u32 {
        let numbering = self.numbering();
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
        numbering.side_sample(&self.base, f, side, t as u32)
    }

    /// Children of the level-`l` node at `(x, y)` of face `f`, `h = 2^(L-l)`,
    /// as `(face, x, y)`, in the order the module docs define: a face point's
    /// four sub-face centres; an edge point's spokes from its incident coarse
    /// faces (the one below or left first, then across a base edge by face
    /// index) with its two halves after the spoke of the face that owns it.
    #[inline]
    fn children_of(
        layout: &Layout,
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
        let n = layout.n();
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
        let base = layout.base();
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

    /// Number of coefficients (nodes).
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

    /// Finest level `L`.
    pub fn max_level(&self) -> u32 {
        self.max_level
    }

    /// Number of base vertices: the level-0 values, which are not nodes
    /// (sample ids `0..base_vertices`).
    pub fn base_vertices(&self) -> usize {
        self.base.vertex_count() as usize
    }

    /// Node range of level `l` (1 ..= L).
    pub fn level_range(&self, l: u32) -> std::ops::Range<usize> {
        self.level_starts[l as usize - 1]..self.level_starts[l as usize]
    }

    /// Sample id of each node.
    pub fn samples(&self) -> &[u32] {
        &self.samples
    }

    /// Level (1 ..= L) of each node.
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

    /// Children of node `k`: a contiguous node range.
    #[inline]
    pub fn children(&self, k: usize) -> std::ops::Range<usize> {
        match self.first_child.get(k) {
            Some(&first) => first as usize..first as usize + self.child_counts[k] as usize,
            // The finest level.
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
