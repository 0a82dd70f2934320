//! Tests of the clean-up: each step on small hand-made meshes (polygons,
//! seams, non-manifold edges and vertices, opposite and duplicate faces,
//! Möbius strips and Klein bottles), the bundled models, and a timing.

use std::collections::HashMap;

use qm_lift::glam::DVec3;

use super::duplicates::{drop_bad_triangles, merge_identical};
use super::report::Thousands;
use super::triangulate::triangulate;
use super::*;

fn dv(p: [f64; 3]) -> DVec3 {
    DVec3::from_array(p)
}

fn poly<const K: usize>(p: &[[f64; 3]], f: &[[u32; K]]) -> PolyMesh {
    PolyMesh::from_faces(p.iter().copied().map(dv).collect(), f)
}

/// A convex 12-gon becomes a strip: no corner in more than three of
/// its triangles, all facing the polygon's way, covering its area; a
/// non-convex polygon keeps its fan.
#[test]
fn a_convex_polygon_is_a_strip_not_a_fan() {
    let n = 12u32;
    let mut mesh = qm_shapes::ngon(n);
    let points = mesh.positions.clone();
    let tris = triangulate(&mesh, &mut CleanReport::default()).unwrap();
    assert_eq!(tris.len(), n as usize - 2);
    let mut uses = vec![0; n as usize];
    let mut area = 0.0;
    for t in &tris {
        let [a, b, c] = t.map(|v| points[v as usize]);
        let z = (b - a).cross(c - a).z;
        assert!(z > 0.0, "{t:?} faces the other way");
        area += z / 2.0;
        t.iter().for_each(|&v| uses[v as usize] += 1);
    }
    assert!(uses.iter().all(|&u| u <= 3), "{uses:?}");
    let polygon = f64::from(n) / 2.0 * (std::f64::consts::TAU / f64::from(n)).sin();
    assert!((area - polygon).abs() < 1e-12);
    // A dent: the fan from the first corner, as before.
    mesh.positions[6] *= 0.1;
    let tris = triangulate(&mesh, &mut CleanReport::default()).unwrap();
    assert!(tris.iter().all(|t| t[0] == 0));
}

/// The corner tetrahedron, faces outward.
fn tetra(o: [f64; 3]) -> (Vec<[f64; 3]>, Vec<[u32; 3]>) {
    let (p, f) = qm_shapes::tetrahedron();
    (moved(&p, o), f)
}

/// The unit cube, outward quads.
fn cube(o: [f64; 3]) -> (Vec<[f64; 3]>, Vec<[u32; 4]>) {
    let (p, f) = qm_shapes::cube();
    (moved(&p, o), f)
}

/// Positions moved by `o`, as arrays.
fn moved(p: &[DVec3], o: [f64; 3]) -> Vec<[f64; 3]> {
    p.iter()
        .map(|q| [q.x + o[0], q.y + o[1], q.z + o[2]])
        .collect()
}

fn volume(m: &TriMesh) -> f64 {
    m.triangles
        .iter()
        .map(|t| {
            let [a, b, c] = m.corners(t);
            a.dot(b.cross(c)) / 6.0
        })
        .sum()
}

fn assert_clean(c: &Cleaned) {
    for m in &c.components {
        let t = topology(m);
        assert!(t.manifold, "{t:?}");
    }
}

#[test]
fn report_line_has_separators() {
    let r = CleanReport {
        input_vertices: 3225,
        output_vertices: 2930,
        merged_vertices: 295,
        components: 1,
        ..CleanReport::default()
    };
    let s = r.to_string();
    assert!(
        s.starts_with("clean-up: 3,225 -> 2,930 vertices (295 duplicates merged"),
        "{s}"
    );
    assert!(s.ends_with("1 component"), "{s}");
    assert!(!s.contains('\n'));
    assert_eq!(Thousands(1_234_567).to_string(), "1,234,567");
    assert_eq!(Thousands(0).to_string(), "0");
}

