//! Mesh clean-up before parameterization.
//!
//! [`clean`] turns any polygon mesh into a list of triangle meshes, one per
//! connected component, each a single edge-manifold, vertex-manifold,
//! consistently oriented surface, and reports what it changed in one line
//! ([`CleanReport`]). In order:
//!
//! 1. polygons are split into triangle fans `(v0, vi, vi+1)`;
//! 2. vertices with bit-identical positions are merged (texture-seam
//!    duplicates);
//! 3. degenerate triangles (a repeated vertex, or an exactly zero cross
//!    product) and duplicate triangles (the same vertex set in any order or
//!    orientation; the first is kept) are dropped;
//! 4. faces are oriented greedily, breadth first: a face joins its neighbour
//!    across an edge only if exactly two faces use the edge and their
//!    orientations can agree (flipping the newly reached face if needed).
//!    Every other shared edge (more than two faces, or an orientation
//!    conflict as on a Möbius strip) is cut;
//! 5. every vertex gets one copy per fan of faces joined around it, which
//!    both separates the sides of cut edges and splits non-manifold
//!    (bow-tie) vertices. Where a cut edge's faces would still share both
//!    copies (a cut across a closed fan), one face is detached at that
//!    vertex by cutting its other edge there;
//! 6. components (faces connected through joined edges) are separated and
//!    renumbered compactly, in input order; unused vertices disappear;
//! 7. each component keeps the orientation most of its input faces had,
//!    except that a closed component is oriented to positive signed volume
//!    `sum of a . (b x c) / 6` (outward normals).
//!
//! Holes stay holes. Everything is sorting and union-find, `O(n log n)`.
//!
//! [`topology`] counts a triangle mesh's vertices, edges, faces, boundary
//! loops and genus (`V - E + F = 2 - 2g - b`) and checks it is manifold.

use std::collections::{HashMap, VecDeque};
use std::fmt;

use qm_io::PolyMesh;
use qm_lift::glam::DVec3;

use crate::{Error, Result, TriMesh};

/// The components of a cleaned mesh and what cleaning changed.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Cleaned {
    /// One connected, manifold, consistently oriented mesh per component, in
    /// the order of their first input face.
    pub components: Vec<TriMesh>,
    /// What was changed; its `Display` is one summary line.
    pub report: CleanReport,
}

/// Counts of what [`clean`] changed. Face counts after step 1 are in
/// triangles.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[non_exhaustive]
pub struct CleanReport {
    /// Vertices of the input.
    pub input_vertices: usize,
    /// Faces (polygons) of the input.
    pub input_faces: usize,
    /// Triangles after fan triangulation.
    pub triangles: usize,
    /// Vertices merged into an earlier one with a bit-identical position.
    pub merged_vertices: usize,
    /// Faces with fewer than three corners, and triangles with a repeated
    /// vertex or zero area.
    pub dropped_degenerate: usize,
    /// Triangles with the same vertex set as an earlier one.
    pub dropped_duplicate: usize,
    /// Edges shared by faces that were not joined across them: more than
    /// two faces, an orientation conflict, or a cut to separate a fan.
    pub split_edges: usize,
    /// Vertices given more than one copy (split edges' ends and bow ties).
    pub split_vertices: usize,
    /// Vertex copies added by splitting.
    pub added_vertices: usize,
    /// Output triangles whose orientation is the reverse of the input's.
    pub flipped_faces: usize,
    /// Vertices (after merging) used by no remaining triangle.
    pub dropped_unused_vertices: usize,
    /// Connected components.
    pub components: usize,
    /// Vertices of all components together.
    pub output_vertices: usize,
    /// Triangles of all components together.
    pub output_faces: usize,
}

impl fmt::Display for CleanReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "clean-up: {} -> {} vertices ({} duplicates merged, {} unused dropped, {} added by splits), \
             {} faces -> {} triangles ({} degenerate and {} duplicate dropped), \
             {} non-manifold edges and {} vertices split, {} faces flipped, {} component{}",
            Thousands(self.input_vertices),
            Thousands(self.output_vertices),
            Thousands(self.merged_vertices),
            Thousands(self.dropped_unused_vertices),
            Thousands(self.added_vertices),
            Thousands(self.input_faces),
            Thousands(self.output_faces),
            Thousands(self.dropped_degenerate),
            Thousands(self.dropped_duplicate),
            Thousands(self.split_edges),
            Thousands(self.split_vertices),
            Thousands(self.flipped_faces),
            Thousands(self.components),
            if self.components == 1 { "" } else { "s" },
        )
    }
}

/// A count with thousands separators: `3,225`.
struct Thousands(usize);

impl fmt::Display for Thousands {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let digits = self.0.to_string();
        for (i, d) in digits.chars().enumerate() {
            if i > 0 && (digits.len() - i) % 3 == 0 {
                f.write_str(",")?;
            }
            write!(f, "{d}")?;
        }
        Ok(())
    }
}

