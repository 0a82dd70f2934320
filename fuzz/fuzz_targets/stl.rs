//! Arbitrary bytes through the STL reader: `Ok` or `Err`, never a panic.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let _ = qm::io::read_mesh_bytes(data, qm::io::Format::Stl, "fuzz");
});
