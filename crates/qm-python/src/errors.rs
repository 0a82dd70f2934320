//! The facade's [`qm::Error`] as Python exceptions.
//!
//! The classes live in `qm_mesh/_errors.py` (a base `QmError`; `DataError`
//! and its `TruncatedError`, `LimitError`, `ParameterError`, `FileError`),
//! so that they can have two bases (`DataError` is also a `ValueError`,
//! `FileError` an `OSError`). Each `qm::Error` goes to the class of its
//! [`qm::ErrorKind`] (the library sorts errors by who is responsible). The message is the
//! library's own, the one `qm` prints after `error:`, with the keyword
//! argument that lifts a refusal where there is one (as the CLI names its
//! flag).

use pyo3::PyErr;

use qm::ErrorKind;
use qm::codec::Error as Codec;
use qm::param::{Error as Param, RemeshFailure};

pyo3::import_exception!(qm_mesh._errors, QmError);
pyo3::import_exception!(qm_mesh._errors, DataError);
pyo3::import_exception!(qm_mesh._errors, TruncatedError);
pyo3::import_exception!(qm_mesh._errors, LimitError);
pyo3::import_exception!(qm_mesh._errors, ParameterError);
pyo3::import_exception!(qm_mesh._errors, FileError);

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
    match e.kind() {
        ErrorKind::Data => DataError::new_err(message),
        ErrorKind::Truncated => TruncatedError::new_err(message),
        ErrorKind::Limit => LimitError::new_err(message),
        ErrorKind::Parameter => ParameterError::new_err(message),
        ErrorKind::File => FileError::new_err(message),
        // A bug, or a kind this binding does not know yet.
        _ => QmError::new_err(message),
    }
}
