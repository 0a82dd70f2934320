//! The high-valence fuzz target's input, shared with `tests/fuzz_replay.rs`:
//! a hub of many triangles, or an n-gon, built from bytes and made
//! semi-regular by clean-up and the remesher.
//!
//! Input layout (short inputs are padded with zeros):
//! bytes 0-1: `n = 3 + (little-endian u16) % 600` rim vertices;
//! byte 2: the shape, `b % 4`: one n-gon face, a fan-capped cylinder, a
//! cone (a fan around an apex over an n-gon base), a fan of `n` triangles
//! around a hub left open; byte 3: the jitter `10^-(b % 8)`;
//! byte 4: the unit `10^(5 (b % 128 - 64))`, clamped as in `remesh_input`;
//! then one byte a rim vertex, its radial jitter `(b - 128) / 128` times
//! the jitter (a rim that zigzags, folds on itself at large jitters).

use std::f64::consts::TAU;

use qm::lift::glam::DVec3;

/// Makes the input's mesh semi-regular: `Ok` or `Err`, never a panic.
pub fn run(data: &[u8]) {
    let mesh = input(data);
    let options = qm::RemeshOptions::DEFAULT
        .with_max_memory(256 << 20)
        .with_samples_per_vertex(8.0);
    if let Ok(prepared) = qm::prepare(&mesh, &options) {
        assert!(prepared.mesh.positions().iter().all(|p| p.is_finite()));
    }
}

/// The mesh that `data` describes.
pub fn input(data: &[u8]) -> qm::PolyMesh {
    let byte = |i: usize| data.get(i).copied().unwrap_or(0);
    let n = 3 + u32::from(u16::from_le_bytes([byte(0), byte(1)])) % 600;
    let jitter = 10f64.powi(-i32::from(byte(3) % 8));
    let unit = 10f64.powi((5 * (i32::from(byte(4) % 128) - 64)).clamp(-320, 305));
    let rim = |z: f64| -> Vec<DVec3> {
        (0..n)
            .map(|i| {
                let a = TAU * f64::from(i) / f64::from(n);
                let r = 1.0 + (f64::from(byte(5 + i as usize)) - 128.0) / 128.0 * jitter;
                DVec3::new(r * a.cos(), r * a.sin(), z) * unit
            })
            .collect()
    };
    let mut positions = rim(0.0);
    let mut faces: Vec<[u32; 3]> = Vec::new();
    let around = |hub: u32, offset: u32, flip: bool, faces: &mut Vec<[u32; 3]>| {
        for i in 0..n {
            let (a, b) = (offset + i, offset + (i + 1) % n);
            faces.push(if flip { [hub, b, a] } else { [hub, a, b] });
        }
    };
    match byte(2) % 4 {
        0 => {
            let mut mesh = qm::PolyMesh::from_faces::<3>(positions, &[]);
            mesh.push_face(&(0..n).collect::<Vec<u32>>());
            return mesh;
        }
        1 => {
            positions.extend(rim(2.0 * unit));
            positions.extend([DVec3::ZERO, DVec3::Z * 2.0 * unit]);
            for i in 0..n {
                let j = (i + 1) % n;
                faces.extend([[i, j, n + j], [i, n + j, n + i]]);
            }
            around(2 * n, 0, true, &mut faces);
            around(2 * n + 1, n, false, &mut faces);
        }
        2 => {
            positions.extend([DVec3::Z * unit, DVec3::ZERO]);
            around(n, 0, false, &mut faces);
            around(n + 1, 0, true, &mut faces);
        }
        _ => {
            positions.push(DVec3::Z * 0.3 * unit);
            around(n, 0, false, &mut faces);
        }
    }
    qm::PolyMesh::from_faces(positions, &faces)
}
