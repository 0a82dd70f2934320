//! Cutting a surface open into a topological disk.
//!
//! The cut graph is the complement of a spanning tree of the dual graph
//! (faces joined across edges): gluing the faces along the tree's edges gives
//! a disk, so cutting along every other edge opens the surface into that
//! disk. Branches that end in a vertex of degree one are pruned away (cutting
//! them is never needed); what remains is the surface's boundary loops, `2g`
//! loops for genus `g`, and paths joining them. A closed genus-0 surface
//! prunes to nothing, and is cut along a longest shortest path instead.
//!
//! The disk keeps one copy of each vertex per *wedge*: the faces around a
//! vertex between two consecutive cut edges.

use std::collections::{HashMap, VecDeque};

use qm_lift::glam::DVec3;

use crate::TriMesh;

const NONE: u32 = u32::MAX;

/// Edge adjacency of a triangle mesh.
pub struct Topology {
    /// Undirected edges as `(min, max)` vertex pairs.
    pub edges: Vec<[u32; 2]>,
    /// The one or two faces of each edge (`NONE` for a boundary side).
    pub edge_faces: Vec<[u32; 2]>,
    /// The edge of each triangle side `k` (from corner `k` to `k + 1`).
    pub face_edges: Vec<[u32; 3]>,
    /// The edge joining two vertices, by `(min, max)` vertex pair.
    index: HashMap<(u32, u32), u32>,
    /// The vertices joined to each vertex by an edge.
    neighbours: Vec<Vec<u32>>,
}

impl Topology {
    pub fn new(mesh: &TriMesh) -> Self {
        let mut index: HashMap<(u32, u32), u32> = HashMap::with_capacity(mesh.triangles.len() * 2);
        let mut edges = Vec::with_capacity(mesh.triangles.len() * 3 / 2 + 2);
        let mut edge_faces: Vec<[u32; 2]> = Vec::with_capacity(edges.capacity());
        let mut face_edges = Vec::with_capacity(mesh.triangles.len());
        for (f, t) in mesh.triangles.iter().enumerate() {
            let mut fe = [0u32; 3];
            for k in 0..3 {
                let (a, b) = (t[k], t[(k + 1) % 3]);
                let key = (a.min(b), a.max(b));
                let e = *index.entry(key).or_insert_with(|| {
                    edges.push([key.0, key.1]);
                    edge_faces.push([NONE, NONE]);
                    edges.len() as u32 - 1
                });
                let slot = &mut edge_faces[e as usize];
                if slot[0] == NONE {
                    slot[0] = f as u32;
                } else {
                    slot[1] = f as u32;
                }
                fe[k] = e;
            }
            face_edges.push(fe);
        }
        let mut neighbours: Vec<Vec<u32>> = vec![Vec::new(); mesh.positions.len()];
        for &[a, b] in &edges {
            neighbours[a as usize].push(b);
            neighbours[b as usize].push(a);
        }
        Topology {
            edges,
            edge_faces,
            face_edges,
            index,
            neighbours,
        }
    }

    /// The edge joining vertices `a` and `b`, if there is one.
    fn edge(&self, a: u32, b: u32) -> Option<u32> {
        self.index.get(&(a.min(b), a.max(b))).copied()
    }

    /// The face across edge `e` from face `f`.
    fn other(&self, e: u32, f: u32) -> u32 {
        let [a, b] = self.edge_faces[e as usize];
        if a == f { b } else { a }
    }
}

/// A surface cut open into a disk.
pub struct Disk {
    /// Positions of the disk's vertices (cut vertices appear once per wedge).
    pub positions: Vec<DVec3>,
    /// The triangles, on disk vertices.
    pub triangles: Vec<[u32; 3]>,
    /// The boundary loop, counter-clockwise (interior on the left).
    pub boundary: Vec<u32>,
    /// For boundary edge `k` (from `boundary[k]` to `boundary[k + 1]`): the
    /// mesh edge and whether it is a cut (true) or a real boundary (false).
    pub boundary_edges: Vec<(u32, bool)>,
    /// The mesh vertex of each disk vertex.
    pub origin: Vec<u32>,
    /// The parameterization matrix's symbolic factorization: its pattern
    /// depends only on the disk, so every solve on this disk shares it (or
    /// the error that computing it gave). Concurrent solves wait for the
    /// first to compute it.
    pub symbolic: std::sync::OnceLock<Result<super::lu::SymbolicFactorization, String>>,
}

