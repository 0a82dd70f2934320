//! Errors of the parameterization layer.

use thiserror::Error as ThisError;

use crate::distance::Side;

/// Everything that can go wrong while turning an input mesh into a
/// semi-regular one.
///
/// Sorted by who is responsible: the input mesh, the caller, an exceeded
/// limit, or a bug in this crate.
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
    /// A mesh given to [`crate::distance::distance`] has no faces.
    #[error("mesh {mesh} has no faces")]
    NoFaces { mesh: Side },
    /// A mesh given to [`crate::distance::distance`] has no area to sample.
    #[error("mesh {mesh} has no face of positive area")]
    ZeroArea { mesh: Side },
    /// A face refers to a vertex the mesh does not have.
    #[error("mesh {mesh}: face {face} refers to missing vertex {vertex}")]
    MissingVertex {
        mesh: Side,
        face: usize,
        vertex: u32,
    },
    /// A vertex used by a face has a NaN or infinite coordinate.
    #[error("mesh {mesh}: vertex {vertex} is not finite")]
    NonFinite { mesh: Side, vertex: u32 },
    /// [`crate::distance::DistanceOptions::samples`] is 0.
    #[error("the sample count must be at least 1")]
    NoSamples,
    /// The mesh has more vertices than a semi-regular mesh may hold.
    #[error("{vertices} vertices exceed the limit of {max}")]
    TooManyVertices { vertices: usize, max: u64 },
    /// Building the semi-regular mesh failed after detection succeeded: a
    /// position is not finite, or the mesh exceeds a limit of `qm-lift`.
    #[error("building the semi-regular mesh failed: {0}")]
    Lift(#[from] qm_lift::Error),
    /// A face of the mesh given to [`crate::clean::clean`] refers to a vertex
    /// the mesh does not have.
    #[error("face {face} refers to missing vertex {vertex}")]
    VertexOutOfRange { face: usize, vertex: u32 },
    /// A vertex used by a face of the mesh given to [`crate::clean::clean`]
    /// has a NaN or infinite coordinate.
    #[error("vertex {vertex} is not finite")]
    NonFiniteVertex { vertex: u32 },
    /// The remesher could not parameterize or resample a component.
    #[error("remeshing failed: {0}")]
    Remesh(String),
    /// A consistency check that this crate guarantees did not hold: a bug here.
    #[error("internal error in qm-param: {0}")]
    Internal(&'static str),
}

/// Result alias of this crate.
pub type Result<T, E = Error> = std::result::Result<T, E>;
