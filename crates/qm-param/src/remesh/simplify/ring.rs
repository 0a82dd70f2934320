//! A vertex's 1-ring in a triangle mesh, in order around it, and the key
//! of an undirected edge.

pub(super) fn edge_key(a: u32, b: u32) -> u64 {
    (u64::from(a.min(b)) << 32) | u64::from(a.max(b))
}

/// A vertex's 1-ring: `faces[i]` is `(v, verts[i], verts[i + 1])` (indices
/// taken cyclically when `closed`).
pub(in crate::remesh) struct Ring {
    pub verts: Vec<u32>,
    pub faces: Vec<u32>,
    pub closed: bool,
}

/// The 1-ring of `v` in a manifold triangle mesh, from `faces`, the indices
/// into `triangles` of its triangles (counter-clockwise): in order around
/// it, a boundary fan from its first boundary neighbour. `None` if they do
/// not make one fan.
pub(in crate::remesh) fn ring(v: u32, faces: &[u32], triangles: &[[u32; 3]]) -> Option<Ring> {
    if faces.is_empty() {
        return None;
    }
    // (x, y, face) per face: v, x, y counter-clockwise.
    let spokes: Vec<(u32, u32, u32)> = faces
        .iter()
        .map(|&f| {
            let t = triangles[f as usize];
            let c = t.iter().position(|&w| w == v).expect("face of its vertex");
            (t[(c + 1) % 3], t[(c + 2) % 3], f)
        })
        .collect();
    // Sorted lookups, so that a vertex of high valence costs k log k, not
    // k^2: (x, spoke) and the ys.
    let mut by_x: Vec<(u32, usize)> = spokes.iter().enumerate().map(|(i, s)| (s.0, i)).collect();
    by_x.sort_unstable();
    let mut ys: Vec<u32> = spokes.iter().map(|s| s.1).collect();
    ys.sort_unstable();
    let is_y = |x: u32| ys.binary_search(&x).is_ok();
    // The first spoke whose x is `y`.
    let from = |y: u32| {
        let i = by_x.partition_point(|e| e.0 < y);
        by_x.get(i).filter(|e| e.0 == y).map(|e| e.1)
    };
    // A boundary fan starts at the x that is no face's y.
    let start = spokes.iter().position(|s| !is_y(s.0)).unwrap_or(0);
    let closed = spokes.iter().all(|s| is_y(s.0));
    let mut verts = vec![spokes[start].0];
    let mut order = Vec::with_capacity(spokes.len());
    let mut at = start;
    for _ in 0..spokes.len() {
        let (_, y, f) = spokes[at];
        order.push(f);
        match from(y) {
            Some(next) if order.len() < spokes.len() => {
                verts.push(y);
                at = next;
            }
            _ => {
                if !closed {
                    verts.push(y);
                }
                break;
            }
        }
    }
    if order.len() != spokes.len() {
        return None;
    }
    let mut unique = verts.clone();
    unique.sort_unstable();
    unique.dedup();
    if unique.len() != verts.len() {
        return None;
    }
    Some(Ring {
        verts,
        faces: order,
        closed,
    })
}
