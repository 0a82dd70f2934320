use std::collections::HashMap;
use std::path::Path;

use qm_io::SplitMix64;
use qm_lift::glam::DVec3;
use qm_shapes::{Quads, holed_grid, open_cylinder_quads, quad_fan, square, torus_quads};

use super::*;

/// The cube `[-1, 1]^3` with the faces of `qm_lift::synthetic::cube`.
fn cube() -> Quads {
    let positions = (0..8)
        .map(|v| {
            let x = if (v + 1) & 2 == 0 { -1.0 } else { 1.0 };
            let y = if v & 2 == 0 { -1.0 } else { 1.0 };
            let z = if v < 4 { -1.0 } else { 1.0 };
            DVec3::new(x, y, z)
        })
        .collect();
    (positions, qm_lift::synthetic::cube().faces().to_vec())
}

/// Both meshes side by side.
fn disjoint(a: Quads, b: Quads) -> Quads {
    let (mut positions, mut faces) = a;
    let offset = positions.len() as u32;
    positions.extend(b.0.iter().map(|p| *p + DVec3::splat(10.0)));
    faces.extend(b.1.iter().map(|f| f.map(|v| v + offset)));
    (positions, faces)
}

/// Two cubes touching at one corner: a vertex shared by two components.
fn cubes_sharing_a_corner() -> Quads {
    let (positions, mut faces) = disjoint(cube(), cube());
    for f in &mut faces[6..] {
        for v in f.iter_mut() {
            if *v == 8 {
                *v = 0;
            }
        }
    }
    compacted((positions, faces))
}

/// One step of quad subdivision connectivity, with bilinear positions.
fn refine((old, faces): &Quads) -> Quads {
    let mut positions = old.clone();
    let mut edge_points = HashMap::new();
    let mut quads = Vec::with_capacity(faces.len() * 4);
    for face in faces {
        let mut mid = [0u32; 4];
        for k in 0..4 {
            let (a, b) = (face[k], face[(k + 1) % 4]);
            mid[k] = *edge_points.entry((a.min(b), a.max(b))).or_insert_with(|| {
                positions.push((old[a as usize] + old[b as usize]) / 2.0);
                positions.len() as u32 - 1
            });
        }
        let centre = positions.len() as u32;
        positions.push(face.iter().map(|&v| old[v as usize]).sum::<DVec3>() / 4.0);
        for k in 0..4 {
            quads.push([face[k], mid[k], centre, mid[(k + 3) % 4]]);
        }
    }
    (positions, quads)
}

fn refined(base: Quads, levels: u32) -> Quads {
    (0..levels).fold(base, |mesh, _| refine(&mesh))
}

/// The same mesh with vertex ids, face order and each face's first corner
/// scrambled, so detection cannot lean on how the generator numbered things.
fn shuffled((positions, faces): &Quads, rng: &mut SplitMix64) -> PolyMesh {
    let mut new_id: Vec<u32> = (0..positions.len() as u32).collect();
    rng.shuffle(&mut new_id);
    let mut moved = vec![DVec3::ZERO; positions.len()];
    for (old, &new) in new_id.iter().enumerate() {
        moved[new as usize] = positions[old];
    }
    let mut quads: Vec<[u32; 4]> = faces
        .iter()
        .map(|f| {
            let r = rng.below(4);
            std::array::from_fn(|k| new_id[f[(k + r) % 4] as usize])
        })
        .collect();
    rng.shuffle(&mut quads);
    PolyMesh::from_faces(moved, &quads)
}

/// A quad starting at its smallest id: equal for the same cyclic order.
fn canonical(q: [u32; 4]) -> [u32; 4] {
    let k = (0..4).min_by_key(|&k| q[k]).unwrap();
    std::array::from_fn(|t| q[(k + t) % 4])
}

/// Checks that `found` is `mesh`, exactly: sample positions are their source
/// vertices' and the finest quads are the input quads, orientation included.
fn check(mesh: &PolyMesh, found: &Detected, level: u32, base_faces: usize) {
    let layout = found.mesh.layout();
    assert_eq!(found.level, level);
    assert_eq!(layout.level(), level);
    assert_eq!(layout.face_count(), base_faces);
    assert_eq!(found.source.len(), mesh.positions.len());
    for (s, &v) in found.source.iter().enumerate() {
        assert_eq!(found.mesh.positions()[s], mesh.positions[v as usize]);
    }
    let mut want: Vec<[u32; 4]> = mesh
        .faces()
        .map(|f| canonical(f.try_into().unwrap()))
        .collect();
    let mut got: Vec<[u32; 4]> = layout
        .quads(level)
        .into_iter()
        .map(|q| canonical(q.map(|s| found.source[s as usize])))
        .collect();
    want.sort_unstable();
    got.sort_unstable();
    assert_eq!(got, want);
}

