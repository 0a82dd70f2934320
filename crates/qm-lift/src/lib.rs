//! Semi-regular quad meshes and their integer lifting wavelet transform.
//!
//! This is the bottom layer of qm. A [`BaseMesh`] is a coarse quad mesh of any
//! topology; a [`Layout`] refines each of its faces to a regular
//! `(2^L + 1)^2` grid with the samples on base edges and vertices shared; a
//! [`SemiRegularMesh`] gives every sample a position. [`Quantizer`] maps
//! positions to integers and [`Lifting`] transforms those integers into base
//! scaling values and per-level details (Kobbelt's interpolatory quad
//! stencils for prediction, a mean-preserving update), exactly invertibly.
//!
//! This crate knows nothing of trees, coding or files.

mod base;
mod error;
pub mod frames;
mod layout;
mod lifting;
mod mesh;
mod split;
pub mod synthetic;

pub use base::{BaseMesh, Edge, NO_FACE, Side};
pub use error::{Error, ErrorKind, Result};
pub use layout::{Layout, MAX_LEVEL, MAX_SAMPLES, Numbering, Place, side_coords, side_point};
pub use lifting::{Lifting, UpdateRule};
pub use mesh::{
    ByteSize, Coord, DEFAULT_BITS, MAX_BITS, MIN_BITS, Quantizer, SemiRegularMesh, bounding_box,
    unit_scale,
};
pub use split::{TriangleSplit, coding_order, split_triangles, unsplit};

pub use glam;
