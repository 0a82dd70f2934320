//! Errors of the parameterization layer.

use qm_lift::ErrorKind;
use thiserror::Error as ThisError;

use crate::distance::Side;

/// Everything that can go wrong while turning an input mesh into a
/// semi-regular one.
///
/// Sorted by who is responsible: the input mesh, the caller, an exceeded
/// limit, or a bug in this crate.
#[derive(Debug, Clone, PartialEq, ThisError)]
#[non_exhaustive]
pub enum Error {
    /// A face is not a quad.
    #[error("not a quad mesh: face {face} has {corners} corners")]
    NotQuads { face: usize, corners: usize },
    /// A vertex is used by no face, so it cannot be a sample of any grid.
    #[error("vertex {vertex} is used by no face")]
    UnusedVertex { vertex: u32 },
    /// The quads do not form a consistently oriented, edge-manifold mesh.
    #[error("not a valid oriented edge-manifold quad mesh: {0}")]
    InvalidMesh(qm_lift::Error),
    /// Not even one step of quad subdivision can be undone.
    #[error(
        "the quad mesh has no subdivision connectivity (it is not a quad-split of a coarser mesh); it needs remeshing"
    )]
    NoSubdivisionConnectivity,
    /// The mesh has no faces at all (`mesh` names which of the two given
    /// to [`crate::distance::distance`]; `None` for the one mesh of any
    /// other call).
    #[error("{}has no faces", MeshName(*mesh))]
    NoFaces { mesh: Option<Side> },
    /// A mesh given to [`crate::distance::distance`] has no area to sample.
    #[error("mesh {mesh} has no face of positive area")]
    ZeroArea { mesh: Side },
    /// A face refers to a vertex the mesh does not have (`mesh` as for
    /// [`Error::NoFaces`]).
    #[error("{}face {face} refers to missing vertex {vertex}", MeshPrefix(*mesh))]
    MissingVertex {
        mesh: Option<Side>,
        face: usize,
        vertex: u32,
    },
    /// A vertex used by a face has a NaN or infinite coordinate (`mesh` as
    /// for [`Error::NoFaces`]).
    #[error("{}vertex {vertex} is not finite", MeshPrefix(*mesh))]
    NonFinite { mesh: Option<Side>, vertex: u32 },
    /// An [`Asset`](qm_io::Asset)'s appearance does not fit its mesh (a
    /// colour count other than the vertex count, texture coordinates for
    /// another number of corners, a material that does not exist, an image
    /// whose pixels do not match its size); `mesh` as for
    /// [`Error::NoFaces`]. The readers never return such an asset.
    #[error("{}appearance does not fit the mesh: {problem}", MeshPrefix(*mesh))]
    Appearance { mesh: Option<Side>, problem: String },
    /// [`crate::distance::DistanceOptions::samples`] is 0.
    #[error("the sample count must be at least 1")]
    NoSamples,
    /// The mesh has more vertices than a semi-regular mesh may hold.
    #[error("{vertices} vertices exceed the limit of {max}")]
    TooManyVertices { vertices: usize, max: u64 },
    /// Building the semi-regular mesh failed after detection succeeded: a
    /// position is not finite, or the mesh exceeds a limit of `qm-lift`.
    #[error("building the semi-regular mesh failed: {0}")]
    Lift(qm_lift::Error),
    /// The remesher could not make a part of the mesh semi-regular.
    #[error("remeshing failed: {}{failure}", part.map_or(String::new(), |p| format!("{p} ")))]
    Remesh {
        /// The part (connected component after clean-up), when one is to
        /// blame.
        part: Option<Part>,
        /// What went wrong.
        failure: RemeshFailure,
    },
    /// Remeshing and encoding would take more memory than the limit
    /// ([`crate::remesh::encode_memory`]).
    #[error(
        "remeshing and encoding needs about {} of memory ({triangles} input triangles{}), \
         above the limit of {}",
        qm_lift::ByteSize(*needed),
        if *samples > 0 { format!(", {samples} samples") } else { String::new() },
        qm_lift::ByteSize(*limit)
    )]
    Memory {
        /// Bytes the work would take, estimated.
        needed: u64,
        /// The limit.
        limit: u64,
        /// Input triangles.
        triangles: u64,
        /// Samples of the remesh (0 when refused on the input alone).
        samples: u64,
    },
    /// A consistency check that this crate guarantees did not hold: a bug here.
    #[error("internal error in qm-param: {0}")]
    Internal(&'static str),
}

/// `the mesh ` or `mesh A `, for a message about one mesh or one of two.
struct MeshName(Option<Side>);

impl std::fmt::Display for MeshName {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self.0 {
            Some(side) => write!(f, "mesh {side} "),
            None => f.write_str("the mesh "),
        }
    }
}

/// `mesh A: ` where one of two meshes is meant, nothing otherwise.
struct MeshPrefix(Option<Side>);

impl std::fmt::Display for MeshPrefix {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self.0 {
            Some(side) => write!(f, "mesh {side}: "),
            None => Ok(()),
        }
    }
}

/// A part of the mesh: one connected component after clean-up.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[non_exhaustive]
pub struct Part {
    /// Its index among the cleaned components.
    pub index: usize,
    /// Its vertices.
    pub vertices: usize,
    /// Its genus (from its Euler characteristic; negative for a part
    /// that clean-up left odd).
    pub genus: i64,
    /// Its boundary loops.
    pub holes: usize,
}

impl std::fmt::Display for Part {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "component {} ({} vertices, genus {}, {} holes)",
            self.index, self.vertices, self.genus, self.holes
        )
    }
}

