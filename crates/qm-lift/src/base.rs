//! The coarse base quad mesh and its adjacency.
//!
//! Conventions used everywhere in qm:
//! - face `f` has corners `faces[f][0..4]`, counter-clockwise seen from outside;
//! - side `k` of a face runs from corner `k` to corner `k + 1 (mod 4)`;
//! - a base edge runs in the direction of the side of its *first* face (the
//!   face that owns it); its second face, if any, runs along it the other way.

use std::collections::HashMap;

use serde::{Deserialize, Serialize};

use crate::{Error, Result};

/// Marker for "no face" across a boundary side.
pub const NO_FACE: u32 = u32::MAX;

/// A face side: `(face, side)`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub struct Side {
    pub face: u32,
    pub side: u8,
}

impl Side {
    /// The side across a boundary: no face.
    pub const NONE: Side = Side {
        face: NO_FACE,
        side: 0,
    };

    /// Whether this names a real face side.
    pub const fn exists(self) -> bool {
        self.face != NO_FACE
    }
}

/// One undirected base edge.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Edge {
    /// End vertices in the edge's own direction (that of `sides[0]`).
    pub ends: [u32; 2],
    /// The owning side, and the opposite side or [`Side::NONE`] on a boundary.
    pub sides: [Side; 2],
}

impl Edge {
    /// Whether only one face uses this edge.
    pub const fn is_boundary(&self) -> bool {
        !self.sides[1].exists()
    }
}

/// A coarse quad mesh of any topology: boundaries, extraordinary vertices of
/// any valence, several components. Faces must be consistently oriented and
/// every edge used by at most two faces.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct BaseMesh {
    vertex_count: u32,
    faces: Vec<[u32; 4]>,
    edges: Vec<Edge>,
    face_edges: Vec<[u32; 4]>,
    regular: Vec<bool>,
}

impl BaseMesh {
    /// Builds the adjacency of `faces` over `vertex_count` vertices and checks
    /// that it is a valid, consistently oriented, edge-manifold quad mesh.
    pub fn new(vertex_count: u32, faces: Vec<[u32; 4]>) -> Result<Self> {
        if faces.is_empty() {
            return Err(Error::Empty);
        }
        let mut used = vec![false; vertex_count as usize];
        for (fi, face) in faces.iter().enumerate() {
            for (k, &v) in face.iter().enumerate() {
                if v >= vertex_count {
                    return Err(Error::VertexOutOfRange {
                        face: fi,
                        vertex: v,
                        count: vertex_count,
                    });
                }
                if face[..k].contains(&v) {
                    return Err(Error::DegenerateFace { face: fi });
                }
                used[v as usize] = true;
            }
        }
        if let Some(v) = used.iter().position(|&u| !u) {
            return Err(Error::UnusedVertex { vertex: v as u32 });
        }

        let mut edges: Vec<Edge> = Vec::with_capacity(faces.len() * 2);
        let mut face_edges = vec![[0u32; 4]; faces.len()];
        let mut by_key: HashMap<(u32, u32), u32> = HashMap::with_capacity(faces.len() * 2);
        for (fi, face) in faces.iter().enumerate() {
            for k in 0..4 {
                let (a, b) = (face[k], face[(k + 1) % 4]);
                let key = (a.min(b), a.max(b));
                let side = Side {
                    face: fi as u32,
                    side: k as u8,
                };
                match by_key.get(&key) {
                    None => {
                        by_key.insert(key, edges.len() as u32);
                        face_edges[fi][k] = edges.len() as u32;
                        edges.push(Edge {
                            ends: [a, b],
                            sides: [side, Side::NONE],
                        });
                    }
                    Some(&e) => {
                        let edge = &mut edges[e as usize];
                        if edge.sides[1].exists() {
                            return Err(Error::NonManifoldEdge { a: key.0, b: key.1 });
                        }
                        if edge.ends != [b, a] {
                            return Err(Error::InconsistentOrientation { a: key.0, b: key.1 });
                        }
                        edge.sides[1] = side;
                        face_edges[fi][k] = e;
                    }
                }
            }
        }

        let mut mesh = BaseMesh {
            vertex_count,
            faces,
            edges,
            face_edges,
            regular: Vec::new(),
        };
        mesh.regular = mesh.find_regular_vertices();
        Ok(mesh)
    }

