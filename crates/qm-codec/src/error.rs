//! Errors of the container and codec layer.

use qm_lift::ErrorKind;
use thiserror::Error as ThisError;

/// Everything that can go wrong reading or writing `.qm` data.
///
/// A stream cut short *after* the base mesh is not an error: it decodes to a
/// coarser mesh. Cut inside the header or the base mesh, it is
/// [`Error::Truncated`] (see [`Error::is_truncated`]).
#[derive(Debug, ThisError)]
#[non_exhaustive]
pub enum Error {
    /// The data does not start with the `.qm` magic bytes.
    #[error("not a .qm stream (bad magic bytes)")]
    NotQm,
    /// A format version this build cannot read.
    #[error(".qm format version {found} is not supported (this build reads version {newest})")]
    UnsupportedVersion {
        /// The version in the file.
        found: u8,
        /// The newest version this build reads.
        newest: u8,
    },
    /// The data ends inside the header or the base mesh.
    #[error(
        "truncated inside the header or base mesh: {available} bytes, at least {needed} needed"
    )]
    Truncated {
        /// Bytes needed to get past the base mesh, at least.
        needed: usize,
        /// Bytes there are.
        available: usize,
    },
    /// A checksum does not match: the named section is corrupt.
    #[error("checksum mismatch: the {section} is corrupt")]
    Checksum {
        /// `header` or `base mesh`.
        section: &'static str,
    },
    /// A header or base mesh field is malformed.
    #[error("malformed stream: {what}")]
    Malformed {
        /// What is wrong.
        what: String,
    },
    /// An encoder setting is outside its range.
    #[error("{what} is {value}, outside {min} to {max}")]
    Setting {
        /// The setting.
        what: &'static str,
        /// Its value.
        value: u64,
        /// The smallest value allowed.
        min: u64,
        /// The largest value allowed.
        max: u64,
    },
    /// A field asks for more than the decoder's limits allow.
    #[error("{what} is {value}, above the limit of {max}")]
    Limit {
        /// The field.
        what: &'static str,
        /// What the file asks for.
        value: u64,
        /// The limit.
        max: u64,
    },
    /// A byte budget below the bytes of the header and base mesh, which
    /// must be sent whole.
    #[error(
        "a byte budget of {budget} bytes is below the {needed} bytes of the header and base \
         mesh, the least a file can have"
    )]
    Budget {
        /// The budget asked for.
        budget: u64,
        /// Bytes of the header and base mesh.
        needed: u64,
    },
    /// Decoding (or encoding) would take more memory than the limit allows.
    #[error(
        "needs about {} of memory for {samples} samples, above the limit of {}",
        qm_lift::ByteSize(*needed),
        qm_lift::ByteSize(*limit)
    )]
    Memory {
        /// Bytes the work would take, estimated.
        needed: u64,
        /// The limit.
        limit: u64,
        /// Samples of the mesh.
        samples: u64,
    },
    /// The semi-regular layer refused the mesh.
    #[error(transparent)]
    Lift(#[from] qm_lift::Error),
    /// Reading or writing failed.
    #[error(transparent)]
    Io(#[from] std::io::Error),
}

impl Error {
    /// Whether the data simply ended too early (more bytes would help).
    pub fn is_truncated(&self) -> bool {
        matches!(self, Error::Truncated { .. })
    }

    /// Who is responsible for this error.
    pub fn kind(&self) -> ErrorKind {
        match self {
            Error::NotQm
            | Error::UnsupportedVersion { .. }
            | Error::Checksum { .. }
            | Error::Malformed { .. } => ErrorKind::Data,
            Error::Truncated { .. } => ErrorKind::Truncated,
            Error::Setting { .. } | Error::Budget { .. } => ErrorKind::Parameter,
            Error::Limit { .. } | Error::Memory { .. } => ErrorKind::Limit,
            Error::Lift(e) => e.kind(),
            Error::Io(_) => ErrorKind::File,
        }
    }
}

/// Result alias of this crate.
pub type Result<T, E = Error> = std::result::Result<T, E>;
