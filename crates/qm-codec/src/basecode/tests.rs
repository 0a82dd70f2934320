use qm_lift::unsplit;

use super::values::{Corners, KEEPS, SPLIT_KEEPS, median_residual_length};
use super::*;

/// A `k x k` grid of quads numbered row by row, on a wavy surface.
fn grid(k: u32) -> (Vec<[u32; 4]>, Vec<[i32; 3]>) {
    let faces = qm_shapes::grid_quads(k, k);
    let values = (0..(k + 1) * (k + 1))
        .map(|i| {
            let (x, y) = ((i % (k + 1)) as f64, (i / (k + 1)) as f64);
            [
                (x * 4000.0) as i32,
                (y * 4000.0) as i32,
                (3000.0 * (x * 0.7).sin() * (y * 0.4).cos()) as i32,
            ]
        })
        .collect();
    (faces, values)
}

type Triangles = Vec<[u32; 3]>;

/// The triangles of a wavy `k x k` grid, two to a square, row by row,
/// split into quads: faces, values, triangles.
fn split_grid(k: u32) -> (Vec<[u32; 4]>, Vec<[i32; 3]>, Triangles) {
    let triangles = qm_shapes::grid_triangles(k, k);
    let split = split_triangles(&triangles);
    // Corners where the grid has them, the rest on the surface halfway.
    let at = |x: f64, y: f64| {
        let z = 3000.0 * (x * 0.7).sin() * (y * 0.4).cos();
        [(x * 4000.0) as i32, (y * 4000.0) as i32, z as i32]
    };
    let corner = |c: u32| ((c % (k + 1)) as f64, (c / (k + 1)) as f64);
    let mut places = vec![(0.0, 0.0); split.vertex_count as usize];
    for (i, &c) in split.corners.iter().enumerate() {
        places[i] = corner(c);
    }
    for (q, face) in split.faces.iter().enumerate() {
        let t = triangles[q / 3];
        let (a, b) = (corner(t[q % 3]), corner(t[(q + 1) % 3]));
        places[face[1] as usize] = ((a.0 + b.0) / 2.0, (a.1 + b.1) / 2.0);
        let centre = t.map(corner);
        places[face[2] as usize] = (
            centre.iter().map(|p| p.0).sum::<f64>() / 3.0,
            centre.iter().map(|p| p.1).sum::<f64>() / 3.0,
        );
    }
    let values = places.iter().map(|&(x, y)| at(x, y)).collect();
    let triangles = unsplit(&split.faces, split.vertex_count).unwrap();
    (split.faces, values, triangles)
}

/// Snapped to their predictions, a split base's midpoints and centres
/// cost next to nothing, move by a step or two at most, and come back
/// exactly; a base that is no split is none to snap.
#[test]
fn snapped_midpoints_and_centres_cost_next_to_nothing() {
    let (faces, values, triangles) = split_grid(16);
    let corners = corner_count(&triangles);
    // The grid's midpoints and centres off the flat triangles between
    // the corners by up to 1 in 4000: what snapping moves.
    let mut snapped = values.clone();
    assert!(snap_split(&faces, &triangles, &mut snapped, i64::MAX));
    assert_eq!(snapped[..corners], values[..corners]);
    let moved = (corners..values.len())
        .flat_map(|v| (0..3).map(move |i| (v, i)))
        .filter(|&(v, i)| snapped[v][i] != values[v][i])
        .count();
    assert!(moved > 0);
    let (before, after) = (
        encode(&faces, &values, 3, false),
        encode(&faces, &snapped, 3, false),
    );
    // Zero residuals: under a bit a value.
    assert!(
        8 * (before.len() - after.len()) > values.len() - corners,
        "{} against {}",
        after.len(),
        before.len()
    );
    let got = decode(&after, faces.len(), values.len(), 0, 3, false).unwrap();
    assert_eq!(got.values, snapped);
    let (quads, grid) = grid(4);
    assert!(split_triangles_of(&quads, grid.len()).is_none());
    // Implied, only the corners are coded; a base that is no split
    // cannot be implied.
    let corners_only = encode(&faces, &snapped, 3, true);
    assert!(corners_only.len() < after.len());
    let got = decode(&corners_only, faces.len(), values.len(), 0, 3, true).unwrap();
    assert_eq!(got.values[..corners], snapped[..corners]);
    assert!(got.values[corners..].iter().all(|v| *v == [0; 3]));
    let bytes = encode(&quads, &grid, 3, true);
    let err = decode(&bytes, quads.len(), grid.len(), 0, 3, true).unwrap_err();
    assert!(err.contains("no split"), "{err}");
}

