//! The topology of a triangle mesh: its vertices, edges, faces and
//! boundary loops, its genus from `V - E + F = 2 - 2g - b`, and whether it
//! is a consistently oriented manifold.

use std::collections::HashMap;

use super::edges::next_corner;
use crate::TriMesh;
use crate::union_find::UnionFind;

/// Topology of one triangle mesh, as [`topology`] finds it.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[non_exhaustive]
pub struct Topology {
    /// Vertices.
    pub vertices: usize,
    /// Undirected edges.
    pub edges: usize,
    /// Triangles.
    pub faces: usize,
    /// Edges with one face.
    pub boundary_edges: usize,
    /// Closed loops of boundary edges (holes).
    pub boundary_loops: usize,
    /// `V - E + F`.
    pub euler: i64,
    /// `g` from `V - E + F = 2 - 2g - b`, meaningful for a connected
    /// manifold.
    pub genus: i64,
    /// Every vertex used; every directed edge used once (edge-manifold and
    /// consistently oriented); every vertex's faces one fan.
    pub manifold: bool,
}

impl Topology {
    /// Whether the surface has no boundary.
    pub fn is_closed(&self) -> bool {
        self.boundary_edges == 0
    }
}

/// Counts `mesh`'s vertices, edges, faces and boundary loops, derives its
/// genus and checks that it is a consistently oriented manifold.
pub fn topology(mesh: &TriMesh) -> Topology {
    let n = mesh.positions.len();
    let mut directed: Vec<(u64, u32)> = Vec::with_capacity(3 * mesh.triangles.len());
    let mut manifold = true;
    let mut used = vec![false; n];
    for (t, tri) in mesh.triangles.iter().enumerate() {
        for i in 0..3 {
            let (a, b) = (tri[i], tri[(i + 1) % 3]);
            if a as usize >= n || b as usize >= n || a == b {
                manifold = false;
                continue;
            }
            used[a as usize] = true;
            directed.push(((u64::from(a) << 32) | u64::from(b), (3 * t + i) as u32));
        }
    }
    manifold &= used.iter().all(|&u| u);
    directed.sort_unstable();
    manifold &= directed.windows(2).all(|w| w[0].0 != w[1].0);
    let twin = |key: u64| -> Option<u32> {
        let rev = key.rotate_right(32);
        directed
            .binary_search_by_key(&rev, |&(k, _)| k)
            .ok()
            .map(|i| directed[i].1)
    };

    let mut sets = UnionFind::new(3 * mesh.triangles.len());
    let mut interior = 0usize;
    let mut boundary: HashMap<u32, u32> = HashMap::new();
    for &(key, c) in &directed {
        let (a, b) = ((key >> 32) as u32, key as u32);
        match twin(key) {
            Some(d) => {
                interior += 1;
                // Corner c starts at a, d starts at b: join the fans.
                sets.union(c, next_corner(d as usize) as u32);
                sets.union(next_corner(c as usize) as u32, d);
            }
            None => {
                if boundary.insert(a, b).is_some() {
                    manifold = false;
                }
            }
        }
    }
    // One fan per vertex.
    let mut fan = vec![u32::MAX; n];
    for (t, tri) in mesh.triangles.iter().enumerate() {
        for (i, &v) in tri.iter().enumerate() {
            let Some(slot) = fan.get_mut(v as usize) else {
                continue;
            };
            let r = sets.find((3 * t + i) as u32);
            if *slot == u32::MAX {
                *slot = r;
            } else if *slot != r {
                manifold = false;
            }
        }
    }

    let mut loops = 0;
    let mut seen: HashMap<u32, ()> = HashMap::new();
    for &start in boundary.keys() {
        if seen.contains_key(&start) {
            continue;
        }
        let mut v = start;
        while seen.insert(v, ()).is_none() {
            match boundary.get(&v) {
                Some(&w) => v = w,
                None => break,
            }
        }
        loops += 1;
    }

    let edges = interior / 2 + boundary.len();
    let euler = n as i64 - edges as i64 + mesh.triangles.len() as i64;
    Topology {
        vertices: n,
        edges,
        faces: mesh.triangles.len(),
        boundary_edges: boundary.len(),
        boundary_loops: loops,
        euler,
        genus: (2 - loops as i64 - euler) / 2,
        manifold,
    }
}

/// [`topology`] of every component.
pub fn components_topology(components: &[TriMesh]) -> Vec<Topology> {
    components.iter().map(topology).collect()
}
