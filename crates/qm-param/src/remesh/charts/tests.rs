//! Tests of the charts: the lookup among drawn triangles, the untangling
//! and relaxation of the map, and remeshes through charts.

use qm_lift::glam::{DVec2, DVec3};

use super::drawn::{Drawn, drawn_right};
use super::map::Map;
use super::relax::{Knots, colours, relax_stretch, untangle_knots};
use super::star::Domain;
use super::untangle::untangle_map;
use crate::clean::topology;
use crate::remesh::simplify::{Base, Location};
use crate::remesh::{BaseDomain, RemeshOptions, remesh};
use crate::{Error, PolyMesh, RemeshFailure, TriMesh};

/// Where drawn triangles overlap, a point is looked up on the smallest
/// that holds it, wherever it comes in the list; outside all, on the
/// nearest.
#[test]
fn overlapping_drawn_triangles_give_the_smallest() {
    let v = DVec2::new;
    let big = [v(-10.0, -10.0), v(10.0, -10.0), v(0.0, 10.0)];
    let small = [v(-0.5, -0.5), v(0.5, -0.5), v(0.0, 0.5)];
    let middle = [v(-2.0, -2.0), v(2.0, -2.0), v(0.0, 2.0)];
    let drawn = Drawn::new(vec![(7, big), (8, middle), (9, small)]);
    assert_eq!(drawn.nearest(v(0.0, 0.0)).map(|h| h.1), Some(9));
    assert_eq!(drawn.nearest(v(0.0, 1.0)).map(|h| h.1), Some(8));
    assert_eq!(drawn.nearest(v(0.0, 5.0)).map(|h| h.1), Some(7));
    let (worst, t, _) = drawn.nearest(v(0.0, 11.0)).unwrap();
    assert!(worst < 0.0 && t == 7);
}

/// A torus of `m x n` vertices, radii 1 and 0.35, a little bumpy.
fn torus(m: u32, n: u32) -> PolyMesh {
    let minor = |u: f64, v: f64| 0.35 + 0.03 * (3.0 * u).sin() * (2.0 * v).cos();
    qm_shapes::poly(qm_shapes::torus_ring_by_ring(m, n, 1.0, minor))
}

fn options() -> RemeshOptions {
    RemeshOptions::DEFAULT.with_domain(BaseDomain::Charts)
}

/// The remesh as triangles (each quad split), for its topology.
fn triangles(r: &crate::remesh::Remeshed) -> TriMesh {
    let layout = r.mesh.layout();
    let triangles = layout
        .quads(layout.level())
        .iter()
        .flat_map(|q| [[q[0], q[1], q[2]], [q[0], q[2], q[3]]])
        .collect();
    TriMesh {
        positions: r.mesh.positions().to_vec(),
        triangles,
    }
}

#[test]
fn a_torus_remeshes_closed_with_its_genus_and_near_the_input() {
    let input = torus(48, 24);
    let r = remesh(&input, &options()).expect("remesh");
    assert_eq!(r.report.domain, "charts");
    let psnr = r.report.psnr.expect("measured");
    assert!(psnr > 70.0, "remesh at {psnr:.1} dB");
    let topo = topology(&triangles(&r));
    assert!(topo.manifold && topo.is_closed(), "{topo:?}");
    assert_eq!(topo.genus, 1);
    let samples = r.mesh.positions().len() as f64;
    assert!(samples <= crate::remesh::MAX_SAMPLES_PER_VERTEX * 48.0 * 24.0);
    assert!(r.report.components.iter().all(|c| c.flipped == 0));
}

/// A simplified sphere, its domain, and its map's fold count.
fn sphere_map() -> (TriMesh, Base) {
    let sphere = qm_shapes::uv_sphere_poles_first(24, 48);
    let mesh = crate::clean::clean(&sphere).unwrap().components.remove(0);
    let base = crate::remesh::simplify::simplify(&mesh, 40);
    (mesh, base)
}

fn folds(mesh: &TriMesh, domain: &Domain, base: &Base) -> usize {
    let knots = Knots::new(mesh, domain);
    (0..mesh.triangles.len() as u32)
        .filter(|&t| knots.folded(Map::new(base), t))
        .count()
}

fn free(base: &Base, v: u32) -> bool {
    matches!(base.location[v as usize], Location::Face(..)) && !base.feature[v as usize]
}