/// Cleans `mesh` into manifold, consistently oriented components (see the
/// module documentation for the steps).
///
/// A mesh with no usable face gives no components, not an error.
///
/// # Errors
/// [`Error::VertexOutOfRange`] if a face refers to a missing vertex,
/// [`Error::NonFiniteVertex`] if a used vertex is NaN or infinite.
pub fn clean(mesh: &PolyMesh) -> Result<Cleaned> {
    let mut report = CleanReport {
        input_vertices: mesh.positions.len(),
        input_faces: mesh.face_count(),
        ..CleanReport::default()
    };
    let tris = triangulate(mesh, &mut report)?;
    report.triangles = tris.len();

    let (remap, positions) = merge_identical(&mesh.positions);
    report.merged_vertices = mesh.positions.len() - positions.len();
    let tris = drop_bad_triangles(tris, &remap, &positions, &mut report);

    let edges = EdgeTable::new(&tris);
    let (flip, mut state) = orient(&tris, &edges, &mut report);

    // Step 5: one vertex copy per fan; detach faces where cut edges still
    // share both copies, then regroup (splitting only ever separates more).
    let mut roots = corner_groups(&tris, &edges, &state);
    let detach = shared_cut_corners(&edges, &state, &roots);
    for &c in &detach {
        let prev = c - c % 3 + (c % 3 + 2) % 3;
        let e = edges.edge_of[prev] as usize;
        if state[e] == EdgeState::Joined {
            state[e] = EdgeState::Cut;
            report.split_edges += 1;
        }
    }
    if !detach.is_empty() {
        roots = corner_groups(&tris, &edges, &state);
        if !shared_cut_corners(&edges, &state, &roots).is_empty() {
            return Err(Error::Internal("clean-up left a cut edge shared"));
        }
    }

    let components = assemble(
        &tris,
        &positions,
        &edges,
        &state,
        &flip,
        &roots,
        &mut report,
    );
    Ok(Cleaned { components, report })
}

/// Step 1: fan triangulation, checking indices and used positions.
fn triangulate(mesh: &PolyMesh, report: &mut CleanReport) -> Result<Vec<[u32; 3]>> {
    let n = mesh.positions.len();
    let mut tris = Vec::with_capacity(mesh.face_count());
    for (k, face) in mesh.faces().enumerate() {
        for &v in face {
            match mesh.positions.get(v as usize) {
                None => return Err(Error::VertexOutOfRange { face: k, vertex: v }),
                Some(p) if !p.is_finite() => return Err(Error::NonFiniteVertex { vertex: v }),
                Some(_) => {}
            }
        }
        debug_assert!(face.iter().all(|&v| (v as usize) < n));
        if face.len() < 3 {
            report.dropped_degenerate += 1;
            continue;
        }
        for i in 1..face.len() - 1 {
            tris.push([face[0], face[i], face[i + 1]]);
        }
    }
    Ok(tris)
}

/// Step 2: merges bit-identical positions. Returns the new index of every
/// input vertex and the unique positions, in order of first occurrence.
fn merge_identical(positions: &[DVec3]) -> (Vec<u32>, Vec<DVec3>) {
    let mut keyed: Vec<([u64; 3], u32)> = positions
        .iter()
        .enumerate()
        .map(|(i, p)| ([p.x.to_bits(), p.y.to_bits(), p.z.to_bits()], i as u32))
        .collect();
    keyed.sort_unstable();
    // Sorted by (key, index): the first of each run is its smallest index.
    let mut first = vec![0u32; positions.len()];
    let mut run = 0;
    for k in 0..keyed.len() {
        if keyed[k].0 != keyed[run].0 {
            run = k;
        }
        first[keyed[k].1 as usize] = keyed[run].1;
    }
    let mut remap = vec![0u32; positions.len()];
    let mut unique = Vec::new();
    for i in 0..positions.len() {
        let f = first[i] as usize;
        if f == i {
            remap[i] = unique.len() as u32;
            unique.push(positions[i]);
        } else {
            remap[i] = remap[f];
        }
    }
    (remap, unique)
}

