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

impl TriMesh {
    /// The same surface with every triangle split into four at its edges'
    /// midpoints (the new vertices follow the old, in order of first use).
    pub fn split_at_midpoints(&self) -> TriMesh {
        let mut positions = self.positions.clone();
        let mut midpoint = std::collections::HashMap::new();
        let mut mid = |a: u32, b: u32| {
            *midpoint.entry((a.min(b), a.max(b))).or_insert_with(|| {
                positions.push(0.5 * (self.positions[a as usize] + self.positions[b as usize]));
                (positions.len() - 1) as u32
            })
        };
        let mut triangles = Vec::with_capacity(4 * self.triangles.len());
        for &[a, b, c] in &self.triangles {
            let (ab, bc, ca) = (mid(a, b), mid(b, c), mid(c, a));
            triangles.extend([[a, ab, ca], [ab, b, bc], [ca, bc, c], [ab, bc, ca]]);
        }
        TriMesh {
            positions,
            triangles,
        }
    }
}
