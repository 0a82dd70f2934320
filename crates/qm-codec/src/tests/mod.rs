//! End-to-end tests of the crate: meshes compressed with [`crate::compress`]
//! and decoded again, by topic. Tests of one module's parts alone stay in
//! that module.

mod colour;
mod frames;
mod holds;
mod lazy;
mod levels;
mod round_trip;
