//! Triangle meshes inside the remesher.

use qm_lift::glam::DVec3;

/// An indexed triangle mesh. After [`crate::clean`] each one is a single
/// connected, edge-manifold, vertex-manifold, consistently oriented surface
/// with no degenerate or duplicate triangles and no unused vertices.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct TriMesh {
    /// Vertex positions.
    pub positions: Vec<DVec3>,
    /// Counter-clockwise triangles.
    pub triangles: Vec<[u32; 3]>,
}

impl TriMesh {
    /// Total surface area.
    pub fn area(&self) -> f64 {
        self.triangles
            .iter()
            .map(|t| triangle_area(self.corners(t)))
            .sum()
    }

    /// Corner positions of a triangle.
    pub fn corners(&self, t: &[u32; 3]) -> [DVec3; 3] {
        t.map(|v| self.positions[v as usize])
    }
}

/// Area of a triangle.
pub fn triangle_area([a, b, c]: [DVec3; 3]) -> f64 {
    0.5 * (b - a).cross(c - a).length()
}
