//! Step 1 of the clean-up: polygons split into triangles, fans or, for a
//! convex polygon of more than four corners, strips; indices and used
//! positions checked.

use qm_io::PolyMesh;
use qm_lift::glam::DVec3;

use super::report::CleanReport;
use crate::{Error, Result};

/// Step 1: fan triangulation, checking indices and used positions.
pub(super) fn triangulate(mesh: &PolyMesh, report: &mut CleanReport) -> Result<Vec<[u32; 3]>> {
    let n = mesh.positions.len();
    let mut tris = Vec::with_capacity(mesh.face_count());
    for (k, face) in mesh.faces().enumerate() {
        for &v in face {
            match mesh.positions.get(v as usize) {
                None => {
                    return Err(Error::MissingVertex {
                        mesh: None,
                        face: k,
                        vertex: v,
                    });
                }
                Some(p) if !p.is_finite() => {
                    return Err(Error::NonFinite {
                        mesh: None,
                        vertex: v,
                    });
                }
                Some(_) => {}
            }
        }
        debug_assert!(face.iter().all(|&v| (v as usize) < n));
        if face.len() < 3 {
            report.dropped_degenerate += 1;
            continue;
        }
        if face.len() > 4 && convex(&mesh.positions, face) {
            zigzag(face, &mut tris);
        } else {
            for i in 1..face.len() - 1 {
                tris.push([face[0], face[i], face[i + 1]]);
            }
        }
    }
    Ok(tris)
}

/// A convex polygon of more than four corners as a strip of triangles
/// taken from both ends in turn, not a fan: a fan's triangles all meet at
/// its first corner, which then has the polygon's whole valence, and the
/// closest-point queries near it try every one of them
/// (docs/decisions/006-high-valence-bounds.md).
fn zigzag(face: &[u32], tris: &mut Vec<[u32; 3]>) {
    let (mut l, mut r) = (0, face.len() - 1);
    let mut from_left = true;
    while r - l >= 2 {
        if from_left {
            tris.push([face[l], face[l + 1], face[r]]);
            l += 1;
        } else {
            tris.push([face[l], face[r - 1], face[r]]);
            r -= 1;
        }
        from_left = !from_left;
    }
}

/// Whether `face` is a convex polygon: every corner turns the same way
/// about the polygon's normal (Newell's), none straight or back.
fn convex(positions: &[DVec3], face: &[u32]) -> bool {
    let at = |i: usize| positions[face[i % face.len()] as usize];
    let normal = (0..face.len()).fold(DVec3::ZERO, |n, i| n + at(i).cross(at(i + 1)));
    (0..face.len()).all(|i| {
        let turn = (at(i + 1) - at(i)).cross(at(i + 2) - at(i + 1));
        turn.dot(normal) > 0.0
    })
}
