//! Cylinders of radius 1 around the z axis: closed ones of height 2 whose
//! caps are fans of `n` triangles around a hub (a vertex of valence `n`, as
//! CAD exports make), in two vertex orders, and an open one in quads.

use std::f64::consts::TAU;

use glam::DVec3;

use crate::{Quads, Triangles, torus_quads};

/// A closed cylinder of `n` segments, vertex `2 i` at the bottom and
/// `2 i + 1` above it, then the bottom hub and the top hub. Segment by
/// segment: the side's two triangles, the bottom cap's, the top cap's.
pub fn cylinder(n: u32) -> Triangles {
    let mut positions = Vec::new();
    for i in 0..n {
        let a = TAU * i as f64 / n as f64;
        positions.push(DVec3::new(a.cos(), a.sin(), 0.0));
        positions.push(DVec3::new(a.cos(), a.sin(), 2.0));
    }
    positions.extend([DVec3::ZERO, DVec3::new(0.0, 0.0, 2.0)]);
    (positions, fan_capped(n, |i| 2 * i, |i| 2 * i + 1))
}

/// [`cylinder`] numbered ring by ring: the bottom ring, the top ring, then
/// the two hubs.
pub fn cylinder_ring_by_ring(n: u32) -> Triangles {
    let ring = |z: f64| {
        (0..n).map(move |i| {
            let a = TAU * f64::from(i) / f64::from(n);
            DVec3::new(a.cos(), a.sin(), z)
        })
    };
    let mut positions: Vec<DVec3> = ring(0.0).collect();
    positions.extend(ring(2.0));
    positions.extend([DVec3::ZERO, DVec3::new(0.0, 0.0, 2.0)]);
    (positions, fan_capped(n, |i| i, |i| n + i))
}

/// The triangles of a fan-capped cylinder whose segment `i` has the
/// vertices `bottom(i)` and `top(i)`, the hubs `2 n` and `2 n + 1`.
fn fan_capped(n: u32, bottom: impl Fn(u32) -> u32, top: impl Fn(u32) -> u32) -> Vec<[u32; 3]> {
    let (low, high) = (2 * n, 2 * n + 1);
    let mut faces = Vec::new();
    for i in 0..n {
        let j = (i + 1) % n;
        faces.extend([
            [bottom(i), bottom(j), top(j)],
            [bottom(i), top(j), top(i)],
            [low, bottom(j), bottom(i)],
            [high, top(i), top(j)],
        ]);
    }
    faces
}

/// An open cylinder, `a` quads around and `h` high, at heights `0..=h`:
/// no extraordinary vertex. Vertex `i + a k` is corner `i` of ring `k`; the
/// quads are [`torus_quads`]'s first `a h`.
pub fn open_cylinder_quads(a: u32, h: u32) -> Quads {
    let (mut positions, faces) = torus_quads(a, h + 1, 2.0, 1.0);
    for (v, p) in positions.iter_mut().enumerate() {
        let u = TAU * (v as u32 % a) as f64 / a as f64;
        *p = DVec3::new(u.cos(), u.sin(), (v as u32 / a) as f64);
    }
    let faces = faces.into_iter().take((a * h) as usize).collect();
    (positions, faces)
}
