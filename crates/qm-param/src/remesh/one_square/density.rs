//! The sample density a part's square aims for: curvature-driven, so that
//! curved regions get more samples and flat ones fewer.
//!
//! Interpolating a surface of curvature `k` with samples `h` apart errs by
//! about `k h^2`; with the density `rho = 1 / h^2` free, the squared error
//! `integral of k^2 / rho^2` over a fixed sample count is least for
//! `rho ~ k^(2/3)` (see [`density`]).

use qm_lift::glam::DVec3;

use crate::TriMesh;
use crate::remesh::cut;

/// Floor of the curvature that sets the sample density, relative to the
/// mean curvature (see [`density`]): lower starves flat parts, higher gives
/// away the gain of curved ones (docs/decisions/002-sample-density-floor.md).
const DENSITY_FLOOR: f64 = 0.3;

/// Per triangle, the sample density to aim for, relative to the mean (the
/// area-weighted mean of the result is 1): `rho ~ k^(2/3)` (see the module
/// documentation), with `k` the curvature. On a triangle mesh the curvature
/// sits on the edges: each vertex gets the dihedral angles of its edges
/// times their half-lengths over its area (the integral of the absolute mean
/// curvature, doubled), smoothed over about one sample spacing. A floor of
/// [`DENSITY_FLOOR`] times the mean curvature keeps flat parts sampled.
pub(super) fn density(mesh: &TriMesh, topo: &cut::Topology, spacing: f64) -> Vec<f64> {
    let nv = mesh.positions.len();
    let p = |v: u32| mesh.positions[v as usize];
    let normal: Vec<DVec3> = mesh
        .triangles
        .iter()
        .map(|t| (p(t[1]) - p(t[0])).cross(p(t[2]) - p(t[0])))
        .collect();
    let area: Vec<f64> = normal.iter().map(|n| n.length() / 2.0).collect();
    let mut varea = vec![0.0; nv];
    for (t, &a) in mesh.triangles.iter().zip(&area) {
        for &v in t {
            varea[v as usize] += a / 3.0;
        }
    }
    let mut bend = vec![0.0; nv];
    let mut edge_sum = 0.0;
    for (e, &[a, b]) in topo.edges.iter().enumerate() {
        let len = p(a).distance(p(b));
        edge_sum += len;
        let [f, g] = topo.edge_faces[e];
        if g == u32::MAX {
            continue;
        }
        let theta = normal[f as usize].angle_between(normal[g as usize]);
        if theta.is_finite() {
            bend[a as usize] += theta * len / 2.0;
            bend[b as usize] += theta * len / 2.0;
        }
    }
    let mean_edge = edge_sum / topo.edges.len().max(1) as f64;
    // Curvature per triangle, then smoothed over about the sample spacing.
    let mut kappa: Vec<f64> = mesh
        .triangles
        .iter()
        .map(|t| {
            let (b, a): (f64, f64) = t
                .iter()
                .map(|&v| (bend[v as usize], varea[v as usize]))
                .fold((0.0, 0.0), |s, x| (s.0 + x.0, s.1 + x.1));
            if a > 0.0 { b / a } else { 0.0 }
        })
        .collect();
    // Each round spreads the curvature by about one edge length.
    let rounds = (spacing / mean_edge.max(1e-300)).powi(2).round().min(16.0) as usize;
    for _ in 0..rounds {
        let mut vs = vec![(0.0, 0.0); nv];
        for (f, t) in mesh.triangles.iter().enumerate() {
            for &v in t {
                vs[v as usize].0 += kappa[f] * area[f];
                vs[v as usize].1 += area[f];
            }
        }
        for (f, t) in mesh.triangles.iter().enumerate() {
            let (s, a) = t
                .iter()
                .map(|&v| vs[v as usize])
                .fold((0.0, 0.0), |s, x| (s.0 + x.0, s.1 + x.1));
            kappa[f] = if a > 0.0 { s / a } else { 0.0 };
        }
    }
    let total: f64 = area.iter().sum();
    let mean = kappa.iter().zip(&area).map(|(k, a)| k * a).sum::<f64>() / total.max(1e-300);
    let mut d: Vec<f64> = kappa
        .iter()
        .map(|k| (k + DENSITY_FLOOR * mean).powf(2.0 / 3.0))
        .collect();
    let norm = d.iter().zip(&area).map(|(d, a)| d * a).sum::<f64>() / total.max(1e-300);
    if norm > 0.0 && norm.is_finite() {
        for x in &mut d {
            *x /= norm;
        }
    } else {
        d.fill(1.0);
    }
    d
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn density_follows_the_creases_and_averages_one() {
        // A folded strip: two flat halves meeting at a right angle along
        // x = 0, triangles away from the fold far from it.
        let mut positions = Vec::new();
        for j in 0..3 {
            for i in -4i32..=4 {
                let x = i as f64;
                let p = if i <= 0 {
                    DVec3::new(x, j as f64, 0.0)
                } else {
                    DVec3::new(0.0, j as f64, x)
                };
                positions.push(p);
            }
        }
        let mesh = TriMesh {
            positions,
            triangles: qm_shapes::grid_triangles(8, 2),
        };
        let topo = cut::Topology::new(&mesh);
        let d = density(&mesh, &topo, 0.5);
        let area: Vec<f64> = mesh
            .triangles
            .iter()
            .map(|t| crate::triangle_area(t.map(|v| mesh.positions[v as usize])))
            .collect();
        let mean = d.iter().zip(&area).map(|(d, a)| d * a).sum::<f64>() / area.iter().sum::<f64>();
        assert!((mean - 1.0).abs() < 1e-12, "mean density {mean}");
        // Triangle 6 and 7 touch the fold (columns 3..4 end at x = 0);
        // triangles 0 and 1 lie four edges away from it.
        assert!(d[7] > 2.0 * d[0], "{d:?}");
        assert!(d.iter().all(|&x| x > 0.0));
    }
}