/// Step 3: renumbers and drops degenerate and duplicate triangles.
fn drop_bad_triangles(
    tris: Vec<[u32; 3]>,
    remap: &[u32],
    positions: &[DVec3],
    report: &mut CleanReport,
) -> Vec<[u32; 3]> {
    let mut kept = Vec::with_capacity(tris.len());
    for t in tris {
        let [a, b, c] = t.map(|v| remap[v as usize]);
        let [pa, pb, pc] = [a, b, c].map(|v| positions[v as usize]);
        if a == b || b == c || a == c || (pb - pa).cross(pc - pa) == DVec3::ZERO {
            report.dropped_degenerate += 1;
        } else {
            kept.push([a, b, c]);
        }
    }
    let mut keyed: Vec<([u32; 3], u32)> = kept
        .iter()
        .enumerate()
        .map(|(i, t)| {
            let mut s = *t;
            s.sort_unstable();
            (s, i as u32)
        })
        .collect();
    keyed.sort_unstable();
    let mut keep = vec![true; kept.len()];
    for w in keyed.windows(2) {
        if w[0].0 == w[1].0 {
            keep[w[1].1 as usize] = false;
            report.dropped_duplicate += 1;
        }
    }
    let mut i = 0;
    kept.retain(|_| {
        i += 1;
        keep[i - 1]
    });
    kept
}

/// Undirected edges and the corners using them. Corner `c = 3 t + i` of
/// triangle `t` starts the directed edge `t[i] -> t[(i + 1) % 3]`.
struct EdgeTable {
    /// Edge of each corner.
    edge_of: Vec<u32>,
    /// Corners sorted by edge; edge `e` has `corners[start[e]..start[e + 1]]`.
    corners: Vec<u32>,
    start: Vec<usize>,
}

impl EdgeTable {
    fn new(tris: &[[u32; 3]]) -> Self {
        let mut keyed: Vec<(u64, u32)> = Vec::with_capacity(3 * tris.len());
        for (t, tri) in tris.iter().enumerate() {
            for i in 0..3 {
                let (a, b) = (tri[i], tri[(i + 1) % 3]);
                let key = (u64::from(a.min(b)) << 32) | u64::from(a.max(b));
                keyed.push((key, (3 * t + i) as u32));
            }
        }
        keyed.sort_unstable();
        let mut edge_of = vec![0u32; keyed.len()];
        let mut start = Vec::new();
        for (k, &(key, c)) in keyed.iter().enumerate() {
            if k == 0 || keyed[k - 1].0 != key {
                start.push(k);
            }
            edge_of[c as usize] = (start.len() - 1) as u32;
        }
        start.push(keyed.len());
        EdgeTable {
            edge_of,
            corners: keyed.into_iter().map(|(_, c)| c).collect(),
            start,
        }
    }

    fn count(&self) -> usize {
        self.start.len() - 1
    }

