//! Mesh clean-up before parameterization.
//!
//! [`clean`] turns any polygon mesh into a list of triangle meshes, one per
//! connected component, each a single edge-manifold, vertex-manifold,
//! consistently oriented surface, and reports what it changed in one line
//! ([`CleanReport`]). In order:
//!
//! 1. polygons are split into triangles: fans `(v0, vi, vi+1)`, or for a convex
//!    polygon of more than four corners a strip from both ends in turn;
//! 2. vertices with bit-identical positions are merged (texture-seam
//!    duplicates);
//! 3. degenerate triangles (a repeated vertex, or an exactly zero cross
//!    product) are dropped. Triangles on the same vertex set cancel in
//!    pairs that run opposite ways, as in a sum of oriented faces: of those
//!    on one set, one opposite pair stands for the cancelled ones, one
//!    triangle of the orientation left over (if any) is kept, and the rest
//!    are dropped as duplicates. The pairs then cancel (both faces go) in
//!    every patch of such pairs that meets two or more other faces at some
//!    edge: a thin part that a reconstruction collapsed to zero thickness,
//!    or the wall where two parts touch face to face, whose rim would
//!    otherwise have four faces to an edge all around it. A patch that
//!    meets at most one other face at each edge (a free two-sided sheet, or
//!    a face stored again, reversed, on a surface) keeps one face per
//!    vertex set;
//! 4. the faces around an edge with more than two are paired into sheets
//!    where they can be (see `pair_sheets`): sorted by angle about the
//!    edge, a face pairs with its neighbour when the two run the edge in
//!    opposite directions and the wedge between them is inside the solid
//!    (parts that touch along the edge come apart), or, the other way,
//!    outside it (they join there). Both are tried where any edge has more
//!    than two faces, and the simpler result is kept: fewer handles, holes and
//!    components, which is what the remesher must cut through. Pinched
//!    edges of a reconstructed scan then become manifold sheets instead of
//!    faces cut loose, which left slits. Faces left over are cut loose, as
//!    are all of an edge's faces where none pair;
//! 5. faces are oriented greedily, breadth first: a face joins its neighbour
//!    across an edge (or a sheet) only if exactly two faces use it and their
//!    orientations can agree (flipping the newly reached face if needed).
//!    Every other shared edge (an orientation conflict as on a Möbius
//!    strip) is cut;
//! 6. every vertex gets one copy per fan of faces joined around it, which
//!    both separates the sides of cut edges and splits non-manifold
//!    (bow-tie) vertices. Where two sheets of an edge would still share both
//!    copies (the fans around its ends join them elsewhere, as when the
//!    pairing joins two parts that touch only along the edge), the edge's
//!    pairing is undone; where a cut edge's faces would still share both
//!    copies (a cut across a closed fan), one face is detached at that
//!    vertex by cutting its other edge there. Each round regroups, until
//!    nothing is shared (two rounds at most on every input tried);
//! 7. components (faces connected through joined edges) are separated and
//!    renumbered compactly, in input order; unused vertices disappear;
//! 8. each component keeps the orientation most of its input faces had,
//!    except that a closed component is oriented to positive signed volume
//!    `sum of a . (b x c) / 6` (outward normals).
//!
//! Holes stay holes. The only faces removed that are not degenerate or
//! duplicates are cancelled pairs (step 3), which leave an opening only
//! where such a patch also meets a single face at some edge. Everything is
//! sorting and union-find, `O(n log n)` per round of step 6.
//!
//! [`topology`] counts a triangle mesh's vertices, edges, faces, boundary
//! loops and genus (`V - E + F = 2 - 2g - b`) and checks it is manifold.

use std::collections::{HashMap, VecDeque};
use std::fmt;

use qm_io::PolyMesh;
use qm_lift::glam::DVec3;

use crate::union_find::UnionFind;
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
    /// Triangles dropped for sharing their vertex set with a triangle that
    /// is kept (step 3); those in [`Self::cancelled_faces`] are not counted.
    pub dropped_duplicate: usize,
    /// Faces of opposite pairs (the same vertex set, run the other way)
    /// dropped both, in sheets that meet other faces.
    pub cancelled_faces: usize,
    /// Edges shared by faces that were not joined across them: more than
    /// two faces left unpaired, an orientation conflict, or a cut to
    /// separate a fan.
    pub split_edges: usize,
    /// Edges with more than two faces whose faces were paired into
    /// manifold sheets (step 4).
    pub paired_edges: usize,
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
             {} faces -> {} triangles ({} degenerate and {} duplicate dropped, {} cancelled in opposite pairs), \
             {} non-manifold edges paired, {} edges and {} vertices split, {} faces flipped, {} component{}",
            Thousands(self.input_vertices),
            Thousands(self.output_vertices),
            Thousands(self.merged_vertices),
            Thousands(self.dropped_unused_vertices),
            Thousands(self.added_vertices),
            Thousands(self.input_faces),
            Thousands(self.output_faces),
            Thousands(self.dropped_degenerate),
            Thousands(self.dropped_duplicate),
            Thousands(self.cancelled_faces),
            Thousands(self.paired_edges),
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
    clean_with(mesh, true)
}

