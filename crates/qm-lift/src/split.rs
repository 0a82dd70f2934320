//! Base quad meshes made of triangle meshes: every triangle split into three
//! quads through its centroid and its edges' midpoints, with one numbering
//! that both the remesher and the base coder follow, so that the coder can
//! send the triangles alone and the decoder make the same quads.

use std::collections::HashMap;

/// The quads of a split triangle mesh ([`split_triangles`]).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct TriangleSplit {
    /// Three quads per triangle, in triangle order: the quad at corner `c` of
    /// triangle `(a, b, d)` (`a` at `c`) is `[a, mid(a b), centre, mid(d a)]`.
    pub faces: Vec<[u32; 4]>,
    /// Corners, then edge midpoints, then centres.
    pub vertex_count: u32,
    /// Per split corner (ids `0..corners.len()`), the triangle mesh's vertex.
    pub corners: Vec<u32>,
    /// How many distinct edges the triangles have (ids from
    /// `corners.len()` on, in order of first use).
    pub edge_count: u32,
}

/// Splits `triangles` into quads. Vertices are numbered: the triangles'
/// corners in order of first use, then one per edge in order of first use
/// (edges `t[0] t[1]`, `t[1] t[2]`, `t[2] t[0]` of each triangle), then one
/// per triangle.
pub fn split_triangles(triangles: &[[u32; 3]]) -> TriangleSplit {
    let mut compact: HashMap<u32, u32> = HashMap::new();
    let mut corners = Vec::new();
    for &v in triangles.iter().flatten() {
        compact.entry(v).or_insert_with(|| {
            corners.push(v);
            corners.len() as u32 - 1
        });
    }
    let first_edge = corners.len() as u32;
    let mut edges: HashMap<(u32, u32), u32> = HashMap::new();
    for t in triangles {
        for i in 0..3 {
            let (a, b) = (t[i], t[(i + 1) % 3]);
            let next = first_edge + edges.len() as u32;
            edges.entry((a.min(b), a.max(b))).or_insert(next);
        }
    }
    let first_centre = first_edge + edges.len() as u32;
    let edge = |a: u32, b: u32| edges[&(a.min(b), a.max(b))];
    let compact = &compact;
    let faces = triangles
        .iter()
        .enumerate()
        .flat_map(|(ti, t)| {
            let centre = first_centre + ti as u32;
            (0..3).map(move |c| {
                let (a, b, d) = (t[c], t[(c + 1) % 3], t[(c + 2) % 3]);
                [compact[&a], edge(a, b), centre, edge(d, a)]
            })
        })
        .collect();
    TriangleSplit {
        faces,
        vertex_count: first_centre + triangles.len() as u32,
        corners,
        edge_count: edges.len() as u32,
    }
}

/// The base triangles in the order the base coder sends them cheaply, each
/// with the corner it starts at: every triangle after the first of its
/// part shares an edge with one before it, the most recently opened such
/// edge first, and starts at that edge (`docs/format.md`, version 3). The
/// remesher orders its bases' triangles so.
pub fn coding_order(triangles: &[[u32; 3]]) -> Vec<(u32, u8)> {
    let mut holding: HashMap<(u32, u32), (u32, u8)> = HashMap::with_capacity(3 * triangles.len());
    for (t, tri) in triangles.iter().enumerate() {
        for i in 0..3 {
            holding.insert((tri[i], tri[(i + 1) % 3]), (t as u32, i as u8));
        }
    }
    let mut placed = vec![false; triangles.len()];
    let mut order = Vec::with_capacity(triangles.len());
    // Open edges, the most recent last, as the coder lists them: a
    // triangle opens its edges in turn, so its last is the most recent.
    let mut open: Vec<(u32, u32)> = Vec::new();
    for seed in 0..triangles.len() as u32 {
        let mut next = (!placed[seed as usize]).then_some((seed, 0u8));
        while let Some((t, r)) = next {
            placed[t as usize] = true;
            order.push((t, r));
            let tri = triangles[t as usize];
            // The first edge is the one attached to (but in a part's first
            // triangle), and its twin is placed: it is dropped when popped.
            for i in 0..3 {
                let k = (r as usize + i) % 3;
                open.push((tri[k], tri[(k + 1) % 3]));
            }
            next = None;
            while let Some((a, b)) = open.pop() {
                if let Some(&(u, i)) = holding.get(&(b, a)).filter(|(u, _)| !placed[*u as usize]) {
                    next = Some((u, i));
                    break;
                }
            }
        }
    }
    order
}

/// The triangles that `faces` over `vertex_count` vertices are the split of,
/// corners numbered `0..` in order of first use; `None` when they are not
/// exactly such a split.
pub fn unsplit(faces: &[[u32; 4]], vertex_count: u32) -> Option<Vec<[u32; 3]>> {
    if faces.is_empty() || faces.len() % 3 != 0 {
        return None;
    }
    let triangles: Vec<[u32; 3]> = faces
        .chunks_exact(3)
        .map(|q| [q[0][0], q[1][0], q[2][0]])
        .collect();
    let split = split_triangles(&triangles);
    let numbered = split
        .corners
        .iter()
        .enumerate()
        .all(|(i, &v)| i as u32 == v);
    (numbered && split.vertex_count == vertex_count && split.faces == faces).then_some(triangles)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::BaseMesh;
    use crate::synthetic::OCTAHEDRON;

    #[test]
    fn a_split_is_a_valid_base_and_unsplits() {
        let split = split_triangles(&OCTAHEDRON);
        // 6 corners, 12 edges, 8 centres; 24 quads.
        assert_eq!((split.vertex_count, split.edge_count), (26, 12));
        assert_eq!(split.faces.len(), 24);
        assert!(BaseMesh::new(split.vertex_count, split.faces.clone()).is_ok());
        assert_eq!(
            unsplit(&split.faces, split.vertex_count).as_deref(),
            Some(&OCTAHEDRON[..])
        );
    }

    #[test]
    fn corners_are_numbered_by_first_use() {
        let triangles = [[7, 3, 9], [3, 7, 5]];
        let split = split_triangles(&triangles);
        assert_eq!(split.corners, vec![7, 3, 9, 5]);
        assert_eq!(split.faces[0], [0, 4, 9, 6]);
        // The quads name the compact ids.
        assert_eq!(
            unsplit(&split.faces, split.vertex_count),
            Some(vec![[0, 1, 2], [1, 0, 3]])
        );
    }

    #[test]
    fn other_quad_meshes_do_not_unsplit() {
        let mut split = split_triangles(&OCTAHEDRON);
        assert_eq!(unsplit(&split.faces, split.vertex_count + 1), None);
        split.faces.swap(0, 1);
        assert_eq!(unsplit(&split.faces, split.vertex_count), None);
        // Corners not numbered in order of first use.
        let renamed = split_triangles(&[[1, 0, 2]]);
        let faces: Vec<[u32; 4]> = renamed
            .faces
            .iter()
            .map(|f| {
                let mut f = *f;
                f[0] ^= u32::from(f[0] < 2);
                f
            })
            .collect();
        assert_eq!(unsplit(&faces, renamed.vertex_count), None);
        assert_eq!(unsplit(&[[0, 1, 2, 3]], 4), None);
        assert_eq!(unsplit(&[], 0), None);
    }
}
