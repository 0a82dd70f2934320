//! The `.qm` container and the codec driver.
//!
//! [`compress`] turns a [`qm_lift::SemiRegularMesh`] into the bytes of a `.qm`
//! file (header, base mesh, embedded stream; see [`container`]) and
//! [`decompress`] turns any prefix of those bytes that contains the base mesh
//! back into a mesh; [`Decoder`] does so for a growing stream, resuming from
//! its last complete pass. The encoder's [`holds`] keep a longer cut from
//! decoding worse than a shorter one.
//!
//! This crate builds on `qm-lift`, `qm-tree` and `qm-ezw` only: it knows
//! nothing of mesh files or remeshing.
//!
//! Main types: [`EncodeOptions`], [`Compressed`], [`DecodeOptions`],
//! [`Decompressed`], [`container::Header`], [`Error`].
//!
//! The modules, by step: `encode` ([`compress`]) chooses the frames
//! ([`Frames`]), writes the [`container`] with its base section
//! (`basecode`) and finds the [`holds`], measuring cuts of the
//! [`Compressed`] stream; `decode` ([`decompress`], [`Decoder`]) reads them
//! back and chooses the output level by its error estimate ([`levels`]);
//! `stream` ([`StreamDecoder`]) decodes a file received in pieces.

pub mod atlas;
mod basecode;
mod colour;
mod compressed;
pub mod container;
mod decode;
mod encode;
mod error;
mod frames;
pub mod holds;
pub mod levels;
mod stream;
#[cfg(test)]
mod tests;

pub use atlas::Atlas;
pub use basecode::coded_base_values;
pub use colour::Colours;
pub use compressed::Compressed;
pub use container::{DEFAULT_MAX_MEMORY, Limits};
pub use decode::{DecodeOptions, DecodeStatus, Decoder, Decompressed, decompress};
pub use encode::{EncodeOptions, compress, compress_coloured, compress_probed};
pub use error::{Error, Result};
pub use frames::{AUTO_CUTS, AUTO_MIN_GAIN_DB, Frames};
pub use holds::{Probes, SurfacePoint, surface_points};
pub use levels::{DEFAULT_TOLERANCE_DB, Estimate, LevelChoice};
pub use qm_ezw::{self, Contexts, Weighting};
pub use qm_lift::ErrorKind;
pub use qm_lift::{self, UpdateRule};
pub use stream::{LevelMesh, PrefixRow, StreamDecoder, Textured, prefix_table, vertex_normals};