/// [`clean`], except that attached zero-thickness sheets are kept: both
/// faces of each opposite pair go on to the pairing of step 4, which joins
/// them to the surface where it can and cuts them loose as parts of their
/// own where it cannot. For a base that is the input's own triangles
/// (`remesh::exact`), where a part costs no more than its triangles: the
/// thin parts of a coarse reconstruction (dragon_vrip_res4's fins) stay.
/// A remesh cannot afford them (a level for every such splinter).
pub fn clean_keeping_sheets(mesh: &PolyMesh) -> Result<Cleaned> {
    clean_with(mesh, false)
}

fn clean_with(mesh: &PolyMesh, cancel: bool) -> Result<Cleaned> {
    let mut report = CleanReport {
        input_vertices: mesh.positions.len(),
        input_faces: mesh.face_count(),
        ..CleanReport::default()
    };
    let tris = triangulate(mesh, &mut report)?;
    report.triangles = tris.len();

    let (remap, positions) = merge_identical(&mesh.positions);
    report.merged_vertices = mesh.positions.len() - positions.len();
    let tris = drop_bad_triangles(tris, &remap, &positions, cancel, &mut report);

    // Step 4 both ways (parts kept apart, parts joined) where any edge has
    // more than two faces: the simpler surface wins.
    let outward = signed_volume(&tris, &positions) >= 0.0;
    let (first, crowded) = resolve(&tris, &positions, report, outward)?;
    if !crowded {
        return Ok(first);
    }
    let (second, _) = resolve(&tris, &positions, report, !outward)?;
    Ok(if complexity(&second) < complexity(&first) {
        second
    } else {
        first
    })
}

/// How hard a cleaned surface is to remesh: twice the genus plus the holes,
/// summed, plus the components (each handle takes two loops of cut, each
/// hole a path to it, each component a chart).
fn complexity(cleaned: &Cleaned) -> i64 {
    let topo = components_topology(&cleaned.components);
    topo.iter()
        .map(|t| 2 * t.genus + t.boundary_loops as i64 + 1)
        .sum()
}

/// Steps 4 to 8 on the clean-up's triangles, pairing as if the normals
/// pointed `outward` (see `pair_sheets`). Also says whether any edge has
/// more than two faces (so that pairing the other way may differ).
fn resolve(
    tris: &[[u32; 3]],
    positions: &[DVec3],
    mut report: CleanReport,
    outward: bool,
) -> Result<(Cleaned, bool)> {
    let edges = EdgeTable::new(tris, positions, outward);
    let (flip, mut state) = orient(tris, &edges);

    // Step 6: one vertex copy per fan. Where faces of an edge still share
    // both copies without being joined there, undo the edge's pairing, or
    // else detach a face; regroup after each round (splitting only ever
    // separates more, so this ends).
    let mut roots = corner_groups(tris, &edges, &state);
    loop {
        let shared = shared_ends(&edges, &state, &roots);
        if shared.is_empty() {
            break;
        }
        let mut changed = false;
        let mut undone = None;
        for (k, c) in shared {
            // The next round looks at an edge again once its pairing is undone.
            if undone == Some(k) {
                continue;
            }
            let sheets = edges.sheets(k);
            if sheets.len() > 1 && sheets.clone().any(|e| state[e] == EdgeState::Joined) {
                for e in sheets {
                    if state[e] == EdgeState::Joined {
                        state[e] = EdgeState::Cut;
                        changed = true;
                    }
                }
                undone = Some(k);
                continue;
            }
            let e = edges.edge_of[prev_corner(c)] as usize;
            if state[e] == EdgeState::Joined {
                state[e] = EdgeState::Cut;
                changed = true;
            }
        }
        if !changed {
            return Err(Error::Internal("clean-up left an edge shared"));
        }
        roots = corner_groups(tris, &edges, &state);
    }
    count_edges(&edges, &state, &mut report);

    let components = assemble(tris, positions, &edges, &state, &flip, &roots, &mut report);
    Ok((Cleaned { components, report }, edges.crowded))
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
        if face.len() > 4 && convex(&mesh.positions, face) {
            zigzag(face, &mut tris);
        } else {
            for i in 1..face.len() - 1 {
                tris.push([face[0], face[i], face[i + 1]]);
            }
        }
    }
    Ok(tris)
}