#[test]
fn seam_duplicates_merge() {
    // A tetrahedron whose vertex 0 is stored three times, one per face
    // using it (as texture seams do).
    let (mut p, _) = tetra([0.; 3]);
    p.push(p[0]);
    p.push(p[0]);
    let f = [[0, 2, 1], [4, 1, 3], [5, 3, 2], [1, 2, 3]];
    let c = clean(&poly(&p, &f)).unwrap();
    assert_eq!(c.report.merged_vertices, 2);
    assert_eq!(c.report.output_vertices, 4);
    assert_eq!(c.components.len(), 1);
    let t = topology(&c.components[0]);
    assert!(t.manifold && t.is_closed() && t.genus == 0, "{t:?}");
}

#[test]
fn disjoint_tetrahedra_are_two_components() {
    let (mut p, mut f) = tetra([0.; 3]);
    let (p2, f2) = tetra([5., 0., 0.]);
    p.extend(p2);
    f.extend(f2.iter().map(|t| t.map(|v| v + 4)));
    let c = clean(&poly(&p, &f)).unwrap();
    assert_eq!(c.components.len(), 2);
    assert_eq!(c.report.flipped_faces, 0);
    for m in &c.components {
        assert_eq!((m.positions.len(), m.triangles.len()), (4, 4));
        assert!(volume(m) > 0.0);
    }
    assert_clean(&c);
}

#[test]
fn non_manifold_edge_is_split() {
    // Three triangles on edge 0-1.
    let p = [
        [0., 0., 0.],
        [1., 0., 0.],
        [0., 1., 0.],
        [0., -1., 0.],
        [0., 0., 1.],
    ];
    let f = [[0, 1, 2], [1, 0, 3], [0, 1, 4]];
    let c = clean(&poly(&p, &f)).unwrap();
    // Two faces pair into a sheet, the third is cut loose.
    assert_eq!((c.report.paired_edges, c.report.split_edges), (1, 1));
    assert_eq!(c.report.split_vertices, 2);
    assert_eq!(c.components.len(), 2);
    assert_eq!(c.report.output_vertices, 7);
    assert_clean(&c);
}

/// Two cubes that touch along an edge: four faces on it, which pair
/// within each cube, so both stay closed (cut loose, all four would leave
/// a slit in each).
fn touching_cubes(inward: bool) -> (Vec<[f64; 3]>, Vec<[u32; 4]>) {
    let (mut p, mut f) = cube([0.; 3]);
    let (p2, f2) = cube([1., 1., 0.]);
    // Cube 2's edge 0-4 is cube 1's edge 3-7.
    p.extend(p2);
    f.extend(f2.iter().map(|q| q.map(|v| v + 8)));
    if inward {
        for q in &mut f {
            q.reverse();
        }
    }
    (p, f)
}

fn assert_closed_cubes(c: &Cleaned, n: usize) {
    assert_eq!(c.components.len(), n);
    for m in &c.components {
        let t = topology(m);
        assert!(t.manifold && t.is_closed() && t.genus == 0, "{t:?}");
        assert!((volume(m).abs() - volume(m).abs().round()).abs() < 1e-12);
        assert!(volume(m) > 0.0);
    }
}

#[test]
fn cubes_touching_along_an_edge_stay_closed() {
    let (p, f) = touching_cubes(false);
    let c = clean(&poly(&p, &f)).unwrap();
    assert_eq!((c.report.paired_edges, c.report.split_edges), (1, 0));
    assert_eq!(c.report.split_vertices, 2);
    assert_closed_cubes(&c, 2);
}

