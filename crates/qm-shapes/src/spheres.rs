//! UV (latitude-longitude) spheres: `rings` bands from pole to pole,
//! `segments` around. Ring `i` (1 to `rings - 1`) lies at the polar angle
//! `theta = pi i / rings`, segment `j` at `phi = 2 pi j / segments`, on
//! `radius (sin theta cos phi, sin theta sin phi, cos theta)`. The four
//! variants differ in where the poles are numbered, in the faces' order and
//! kind, and in the radius: tests pin each.

use std::f64::consts::{PI, TAU};

use glam::DVec3;
use qm_io::PolyMesh;

use crate::Triangles;

/// A UV sphere of radius `radius`: the north pole, the rings from the north,
/// the south pole last; each pole's cap in triangles (first a triangle at
/// the north, then one at the south, segment by segment), then the bands
/// between the rings in quads, ring by ring.
pub fn uv_sphere(rings: u32, segments: u32, radius: f64) -> PolyMesh {
    let mut positions = vec![DVec3::new(0.0, 0.0, radius)];
    positions.extend(ring_points(rings, segments, |_, _| radius));
    positions.push(DVec3::new(0.0, 0.0, -radius));
    let south = positions.len() as u32 - 1;
    let at = |i: u32, j: u32| 1 + (i - 1) * segments + j % segments;
    let mut mesh = PolyMesh::from_faces(positions, &[] as &[[u32; 3]]);
    for j in 0..segments {
        mesh.push_face(&[0, at(1, j), at(1, j + 1)]);
        mesh.push_face(&[south, at(rings - 1, j + 1), at(rings - 1, j)]);
    }
    for i in 1..rings - 1 {
        for j in 0..segments {
            mesh.push_face(&[at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j + 1)]);
        }
    }
    mesh
}

/// A unit UV sphere in triangles: the north pole `+z`, the rings from the
/// north, the south pole last as `-z` negated whole (its x and y are -0.0).
/// Segment by segment: the north cap's triangle, the south cap's, then down
/// the rings each band's quad as two triangles.
pub fn uv_sphere_triangles(rings: u32, segments: u32) -> Triangles {
    let mut positions = vec![DVec3::Z];
    positions.extend(ring_points(rings, segments, |_, _| 1.0));
    positions.push(-DVec3::Z);
    let south = positions.len() as u32 - 1;
    (positions, band_triangles(rings, segments, [0, south, 1]))
}

/// [`uv_sphere_triangles`] with both poles first: vertex 0 the north pole,
/// 1 the south pole `(0, 0, -1)`, the rings from 2.
pub fn uv_sphere_poles_first(rings: u32, segments: u32) -> PolyMesh {
    let mut positions = vec![DVec3::Z, DVec3::NEG_Z];
    positions.extend(ring_points(rings, segments, |_, _| 1.0));
    PolyMesh::from_faces(positions, &band_triangles(rings, segments, [0, 1, 2]))
}

/// A closed radial surface: a UV sphere whose radius in each direction is
/// `radius(theta, phi)` (at the poles `radius(0, 0)` and `radius(pi, 0)`),
/// numbered as [`uv_sphere`]. Segment by segment: the north cap's triangle,
/// down the rings each band's quad as two triangles, then the south cap's.
pub fn uv_sphere_radial(rings: u32, segments: u32, radius: impl Fn(f64, f64) -> f64) -> Triangles {
    let mut positions = vec![DVec3::new(0.0, 0.0, radius(0.0, 0.0))];
    positions.extend(ring_points(rings, segments, &radius));
    positions.push(DVec3::new(0.0, 0.0, -radius(PI, 0.0)));
    let ring = |i: u32, j: u32| 1 + (i - 1) * segments + j % segments;
    let last = positions.len() as u32 - 1;
    let mut triangles = Vec::new();
    for j in 0..segments {
        triangles.push([0, ring(1, j), ring(1, j + 1)]);
        for i in 1..rings - 1 {
            triangles.push([ring(i, j), ring(i + 1, j), ring(i + 1, j + 1)]);
            triangles.push([ring(i, j), ring(i + 1, j + 1), ring(i, j + 1)]);
        }
        triangles.push([ring(rings - 1, j), last, ring(rings - 1, j + 1)]);
    }
    (positions, triangles)
}

/// The ring vertices, ring by ring from the north, each `radius(theta, phi)`
/// times its direction.
fn ring_points(rings: u32, segments: u32, radius: impl Fn(f64, f64) -> f64) -> Vec<DVec3> {
    let mut positions = Vec::new();
    for i in 1..rings {
        let theta = PI * i as f64 / rings as f64;
        for j in 0..segments {
            let phi = TAU * j as f64 / segments as f64;
            positions.push(
                radius(theta, phi)
                    * DVec3::new(
                        theta.sin() * phi.cos(),
                        theta.sin() * phi.sin(),
                        theta.cos(),
                    ),
            );
        }
    }
    positions
}

/// The triangles of a UV sphere whose poles are `north` and `south` and
/// whose rings start at vertex `first`: segment by segment, the north cap's
/// triangle, the south cap's, then down the rings two triangles a band.
fn band_triangles(rings: u32, segments: u32, [north, south, first]: [u32; 3]) -> Vec<[u32; 3]> {
    let at = |r: u32, s: u32| first + (r - 1) * segments + s % segments;
    let mut faces = Vec::new();
    for s in 0..segments {
        faces.push([north, at(1, s), at(1, s + 1)]);
        faces.push([south, at(rings - 1, s + 1), at(rings - 1, s)]);
        for r in 1..rings - 1 {
            faces.push([at(r, s), at(r + 1, s), at(r + 1, s + 1)]);
            faces.push([at(r, s), at(r + 1, s + 1), at(r, s + 1)]);
        }
    }
    faces
}
