//! Errors of the facade: those of the layers below, kept typed.

pub use qm_lift::ErrorKind;
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

    /// Who is responsible for this error: the kind of the layer's error
    /// (mesh files sit below the kinds and are sorted here).
    pub fn kind(&self) -> ErrorKind {
        use qm_io::MeshError as Mesh;
        match self {
            Error::Mesh(m) => match m {
                Mesh::Io { .. } => ErrorKind::File,
                Mesh::UnsupportedOutput { .. } | Mesh::InvalidMesh { .. } => ErrorKind::Parameter,
                _ if m.is_truncated() => ErrorKind::Truncated,
                _ => ErrorKind::Data,
            },
            Error::Param(p) => p.kind(),
            Error::Codec(c) => c.kind(),
        }
    }
}

/// Result alias of the facade.
pub type Result<T, E = Error> = std::result::Result<T, E>;

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{DecodeOptions, EncodeOptions, Options, PolyMesh};

    fn tetrahedron() -> PolyMesh {
        qm_shapes::poly(qm_shapes::tetrahedron())
    }

    /// One error of each kind, each from what a user would do.
    #[test]
    fn each_error_names_who_is_responsible() {
        let bytes = crate::encode(&tetrahedron(), &Options::default())
            .unwrap()
            .bytes;
        let decode = |b: &[u8], o: &DecodeOptions| crate::decode(b, o).unwrap_err().kind();
        let defaults = DecodeOptions::DEFAULT;
        assert_eq!(decode(b"not a qm file at all", &defaults), ErrorKind::Data);
        assert_eq!(decode(&bytes[..10], &defaults), ErrorKind::Truncated);
        let tight = defaults.with_limits(qm_codec::Limits::DEFAULT.with_max_memory(1));
        assert_eq!(decode(&bytes, &tight), ErrorKind::Limit);
        let bits = Options::default().with_encode(EncodeOptions::DEFAULT.with_bits(40));
        let err = crate::encode(&tetrahedron(), &bits).unwrap_err();
        assert_eq!(err.kind(), ErrorKind::Parameter, "{err}");
        // An encoder setting out of range is the caller's, not a limit.
        let heavy = crate::Weighting {
            bits_per_level: 3,
            normal_bits: 0,
        };
        let heavy = Options::default().with_encode(EncodeOptions::DEFAULT.with_weighting(heavy));
        let err = crate::encode(&tetrahedron(), &heavy).unwrap_err();
        assert_eq!(err.kind(), ErrorKind::Parameter, "{err}");
        let missing = crate::read_mesh("no-such-folder/no-such-mesh.obj").unwrap_err();
        assert_eq!(missing.kind(), ErrorKind::File, "{missing}");
    }
}