/// Cuts `mesh` (one connected, manifold, oriented component) into a disk,
/// adding the extra cut paths `extra` (vertex sequences along mesh edges).
pub fn cut_to_disk(mesh: &TriMesh, topo: &Topology, extra: &[Vec<u32>]) -> Disk {
    let faces = mesh.triangles.len();
    let vertices = mesh.positions.len();
    // Dual spanning tree by breadth-first search from face 0.
    let mut in_tree = vec![false; topo.edges.len()];
    let mut seen = vec![false; faces];
    let mut queue = VecDeque::from([0u32]);
    seen[0] = true;
    while let Some(f) = queue.pop_front() {
        for &e in &topo.face_edges[f as usize] {
            let g = topo.other(e, f);
            if g != NONE && !seen[g as usize] {
                seen[g as usize] = true;
                in_tree[e as usize] = true;
                queue.push_back(g);
            }
        }
    }
    let mut cut: Vec<bool> = in_tree.iter().map(|&t| !t).collect();
    prune(topo, &mut cut, vertices);
    // Closed genus 0 prunes to nothing: cut along a longest shortest path.
    let longest = if cut.contains(&true) {
        None
    } else {
        Some(longest_path(mesh, topo))
    };
    for path in longest.iter().chain(extra) {
        for w in path.windows(2) {
            if let Some(e) = topo.edge(w[0], w[1]) {
                cut[e as usize] = true;
            }
        }
    }
    open(mesh, topo, &cut)
}

/// Removes cut edges hanging from vertices of degree one, repeatedly.
fn prune(topo: &Topology, cut: &mut [bool], vertices: usize) {
    let mut degree = vec![0u32; vertices];
    let mut incident: Vec<Vec<u32>> = vec![Vec::new(); vertices];
    for (e, &[a, b]) in topo.edges.iter().enumerate() {
        if cut[e] {
            degree[a as usize] += 1;
            degree[b as usize] += 1;
            incident[a as usize].push(e as u32);
            incident[b as usize].push(e as u32);
        }
    }
    let mut queue: Vec<u32> = (0..vertices as u32)
        .filter(|&v| degree[v as usize] == 1)
        .collect();
    while let Some(v) = queue.pop() {
        if degree[v as usize] != 1 {
            continue;
        }
        let Some(&e) = incident[v as usize].iter().find(|&&e| cut[e as usize]) else {
            continue;
        };
        cut[e as usize] = false;
        let [a, b] = topo.edges[e as usize];
        for w in [a, b] {
            degree[w as usize] -= 1;
            if degree[w as usize] == 1 {
                queue.push(w);
            }
        }
    }
}

/// Dijkstra distances (edge lengths) from `source`, with predecessors.
pub fn shortest_paths(mesh: &TriMesh, topo: &Topology, source: u32) -> (Vec<f64>, Vec<u32>) {
    let n = mesh.positions.len();
    let mut dist = vec![f64::INFINITY; n];
    let mut pred = vec![NONE; n];
    let mut heap = std::collections::BinaryHeap::new();
    dist[source as usize] = 0.0;
    heap.push((std::cmp::Reverse(Ordered(0.0)), source));
    while let Some((std::cmp::Reverse(Ordered(d)), v)) = heap.pop() {
        if d > dist[v as usize] {
            continue;
        }
        for &w in &topo.neighbours[v as usize] {
            let nd = d + mesh.positions[v as usize].distance(mesh.positions[w as usize]);
            if nd < dist[w as usize] {
                dist[w as usize] = nd;
                pred[w as usize] = v;
                heap.push((std::cmp::Reverse(Ordered(nd)), w));
            }
        }
    }
    (dist, pred)
}

/// A total order on finite distances for the heap.
struct Ordered(f64);
impl PartialEq for Ordered {
    fn eq(&self, other: &Self) -> bool {
        self.cmp(other).is_eq()
    }
}
impl Eq for Ordered {}
impl PartialOrd for Ordered {
    fn partial_cmp(&self, other: &Self) -> Option<std::cmp::Ordering> {
        Some(self.cmp(other))
    }
}
impl Ord for Ordered {
    fn cmp(&self, other: &Self) -> std::cmp::Ordering {
        self.0.total_cmp(&other.0)
    }
}

/// The vertex path from `pred`'s source to `to`.
pub fn path_to(pred: &[u32], to: u32) -> Vec<u32> {
    let mut path = vec![to];
    let mut v = to;
    while pred[v as usize] != NONE {
        v = pred[v as usize];
        path.push(v);
    }
    path.reverse();
    path
}

/// A path between two far-apart vertices (the farthest from the farthest).
fn longest_path(mesh: &TriMesh, topo: &Topology) -> Vec<u32> {
    let far = |dist: &[f64]| {
        (0..dist.len())
            .filter(|&v| dist[v].is_finite())
            .max_by(|&a, &b| dist[a].total_cmp(&dist[b]))
            .unwrap_or(0) as u32
    };
    let (d0, _) = shortest_paths(mesh, topo, 0);
    let a = far(&d0);
    let (da, pred) = shortest_paths(mesh, topo, a);
    let b = far(&da);
    path_to(&pred, b)
}