    /// A vertex is regular when exactly four faces surround it in one closed
    /// fan: only there does a grid line run straight on through it.
    fn find_regular_vertices(&self) -> Vec<bool> {
        let mut corners = vec![0u32; self.vertex_count as usize];
        let mut first = vec![(0u32, 0u8); self.vertex_count as usize];
        for (f, face) in self.faces.iter().enumerate() {
            for (c, &v) in face.iter().enumerate() {
                corners[v as usize] += 1;
                first[v as usize] = (f as u32, c as u8);
            }
        }
        (0..self.vertex_count as usize)
            .map(|v| {
                if corners[v] != 4 {
                    return false;
                }
                // One closed fan: back at the start after exactly four steps,
                // not before (two fans of two faces also have four corners).
                let (mut f, mut c) = first[v];
                for step in 1..=4 {
                    match self.rotate(f, c) {
                        Some(next) => (f, c) = next,
                        None => return false,
                    }
                    if ((f, c) == first[v]) != (step == 4) {
                        return false;
                    }
                }
                true
            })
            .collect()
    }

    /// The next corner around the same vertex: across the side leaving corner
    /// `c` of face `f`. `None` at a boundary.
    pub fn rotate(&self, f: u32, c: u8) -> Option<(u32, u8)> {
        let across = self.across(f, c);
        across
            .exists()
            .then(|| (across.face, (across.side + 1) % 4))
    }

    /// The face side opposite side `side` of face `face`.
    pub fn across(&self, face: u32, side: u8) -> Side {
        let edge = &self.edges[self.face_edges[face as usize][side as usize] as usize];
        let me = Side { face, side };
        if edge.sides[0] == me {
            edge.sides[1]
        } else {
            edge.sides[0]
        }
    }

    /// Whether `face` owns (codes) the edge of its side `side`.
    pub fn owns(&self, face: u32, side: u8) -> bool {
        self.edges[self.face_edges[face as usize][side as usize] as usize].sides[0]
            == Side { face, side }
    }

    /// Number of base vertices.
    pub fn vertex_count(&self) -> u32 {
        self.vertex_count
    }

    /// The faces, four counter-clockwise corners each.
    pub fn faces(&self) -> &[[u32; 4]] {
        &self.faces
    }

    /// The undirected edges.
    pub fn edges(&self) -> &[Edge] {
        &self.edges
    }

    /// The edge index of each face side.
    pub fn face_edges(&self) -> &[[u32; 4]] {
        &self.face_edges
    }

    /// Whether base vertex `v` is regular (closed fan of four faces).
    pub fn is_regular(&self, v: u32) -> bool {
        self.regular[v as usize]
    }

    /// Number of samples (distinct vertices) once every face is refined
    /// `level` times: base vertices, `2^level - 1` per edge and
    /// `(2^level - 1)^2` per face. Computed, not allocated.
    pub fn sample_count(&self, level: u32) -> u64 {
        let inner = (1u64 << level.min(63)) - 1;
        self.vertex_count as u64
            + self.edges.len() as u64 * inner
            + self.faces.len() as u64 * inner * inner
    }

    /// Number of boundary edges.
    pub fn boundary_edge_count(&self) -> usize {
        self.edges.iter().filter(|e| e.is_boundary()).count()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::synthetic::cube;

    #[test]
    fn cube_is_closed_with_irregular_corners() {
        let cube = cube();
        assert_eq!(cube.edges().len(), 12);
        assert_eq!(cube.boundary_edge_count(), 0);
        assert!((0..8).all(|v| !cube.is_regular(v)));
        for f in 0..6 {
            for s in 0..4 {
                let a = cube.across(f, s);
                assert!(a.exists());
                assert_eq!(cube.across(a.face, a.side), Side { face: f, side: s });
                assert_ne!(cube.owns(f, s), cube.owns(a.face, a.side));
            }
        }
    }

    #[test]
    fn grid_centre_vertex_is_regular() {
        // 2x2 grid of quads: vertices 0..9 row-major.
        let m = BaseMesh::new(9, qm_shapes::grid_quads(2, 2)).unwrap();
        assert!(m.is_regular(4));
        assert!(!m.is_regular(1));
        assert_eq!(m.boundary_edge_count(), 8);
    }

    #[test]
    fn rejects_bad_meshes() {
        assert_eq!(BaseMesh::new(4, vec![]), Err(Error::Empty));
        assert!(matches!(
            BaseMesh::new(4, vec![[0, 1, 2, 9]]),
            Err(Error::VertexOutOfRange { .. })
        ));
        assert!(matches!(
            BaseMesh::new(4, vec![[0, 1, 1, 3]]),
            Err(Error::DegenerateFace { .. })
        ));
        assert!(matches!(
            BaseMesh::new(6, vec![[0, 1, 2, 3], [0, 1, 4, 5]]),
            Err(Error::InconsistentOrientation { .. })
        ));
        assert!(matches!(
            BaseMesh::new(8, vec![[0, 1, 2, 3], [1, 0, 4, 5], [1, 0, 6, 7]]),
            Err(Error::NonManifoldEdge { .. })
        ));
        assert!(matches!(
            BaseMesh::new(5, vec![[0, 1, 2, 3]]),
            Err(Error::UnusedVertex { .. })
        ));
    }
}