/// `triangles` in the order the remesher gives them (depth first, each
/// from the most recently opened edge it shares and turned to start
/// there).
fn depth_first(triangles: &[[u32; 3]]) -> Triangles {
    qm_lift::coding_order(triangles)
        .into_iter()
        .map(|(t, r)| std::array::from_fn(|i| triangles[t as usize][(r as usize + i) % 3]))
        .collect()
}

/// Version 4 flags a triangle's vertex when it is the next along the
/// open edges beside the one the triangle attaches to, which version 3
/// named by its distance back (docs/decisions/026-base-connectivity.md):
/// here a 48 x 48 grid's triangles, depth first, cost a quarter less than
/// in version 3 (1,780 bytes against 2,364), and come back.
#[test]
fn vertices_beside_their_edge_cost_less_in_version_4() {
    let triangles = depth_first(&qm_shapes::grid_triangles(48, 48));
    let split = split_triangles(&triangles);
    let none = vec![[0; 3]; split.vertex_count as usize];
    let (three, four) = (
        encode(&split.faces, &none, 3, false),
        encode(&split.faces, &none, 4, false),
    );
    assert!(
        5 * four.len() < 4 * three.len(),
        "version 3 {} bytes, version 4 {}",
        three.len(),
        four.len()
    );
    let got = decode(&four, split.faces.len(), none.len(), 0, 4, false).unwrap();
    assert_eq!(got.faces, split.faces);
}

/// Version 3 sends a split base's triangles and predicts its values
/// over them: the faces cost under a fifth of version 2's bytes here
/// (240 against 1,544), the whole section about half (1,820 against
/// 3,597), and both come back exactly.
#[test]
fn split_bases_cost_less_in_version_3() {
    let (faces, values, triangles) = split_grid(16);
    let faces_alone = |version| {
        let none = vec![[0; 3]; values.len()];
        encode(&faces, &none, version, false).len()
    };
    let (two, three) = (faces_alone(2), faces_alone(3));
    assert!(
        5 * three < two,
        "faces: version 2 {two} bytes, version 3 {three}"
    );
    let (two, three) = (
        encode(&faces, &values, 2, false),
        encode(&faces, &values, 3, false),
    );
    assert!(
        3 * three.len() < 2 * two.len(),
        "{} against {}",
        three.len(),
        two.len()
    );
    let got = decode(&three, faces.len(), values.len(), 0, 3, false).unwrap();
    assert_eq!((got.faces, got.values), (faces.clone(), values.clone()));
    assert_eq!(split_of(&faces, values.len(), 3), Some(triangles));
    // A header that counts other vertices than the triangles make.
    let err = decode(&three, faces.len(), values.len() + 1, 0, 3, false).unwrap_err();
    assert!(err.contains("base vertices"), "{err}");
    assert!(decode(&three, faces.len() - 1, values.len(), 0, 3, false).is_err());
}

