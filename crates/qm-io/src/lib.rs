//! The `.qm` container, the codec driver, and mesh file input/output.
//!
//! [`compress`] turns a [`qm_lift::SemiRegularMesh`] into the bytes of a `.qm`
//! file (header, base mesh, embedded stream; see [`container`]) and
//! [`decompress`] turns any prefix of those bytes that contains the base mesh
//! back into a mesh. [`mesh`] reads and writes OBJ, PLY, OFF and STL files
//! into [`PolyMesh`].
//!
//! Main types: [`EncodeOptions`], [`Compressed`], [`DecodeOptions`],
//! [`Decompressed`], [`container::Header`], [`PolyMesh`], [`Error`].

mod basecode;
mod codec;
pub mod container;
mod error;
pub mod holds;
pub mod mesh;
mod polymesh;

pub use codec::{
    AUTO_CUTS, AUTO_MIN_GAIN_DB, BasePlacement, Compressed, DecodeOptions, DecodeStatus, Decoder,
    Decompressed, EncodeOptions, Frames, compress, compress_probed, decompress,
};
pub use container::Limits;
pub use error::{Error, Result};
pub use holds::Probes;
pub use polymesh::PolyMesh;
pub use qm_ezw::{self, Contexts, Weighting};
pub use qm_lift::{self, UpdateRule};
