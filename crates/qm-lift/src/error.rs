//! Errors of the semi-regular layer.

use std::fmt;

/// Everything that can go wrong while building or transforming a semi-regular mesh.
///
/// Sorted by who is responsible: the input (a base mesh that is not a valid
/// quad mesh), the caller (mismatched sizes), or a limit.
#[derive(Debug, Clone, PartialEq, Eq)]
#[non_exhaustive]
pub enum Error {
    /// A base face names a vertex that does not exist.
    VertexOutOfRange {
        face: usize,
        vertex: u32,
        count: u32,
    },
    /// A base face uses the same vertex twice.
    DegenerateFace { face: usize },
    /// An undirected base edge is used by more than two faces.
    NonManifoldEdge { a: u32, b: u32 },
    /// Two faces share an edge in the same direction: the base mesh is not
    /// consistently oriented (or not orientable).
    InconsistentOrientation { a: u32, b: u32 },
    /// A base vertex is used by no face.
    UnusedVertex { vertex: u32 },
    /// The base mesh has no faces.
    Empty,
    /// The subdivision level is beyond what this build supports.
    LevelTooHigh { level: u32, max: u32 },
    /// The mesh would have more samples than the limit allows.
    TooManySamples { samples: u64, max: u64 },
    /// The caller passed arrays whose sizes do not match the layout.
    SizeMismatch {
        what: &'static str,
        expected: usize,
        found: usize,
    },
    /// Two faces disagree about the input vertex of a shared sample.
    InconsistentGrid { sample: u32 },
    /// Quantization bits outside the supported range.
    BadBits { bits: u32 },
    /// A coordinate is NaN or infinite.
    NonFinite,
}

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Error::VertexOutOfRange {
                face,
                vertex,
                count,
            } => write!(
                f,
                "base face {face} uses vertex {vertex}, but there are only {count} vertices"
            ),
            Error::DegenerateFace { face } => write!(f, "base face {face} repeats a vertex"),
            Error::NonManifoldEdge { a, b } => {
                write!(f, "edge {a}-{b} is shared by more than two faces")
            }
            Error::InconsistentOrientation { a, b } => write!(
                f,
                "faces on both sides of edge {a}-{b} run the same way: inconsistent orientation"
            ),
            Error::UnusedVertex { vertex } => write!(f, "base vertex {vertex} is used by no face"),
            Error::Empty => write!(f, "the base mesh has no faces"),
            Error::LevelTooHigh { level, max } => {
                write!(f, "subdivision level {level} is above the maximum {max}")
            }
            Error::TooManySamples { samples, max } => {
                write!(f, "{samples} samples exceed the limit of {max}")
            }
            Error::SizeMismatch {
                what,
                expected,
                found,
            } => {
                write!(f, "{what}: expected {expected} entries, found {found}")
            }
            Error::InconsistentGrid { sample } => write!(
                f,
                "sample {sample} is claimed by two different input vertices: not subdivision connectivity"
            ),
            Error::BadBits { bits } => write!(
                f,
                "{bits} quantization bits are outside the supported range {}..={}",
                crate::MIN_BITS,
                crate::MAX_BITS
            ),
            Error::NonFinite => write!(f, "a coordinate is NaN or infinite"),
        }
    }
}

impl std::error::Error for Error {}

/// Result alias of this crate.
pub type Result<T, E = Error> = std::result::Result<T, E>;
