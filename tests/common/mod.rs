//! Shared helpers of the integration tests.
#![allow(dead_code)]

use std::path::PathBuf;

use qm::lift::glam::DVec3;

/// The quad meshes with subdivision connectivity made outside the project.
pub const QUAD_MODELS: [&str; 4] = [
    "cc_cube.obj",
    "cc_dodecahedron.obj",
    "torus_4x6_l4.obj",
    "holed_grid_l4.obj",
];

/// Path of a bundled asset.
pub fn asset(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../../assets")
        .join(name)
}

/// Root-mean-square distance between corresponding points.
pub fn rms(a: &[DVec3], b: &[DVec3]) -> f64 {
    assert_eq!(a.len(), b.len());
    (a.iter()
        .zip(b)
        .map(|(p, q)| p.distance_squared(*q))
        .sum::<f64>()
        / a.len() as f64)
        .sqrt()
}
