//! Quad meshes with half-edge adjacency, built in linear time.
//!
//! Side `k` of face `f` is half-edge `4 f + k`, running from corner `k` to
//! corner `k + 1`; its twin is the opposite side of the neighbouring face.
//! The validity rules are those of [`qm_lift::BaseMesh::new`] (no repeated
//! corner, every vertex used, no directed edge twice, so an undirected edge
//! has at most two faces running along it opposite ways), but checked with
//! per-vertex lists instead of a hash map: detection builds one of these per
//! level, and on million-quad inputs with scattered vertex ids the hash map
//! dominated the run time.

/// Marks a boundary half-edge.
const NO_TWIN: u32 = u32::MAX;

/// Which roles a vertex may take when subdivision is undone, from the quads
/// around it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Valence {
    /// Interior, in one closed fan of four quads.
    Interior4,
    /// On the boundary, in one open fan of two quads.
    Boundary2,
    /// Anything else.
    Extraordinary,
}

/// A valid, consistently oriented, edge-manifold quad mesh.
pub(crate) struct QuadMesh {
    vertex_count: u32,
    faces: Vec<[u32; 4]>,
    twin: Vec<u32>,
    valence: Vec<Valence>,
}

impl QuadMesh {
    /// Builds the adjacency, or hands the faces back if they break a rule.
    pub(crate) fn new(vertex_count: u32, faces: Vec<[u32; 4]>) -> Result<Self, Vec<[u32; 4]>> {
        let nv = vertex_count as usize;
        if faces.is_empty() || faces.len() > (u32::MAX / 4) as usize {
            return Err(faces);
        }
        // Outgoing half-edges of each vertex, grouped by vertex.
        let mut start = vec![0u32; nv + 1];
        for face in &faces {
            for (k, &v) in face.iter().enumerate() {
                if v >= vertex_count || face[..k].contains(&v) {
                    return Err(faces);
                }
                start[v as usize + 1] += 1;
            }
        }
        for v in 0..nv {
            if start[v + 1] == 0 {
                return Err(faces);
            }
            start[v + 1] += start[v];
        }
        let mut cursor = start.clone();
        let mut out = vec![(0u32, 0u32); faces.len() * 4];
        for (f, face) in faces.iter().enumerate() {
            for k in 0..4 {
                let slot = &mut cursor[face[k] as usize];
                out[*slot as usize] = (face[(k + 1) & 3], (4 * f + k) as u32);
                *slot += 1;
            }
        }
        drop(cursor);
        let list = |v: u32| start[v as usize] as usize..start[v as usize + 1] as usize;
        for v in 0..vertex_count {
            let edges = &mut out[list(v)];
            edges.sort_unstable_by_key(|&(to, _)| to);
            if edges.windows(2).any(|w| w[0].0 == w[1].0) {
                return Err(faces);
            }
        }

        let mut twin = vec![NO_TWIN; faces.len() * 4];
        for (f, face) in faces.iter().enumerate() {
            for k in 0..4 {
                let (a, b) = (face[k], face[(k + 1) & 3]);
                let back = &out[list(b)];
                let found = if back.len() <= 8 {
                    back.iter().find(|&&(to, _)| to == a)
                } else {
                    back.binary_search_by_key(&a, |&(to, _)| to)
                        .ok()
                        .map(|i| &back[i])
                };
                if let Some(&(_, h)) = found {
                    twin[4 * f + k] = h;
                }
            }
        }

        let mut mesh = QuadMesh {
            vertex_count,
            faces,
            twin,
            valence: Vec::new(),
        };
        mesh.valence = (0..vertex_count)
            .map(|v| {
                let edges = &out[list(v)];
                let interior = edges
                    .iter()
                    .filter(|&&(_, h)| mesh.twin[h as usize] != NO_TWIN)
                    .count();
                match (edges.len(), interior) {
                    // Four quads could still form two closed fans of two; one
                    // fan needs four turns to come back, not two.
                    (4, 4) => {
                        let h = edges[0].1;
                        let twice = mesh.turn(mesh.turn(h));
                        if twice == h {
                            Valence::Extraordinary
                        } else {
                            Valence::Interior4
                        }
                    }
                    (2, 1) => Valence::Boundary2,
                    _ => Valence::Extraordinary,
                }
            })
            .collect();
        Ok(mesh)
    }

    /// The next half-edge leaving the same vertex, across this one; only for
    /// half-edges with a twin.
    fn turn(&self, h: u32) -> u32 {
        let t = self.twin[h as usize];
        (t & !3) | ((t + 1) & 3)
    }

    pub(crate) fn vertex_count(&self) -> u32 {
        self.vertex_count
    }

    pub(crate) fn faces(&self) -> &[[u32; 4]] {
        &self.faces
    }

    pub(crate) fn into_faces(self) -> Vec<[u32; 4]> {
        self.faces
    }

    pub(crate) fn valence(&self, v: u32) -> Valence {
        self.valence[v as usize]
    }

    /// The face and side across side `side` of face `face`; `None` at a
    /// boundary.
    pub(crate) fn across(&self, face: u32, side: u8) -> Option<(u32, u8)> {
        let t = self.twin[(4 * face + side as u32) as usize];
        (t != NO_TWIN).then_some((t >> 2, (t & 3) as u8))
    }

    /// Number of undirected edges.
    pub(crate) fn edge_count(&self) -> usize {
        let paired = self.twin.iter().filter(|&&t| t != NO_TWIN).count();
        self.twin.len() - paired / 2
    }
}

#[cfg(test)]
mod tests {
    use qm_lift::BaseMesh;

    use super::*;

    #[test]
    fn agrees_with_base_mesh_on_what_is_valid() {
        let cases: [(u32, Vec<[u32; 4]>); 8] = [
            (
                9,
                vec![[0, 1, 4, 3], [1, 2, 5, 4], [3, 4, 7, 6], [4, 5, 8, 7]],
            ),
            (4, vec![]),
            (4, vec![[0, 1, 2, 9]]),
            (4, vec![[0, 1, 1, 3]]),
            (6, vec![[0, 1, 2, 3], [0, 1, 4, 5]]),
            (8, vec![[0, 1, 2, 3], [1, 0, 4, 5], [1, 0, 6, 7]]),
            (5, vec![[0, 1, 2, 3]]),
            // A pillow: two quads glued along all four sides.
            (4, vec![[0, 1, 2, 3], [3, 2, 1, 0]]),
        ];
        for (count, faces) in cases {
            let ours = QuadMesh::new(count, faces.clone()).is_ok();
            assert_eq!(
                ours,
                BaseMesh::new(count, faces.clone()).is_ok(),
                "{faces:?}"
            );
        }
    }

    #[test]
    fn grid_valences_and_adjacency() {
        let mesh = QuadMesh::new(9, qm_shapes::grid_quads(2, 2)).unwrap();
        assert_eq!(mesh.valence(4), Valence::Interior4);
        assert_eq!(mesh.valence(1), Valence::Boundary2);
        assert_eq!(mesh.valence(0), Valence::Extraordinary);
        assert_eq!(mesh.across(0, 1), Some((1, 3)));
        assert_eq!(mesh.across(0, 0), None);
        assert_eq!(mesh.edge_count(), 12);
        // Pillow corners see two quads in a closed fan: extraordinary.
        let pillow = QuadMesh::new(4, vec![[0, 1, 2, 3], [3, 2, 1, 0]]).unwrap();
        assert_eq!(pillow.valence(0), Valence::Extraordinary);
    }
}