/// Opens the mesh along the cut edges into a disk.
fn open(mesh: &TriMesh, topo: &Topology, cut: &[bool]) -> Disk {
    let tris = &mesh.triangles;
    // Corner (f, k) -> disk vertex.
    let mut corner = vec![NONE; tris.len() * 3];
    let mut positions = Vec::with_capacity(mesh.positions.len() + 64);
    let mut origin = Vec::with_capacity(positions.capacity());
    let on_cut: Vec<bool> = {
        let mut v = vec![false; mesh.positions.len()];
        for (e, &[a, b]) in topo.edges.iter().enumerate() {
            if cut[e] || topo.edge_faces[e][1] == NONE {
                v[a as usize] = true;
                v[b as usize] = true;
            }
        }
        v
    };
    let is_cut = |e: u32| cut[e as usize] || topo.edge_faces[e as usize][1] == NONE;
    // Interior vertices: one disk vertex each.
    let mut single = vec![NONE; mesh.positions.len()];
    for (f, t) in tris.iter().enumerate() {
        for k in 0..3 {
            let v = t[k];
            if !on_cut[v as usize] {
                if single[v as usize] == NONE {
                    single[v as usize] = positions.len() as u32;
                    positions.push(mesh.positions[v as usize]);
                    origin.push(v);
                }
                corner[f * 3 + k] = single[v as usize];
            }
        }
    }
    // Walk the boundary: from half-edge (f, k) = t[k] -> t[k+1] on a cut edge,
    // rotate around its end vertex through uncut edges to the next cut edge;
    // every face passed belongs to the same wedge.
    let mut boundary = Vec::new();
    let mut boundary_edges = Vec::new();
    let mut visited = vec![false; tris.len() * 3];
    let start = (0..tris.len() * 3).find(|&h| is_cut(topo.face_edges[h / 3][h % 3]));
    let Some(start) = start else {
        return Disk {
            positions,
            triangles: Vec::new(),
            boundary,
            boundary_edges,
            origin,
            symbolic: Default::default(),
        };
    };
    let mut h = start;
    loop {
        visited[h] = true;
        let (f, k) = (h / 3, h % 3);
        let e = topo.face_edges[f][k];
        boundary_edges.push((e, cut[e as usize] && topo.edge_faces[e as usize][1] != NONE));
        let v = tris[f][(k + 1) % 3];
        let wedge = positions.len() as u32;
        positions.push(mesh.positions[v as usize]);
        origin.push(v);
        boundary.push(wedge);
        // Rotate around v: in face g, v is at corner c; the half-edge leaving
        // v is (g, c).
        let (mut g, mut c) = (f, (k + 1) % 3);
        loop {
            corner[g * 3 + c] = wedge;
            let out = topo.face_edges[g][c];
            if is_cut(out) {
                h = g * 3 + c;
                break;
            }
            let next = topo.other(out, g as u32) as usize;
            let cn = (0..3)
                .find(|&j| tris[next][j] == v)
                .expect("v is in the face across");
            g = next;
            c = cn;
        }
        if h == start || visited[h] {
            break;
        }
    }
    // The loop lists the end vertex of each boundary half-edge; rotate so
    // that boundary[k] is where boundary edge k starts.
    boundary.rotate_right(1);
    let triangles = (0..tris.len())
        .map(|f| [corner[f * 3], corner[f * 3 + 1], corner[f * 3 + 2]])
        .collect();
    Disk {
        positions,
        triangles,
        boundary,
        boundary_edges,
        origin,
        symbolic: Default::default(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// An octahedron: closed, genus 0.
    fn octahedron() -> TriMesh {
        let (positions, triangles) = qm_shapes::octahedron();
        TriMesh {
            positions,
            triangles,
        }
    }

    #[test]
    fn a_closed_sphere_opens_along_one_path() {
        let mesh = octahedron();
        let topo = Topology::new(&mesh);
        let disk = cut_to_disk(&mesh, &topo, &[]);
        // Euler characteristic of a disk is 1.
        let v = disk.positions.len() as i64;
        let f = disk.triangles.len() as i64;
        let e = (3 * f + disk.boundary.len() as i64) / 2;
        assert_eq!(v - e + f, 1);
        assert!(disk.triangles.iter().flatten().all(|&x| x != NONE));
        assert!(disk.boundary_edges.iter().all(|&(_, is_cut)| is_cut));
        // Every cut edge appears twice on the boundary.
        let mut count: HashMap<u32, u32> = HashMap::new();
        for &(e, _) in &disk.boundary_edges {
            *count.entry(e).or_default() += 1;
        }
        assert!(count.values().all(|&c| c == 2));
    }

    #[test]
    fn a_mesh_with_a_hole_keeps_it_as_boundary() {
        let mut mesh = octahedron();
        mesh.triangles.pop();
        let topo = Topology::new(&mesh);
        let disk = cut_to_disk(&mesh, &topo, &[]);
        assert_eq!(disk.boundary.len(), 3);
        assert!(disk.boundary_edges.iter().all(|&(_, is_cut)| !is_cut));
        assert_eq!(disk.positions.len(), 6);
    }
}
