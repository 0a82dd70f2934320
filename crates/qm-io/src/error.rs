//! Errors of the container and codec layer.

use std::fmt;

use crate::mesh::MeshError;

/// Everything that can go wrong reading or writing `.qm` data.
///
/// A stream cut short *after* the base mesh is not an error: it decodes to a
/// coarser mesh. Cut inside the header or the base mesh, it is
/// [`Error::Truncated`] (see [`Error::is_truncated`]).
#[derive(Debug)]
#[non_exhaustive]
pub enum Error {
    /// The data does not start with the `.qm` magic bytes.
    NotQm,
    /// A format version this build cannot read.
    UnsupportedVersion {
        /// The version in the file.
        found: u8,
        /// The oldest version this build reads.
        oldest: u8,
        /// The newest version this build reads.
        newest: u8,
    },
    /// The data ends inside the header or the base mesh.
    Truncated { needed: usize, available: usize },
    /// A checksum does not match: the named section is corrupt.
    Checksum { section: &'static str },
    /// A header or base mesh field is malformed.
    Malformed { what: String },
    /// An encoder setting is outside its range.
    Setting {
        what: &'static str,
        value: u64,
        min: u64,
        max: u64,
    },
    /// A field asks for more than the decoder's limits allow.
    Limit {
        what: &'static str,
        value: u64,
        max: u64,
    },
    /// The semi-regular layer refused the mesh.
    Lift(qm_lift::Error),
    /// A mesh file could not be read or written.
    Mesh(MeshError),
    /// Reading or writing failed.
    Io(std::io::Error),
}

impl Error {
    /// Whether the data simply ended too early (more bytes would help).
    pub fn is_truncated(&self) -> bool {
        matches!(self, Error::Truncated { .. })
    }
}

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Error::NotQm => write!(f, "not a .qm stream (bad magic bytes)"),
            Error::UnsupportedVersion {
                found,
                oldest,
                newest,
            } => {
                write!(
                    f,
                    ".qm format version {found} is not supported (this build reads versions {oldest} to {newest})"
                )
            }
            Error::Truncated { needed, available } => write!(
                f,
                "truncated inside the header or base mesh: {available} bytes, at least {needed} needed"
            ),
            Error::Checksum { section } => write!(f, "checksum mismatch: the {section} is corrupt"),
            Error::Malformed { what } => write!(f, "malformed stream: {what}"),
            Error::Setting {
                what,
                value,
                min,
                max,
            } => write!(f, "{what} is {value}, outside {min} to {max}"),
            Error::Limit { what, value, max } => {
                write!(f, "{what} is {value}, above the limit of {max}")
            }
            Error::Lift(e) => write!(f, "{e}"),
            Error::Mesh(e) => write!(f, "{e}"),
            Error::Io(e) => write!(f, "{e}"),
        }
    }
}

impl std::error::Error for Error {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        match self {
            Error::Lift(e) => Some(e),
            Error::Mesh(e) => Some(e),
            Error::Io(e) => Some(e),
            _ => None,
        }
    }
}

impl From<qm_lift::Error> for Error {
    fn from(e: qm_lift::Error) -> Self {
        Error::Lift(e)
    }
}

impl From<MeshError> for Error {
    fn from(e: MeshError) -> Self {
        Error::Mesh(e)
    }
}

impl From<std::io::Error> for Error {
    fn from(e: std::io::Error) -> Self {
        Error::Io(e)
    }
}

/// Result alias of this crate.
pub type Result<T, E = Error> = std::result::Result<T, E>;
