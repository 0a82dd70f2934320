//! The open edges of a split base's triangles as they are coded
//! ([`OpenEdges`]): edges used by one triangle so far, listed most recent
//! first, each named by its place in that list.
//!
//! Versions 3 to 5 keep the 256 most recent edges; version 6 keeps them
//! all, since a traversal's front on a faceted or long mesh grows past any
//! such bound, and a triangle beyond it costs a vertex named by its
//! distance back, or three. Places are counted by a Fenwick tree over the
//! edges' insertion stamps, so an operation costs a logarithm (and, in
//! versions 3 to 5, a search of a vertex's live edges, at most 256), not
//! the list's length.

use std::collections::HashMap;

/// Directed open edges, most recent first.
pub(super) struct OpenEdges {
    /// Most edges kept (the oldest are dropped), or all.
    limit: Option<usize>,
    /// Each stamp's edge, in order of opening.
    edges: Vec<(u32, u32)>,
    alive: Vec<bool>,
    /// Live stamps per stamp, summed over Fenwick ranges (1-based).
    tree: Vec<u32>,
    len: usize,
    /// No live stamp is below this one.
    oldest: usize,
    /// Live stamps of each directed edge, oldest first (a non-manifold base
    /// may open the same edge twice).
    by_edge: HashMap<(u32, u32), Vec<u32>>,
    /// Stamps of the edges from and into each vertex, dead ones dropped
    /// as they are met.
    from: HashMap<u32, Vec<u32>>,
    into: HashMap<u32, Vec<u32>>,
    /// Stamps [`Self::latest`] has looked at, for a test of its cost.
    #[cfg(test)]
    looked: usize,
}

impl OpenEdges {
    pub(super) fn new(limit: Option<usize>) -> Self {
        OpenEdges {
            limit,
            edges: Vec::new(),
            alive: Vec::new(),
            tree: vec![0; 65],
            len: 0,
            oldest: 0,
            by_edge: HashMap::new(),
            from: HashMap::new(),
            into: HashMap::new(),
            #[cfg(test)]
            looked: 0,
        }
    }

    pub(super) fn len(&self) -> usize {
        self.len
    }

    /// Live stamps up to `stamp`, inclusive.
    fn up_to(&self, stamp: usize) -> usize {
        let mut i = stamp + 1;
        let mut sum = 0;
        while i > 0 {
            sum += self.tree[i] as usize;
            i &= i - 1;
        }
        sum
    }

    fn add(&mut self, stamp: usize, up: bool) {
        let mut i = stamp + 1;
        while i < self.tree.len() {
            self.tree[i] = if up {
                self.tree[i] + 1
            } else {
                self.tree[i] - 1
            };
            i += i & i.wrapping_neg();
        }
    }

    /// The place of `stamp`: how many live edges are more recent.
    fn place_of(&self, stamp: u32) -> usize {
        self.len - self.up_to(stamp as usize)
    }

    /// The live stamp at `place`.
    fn stamp_at(&self, place: usize) -> Option<u32> {
        if place >= self.len {
            return None;
        }
        // The k-th live stamp from the oldest, by descending the tree.
        let mut k = self.len - place;
        let mut at = 0;
        let mut step = (self.tree.len() - 1).next_power_of_two();
        while step > 0 {
            let next = at + step;
            if next < self.tree.len() && (self.tree[next] as usize) < k {
                at = next;
                k -= self.tree[next] as usize;
            }
            step >>= 1;
        }
        Some(at as u32)
    }

    /// The edge at `place`.
    pub(super) fn at(&self, place: usize) -> Option<(u32, u32)> {
        self.stamp_at(place).map(|s| self.edges[s as usize])
    }

