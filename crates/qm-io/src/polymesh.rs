//! A plain indexed polygon mesh: what mesh files hold.

use glam::DVec3;

/// Positions and polygonal faces (any number of corners each), as read from or
/// written to a mesh file.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct PolyMesh {
    /// Vertex positions.
    pub positions: Vec<DVec3>,
    /// Face corner indices, all faces concatenated.
    indices: Vec<u32>,
    /// Face `k` is `indices[offsets[k] .. offsets[k + 1]]`; starts with 0.
    offsets: Vec<u32>,
}

impl PolyMesh {
    /// An empty mesh.
    pub fn new() -> Self {
        PolyMesh {
            positions: Vec::new(),
            indices: Vec::new(),
            offsets: vec![0],
        }
    }

    /// A mesh from positions and faces of a fixed size (triangles or quads).
    pub fn from_faces<const K: usize>(positions: Vec<DVec3>, faces: &[[u32; K]]) -> Self {
        let mut mesh = PolyMesh {
            positions,
            ..PolyMesh::new()
        };
        for face in faces {
            mesh.push_face(face);
        }
        mesh
    }

    /// Appends a face.
    pub fn push_face(&mut self, corners: &[u32]) {
        if self.offsets.is_empty() {
            self.offsets.push(0);
        }
        self.indices.extend_from_slice(corners);
        self.offsets.push(self.indices.len() as u32);
    }

    /// Number of faces.
    pub fn face_count(&self) -> usize {
        self.offsets.len().saturating_sub(1)
    }

    /// Corners of face `k`.
    pub fn face(&self, k: usize) -> &[u32] {
        &self.indices[self.offsets[k] as usize..self.offsets[k + 1] as usize]
    }

    /// All faces in order.
    pub fn faces(&self) -> impl ExactSizeIterator<Item = &[u32]> + '_ {
        (0..self.face_count()).map(|k| self.face(k))
    }

    /// Appends `other`'s vertices and faces, moved by `offset` (its faces
    /// renumbered to its vertices here).
    pub fn append(&mut self, other: &PolyMesh, offset: DVec3) {
        let first = self.positions.len() as u32;
        self.positions
            .extend(other.positions.iter().map(|&p| p + offset));
        for face in other.faces() {
            let corners: Vec<u32> = face.iter().map(|&v| v + first).collect();
            self.push_face(&corners);
        }
    }

    /// Whether every face has exactly `k` corners (false for a mesh with no faces).
    pub fn all_faces_have(&self, k: usize) -> bool {
        self.face_count() > 0 && self.faces().all(|f| f.len() == k)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn append_renumbers_and_moves() {
        let triangle = PolyMesh::from_faces(vec![DVec3::ZERO, DVec3::X, DVec3::Y], &[[0, 1, 2]]);
        let mut mesh = triangle.clone();
        mesh.append(&triangle, DVec3::Z);
        assert_eq!(mesh.face_count(), 2);
        assert_eq!(mesh.face(1), &[3, 4, 5]);
        assert_eq!(mesh.positions[4], DVec3::new(1.0, 0.0, 1.0));
    }
}
