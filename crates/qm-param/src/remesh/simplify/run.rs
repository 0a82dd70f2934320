//! Running a simplification: every vertex's removal planned, then the
//! cheapest made, one at a time, the plans around it made again, until the
//! target is reached or no removal is left; a run stuck far above its target
//! goes on with lower shape bounds. The bases passed at the checkpoints
//! asked for are kept on the way.

use std::cmp::Ordering;

use foldhash::fast::FixedState;
use priority_queue::PriorityQueue;
use rayon::prelude::*;

use super::base::Simplified;
use super::simplifier::Simplifier;

/// How many times its target a simplification may stop at before it goes
/// on with lower shape bounds.
pub(super) const STUCK: usize = 2;

/// The lower shape bounds a stuck simplification goes on with, in turn.
const LOWER_QUALITY: &[f64] = &[0.005, 0.001, 0.0002];

/// A vertex's priority in the queue of removals: its planned cost.
#[derive(PartialEq)]
struct Cost {
    cost: f64,
    v: u32,
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

impl Simplifier<'_> {
    /// Removes vertices, cheapest first, until `stop` triangles are left
    /// or no removal is. A part left at more than [`STUCK`] times its `goal`
    /// (a dense scan, whose every removal would make a sliver) goes on with
    /// the lower shape bounds of [`LOWER_QUALITY`] in turn, from the
    /// vertices no removal has touched yet (see [`Self::run_at`]).
    pub(super) fn run(&mut self, goal: usize, stop: usize) {
        self.run_at(stop);
        for &bound in LOWER_QUALITY {
            if self.alive_faces <= STUCK * goal || self.alive_faces <= stop {
                break;
            }
            self.min_quality = bound;
            self.run_at(stop);
        }
    }

    fn run_at(&mut self, target: usize) {
        // The first plans, in parallel (the heap breaks ties by vertex, so
        // its order does not depend on the threads), of the vertices no run
        // before touched: a run under a lower shape bound reaches into the
        // regions where the usual one removed nothing, and leaves those it
        // simplified as they are (docs/decisions/014-simplifier-runs.md).
        //
        // The queue holds each vertex once, its priority updated where its
        // ring changes.
        let first: Vec<(u32, Cost)> = (0..self.positions.len() as u32)
            .into_par_iter()
            .with_min_len(1024)
            .filter(|&v| !self.touched[v as usize])
            .filter_map(|v| self.plan(v).map(|p| (v, Cost { cost: p.cost, v })))
            .collect();
        let mut queue: PriorityQueue<u32, Cost, FixedState> = first.into_iter().collect();
        self.pass_checkpoints();
        while self.alive_faces > target {
            let Some((v, planned)) = queue.pop() else {
                break;
            };
            let Some(plan) = self.plan(v) else { continue };
            if plan.cost > planned.cost * (1.0 + 1e-9) + 1e-300 {
                self.touched[v as usize] = true;
                queue.push(v, Cost { cost: plan.cost, v });
                continue;
            }
            let touched = self.collapse(v, &plan);
            self.pass_checkpoints();
            for w in touched {
                self.touched[w as usize] = true;
                match self.plan(w) {
                    Some(p) => queue.push(w, Cost { cost: p.cost, v: w }),
                    None => queue.remove(&w).map(|(_, c)| c),
                };
            }
        }
    }

    /// Keeps the base now at every checkpoint the count has come down to.
    fn pass_checkpoints(&mut self) {
        while let Some(&count) = self.checkpoints.first()
            && self.alive_faces <= count
        {
            self.checkpoints.remove(0);
            let base = self.base();
            self.passed.push((count, base));
        }
    }

    pub(super) fn finish_with_passed(mut self) -> Simplified {
        let passed = std::mem::take(&mut self.passed);
        Simplified {
            base: self.base(),
            passed,
        }
    }
}
