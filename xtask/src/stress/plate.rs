//! `genus12`: a closed, wavy plate with a 4 x 3 grid of holes, the zero
//! set of a signed distance function extracted by marching tetrahedra
//! ([`marching_tetrahedra`]).

use std::collections::HashMap;

use qm::lift::glam::DVec3;

use super::tris::{Tris, between};

/// Grid step of the genus-12 plate's marching tetrahedra (~60k vertices).
pub(super) const PLATE_STEP: f64 = 0.052;

/// Polynomial smooth minimum with blend width `k`.
fn smin(a: f64, b: f64, k: f64) -> f64 {
    let h = (0.5 + 0.5 * (b - a) / k).clamp(0.0, 1.0);
    b + (a - b) * h - k * h * (1.0 - h)
}

fn smax(a: f64, b: f64, k: f64) -> f64 {
    -smin(-a, -b, k)
}

/// Half extents of the plate (before the wave).
const PLATE: DVec3 = DVec3::new(2.3, 1.8, 0.2);

/// The plate's hole centres and radii: a 4 x 3 grid, radii varied.
fn plate_holes() -> Vec<(f64, f64, f64)> {
    let mut holes = Vec::new();
    for j in 0..3 {
        for i in 0..4 {
            let k = (j * 4 + i) as u64;
            let x = -1.5 + i as f64 + between(11, k, -0.08, 0.08);
            let y = -1.1 + 1.1 * j as f64 + between(12, k, -0.08, 0.08);
            holes.push((x, y, between(13, k, 0.22, 0.36)));
        }
    }
    holes
}

/// Signed distance (roughly) to the wavy plate: negative inside.
fn plate_sdf(p: DVec3, holes: &[(f64, f64, f64)]) -> f64 {
    let p = DVec3::new(
        p.x,
        p.y,
        p.z - 0.18 * (1.3 * p.x).sin() * (1.1 * p.y + 0.4).cos(),
    );
    let r = 0.15;
    let q = p.abs() - (PLATE - r);
    let slab = q.max(DVec3::ZERO).length() + q.max_element().min(0.0) - r;
    let hole = holes
        .iter()
        .map(|&(x, y, radius)| (p.truncate() - qm::lift::glam::DVec2::new(x, y)).length() - radius)
        .fold(f64::INFINITY, f64::min);
    smax(slab, -hole, 0.08)
}

pub(super) fn genus_plate(step: f64) -> Tris {
    let holes = plate_holes();
    let lo = -(PLATE + DVec3::new(0.1, 0.1, 0.35));
    let hi = -lo;
    marching_tetrahedra(lo, hi, step, |p| plate_sdf(p, &holes))
}

