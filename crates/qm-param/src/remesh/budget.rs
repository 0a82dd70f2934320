//! The sample budget: how many samples a remesh aims for, and each part's
//! share of them.
//!
//! The target is [`RemeshOptions::samples_per_vertex`] samples per input
//! vertex (never more than [`MAX_SAMPLES_PER_VERTEX`]), at most
//! [`RemeshOptions::max_samples`] or [`DENSE_SAMPLES_PER_VERTEX`] a vertex,
//! whichever is more; a part's share is its share of the
//! surface's area. Both pipelines choose their level from it
//! (modules `one_square` and `simplified`).

use super::options::RemeshOptions;
use crate::{Error, RemeshFailure, Result, TriMesh};

/// The remesher never makes more samples than this many per input vertex.
pub const MAX_SAMPLES_PER_VERTEX: f64 = 32.0;

/// How far a chart's square may be over its share of the samples, a side,
/// at the level chosen (see `one_square::remesh_square`). A level where some charts are
/// oversampled (their smallest square is larger still) must keep the whole
/// remesh within this much over its target, `SHARE_SLACK^2` in samples: no
/// more than one chart may take. With the default 30 samples per input
/// vertex the cap of 32 binds first; this binds where `max_samples` caps
/// the target. That also keeps a mesh of one component from counting as
/// oversampled at levels past its share
/// (docs/decisions/003-level-and-base-size.md).
pub(super) const SHARE_SLACK: f64 = 1.15;

/// Samples per input vertex a remesh aims for at least where
/// [`RemeshOptions::max_samples`] would give fewer: a dense scan keeps about
/// its own resolution, so that its lossless stream comes near the scan's
/// own precision (docs/scale.md, "The sample ceiling").
pub const DENSE_SAMPLES_PER_VERTEX: f64 = 1.0;

/// The samples a remesh of `input_vertices` vertices aims for:
/// [`RemeshOptions::samples_per_vertex`] a vertex (at most
/// [`MAX_SAMPLES_PER_VERTEX`]), no more than [`RemeshOptions::max_samples`]
/// unless that is below [`DENSE_SAMPLES_PER_VERTEX`] a vertex.
pub(super) fn target_samples(options: &RemeshOptions, input_vertices: usize) -> f64 {
    let vertices = input_vertices as f64;
    let most = (options.max_samples as f64).max(DENSE_SAMPLES_PER_VERTEX * vertices);
    (options.samples_per_vertex.min(MAX_SAMPLES_PER_VERTEX) * vertices).min(most)
}

/// The total area of `components` and each one's share of it; fails where
/// nothing is left to remesh (no component, or no area).
pub(super) fn area_shares(components: &[TriMesh]) -> Result<(f64, Vec<f64>)> {
    let total_area: f64 = components.iter().map(TriMesh::area).sum();
    if components.is_empty() || total_area <= 0.0 {
        return Err(Error::remesh(RemeshFailure::NothingLeft));
    }
    let shares = components.iter().map(|c| c.area() / total_area).collect();
    Ok((total_area, shares))
}
