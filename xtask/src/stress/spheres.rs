//! `holes100` and `pocked`: subdivided icosahedra with holes, 100 round
//! ones around Fibonacci points or hundreds of one or two missing
//! triangles, pinched vertices pruned.

use std::collections::HashMap;
use std::f64::consts::PI;

use qm::lift::glam::DVec3;

use super::topology::{UnionFind, fans};
use super::tris::{Tris, between, unit};

/// Subdivisions of the holed sphere's icosahedron (40,962 vertices).
pub(super) const SPHERE_LEVEL: u32 = 6;
/// Subdivisions of the pocked sphere's icosahedron (10,242 vertices).
pub(super) const POCKED_LEVEL: u32 = 5;
/// Share of the pocked sphere's triangles missing.
pub(super) const POCKED_SHARE: f64 = 0.02;

/// A unit icosahedron subdivided `level` times, projected to the sphere.
fn icosphere(level: u32) -> Tris {
    let t = (1.0 + 5f64.sqrt()) / 2.0;
    let mut tris = Tris::default();
    for p in [
        [-1.0, t, 0.0],
        [1.0, t, 0.0],
        [-1.0, -t, 0.0],
        [1.0, -t, 0.0],
        [0.0, -1.0, t],
        [0.0, 1.0, t],
        [0.0, -1.0, -t],
        [0.0, 1.0, -t],
        [t, 0.0, -1.0],
        [t, 0.0, 1.0],
        [-t, 0.0, -1.0],
        [-t, 0.0, 1.0],
    ] {
        tris.push(DVec3::from(p).normalize());
    }
    tris.faces = vec![
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    for _ in 0..level {
        let mut mid: HashMap<(u32, u32), u32> = HashMap::new();
        let mut faces = Vec::with_capacity(4 * tris.faces.len());
        for f in std::mem::take(&mut tris.faces) {
            let mut m = [0u32; 3];
            for k in 0..3 {
                let (a, b) = (f[k], f[(k + 1) % 3]);
                m[k] = *mid.entry((a.min(b), a.max(b))).or_insert_with(|| {
                    let p = (tris.positions[a as usize] + tris.positions[b as usize]).normalize();
                    tris.push(p)
                });
            }
            faces.push([f[0], m[0], m[2]]);
            faces.push([f[1], m[1], m[0]]);
            faces.push([f[2], m[2], m[1]]);
            faces.push(m);
        }
        tris.faces = faces;
    }
    tris.orient(|c| c);
    tris
}

/// `n` well-spread unit vectors (a Fibonacci spiral).
fn fibonacci(n: usize) -> Vec<DVec3> {
    let golden = PI * (3.0 - 5f64.sqrt());
    (0..n)
        .map(|i| {
            let z = 1.0 - (2.0 * i as f64 + 1.0) / n as f64;
            let r = (1.0 - z * z).sqrt();
            let a = golden * i as f64;
            DVec3::new(r * a.cos(), r * a.sin(), z)
        })
        .collect()
}

pub(super) fn holed_sphere(level: u32, holes: usize) -> Tris {
    let mut tris = icosphere(level);
    let centres = fibonacci(holes);
    // Fibonacci points lie at least ~0.3 apart for 100 points; radii up to
    // 0.1 leave a band of faces between any two holes.
    let radii: Vec<f64> = (0..holes as u64)
        .map(|i| between(21, i, 0.06, 0.1))
        .collect();
    let pos = &tris.positions;
    tris.faces.retain(|f| {
        let c = (pos[f[0] as usize] + pos[f[1] as usize] + pos[f[2] as usize]).normalize();
        !centres
            .iter()
            .zip(&radii)
            .any(|(h, &r)| c.distance_squared(*h) < r * r)
    });
    prune_pinches(&mut tris);
    for p in &mut tris.positions {
        let bump = broad_bump(*p) + 0.006 * (23.0 * p.x).sin() * (19.0 * p.z + 1.0).sin();
        *p *= 1.0 + bump;
    }
    tris.compact();
    tris
}

/// The holed and pocked spheres' broad bumps, a share of the radius at `p`.
fn broad_bump(p: DVec3) -> f64 {
    0.02 * (5.0 * p.x + 1.0).sin() * (4.0 * p.y).cos() * (6.0 * p.z + 2.0).sin()
}

/// A scan with many small holes: `icosphere(level)` with the holed
/// sphere's broad bumps, its vertices moved by up to 0.3% of the radius
/// along the normal, and a `share` of its triangles dropped (then pinches
/// pruned).
pub(super) fn pocked_sphere(level: u32, share: f64) -> Tris {
    let mut tris = icosphere(level);
    let mut i = 0u64;
    tris.faces.retain(|_| {
        i += 1;
        unit(41, i) >= share
    });
    prune_pinches(&mut tris);
    for (i, p) in tris.positions.iter_mut().enumerate() {
        *p *= 1.0 + broad_bump(*p) + between(42, i as u64, -0.003, 0.003);
    }
    tris.compact();
    tris
}

/// Removes faces until no vertex is pinched: at a vertex where several fans
/// meet, all but the largest fan go.
fn prune_pinches(tris: &mut Tris) {
    loop {
        let counts = fans(tris);
        let pinched: Vec<u32> = (0..counts.len() as u32)
            .filter(|&v| counts[v as usize] > 1)
            .collect();
        if pinched.is_empty() {
            return;
        }
        let mut drop = vec![false; tris.faces.len()];
        for v in pinched {
            let around: Vec<usize> = (0..tris.faces.len())
                .filter(|&f| !drop[f] && tris.faces[f].contains(&v))
                .collect();
            // Group the faces at `v` into fans by shared edges through `v`.
            let mut uf = UnionFind::new(around.len());
            for (x, &fx) in around.iter().enumerate() {
                for (y, &fy) in around.iter().enumerate().skip(x + 1) {
                    let shared = tris.faces[fx]
                        .iter()
                        .filter(|&&w| w != v && tris.faces[fy].contains(&w))
                        .count();
                    if shared > 0 {
                        uf.union(x as u32, y as u32);
                    }
                }
            }
            let roots: Vec<u32> = (0..around.len() as u32).map(|x| uf.find(x)).collect();
            let size = |r: u32| roots.iter().filter(|&&s| s == r).count();
            let keep = *roots.iter().max_by_key(|&&r| (size(r), r)).unwrap();
            for (x, &f) in around.iter().enumerate() {
                if roots[x] != keep {
                    drop[f] = true;
                }
            }
        }
        let mut k = 0;
        tris.faces.retain(|_| {
            k += 1;
            !drop[k - 1]
        });
    }
}

#[cfg(test)]
mod tests {
    use super::super::topology::Topology;
    use super::*;

    #[test]
    fn sphere_has_a_hundred_holes() {
        let t = Topology::of(&holed_sphere(5, 100));
        assert!(t.whole.manifold, "{t}");
        assert_eq!(t.parts.len(), 1, "{t}");
        assert_eq!(t.whole.boundary_loops, 100, "{t}");
        assert_eq!(t.genus(), Some(0), "{t}");
    }

    #[test]
    fn pocked_sphere_has_hundreds_of_small_holes() {
        let tris = pocked_sphere(POCKED_LEVEL, POCKED_SHARE);
        let t = Topology::of(&tris);
        assert!(t.whole.manifold, "{t}");
        assert_eq!(t.parts.len(), 1, "{t}");
        assert!(t.whole.boundary_loops >= 300, "{t}");
        // Small holes: one or two missing triangles each, on average.
        assert!(t.whole.boundary_edges <= 5 * t.whole.boundary_loops, "{t}");
        assert_eq!(t.genus(), Some(0), "{t}");
    }
}