/// A convex polygon of more than four corners as a strip of triangles
/// taken from both ends in turn, not a fan: a fan's triangles all meet at
/// its first corner, which then has the polygon's whole valence, and the
/// closest-point queries near it try every one of them (a 3,000-gon took
/// twice as long as a cylinder capped by fans of 3,000).
fn zigzag(face: &[u32], tris: &mut Vec<[u32; 3]>) {
    let (mut l, mut r) = (0, face.len() - 1);
    let mut from_left = true;
    while r - l >= 2 {
        if from_left {
            tris.push([face[l], face[l + 1], face[r]]);
            l += 1;
        } else {
            tris.push([face[l], face[r - 1], face[r]]);
            r -= 1;
        }
        from_left = !from_left;
    }
}

/// Whether `face` is a convex polygon: every corner turns the same way
/// about the polygon's normal (Newell's), none straight or back.
fn convex(positions: &[DVec3], face: &[u32]) -> bool {
    let at = |i: usize| positions[face[i % face.len()] as usize];
    let normal = (0..face.len()).fold(DVec3::ZERO, |n, i| n + at(i).cross(at(i + 1)));
    (0..face.len()).all(|i| {
        let turn = (at(i + 1) - at(i)).cross(at(i + 2) - at(i + 1));
        turn.dot(normal) > 0.0
    })
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

/// Step 3: renumbers and drops degenerate and duplicate triangles, and
/// (with `cancel`) cancels attached zero-thickness sheets (see the module
/// documentation).
fn drop_bad_triangles(
    tris: Vec<[u32; 3]>,
    remap: &[u32],
    positions: &[DVec3],
    cancel: bool,
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
    // Whether a triangle's corners are a rotation of their sorted order.
    let even = |t: &[u32; 3]| (t[0] < t[1]) as u8 + (t[1] < t[2]) as u8 + (t[2] < t[0]) as u8 == 2;
    let mut keep = vec![false; kept.len()];
    // Per vertex set, triangles cancel in opposite pairs: the first pair
    // stands for them (both kept for now), and of the orientation left over
    // one triangle is kept; the rest are duplicates.
    let mut twins: Vec<Twins> = Vec::new();
    for run in keyed.chunk_by(|x, y| x.0 == y.0) {
        if let [(_, f)] = run {
            keep[*f as usize] = true;
            continue;
        }
        // The run's triangles of one orientation, in order.
        let kept = &kept;
        let of = |ab: bool| {
            run.iter()
                .map(|x| x.1)
                .filter(move |&f| even(&kept[f as usize]) == ab)
        };
        let (n_ab, n_ba) = (of(true).count(), of(false).count());
        let pairs = n_ab.min(n_ba);
        let left =
            (n_ab != n_ba).then(|| of(n_ab > n_ba).nth(pairs).expect("a triangle left over"));
        if let (Some(f), Some(g)) = (of(true).next(), of(false).next()) {
            twins.push(Twins { pair: [f, g], left });
            keep[f as usize] = true;
            keep[g as usize] = true;
        }
        if let Some(l) = left {
            keep[l as usize] = true;
        }
        report.dropped_duplicate += run.len() - 2 * pairs.min(1) - usize::from(left.is_some());
    }
    cancel_sheets(&kept, &twins, &mut keep, cancel, report);
    let mut i = 0;
    kept.retain(|_| {
        i += 1;
        keep[i - 1]
    });
    kept
}

/// The triangles of one vertex set that run both ways: the first of each
/// orientation, and the one left over when the orientations do not balance.
struct Twins {
    pair: [u32; 2],
    left: Option<u32>,
}

/// Cancels the opposite pairs (`twins`) of every patch of such pairs (pairs
/// sharing edges) that meets two or more other faces at some edge: a thin
/// part collapsed to zero thickness, or the wall where two parts touch face
/// to face, whose rim would otherwise have four faces to an edge. A patch
/// that meets at most one other face at each edge (a free two-sided sheet,
/// or a face stored again, reversed, on a surface) keeps one face per
/// vertex set instead: the one left over if any, else one of the pair.
/// Without `cancel`, the pairs of the patches that would cancel stay.
fn cancel_sheets(
    tris: &[[u32; 3]],
    twins: &[Twins],
    keep: &mut [bool],
    cancel: bool,
    report: &mut CleanReport,
) {
    if twins.is_empty() {
        return;
    }
    const NONE: u32 = u32::MAX;
    let mut pair_of = vec![NONE; tris.len()];
    for (p, t) in twins.iter().enumerate() {
        for f in t.pair.into_iter().chain(t.left) {
            pair_of[f as usize] = p as u32;
        }
    }
    let mut edges: Vec<(u64, u32)> = Vec::with_capacity(3 * tris.len());
    for (f, t) in tris.iter().enumerate() {
        if keep[f] {
            for i in 0..3 {
                edges.push((edge_key(t[i], t[(i + 1) % 3]), pair_of[f]));
            }
        }
    }
    edges.sort_unstable();
    let mut sets = UnionFind::new(twins.len());
    // Per pair: meets more than one other face at some edge.
    let mut many = vec![false; twins.len()];
    for run in edges.chunk_by(|x, y| x.0 == y.0) {
        // Sorted by pair, the faces of no pair last.
        let p = run[0].1;
        if p == NONE {
            continue;
        }
        for &(_, q) in run.iter().take_while(|x| x.1 != NONE) {
            sets.union(p, q);
        }
        many[p as usize] |= run.iter().filter(|x| x.1 == NONE).count() > 1;
    }
    for p in 0..twins.len() {
        let root = sets.find(p as u32) as usize;
        many[root] |= many[p];
    }
    for (p, t) in twins.iter().enumerate() {
        let root = sets.find(p as u32) as usize;
        let [f, g] = t.pair;
        if many[root] && !cancel {
            // Both faces stay, for the pairing to place; a third copy goes.
            if let Some(l) = t.left {
                keep[l as usize] = false;
                report.dropped_duplicate += 1;
            }
            continue;
        }
        keep[g as usize] = false;
        if many[root] {
            keep[f as usize] = false;
            report.cancelled_faces += 2;
        } else if t.left.is_some() {
            keep[f as usize] = false;
            report.dropped_duplicate += 2;
        } else {
            report.dropped_duplicate += 1;
        }
    }
}

/// The key of the undirected edge `a`-`b`.
fn edge_key(a: u32, b: u32) -> u64 {
    (u64::from(a.min(b)) << 32) | u64::from(a.max(b))
}

/// Undirected edges and the corners using them. Corner `c = 3 t + i` of
/// triangle `t` starts the directed edge `t[i] -> t[(i + 1) % 3]`.
///
/// An edge with more than two faces is split into *sheets* (step 4): a pair
/// of faces that may join across it, or one face left alone. The rest of
/// the clean-up joins and cuts sheets as it does edges; an edge of at most
/// two faces is one sheet.
struct EdgeTable {
    /// Sheet of each corner.
    edge_of: Vec<u32>,
    /// Corners sorted by edge, then sheet; sheet `e` has
    /// `corners[start[e]..start[e + 1]]`.
    corners: Vec<u32>,
    start: Vec<usize>,
    /// Undirected edge `k` has sheets `first[k]..first[k + 1]`.
    first: Vec<usize>,
    /// Some edge has more than two faces.
    crowded: bool,
}

impl EdgeTable {
    fn new(tris: &[[u32; 3]], positions: &[DVec3], outward: bool) -> Self {
        let mut keyed: Vec<(u64, u32)> = Vec::with_capacity(3 * tris.len());
        for (t, tri) in tris.iter().enumerate() {
            for i in 0..3 {
                keyed.push((edge_key(tri[i], tri[(i + 1) % 3]), (3 * t + i) as u32));
            }
        }
        keyed.sort_unstable();
        let mut corners: Vec<u32> = keyed.iter().map(|&(_, c)| c).collect();
        let mut edge_of = vec![0u32; corners.len()];
        let mut start = Vec::with_capacity(keyed.len() / 2 + 1);
        let mut first = Vec::with_capacity(keyed.len() / 2 + 1);
        let mut crowded = false;
        let mut k = 0;
        while k < keyed.len() {
            let mut end = k + 1;
            while end < keyed.len() && keyed[end].0 == keyed[k].0 {
                end += 1;
            }
            first.push(start.len());
            crowded |= end - k > 2;
            let sizes = pair_sheets(&mut corners[k..end], tris, positions, outward);
            let mut sheet = |at: usize, size: usize| {
                for &c in &corners[at..at + size] {
                    edge_of[c as usize] = start.len() as u32;
                }
                start.push(at);
            };
            match sizes {
                None => sheet(k, end - k),
                Some(sizes) => {
                    let mut at = k;
                    for size in sizes {
                        sheet(at, size);
                        at += size;
                    }
                }
            }
            k = end;
        }
        first.push(start.len());
        start.push(keyed.len());
        EdgeTable {
            edge_of,
            corners,
            start,
            first,
            crowded,
        }
    }

    /// Sheets.
    fn count(&self) -> usize {
        self.start.len() - 1
    }

    fn corners(&self, e: usize) -> &[u32] {
        &self.corners[self.start[e]..self.start[e + 1]]
    }

    /// Undirected edges.
    fn undirected(&self) -> usize {
        self.first.len() - 1
    }

    fn sheets(&self, k: usize) -> std::ops::Range<usize> {
        self.first[k]..self.first[k + 1]
    }

    /// Corners of undirected edge `k`, all its sheets.
    fn edge_corners(&self, k: usize) -> &[u32] {
        &self.corners[self.start[self.first[k]]..self.start[self.first[k + 1]]]
    }
}

/// `sum of a . (b x c) / 6` over the triangles, about their vertices' mean
/// (six times the enclosed volume for a closed surface, for precision).
fn signed_volume(tris: &[[u32; 3]], positions: &[DVec3]) -> f64 {
    let o = positions.iter().sum::<DVec3>() / positions.len().max(1) as f64;
    tris.iter()
        .map(|t| {
            let [a, b, c] = t.map(|v| positions[v as usize] - o);
            a.dot(b.cross(c))
        })
        .sum()
}

/// Step 4: reorders the corners of one edge (`run`, all on the same two
/// vertices `a < b`) into sheets and returns the sheets' sizes, or `None`
/// to keep the edge as it is (one sheet: two faces or fewer, or none to
/// pair).
///
/// The faces are sorted by the angle of their third vertex about the axis
/// `a -> b`. A face that runs the edge `b -> a` pairs with the next face
/// counterclockwise if that one runs `a -> b`: with outward normals both
/// then face away from the wedge between them, which is inside the solid.
/// Two solids that touch along the edge (or a solid that touches itself)
/// thus come apart rather than fuse, which would add a handle. `outward`
/// (the input's signed volume is not negative) false swaps the directions.
/// Each face pairs at most once; faces left over are sheets of their own.
fn pair_sheets(
    run: &mut [u32],
    tris: &[[u32; 3]],
    positions: &[DVec3],
    outward: bool,
) -> Option<Vec<usize>> {
    if run.len() <= 2 {
        return None;
    }
    let start = |c: u32| tris[c as usize / 3][c as usize % 3];
    let third = |c: u32| tris[c as usize / 3][(c as usize % 3 + 2) % 3];
    let ends = |c: u32| {
        let (u, w) = (start(c), tris[c as usize / 3][(c as usize % 3 + 1) % 3]);
        (u.min(w), u.max(w))
    };
    let (a, b) = ends(run[0]);
    let pa = positions[a as usize];
    let axis = (positions[b as usize] - pa).normalize_or_zero();
    let across = |c: u32| {
        let d = positions[third(c) as usize] - pa;
        d - axis * axis.dot(d)
    };
    let x = across(run[0]).normalize_or_zero();
    let y = axis.cross(x);
    if axis == DVec3::ZERO || x == DVec3::ZERO {
        return None;
    }
    // (angle, corner, runs a -> b)
    let mut around: Vec<(f64, u32, bool)> = run
        .iter()
        .map(|&c| {
            let d = across(c);
            (d.dot(y).atan2(d.dot(x)), c, start(c) == a)
        })
        .collect();
    around.sort_by(|p, q| p.0.total_cmp(&q.0).then(p.1.cmp(&q.1)));
    let n = around.len();
    // No face can be in two pairs: it would have to run the edge both ways.
    let mut taken = vec![false; n];
    let mut sheets = Vec::new();
    let mut at = 0;
    for i in 0..n {
        let j = (i + 1) % n;
        if around[i].2 != outward && around[j].2 == outward {
            taken[i] = true;
            taken[j] = true;
            run[at] = around[i].1;
            run[at + 1] = around[j].1;
            at += 2;
            sheets.push(2);
        }
    }
    if sheets.is_empty() {
        return None;
    }
    for (i, &(_, c, _)) in around.iter().enumerate() {
        if !taken[i] {
            run[at] = c;
            at += 1;
            sheets.push(1);
        }
    }
    Some(sheets)
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum EdgeState {
    /// One face: a boundary edge, or a face left alone on an edge of more.
    Boundary,
    /// Two faces, not yet decided.
    Open,
    /// Two faces joined with agreeing orientations.
    Joined,
    /// Shared by faces that are not joined across it.
    Cut,
}

/// Step 5: greedy breadth-first orientation. Returns whether each face is
/// flipped relative to the input, and each sheet's state.
fn orient(tris: &[[u32; 3]], edges: &EdgeTable) -> (Vec<bool>, Vec<EdgeState>) {
    let mut state: Vec<EdgeState> = (0..edges.count())
        .map(|e| match edges.corners(e).len() {
            1 => EdgeState::Boundary,
            2 => EdgeState::Open,
            _ => EdgeState::Cut,
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
                }
            }
        }
    }
    (flip, state)
}

