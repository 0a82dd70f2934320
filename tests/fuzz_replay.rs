//! Replays the fuzz seeds and any saved fuzz findings as ordinary tests: each
//! input goes to its target's entry point, which must return, not panic.

use std::path::{Path, PathBuf};

use qm::io::{AssetOptions, Format, read_asset_bytes, read_mesh_bytes};

#[path = "../fuzz/fuzz_targets/remesh_hub_input.rs"]
mod remesh_hub_input;
#[path = "../fuzz/fuzz_targets/remesh_input.rs"]
mod remesh_input;

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// Runs one input through the entry point of fuzz target `target`.
fn replay(target: &str, bytes: &[u8]) {
    let format = |f| {
        let _ = read_mesh_bytes(bytes, f, "fuzz");
        let images = AssetOptions::DEFAULT.with_images(true);
        let _ = read_asset_bytes(bytes, f, "fuzz", &images);
    };
    match target {
        "decode" => {
            let limits = qm::Limits::DEFAULT.with_max_samples(1 << 12);
            let _ = qm::codec::container::read(bytes, &limits);
            let _ = qm::codec::decompress(bytes, &qm::DecodeOptions::default().with_limits(limits));
        }
        "obj" => format(Format::Obj),
        "ply" => format(Format::Ply),
        "gltf" => format(Format::Glb),
        "off" => format(Format::Off),
        "stl" => format(Format::Stl),
        "remesh" => remesh_input::run(bytes),
        "remesh_hub" => remesh_hub_input::run(bytes),
        // The round-trip target builds meshes from its bytes; its seeds are
        // replayed by the fuzzer itself.
        _ => {}
    }
}

fn files(dir: &Path) -> Vec<PathBuf> {
    let mut found: Vec<PathBuf> = std::fs::read_dir(dir)
        .map(|entries| {
            entries
                .filter_map(|e| e.ok().map(|e| e.path()))
                .filter(|p| p.is_file())
                .collect()
        })
        .unwrap_or_default();
    found.sort();
    found
}

#[test]
fn fuzz_seeds_and_findings_do_not_panic() {
    let mut count = 0;
    for target in [
        "decode",
        "obj",
        "ply",
        "gltf",
        "off",
        "stl",
        "remesh",
        "remesh_hub",
    ] {
        for path in files(&root().join("fuzz/corpus").join(target)) {
            let bytes = std::fs::read(&path).unwrap();
            let result = std::panic::catch_unwind(|| replay(target, &bytes));
            assert!(result.is_ok(), "{} panics", path.display());
            count += 1;
        }
    }
    for path in files(&root().join("tests/fuzz_findings")) {
        let name = path.file_name().unwrap().to_string_lossy().into_owned();
        let Some((target, _)) = name.split_once('-') else {
            continue;
        };
        let bytes = std::fs::read(&path).unwrap();
        let result = std::panic::catch_unwind(|| replay(target, &bytes));
        assert!(result.is_ok(), "{name} panics");
        count += 1;
    }
    assert!(
        count >= 20,
        "only {count} inputs replayed: is fuzz/corpus missing?"
    );
}
