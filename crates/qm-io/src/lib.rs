//! The `.qm` container and mesh file input/output.
//!
//! Main types: [`PolyMesh`] (what mesh files hold).

pub mod mesh;
mod polymesh;

pub use polymesh::PolyMesh;
pub use qm_ezw;
pub use qm_lift;