/// The pairing follows the input's orientation, guessed from the sign of
/// its volume; where that guess is wrong for a part, the other way of
/// pairing gives the simpler surface and is kept. Here the touching cubes
/// face inward inside a large outward box, so the guess says outward.
#[test]
fn the_simpler_pairing_wins() {
    let (mut p, mut f) = touching_cubes(true);
    let (big, fb) = cube([0.; 3]);
    let at = p.len() as u32;
    p.extend(big.iter().map(|q| q.map(|x| 10.0 * x + 20.0)));
    f.extend(fb.iter().map(|q| q.map(|v| v + at)));
    let c = clean(&poly(&p, &f)).unwrap();
    assert_eq!((c.report.paired_edges, c.report.split_edges), (1, 0));
    assert_closed_cubes(&c, 3);
}

/// Two tetrahedra glued on a face, the face stored once by each (so twice,
/// running opposite ways): the two copies cancel and a closed bipyramid
/// is left (one copy kept would be a membrane inside, its three edges of
/// three faces each).
#[test]
fn opposite_faces_between_parts_cancel() {
    let p = [
        [0., 0., 0.],
        [1., 0., 0.],
        [0., 1., 0.],
        [0., 0., 1.],
        [1., 1., 1.],
    ];
    // Outward: tetrahedron 0123, then 1234 (its face 1-2-3 runs the
    // other way).
    let f = [
        [0, 2, 1],
        [0, 1, 3],
        [0, 3, 2],
        [1, 2, 3],
        [1, 3, 2],
        [1, 4, 3],
        [2, 3, 4],
        [1, 2, 4],
    ];
    let c = clean(&poly(&p, &f)).unwrap();
    assert_eq!(c.report.cancelled_faces, 2);
    assert_eq!((c.report.split_edges, c.report.paired_edges), (0, 0));
    assert_eq!(c.components.len(), 1);
    let t = topology(&c.components[0]);
    assert!(t.manifold && t.is_closed() && t.genus == 0, "{t:?}");
    assert_eq!((t.vertices, t.faces), (5, 6));
    assert!((volume(&c.components[0]) - 0.5).abs() < 1e-12);
}

/// A face stored again, reversed, on a closed surface: its edges meet one
/// other face each, so the pair does not cancel (that would leave a
/// hole); one face stays and the surface is closed.
#[test]
fn a_reversed_copy_on_a_closed_surface_leaves_it_closed() {
    let (p, mut f) = tetra([0.; 3]);
    f.push([0, 1, 2]); // face 0 reversed
    let c = clean(&poly(&p, &f)).unwrap();
    assert_eq!(
        (c.report.dropped_duplicate, c.report.cancelled_faces),
        (1, 0)
    );
    assert_eq!(c.components.len(), 1);
    let t = topology(&c.components[0]);
    assert!(t.manifold && t.is_closed() && t.genus == 0, "{t:?}");
    assert!((volume(&c.components[0]) - 1.0 / 6.0).abs() < 1e-12);
}

/// The rule itself, each way: pairing across wedges inside the solid
/// keeps the outward touching cubes apart and closed; across wedges
/// outside, it joins them, which the fans at the edge's ends undo, and
/// the cut leaves a slit in each.
#[test]
fn pairing_inside_keeps_touching_parts_apart() {
    let (p, f) = touching_cubes(false);
    let mesh = poly(&p, &f);
    let mut report = CleanReport::default();
    let tris = triangulate(&mesh, &mut report).unwrap();
    let (remap, positions) = merge_identical(&mesh.positions);
    let tris = drop_bad_triangles(tris, &remap, &positions, true, &mut report);
    let (inside, crowded) = resolve(&tris, &positions, CleanReport::default(), true).unwrap();
    assert!(crowded);
    assert_closed_cubes(&inside, 2);
    let (outside, _) = resolve(&tris, &positions, CleanReport::default(), false).unwrap();
    assert_eq!(outside.report.paired_edges, 0);
    assert!(outside.components.iter().all(|m| !topology(m).is_closed()));
}