/// Swapped locations along input edges: the knots' energy alone
/// undoes them.
#[test]
fn swapped_vertices_come_undone() {
    let (mesh, mut base) = sphere_map();
    let domain = Domain::new(&mesh, &base).expect("stars");
    assert_eq!(folds(&mesh, &domain, &base), 0, "the simplification's map");
    let mut swapped = 0;
    for tri in mesh.triangles.iter().step_by(97) {
        let [a, b, _] = *tri;
        if free(&base, a) && free(&base, b) {
            base.location.swap(a as usize, b as usize);
            swapped += 1;
        }
    }
    assert!(swapped >= 5, "{swapped} swaps");
    let tangled = folds(&mesh, &domain, &base);
    assert!(tangled > 0, "the swaps fold the map");
    let left = untangle_knots(&mesh, &mut base, &domain, 50, &|_, _| false).len();
    assert_eq!(left, 0, "{tangled} folds, {left} left");
    assert_eq!(folds(&mesh, &domain, &base), 0);
}

/// A patch mirrored in its base triangle (two barycentric coordinates
/// swapped about its centre vertex) is folded all over; together the
/// single moves and the knots' energy unfold it.
#[test]
fn a_mirrored_patch_comes_undone() {
    let (mesh, mut base) = sphere_map();
    let domain = Domain::new(&mesh, &base).expect("stars");
    // The free vertex deepest in its base triangle, and the free
    // vertices of its face within three rings.
    let (centre, f, at) = (0..mesh.positions.len() as u32)
        .filter_map(|v| match base.location[v as usize] {
            Location::Face(f, b) if free(&base, v) => Some((v, f, b)),
            _ => None,
        })
        .max_by(|x, y| {
            let m = |b: [f64; 3]| b[0].min(b[1]).min(b[2]);
            m(x.2).total_cmp(&m(y.2))
        })
        .expect("a free vertex");
    let mut patch = vec![centre];
    for _ in 0..4 {
        let mut next = patch.clone();
        for &p in &patch {
            for &t in &domain.around[p as usize] {
                next.extend(mesh.triangles[t as usize]);
            }
        }
        next.sort_unstable();
        next.dedup();
        patch = next;
    }
    let mut mirrored = 0;
    for &v in &patch {
        if let Location::Face(g, b) = base.location[v as usize]
            && g == f
            && free(&base, v)
        {
            let d = [b[0] - at[0], b[1] - at[1], b[2] - at[2]];
            let m = [at[0] + d[0], at[1] + d[2], at[2] + d[1]];
            if m.iter().all(|&x| x >= 0.0) {
                base.location[v as usize] = Location::Face(f, m);
                mirrored += 1;
            }
        }
    }
    assert!(mirrored >= 20, "{mirrored} mirrored");
    let tangled = folds(&mesh, &domain, &base);
    assert!(tangled >= 20, "{tangled} folds");
    untangle_map(&mesh, &mut base, &domain, 50);
    let single = folds(&mesh, &domain, &base);
    // Told after its first neighbourhood that the folds left are
    // hopeless, the untangling returns them at once.
    let mut early = base.clone();
    let asked = std::cell::Cell::new(0);
    let hopeless = |_: &Base, _: &[u32]| {
        asked.set(asked.get() + 1);
        true
    };
    let stopped = untangle_knots(&mesh, &mut early, &domain, 50, &hopeless);
    assert_eq!(asked.get(), 1);
    assert_eq!(stopped.len(), folds(&mesh, &domain, &early));
    let left = untangle_knots(&mesh, &mut base, &domain, 50, &|_, _| false).len();
    assert_eq!(
        left, 0,
        "{tangled} folds, {single} after single moves, {left} after knots"
    );
    assert_eq!(folds(&mesh, &domain, &base), 0);
}

/// The smallest share of the median drawn-to-input area ratio over
/// the triangles (each in its best chart).
fn least_ratio(mesh: &TriMesh, domain: &Domain, base: &Base) -> f64 {
    let knots = Knots::new(mesh, domain);
    let mut ratios: Vec<f64> = (0..mesh.triangles.len() as u32)
        .map(|t| knots.area_ratio(Map::new(base), t))
        .collect();
    ratios.sort_by(f64::total_cmp);
    ratios[0] / ratios[ratios.len() / 2]
}

