//! Builds a small mesh from the input and makes it semi-regular (clean-up,
//! detection and the remesher): `Ok` or `Err`, never a panic, a hang or an
//! unbounded allocation. The input layout is in `remesh_input.rs`.
#![no_main]

use libfuzzer_sys::fuzz_target;

mod remesh_input;

fuzz_target!(|data: &[u8]| remesh_input::run(data));