#[test]
fn round_trip_and_size() {
    let (faces, values) = grid(9);
    for version in [1, 2, 3, 4, 5, 6] {
        let bytes = encode(&faces, &values, version, false);
        let got = decode(&bytes, faces.len(), values.len(), 0, version, false).unwrap();
        assert_eq!((got.faces, got.values), (faces.clone(), values.clone()));
        // The plain coding took one byte per corner and about three per
        // coordinate: 324 + 300 bytes here.
        assert!(
            bytes.len() < 300,
            "version {version}: {} bytes",
            bytes.len()
        );
    }
}

/// Three quads to each triangle of a triangulated grid, the triangles
/// in a scrambled order and split as the remesher's charts split them:
/// version 2 codes the faces in under three quarters of version 1's
/// bytes (on the remesher's own bases:
/// docs/decisions/026-base-connectivity.md).
#[test]
fn quads_of_scrambled_triangles_cost_less_in_version_2() {
    let mut triangles = qm_shapes::grid_triangles(24, 24);
    let mut x = 7u64;
    for i in (1..triangles.len()).rev() {
        x = x
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        triangles.swap(i, (x >> 33) as usize % (i + 1));
    }
    let faces = split_triangles(&triangles).faces;
    let vertices = faces.iter().flatten().max().map_or(0, |&v| v as usize + 1);
    let values = vec![[0; 3]; vertices];
    let size = |version| {
        let bytes = encode(&faces, &values, version, false);
        let got = decode(&bytes, faces.len(), values.len(), 0, version, false).unwrap();
        assert_eq!(got.faces, faces, "version {version}");
        bytes.len()
    };
    let (one, two) = (size(1), size(2));
    assert!(
        4 * two < 3 * one,
        "version 1: {one} bytes, version 2: {two}"
    );
}

/// Noise bits follow the residuals: none on a plane (the parallelogram
/// rule is exact there), five more when the values are 32 times
/// larger, and the high parts left cost fewer bytes.
#[test]
fn noise_bits_follow_the_residuals() {
    let (faces, values) = grid(9);
    let flat: Vec<[i32; 3]> = values.iter().map(|v| [v[0], v[1], 0]).collect();
    // Every coordinate curved, as on a real surface.
    let values: Vec<[i32; 3]> = values
        .iter()
        .map(|v| [v[0] + v[2], v[1] - v[2], v[2]])
        .collect();
    assert_eq!(noise_bits(&faces, &flat, 3, false), 0);
    let k = noise_bits(&faces, &values, 3, false);
    assert!(k > 0);
    let big: Vec<[i32; 3]> = values.iter().map(|v| v.map(|x| x * 32)).collect();
    assert_eq!(noise_bits(&faces, &big, 3, false), k + 5);
    let high: Vec<[i32; 3]> = values.iter().map(|v| v.map(|x| x >> k)).collect();
    assert!(encode(&faces, &high, 2, false).len() < encode(&faces, &values, 2, false).len());
}

/// The bit length of the median prediction residual of `values`, over
/// `triangles` when they are given.
fn median_length(faces: &[[u32; 4]], values: &[[i32; 3]], triangles: Option<&[[u32; 3]]>) -> u32 {
    median_residual_length(
        &Predictor::new(faces, values.len(), triangles, Corners::Plain),
        values,
    )
}

/// A split base keeps the leading one of its median residual in the
/// base section, a base of quads that bit and the next.
#[test]
fn a_split_base_keeps_one_bit_fewer() {
    // Every coordinate curved, as on a real surface.
    let curved = |values: Vec<[i32; 3]>| -> Vec<[i32; 3]> {
        let v = values.iter().map(|v| [v[0] + v[2], v[1] - v[2], v[2]]);
        v.collect()
    };
    let (faces, values) = grid(9);
    let values = curved(values);
    let quads = median_length(&faces, &values, None);
    assert!(quads > 2);
    assert_eq!(noise_bits(&faces, &values, 4, false), quads - KEEPS);
    let (faces, values, triangles) = split_grid(9);
    let values = curved(values);
    let split = median_length(&faces, &values, Some(&triangles));
    assert!(split > 2);
    assert_eq!(noise_bits(&faces, &values, 4, false), split - SPLIT_KEEPS);
    // Version 2 has no split bases.
    assert_eq!(
        noise_bits(&faces, &values, 2, false),
        median_length(&faces, &values, None) - KEEPS
    );
}

