//! Errors of the mesh readers and writers.

use std::fmt;
use std::io;

use super::Format;

/// Why reading or writing a mesh file failed.
///
/// Every variant names the file (as given by the caller) so that a message is
/// useful on its own, e.g. `bunny.obj: line 12: face index 9001 out of range
/// (4000 vertices)`.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum MeshError {
    /// Bad input: the content is not a mesh this reader accepts.
    #[error("{file}: {}{problem}", LinePrefix(*.line))]
    Malformed {
        /// The file name given by the caller.
        file: String,
        /// The 1-based line of a text format, when known.
        line: Option<usize>,
        /// What is wrong.
        problem: Problem,
    },
    /// Bad input: neither the extension nor the content tells the format.
    #[error("{file}: unknown mesh format (known: .obj, .ply, .off, .stl, .gltf, .glb)")]
    UnknownFormat {
        /// The file name given by the caller.
        file: String,
    },
    /// Caller misuse: this format can be read but not written.
    #[error("{file}: unsupported output format {format} (write .obj or .ply)")]
    UnsupportedOutput {
        /// The file name given by the caller.
        file: String,
        /// The format that was asked for.
        format: Format,
    },
    /// Caller misuse: the mesh handed to a writer cannot be stored faithfully
    /// (the readers would refuse the result).
    #[error("{file}: cannot write mesh: {problem}")]
    InvalidMesh {
        /// The file name given by the caller.
        file: String,
        /// What is wrong with the mesh.
        problem: Problem,
    },
    /// The environment: reading, writing or renaming the file failed.
    #[error("{file}: {cause}")]
    Io {
        /// The file name given by the caller.
        file: String,
        /// The underlying error (in the message, so not also a `source()`:
        /// an error chain shows it once).
        cause: io::Error,
    },
}

impl MeshError {
    pub(crate) fn malformed(file: &str, line: Option<usize>, problem: Problem) -> Self {
        MeshError::Malformed {
            file: file.to_owned(),
            line,
            problem,
        }
    }

    pub(crate) fn io(file: &str, cause: io::Error) -> Self {
        MeshError::Io {
            file: file.to_owned(),
            cause,
        }
    }

    /// The file name the error is about.
    pub fn file(&self) -> &str {
        match self {
            MeshError::Malformed { file, .. }
            | MeshError::UnknownFormat { file }
            | MeshError::UnsupportedOutput { file, .. }
            | MeshError::InvalidMesh { file, .. }
            | MeshError::Io { file, .. } => file,
        }
    }

    /// The 1-based line number, for text formats when it is known.
    pub fn line(&self) -> Option<usize> {
        match self {
            MeshError::Malformed { line, .. } => *line,
            _ => None,
        }
    }

    /// What is wrong with the content or with the mesh given to a writer.
    pub fn problem(&self) -> Option<&Problem> {
        match self {
            MeshError::Malformed { problem, .. } | MeshError::InvalidMesh { problem, .. } => {
                Some(problem)
            }
            _ => None,
        }
    }

    /// Whether the input ended before the data its header or syntax promised.
    pub fn is_truncated(&self) -> bool {
        matches!(
            self,
            MeshError::Malformed {
                problem: Problem::Truncated { .. } | Problem::CountExceedsData { .. },
                ..
            }
        )
    }
}

/// What is wrong with a mesh file's content (or with a mesh to be written).
#[derive(Clone, Debug, PartialEq, Eq)]
#[non_exhaustive]
pub enum Problem {
    /// The file has no bytes at all.
    Empty,
    /// The file holds no vertex.
    NoVertices,
    /// The file holds no face.
    NoFaces,
    /// A coordinate is NaN or infinite (`vertex` counts from 0).
    NonFiniteCoordinate {
        /// The vertex, counted from 0 in file order.
        vertex: usize,
    },
    /// A face corner refers to no vertex. `index` is the value as written in
    /// the file (OBJ counts from 1 and allows negative, relative indices).
    IndexOutOfRange {
        /// The index as written.
        index: i64,
        /// How many vertices there are.
        vertices: usize,
    },
    /// A face has fewer than 3 corners.
    TooFewCorners {
        /// How many it has.
        corners: usize,
    },
    /// A face has more corners than the output format can store.
    TooManyCorners {
        /// How many it has.
        corners: usize,
        /// The most the format allows.
        max: usize,
    },
    /// A count exceeds what qm can index (32-bit vertex and corner indices).
    TooMany {
        /// What is counted ("vertices", "face corners").
        what: &'static str,
        /// The count.
        count: u64,
        /// The limit.
        max: u64,
    },
    /// The data ends in the middle of `what`.
    Truncated {
        /// What was being read.
        what: String,
    },
    /// A header declares more items than the remaining bytes could hold, so
    /// the reader refuses before allocating for them.
    CountExceedsData {
        /// What the header counts.
        what: String,
        /// The declared count.
        count: u64,
        /// How many bytes follow the header.
        bytes: usize,
    },
    /// Colours to write do not match the vertices one to one.
    ColourCount {
        /// How many colours were given.
        colours: usize,
        /// How many vertices the mesh has.
        vertices: usize,
    },
    /// A texture to write does not fit the mesh or its own size.
    Texture(String),
    /// The text or binary layout does not follow the format.
    Syntax(String),
    /// A valid variant of the format that this reader does not handle.
    Unsupported(String),
    /// A file the mesh file names, and whose data the geometry needs (a
    /// glTF buffer), cannot be read.
    Resource {
        /// What and where (`buffer 0 "mesh.bin"`).
        what: String,
        /// Why (the system's message).
        cause: String,
    },
}

impl fmt::Display for Problem {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Problem::Empty => write!(f, "file is empty"),
            Problem::NoVertices => write!(f, "no vertices"),
            Problem::NoFaces => write!(f, "no faces"),
            Problem::NonFiniteCoordinate { vertex } => {
                write!(f, "vertex {vertex} has a NaN or infinite coordinate")
            }
            Problem::IndexOutOfRange { index, vertices } => {
                write!(f, "face index {index} out of range ({vertices} vertices)")
            }
            Problem::TooFewCorners { corners } => {
                write!(f, "face with {corners} corners (at least 3 needed)")
            }
            Problem::TooManyCorners { corners, max } => {
                write!(f, "face with {corners} corners (at most {max} allowed)")
            }
            Problem::TooMany { what, count, max } => {
                write!(f, "{count} {what} (at most {max} supported)")
            }
            Problem::Truncated { what } => write!(f, "data ends in the middle of {what}"),
            Problem::CountExceedsData { what, count, bytes } => {
                write!(
                    f,
                    "header declares {count} {what} but only {bytes} bytes follow"
                )
            }
            Problem::ColourCount { colours, vertices } => {
                write!(f, "{colours} colours for {vertices} vertices")
            }
            Problem::Syntax(message) | Problem::Texture(message) => write!(f, "{message}"),
            Problem::Unsupported(what) => write!(f, "unsupported: {what}"),
            Problem::Resource { what, cause } => write!(f, "cannot read {what}: {cause}"),
        }
    }
}

/// Formats `line N: ` when the line is known, nothing otherwise.
struct LinePrefix(Option<usize>);

impl fmt::Display for LinePrefix {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.0 {
            Some(line) => write!(f, "line {line}: "),
            None => Ok(()),
        }
    }
}
