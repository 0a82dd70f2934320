//! Tests of the simplifier: crease lines (noisy, budgeted, clean), a ring
//! no fan fills, and a sphere simplified to its target with every vertex
//! mapped and the bases passed through kept.

use qm_lift::glam::{DVec2, DVec3};

use super::ring::edge_key;
use super::simplifier::Simplifier;
use super::*;

fn euler(triangles: &[[u32; 3]]) -> i64 {
    let mut verts: Vec<u32> = triangles.iter().flatten().copied().collect();
    verts.sort_unstable();
    verts.dedup();
    let mut edges: Vec<u64> = triangles
        .iter()
        .flat_map(|t| (0..3).map(move |i| edge_key(t[i], t[(i + 1) % 3])))
        .collect();
    edges.sort_unstable();
    edges.dedup();
    verts.len() as i64 - edges.len() as i64 + triangles.len() as i64
}

/// A 24 x 24 grid folded at 70 degrees along a ridge: straight down
/// the middle column, or zigzagging between it and the next at every
/// row (a turn of 90 degrees). Heights fall with the distance from the
/// ridge, so only its edges are creases.
fn ridge(zigzag: bool) -> TriMesh {
    let n = 24u32;
    let column = |row: u32| f64::from(n / 2 + u32::from(zigzag) * (row % 2));
    let line: Vec<DVec2> = (0..=n)
        .map(|j| DVec2::new(column(j), f64::from(j)))
        .collect();
    let from_line = |p: DVec2| {
        line.windows(2)
            .map(|w| {
                let (a, b) = (w[0], w[1]);
                let t = ((p - a).dot(b - a) / (b - a).length_squared()).clamp(0.0, 1.0);
                p.distance(a + t * (b - a))
            })
            .fold(f64::INFINITY, f64::min)
    };
    let mut positions = Vec::new();
    for j in 0..=n {
        for i in 0..=n {
            let p = DVec2::new(f64::from(i), f64::from(j));
            positions.push(DVec3::new(p.x, p.y, -0.7 * from_line(p)));
        }
    }
    let at = |i: u32, j: u32| j * (n + 1) + i;
    let mut triangles = Vec::new();
    for j in 0..n {
        for i in 0..n {
            let (a, b, c, d) = (at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j + 1));
            // The diagonal follows the ridge where it crosses the cell.
            if f64::from(i + 1) == column(j) && f64::from(i) == column(j + 1) {
                triangles.extend([[a, b, d], [b, c, d]]);
            } else {
                triangles.extend([[a, b, c], [a, c, d]]);
            }
        }
    }
    TriMesh {
        positions,
        triangles,
    }
}

/// Crease lines taken for noise end at their sharp turns, and the short
/// pieces are dropped: a zigzag ridge is then no feature line, while a
/// straight one is one either way.
#[test]
fn noisy_creases_end_at_sharp_turns() {
    let inner_features = |mesh: &TriMesh, noisy: bool| {
        let base = simplify_keeping(mesh, 60, 60, &[], noisy);
        (0..mesh.positions.len())
            .filter(|&v| {
                let p = mesh.positions[v];
                let inner = |x: f64| x > 0.5 && x < 23.5;
                base.feature[v] && inner(p.x) && inner(p.y)
            })
            .count()
    };
    let (straight, zigzag) = (ridge(false), ridge(true));
    let counts = [
        inner_features(&straight, false),
        inner_features(&straight, true),
        inner_features(&zigzag, false),
        inner_features(&zigzag, true),
    ];
    assert!(counts[..3].iter().all(|&c| c >= 20), "{counts:?}");
    assert_eq!(counts[3], 0, "{counts:?}");
}

/// Edges across the sheet of [`ridges`].
const RIDGES_WIDTH: u32 = 66;

/// A flat sheet with eight straight tent-shaped ridges of 4 to 25
/// edges, 8 apart: each ridge's top is a crease line, its feet are not
/// (under 42 degrees). The first, shortest ridge is clean (70 degrees
/// all along); along the others the slope varies, and the crease with
/// it (55 to 82 degrees).
fn ridges() -> (TriMesh, Vec<(u32, std::ops::RangeInclusive<u32>)>) {
    let (w, h) = (RIDGES_WIDTH, 30u32);
    let ridges: Vec<(u32, std::ops::RangeInclusive<u32>)> =
        (0..8).map(|k| (5 + 8 * k, 2..=2 + 4 + 3 * k)).collect();
    let mut positions = Vec::new();
    for j in 0..=h {
        for i in 0..=w {
            let p = DVec2::new(f64::from(i), f64::from(j));
            let z = ridges
                .iter()
                .enumerate()
                .map(|(k, (x, rows))| {
                    let y = p.y.clamp(f64::from(*rows.start()), f64::from(*rows.end()));
                    let d = p.distance(DVec2::new(f64::from(*x), y));
                    let wobble = if k == 0 {
                        0.0
                    } else {
                        (1.3 * y + k as f64).sin()
                    };
                    (2.1 - 0.7 * (1.0 + 0.25 * wobble) * d).max(0.0)
                })
                .fold(0.0, f64::max);
            positions.push(DVec3::new(p.x, p.y, z));
        }
    }
    let mesh = TriMesh {
        positions,
        triangles: qm_shapes::grid_triangles(w, h),
    };
    (mesh, ridges)
}

