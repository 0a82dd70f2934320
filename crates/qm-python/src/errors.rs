//! The facade's [`qm::Error`] as Python exceptions.
//!
//! The classes live in `qm_mesh/_errors.py` (a base `QmError`; `DataError`
//! and its `TruncatedError`, `LimitError`, `ParameterError`, `FileError`),
//! so that they can have two bases (`DataError` is also a `ValueError`,
//! `FileError` an `OSError`). Each `qm::Error` is sorted by who is
//! responsible, as the layers' error enums are: the data, an exceeded
//! limit, the caller's parameters, the file system. The message is the
//! library's own, the one `qm` prints after `error:`, with the keyword
//! argument that lifts a refusal where there is one (as the CLI names its
//! flag).

use pyo3::PyErr;

use qm::codec::Error as Codec;
use qm::io::MeshError as Mesh;
use qm::param::{Error as Param, RemeshFailure};

pyo3::import_exception!(qm_mesh._errors, QmError);
pyo3::import_exception!(qm_mesh._errors, DataError);
pyo3::import_exception!(qm_mesh._errors, TruncatedError);
pyo3::import_exception!(qm_mesh._errors, LimitError);
pyo3::import_exception!(qm_mesh._errors, ParameterError);
pyo3::import_exception!(qm_mesh._errors, FileError);

/// Who is responsible for an error.
enum Kind {
    Data,
    Truncated,
    Limit,
    Parameter,
    File,
    /// A bug in qm (a broken internal guarantee), or a kind this binding
    /// does not know yet.
    Other,
}

fn kind(e: &qm::Error) -> Kind {
    match e {
        qm::Error::Mesh(m) => match m {
            Mesh::Io { .. } => Kind::File,
            Mesh::UnsupportedOutput { .. } | Mesh::InvalidMesh { .. } => Kind::Parameter,
            _ if m.is_truncated() => Kind::Truncated,
            _ => Kind::Data,
        },
        qm::Error::Param(p) => match p {
            // Bits are checked against the caller's setting only: a file's
            // bits are checked by its container (`Codec::Malformed`).
            Param::NoSamples | Param::Lift(qm::lift::Error::BadBits { .. }) => Kind::Parameter,
            Param::TooManyVertices { .. } | Param::Memory { .. } => Kind::Limit,
            Param::Internal(_) => Kind::Other,
            _ => Kind::Data,
        },
        qm::Error::Codec(c) => match c {
            Codec::Truncated { .. } => Kind::Truncated,
            Codec::Setting { .. }
            | Codec::Budget { .. }
            | Codec::Lift(qm::lift::Error::BadBits { .. }) => Kind::Parameter,
            Codec::Limit { .. } | Codec::Memory { .. } => Kind::Limit,
            Codec::Io(_) => Kind::File,
            _ => Kind::Data,
        },
        _ => Kind::Other,
    }
}

/// The keyword argument that lifts this refusal, if one does.
fn remedy(e: &qm::Error) -> Option<&'static str> {
    match e {
        qm::Error::Param(Param::Remesh {
            failure: RemeshFailure::Folds { .. },
            ..
        }) => Some("accept_folds=True encodes it anyway"),
        qm::Error::Param(Param::Remesh {
            failure: RemeshFailure::TooFar { .. },
            ..
        }) => Some("min_remesh_psnr=0 encodes it anyway"),
        qm::Error::Codec(Codec::Memory { .. }) | qm::Error::Param(Param::Memory { .. }) => {
            Some("max_memory raises it")
        }
        _ => None,
    }
}

/// `e` as an exception of its kind.
pub fn to_py(e: qm::Error) -> PyErr {
    let message = match remedy(&e) {
        Some(r) => format!("{e} ({r})"),
        None => e.to_string(),
    };
    match kind(&e) {
        Kind::Data => DataError::new_err(message),
        Kind::Truncated => TruncatedError::new_err(message),
        Kind::Limit => LimitError::new_err(message),
        Kind::Parameter => ParameterError::new_err(message),
        Kind::File => FileError::new_err(message),
        Kind::Other => QmError::new_err(message),
    }
}