/// A two-sided sheet on its own (each face stored both ways, nothing else
/// attached) keeps one side instead of vanishing, also where a face is
/// stored a third time.
#[test]
fn a_free_two_sided_sheet_keeps_one_side() {
    let p = [[0., 0., 0.], [1., 0., 0.], [1., 1., 0.], [0., 1., 0.]];
    let f = [[0, 1, 2], [0, 2, 3], [2, 1, 0], [3, 2, 0], [2, 3, 0]];
    let c = clean(&poly(&p, &f)).unwrap();
    assert_eq!(
        (c.report.cancelled_faces, c.report.dropped_duplicate),
        (0, 3)
    );
    assert_eq!(c.components.len(), 1);
    let t = topology(&c.components[0]);
    assert_eq!((t.faces, t.boundary_loops), (2, 1));
}

#[test]
fn bow_tie_cubes_split_at_the_shared_vertex() {
    let (mut p, mut f) = cube([0.; 3]);
    let (p2, f2) = cube([1., 1., 1.]);
    // Cube 2's vertex 0 is cube 1's vertex 7.
    p.extend(p2);
    f.extend(f2.iter().map(|q| q.map(|v| v + 8)));
    let c = clean(&poly(&p, &f)).unwrap();
    assert_eq!(c.report.merged_vertices, 1);
    assert_eq!(c.report.split_vertices, 1);
    assert_eq!(c.report.split_edges, 0);
    assert_eq!(c.components.len(), 2);
    for m in &c.components {
        let t = topology(m);
        assert!(t.manifold && t.is_closed() && t.genus == 0, "{t:?}");
        assert_eq!((t.vertices, t.faces), (8, 12));
        assert!((volume(m) - 1.0).abs() < 1e-12);
    }
}

#[test]
fn degenerate_faces_and_unused_vertices_drop() {
    let (mut p, mut f) = tetra([0.; 3]);
    p.push([9., 9., 9.]); // unused
    p.push([0.5, 0., 0.]); // on edge 0-1
    f.push([0, 5, 1]); // zero area
    f.push([2, 2, 3]); // repeated vertex
    let mut m = poly(&p, &f);
    m.push_face(&[0, 1]); // too few corners
    let c = clean(&m).unwrap();
    assert_eq!(c.report.dropped_degenerate, 3);
    // Vertex 5 is used only by the dropped face.
    assert_eq!(c.report.dropped_unused_vertices, 2);
    assert_eq!(c.components.len(), 1);
    assert_eq!(c.components[0].positions.len(), 4);
    assert_clean(&c);
}

#[test]
fn duplicate_faces_drop() {
    let (p, mut f) = tetra([0.; 3]);
    f.push([2, 1, 0]); // same as face 0, rotated
    f.push([1, 3, 0]); // same as face 1, rotated
    let c = clean(&poly(&p, &f)).unwrap();
    assert_eq!(c.report.dropped_duplicate, 2);
    assert_eq!(c.report.output_faces, 4);
    assert_eq!(c.report.split_edges, 0);
    assert_clean(&c);
}

#[test]
fn ngons_are_split_and_their_duplicates_found() {
    let p = [
        [0., 0., 0.],
        [1., 0., 0.],
        [2., 1., 0.],
        [1., 2., 0.],
        [0., 1., 0.],
    ];
    let mut m = poly(&p, &[[0, 1, 2, 3, 4]]);
    m.push_face(&[0, 1, 4]); // a duplicate of the strip's first triangle
    let c = clean(&m).unwrap();
    assert_eq!(c.report.triangles, 4);
    assert_eq!(c.report.dropped_duplicate, 1);
    let t = topology(&c.components[0]);
    assert_eq!((t.faces, t.boundary_loops, t.genus), (3, 1, 0));
}

