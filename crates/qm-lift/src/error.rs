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

/// Who is responsible for an error: what a binding maps to its exception
/// classes, what sets the command line's exit code, and what tells a user
/// whether to fix the input, the call, or the limit. Every layer's error
/// has a `kind()` giving it; the layers above re-export this type.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[non_exhaustive]
pub enum ErrorKind {
    /// The data: not `.qm`, corrupt, a malformed mesh file, a mesh that
    /// cannot be remeshed.
    Data,
    /// The data ended inside the part that must arrive whole (a `.qm`
    /// stream's header or base mesh, a mesh file's promised data); a cut
    /// after a `.qm` stream's base mesh is no error.
    Truncated,
    /// A limit the caller may raise: memory, samples, 32-bit indices.
    Limit,
    /// The caller's settings or arguments: a value out of range, arrays of
    /// mismatched sizes, an output format that cannot be written.
    Parameter,
    /// The file system: a file that cannot be read or written.
    File,
    /// A broken internal guarantee of qm: a bug.
    Bug,
}

impl Error {
    /// Who is responsible for this error. A base mesh that is not a valid
    /// quad mesh is the data's fault (it came from a file or a remesh);
    /// a level, bits or array sizes out of range are the caller's.
    pub fn kind(&self) -> ErrorKind {
        match self {
            Error::VertexOutOfRange { .. }
            | Error::DegenerateFace { .. }
            | Error::NonManifoldEdge { .. }
            | Error::InconsistentOrientation { .. }
            | Error::UnusedVertex { .. }
            | Error::Empty
            | Error::InconsistentGrid { .. }
            | Error::NonFinite => ErrorKind::Data,
            Error::LevelTooHigh { .. } | Error::SizeMismatch { .. } | Error::BadBits { .. } => {
                ErrorKind::Parameter
            }
            Error::TooManySamples { .. } => ErrorKind::Limit,
        }
    }
}

/// Result alias of this crate.
pub type Result<T, E = Error> = std::result::Result<T, E>;