/// Crease lines other than clean ones end at no more vertices than their
/// share of the base: the longest are kept, the rest are dropped. A
/// clean line stays, however short.
#[test]
fn crease_lines_hold_at_most_their_share_of_the_base() {
    let (mesh, ridges) = ridges();
    let target = 200;
    let base = simplify(&mesh, target);
    let kept: Vec<bool> = ridges
        .iter()
        .map(|(x, rows)| {
            let inner = *rows.start() + 1..*rows.end();
            inner
                .filter(|&j| base.feature[(j * (RIDGES_WIDTH + 1) + x) as usize])
                .count()
                > 0
        })
        .collect();
    // 100 base vertices, 5% of them line ends: the clean ridge's two,
    // and the longest of the others (the ridges grow with k) as far as
    // the rest goes.
    assert!(kept[0], "{kept:?}");
    let noisy = kept[1..].iter().filter(|&&k| k).count();
    assert!((1..=2).contains(&noisy) && kept[7], "{kept:?}");
}

/// A vertex whose ring, flat, is a six-pointed star: no ring vertex
/// sees the whole ring, so no half-edge collapse may remove it, but the
/// ring retriangulated may; every point of the removed triangles lands
/// in the new ones.
#[test]
fn a_ring_no_fan_fills_is_retriangulated() {
    let k = 12u32;
    let mut positions = vec![DVec3::ZERO];
    for i in 0..k {
        let r = if i % 2 == 0 { 1.0 } else { 0.3 };
        let phi = std::f64::consts::TAU * f64::from(i) / f64::from(k);
        positions.push(DVec3::new(r * phi.cos(), r * phi.sin(), 0.0));
    }
    let triangles = (0..k).map(|i| [0, 1 + i, 1 + (i + 1) % k]).collect();
    let mesh = TriMesh {
        positions,
        triangles,
    };
    let mut s = Simplifier::new(&mesh, 0.0, f64::INFINITY, false);
    let plan = s.plan(0).expect("a removal of the centre");
    let made = plan.triangles.as_ref().expect("the ring retriangulated");
    assert_eq!(made.len(), k as usize - 2);
    let ring = s.ring(0).unwrap();
    let flat = s.flatten(0, &ring, None).unwrap();
    for ui in 0..k as usize {
        let fan = Simplifier::fan(&ring, ui);
        let folds = fan
            .iter()
            .any(|&(_, [a, b, c])| (flat[b] - flat[a]).perp_dot(flat[c] - flat[a]) <= 0.0);
        assert!(folds, "the fan from {ui} fills the ring");
    }
    s.collapse(0, &plan);
    let base = s.base();
    assert_eq!(base.triangles.len(), k as usize - 2);
    assert!(matches!(base.location[0], Location::Face(..)));
    assert_mapped(&base);
}

#[test]
fn a_sphere_simplifies_to_its_target_and_every_vertex_is_mapped() {
    let sphere = qm_shapes::uv_sphere_poles_first(16, 32);
    let mesh = &crate::clean::clean(&sphere).unwrap().components[0];
    let base = simplify(mesh, 40);
    assert!(
        base.triangles.len() <= 40,
        "{} base triangles",
        base.triangles.len()
    );
    assert_eq!(euler(&base.triangles), 2, "genus kept");
    assert_mapped(&base);
}

/// Every vertex of `base`'s map is a base vertex or in a base triangle.
fn assert_mapped(base: &Base) {
    for (v, l) in base.location.iter().enumerate() {
        match *l {
            Location::Vertex => {
                assert!(base.triangles.iter().flatten().any(|&w| w == v as u32))
            }
            Location::Face(f, b) => {
                assert!((f as usize) < base.triangles.len());
                assert!(b.iter().all(|&x| x >= 0.0) && (b.iter().sum::<f64>() - 1.0).abs() < 1e-9);
            }
        }
    }
}

/// The bases a run passes through at its checkpoints are bases like
/// its last: at their count or one collapse under it, genus kept,
/// every vertex mapped. A checkpoint under where the run stops passes
/// nothing.
#[test]
fn a_run_keeps_the_bases_it_passes_through() {
    let sphere = qm_shapes::uv_sphere_poles_first(16, 32);
    let mesh = &crate::clean::clean(&sphere).unwrap().components[0];
    let simplified = simplify_part(mesh, 40, &[10, 400, 100]);
    let counts: Vec<usize> = simplified.passed.iter().map(|(c, _)| *c).collect();
    assert_eq!(counts, [400, 100]);
    for (count, base) in &simplified.passed {
        let n = base.triangles.len();
        assert!(n <= *count && n + 2 >= *count, "{n} triangles for {count}");
        assert_eq!(euler(&base.triangles), 2, "genus kept");
        assert_mapped(base);
    }
    assert!(simplified.base.triangles.len() <= 40);
}