    /// The most recent live stamp among `stamps` whose edge passes `keep`:
    /// with a limit (versions 3 to 5, at most that many live edges) the
    /// most recent that does, else (version 6) the most recent if it does.
    /// Version 6 looks no further, so that a vertex with many open edges
    /// (a hostile base's hub) costs no more than a few steps a triangle;
    /// on a manifold base the edge it would skip, the twin of the edge
    /// asked about, is never open.
    fn latest(&mut self, from: bool, v: u32, keep: impl Fn((u32, u32)) -> bool) -> Option<u32> {
        let lists = if from { &mut self.from } else { &mut self.into };
        let stamps = lists.get_mut(&v)?;
        let alive = &self.alive;
        if self.limit.is_some() {
            #[cfg(test)]
            {
                self.looked += stamps.len();
            }
            stamps.retain(|&s| alive[s as usize]);
            let edges = &self.edges;
            return stamps
                .iter()
                .rev()
                .copied()
                .find(|&s| keep(edges[s as usize]));
        }
        while stamps.last().is_some_and(|&s| !alive[s as usize]) {
            stamps.pop();
            #[cfg(test)]
            {
                self.looked += 1;
            }
        }
        #[cfg(test)]
        {
            self.looked += 1;
        }
        stamps
            .last()
            .copied()
            .filter(|&s| keep(self.edges[s as usize]))
    }

    /// The most recent open edge that triangle `t` shares (reversed), as
    /// its place and the corner `i` where it starts in `t` (the edge is
    /// `t[i + 1] t[i]`).
    pub(super) fn attach(&self, t: &[u32; 3]) -> Option<(usize, usize)> {
        (0..3)
            .filter_map(|i| {
                let stamps = self.by_edge.get(&(t[(i + 1) % 3], t[i]))?;
                stamps.last().map(|&s| (s, i))
            })
            .max()
            .map(|(s, i)| (self.place_of(s), i))
    }

    /// For open edge `a b`: the end of the most recent open edge from `b`
    /// not back to `a`, and the start of the most recent one into `a` not
    /// from `b` (version 6: of the most recent from `b` and into `a`, if
    /// they are not), the second left out when it is the first.
    pub(super) fn beside(&mut self, (a, b): (u32, u32)) -> (Option<u32>, Option<u32>) {
        let after = (self.latest(true, b, |e| e.1 != a)).map(|s| self.edges[s as usize].1);
        let before = (self.latest(false, a, |e| e.0 != b))
            .map(|s| self.edges[s as usize].0)
            .filter(|&x| Some(x) != after);
        (after, before)
    }

    /// The most recent open edge with `v` at an end: its place, and
    /// whether `v` is its end (else its start).
    pub(super) fn touching(&mut self, v: u32) -> Option<(usize, bool)> {
        let out = self.latest(true, v, |_| true);
        let inn = self.latest(false, v, |_| true);
        let (stamp, end) = match (out, inn) {
            (Some(o), Some(i)) if i > o => (i, true),
            (Some(o), _) => (o, false),
            (None, Some(i)) => (i, true),
            (None, None) => return None,
        };
        Some((self.place_of(stamp), end))
    }

    /// After a triangle's edge `a b`: it closes the most recent open edge
    /// `b a`, or opens anew (then [`Self::cut`]).
    pub(super) fn close_or_open(&mut self, a: u32, b: u32) {
        if let Some(stamps) = self.by_edge.get_mut(&(b, a))
            && let Some(s) = stamps.pop()
        {
            if stamps.is_empty() {
                self.by_edge.remove(&(b, a));
            }
            self.kill(s as usize);
            return;
        }
        let stamp = self.edges.len();
        if stamp + 1 >= self.tree.len() {
            self.grow();
        }
        self.edges.push((a, b));
        self.alive.push(true);
        self.add(stamp, true);
        self.len += 1;
        let s = stamp as u32;
        self.by_edge.entry((a, b)).or_default().push(s);
        self.from.entry(a).or_default().push(s);
        self.into.entry(b).or_default().push(s);
    }

    /// Drops the oldest edges beyond the limit, if there is one: after a
    /// triangle's three edges, as versions 3 to 5 did.
    pub(super) fn cut(&mut self) {
        if let Some(limit) = self.limit {
            while self.len > limit {
                while !self.alive[self.oldest] {
                    self.oldest += 1;
                }
                let (x, y) = self.edges[self.oldest];
                if let Some(stamps) = self.by_edge.get_mut(&(x, y)) {
                    stamps.retain(|&t| t as usize != self.oldest);
                    if stamps.is_empty() {
                        self.by_edge.remove(&(x, y));
                    }
                }
                self.kill(self.oldest);
            }
        }
    }