#[test]
fn extreme_values_round_trip() {
    let faces = vec![[0, 1, 2, 3], [3, 2, 1, 0]];
    let values = vec![
        [i32::MIN, i32::MAX, 0],
        [i32::MAX, i32::MIN, -1],
        [0; 3],
        [5, -5, 7],
    ];
    for version in [1, 2, 3, 4, 5, 6] {
        let bytes = encode(&faces, &values, version, false);
        let got = decode(&bytes, 2, 4, 0, version, false).unwrap();
        assert_eq!((&got.faces, &got.values), (&faces, &values));
    }
}

#[test]
fn damage_gives_errors_not_panics() {
    for version in [1, 2, 3, 4, 5, 6] {
        let (faces, values) = grid(4);
        damage(version, faces, values);
    }
    for version in [3, 4, 5, 6] {
        let (faces, values, _) = split_grid(3);
        damage(version, faces, values);
    }
    for version in [5, 6] {
        let (faces, values) = cad_cylinder(6);
        damage(version, faces, values);
    }
}

/// Version 6 keeps every open edge, names a vertex met again by an open
/// edge it ends, and learns each triangle's flags after what the one or two
/// triangles before did. Depth first, a 96 x 96 grid's 18,432 triangles
/// cost 8,624 bytes in version 5 and 473 in version 6 (its front outgrows
/// version 5's 256 open edges); a fan-capped cylinder of 600 segments
/// 1,353 and 32, one of 64 segments 54 and 27. All come back.
#[test]
fn triangles_cost_less_in_version_6() {
    let grid = depth_first(&qm_shapes::grid_triangles(96, 96));
    let shapes = [
        (grid, 4),
        (depth_first(&qm_shapes::cylinder(600).1), 4),
        (depth_first(&qm_shapes::cylinder(64).1), 1),
    ];
    for (triangles, at_least) in shapes {
        let split = split_triangles(&triangles);
        let none = vec![[0; 3]; split.vertex_count as usize];
        let [five, six] = [5, 6].map(|v| encode(&split.faces, &none, v, false));
        let count = triangles.len();
        assert!(
            at_least * six.len() < five.len(),
            "{count} triangles: version 5 {} bytes, version 6 {}",
            five.len(),
            six.len()
        );
        let got = decode(&six, split.faces.len(), none.len(), 0, 6, false).unwrap();
        assert_eq!(got.faces, split.faces, "{count} triangles");
        // Contexts by one triangle before or by two: both come back.
        let numbered = unsplit(&split.faces, split.vertex_count).unwrap();
        for history in [1, 2] {
            let (faces, tri) = (&split.faces, Some(&numbered[..]));
            let bytes = encode_choosing(faces, &none, 6, tri, false, Corners::Plain, history);
            let got = decode(&bytes, faces.len(), none.len(), 0, 6, false).unwrap();
            assert_eq!(&got.faces, faces, "{count} triangles, history {history}");
        }
    }
}

/// A fan-capped cylinder of `n` segments (as CAD exports make) as a split
/// base in the coder's depth-first order, its corners quantized to a
/// 16-bit grid (the others are 0).
fn cad_cylinder(n: u32) -> (Vec<[u32; 4]>, Vec<[i32; 3]>) {
    let (positions, triangles) = qm_shapes::cylinder(n);
    let split = split_triangles(&depth_first(&triangles));
    let mut values = vec![[0; 3]; split.vertex_count as usize];
    for (i, &c) in split.corners.iter().enumerate() {
        let p = positions[c as usize] * 16000.0;
        values[i] = [p.x, p.y, p.z].map(|x| x.round() as i32);
    }
    (split.faces, values)
}

