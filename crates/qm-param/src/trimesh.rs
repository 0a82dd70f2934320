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

/// Where the closest point of a triangle lies.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Feature {
    Inside,
    /// On the edge opposite this corner.
    Edge(usize),
    Corner(usize),
}

/// The point of triangle `[a, b, c]` closest to `p`, and where on the
/// triangle it lies, by the regions of the corners' and edges' Voronoi
/// cells (Ericson, *Real-Time Collision Detection*, 2005, section 5.1.5).
pub(crate) fn closest_on_triangle(p: DVec3, [a, b, c]: [DVec3; 3]) -> (DVec3, Feature) {
    let (ab, ac, ap) = (b - a, c - a, p - a);
    let (d1, d2) = (ab.dot(ap), ac.dot(ap));
    if d1 <= 0.0 && d2 <= 0.0 {
        return (a, Feature::Corner(0));
    }
    let bp = p - b;
    let (d3, d4) = (ab.dot(bp), ac.dot(bp));
    if d3 >= 0.0 && d4 <= d3 {
        return (b, Feature::Corner(1));
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        return (a + ab * (d1 / (d1 - d3)), Feature::Edge(2));
    }
    let cp = p - c;
    let (d5, d6) = (ab.dot(cp), ac.dot(cp));
    if d6 >= 0.0 && d5 <= d6 {
        return (c, Feature::Corner(2));
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        return (a + ac * (d2 / (d2 - d6)), Feature::Edge(1));
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && d4 >= d3 && d5 >= d6 {
        let w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
        return (b + (c - b) * w, Feature::Edge(0));
    }
    let sum = va + vb + vc;
    if sum <= 0.0 {
        // Degenerate: a corner is as good as any point.
        return (a, Feature::Corner(0));
    }
    (a + ab * (vb / sum) + ac * (vc / sum), Feature::Inside)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The closest point of a triangle in each of its seven regions.
    #[test]
    fn closest_on_a_triangle_by_region() {
        let (a, b, c) = (
            DVec3::new(0.0, 0.0, 0.0),
            DVec3::new(2.0, 0.0, 0.0),
            DVec3::new(0.0, 2.0, 0.0),
        );
        let cases = [
            ((-1.0, -1.0, 3.0), (0.0, 0.0, 0.0)),
            ((3.0, -1.0, 1.0), (2.0, 0.0, 0.0)),
            ((-1.0, 3.0, -1.0), (0.0, 2.0, 0.0)),
            ((1.0, -1.0, 0.5), (1.0, 0.0, 0.0)),
            ((-1.0, 1.0, 0.5), (0.0, 1.0, 0.0)),
            ((2.0, 2.0, 0.0), (1.0, 1.0, 0.0)),
            ((0.5, 0.5, -4.0), (0.5, 0.5, 0.0)),
        ];
        for ((x, y, z), (ex, ey, ez)) in cases {
            let (q, _) = closest_on_triangle(DVec3::new(x, y, z), [a, b, c]);
            assert!(
                (q - DVec3::new(ex, ey, ez)).length() < 1e-12,
                "{q:?} for {x} {y} {z}"
            );
        }
    }
}