/// `measure` of the map of `sphere` onto a base of 40 triangles before
/// and after relaxing its stretch, and the folds after.
fn relaxed<T>(sphere: &PolyMesh, measure: fn(&TriMesh, &Domain, &Base) -> T) -> (T, T, usize) {
    let mesh = crate::clean::clean(sphere).unwrap().components.remove(0);
    let mut base = crate::remesh::simplify::simplify(&mesh, 40);
    let domain = Domain::new(&mesh, &base).expect("stars");
    let before = measure(&mesh, &domain, &base);
    relax_stretch(&mesh, &mut base, &domain, 50);
    (
        before,
        measure(&mesh, &domain, &base),
        folds(&mesh, &domain, &base),
    )
}

/// No two vertices of a triangle share a colour, so the vertices of
/// one colour read none of each other's places when they move.
#[test]
fn neighbours_never_share_a_colour() {
    let mesh = crate::clean::clean(&torus(24, 12))
        .unwrap()
        .components
        .remove(0);
    let domain = Domain::new(&mesh, &crate::remesh::simplify::simplify(&mesh, 60)).expect("stars");
    let colours = colours(&mesh, &domain.around);
    for t in &mesh.triangles {
        let [a, b, c] = t.map(|v| colours[v as usize]);
        assert!(a != b && b != c && c != a, "triangle {t:?}: {a} {b} {c}");
    }
    // A torus of valence 6 needs few colours.
    assert!(colours.iter().all(|&c| c < 8), "{:?}", colours.iter().max());
}

/// On a sphere with a long bump, the map the simplification leaves
/// squeezes the bump's triangles (the flattenings compound); relaxing
/// its stretch opens them up, and nothing folds.
#[test]
fn relaxing_the_stretch_opens_up_squeezed_triangles() {
    let mut sphere = qm_shapes::uv_sphere_poles_first(24, 48);
    for p in &mut sphere.positions {
        let d = p.distance_squared(DVec3::Z);
        *p *= 1.0 + 1.5 * (-d / 0.05).exp();
    }
    let (before, after, folded) = relaxed(&sphere, least_ratio);
    assert_eq!(folded, 0);
    assert!(
        after > 1.5 * before,
        "least area ratio {before:.4} -> {after:.4}"
    );
}

/// Input triangles turned over in some of the charts that draw them,
/// but not all (pleats: the charts overlap themselves there).
fn pleats(mesh: &TriMesh, domain: &Domain, base: &Base) -> usize {
    let knots = Knots::new(mesh, domain);
    (0..mesh.triangles.len() as u32)
        .filter(|&t| {
            let right: Vec<bool> = knots
                .drawings(Map::new(base), t)
                .map(|[p, q, r]| drawn_right(p, q, r))
                .collect();
            right.contains(&true) && right.contains(&false)
        })
        .count()
}

/// Relaxing the stretch weighs every chart that draws a triangle: on
/// rippled spheres with three bumps it leaves no more pleats than it
/// found (docs/decisions/004-chart-map-relaxation.md).
#[test]
fn relaxing_the_stretch_adds_no_pleats() {
    for (tall, wide, n, ripple) in [(0.8, 0.1, 40, 0.02), (2.0, 0.03, 48, 0.05)] {
        let mut sphere = qm_shapes::uv_sphere_poles_first(n / 2, n);
        let bumps = [DVec3::Z, DVec3::X, DVec3::new(0.0, -0.6, -0.8)];
        for p in &mut sphere.positions {
            let height: f64 = bumps
                .iter()
                .map(|b| (-p.distance_squared(*b) / wide).exp())
                .sum();
            *p *= 1.0 + tall * height + ripple * (13.0 * p.x).sin() * (11.0 * p.y).cos();
        }
        let (before, after, _) = relaxed(&sphere, pleats);
        assert!(after <= before, "pleats {before} -> {after}");
    }
}

/// A patch whose border is ragged (a notch every few edges): the
/// remesh's boundary samples lie on the input's border, through the
/// notches, not on the chords the straight base edges lay across them.
#[test]
fn a_ragged_border_is_sampled_along_itself() {
    let input = ragged_patch();
    // Sampling itself: no fit or normal placement after it.
    let sampling = options().with_normal(false).with_fit_rounds(0);
    let (on, total) = on_border(&input, &sampling);
    // Through the charts alone, far fewer were
    // (docs/decisions/015-chart-sampling.md).
    assert!(
        on as f64 >= 0.99 * total as f64,
        "{on} of {total} remesh boundary points on the input's border"
    );
}