#[test]
fn finds_the_level_of_scrambled_refinements() {
    let cases: Vec<(&str, Quads, u32, usize)> = vec![
        ("cube", cube(), 1, 6),
        ("cube", cube(), 3, 6),
        ("torus 4x6", torus_quads(4, 6, 2.0, 1.0), 2, 24),
        ("holed grid", holed_grid(), 3, 8),
        ("two cubes", disjoint(cube(), cube()), 2, 12),
        ("touching cubes", cubes_sharing_a_corner(), 2, 12),
        ("valence 5", quad_fan(5), 3, 5),
        ("valence 3", quad_fan(3), 2, 3),
        ("cylinder", open_cylinder_quads(4, 2), 3, 8),
        ("single quad", square(0.0), 2, 1),
    ];
    let mut rng = SplitMix64::new(0x9E37_79B9_7F4A_7C15);
    for (name, base, levels, base_faces) in cases {
        let fine = refined(base, levels);
        for _ in 0..4 {
            let mesh = shuffled(&fine, &mut rng);
            let found = detect_subdivision(&mesh).unwrap_or_else(|e| panic!("{name}: {e}"));
            check(&mesh, &found, levels, base_faces);
        }
    }
}

#[test]
fn tori_coarsen_as_far_as_the_base_stays_valid() {
    // 8x6 coarsens to 4x3, which cannot be halved again (3 is odd).
    let mut rng = SplitMix64::new(7);
    let mesh = shuffled(&refined(torus_quads(8, 6, 2.0, 1.0), 1), &mut rng);
    check(&mesh, &detect_subdivision(&mesh).unwrap(), 2, 12);
    // 4x6 would coarsen to 2x3, whose edges come in pairs.
    let mesh = shuffled(&torus_quads(4, 6, 2.0, 1.0), &mut rng);
    assert_eq!(
        detect_subdivision(&mesh).unwrap_err(),
        Error::NoSubdivisionConnectivity
    );
}

#[test]
fn components_share_one_level() {
    // The cube could lose three levels, the torus only two.
    let cube = refined(cube(), 3);
    let torus = refined(torus_quads(4, 6, 2.0, 1.0), 2);
    let mut rng = SplitMix64::new(11);
    let mesh = shuffled(&disjoint(cube, torus), &mut rng);
    check(&mesh, &detect_subdivision(&mesh).unwrap(), 2, 6 * 4 + 24);
}

#[test]
fn rejects_what_it_cannot_use_with_clear_errors() {
    let triangles = PolyMesh::from_faces(vec![DVec3::ZERO, DVec3::X, DVec3::Y], &[[0u32, 1, 2]]);
    let err = detect_subdivision(&triangles).unwrap_err();
    assert_eq!(
        err,
        Error::NotQuads {
            face: 0,
            corners: 3
        }
    );

    let (positions, faces) = refined(cube(), 1);
    let mut mixed = PolyMesh::from_faces(positions.clone(), &faces);
    mixed.push_face(&[0, 1, 2]);
    assert_eq!(
        detect_subdivision(&mixed).unwrap_err().to_string(),
        "not a quad mesh: face 24 has 3 corners"
    );

    assert_eq!(
        detect_subdivision(&PolyMesh::new()).unwrap_err(),
        Error::NoFaces { mesh: None }
    );

    let (positions0, faces0) = cube();
    let plain = PolyMesh::from_faces(positions0, &faces0);
    let err = detect_subdivision(&plain).unwrap_err();
    assert_eq!(err, Error::NoSubdivisionConnectivity);
    assert!(err.to_string().contains("no subdivision connectivity"));
    assert!(err.to_string().contains("remeshing"));

    let mut extra = positions.clone();
    extra.push(DVec3::ONE);
    let unused = PolyMesh::from_faces(extra, &faces);
    assert_eq!(
        detect_subdivision(&unused).unwrap_err(),
        Error::UnusedVertex { vertex: 26 }
    );

    let mut flipped = faces.clone();
    flipped[5].reverse();
    let err = detect_subdivision(&PolyMesh::from_faces(positions.clone(), &flipped)).unwrap_err();
    assert!(
        matches!(
            err,
            Error::InvalidMesh(qm_lift::Error::InconsistentOrientation { .. })
        ),
        "{err}"
    );

    // Three quads on one edge.
    let fin: Vec<DVec3> = (0..8).map(|v| DVec3::splat(v as f64)).collect();
    let fins = PolyMesh::from_faces(fin, &[[0u32, 1, 2, 3], [1, 0, 4, 5], [1, 0, 6, 7]]);
    let err = detect_subdivision(&fins).unwrap_err();
    assert!(
        matches!(
            err,
            Error::InvalidMesh(qm_lift::Error::NonManifoldEdge { .. })
        ),
        "{err}"
    );

    let mut out_of_range = faces.clone();
    out_of_range[0][0] = 1000;
    let err = detect_subdivision(&PolyMesh::from_faces(positions, &out_of_range)).unwrap_err();
    assert!(matches!(err, Error::InvalidMesh(_)), "{err}");
    assert!(!err.to_string().contains('\n'));
}

/// Drops vertices no face uses, renumbering the rest.
fn compacted((positions, faces): Quads) -> Quads {
    let mut new_id = vec![u32::MAX; positions.len()];
    let mut kept = Vec::new();
    let faces = faces
        .iter()
        .map(|f| {
            f.map(|v| {
                if new_id[v as usize] == u32::MAX {
                    new_id[v as usize] = kept.len() as u32;
                    kept.push(positions[v as usize]);
                }
                new_id[v as usize]
            })
        })
        .collect();
    (kept, faces)
}

