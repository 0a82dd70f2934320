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

use qm_lift::Layout;

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
}

impl ZeroTree {
    /// Builds the forest of `layout`'s coefficients (all samples but the
    /// base vertices).
    pub fn new(layout: &Layout) -> Self {
        let big_l = layout.level();
        let samples = layout.sample_count();
        let base = layout.base();
        let mut kids: Vec<[u32; 4]> = vec![[0; 4]; samples];
        let mut kid_count = vec![0u8; samples];
        let mut add = |parent: u32, child: u32| {
            let c = &mut kid_count[parent as usize];
            kids[parent as usize][*c as usize] = child;
            *c += 1;
        };
        let mut roots = Vec::new();
        for f in 0..layout.face_count() {
            let owns = |k: u8| base.owns(f as u32, k);
            for l in 1..=big_l {
                let h = 1usize << (big_l - l);
                let s = 2 * h;
                let m = layout.n() / s;
                let at = |i: usize, j: usize| layout.sample(f, i, j);
                if l == 1 {
                    let c = layout.n() / 2;
                    roots.push((at(c, c), Kind::Face));
                    for k in 0..4u8 {
                        if owns(k) {
                            let (i, j) = qm_lift::side_point(layout.n() as i32, k, c as i32, 0);
                            roots.push((at(i as usize, j as usize), Kind::Edge));
                        }
                    }
                }
                if l == big_l {
                    continue;
                }
                let q = h / 2;
                for b in 0..m {
                    for a in 0..m {
                        let (cx, cy) = (a * s + h, b * s + h);
                        // Face point: its four sub-face centres.
                        let centre = at(cx, cy);
                        for (dx, dy) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
                            add(centre, at(cx - q + 2 * q * dx, cy - q + 2 * q * dy));
                        }
                        // Side midpoints and, per side k, the spoke towards side k + 1.
                        let mids = [(cx, cy - h), (cx + h, cy), (cx, cy + h), (cx - h, cy)];
                        for k in 0..4 {
                            let (nx, ny) = mids[(k + 1) % 4];
                            let spoke = at((cx + nx) / 2, (cy + ny) / 2);
                            add(at(mids[k].0, mids[k].1), spoke);
                        }
                    }
                }
                // Halves of every edge point, once per edge (owner face only
                // for points on base edges).
                for b in 0..=m {
                    if (b == 0 && !owns(0)) || (b == m && !owns(2)) {
                        continue;
                    }
                    for a in 0..m {
                        let (x, y) = (a * s + h, b * s);
                        add(at(x, y), at(x - q, y));
                        add(at(x, y), at(x + q, y));
                    }
                }
                for a in 0..=m {
                    if (a == 0 && !owns(3)) || (a == m && !owns(1)) {
                        continue;
                    }
                    for b in 0..m {
                        let (x, y) = (a * s, b * s + h);
                        add(at(x, y), at(x, y - q));
                        add(at(x, y), at(x, y + q));
                    }
                }
            }
        }

        // Breadth-first order from the roots.
        let count = samples - base.vertex_count() as usize;
        let mut tree = ZeroTree {
            samples: Vec::with_capacity(count),
            levels: Vec::with_capacity(count),
            kinds: Vec::with_capacity(count),
            parents: Vec::with_capacity(count),
            first_child: Vec::with_capacity(count),
            child_counts: Vec::with_capacity(count),
            level_starts: vec![0],
            max_level: big_l,
        };
        // Children are one level finer than their parent and of its kind.
        for &(r, kind) in &roots {
            tree.samples.push(r);
            tree.parents.push(NO_PARENT);
            tree.levels.push(1);
            tree.kinds.push(kind);
        }
        let mut next = 0;
        while next < tree.samples.len() {
            let sample = tree.samples[next] as usize;
            let (level, kind) = (tree.levels[next], tree.kinds[next]);
            tree.first_child.push(tree.samples.len() as u32);
            tree.child_counts.push(kid_count[sample]);
            for &child in &kids[sample][..kid_count[sample] as usize] {
                tree.samples.push(child);
                tree.parents.push(next as u32);
                tree.levels.push(level + 1);
                tree.kinds.push(kind);
            }
            next += 1;
        }
        for l in 1..=big_l as u8 {
            let end = tree
                .levels
                .iter()
                .rposition(|&x| x <= l)
                .map_or(0, |p| p + 1);
            tree.level_starts.push(end);
        }
        tree
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
        let first = self.first_child[k] as usize;
        first..first + self.child_counts[k] as usize
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
        let v = |x: u32, y: u32| y * 4 + x;
        let faces = (0..9u32)
            .filter(|&k| k != 4)
            .map(|k| {
                let (x, y) = (k % 3, k / 3);
                [v(x, y), v(x + 1, y), v(x + 1, y + 1), v(x, y + 1)]
            })
            .collect();
        BaseMesh::new(16, faces).unwrap()
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