/// Version 5 names which parallelograms predict a corner: across a crease
/// (a cap's rim) the others are far off, on the same face exact. A
/// fan-capped cylinder's 130 corners cost 545 bytes in version 4, 494
/// with the choice and 263 with the choice in the order that gives each
/// corner the most parallelograms known; every way comes back; where the
/// choice saves nothing (a smooth grid) version 5 costs at most the byte of
/// its flag more.
#[test]
fn corners_by_chosen_parallelograms_cost_less_in_version_5() {
    let (faces, values) = cad_cylinder(64);
    let [four, five] = [4, 5].map(|v| encode(&faces, &values, v, true));
    assert!(
        5 * five.len() < 3 * four.len(),
        "version 4 {} bytes, version 5 {}",
        four.len(),
        five.len()
    );
    // Each way of predicting the corners comes back, whole or cut.
    let triangles = unsplit(&faces, values.len() as u32).unwrap();
    let corners = corner_count(&triangles);
    for mode in [Corners::Plain, Corners::Chosen, Corners::ChosenInOrder] {
        let bytes = encode_choosing(&faces, &values, 5, Some(&triangles), true, mode, 1);
        let got = decode(&bytes, faces.len(), values.len(), 0, 5, true).unwrap();
        assert_eq!(got.faces, faces);
        assert_eq!(got.values[..corners], values[..corners], "{mode:?}");
        for cut in 0..bytes.len() {
            if let Ok(got) = decode(&bytes[..cut], faces.len(), values.len(), 0, 5, true) {
                assert_eq!(
                    got.values[..corners],
                    values[..corners],
                    "{mode:?} cut {cut}"
                );
            }
        }
    }
    let (faces, values, _) = split_grid(16);
    let [four, five] = [4, 5].map(|v| encode(&faces, &values, v, false));
    assert!(five.len() <= four.len() + 1);
}

/// A hub that 100,000 triangles share, each otherwise apart, keeps 200,000
/// edges open at one vertex: such a base (a hostile file's, or a fan's)
/// codes and decodes (in steps a triangle, not in a search of the hub's
/// edges, 5 · 10^9 steps here: `front`'s `a_hub_costs_steps_not_searches`
/// counts them).
#[test]
fn a_hub_of_open_edges_codes_in_steps() {
    let triangles: Triangles = (0..100_000u32).map(|i| [0, 2 * i + 1, 2 * i + 2]).collect();
    let split = split_triangles(&triangles);
    let none = vec![[0; 3]; split.vertex_count as usize];
    let bytes = encode(&split.faces, &none, 6, false);
    let got = decode(&bytes, split.faces.len(), none.len(), 0, 6, false).unwrap();
    assert_eq!(got.faces, split.faces);
}

fn damage(version: u8, faces: Vec<[u32; 4]>, values: Vec<[i32; 3]>) {
    let decode = |b: &[u8], f, v| decode(b, f, v, 0, version, false);
    let bytes = encode(&faces, &values, version, false);
    // A cut either fails or, when the coder's last bytes were not
    // needed, still gives exactly the data.
    for cut in 0..bytes.len() {
        if let Ok(got) = decode(&bytes[..cut], faces.len(), values.len()) {
            assert_eq!(
                (got.faces, got.values),
                (faces.clone(), values.clone()),
                "cut {cut}"
            );
        }
    }
    assert!(decode(&bytes[..bytes.len() / 2], faces.len(), values.len()).is_err());
    let mut x = 1u64;
    for _ in 0..2000 {
        let mut b = bytes.clone();
        x = x.wrapping_mul(6364136223846793005).wrapping_add(1);
        let at = (x >> 33) as usize % b.len();
        b[at] ^= 1 << ((x >> 20) % 8);
        let _ = decode(&b, faces.len(), values.len());
    }
    assert!(decode(&bytes, faces.len(), values.len() - 1).is_err());
}