    fn kill(&mut self, stamp: usize) {
        self.alive[stamp] = false;
        self.add(stamp, false);
        self.len -= 1;
    }

    /// Doubles the tree's stamps, rebuilt from the live ones.
    fn grow(&mut self) {
        let size = 2 * self.tree.len();
        self.tree = vec![0; size];
        for s in 0..self.alive.len() {
            if self.alive[s] {
                self.add(s, true);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The places, ends and neighbours agree with a plain list, most
    /// recent first, through openings, closings, duplicates and a limit.
    #[test]
    fn agrees_with_a_plain_list() {
        for limit in [None, Some(7)] {
            let mut open = OpenEdges::new(limit);
            let mut list: Vec<(u32, u32)> = Vec::new();
            let mut x = 12345u32;
            for _ in 0..3000 {
                x = x.wrapping_mul(1_103_515_245).wrapping_add(12_345);
                let (a, b) = ((x >> 8) % 13, (x >> 20) % 13);
                if a == b {
                    continue;
                }
                open.close_or_open(a, b);
                open.cut();
                match list.iter().position(|&e| e == (b, a)) {
                    Some(p) => {
                        list.remove(p);
                    }
                    None => list.insert(0, (a, b)),
                }
                if let Some(limit) = limit {
                    list.truncate(limit);
                }
                assert_eq!(open.len(), list.len());
                for (place, &e) in list.iter().enumerate() {
                    assert_eq!(open.at(place), Some(e));
                }
                assert_eq!(open.at(list.len()), None);
                for v in 0..13 {
                    let want = (list.iter().enumerate())
                        .find_map(|(p, &(a, b))| (a == v || b == v).then_some((p, b == v)));
                    assert_eq!(open.touching(v), want);
                }
                if let Some(&(a, b)) = list.first() {
                    // Version 6 looks at the most recent edge alone.
                    let most_recent = limit.is_none();
                    let after = (list.iter())
                        .find(|e| e.0 == b && (most_recent || e.1 != a))
                        .filter(|e| e.1 != a)
                        .map(|e| e.1);
                    let before = (list.iter())
                        .find(|e| e.1 == a && (most_recent || e.0 != b))
                        .filter(|e| e.0 != b)
                        .map(|e| e.0)
                        .filter(|&y| Some(y) != after);
                    assert_eq!(open.beside((a, b)), (after, before));
                }
                let t = [a, b, (a + b + 1) % 13];
                let want = list.iter().enumerate().find_map(|(place, &(p, q))| {
                    (0..3)
                        .find(|&i| t[i] == q && t[(i + 1) % 3] == p)
                        .map(|i| (place, i))
                });
                if t[2] != a && t[2] != b {
                    assert_eq!(open.attach(&t), want);
                }
            }
        }
    }

    /// A hub holding 200,000 open edges costs version 6 a few stamps a
    /// question, as its edges open and close; versions 3 to 5, which search
    /// a vertex's live edges, look at every one kept.
    #[test]
    fn a_hub_costs_steps_not_searches() {
        let n = 100_000u32;
        for limit in [None, Some(256)] {
            let mut open = OpenEdges::new(limit);
            for i in 1..=n {
                open.close_or_open(0, 2 * i - 1);
                open.close_or_open(2 * i, 0);
                open.cut();
            }
            open.looked = 0;
            let asked = 2_000;
            for i in 1..=asked {
                assert!(open.touching(0).is_some());
                let _ = open.beside((2 * (n - i % 100), 0));
                // One of the hub's edges closes, as a triangle would close it.
                open.close_or_open(2 * (n - i) + 1, 0);
            }
            let per_question = open.looked as f64 / (3 * asked) as f64;
            match limit {
                None => assert!(per_question < 4.0, "{per_question} stamps a question"),
                Some(_) => assert!(per_question > 50.0, "{per_question} stamps a question"),
            }
        }
    }
}
