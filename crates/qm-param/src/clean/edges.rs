//! Step 4 of the clean-up: the undirected edges, the corners that use
//! them, and the faces around an edge of more than two paired into sheets.
//!
//! Corner `c = 3 t + i` of triangle `t` starts the directed edge
//! `t[i] -> t[(i + 1) % 3]`. Around an edge of more than two faces, sorted
//! by angle about it, a face pairs with its neighbour when the two run the
//! edge in opposite directions and the wedge between them is inside the
//! solid (or, the other way, outside it) ([`pair_sheets`]).

use qm_lift::glam::DVec3;

/// The key of the undirected edge `a`-`b`.
pub(super) fn edge_key(a: u32, b: u32) -> u64 {
    (u64::from(a.min(b)) << 32) | u64::from(a.max(b))
}

/// Undirected edges and the corners using them. Corner `c = 3 t + i` of
/// triangle `t` starts the directed edge `t[i] -> t[(i + 1) % 3]`.
///
/// An edge with more than two faces is split into *sheets* (step 4): a pair
/// of faces that may join across it, or one face left alone. The rest of
/// the clean-up joins and cuts sheets as it does edges; an edge of at most
/// two faces is one sheet.
pub(super) struct EdgeTable {
    /// Sheet of each corner.
    pub(super) edge_of: Vec<u32>,
    /// Corners sorted by edge, then sheet; sheet `e` has
    /// `corners[start[e]..start[e + 1]]`.
    pub(super) corners: Vec<u32>,
    pub(super) start: Vec<usize>,
    /// Undirected edge `k` has sheets `first[k]..first[k + 1]`.
    pub(super) first: Vec<usize>,
    /// Some edge has more than two faces.
    pub(super) crowded: bool,
}

impl EdgeTable {
    pub(super) fn new(tris: &[[u32; 3]], positions: &[DVec3], outward: bool) -> Self {
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
    pub(super) fn count(&self) -> usize {
        self.start.len() - 1
    }

    pub(super) fn corners(&self, e: usize) -> &[u32] {
        &self.corners[self.start[e]..self.start[e + 1]]
    }

    /// Undirected edges.
    pub(super) fn undirected(&self) -> usize {
        self.first.len() - 1
    }

    pub(super) fn sheets(&self, k: usize) -> std::ops::Range<usize> {
        self.first[k]..self.first[k + 1]
    }

    /// Corners of undirected edge `k`, all its sheets.
    pub(super) fn edge_corners(&self, k: usize) -> &[u32] {
        &self.corners[self.start[self.first[k]]..self.start[self.first[k + 1]]]
    }
}

/// `sum of a . (b x c) / 6` over the triangles, about their vertices' mean
/// (six times the enclosed volume for a closed surface, for precision).
pub(super) fn signed_volume(tris: &[[u32; 3]], positions: &[DVec3]) -> f64 {
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

pub(super) fn next_corner(c: usize) -> usize {
    c - c % 3 + (c % 3 + 1) % 3
}

pub(super) fn prev_corner(c: usize) -> usize {
    c - c % 3 + (c % 3 + 2) % 3
}
