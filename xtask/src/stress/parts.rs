//! `parts300`: 300 separate closed parts (UV spheres, subdivided boxes,
//! tori) of 50 to 500 vertices each, rotated and placed on a jittered 3D
//! grid without overlaps.

use std::f64::consts::TAU;

use qm::lift::glam::{DQuat, DVec3};

use super::faceted::{grid_box, torus, uv_sphere};
use super::tris::{Tris, between};

/// `count` parts in cells of side 1 of a cubic grid: each fits in a ball of
/// radius 0.36 around its cell's centre, jittered by at most 0.1, so parts
/// are at least 0.08 apart.
pub(super) fn parts(count: usize) -> Tris {
    let side = (count as f64).cbrt().ceil() as usize;
    let mut all = Tris::default();
    for i in 0..count as u64 {
        let k = i as usize;
        let cell = DVec3::new(
            (k % side) as f64,
            (k / side % side) as f64,
            (k / side / side) as f64,
        );
        let size = between(31, i, 0.14, 0.36);
        let draw = |s: u64, lo: f64, hi: f64| between(32 + s, i, lo, hi);
        let mut part = match i % 3 {
            0 => uv_sphere(draw(0, 6.0, 17.0) as u32, draw(1, 10.0, 31.0) as u32),
            1 => {
                // Half extents up to 1/sqrt(3) keep the box inside the ball.
                let half = DVec3::new(draw(2, 0.3, 0.577), draw(3, 0.3, 0.577), 0.577);
                grid_box(draw(4, 3.0, 9.99) as u32, half)
            }
            _ => {
                let r = draw(5, 0.2, 0.45);
                // Scaled so the outer radius 1 + r is 1.
                let mut t = torus(draw(6, 9.0, 29.0) as u32, draw(7, 6.0, 17.0) as u32, r);
                t.positions.iter_mut().for_each(|p| *p /= 1.0 + r);
                t
            }
        };
        let axis = DVec3::new(draw(8, -1.0, 1.0), draw(9, -1.0, 1.0), draw(10, -1.0, 1.0));
        let turn =
            DQuat::from_axis_angle(axis.try_normalize().unwrap_or(DVec3::Z), draw(11, 0.0, TAU));
        let jitter = DVec3::new(
            draw(12, -0.1, 0.1),
            draw(13, -0.1, 0.1),
            draw(14, -0.1, 0.1),
        );
        for p in &mut part.positions {
            *p = cell + jitter + turn * (*p * size);
        }
        all.append(&part);
    }
    all
}

#[cfg(test)]
mod tests {
    use qm::PolyMesh;
    use qm::param::{TriMesh, clean};

    use super::super::topology::Topology;
    use super::*;

    /// The remesher's components of the 300 parts.
    fn components(all: &Tris) -> Vec<TriMesh> {
        clean::clean(&PolyMesh::from_faces(all.positions.clone(), &all.faces))
            .unwrap()
            .components
    }

    #[test]
    fn parts_are_separate_and_closed() {
        let all = parts(300);
        let t = Topology::of(&all);
        assert!(t.whole.manifold, "{t}");
        assert_eq!((t.parts.len(), t.whole.boundary_edges), (300, 0), "{t}");
        let mut tori = 0;
        for p in &t.parts {
            assert!((50..=500).contains(&p.vertices), "{p:?}");
            assert!(p.manifold && p.is_closed(), "{p:?}");
            match p.genus {
                0 => {}
                1 => tori += 1,
                _ => panic!("{p:?}"),
            }
        }
        assert_eq!(tori, 100);
    }

    #[test]
    fn parts_do_not_overlap() {
        // The parts' bounding balls (around their mean vertex) are disjoint.
        let balls: Vec<(DVec3, f64)> = components(&parts(300))
            .iter()
            .map(|part| {
                let ps = &part.positions;
                let c = ps.iter().sum::<DVec3>() / ps.len() as f64;
                (c, ps.iter().map(|p| p.distance(c)).fold(0.0, f64::max))
            })
            .collect();
        assert_eq!(balls.len(), 300);
        for (i, a) in balls.iter().enumerate() {
            for b in &balls[i + 1..] {
                assert!(a.0.distance(b.0) > a.1 + b.1, "{a:?} {b:?}");
            }
        }
    }
}
