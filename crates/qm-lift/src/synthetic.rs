//! Synthetic semi-regular meshes, for tests and benchmarks. Plain meshes
//! (positions and faces, a `PolyMesh`) live in the dev-only crate `qm-shapes`.

use glam::DVec3;

use crate::{BaseMesh, Layout, SemiRegularMesh, split_triangles};

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
    // Vertices 0..4 go around the bottom face, 4..8 around the top.
    let corner = |v: u32| {
        let (x, y) = [(0.0, 0.0), (1.0, 0.0), (1.0, 1.0), (0.0, 1.0)][(v % 4) as usize];
        DVec3::new(x, y, (v / 4) as f64) * 2.0 - 1.0
    };
    bumpy(cube(), corner, level)
}

/// The eight faces of an octahedron, outward, its corners numbered in order
/// of first use: `+x +y +z -x -y -z`.
pub const OCTAHEDRON: [[u32; 3]; 8] = [
    [0, 1, 2],
    [1, 3, 2],
    [3, 4, 2],
    [4, 0, 2],
    [1, 0, 5],
    [3, 1, 5],
    [4, 3, 5],
    [0, 4, 5],
];

/// The octahedron's triangles split into three quads each
/// ([`split_triangles`]), and each base vertex's place on them: corners at
/// the unit axes, midpoints and centres on the flat triangles.
fn split_octahedron() -> (BaseMesh, Vec<DVec3>) {
    let axes = [
        DVec3::X,
        DVec3::Y,
        DVec3::Z,
        -DVec3::X,
        -DVec3::Y,
        -DVec3::Z,
    ];
    let split = split_triangles(&OCTAHEDRON);
    let mut places = vec![DVec3::ZERO; split.vertex_count as usize];
    for (q, face) in split.faces.iter().enumerate() {
        let t = OCTAHEDRON[q / 3].map(|c| axes[c as usize]);
        places[face[0] as usize] = t[q % 3];
        places[face[1] as usize] = (t[q % 3] + t[(q + 1) % 3]) / 2.0;
        places[face[2] as usize] = (t[0] + t[1] + t[2]) / 3.0;
    }
    let base = BaseMesh::new(split.vertex_count, split.faces).expect("a split is a valid base");
    (base, places)
}

/// An octahedron's own eight flat triangles, split into three quads each,
/// at level 0 (what the remesher makes of a faceted input), scaled by 1000
/// and moved off the origin so that quantization rounds every value.
pub fn flat_split_octahedron() -> SemiRegularMesh {
    let (base, places) = split_octahedron();
    let positions = places.iter().map(|&p| p * 1000.0 + 123.456).collect();
    let layout = Layout::new(base, 0).expect("level 0");
    SemiRegularMesh::new(layout, positions).expect("one position a sample")
}

/// The same relief on an octahedron whose triangles are split into three
/// quads each ([`split_triangles`]), as the remesher's charts make bases:
/// 24 base quads with corners of valence 4 and 3.
pub fn bumpy_split_octahedron(level: u32) -> SemiRegularMesh {
    let (base, places) = split_octahedron();
    bumpy(base, |v| places[v as usize], level)
}

/// `base` refined `level` times, each face bilinear between its corners'
/// places `corner(v)`, pushed out onto a sphere with a wavy relief.
fn bumpy(base: BaseMesh, corner: impl Fn(u32) -> DVec3, level: u32) -> SemiRegularMesh {
    refined(base, corner, level, |p| {
        let d = p.normalize();
        d * (1.0 + 0.05 * (7.0 * d.x).sin() * (5.0 * d.y).cos() + 0.01 * (23.0 * d.z).sin())
    })
}

/// `base` refined `level` times (at most [`crate::MAX_LEVEL`]), each face
/// bilinear between its corners' places `corner(v)`, every point then
/// moved to `shape(point)`; points on shared edges get one position.
pub fn refined(
    base: BaseMesh,
    corner: impl Fn(u32) -> DVec3,
    level: u32,
    shape: impl Fn(DVec3) -> DVec3,
) -> SemiRegularMesh {
    let layout = Layout::new(base, level).expect("level within limits");
    let n = layout.n();
    let mut positions = vec![DVec3::ZERO; layout.sample_count()];
    for (f, face) in layout.base().faces().iter().enumerate() {
        let c = face.map(&corner);
        for j in 0..=n {
            for i in 0..=n {
                let (u, v) = (i as f64 / n as f64, j as f64 / n as f64);
                let p = c[0] * (1.0 - u) * (1.0 - v)
                    + c[1] * u * (1.0 - v)
                    + c[2] * u * v
                    + c[3] * (1.0 - u) * v;
                positions[layout.sample(f, i, j) as usize] = shape(p);
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

    #[test]
    fn the_split_octahedron_is_a_sphere() {
        let mesh = bumpy_split_octahedron(2);
        // 26 base vertices, 48 edges of 3 inner samples, 24 faces of 9.
        assert_eq!(mesh.positions().len(), 26 + 48 * 3 + 24 * 9);
        // Numbered as the base coder's version 3 recognises a split.
        let base = mesh.layout().base();
        assert!(crate::unsplit(base.faces(), base.vertex_count()).is_some());
        let r: Vec<f64> = mesh.positions().iter().map(|p| p.length()).collect();
        assert!(r.iter().all(|&r| (0.9..1.1).contains(&r)));
    }
}
