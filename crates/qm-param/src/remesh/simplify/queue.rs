//! The queue of planned removals: a binary heap of vertices by planned
//! cost, with each vertex's place in it kept in an array, so that a plan
//! made again moves its vertex in place.
//!
//! Costs are ordered by `f64::total_cmp` and ties by vertex, and a vertex
//! is in the queue at most once, so the order is total and any heap pops
//! the same sequence: the removals do not depend on how the heap is laid
//! out (docs/decisions/033-exact-speedups.md).

use std::cmp::Ordering;

/// A vertex's priority in the queue of removals: its planned cost.
#[derive(Clone, Copy, PartialEq)]
pub(super) struct Cost {
    pub(super) cost: f64,
    pub(super) v: u32,
}

impl Eq for Cost {}

impl PartialOrd for Cost {
    fn partial_cmp(&self, other: &Self) -> Option<Ordering> {
        Some(self.cmp(other))
    }
}

impl Ord for Cost {
    /// Cheapest first in a max-heap; ties by vertex, for determinism.
    fn cmp(&self, other: &Self) -> Ordering {
        other
            .cost
            .total_cmp(&self.cost)
            .then_with(|| other.v.cmp(&self.v))
    }
}

/// Not in the heap.
const ABSENT: u32 = u32::MAX;

/// A max-heap of [`Cost`]s (so cheapest first), at most one per vertex.
pub(super) struct Queue {
    heap: Vec<Cost>,
    /// Per vertex: its index in `heap`, or [`ABSENT`].
    at: Vec<u32>,
}

impl Queue {
    /// A queue of `entries` (one per vertex at most) over `n` vertices.
    pub(super) fn new(n: usize, entries: Vec<Cost>) -> Queue {
        let mut queue = Queue {
            heap: entries,
            at: vec![ABSENT; n],
        };
        for (i, c) in queue.heap.iter().enumerate() {
            queue.at[c.v as usize] = i as u32;
        }
        for i in (0..queue.heap.len() / 2).rev() {
            queue.down(i);
        }
        queue
    }

    /// The cheapest entry, taken out.
    pub(super) fn pop(&mut self) -> Option<Cost> {
        let top = *self.heap.first()?;
        self.take(0);
        Some(top)
    }

    /// Puts `c` in, or moves its vertex to its new cost.
    pub(super) fn push(&mut self, c: Cost) {
        match self.at[c.v as usize] {
            ABSENT => {
                self.heap.push(c);
                let i = self.heap.len() - 1;
                self.at[c.v as usize] = i as u32;
                self.up(i);
            }
            i => {
                let i = i as usize;
                let old = std::mem::replace(&mut self.heap[i], c);
                if c > old {
                    self.up(i);
                } else {
                    self.down(i);
                }
            }
        }
    }

    /// Takes vertex `v` out, if it is in.
    pub(super) fn remove(&mut self, v: u32) {
        if let Some(&i) = self.at.get(v as usize)
            && i != ABSENT
        {
            self.take(i as usize);
        }
    }

    /// Takes out the entry at `i`: the last takes its place and moves.
    fn take(&mut self, i: usize) {
        let gone = self.heap.swap_remove(i);
        self.at[gone.v as usize] = ABSENT;
        if i < self.heap.len() {
            self.at[self.heap[i].v as usize] = i as u32;
            if i > 0 && self.heap[i] > self.heap[(i - 1) / 2] {
                self.up(i);
            } else {
                self.down(i);
            }
        }
    }

    fn up(&mut self, mut i: usize) {
        while i > 0 {
            let parent = (i - 1) / 2;
            if self.heap[i] <= self.heap[parent] {
                break;
            }
            self.swap(i, parent);
            i = parent;
        }
    }

    fn down(&mut self, mut i: usize) {
        loop {
            let (l, r) = (2 * i + 1, 2 * i + 2);
            let mut top = i;
            if l < self.heap.len() && self.heap[l] > self.heap[top] {
                top = l;
            }
            if r < self.heap.len() && self.heap[r] > self.heap[top] {
                top = r;
            }
            if top == i {
                break;
            }
            self.swap(i, top);
            i = top;
        }
    }

    fn swap(&mut self, i: usize, j: usize) {
        self.heap.swap(i, j);
        self.at[self.heap[i].v as usize] = i as u32;
        self.at[self.heap[j].v as usize] = j as u32;
    }
}

#[cfg(test)]
mod tests {
    use super::{Cost, Queue};

    /// Pushes, updates and removals against a sorted list: the queue pops
    /// the same sequence.
    #[test]
    fn pops_cheapest_first_like_a_sorted_list() {
        let n = 200u32;
        // A small linear congruential sequence, with repeated costs.
        let mut x = 12345u64;
        let mut next = || {
            x = x
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (x >> 33) as u32
        };
        let first: Vec<Cost> = (0..n)
            .filter(|v| v % 3 != 0)
            .map(|v| Cost {
                cost: f64::from(next() % 50),
                v,
            })
            .collect();
        let mut queue = Queue::new(n as usize, first.clone());
        let mut list = first;
        for round in 0..2000 {
            let v = next() % n;
            match round % 4 {
                0 => {
                    queue.remove(v);
                    list.retain(|c| c.v != v);
                }
                1 | 2 => {
                    let c = Cost {
                        cost: f64::from(next() % 50),
                        v,
                    };
                    queue.push(c);
                    list.retain(|c| c.v != v);
                    list.push(c);
                }
                _ => {
                    let expected = list.iter().copied().max();
                    let got = queue.pop();
                    assert_eq!(got.map(|c| (c.cost, c.v)), expected.map(|c| (c.cost, c.v)));
                    if let Some(c) = expected {
                        list.retain(|d| d.v != c.v);
                    }
                }
            }
        }
        while let Some(expected) = list.iter().copied().max() {
            assert_eq!(queue.pop().map(|c| c.v), Some(expected.v));
            list.retain(|d| d.v != expected.v);
        }
        assert!(queue.pop().is_none());
    }
}
