//! Steps 7 and 8 of the clean-up: the components separated, one vertex
//! copy per fan, numbered compactly in input order, and each component
//! oriented (closed ones outward, open ones as most of their input faces).

use qm_lift::glam::DVec3;

use super::edges::EdgeTable;
use super::orient::EdgeState;
use super::report::CleanReport;
use crate::TriMesh;
use crate::union_find::UnionFind;

/// Steps 6 and 7: components, orientation, compact numbering.
pub(super) fn assemble(
    tris: &[[u32; 3]],
    positions: &[DVec3],
    edges: &EdgeTable,
    state: &[EdgeState],
    flip: &[bool],
    roots: &[u32],
    report: &mut CleanReport,
) -> Vec<TriMesh> {
    let nf = tris.len();
    let mut sets = UnionFind::new(nf);
    for (e, s) in state.iter().enumerate() {
        if *s == EdgeState::Joined {
            let pair = edges.corners(e);
            sets.union(pair[0] / 3, pair[1] / 3);
        }
    }
    // Components numbered by their first face.
    let mut comp_of = vec![u32::MAX; nf];
    let mut count = 0usize;
    for f in 0..nf {
        let r = sets.find(f as u32) as usize;
        if comp_of[r] == u32::MAX {
            comp_of[r] = count as u32;
            count += 1;
        }
        comp_of[f] = comp_of[r];
    }

    // Orientation per component: closed ones outward, open ones as most of
    // their input faces were.
    let mut closed = vec![true; count];
    let mut flipped = vec![0usize; count];
    let mut faces = vec![0usize; count];
    let mut volume = vec![0.0f64; count];
    let mut origin: Vec<Option<DVec3>> = vec![None; count];
    for f in 0..nf {
        let k = comp_of[f] as usize;
        faces[k] += 1;
        flipped[k] += usize::from(flip[f]);
        if (0..3).any(|i| state[edges.edge_of[3 * f + i] as usize] != EdgeState::Joined) {
            closed[k] = false;
        }
        let [a, b, c] = tris[f].map(|v| positions[v as usize]);
        // Relative to a point of the component, for precision far from 0.
        let o = *origin[k].get_or_insert(a);
        let v = (a - o).dot((b - o).cross(c - o));
        volume[k] += if flip[f] { -v } else { v };
    }
    let reverse: Vec<bool> = (0..count)
        .map(|k| {
            if closed[k] && volume[k] != 0.0 {
                volume[k] < 0.0
            } else {
                2 * flipped[k] > faces[k]
            }
        })
        .collect();

    // Vertex copies numbered within their component in input vertex order.
    let mut by_vertex_start = vec![0usize; positions.len() + 1];
    for t in tris {
        for &v in t {
            by_vertex_start[v as usize + 1] += 1;
        }
    }
    for v in 0..positions.len() {
        by_vertex_start[v + 1] += by_vertex_start[v];
    }
    let mut fill = by_vertex_start.clone();
    let mut by_vertex = vec![0u32; 3 * nf];
    for (t, tri) in tris.iter().enumerate() {
        for (i, &v) in tri.iter().enumerate() {
            by_vertex[fill[v as usize]] = (3 * t + i) as u32;
            fill[v as usize] += 1;
        }
    }
    let mut components = vec![TriMesh::default(); count];
    let mut local = vec![u32::MAX; 3 * nf];
    for v in 0..positions.len() {
        let corners = &by_vertex[by_vertex_start[v]..by_vertex_start[v + 1]];
        if corners.is_empty() {
            report.dropped_unused_vertices += 1;
            continue;
        }
        let mut copies = 0;
        for &c in corners {
            let r = roots[c as usize] as usize;
            if local[r] == u32::MAX {
                let mesh = &mut components[comp_of[c as usize / 3] as usize];
                local[r] = mesh.positions.len() as u32;
                mesh.positions.push(positions[v]);
                copies += 1;
            }
        }
        if copies > 1 {
            report.split_vertices += 1;
            report.added_vertices += copies - 1;
        }
    }
    for f in 0..nf {
        let k = comp_of[f] as usize;
        let [a, b, c] = [0, 1, 2].map(|i| local[roots[3 * f + i] as usize]);
        let flipped = flip[f] ^ reverse[k];
        report.flipped_faces += usize::from(flipped);
        components[k]
            .triangles
            .push(if flipped { [a, c, b] } else { [a, b, c] });
    }
    report.components = count;
    report.output_vertices = components.iter().map(|m| m.positions.len()).sum();
    report.output_faces = nf;
    components
}