/// Why the remesher could not make a part semi-regular.
#[derive(Debug, Clone, PartialEq, ThisError)]
#[non_exhaustive]
pub enum RemeshFailure {
    /// Nothing with area is left after clean-up.
    #[error("nothing with area left after clean-up")]
    NothingLeft,
    /// The part's map onto its square leaves samples far outside the part.
    #[error(
        "does not map onto its square: {stray} samples fell outside its bounds (stretch \
         {stretch:.3e}, {folded} folded triangles); a scan with many small holes or handles \
         may need repair first"
    )]
    DoesNotMap {
        /// Samples more than a quarter of the part's diagonal outside its
        /// bounding box.
        stray: usize,
        /// The map's stretch.
        stretch: f64,
        /// Folded triangles in the map.
        folded: usize,
    },
    /// No square size tried glues the part's cut into a valid base mesh.
    #[error(
        "could not glue its cut ({disk_vertices} disk vertices, {boundary_edges} boundary \
         edges after cutting) into a valid base mesh with {} base quads a side (last problem: \
         {problem}); a mesh with many holes, handles or split non-manifold edges may need \
         repair first",
        sizes.iter().map(usize::to_string).collect::<Vec<_>>().join(", ")
    )]
    DoesNotGlue {
        /// Vertices of the part cut open into a disk.
        disk_vertices: usize,
        /// Boundary edges of that disk.
        boundary_edges: usize,
        /// The square sizes tried.
        sizes: Vec<usize>,
        /// Why the last one did not glue.
        problem: String,
    },
    /// The part's map onto its base domain (its square, or its charts)
    /// folds: the remesh would overlap itself there.
    #[error(
        "folds: {folded} of its {triangles} triangles are folded in its map onto its base \
         domain, so the remesh would overlap itself there"
    )]
    Folds {
        /// Triangles whose image in the square is turned over.
        folded: usize,
        /// The part's triangles.
        triangles: usize,
    },
    /// The remesh lies further from the input than the floor allows
    /// ([`crate::RemeshOptions::min_psnr`]), measured by the remesher.
    #[error(
        "its remesh is {psnr:.1} dB from the input (symmetric RMS distance), below the floor of \
         {floor:.1} dB"
    )]
    TooFar {
        /// The remesh's PSNR against the input.
        psnr: f64,
        /// The floor.
        floor: f64,
    },
    /// The cut has too many segments to lay out on a square.
    #[error("its cut has too many segments to lay out on a square")]
    TooManySegments,
    /// A linear solve failed, or another step of the remesher (named).
    #[error("{0}")]
    Step(String),
}

/// The message carries the inner error's, so it is not also a `source()`:
/// an error chain shows each message once.
impl From<qm_lift::Error> for Error {
    fn from(e: qm_lift::Error) -> Self {
        Error::Lift(e)
    }
}

impl Error {
    /// Who is responsible for this error. A mesh the remesher cannot make
    /// semi-regular is the data's: a user repairs it or picks another base
    /// domain.
    pub fn kind(&self) -> ErrorKind {
        match self {
            Error::NotQuads { .. }
            | Error::UnusedVertex { .. }
            | Error::InvalidMesh(_)
            | Error::NoSubdivisionConnectivity
            | Error::NoFaces { .. }
            | Error::ZeroArea { .. }
            | Error::MissingVertex { .. }
            | Error::NonFinite { .. }
            | Error::Remesh { .. } => ErrorKind::Data,
            Error::NoSamples | Error::Appearance { .. } => ErrorKind::Parameter,
            Error::TooManyVertices { .. } | Error::Memory { .. } => ErrorKind::Limit,
            Error::Lift(e) => e.kind(),
            Error::Internal(_) => ErrorKind::Bug,
        }
    }

    /// A remesher failure, its part not yet known.
    pub(crate) fn remesh(failure: RemeshFailure) -> Error {
        Error::Remesh {
            part: None,
            failure,
        }
    }

    /// This error, blamed on `part` if it is a remesher failure that names
    /// none yet.
    pub(crate) fn in_part(self, part: impl FnOnce() -> Part) -> Error {
        match self {
            Error::Remesh {
                part: None,
                failure,
            } => Error::Remesh {
                part: Some(part()),
                failure,
            },
            other => other,
        }
    }
}

/// Result alias of this crate.
pub type Result<T, E = Error> = std::result::Result<T, E>;

#[cfg(test)]
mod tests {
    use super::*;

    /// A remesher failure names the part it is blamed on first, once, and
    /// keeps its kind for callers to match on.
    #[test]
    fn remesh_failures_name_their_part_once() {
        let part = |index| Part {
            index,
            vertices: 10,
            genus: 1,
            holes: 3,
        };
        let e = Error::remesh(RemeshFailure::DoesNotGlue {
            disk_vertices: 12,
            boundary_edges: 20,
            sizes: vec![3, 4],
            problem: "two edges share both ends".into(),
        })
        .in_part(|| part(2))
        .in_part(|| part(5));
        let text = e.to_string();
        assert!(
            text.starts_with(
                "remeshing failed: component 2 (10 vertices, genus 1, 3 holes) could not glue \
                 its cut (12 disk vertices, 20 boundary edges after cutting) into a valid base \
                 mesh with 3, 4 base quads a side"
            ),
            "{text}"
        );
        assert!(matches!(
            e,
            Error::Remesh {
                part: Some(Part { index: 2, .. }),
                failure: RemeshFailure::DoesNotGlue { .. }
            }
        ));
        let plain = Error::remesh(RemeshFailure::NothingLeft).to_string();
        assert_eq!(
            plain,
            "remeshing failed: nothing with area left after clean-up"
        );
    }
}
