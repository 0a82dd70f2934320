//! The level of one square per part, and each square's size there.
//!
//! A part's share of the samples, by area, gives it a square of
//! `side / 2^L` base quads a side at level `L` (`side` the square root of
//! its share). One level serves all parts: the one that gives the most
//! samples to the parts whose squares fit their share there, within the
//! cap of samples per input vertex; a part whose smallest square is too
//! large for its share at a level is oversampled there instead, within
//! bounds ([`SHARE_SLACK`]).

use super::chart::Chart;
use crate::remesh::budget::SHARE_SLACK;

/// The parts' shares of the samples, from which the level and the square
/// sizes follow.
pub(super) struct Sizing {
    /// The samples aimed for.
    pub target: f64,
    /// The most samples a level may have (per input vertex).
    pub cap: f64,
    /// Each part's share of the surface.
    pub shares: Vec<f64>,
}

impl Sizing {
    /// A component's share of the samples, a side.
    pub fn side(&self, c: usize) -> f64 {
        (self.target * self.shares[c]).sqrt()
    }

    /// A chart whose smallest square is too large for its share at a level
    /// (a small separate part: an eye, a button, a loose splinter) may be
    /// sampled more densely than its share asks, at that smallest square,
    /// as long as the whole remesh stays within `SHARE_SLACK` of its target.
    /// Otherwise one small part would hold every other chart down to a level
    /// it fits at, each then with many more, smaller base quads. Returns
    /// whether each chart is oversampled at `level`, the samples they take,
    /// and the most samples the level may have (the cap, and with
    /// oversampled charts `SHARE_SLACK` over the target).
    pub fn oversampled(&self, charts: &[Chart], level: u32) -> (Vec<bool>, f64, f64) {
        let over: Vec<bool> = charts
            .iter()
            .enumerate()
            .map(|(c, chart)| (chart.map.k << level) as f64 > SHARE_SLACK * self.side(c))
            .collect();
        let taken: f64 = charts
            .iter()
            .zip(&over)
            .filter(|&(_, &o)| o)
            .map(|(chart, _)| square_samples(chart.map.k, level))
            .sum();
        let limit = if taken > 0.0 {
            self.cap.min(SHARE_SLACK * SHARE_SLACK * self.target)
        } else {
            self.cap
        };
        (over, taken, limit)
    }

    /// The square size of component `c` at a level: nearest to its share,
    /// unless rounding up breaks its share of `room` (the level's limit less
    /// the oversampled charts' samples); never below what its chart needs.
    pub fn size(&self, c: usize, level: u32, k: usize, room: f64) -> usize {
        let exact = self.side(c) / (1u64 << level) as f64;
        let cap_side = (room * self.shares[c]).sqrt();
        let want = if (exact.round() * (1u64 << level) as f64) < cap_side {
            exact.round()
        } else {
            exact.floor()
        } as usize;
        want.max(k)
    }

    /// The level for `charts`, each at its smallest square.
    ///
    /// The samples at each level where every chart fits (its size at most
    /// `SHARE_SLACK` over its share, all under the cap) or is oversampled
    /// within the limit (counted at its share, so that levels which only add
    /// samples to it do not win). The level with the most samples wins, or
    /// the highest level with at least 85% of them: fewer, larger base quads
    /// for the same sampling, since the codec pays for every base vertex.
    pub fn level(&self, charts: &[Chart]) -> u32 {
        let samples = |level: u32| -> Option<f64> {
            let (over, taken, limit) = self.oversampled(charts, level);
            let (mut total, mut counted) = (taken, 0.0);
            for (c, chart) in charts.iter().enumerate() {
                if over[c] {
                    counted += self.side(c).powi(2);
                } else {
                    let n = square_samples(self.size(c, level, chart.map.k, limit - taken), level);
                    total += n;
                    counted += n;
                }
            }
            (total <= limit).then_some(counted)
        };
        let feasible: Vec<(u32, f64)> = (1..=qm_lift::MAX_LEVEL)
            .filter_map(|l| samples(l).map(|s| (l, s)))
            .collect();
        let most = feasible.iter().map(|&(_, s)| s).fold(0.0, f64::max);
        match feasible.iter().rev().find(|&&(_, s)| s >= 0.85 * most) {
            Some(&(l, _)) => l,
            // Nothing fits: the level that keeps every chart in its share.
            None => (0..charts.len())
                .map(|c| (self.side(c) / charts[c].map.k as f64).log2().floor())
                .fold(f64::INFINITY, f64::min)
                .clamp(1.0, qm_lift::MAX_LEVEL as f64) as u32,
        }
    }
}

/// Samples of a square of `k` base quads a side at `level`: `(k 2^L + 1)^2`.
pub(in crate::remesh) fn square_samples(k: usize, level: u32) -> f64 {
    ((k << level) as f64 + 1.0).powi(2)
}
