//! Arbitrary bytes through the OBJ reader, geometry alone and with appearance:
//! `Ok` or `Err`, never a panic.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let _ = qm::io::read_mesh_bytes(data, qm::io::Format::Obj, "fuzz");
    let images = qm::io::AssetOptions::DEFAULT.with_images(true);
    let _ = qm::io::read_asset_bytes(data, qm::io::Format::Obj, "fuzz", &images);
});