/// Normal placement leaves the samples on feature lines (here the
/// border) where the sampling put them: the frame normal there is one
/// side's, and a ray along it slides the sample off the line
/// (docs/decisions/007-normal-placement.md).
#[test]
fn normal_placement_keeps_feature_lines() {
    let input = ragged_patch();
    let (on, total) = on_border(&input, &options().with_fit_rounds(0));
    assert!(
        on as f64 >= 0.99 * total as f64,
        "{on} of {total} remesh boundary points on the input's border"
    );
}

/// A 40 x 40 patch with a triangle of its border cells dropped here and
/// there.
fn ragged_patch() -> PolyMesh {
    let m = 40;
    let border = |i: usize, j: usize| i == 0 || j == 0 || i == m - 2 || j == m - 2;
    patch(m, 0.1, |i, j| !(border(i, j) && (i + j) % 3 == 0))
}

/// How many of the remesh's boundary points lie on the input's border,
/// of how many.
fn on_border(input: &PolyMesh, options: &RemeshOptions) -> (usize, usize) {
    let cleaned = crate::clean::clean(input).unwrap();
    assert_eq!(cleaned.components.len(), 1);
    let mesh = &cleaned.components[0];
    let border = boundary_edges(mesh);
    let r = remesh(input, options).expect("remesh");
    let remeshed = triangles(&r);
    let (mut on, mut total) = (0, 0);
    for [a, b] in boundary_edges(&remeshed) {
        for p in [
            remeshed.positions[a as usize],
            remeshed.positions[b as usize],
        ] {
            let d = border
                .iter()
                .map(|&[u, w]| {
                    let (u, w) = (mesh.positions[u as usize], mesh.positions[w as usize]);
                    let t = ((p - u).dot(w - u) / (w - u).length_squared()).clamp(0.0, 1.0);
                    p.distance(u.lerp(w, t))
                })
                .fold(f64::INFINITY, f64::min);
            total += 1;
            on += usize::from(d < 1e-9);
        }
    }
    (on, total)
}

/// The edges of one triangle only.
fn boundary_edges(mesh: &TriMesh) -> Vec<[u32; 2]> {
    let topo = crate::remesh::cut::Topology::new(mesh);
    topo.edges
        .iter()
        .zip(&topo.edge_faces)
        .filter(|(_, faces)| faces[1] == u32::MAX)
        .map(|(&e, _)| e)
        .collect()
}

/// An `m x m` grid patch over the unit square, a height field of
/// amplitude `z`; each cell's first triangle only where `keep(i, j)`.
fn patch(m: usize, z: f64, keep: impl Fn(usize, usize) -> bool) -> PolyMesh {
    let n = m - 1;
    let (flat, cells) = qm_shapes::plane(n as u32);
    let positions = flat
        .into_iter()
        .map(|p| DVec3::new(p.x, p.y, z * (3.0 * p.x).sin() * (2.0 * p.y).cos()))
        .collect();
    // Cell k's triangles are 2 k and 2 k + 1.
    let faces: Vec<[u32; 3]> = cells
        .into_iter()
        .enumerate()
        .filter(|&(k, _)| k % 2 == 1 || keep(k / 2 % n, k / 2 / n))
        .map(|(_, t)| t)
        .collect();
    PolyMesh::from_faces(positions, &faces)
}

#[test]
fn an_open_patch_keeps_its_boundary() {
    let input = patch(30, 0.2, |_, _| true);
    let r = remesh(&input, &options()).expect("remesh");
    let topo = topology(&triangles(&r));
    assert!(topo.manifold, "{topo:?}");
    assert_eq!((topo.boundary_loops, topo.genus), (1, 0));
    assert!(r.report.psnr.expect("measured") > 70.0);
}

#[test]
fn a_remesh_below_the_floor_is_refused() {
    let input = torus(32, 16);
    let err = remesh(&input, &options().with_min_psnr(400.0)).expect_err("above any remesh");
    assert!(
        matches!(
            err,
            Error::Remesh {
                failure: RemeshFailure::TooFar { floor, .. },
                ..
            } if floor == 400.0
        ),
        "{err}"
    );
}
