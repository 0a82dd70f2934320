//! Tori: `major` segments around the axis (angle `u`), `minor` around the
//! tube (angle `v`), the point `((R + r cos v) cos u, (R + r cos v) sin u,
//! r sin v)` for the major radius `R` and the minor radius `r`. The three
//! variants differ in vertex order, in how the angles are computed (which
//! can differ in the last bit) and in triangles or quads: tests pin each.

use std::f64::consts::TAU;

use glam::DVec3;

use crate::{Quads, Triangles, cell_quads, cell_triangles, rows};

/// A torus in triangles, vertex `(i, j)` at `j * major + i`, the angles
/// `i / major * 2 pi` and `j / minor * 2 pi`, the minor radius
/// `minor_radius(u, v)`; cell by cell, `j` outer, two triangles each.
pub fn torus(
    major: u32,
    minor: u32,
    major_radius: f64,
    minor_radius: impl Fn(f64, f64) -> f64,
) -> Triangles {
    let (n, m) = (major, minor);
    let mut positions = Vec::with_capacity((n * m) as usize);
    for j in 0..m {
        for i in 0..n {
            let (u, v) = (i as f64 / n as f64 * TAU, j as f64 / m as f64 * TAU);
            let r = minor_radius(u, v);
            positions.push(DVec3::new(
                (major_radius + r * v.cos()) * u.cos(),
                (major_radius + r * v.cos()) * u.sin(),
                r * v.sin(),
            ));
        }
    }
    let id = |i: u32, j: u32| (j % m) * n + (i % n);
    (positions, cell_triangles(rows(n, m), id))
}

/// A torus in quads, numbered as [`torus`] but with the angles
/// `2 pi i / major` and `2 pi j / minor`; one quad a cell, `j` outer.
pub fn torus_quads(major: u32, minor: u32, major_radius: f64, minor_radius: f64) -> Quads {
    let id = |i: u32, j: u32| (i % major) + major * (j % minor);
    let mut positions = Vec::new();
    for j in 0..minor {
        for i in 0..major {
            let (u, v) = (TAU * i as f64 / major as f64, TAU * j as f64 / minor as f64);
            positions.push(DVec3::new(
                (major_radius + minor_radius * v.cos()) * u.cos(),
                (major_radius + minor_radius * v.cos()) * u.sin(),
                minor_radius * v.sin(),
            ));
        }
    }
    (positions, cell_quads(rows(major, minor), id))
}

/// A torus in triangles listed ring by ring around the tube: vertex
/// `(i, j)` at `i * minor + j`, the angles `2 pi i / major` and
/// `2 pi j / minor`, the minor radius `minor_radius(u, v)`; cell by cell,
/// `i` outer, two triangles each.
pub fn torus_ring_by_ring(
    major: u32,
    minor: u32,
    major_radius: f64,
    minor_radius: impl Fn(f64, f64) -> f64,
) -> Triangles {
    let mut positions = Vec::new();
    for i in 0..major {
        let u = TAU * i as f64 / major as f64;
        for j in 0..minor {
            let v = TAU * j as f64 / minor as f64;
            let r = minor_radius(u, v);
            let ring = major_radius + r * v.cos();
            positions.push(DVec3::new(ring * u.cos(), ring * u.sin(), r * v.sin()));
        }
    }
    let at = |i: u32, j: u32| (i % major) * minor + j % minor;
    // Cells tube ring by tube ring: `i` outer.
    let cells = (0..major).flat_map(|i| (0..minor).map(move |j| (i, j)));
    (positions, cell_triangles(cells, at))
}
