//! Arbitrary bytes through the glTF reader (GLB or JSON, told apart by the
//! magic), geometry alone and with appearance, images decoded: `Ok` or
//! `Err`, never a panic.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let _ = qm::io::read_mesh_bytes(data, qm::io::Format::Glb, "fuzz");
    let images = qm::io::AssetOptions::DEFAULT.with_images(true);
    let _ = qm::io::read_asset_bytes(data, qm::io::Format::Glb, "fuzz", &images);
});