fn next_corner(c: usize) -> usize {
    c - c % 3 + (c % 3 + 1) % 3
}

fn prev_corner(c: usize) -> usize {
    c - c % 3 + (c % 3 + 2) % 3
}

/// The fan of every corner around its vertex: corners joined across
/// [`EdgeState::Joined`] edges share a root (the smallest corner of the fan).
fn corner_groups(tris: &[[u32; 3]], edges: &EdgeTable, state: &[EdgeState]) -> Vec<u32> {
    let mut sets = UnionFind::new(3 * tris.len());
    for (e, s) in state.iter().enumerate() {
        if *s != EdgeState::Joined {
            continue;
        }
        let pair = edges.corners(e);
        let (c1, c2) = (pair[0] as usize, pair[1] as usize);
        let (n1, n2) = (next_corner(c1), next_corner(c2));
        if tris[c1 / 3][c1 % 3] == tris[c2 / 3][c2 % 3] {
            sets.union(c1 as u32, c2 as u32);
            sets.union(n1 as u32, n2 as u32);
        } else {
            sets.union(c1 as u32, n2 as u32);
            sets.union(n1 as u32, c2 as u32);
        }
    }
    (0..sets.len() as u32).map(|c| sets.find(c)).collect()
}

/// Corners whose face still shares both end copies with an earlier corner
/// of the same undirected edge without being joined to it there (the output
/// would have an edge of more than two faces), with their edge.
fn shared_ends(edges: &EdgeTable, state: &[EdgeState], roots: &[u32]) -> Vec<(usize, usize)> {
    let mut shared = Vec::new();
    let mut ends: Vec<(u32, u32, u32)> = Vec::new();
    for k in 0..edges.undirected() {
        let corners = edges.edge_corners(k);
        // One face, or two joined: nothing to share.
        let joined = |c: u32| state[edges.edge_of[c as usize] as usize] == EdgeState::Joined;
        if corners.len() < 2 || (corners.len() == 2 && joined(corners[0])) {
            continue;
        }
        ends.clear();
        for &c in corners {
            let (x, y) = (roots[c as usize], roots[next_corner(c as usize)]);
            ends.push((x.min(y), x.max(y), c));
        }
        ends.sort_unstable();
        for w in ends.windows(2) {
            let (e, f) = (
                edges.edge_of[w[0].2 as usize],
                edges.edge_of[w[1].2 as usize],
            );
            let joined = e == f && state[e as usize] == EdgeState::Joined;
            if (w[0].0, w[0].1) == (w[1].0, w[1].1) && !joined {
                shared.push((k, w[1].2 as usize));
            }
        }
    }
    shared
}

