//! Simplification to a base: the level, and each part's base for it.
//!
//! At level `L` a base triangle is three quads of `(2^L + 1)^2` samples, so
//! `S` samples take about `S / (3 4^L)` base triangles; each part's goal is
//! its share of them by area. The level first chosen is the shallowest
//! whose base needs no more than [`MAX_BASE_TRIANGLES`] and [`BASE_SHARE`]
//! of the samples (with [`BASE_SLACK`]); each part is simplified towards its
//! goal there (module `simplify`), keeping the bases it passes through at
//! the goals of shallower levels. Where parts stop above their goals, the
//! level is lowered until the samples fit under the cap, and the parts
//! coarser than their goal there take the base they passed through.

use rayon::prelude::*;

use crate::Result;
use crate::clean::Cleaned;
use crate::remesh::budget::{MAX_SAMPLES_PER_VERTEX, SHARE_SLACK, area_shares, target_samples};
use crate::remesh::options::RemeshOptions;
use crate::remesh::simplify;

/// The most base triangles the level is chosen for: near 65 dB the base is
/// still most of what qm sends. The level taken is the shallowest whose
/// share of the samples needs no more base triangles than this and than
/// [`BASE_SHARE`] of the samples allow; a coarser base maps with more
/// distortion (docs/decisions/003-level-and-base-size.md).
const MAX_BASE_TRIANGLES: f64 = 500.0;

/// How far over [`MAX_BASE_TRIANGLES`] and [`BASE_SHARE`] a level's base may
/// be rather than a level deeper (four times fewer base triangles).
pub(super) const BASE_SLACK: f64 = 1.1;

/// Base triangles per sample at most: a base section of a few percent of a
/// stream of about a byte a sample (docs/decisions/003-level-and-base-size.md).
const BASE_SHARE: f64 = 0.02 / 16.0;

/// Each part's base at the level taken, and what the tries of
/// [`super::remesh_charts`] need beside it.
pub(super) struct Bases {
    /// Per part, its base at `level`.
    pub bases: Vec<simplify::Base>,
    /// The level taken.
    pub level: u32,
    /// Per part, its base one level shallower (four times its goal), for a
    /// remesh that measures poorly: the base its simplification passed
    /// through at that goal, or its own where it stopped above it. `None`
    /// where a level was asked for, at level 1, or where a part passed no
    /// base at that goal.
    pub shallower: Option<Vec<simplify::Base>>,
    /// Per part, its goal at the level first chosen, whose goals the bases
    /// were simplified for: a part simplified again around its folds aims
    /// for it.
    pub refold_goals: Vec<usize>,
    /// Per part, its share of the surface.
    pub shares: Vec<f64>,
}

/// Chooses the level and simplifies each part of `cleaned` to its base
/// there (see the module documentation).
pub(super) fn simplify_to_bases(cleaned: &Cleaned, options: &RemeshOptions) -> Result<Bases> {
    let input_vertices: usize = cleaned.components.iter().map(|c| c.positions.len()).sum();
    let (_, shares) = area_shares(&cleaned.components)?;
    let target = target_samples(options, input_vertices);
    let cap =
        (MAX_SAMPLES_PER_VERTEX * input_vertices as f64).min(SHARE_SLACK * SHARE_SLACK * target);
    // Base triangles for the whole mesh at a level.
    let triangles_at = |level: u32| target / (3.0 * (1u64 << (2 * level)) as f64);
    let most = MAX_BASE_TRIANGLES.min(BASE_SHARE * target).max(4.0);
    let mut level = options.level.unwrap_or_else(|| {
        (1..=qm_lift::MAX_LEVEL)
            .find(|&l| triangles_at(l) <= BASE_SLACK * most)
            .unwrap_or(qm_lift::MAX_LEVEL)
    });
    let goal = |c: usize, level: u32| (shares[c] * triangles_at(level)).round() as usize;
    // Each part's base at the level, and the bases its simplification
    // passed through at the goals of shallower levels.
    let (mut bases, mut passed): (Vec<simplify::Base>, Vec<Vec<(usize, simplify::Base)>>) = cleaned
        .components
        .par_iter()
        .enumerate()
        .map(|(c, component)| {
            let checkpoints: Vec<usize> = if options.level.is_none() {
                (1..level).map(|l| goal(c, l)).collect()
            } else {
                Vec::new()
            };
            let s = simplify::simplify_part(component, goal(c, level), &checkpoints);
            (s.base, s.passed)
        })
        .unzip();
    // The level first chosen, whose goals the bases were simplified for.
    let first_level = level;
    if options.level.is_none() {
        // A part that could not come down to its goal (a small separate
        // part, or one whose feature lines hold many base vertices) keeps
        // at least the base it has at any level; every part takes its goal
        // where that is larger. The deepest level where the samples fit
        // under the cap is taken, and the parts whose base is coarser than
        // their goal there take the base their simplification passed
        // through at that goal, rather than being simplified again for it
        // (docs/decisions/003-level-and-base-size.md).
        let counts: Vec<usize> = bases.iter().map(|b| b.triangles.len()).collect();
        let base_at = |l: u32| -> f64 {
            (0..bases.len())
                .map(|c| 3.0 * goal(c, l).max(counts[c]) as f64)
                .sum()
        };
        let fits = |l: u32| base_at(l) * (1u64 << (2 * l)) as f64 <= cap;
        let chosen = (1..=level).rev().find(|&l| fits(l)).unwrap_or(1);
        if chosen != level {
            level = chosen;
            for c in 0..bases.len() {
                let goal = goal(c, level);
                if goal > counts[c]
                    && let Some(i) = passed[c].iter().position(|(count, _)| *count == goal)
                {
                    bases[c] = passed[c].swap_remove(i).1;
                }
            }
        }
    }
    // Each part's base one level shallower.
    let shallower: Option<Vec<simplify::Base>> = (options.level.is_none() && level > 1)
        .then(|| {
            (0..bases.len())
                .map(|c| {
                    let goal = goal(c, level - 1);
                    if bases[c].triangles.len() >= goal {
                        Some(bases[c].clone())
                    } else {
                        let i = passed[c].iter().position(|(count, _)| *count == goal)?;
                        Some(passed[c].swap_remove(i).1)
                    }
                })
                .collect()
        })
        .flatten();
    drop(passed);
    let refold_goals: Vec<usize> = (0..bases.len()).map(|c| goal(c, first_level)).collect();
    Ok(Bases {
        bases,
        level,
        shallower,
        refold_goals,
        shares,
    })
}