#[test]
fn inconsistent_orientation_is_made_consistent() {
    // A grid of triangles, all but every third one turned over.
    let c = clean(&qm_shapes::poly(qm_shapes::grid(6, 5, true))).unwrap();
    assert_eq!(c.components.len(), 1);
    assert_eq!(c.report.split_edges, 0);
    let m = &c.components[0];
    // Every interior edge once in each direction.
    let mut dir = HashMap::new();
    for t in &m.triangles {
        for i in 0..3 {
            *dir.entry((t[i], t[(i + 1) % 3])).or_insert(0) += 1;
        }
    }
    let mut interior = 0;
    for (&(a, b), &n) in &dir {
        assert_eq!(n, 1);
        interior += usize::from(dir.contains_key(&(b, a)));
    }
    assert_eq!(interior / 2, 6 * 4 + 5 * 5 + 30);
    // Kept the orientation most input faces had (2 of 3 reversed: -z).
    assert!(m.triangles.iter().all(|t| {
        let [a, b, c] = m.corners(t);
        (b - a).cross(c - a).z < 0.0
    }));
    assert!(topology(m).manifold);
}

#[test]
fn closed_mesh_turns_outward() {
    let (p, f) = tetra([0.; 3]);
    let inward: Vec<[u32; 3]> = f.iter().map(|t| [t[0], t[2], t[1]]).collect();
    let c = clean(&poly(&p, &inward)).unwrap();
    assert_eq!(c.report.flipped_faces, 4);
    assert!(volume(&c.components[0]) > 0.0);
    let (p, f) = cube([3., -2., 7.]);
    let inward: Vec<[u32; 4]> = f.iter().map(|q| [q[3], q[2], q[1], q[0]]).collect();
    let c = clean(&poly(&p, &inward)).unwrap();
    assert!((volume(&c.components[0]) - 1.0).abs() < 1e-12);
}

#[test]
fn mobius_strip_becomes_orientable() {
    let n = 12u32;
    let mut p = Vec::new();
    for i in 0..n {
        let a = std::f64::consts::TAU * f64::from(i) / f64::from(n);
        for s in [-0.3, 0.3] {
            let (r, z) = (1.0 + s * (a / 2.0).cos(), s * (a / 2.0).sin());
            p.push([r * a.cos(), r * a.sin(), z]);
        }
    }
    let mut f = Vec::new();
    for i in 0..n {
        let (a, b) = (2 * i, 2 * i + 1);
        // The last rung joins with a half twist.
        let (c, d) = if i + 1 == n {
            (1, 0)
        } else {
            (2 * i + 2, 2 * i + 3)
        };
        f.push([a, c, d]);
        f.push([a, d, b]);
    }
    let c = clean(&poly(&p, &f)).unwrap();
    assert_eq!(c.components.len(), 1);
    assert!(c.report.split_edges >= 1);
    let t = topology(&c.components[0]);
    assert!(t.manifold, "{t:?}");
    assert_eq!((t.boundary_loops, t.genus), (1, 0));
}

#[test]
fn hostile_inputs_do_not_panic() {
    assert_eq!(clean(&PolyMesh::new()).unwrap().components.len(), 0);
    let m = poly(&[[0.; 3]], &[[0, 0, 0]]);
    assert_eq!(clean(&m).unwrap().report.dropped_degenerate, 1);
    let m = poly(&[[0.; 3]], &[[0, 1, 2]]);
    assert!(matches!(
        clean(&m),
        Err(Error::MissingVertex {
            mesh: None,
            face: 0,
            vertex: 1
        })
    ));
    let m = poly(&[[0.; 3], [1., 0., 0.], [f64::NAN, 0., 0.]], &[[0, 1, 2]]);
    assert!(matches!(
        clean(&m),
        Err(Error::NonFinite {
            mesh: None,
            vertex: 2
        })
    ));
    // Many faces on one edge, and a Klein-bottle-like tangle.
    let p: Vec<[f64; 3]> = (0..40)
        .map(|i| [f64::from(i), f64::from(i * i % 7), f64::from(i % 5)])
        .collect();
    let mut f = Vec::new();
    for i in 2..40u32 {
        f.push([0, 1, i]);
        f.push([i, (i * 7) % 40, (i * 13 + 1) % 40]);
    }
    let c = clean(&poly(&p, &f)).unwrap();
    assert_clean(&c);
}