/// Counts the edges split (some face not joined across them) and paired
/// (split into sheets, and at least one of them joined).
fn count_edges(edges: &EdgeTable, state: &[EdgeState], report: &mut CleanReport) {
    for k in 0..edges.undirected() {
        if edges.edge_corners(k).len() < 2 {
            continue;
        }
        let joined = edges
            .sheets(k)
            .filter(|&e| state[e] == EdgeState::Joined)
            .count();
        report.paired_edges += usize::from(joined > 0 && edges.sheets(k).len() > 1);
        report.split_edges += usize::from(edges.sheets(k).any(|e| state[e] != EdgeState::Joined));
    }
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
    let mut sets = UnionFind::new(nf);
    for (e, s) in state.iter().enumerate() {
        if *s == EdgeState::Joined {
            let pair = edges.corners(e);
            sets.union(pair[0] / 3, pair[1] / 3);
        }
    }
    // Components numbered by their first face.
    let mut comp_of = vec![u32::MAX; nf];
    let mut count = 0usize;
    for f in 0..nf {
        let r = sets.find(f as u32) as usize;
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

#[cfg(test)]
mod tests {
    use super::*;

    fn dv(p: [f64; 3]) -> DVec3 {
        DVec3::from_array(p)
    }

    fn poly<const K: usize>(p: &[[f64; 3]], f: &[[u32; K]]) -> PolyMesh {
        PolyMesh::from_faces(p.iter().copied().map(dv).collect(), f)
    }

    /// A convex 12-gon becomes a strip: no corner in more than three of
    /// its triangles, all facing the polygon's way, covering its area; a
    /// non-convex polygon keeps its fan.
    #[test]
    fn a_convex_polygon_is_a_strip_not_a_fan() {
        let n = 12u32;
        let points: Vec<DVec3> = (0..n)
            .map(|i| {
                let a = std::f64::consts::TAU * f64::from(i) / f64::from(n);
                DVec3::new(a.cos(), a.sin(), 0.0)
            })
            .collect();
        let mut mesh = PolyMesh::from_faces::<3>(points.clone(), &[]);
        mesh.push_face(&(0..n).collect::<Vec<u32>>());
        let tris = triangulate(&mesh, &mut CleanReport::default()).unwrap();
        assert_eq!(tris.len(), n as usize - 2);
        let mut uses = vec![0; n as usize];
        let mut area = 0.0;
        for t in &tris {
            let [a, b, c] = t.map(|v| points[v as usize]);
            let z = (b - a).cross(c - a).z;
            assert!(z > 0.0, "{t:?} faces the other way");
            area += z / 2.0;
            t.iter().for_each(|&v| uses[v as usize] += 1);
        }
        assert!(uses.iter().all(|&u| u <= 3), "{uses:?}");
        let polygon = f64::from(n) / 2.0 * (std::f64::consts::TAU / f64::from(n)).sin();
        assert!((area - polygon).abs() < 1e-12);
        // A dent: the fan from the first corner, as before.
        let mut dented = points;
        dented[6] *= 0.1;
        let mut mesh = PolyMesh::from_faces::<3>(dented, &[]);
        mesh.push_face(&(0..n).collect::<Vec<u32>>());
        let tris = triangulate(&mesh, &mut CleanReport::default()).unwrap();
        assert!(tris.iter().all(|t| t[0] == 0));
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
        // Two faces pair into a sheet, the third is cut loose.
        assert_eq!((c.report.paired_edges, c.report.split_edges), (1, 1));
        assert_eq!(c.report.split_vertices, 2);
        assert_eq!(c.components.len(), 2);
        assert_eq!(c.report.output_vertices, 7);
        assert_clean(&c);
    }

    /// Two cubes that touch along an edge: four faces on it, which pair
    /// within each cube, so both stay closed (before, all four were cut
    /// loose, leaving a slit in each).
    fn touching_cubes(inward: bool) -> (Vec<[f64; 3]>, Vec<[u32; 4]>) {
        let (mut p, mut f) = cube([0.; 3]);
        let (p2, f2) = cube([1., 1., 0.]);
        // Cube 2's edge 0-4 is cube 1's edge 3-7.
        p.extend(p2);
        f.extend(f2.iter().map(|q| q.map(|v| v + 8)));
        if inward {
            for q in &mut f {
                q.reverse();
            }
        }
        (p, f)
    }

    fn assert_closed_cubes(c: &Cleaned, n: usize) {
        assert_eq!(c.components.len(), n);
        for m in &c.components {
            let t = topology(m);
            assert!(t.manifold && t.is_closed() && t.genus == 0, "{t:?}");
            assert!((volume(m).abs() - volume(m).abs().round()).abs() < 1e-12);
            assert!(volume(m) > 0.0);
        }
    }

    #[test]
    fn cubes_touching_along_an_edge_stay_closed() {
        let (p, f) = touching_cubes(false);
        let c = clean(&poly(&p, &f)).unwrap();
        assert_eq!((c.report.paired_edges, c.report.split_edges), (1, 0));
        assert_eq!(c.report.split_vertices, 2);
        assert_closed_cubes(&c, 2);
    }

    /// The pairing follows the input's orientation, guessed from the sign of
    /// its volume; where that guess is wrong for a part, the other way of
    /// pairing gives the simpler surface and is kept. Here the touching cubes
    /// face inward inside a large outward box, so the guess says outward.
    #[test]
    fn the_simpler_pairing_wins() {
        let (mut p, mut f) = touching_cubes(true);
        let (big, fb) = cube([0.; 3]);
        let at = p.len() as u32;
        p.extend(big.iter().map(|q| q.map(|x| 10.0 * x + 20.0)));
        f.extend(fb.iter().map(|q| q.map(|v| v + at)));
        let c = clean(&poly(&p, &f)).unwrap();
        assert_eq!((c.report.paired_edges, c.report.split_edges), (1, 0));
        assert_closed_cubes(&c, 3);
    }

    /// Two tetrahedra glued on a face, the face stored once by each (so twice,
    /// running opposite ways): the two copies cancel and a closed bipyramid
    /// is left. Before, one copy was kept as a membrane inside, and its
    /// three edges had three faces each.
    #[test]
    fn opposite_faces_between_parts_cancel() {
        let p = [
            [0., 0., 0.],
            [1., 0., 0.],
            [0., 1., 0.],
            [0., 0., 1.],
            [1., 1., 1.],
        ];
        // Outward: tetrahedron 0123, then 1234 (its face 1-2-3 runs the
        // other way).
        let f = [
            [0, 2, 1],
            [0, 1, 3],
            [0, 3, 2],
            [1, 2, 3],
            [1, 3, 2],
            [1, 4, 3],
            [2, 3, 4],
            [1, 2, 4],
        ];
        let c = clean(&poly(&p, &f)).unwrap();
        assert_eq!(c.report.cancelled_faces, 2);
        assert_eq!((c.report.split_edges, c.report.paired_edges), (0, 0));
        assert_eq!(c.components.len(), 1);
        let t = topology(&c.components[0]);
        assert!(t.manifold && t.is_closed() && t.genus == 0, "{t:?}");
        assert_eq!((t.vertices, t.faces), (5, 6));
        assert!((volume(&c.components[0]) - 0.5).abs() < 1e-12);
    }

    /// A face stored again, reversed, on a closed surface: its edges meet one
    /// other face each, so the pair does not cancel (that would leave a
    /// hole); one face stays and the surface is closed.
    #[test]
    fn a_reversed_copy_on_a_closed_surface_leaves_it_closed() {
        let (p, mut f) = tetra([0.; 3]);
        f.push([0, 1, 2]); // face 0 reversed
        let c = clean(&poly(&p, &f)).unwrap();
        assert_eq!(
            (c.report.dropped_duplicate, c.report.cancelled_faces),
            (1, 0)
        );
        assert_eq!(c.components.len(), 1);
        let t = topology(&c.components[0]);
        assert!(t.manifold && t.is_closed() && t.genus == 0, "{t:?}");
        assert!((volume(&c.components[0]) - 1.0 / 6.0).abs() < 1e-12);
    }

    /// The rule itself, each way: pairing across wedges inside the solid
    /// keeps the outward touching cubes apart and closed; across wedges
    /// outside, it joins them, which the fans at the edge's ends undo, and
    /// the cut leaves a slit in each.
    #[test]
    fn pairing_inside_keeps_touching_parts_apart() {
        let (p, f) = touching_cubes(false);
        let mesh = poly(&p, &f);
        let mut report = CleanReport::default();
        let tris = triangulate(&mesh, &mut report).unwrap();
        let (remap, positions) = merge_identical(&mesh.positions);
        let tris = drop_bad_triangles(tris, &remap, &positions, true, &mut report);
        let (inside, crowded) = resolve(&tris, &positions, CleanReport::default(), true).unwrap();
        assert!(crowded);
        assert_closed_cubes(&inside, 2);
        let (outside, _) = resolve(&tris, &positions, CleanReport::default(), false).unwrap();
        assert_eq!(outside.report.paired_edges, 0);
        assert!(outside.components.iter().all(|m| !topology(m).is_closed()));
    }

    /// A two-sided sheet on its own (each face stored both ways, nothing else
    /// attached) keeps one side instead of vanishing, also where a face is
    /// stored a third time.
    #[test]
    fn a_free_two_sided_sheet_keeps_one_side() {
        let p = [[0., 0., 0.], [1., 0., 0.], [1., 1., 0.], [0., 1., 0.]];
        let f = [[0, 1, 2], [0, 2, 3], [2, 1, 0], [3, 2, 0], [2, 3, 0]];
        let c = clean(&poly(&p, &f)).unwrap();
        assert_eq!(
            (c.report.cancelled_faces, c.report.dropped_duplicate),
            (0, 3)
        );
        assert_eq!(c.components.len(), 1);
        let t = topology(&c.components[0]);
        assert_eq!((t.faces, t.boundary_loops), (2, 1));
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
        f.push([2, 1, 0]); // same as face 0, rotated
        f.push([1, 3, 0]); // same as face 1, rotated
        let c = clean(&poly(&p, &f)).unwrap();
        assert_eq!(c.report.dropped_duplicate, 2);
        assert_eq!(c.report.output_faces, 4);
        assert_eq!(c.report.split_edges, 0);
        assert_clean(&c);
    }

    #[test]
    fn ngons_are_split_and_their_duplicates_found() {
        let p = [
            [0., 0., 0.],
            [1., 0., 0.],
            [2., 1., 0.],
            [1., 2., 0.],
            [0., 1., 0.],
        ];
        let mut m = poly(&p, &[[0, 1, 2, 3, 4]]);
        m.push_face(&[0, 1, 4]); // a duplicate of the strip's first triangle
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

    /// Cleans every bundled model: manifold components, closed ones
    /// outward.
    #[test]
    fn bundled_models() {
        let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../assets");
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
        assert!(files.len() >= 5, "{files:?}");
        for path in files {
            let mesh = qm_io::read_mesh(&path).unwrap();
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
                "torus_4x6_l4" => assert_eq!(topo[0].genus, 1),
                "holed_grid_l4" => assert!(topo[0].boundary_loops > 1),
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
