//! Errors of the facade: those of the layers below, kept typed.

use std::fmt;

/// Any error of qm.
#[derive(Debug)]
#[non_exhaustive]
pub enum Error {
    /// Container, codec or mesh file error.
    Io(qm_io::Error),
    /// The input mesh could not be made semi-regular.
    Param(qm_param::Error),
}

impl Error {
    /// Whether the data simply ended too early.
    pub fn is_truncated(&self) -> bool {
        matches!(self, Error::Io(e) if e.is_truncated())
    }
}

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Error::Io(e) => e.fmt(f),
            Error::Param(e) => e.fmt(f),
        }
    }
}

impl std::error::Error for Error {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        match self {
            Error::Io(e) => Some(e),
            Error::Param(e) => Some(e),
        }
    }
}

impl From<qm_io::Error> for Error {
    fn from(e: qm_io::Error) -> Self {
        Error::Io(e)
    }
}

impl From<qm_param::Error> for Error {
    fn from(e: qm_param::Error) -> Self {
        Error::Param(e)
    }
}

impl From<qm_io::mesh::MeshError> for Error {
    fn from(e: qm_io::mesh::MeshError) -> Self {
        Error::Io(e.into())
    }
}

/// Result alias of the facade.
pub type Result<T, E = Error> = std::result::Result<T, E>;
