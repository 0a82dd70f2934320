//! Running a simplification: every vertex's removal planned, then the
//! cheapest made, one at a time, the plans around it made again, until the
//! target is reached or no removal is left; a run stuck far above its target
//! goes on with lower shape bounds. The bases passed at the checkpoints
//! asked for are kept on the way.

use rayon::prelude::*;

use super::base::Simplified;
use super::plan::Plan;
use super::queue::{Cost, Queue};
use super::simplifier::Simplifier;

/// How many times its target a simplification may stop at before it goes
/// on with lower shape bounds.
pub(super) const STUCK: usize = 2;

/// The lower shape bounds a stuck simplification goes on with, in turn.
const LOWER_QUALITY: &[f64] = &[0.005, 0.001, 0.0002];

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
        let first: Vec<(u32, Plan)> = (0..self.positions.len() as u32)
            .into_par_iter()
            .with_min_len(1024)
            .filter(|&v| !self.touched[v as usize])
            .filter_map(|v| self.plan(v).map(|p| (v, p)))
            .collect();
        // Per vertex: its plan, while nothing it reads has changed since it
        // was made (a removal changes what the plans of the vertices within
        // two rings of it read: see [`Self::stale_around`]). Taken from
        // here, a plan is the one made again.
        let mut plans: Vec<Option<Plan>> = Vec::new();
        plans.resize_with(self.positions.len(), || None);
        let first = first
            .into_iter()
            .map(|(v, p)| {
                let cost = Cost { cost: p.cost, v };
                plans[v as usize] = Some(p);
                cost
            })
            .collect();
        let mut queue = Queue::new(self.positions.len(), first);
        self.pass_checkpoints();
        while self.alive_faces > target {
            let Some(planned) = queue.pop() else {
                break;
            };
            let v = planned.v;
            let kept = plans[v as usize].take().filter(|_| !self.exhausted());
            let Some(plan) = kept.or_else(|| self.plan(v)) else {
                continue;
            };
            if plan.cost > planned.cost * (1.0 + 1e-9) + 1e-300 {
                self.touched[v as usize] = true;
                queue.push(Cost { cost: plan.cost, v });
                plans[v as usize] = Some(plan);
                continue;
            }
            let touched = self.collapse(v, &plan);
            self.pass_checkpoints();
            self.stale_around(&touched, &mut plans);
            for w in touched {
                self.touched[w as usize] = true;
                match self.plan(w) {
                    Some(p) => {
                        queue.push(Cost { cost: p.cost, v: w });
                        plans[w as usize] = Some(p);
                    }
                    None => queue.remove(w),
                }
            }
        }
    }

    /// Drops the plans a removal may have changed, `ring` the removed
    /// vertex's ring: a plan reads its vertex's ring, the edges and crease
    /// lines among the ring's vertices and their quadrics, and a removal
    /// changes the faces around its ring's vertices, the edges among them
    /// and one of their quadrics. So the plans of the ring's vertices and
    /// of their neighbours change, and no other.
    fn stale_around(&self, ring: &[u32], plans: &mut [Option<Plan>]) {
        for &y in ring {
            plans[y as usize] = None;
            for &f in &self.vfaces[y as usize] {
                for z in self.faces[f as usize] {
                    plans[z as usize] = None;
                }
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
