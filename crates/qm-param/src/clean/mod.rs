//! Mesh clean-up before parameterization.
//!
//! [`clean`] turns any polygon mesh into a list of triangle meshes, one per
//! connected component, each a single edge-manifold, vertex-manifold,
//! consistently oriented surface, and reports what it changed in one line
//! ([`CleanReport`]). In order:
//!
//! 1. polygons are split into triangles: fans `(v0, vi, vi+1)`, or for a convex
//!    polygon of more than four corners a strip from both ends in turn;
//! 2. vertices with bit-identical positions are merged (texture-seam
//!    duplicates);
//! 3. degenerate triangles (a repeated vertex, or an exactly zero cross
//!    product) are dropped. Triangles on the same vertex set cancel in
//!    pairs that run opposite ways, as in a sum of oriented faces: of those
//!    on one set, one opposite pair stands for the cancelled ones, one
//!    triangle of the orientation left over (if any) is kept, and the rest
//!    are dropped as duplicates. The pairs then cancel (both faces go) in
//!    every patch of such pairs that meets two or more other faces at some
//!    edge: a thin part that a reconstruction collapsed to zero thickness,
//!    or the wall where two parts touch face to face, whose rim would
//!    otherwise have four faces to an edge all around it. A patch that
//!    meets at most one other face at each edge (a free two-sided sheet, or
//!    a face stored again, reversed, on a surface) keeps one face per
//!    vertex set;
//! 4. the faces around an edge with more than two are paired into sheets
//!    where they can be (see `pair_sheets`): sorted by angle about the
//!    edge, a face pairs with its neighbour when the two run the edge in
//!    opposite directions and the wedge between them is inside the solid
//!    (parts that touch along the edge come apart), or, the other way,
//!    outside it (they join there). Both are tried where any edge has more
//!    than two faces, and the simpler result is kept: fewer handles, holes and
//!    components, which is what the remesher must cut through. Pinched
//!    edges of a reconstructed scan then become manifold sheets; cut
//!    loose, their faces would leave slits. Faces left over are cut loose,
//!    as are all of an edge's faces where none pair;
//! 5. faces are oriented greedily, breadth first: a face joins its neighbour
//!    across an edge (or a sheet) only if exactly two faces use it and their
//!    orientations can agree (flipping the newly reached face if needed).
//!    Every other shared edge (an orientation conflict as on a Möbius
//!    strip) is cut;
//! 6. every vertex gets one copy per fan of faces joined around it, which
//!    both separates the sides of cut edges and splits non-manifold
//!    (bow-tie) vertices. Where two sheets of an edge would still share both
//!    copies (the fans around its ends join them elsewhere, as when the
//!    pairing joins two parts that touch only along the edge), the edge's
//!    pairing is undone; where a cut edge's faces would still share both
//!    copies (a cut across a closed fan), one face is detached at that
//!    vertex by cutting its other edge there. Each round regroups, until
//!    nothing is shared;
//! 7. components (faces connected through joined edges) are separated and
//!    renumbered compactly, in input order; unused vertices disappear;
//! 8. each component keeps the orientation most of its input faces had,
//!    except that a closed component is oriented to positive signed volume
//!    `sum of a . (b x c) / 6` (outward normals).
//!
//! Holes stay holes. The only faces removed that are not degenerate or
//! duplicates are cancelled pairs (step 3), which leave an opening only
//! where such a patch also meets a single face at some edge. Everything is
//! sorting and union-find, `O(n log n)` per round of step 6.
//!
//! [`topology()`] counts a triangle mesh's vertices, edges, faces, boundary
//! loops and genus (`V - E + F = 2 - 2g - b`) and checks it is manifold.
//!
//! The steps have modules: `triangulate` (1), `duplicates` (2 and 3),
//! `edges` (4), `orient` (5), `fans` (6) and `assemble` (7 and 8); what was
//! changed is counted in `report`. Why sheets are paired and cancelled as
//! they are: docs/decisions/022-clean-up-sheets.md.

mod assemble;
mod duplicates;
mod edges;
mod fans;
mod orient;
mod report;
#[cfg(test)]
mod tests;
mod topology;
mod triangulate;

use qm_io::PolyMesh;
use qm_lift::glam::DVec3;

use assemble::assemble;
use duplicates::{drop_bad_triangles, merge_identical};
use edges::{EdgeTable, prev_corner, signed_volume};
use fans::{corner_groups, count_edges, shared_ends};
use orient::{EdgeState, orient};
pub use report::CleanReport;
pub use topology::{Topology, components_topology, topology};
use triangulate::triangulate;

use crate::{Error, Result, TriMesh};

