//! From an input mesh to a semi-regular quad mesh.
//!
//! A quad mesh that already has subdivision connectivity (made by repeated
//! quad splitting, as Catmull-Clark subdivision in a modelling tool does) is
//! taken as it is: [`detect_subdivision`] undoes the splitting level by level
//! and returns the coarsest base mesh with the input as its finest level, a
//! [`SemiRegularMesh`], plus which input vertex each sample is ([`Detected`]).
//! Any other mesh is remeshed: [`clean::clean`] repairs it and splits it into
//! components, and [`remesh()`] cuts each component open into a disk, maps it
//! onto a square and resamples it as `K x K` base quads refined `L` times,
//! with the cut's sides glued so the result has no seams, the samples
//! placed where the codec's details come out normal where that is safe
//! ([`Remeshed`], [`RemeshOptions`]).
//!
//! [`distance()`] measures how far two surfaces are apart (RMS, mean and
//! Hausdorff distance and PSNR, as Metro does), to judge a remeshed or
//! decoded mesh against its input; [`ColourSurface`] gives the colour of an
//! [`Asset`](qm_io::Asset)'s surface at the point closest to any point, and
//! [`colour_distance()`] compares two assets' colours at the same samples.
//!
//! This crate reads meshes through `qm-io`'s [`PolyMesh`] and builds
//! `qm-lift`'s types; it knows nothing of trees, coding or files.

pub mod clean;
mod closest;
pub mod colour;
pub mod distance;
mod error;
mod quads;
pub mod remesh;
mod subdivision;
mod trimesh;
mod union_find;

pub use colour::{ColourReport, ColourSide, ColourSurface, colour_distance, colour_psnr};
pub use distance::{DistanceOptions, DistanceReport, OneSided, Side, distance};
pub use error::{Error, Part, RemeshFailure, Result};
pub use qm_io::PolyMesh;
pub use qm_lift::ErrorKind;
pub use qm_lift::SemiRegularMesh;
pub use remesh::{
    BaseDomain, NormalReport, RemeshOptions, RemeshReport, Remeshed, Reporter, Step, remesh,
    remesh_reporting,
};
pub use subdivision::{Detected, detect_subdivision};
pub use trimesh::{TriMesh, triangle_area};
