//! Errors of the facade: those of the layers below, kept typed.

use thiserror::Error as ThisError;

/// Any error of qm. Each variant is its layer's error, shown as that error
/// alone (its message is not repeated by this wrapper).
#[derive(Debug, ThisError)]
#[non_exhaustive]
pub enum Error {
    /// A mesh file could not be read or written.
    #[error(transparent)]
    Mesh(#[from] qm_io::MeshError),
    /// The input mesh could not be made semi-regular.
    #[error(transparent)]
    Param(#[from] qm_param::Error),
    /// Container or codec error.
    #[error(transparent)]
    Codec(#[from] qm_codec::Error),
}

impl Error {
    /// Whether the data simply ended too early (inside the header or the
    /// base mesh; a cut after the base mesh is not an error).
    pub fn is_truncated(&self) -> bool {
        matches!(self, Error::Codec(e) if e.is_truncated())
    }
}

/// Result alias of the facade.
pub type Result<T, E = Error> = std::result::Result<T, E>;