/// The components of a cleaned mesh and what cleaning changed.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Cleaned {
    /// One connected, manifold, consistently oriented mesh per component, in
    /// the order of their first input face.
    pub components: Vec<TriMesh>,
    /// What was changed; its `Display` is one summary line.
    pub report: CleanReport,
}

/// Cleans `mesh` into manifold, consistently oriented components (see the
/// module documentation for the steps).
///
/// A mesh with no usable face gives no components, not an error.
///
/// # Errors
/// [`Error::MissingVertex`] if a face refers to a missing vertex,
/// [`Error::NonFinite`] if a used vertex is NaN or infinite.
pub fn clean(mesh: &PolyMesh) -> Result<Cleaned> {
    clean_with(mesh, true)
}

/// [`clean`], except that attached zero-thickness sheets are kept: both
/// faces of each opposite pair go on to the pairing of step 4, which joins
/// them to the surface where it can and cuts them loose as parts of their
/// own where it cannot. For a base that is the input's own triangles
/// (`remesh::exact`), where a part costs no more than its triangles: the
/// thin parts of a coarse reconstruction (dragon_vrip_res4's fins) stay.
/// A remesh cannot afford them (a level for every such splinter).
pub fn clean_keeping_sheets(mesh: &PolyMesh) -> Result<Cleaned> {
    clean_with(mesh, false)
}

fn clean_with(mesh: &PolyMesh, cancel: bool) -> Result<Cleaned> {
    let mut report = CleanReport {
        input_vertices: mesh.positions.len(),
        input_faces: mesh.face_count(),
        ..CleanReport::default()
    };
    let tris = triangulate(mesh, &mut report)?;
    report.triangles = tris.len();

    let (remap, positions) = merge_identical(&mesh.positions);
    report.merged_vertices = mesh.positions.len() - positions.len();
    let tris = drop_bad_triangles(tris, &remap, &positions, cancel, &mut report);

    // Step 4 both ways (parts kept apart, parts joined) where any edge has
    // more than two faces: the simpler surface wins.
    let outward = signed_volume(&tris, &positions) >= 0.0;
    let (first, crowded) = resolve(&tris, &positions, report, outward)?;
    if !crowded {
        return Ok(first);
    }
    let (second, _) = resolve(&tris, &positions, report, !outward)?;
    Ok(if complexity(&second) < complexity(&first) {
        second
    } else {
        first
    })
}

/// How hard a cleaned surface is to remesh: twice the genus plus the holes,
/// summed, plus the components (each handle takes two loops of cut, each
/// hole a path to it, each component a chart).
fn complexity(cleaned: &Cleaned) -> i64 {
    let topo = components_topology(&cleaned.components);
    topo.iter()
        .map(|t| 2 * t.genus + t.boundary_loops as i64 + 1)
        .sum()
}

/// Steps 4 to 8 on the clean-up's triangles, pairing as if the normals
/// pointed `outward` (see `pair_sheets`). Also says whether any edge has
/// more than two faces (so that pairing the other way may differ).
fn resolve(
    tris: &[[u32; 3]],
    positions: &[DVec3],
    mut report: CleanReport,
    outward: bool,
) -> Result<(Cleaned, bool)> {
    let edges = EdgeTable::new(tris, positions, outward);
    let (flip, mut state) = orient(tris, &edges);

    // Step 6: one vertex copy per fan. Where faces of an edge still share
    // both copies without being joined there, undo the edge's pairing, or
    // else detach a face; regroup after each round (splitting only ever
    // separates more, so this ends).
    let mut roots = corner_groups(tris, &edges, &state);
    loop {
        let shared = shared_ends(&edges, &state, &roots);
        if shared.is_empty() {
            break;
        }
        let mut changed = false;
        let mut undone = None;
        for (k, c) in shared {
            // The next round looks at an edge again once its pairing is undone.
            if undone == Some(k) {
                continue;
            }
            let sheets = edges.sheets(k);
            if sheets.len() > 1 && sheets.clone().any(|e| state[e] == EdgeState::Joined) {
                for e in sheets {
                    if state[e] == EdgeState::Joined {
                        state[e] = EdgeState::Cut;
                        changed = true;
                    }
                }
                undone = Some(k);
                continue;
            }
            let e = edges.edge_of[prev_corner(c)] as usize;
            if state[e] == EdgeState::Joined {
                state[e] = EdgeState::Cut;
                changed = true;
            }
        }
        if !changed {
            return Err(Error::Internal("clean-up left an edge shared"));
        }
        roots = corner_groups(tris, &edges, &state);
    }
    count_edges(&edges, &state, &mut report);

    let components = assemble(tris, positions, &edges, &state, &flip, &roots, &mut report);
    Ok((Cleaned { components, report }, edges.crowded))
}
