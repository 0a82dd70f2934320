//! A generated mesh's topology as the remesher sees it ([`Topology`]), and
//! the fans at each vertex ([`fans`]), which tell a pinched vertex.

use qm::PolyMesh;
use qm::param::TriMesh;
use qm::param::clean;

use super::tris::Tris;

/// A generated mesh's topology: the whole mesh's (`qm::param::clean::topology`,
/// which also checks that it is a consistently oriented manifold), and each
/// connected component's after the remesher's clean-up.
pub struct Topology {
    pub whole: clean::Topology,
    pub parts: Vec<clean::Topology>,
}

impl Topology {
    pub fn of(tris: &Tris) -> Topology {
        let whole = clean::topology(&TriMesh {
            positions: tris.positions.clone(),
            triangles: tris.faces.clone(),
        });
        let mesh = PolyMesh::from_faces(tris.positions.clone(), &tris.faces);
        let parts = clean::clean(&mesh)
            .map(|c| clean::components_topology(&c.components))
            .unwrap_or_default();
        Topology { whole, parts }
    }

    /// The genus of a single closed or bounded part.
    pub fn genus(&self) -> Option<i64> {
        (self.whole.manifold && self.parts.len() == 1).then_some(self.whole.genus)
    }
}

impl std::fmt::Display for Topology {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let w = &self.whole;
        write!(
            f,
            "{} vertices, {} faces, {} edges, Euler {}, {} components, \
             {} boundary loops ({} edges), {}",
            w.vertices,
            w.faces,
            w.edges,
            w.euler,
            self.parts.len(),
            w.boundary_loops,
            w.boundary_edges,
            if w.manifold {
                "manifold"
            } else {
                "NOT manifold"
            }
        )?;
        if let Some(g) = self.genus() {
            write!(f, ", genus {g}")?;
        }
        Ok(())
    }
}

/// How many fans (face sets connected through edges at the vertex) meet at
/// each vertex: 1 on a manifold, 0 for an unused vertex.
pub(super) fn fans(tris: &Tris) -> Vec<usize> {
    let n = tris.positions.len();
    // Each face's "link edge" seen from each of its corners.
    let mut start = vec![0usize; n + 1];
    for f in &tris.faces {
        for &v in f {
            start[v as usize + 1] += 1;
        }
    }
    for v in 0..n {
        start[v + 1] += start[v];
    }
    let mut fill = start.clone();
    let mut link = vec![(0u32, 0u32); 3 * tris.faces.len()];
    for f in &tris.faces {
        for k in 0..3 {
            let v = f[k] as usize;
            link[fill[v]] = (f[(k + 1) % 3], f[(k + 2) % 3]);
            fill[v] += 1;
        }
    }
    let mut out = vec![0; n];
    let mut local: Vec<u32> = Vec::new();
    for v in 0..n {
        let edges = &link[start[v]..start[v + 1]];
        if edges.is_empty() {
            continue;
        }
        local.clear();
        local.extend(edges.iter().flat_map(|&(a, b)| [a, b]));
        local.sort_unstable();
        local.dedup();
        let at = |x: u32| local.binary_search(&x).unwrap() as u32;
        let mut uf = UnionFind::new(local.len());
        for &(a, b) in edges {
            uf.union(at(a), at(b));
        }
        let mut roots: Vec<u32> = (0..local.len() as u32).map(|i| uf.find(i)).collect();
        roots.sort_unstable();
        roots.dedup();
        out[v] = roots.len();
    }
    out
}

pub(super) struct UnionFind(Vec<u32>);

impl UnionFind {
    pub(super) fn new(n: usize) -> Self {
        UnionFind((0..n as u32).collect())
    }

    pub(super) fn find(&mut self, mut x: u32) -> u32 {
        while self.0[x as usize] != x {
            let up = self.0[self.0[x as usize] as usize];
            self.0[x as usize] = up;
            x = up;
        }
        x
    }

    pub(super) fn union(&mut self, a: u32, b: u32) {
        let (a, b) = (self.find(a), self.find(b));
        if a != b {
            self.0[a.max(b) as usize] = a.min(b);
        }
    }
}
