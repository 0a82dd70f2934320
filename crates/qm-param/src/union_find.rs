//! Disjoint sets of `0..n`, each named by its smallest member.

/// A union-find forest over `0..n` with path halving; a set's root is
/// always its smallest member, so roots do not depend on the order of the
/// unions.
pub(crate) struct UnionFind(Vec<u32>);

impl UnionFind {
    /// `n` singletons.
    pub(crate) fn new(n: usize) -> Self {
        UnionFind((0..n as u32).collect())
    }

    /// Members (`n`).
    pub(crate) fn len(&self) -> usize {
        self.0.len()
    }

    /// The smallest member of `x`'s set.
    pub(crate) fn find(&mut self, mut x: u32) -> u32 {
        while self.0[x as usize] != x {
            let up = self.0[self.0[x as usize] as usize];
            self.0[x as usize] = up;
            x = up;
        }
        x
    }

    /// Joins the sets of `a` and `b`.
    pub(crate) fn union(&mut self, a: u32, b: u32) {
        let (a, b) = (self.find(a), self.find(b));
        if a != b {
            self.0[a.max(b) as usize] = a.min(b);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Roots are the sets' smallest members, whatever the order of unions.
    #[test]
    fn roots_are_smallest_members() {
        let mut sets = UnionFind::new(8);
        for (a, b) in [(7, 5), (5, 6), (3, 1), (6, 3), (0, 2)] {
            sets.union(a, b);
        }
        let roots: Vec<u32> = (0..8).map(|x| sets.find(x)).collect();
        assert_eq!(roots, [0, 1, 0, 1, 4, 1, 1, 1]);
    }
}