/// The zero set of `f` (negative inside) on a grid of cubes of side `step`
/// over the box `lo..hi`, each cube cut into six tetrahedra around its
/// main diagonal (the same cut in every cube, so neighbours agree on the
/// shared faces). A vertex is made once per grid edge the surface crosses,
/// so the result is closed wherever `f > 0` on the box's border.
pub fn marching_tetrahedra(lo: DVec3, hi: DVec3, step: f64, f: impl Fn(DVec3) -> f64) -> Tris {
    let n = ((hi - lo) / step).ceil().as_uvec3() + 1;
    let (nx, ny, nz) = (n.x as usize, n.y as usize, n.z as usize);
    let id = |i: usize, j: usize, k: usize| (k * ny + j) * nx + i;
    let point = |i: usize, j: usize, k: usize| lo + DVec3::new(i as f64, j as f64, k as f64) * step;
    let mut value = vec![0.0; nx * ny * nz];
    for k in 0..nz {
        for j in 0..ny {
            for i in 0..nx {
                let v = f(point(i, j, k));
                // Keep values off zero so every crossing lies inside an edge.
                value[id(i, j, k)] = if v.abs() < 1e-12 { 1e-12 } else { v };
            }
        }
    }
    let mut tris = Tris::default();
    let mut on_edge: HashMap<(usize, usize), u32> = HashMap::new();
    let mut cross = |tris: &mut Tris, a: usize, b: usize, pa: DVec3, pb: DVec3| -> u32 {
        let key = (a.min(b), a.max(b));
        *on_edge.entry(key).or_insert_with(|| {
            let (fa, fb) = (value[a], value[b]);
            // Kept off the ends so no two vertices nearly coincide.
            let t = (fa / (fa - fb)).clamp(0.01, 0.99);
            tris.push(pa + (pb - pa) * t)
        })
    };
    // The six tetrahedra: paths from corner 0 to corner 7 along the axes.
    const PATHS: [[usize; 3]; 6] = [
        [0, 1, 2],
        [0, 2, 1],
        [1, 0, 2],
        [1, 2, 0],
        [2, 0, 1],
        [2, 1, 0],
    ];
    for k in 0..nz - 1 {
        for j in 0..ny - 1 {
            for i in 0..nx - 1 {
                for path in PATHS {
                    let mut c = [i, j, k];
                    let mut corners = [(0usize, DVec3::ZERO); 4];
                    corners[0] = (id(c[0], c[1], c[2]), point(c[0], c[1], c[2]));
                    for (s, &axis) in path.iter().enumerate() {
                        c[axis] += 1;
                        corners[s + 1] = (id(c[0], c[1], c[2]), point(c[0], c[1], c[2]));
                    }
                    let (inside, outside): (Vec<_>, Vec<_>) =
                        corners.iter().partition(|&&(v, _)| value[v] < 0.0);
                    let before = tris.faces.len();
                    match inside.len() {
                        1 | 3 => {
                            let (one, three) = if inside.len() == 1 {
                                (inside[0], &outside)
                            } else {
                                (outside[0], &inside)
                            };
                            let v: Vec<u32> = (three.iter())
                                .map(|&&(w, pw)| cross(&mut tris, one.0, w, one.1, pw))
                                .collect();
                            tris.faces.push([v[0], v[1], v[2]]);
                        }
                        2 => {
                            let (a, b, c, d) = (inside[0], inside[1], outside[0], outside[1]);
                            let ac = cross(&mut tris, a.0, c.0, a.1, c.1);
                            let ad = cross(&mut tris, a.0, d.0, a.1, d.1);
                            let bd = cross(&mut tris, b.0, d.0, b.1, d.1);
                            let bc = cross(&mut tris, b.0, c.0, b.1, c.1);
                            tris.faces.push([ac, ad, bd]);
                            tris.faces.push([ac, bd, bc]);
                        }
                        _ => {}
                    }
                    // Outward is from the inside corners to the outside ones.
                    let centre = |s: &[&(usize, DVec3)]| {
                        s.iter().map(|c| c.1).sum::<DVec3>() / s.len().max(1) as f64
                    };
                    let out = centre(&outside) - centre(&inside);
                    for f in &mut tris.faces[before..] {
                        let [a, b, c] = f.map(|v| tris.positions[v as usize]);
                        if (b - a).cross(c - a).dot(out) < 0.0 {
                            f.swap(1, 2);
                        }
                    }
                }
            }
        }
    }
    tris
}

#[cfg(test)]
mod tests {
    use super::super::topology::Topology;
    use super::*;

    #[test]
    fn plate_has_genus_twelve() {
        let t = Topology::of(&genus_plate(0.07));
        assert!(t.whole.manifold, "{t}");
        assert_eq!((t.parts.len(), t.whole.boundary_edges), (1, 0), "{t}");
        assert_eq!(t.genus(), Some(12), "{t}");
    }

    #[test]
    fn marching_tetrahedra_makes_a_sphere() {
        let t = Topology::of(&marching_tetrahedra(
            DVec3::splat(-1.3),
            DVec3::splat(1.3),
            0.1,
            |p| p.length() - 1.0,
        ));
        assert!(t.whole.manifold, "{t}");
        assert_eq!((t.parts.len(), t.whole.boundary_edges), (1, 0), "{t}");
        assert_eq!(t.genus(), Some(0), "{t}");
    }
}
