//! Synthetic semi-regular meshes, for tests and benchmarks.

use glam::DVec3;

use crate::{BaseMesh, Layout, SemiRegularMesh};

/// The base mesh of a cube: vertices 0..4 around the bottom face, 4..8
/// around the top, six faces counter-clockwise seen from outside.
pub fn cube() -> BaseMesh {
    BaseMesh::new(
        8,
        vec![
            [0, 3, 2, 1],
            [4, 5, 6, 7],
            [0, 1, 5, 4],
            [1, 2, 6, 5],
            [2, 3, 7, 6],
            [3, 0, 4, 7],
        ],
    )
    .expect("a cube is a valid base mesh")
}

/// A cube (six base quads, valence-3 corners) refined `level` times and
/// pushed out onto a sphere with a wavy relief: smooth at coarse scales,
/// detailed at fine ones, like a scanned surface.
pub fn bumpy_sphere(level: u32) -> SemiRegularMesh {
    let base = cube();
    // Vertices 0..4 go around the bottom face, 4..8 around the top.
    let corner = |v: u32| {
        let (x, y) = [(0.0, 0.0), (1.0, 0.0), (1.0, 1.0), (0.0, 1.0)][(v % 4) as usize];
        DVec3::new(x, y, (v / 4) as f64) * 2.0 - 1.0
    };
    let layout = Layout::new(base, level).expect("level within limits");
    let n = layout.n();
    let mut positions = vec![DVec3::ZERO; layout.sample_count()];
    for (f, face) in layout.base().faces().iter().enumerate() {
        let c = face.map(corner);
        for j in 0..=n {
            for i in 0..=n {
                let (u, v) = (i as f64 / n as f64, j as f64 / n as f64);
                let p = c[0] * (1.0 - u) * (1.0 - v)
                    + c[1] * u * (1.0 - v)
                    + c[2] * u * v
                    + c[3] * (1.0 - u) * v;
                let d = p.normalize();
                let relief =
                    1.0 + 0.05 * (7.0 * d.x).sin() * (5.0 * d.y).cos() + 0.01 * (23.0 * d.z).sin();
                positions[layout.sample(f, i, j) as usize] = d * relief;
            }
        }
    }
    SemiRegularMesh::new(layout, positions).expect("one position per sample")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shared_samples_get_one_position() {
        let mesh = bumpy_sphere(3);
        assert_eq!(mesh.positions().len(), 6 * 64 + 2);
        let r: Vec<f64> = mesh.positions().iter().map(|p| p.length()).collect();
        assert!(r.iter().all(|&r| (0.9..1.1).contains(&r)));
    }
}
