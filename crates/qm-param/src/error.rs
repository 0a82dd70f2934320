//! Errors of the parameterization layer.

use thiserror::Error as ThisError;

/// Everything that can go wrong while turning an input mesh into a
/// semi-regular one.
///
/// Sorted by who is responsible: the input mesh, an exceeded limit, or a bug
/// in this crate.
#[derive(Debug, Clone, PartialEq, Eq, ThisError)]
#[non_exhaustive]
pub enum Error {
    /// The mesh has no faces at all.
    #[error("the mesh has no faces")]
    Empty,
    /// A face is not a quad.
    #[error("not a quad mesh: face {face} has {corners} corners")]
    NotQuads { face: usize, corners: usize },
    /// A vertex is used by no face, so it cannot be a sample of any grid.
    #[error("vertex {vertex} is used by no face")]
    UnusedVertex { vertex: u32 },
    /// The quads do not form a consistently oriented, edge-manifold mesh.
    #[error("not a valid oriented edge-manifold quad mesh: {0}")]
    InvalidMesh(#[source] qm_lift::Error),
    /// Not even one step of quad subdivision can be undone.
    #[error(
        "the quad mesh has no subdivision connectivity (it is not a quad-split of a coarser mesh); it needs remeshing"
    )]
    NoSubdivisionConnectivity,
    /// The mesh has more vertices than a semi-regular mesh may hold.
    #[error("{vertices} vertices exceed the limit of {max}")]
    TooManyVertices { vertices: usize, max: u64 },
    /// Building the semi-regular mesh failed after detection succeeded: a
    /// position is not finite, or the mesh exceeds a limit of `qm-lift`.
    #[error("building the semi-regular mesh failed: {0}")]
    Lift(#[from] qm_lift::Error),
    /// A consistency check that detection guarantees did not hold: a bug here.
    #[error("internal error in subdivision detection: {0}")]
    Internal(&'static str),
}

/// Result alias of this crate.
pub type Result<T, E = Error> = std::result::Result<T, E>;
