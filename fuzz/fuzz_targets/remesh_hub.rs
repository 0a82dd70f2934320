//! A hub of many triangles or an n-gon made semi-regular: `Ok` or `Err`,
//! never a panic, a hang or an unbounded allocation. The input layout is in
//! `remesh_hub_input.rs`.
#![no_main]

use libfuzzer_sys::fuzz_target;

mod remesh_hub_input;

fuzz_target!(|data: &[u8]| remesh_hub_input::run(data));