    fn corners(&self, e: usize) -> &[u32] {
        &self.corners[self.start[e]..self.start[e + 1]]
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum EdgeState {
    /// One face: a boundary edge.
    Boundary,
    /// Two faces, not yet decided.
    Open,
    /// Two faces joined with agreeing orientations.
    Joined,
    /// Shared by faces that are not joined across it.
    Cut,
}

/// Step 4: greedy breadth-first orientation. Returns whether each face is
/// flipped relative to the input, and each edge's state.
fn orient(
    tris: &[[u32; 3]],
    edges: &EdgeTable,
    report: &mut CleanReport,
) -> (Vec<bool>, Vec<EdgeState>) {
    let mut state: Vec<EdgeState> = (0..edges.count())
        .map(|e| match edges.corners(e).len() {
            1 => EdgeState::Boundary,
            2 => EdgeState::Open,
            _ => {
                report.split_edges += 1;
                EdgeState::Cut
            }
        })
        .collect();
    let mut flip = vec![false; tris.len()];
    let mut seen = vec![false; tris.len()];
    let mut queue = VecDeque::new();
    for seed in 0..tris.len() {
        if seen[seed] {
            continue;
        }
        seen[seed] = true;
        queue.push_back(seed);
        while let Some(f) = queue.pop_front() {
            for i in 0..3 {
                let c = 3 * f + i;
                let e = edges.edge_of[c] as usize;
                if state[e] != EdgeState::Open {
                    continue;
                }
                let pair = edges.corners(e);
                let other = if pair[0] as usize == c {
                    pair[1]
                } else {
                    pair[0]
                } as usize;
                let g = other / 3;
                // Both faces run the edge the same way in the input.
                let same = tris[f][i] == tris[g][other % 3];
                if !seen[g] {
                    seen[g] = true;
                    flip[g] = flip[f] ^ same;
                    queue.push_back(g);
                    state[e] = EdgeState::Joined;
                } else if !same ^ flip[f] ^ flip[g] {
                    state[e] = EdgeState::Joined;
                } else {
                    state[e] = EdgeState::Cut;
                    report.split_edges += 1;
                }
            }
        }
    }
    (flip, state)
}

fn find(parent: &mut [u32], mut x: u32) -> u32 {
    while parent[x as usize] != x {
        let up = parent[parent[x as usize] as usize];
        parent[x as usize] = up;
        x = up;
    }
    x
}

fn union(parent: &mut [u32], a: u32, b: u32) {
    let (a, b) = (find(parent, a), find(parent, b));
    if a != b {
        parent[a.max(b) as usize] = a.min(b);
    }
}

fn next_corner(c: usize) -> usize {
    c - c % 3 + (c % 3 + 1) % 3
}

/// The fan of every corner around its vertex: corners joined across
/// [`EdgeState::Joined`] edges share a root (the smallest corner of the fan).
fn corner_groups(tris: &[[u32; 3]], edges: &EdgeTable, state: &[EdgeState]) -> Vec<u32> {
    let mut parent: Vec<u32> = (0..3 * tris.len() as u32).collect();
    for (e, s) in state.iter().enumerate() {
        if *s != EdgeState::Joined {
            continue;
        }
        let pair = edges.corners(e);
        let (c1, c2) = (pair[0] as usize, pair[1] as usize);
        let (n1, n2) = (next_corner(c1), next_corner(c2));
        if tris[c1 / 3][c1 % 3] == tris[c2 / 3][c2 % 3] {
            union(&mut parent, c1 as u32, c2 as u32);
            union(&mut parent, n1 as u32, n2 as u32);
        } else {
            union(&mut parent, c1 as u32, n2 as u32);
            union(&mut parent, n1 as u32, c2 as u32);
        }
    }
    (0..parent.len() as u32)
        .map(|c| find(&mut parent, c))
        .collect()
}

/// Corners of cut edges whose face still shares both end copies with an
/// earlier corner of the same edge: each must be detached at its start.
fn shared_cut_corners(edges: &EdgeTable, state: &[EdgeState], roots: &[u32]) -> Vec<usize> {
    let mut detach = Vec::new();
    let mut ends: Vec<(u32, u32, u32)> = Vec::new();
    for (e, s) in state.iter().enumerate() {
        let corners = edges.corners(e);
        if corners.len() < 2 || *s == EdgeState::Joined {
            continue;
        }
        ends.clear();
        for &c in corners {
            let (x, y) = (roots[c as usize], roots[next_corner(c as usize)]);
            ends.push((x.min(y), x.max(y), c));
        }
        ends.sort_unstable();
        for w in ends.windows(2) {
            if (w[0].0, w[0].1) == (w[1].0, w[1].1) {
                detach.push(w[1].2 as usize);
            }
        }
    }
    detach
}

/// Steps 6 and 7: components, orientation, compact numbering.
fn assemble(
    tris: &[[u32; 3]],
    positions: &[DVec3],
    edges: &EdgeTable,
    state: &[EdgeState],
    flip: &[bool],
    roots: &[u32],
    report: &mut CleanReport,
) -> Vec<TriMesh> {
    let nf = tris.len();
    let mut parent: Vec<u32> = (0..nf as u32).collect();
    for (e, s) in state.iter().enumerate() {
        if *s == EdgeState::Joined {
            let pair = edges.corners(e);
            union(&mut parent, pair[0] / 3, pair[1] / 3);
        }
    }
    // Components numbered by their first face.
    let mut comp_of = vec![u32::MAX; nf];
    let mut count = 0usize;
    for f in 0..nf {
        let r = find(&mut parent, f as u32) as usize;
        if comp_of[r] == u32::MAX {
            comp_of[r] = count as u32;
            count += 1;
        }
        comp_of[f] = comp_of[r];
    }

    // Orientation per component: closed ones outward, open ones as most of
    // their input faces were.
    let mut closed = vec![true; count];
    let mut flipped = vec![0usize; count];
    let mut faces = vec![0usize; count];
    let mut volume = vec![0.0f64; count];
    let mut origin: Vec<Option<DVec3>> = vec![None; count];
    for f in 0..nf {
        let k = comp_of[f] as usize;
        faces[k] += 1;
        flipped[k] += usize::from(flip[f]);
        if (0..3).any(|i| state[edges.edge_of[3 * f + i] as usize] != EdgeState::Joined) {
            closed[k] = false;
        }
        let [a, b, c] = tris[f].map(|v| positions[v as usize]);
        // Relative to a point of the component, for precision far from 0.
        let o = *origin[k].get_or_insert(a);
        let v = (a - o).dot((b - o).cross(c - o));
        volume[k] += if flip[f] { -v } else { v };
    }
    let reverse: Vec<bool> = (0..count)
        .map(|k| {
            if closed[k] && volume[k] != 0.0 {
                volume[k] < 0.0
            } else {
                2 * flipped[k] > faces[k]
            }
        })
        .collect();

    // Vertex copies numbered within their component in input vertex order.
    let mut by_vertex_start = vec![0usize; positions.len() + 1];
    for t in tris {
        for &v in t {
            by_vertex_start[v as usize + 1] += 1;
        }
    }
    for v in 0..positions.len() {
        by_vertex_start[v + 1] += by_vertex_start[v];
    }
    let mut fill = by_vertex_start.clone();
    let mut by_vertex = vec![0u32; 3 * nf];
    for (t, tri) in tris.iter().enumerate() {
        for (i, &v) in tri.iter().enumerate() {
            by_vertex[fill[v as usize]] = (3 * t + i) as u32;
            fill[v as usize] += 1;
        }
    }
    let mut components = vec![TriMesh::default(); count];
    let mut local = vec![u32::MAX; 3 * nf];
    for v in 0..positions.len() {
        let corners = &by_vertex[by_vertex_start[v]..by_vertex_start[v + 1]];
        if corners.is_empty() {
            report.dropped_unused_vertices += 1;
            continue;
        }
        let mut copies = 0;
        for &c in corners {
            let r = roots[c as usize] as usize;
            if local[r] == u32::MAX {
                let mesh = &mut components[comp_of[c as usize / 3] as usize];
                local[r] = mesh.positions.len() as u32;
                mesh.positions.push(positions[v]);
                copies += 1;
            }
        }
        if copies > 1 {
            report.split_vertices += 1;
            report.added_vertices += copies - 1;
        }
    }
    for f in 0..nf {
        let k = comp_of[f] as usize;
        let [a, b, c] = [0, 1, 2].map(|i| local[roots[3 * f + i] as usize]);
        let flipped = flip[f] ^ reverse[k];
        report.flipped_faces += usize::from(flipped);
        components[k]
            .triangles
            .push(if flipped { [a, c, b] } else { [a, b, c] });
    }
    report.components = count;
    report.output_vertices = components.iter().map(|m| m.positions.len()).sum();
    report.output_faces = nf;
    components
}

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

    let mut parent: Vec<u32> = (0..3 * mesh.triangles.len() as u32).collect();
    let mut interior = 0usize;
    let mut boundary: HashMap<u32, u32> = HashMap::new();
    for &(key, c) in &directed {
        let (a, b) = ((key >> 32) as u32, key as u32);
        match twin(key) {
            Some(d) => {
                interior += 1;
                // Corner c starts at a, d starts at b: join the fans.
                union(&mut parent, c, next_corner(d as usize) as u32);
                union(&mut parent, next_corner(c as usize) as u32, d);
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
            let r = find(&mut parent, (3 * t + i) as u32);
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

#[cfg(test)]
mod tests {
    use super::*;

    fn dv(p: [f64; 3]) -> DVec3 {
        DVec3::from_array(p)
    }

    fn poly<const K: usize>(p: &[[f64; 3]], f: &[[u32; K]]) -> PolyMesh {
        PolyMesh::from_faces(p.iter().copied().map(dv).collect(), f)
    }

    fn tetra(o: [f64; 3]) -> (Vec<[f64; 3]>, Vec<[u32; 3]>) {
        let p = [[0., 0., 0.], [1., 0., 0.], [0., 1., 0.], [0., 0., 1.]]
            .map(|q| [q[0] + o[0], q[1] + o[1], q[2] + o[2]])
            .to_vec();
        (p, vec![[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]])
    }

    fn cube(o: [f64; 3]) -> (Vec<[f64; 3]>, Vec<[u32; 4]>) {
        let mut p = Vec::new();
        for i in 0..8 {
            p.push([
                o[0] + f64::from(i & 1),
                o[1] + f64::from((i >> 1) & 1),
                o[2] + f64::from((i >> 2) & 1),
            ]);
        }
        // Outward quads.
        let f = vec![
            [0, 2, 3, 1],
            [4, 5, 7, 6],
            [0, 1, 5, 4],
            [2, 6, 7, 3],
            [0, 4, 6, 2],
            [1, 3, 7, 5],
        ];
        (p, f)
    }

    fn volume(m: &TriMesh) -> f64 {
        m.triangles
            .iter()
            .map(|t| {
                let [a, b, c] = m.corners(t);
                a.dot(b.cross(c)) / 6.0
            })
            .sum()
    }

    fn assert_clean(c: &Cleaned) {
        for m in &c.components {
            let t = topology(m);
            assert!(t.manifold, "{t:?}");
        }
    }

    #[test]
    fn report_line_has_separators() {
        let r = CleanReport {
            input_vertices: 3225,
            output_vertices: 2930,
            merged_vertices: 295,
            components: 1,
            ..CleanReport::default()
        };
        let s = r.to_string();
        assert!(
            s.starts_with("clean-up: 3,225 -> 2,930 vertices (295 duplicates merged"),
            "{s}"
        );
        assert!(s.ends_with("1 component"), "{s}");
        assert!(!s.contains('\n'));
        assert_eq!(Thousands(1_234_567).to_string(), "1,234,567");
        assert_eq!(Thousands(0).to_string(), "0");
    }

    #[test]
    fn seam_duplicates_merge() {
        // A tetrahedron whose vertex 0 is stored three times, one per face
        // using it (as texture seams do).
        let (mut p, _) = tetra([0.; 3]);
        p.push(p[0]);
        p.push(p[0]);
        let f = [[0, 2, 1], [4, 1, 3], [5, 3, 2], [1, 2, 3]];
        let c = clean(&poly(&p, &f)).unwrap();
        assert_eq!(c.report.merged_vertices, 2);
        assert_eq!(c.report.output_vertices, 4);
        assert_eq!(c.components.len(), 1);
        let t = topology(&c.components[0]);
        assert!(t.manifold && t.is_closed() && t.genus == 0, "{t:?}");
    }

    #[test]
    fn disjoint_tetrahedra_are_two_components() {
        let (mut p, mut f) = tetra([0.; 3]);
        let (p2, f2) = tetra([5., 0., 0.]);
        p.extend(p2);
        f.extend(f2.iter().map(|t| t.map(|v| v + 4)));
        let c = clean(&poly(&p, &f)).unwrap();
        assert_eq!(c.components.len(), 2);
        assert_eq!(c.report.flipped_faces, 0);
        for m in &c.components {
            assert_eq!((m.positions.len(), m.triangles.len()), (4, 4));
            assert!(volume(m) > 0.0);
        }
        assert_clean(&c);
    }

    #[test]
    fn non_manifold_edge_is_split() {
        // Three triangles on edge 0-1.
        let p = [
            [0., 0., 0.],
            [1., 0., 0.],
            [0., 1., 0.],
            [0., -1., 0.],
            [0., 0., 1.],
        ];
        let f = [[0, 1, 2], [1, 0, 3], [0, 1, 4]];
        let c = clean(&poly(&p, &f)).unwrap();
        assert_eq!(c.report.split_edges, 1);
        assert_eq!(c.report.split_vertices, 2);
        assert_eq!(c.components.len(), 3);
        assert_eq!(c.report.output_vertices, 9);
        assert_clean(&c);
    }

    #[test]
    fn bow_tie_cubes_split_at_the_shared_vertex() {
        let (mut p, mut f) = cube([0.; 3]);
        let (p2, f2) = cube([1., 1., 1.]);
        // Cube 2's vertex 0 is cube 1's vertex 7.
        p.extend(p2);
        f.extend(f2.iter().map(|q| q.map(|v| v + 8)));
        let c = clean(&poly(&p, &f)).unwrap();
        assert_eq!(c.report.merged_vertices, 1);
        assert_eq!(c.report.split_vertices, 1);
        assert_eq!(c.report.split_edges, 0);
        assert_eq!(c.components.len(), 2);
        for m in &c.components {
            let t = topology(m);
            assert!(t.manifold && t.is_closed() && t.genus == 0, "{t:?}");
            assert_eq!((t.vertices, t.faces), (8, 12));
            assert!((volume(m) - 1.0).abs() < 1e-12);
        }
    }

    #[test]
    fn degenerate_faces_and_unused_vertices_drop() {
        let (mut p, mut f) = tetra([0.; 3]);
        p.push([9., 9., 9.]); // unused
        p.push([0.5, 0., 0.]); // on edge 0-1
        f.push([0, 5, 1]); // zero area
        f.push([2, 2, 3]); // repeated vertex
        let mut m = poly(&p, &f);
        m.push_face(&[0, 1]); // too few corners
        let c = clean(&m).unwrap();
        assert_eq!(c.report.dropped_degenerate, 3);
        // Vertex 5 is used only by the dropped face.
        assert_eq!(c.report.dropped_unused_vertices, 2);
        assert_eq!(c.components.len(), 1);
        assert_eq!(c.components[0].positions.len(), 4);
        assert_clean(&c);
    }

    #[test]
    fn duplicate_faces_drop() {
        let (p, mut f) = tetra([0.; 3]);
        f.push([2, 1, 0]); // same set, other orientation
        f.push([1, 3, 0]); // same as face 1, rotated
        let c = clean(&poly(&p, &f)).unwrap();
        assert_eq!(c.report.dropped_duplicate, 2);
        assert_eq!(c.report.output_faces, 4);
        assert_eq!(c.report.split_edges, 0);
        assert_clean(&c);
    }

    #[test]
    fn quads_and_ngons_are_fans() {
        let p = [
            [0., 0., 0.],
            [1., 0., 0.],
            [2., 1., 0.],
            [1., 2., 0.],
            [0., 1., 0.],
        ];
        let mut m = poly(&p, &[[0, 1, 2, 3, 4]]);
        m.push_face(&[0, 1, 2]); // a duplicate of the first fan triangle
        let c = clean(&m).unwrap();
        assert_eq!(c.report.triangles, 4);
        assert_eq!(c.report.dropped_duplicate, 1);
        let t = topology(&c.components[0]);
        assert_eq!((t.faces, t.boundary_loops, t.genus), (3, 1, 0));
    }

    /// A `w` by `h` grid of quads split into triangles, every other one
    /// reversed.
    fn grid(w: u32, h: u32, scramble: bool) -> PolyMesh {
        let mut p = Vec::new();
        for y in 0..=h {
            for x in 0..=w {
                p.push([f64::from(x), f64::from(y), 0.0]);
            }
        }
        let id = |x: u32, y: u32| y * (w + 1) + x;
        let mut f = Vec::new();
        for y in 0..h {
            for x in 0..w {
                let (a, b, c, d) = (id(x, y), id(x + 1, y), id(x + 1, y + 1), id(x, y + 1));
                f.push([a, b, c]);
                f.push([a, c, d]);
            }
        }
        if scramble {
            for (k, t) in f.iter_mut().enumerate() {
                if k % 3 != 0 {
                    t.swap(1, 2);
                }
            }
        }
        poly(&p, &f)
    }

    #[test]
    fn inconsistent_orientation_is_made_consistent() {
        let c = clean(&grid(6, 5, true)).unwrap();
        assert_eq!(c.components.len(), 1);
        assert_eq!(c.report.split_edges, 0);
        let m = &c.components[0];
        // Every interior edge once in each direction.
        let mut dir = HashMap::new();
        for t in &m.triangles {
            for i in 0..3 {
                *dir.entry((t[i], t[(i + 1) % 3])).or_insert(0) += 1;
            }
        }
        let mut interior = 0;
        for (&(a, b), &n) in &dir {
            assert_eq!(n, 1);
            interior += usize::from(dir.contains_key(&(b, a)));
        }
        assert_eq!(interior / 2, 6 * 4 + 5 * 5 + 30);
        // Kept the orientation most input faces had (2 of 3 reversed: -z).
        assert!(m.triangles.iter().all(|t| {
            let [a, b, c] = m.corners(t);
            (b - a).cross(c - a).z < 0.0
        }));
        assert!(topology(m).manifold);
    }

    #[test]
    fn closed_mesh_turns_outward() {
        let (p, f) = tetra([0.; 3]);
        let inward: Vec<[u32; 3]> = f.iter().map(|t| [t[0], t[2], t[1]]).collect();
        let c = clean(&poly(&p, &inward)).unwrap();
        assert_eq!(c.report.flipped_faces, 4);
        assert!(volume(&c.components[0]) > 0.0);
        let (p, f) = cube([3., -2., 7.]);
        let inward: Vec<[u32; 4]> = f.iter().map(|q| [q[3], q[2], q[1], q[0]]).collect();
        let c = clean(&poly(&p, &inward)).unwrap();
        assert!((volume(&c.components[0]) - 1.0).abs() < 1e-12);
    }

    #[test]
    fn mobius_strip_becomes_orientable() {
        let n = 12u32;
        let mut p = Vec::new();
        for i in 0..n {
            let a = std::f64::consts::TAU * f64::from(i) / f64::from(n);
            for s in [-0.3, 0.3] {
                let (r, z) = (1.0 + s * (a / 2.0).cos(), s * (a / 2.0).sin());
                p.push([r * a.cos(), r * a.sin(), z]);
            }
        }
        let mut f = Vec::new();
        for i in 0..n {
            let (a, b) = (2 * i, 2 * i + 1);
            // The last rung joins with a half twist.
            let (c, d) = if i + 1 == n {
                (1, 0)
            } else {
                (2 * i + 2, 2 * i + 3)
            };
            f.push([a, c, d]);
            f.push([a, d, b]);
        }
        let c = clean(&poly(&p, &f)).unwrap();
        assert_eq!(c.components.len(), 1);
        assert!(c.report.split_edges >= 1);
        let t = topology(&c.components[0]);
        assert!(t.manifold, "{t:?}");
        assert_eq!((t.boundary_loops, t.genus), (1, 0));
    }

    #[test]
    fn hostile_inputs_do_not_panic() {
        assert_eq!(clean(&PolyMesh::new()).unwrap().components.len(), 0);
        let m = poly(&[[0.; 3]], &[[0, 0, 0]]);
        assert_eq!(clean(&m).unwrap().report.dropped_degenerate, 1);
        let m = poly(&[[0.; 3]], &[[0, 1, 2]]);
        assert!(matches!(
            clean(&m),
            Err(Error::VertexOutOfRange { face: 0, vertex: 1 })
        ));
        let m = poly(&[[0.; 3], [1., 0., 0.], [f64::NAN, 0., 0.]], &[[0, 1, 2]]);
        assert!(matches!(
            clean(&m),
            Err(Error::NonFiniteVertex { vertex: 2 })
        ));
        // Many faces on one edge, and a Klein-bottle-like tangle.
        let p: Vec<[f64; 3]> = (0..40)
            .map(|i| [f64::from(i), f64::from(i * i % 7), f64::from(i % 5)])
            .collect();
        let mut f = Vec::new();
        for i in 2..40u32 {
            f.push([0, 1, i]);
            f.push([i, (i * 7) % 40, (i * 13 + 1) % 40]);
        }
        let c = clean(&poly(&p, &f)).unwrap();
        assert_clean(&c);
    }

    #[test]
    fn closed_non_orientable_surface_is_cut_open() {
        // A Klein bottle as a 6 x 6 grid with twisted identification.
        let (w, h) = (6u32, 6u32);
        let id = |x: u32, y: u32| {
            let (x, y) = (x % w, y);
            if y == h {
                ((w - x) % w) as usize
            } else {
                (y * w + x) as usize
            }
        };
        let p: Vec<[f64; 3]> = (0..w * h)
            .map(|i| [f64::from(i % w), f64::from(i / w), f64::from((i * 7) % 11)])
            .collect();
        let mut f = Vec::new();
        for y in 0..h {
            for x in 0..w {
                let (a, b, c, d) = (id(x, y), id(x + 1, y), id(x + 1, y + 1), id(x, y + 1));
                f.push([a as u32, b as u32, c as u32]);
                f.push([a as u32, c as u32, d as u32]);
            }
        }
        let c = clean(&poly(&p, &f)).unwrap();
        assert!(c.report.split_edges >= 1);
        assert_clean(&c);
    }

    /// Cleans every model in the shared development folder. It lives beside
    /// the checkout and is absent on other machines, so the test then does
    /// nothing.
    #[test]
    fn shared_models() {
        let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared/models");
        if !dir.is_dir() {
            return;
        }
        let mut files = Vec::new();
        for sub in [dir.clone(), dir.join("quad")] {
            let Ok(entries) = std::fs::read_dir(&sub) else {
                continue;
            };
            for e in entries.flatten() {
                let path = e.path();
                let ext = path.extension().and_then(|e| e.to_str()).unwrap_or("");
                if ["obj", "ply", "off", "stl"].contains(&ext) {
                    files.push(path);
                }
            }
        }
        files.sort();
        for path in files {
            let mesh = qm_io::mesh::read_mesh(&path).unwrap();
            let start = std::time::Instant::now();
            let c = clean(&mesh).unwrap();
            let took = start.elapsed();
            let topo = components_topology(&c.components);
            let name = path.file_stem().unwrap().to_string_lossy().into_owned();
            println!("{name}: {} ({:.1} ms)", c.report, took.as_secs_f64() * 1e3);
            for t in &topo {
                println!(
                    "  component: {} vertices, {} faces, {} boundary loops, genus {}",
                    t.vertices, t.faces, t.boundary_loops, t.genus
                );
                assert!(t.manifold, "{name}: {t:?}");
            }
            for m in &c.components {
                if topology(m).is_closed() {
                    assert!(volume(m) > 0.0, "{name}");
                }
            }
            match name.as_str() {
                "spot" => {
                    assert_eq!(c.report.output_vertices, 2930);
                    assert_eq!(topo.len(), 1);
                    assert!(topo[0].is_closed() && topo[0].genus == 0);
                }
                "rocker-arm" => assert_eq!(topo[0].genus, 1),
                "stanford-bunny" => {
                    assert_eq!(topo.len(), 1);
                    assert_eq!((topo[0].boundary_loops, topo[0].genus), (5, 0));
                }
                _ => {}
            }
        }
    }

    /// A 700 x 700 torus grid (490,000 vertices) for timing in release:
    /// `cargo test --release -p qm-param clean::tests::large -- --ignored --nocapture`.
    #[test]
    #[ignore = "timing; run in release"]
    fn large_torus_timing() {
        let (w, h) = (700u32, 700u32);
        let mut p = Vec::new();
        for y in 0..h {
            for x in 0..w {
                let (u, v) = (
                    std::f64::consts::TAU * f64::from(x) / f64::from(w),
                    std::f64::consts::TAU * f64::from(y) / f64::from(h),
                );
                let r = 3.0 + v.cos();
                p.push(DVec3::new(r * u.cos(), r * u.sin(), v.sin()));
            }
        }
        let id = |x: u32, y: u32| (y % h) * w + (x % w);
        let mut m = PolyMesh::new();
        m.positions = p;
        for y in 0..h {
            for x in 0..w {
                m.push_face(&[id(x, y), id(x + 1, y), id(x + 1, y + 1), id(x, y + 1)]);
            }
        }
        let start = std::time::Instant::now();
        let c = clean(&m).unwrap();
        println!(
            "{} ({:.1} ms)",
            c.report,
            start.elapsed().as_secs_f64() * 1e3
        );
        let t = topology(&c.components[0]);
        assert_eq!((t.genus, t.boundary_loops), (1, 0));
        assert!(t.manifold);
    }
}