#[test]
fn closed_non_orientable_surface_is_cut_open() {
    // A Klein bottle as a 6 x 6 grid with twisted identification.
    let (w, h) = (6u32, 6u32);
    let id = |x: u32, y: u32| {
        let (x, y) = (x % w, y);
        if y == h {
            ((w - x) % w) as usize
        } else {
            (y * w + x) as usize
        }
    };
    let p: Vec<[f64; 3]> = (0..w * h)
        .map(|i| [f64::from(i % w), f64::from(i / w), f64::from((i * 7) % 11)])
        .collect();
    let mut f = Vec::new();
    for y in 0..h {
        for x in 0..w {
            let (a, b, c, d) = (id(x, y), id(x + 1, y), id(x + 1, y + 1), id(x, y + 1));
            f.push([a as u32, b as u32, c as u32]);
            f.push([a as u32, c as u32, d as u32]);
        }
    }
    let c = clean(&poly(&p, &f)).unwrap();
    assert!(c.report.split_edges >= 1);
    assert_clean(&c);
}

/// Cleans every bundled model: manifold components, closed ones
/// outward.
#[test]
fn bundled_models() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../assets");
    let mut files = Vec::new();
    for sub in [dir.clone(), dir.join("quad")] {
        let Ok(entries) = std::fs::read_dir(&sub) else {
            continue;
        };
        for e in entries.flatten() {
            let path = e.path();
            let ext = path.extension().and_then(|e| e.to_str()).unwrap_or("");
            if ["obj", "ply", "off", "stl"].contains(&ext) {
                files.push(path);
            }
        }
    }
    files.sort();
    assert!(files.len() >= 5, "{files:?}");
    for path in files {
        let mesh = qm_io::read_mesh(&path).unwrap();
        let start = std::time::Instant::now();
        let c = clean(&mesh).unwrap();
        let took = start.elapsed();
        let topo = components_topology(&c.components);
        let name = path.file_stem().unwrap().to_string_lossy().into_owned();
        println!("{name}: {} ({:.1} ms)", c.report, took.as_secs_f64() * 1e3);
        for t in &topo {
            println!(
                "  component: {} vertices, {} faces, {} boundary loops, genus {}",
                t.vertices, t.faces, t.boundary_loops, t.genus
            );
            assert!(t.manifold, "{name}: {t:?}");
        }
        for m in &c.components {
            if topology(m).is_closed() {
                assert!(volume(m) > 0.0, "{name}");
            }
        }
        match name.as_str() {
            "spot" => {
                assert_eq!(c.report.output_vertices, 2930);
                assert_eq!(topo.len(), 1);
                assert!(topo[0].is_closed() && topo[0].genus == 0);
            }
            "torus_4x6_l4" => assert_eq!(topo[0].genus, 1),
            "holed_grid_l4" => assert!(topo[0].boundary_loops > 1),
            _ => {}
        }
    }
}

/// A 700 x 700 torus grid (490,000 vertices) for timing in release:
/// `cargo test --release -p qm-param clean::tests::large -- --ignored --nocapture`.
#[test]
#[ignore = "timing; run in release"]
fn large_torus_timing() {
    let (w, h) = (700u32, 700u32);
    let m = qm_shapes::poly(qm_shapes::torus_quads(w, h, 3.0, 1.0));
    let start = std::time::Instant::now();
    let c = clean(&m).unwrap();
    println!(
        "{} ({:.1} ms)",
        c.report,
        start.elapsed().as_secs_f64() * 1e3
    );
    let t = topology(&c.components[0]);
    assert_eq!((t.genus, t.boundary_loops), (1, 0));
    assert!(t.manifold);
}