#[test]
fn damaged_meshes_give_errors_or_exact_results_never_panics() {
    let mut rng = SplitMix64::new(0xDEAD_BEEF);
    let bases = [
        refined(cube(), 3),
        refined(torus_quads(4, 6, 2.0, 1.0), 2),
        refined(holed_grid(), 2),
        refined(open_cylinder_quads(4, 2), 3),
        refined(quad_fan(5), 2),
    ];
    let mut detected = 0;
    for base in &bases {
        for round in 0..60 {
            let (positions, mut faces) = base.clone();
            for _ in 0..1 + round % 3 {
                let f = rng.below(faces.len());
                match rng.below(6) {
                    0 => {
                        faces.swap_remove(f);
                    }
                    // `refine` emits the children of a coarser face together,
                    // so an aligned block is a hole that keeps some levels.
                    1 => {
                        let block = [4, 16][rng.below(2)];
                        let at = f / block * block;
                        faces.drain(at..(at + block).min(faces.len()));
                    }
                    2 => faces[f].reverse(),
                    3 => faces[f][rng.below(4)] = rng.below(positions.len()) as u32,
                    4 => faces.push(faces[f]),
                    _ => {
                        // Glue two vertices into one.
                        let (a, b) = (rng.below(positions.len()), rng.below(positions.len()));
                        for q in &mut faces {
                            for v in q.iter_mut() {
                                if *v == a as u32 {
                                    *v = b as u32;
                                }
                            }
                        }
                    }
                }
            }
            let mesh = shuffled(&compacted((positions, faces)), &mut rng);
            if let Ok(found) = detect_subdivision(&mesh) {
                check(&mesh, &found, found.level, found.mesh.layout().face_count());
                detected += 1;
            }
        }
    }
    assert!(detected > 0);
    // Random quad soups over few vertices.
    for _ in 0..300 {
        let n = 4 + rng.below(12);
        let positions = (0..n).map(|v| DVec3::splat(v as f64)).collect();
        let faces: Vec<[u32; 4]> = (0..1 + rng.below(12))
            .map(|_| std::array::from_fn(|_| rng.below(n) as u32))
            .collect();
        let mesh = PolyMesh::from_faces(positions, &faces);
        if let Ok(found) = detect_subdivision(&mesh) {
            check(&mesh, &found, found.level, found.mesh.layout().face_count());
        }
    }
}

/// Reads an OBJ file's polygons as they are (no triangulation).
fn load_obj(path: &Path) -> PolyMesh {
    let options = tobj::LoadOptions {
        triangulate: false,
        ..Default::default()
    };
    let (models, _) = tobj::load_obj(path, &options).unwrap();
    let mut mesh = PolyMesh::new();
    for model in models {
        let m = model.mesh;
        let offset = mesh.positions.len() as u32;
        mesh.positions.extend(
            m.positions
                .chunks_exact(3)
                .map(|p| DVec3::new(p[0] as f64, p[1] as f64, p[2] as f64)),
        );
        let arities = if m.face_arities.is_empty() {
            vec![3; m.indices.len() / 3]
        } else {
            m.face_arities
        };
        let mut at = 0;
        for arity in arities {
            let corners: Vec<u32> = m.indices[at..at + arity as usize]
                .iter()
                .map(|&v| v + offset)
                .collect();
            mesh.push_face(&corners);
            at += arity as usize;
        }
    }
    mesh
}

/// The bundled quad meshes, made outside the project.
#[test]
fn bundled_quad_models() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../assets/quad");
    for (name, level, base_faces) in [
        ("cc_cube.obj", 5, 6),
        ("cc_dodecahedron.obj", 3, 60),
        ("torus_4x6_l4.obj", 4, 24),
        ("holed_grid_l4.obj", 4, 15),
    ] {
        let mesh = load_obj(&dir.join(name));
        let found = detect_subdivision(&mesh).unwrap_or_else(|e| panic!("{name}: {e}"));
        eprintln!(
            "{name}: level {}, {} base faces",
            found.level,
            found.mesh.layout().face_count()
        );
        check(&mesh, &found, level, base_faces);
    }
}

/// Timing on a large mesh, in generation order and scrambled (scattered ids
/// make nearly every access a cache miss):
/// `cargo test --release -p qm-param large -- --ignored --nocapture`.
#[test]
#[ignore]
fn large_mesh_timing() {
    let fine = refined(cube(), 9);
    for (order, mesh) in [
        ("generated", PolyMesh::from_faces(fine.0.clone(), &fine.1)),
        ("scrambled", shuffled(&fine, &mut SplitMix64::new(3))),
    ] {
        let start = std::time::Instant::now();
        let found = detect_subdivision(&mesh).unwrap();
        eprintln!(
            "{order}: {} vertices, {} quads: level {} in {:?}",
            mesh.positions.len(),
            mesh.face_count(),
            found.level,
            start.elapsed()
        );
        check(&mesh, &found, 9, 6);
    }
}
